"""The result of one fit: :class:`Estimate` (what :func:`sca.estimate` and
:func:`sca.estimate_least_squares` return)."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

__all__ = ["Estimate"]


@dataclass
class Estimate:
    """Result of :func:`sca.estimate` (and of :func:`sca.estimate_least_squares`).

    Units: chl mg m^-3, cdom and the attenuation coefficient m^-1, backscatter and objective in
    the units of the measurements. ``values`` and ``intervals`` are dicts keyed by the name of
    every free parameter (C and a_CDOM included, and any name of ``free=``): the estimate and
    its 95 % interval (profile likelihood; Wald for the gain and for z > 1 basis functions).
    Built by :func:`sca.verdict.finish` (:func:`sca.verdict.assess`).

    Attributes
    ----------
    chl : float
        Estimated (or fixed) chlorophyll concentration C, mg m^-3.
    cdom : float
        Estimated (or fixed) a_CDOM(440 nm), m^-1.
    chl_se, cdom_se : float
        Standard errors of chl (mg m^-3) and cdom (m^-1) from the Gauss-Newton covariance at
        the estimate (with the residual as noise estimate where the noise is unknown): large
        values say the data cannot decide; 0 for a fixed parameter or an exact fit whose noise
        is estimated from its (zero) residual; inf where the information is singular or
        dof <= 0.
    chl_ci, cdom_ci : tuple of float
        95 % profile-likelihood intervals (lo, hi), mg m^-3 and m^-1 (lower end 0 where the data
        allow 0, upper end inf where they cannot bound the parameter, beyond
        :data:`sca.model.CHL_MAX` / :data:`sca.model.CDOM_MAX`); Wald intervals clipped at 0 for
        z > 1 basis functions; (value, value) for a fixed parameter.
    reliable : bool
        True only when nothing in ``flags`` blocks it (:data:`sca.assess.BLOCKING`).
    flags : tuple of str
        Input-sanity flags then fit flags (:mod:`sca.assess`).
    fit_rms : float
        ||M - gain G - s 1^T|| / ||M|| (unweighted, dimensionless).
    chi2_dof : float
        Reduced chi^2 of the whitened residual, chi^2 / dof (NaN: noise unknown).
    chi2_p : float
        Its p-value, P(chi^2_dof > chi^2) (NaN: noise unknown).
    dof : int
        Degrees of freedom m n - (free nonlinear parameters) - (active s channels)
        - (z - 1 where w is free) - (1 for a free gain).
    noise_known : bool
        ``sigma`` was given (the objective is chi^2).
    w : ndarray, (z,)
        Phytoplankton basis weights of eq 9 (T w = a_phi, m^-1), on eq 17.
    backscatter : ndarray, (m,)
        The backscatter s of each channel (eq 15), units of the measurements.
    attenuation : ndarray, (q,)
        k = exp(-(depth + distance) c) at the estimate (dimensionless).
    attenuation_coefficient : ndarray, (q,)
        The path coefficient c at the estimate, m^-1.
    wavelengths : ndarray, (q,)
        The grid, nm.
    objective : float
        chi^2 when the noise is known, else ||M - gain G - s 1^T||^2 (data units squared).
    iterations : int
        Convex subproblems solved (:func:`sca.estimate`) or scipy's function evaluations
        (:func:`sca.estimate_least_squares`).
    converged : bool
        The returned point is stationary or fits the data to rounding error.
    status : str
        Why the fit stopped.
    history : list of float
        The objective (units of ``objective``) of every accepted point, the start first (the
        scipy path: its final objective only).
    mode : str
        'paper', 'safeguarded' or 'scipy_least_squares'.
    initial : dict
        The start: {'chl': mg m^-3, 'cdom': m^-1}.
    fixed : dict
        Held values: 'chl', 'cdom' (scalars), 'backscatter' ((m,), data units); held Water
        coefficients are in the water instead.
    eq17_residual : float
        t440 . w - 0.0378 C^0.627 at the estimate, m^-1 (0 for the scipy path, where w is on
        eq 17 by construction).
    trials : list of float
        The true objective of every trial point, accepted or not (``history`` keeps the
        accepted); empty for the scipy path.
    path_model : str
        The water's path model ('beam' or 'absorption').
    gain : float
        The exposure gain of M = gain G(x) + s 1^T, units of the measurements per model unit
        (1 where it is known; ``gain="free"`` estimates it).
    gain_ci : tuple of float
        Its 95 % Wald interval (Gauss-Newton standard error), clipped at 0; (gain, gain) where
        it is known.
    values : dict
        Every free parameter's estimate (float), by name, in its own units.
    intervals : dict
        Every free parameter's 95 % interval (lo, hi), by name (profile likelihood; Wald for
        the gain and for z > 1).
    uncertain : dict
        The uncertainty budget applied (:mod:`sca.budget`), name -> sd as given; {} for the
        paper's exact model or where it was not applied (noise unknown).
    budget : dict
        Each source's share of the variance of C and a_CDOM (:func:`sca.budget.variance_shares`):
        {'chl': {'sd': float, 'shares': {source: fraction}}, 'cdom': ...}; {} without a budget.
    nuisance : dict
        The budget's nuisance parameters at the fit: name -> value ('balance': m values).
    path_models : tuple of str
        The path models the data support (:mod:`sca.pathmodels`); with more than one the
        intervals span them (flag ``path-model-span``). ``path_model`` is the best-fitting.
    path_objective : dict
        Path model -> the objective of the fit under it.
    """

    chl: float
    cdom: float
    #: standard errors of chl and cdom from the Gauss-Newton covariance at the estimate (with
    #: the residual as noise estimate where the noise is unknown): large values say the data
    #: cannot decide; 0 for a fixed parameter or an exact (noise-free) fit
    chl_se: float
    cdom_se: float
    #: 95 % profile-likelihood intervals (lower end 0 where the data allow 0, upper end inf
    #: where they cannot bound the parameter); Wald intervals for z > 1 basis functions
    chl_ci: tuple
    cdom_ci: tuple
    #: True only when nothing in ``flags`` blocks it (sca.assess.BLOCKING)
    reliable: bool
    flags: tuple
    fit_rms: float  # ||M - G - s|| / ||M||
    chi2_dof: float  # reduced chi^2 of the whitened residual (NaN: noise unknown)
    chi2_p: float  # its p-value
    dof: int
    noise_known: bool
    w: np.ndarray
    backscatter: np.ndarray
    attenuation: np.ndarray
    attenuation_coefficient: np.ndarray
    wavelengths: np.ndarray
    objective: float  # chi^2 when the noise is known, else ||M - G - s||^2 (data units)
    iterations: int
    converged: bool
    status: str
    history: list
    mode: str
    initial: dict
    fixed: dict
    eq17_residual: float
    #: the true objective of every trial point, accepted or not (``history`` keeps the accepted)
    trials: list = field(default_factory=list)
    path_model: str = "beam"
    #: the exposure gain of M = gain G(x) + s (1 where it is known, ``gain="free"`` estimates it)
    gain: float = 1.0
    #: its 95 % Wald interval (Gauss-Newton standard error); (gain, gain) where it is known
    gain_ci: tuple = (1.0, 1.0)
    #: every free parameter's estimate, by name
    values: dict = field(default_factory=dict)
    #: every free parameter's 95 % interval, by name
    intervals: dict = field(default_factory=dict)
    #: the uncertainty budget applied: name -> sd as given (:mod:`sca.budget`); {} for the
    #: paper's exact model or where it could not be applied (noise unknown)
    uncertain: dict = field(default_factory=dict)
    #: each source's share of the variance of C and a_CDOM: {'chl': {'sd': float, 'shares':
    #: {source: fraction}}, 'cdom': ...}; {} without a budget
    budget: dict = field(default_factory=dict)
    #: the budget's nuisance parameters at the fit (name -> float, or (m,) list for 'balance')
    nuisance: dict = field(default_factory=dict)
    #: the path models the data support (:mod:`sca.pathmodels`; more than one: the intervals
    #: span them, flag ``path-model-span``); ``path_model`` is the best-fitting one
    path_models: tuple = ()
    #: path model -> the objective of the fit under it
    path_objective: dict = field(default_factory=dict)
    #: what the photo measures (:mod:`sca.derived`): name -> value of every derived quantity
    #: (the path's attenuation coefficient c at 443, 490, 555, 670 nm and a_nw(440); m^-1)
    quantities: dict = field(default_factory=dict)
    #: name -> (lo, hi) their 95 % intervals (spanning the supported path models)
    quantity_intervals: dict = field(default_factory=dict)
    #: (q,) the attenuation coefficient of the light's path, tau / (depth + distance), on
    #: ``wavelengths``, m^-1 (the beam attenuation c = a + b for the paper's path model)
    beam_attenuation: np.ndarray | None = None
    #: (q, 2) its 95 % interval at every wavelength
    beam_attenuation_ci: np.ndarray | None = None
    #: name -> verdict of 'chl', 'cdom' and every quantity: 'measured', 'loosely
    #: measured', 'upper bound' or 'not constrained' (:func:`sca.derived.verdict`)
    verdicts: dict = field(default_factory=dict)
    #: the readings and priors tested against the photos (:mod:`sca.consistency`):
    #: {'readings': {name: {'delta_chi2', 'p', 'conflict'}}, 'pulls': {nuisance: pull in its
    #: prior's sds}, 'pull_max', 'conflict_p'}; {} where no budget or reading applies
    consistency: dict = field(default_factory=dict)

    def to_dict(self) -> dict:
        """Every field, JSON-ready (arrays as lists).

        Returns
        -------
        dict
            Field name -> value; arrays (and ``fixed`` values) as lists, ``values`` as floats,
            ``intervals`` as [lo, hi] lists.
        """
        out = {}
        for key, val in self.__dict__.items():
            out[key] = val.tolist() if isinstance(val, np.ndarray) else val
        out["fixed"] = {k: (np.asarray(v).tolist()) for k, v in self.fixed.items()}
        out["values"] = {k: float(v) for k, v in self.values.items()}
        out["intervals"] = {k: [float(a) for a in v] for k, v in self.intervals.items()}
        out["nuisance"] = {k: np.asarray(v, float).tolist() for k, v in self.nuisance.items()}
        out["quantities"] = {k: float(v) for k, v in self.quantities.items()}
        out["quantity_intervals"] = {k: [float(a) for a in v]
                                     for k, v in self.quantity_intervals.items()}
        return out
