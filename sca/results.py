"""The result of one fit: :class:`Estimate` (what :func:`sca.estimate` and
:func:`sca.estimate_least_squares` return)."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

__all__ = ["Estimate"]


@dataclass
class Estimate:
    """Result of :func:`sca.estimate`.

    Units: chl mg m^-3, cdom and the attenuation coefficient m^-1, backscatter and objective in
    the units of the measurements. ``values`` and ``intervals`` are dicts keyed by the name of
    every free parameter (C and a_CDOM included, and any name of ``free=``): the estimate and
    its 95 % interval (profile likelihood; Wald for the gain and for z > 1 basis functions).
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

    def to_dict(self) -> dict:
        """Every field, JSON-ready (arrays as lists)."""
        out = {}
        for key, val in self.__dict__.items():
            out[key] = val.tolist() if isinstance(val, np.ndarray) else val
        out["fixed"] = {k: (np.asarray(v).tolist()) for k, v in self.fixed.items()}
        out["values"] = {k: float(v) for k, v in self.values.items()}
        out["intervals"] = {k: [float(a) for a in v] for k, v in self.intervals.items()}
        return out
