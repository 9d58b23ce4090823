"""How precisely can a camera measure the water? The Cramér-Rao bound of the chart model.

For each condition (C, a_CDOM(440), depth, distance, and the water's constants) the noise-free
chart M0 = gain (G(x) + s 1^T) is computed with :meth:`sca.model.ChartModel.predict` (camera,
illuminant, chart, :class:`forward.Water`) and the veiling light of :mod:`forward`, its noise
sigma with the sensor's own noise model (:func:`forward.sensor.noise_model`), and the Fisher
information J^T diag(1 / sigma^2) J of the free parameters with the model function's analytic
Jacobian; the backscatter s_1..s_m is a free parameter (the estimators fit it) and is profiled
out (:func:`sca.model.profiled_covariance`, the estimators' own covariance). The covariance
bound is its inverse: the standard deviation of every free parameter (``sd``), the correlation
of C and a_CDOM, (delta method) the expected RRMSE of the attenuation k (eq 19 on the paper's
31 bands of 10 nm) and the standard deviation of every quantity the estimators derive
(:mod:`sca.derived`: the path's attenuation coefficient at 443, 490, 555 and 670 nm and
a_nw(440); ``quantity_sd``), sqrt(grad h^T Sigma grad h) with the bound's covariance Sigma in
the parameters' own units (C in mg m^-3), as the estimators' intervals use theirs.

The bound does not include the estimators' span over the path models the data cannot tell
apart (their intervals are the union over the supported models): :func:`sca.design` (:mod:`sca.protocols`)
predicts it.

``gain``: 'known' (the exposure is known: data in model units), 'free' (one unknown scalar
gain: a photograph's exposure) or 'channels' (an unknown gain per channel: a camera whose R:G:B
balance is not calibrated). ``fix``: parameters held known. ``free``: more parameters estimated
(a forward.Water coefficient such as 'cdom_slope', or the geometry).

Where the bound is not attained (flags): near a bound (the 95 % interval would reach C = 0 or
a_CDOM = 0: the estimator's constraint makes its error distribution one-sided;
``near-bound-chl`` / ``near-bound-cdom``), for charts too dark for the noise (``dark``) or
clipped (``saturated``). The validation (``experiments/instrument.py``, tests) compares the
bound with the estimator's spread where none is raised.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from forward import validate
from forward.imaging import ChartSetup, length, resolve_setup, veiling_light
from forward.sensor import SensorSettings, noise_model
from forward.spectra import DEFAULT_CAMERA
from forward.water import Water, resolve_water

from .assess import Z95, flag_tuples, input_flag_table
from .derived import quantity_sd
from .budget import (DEFAULT_UNCERTAIN, limiting_source, prior_arrays, resolve_budget,
                     variance_shares)
from .fitspec import fit_spec
from .metrics import RRMSE_BANDS_NM
from .model import (CHL_DERIVATIVE_FLOOR, ChartModel, covariance_from_information,
                    profiled_information)
from .problem import observation_terms
from forward.errors import InputError

__all__ = ["GAINS", "Z95", "Precision", "precision"]

GAINS = ("known", "free", "channels")


@dataclass
class Precision:
    """The bound for N conditions (arrays of length N; floats for scalar conditions).

    ``sd`` is a dict of the standard deviation of every free parameter (C and a_CDOM included,
    a free gain too), in its own units.

    Attributes
    ----------
    chl : ndarray, (N,), or float
        C of each condition, mg m^-3.
    cdom : ndarray, (N,), or float
        a_CDOM(440) of each condition, m^-1 (a number given in ``fix`` replaces it).
    depth, distance : ndarray, (N,), or float
        The path, m.
    chl_sd : ndarray, (N,), or float
        Cramér-Rao standard deviation of C, mg m^-3.
    cdom_sd : ndarray, (N,), or float
        That of a_CDOM(440), m^-1 (0 where a_CDOM is held).
    correlation : ndarray, (N,), or float
        corr(C, a_CDOM) of the bound (NaN where a_CDOM is held).
    rrmse : ndarray, (N,), or float
        Expected RRMSE of the attenuation k (eq 19 on the 31 bands of 10 nm, delta method).
    attained : ndarray of bool, (N,), or bool
        No flag raised (the bound is expected to describe the estimator's spread).
    flags : list of tuple of str, or tuple of str
        Raised flags per condition: 'dark', 'saturated', 'near-bound-chl', 'near-bound-cdom'.
    gain : str
        'known', 'free' or 'channels'.
    fixed : dict
        The ``fix`` argument as given.
    sd : dict
        name -> standard deviation of every free parameter (and 'gain' for ``gain='free'``),
        in its own units.
    uncertain : dict
        The uncertainty budget included (:mod:`sca.budget`), name -> sd as given; {}: photon
        and read noise only.
    budget : dict
        Each source's share of the variance of C and a_CDOM (:func:`sca.budget.variance_shares`;
        arrays, floats for scalar conditions); {} without a budget.
    limiting : list of str or str
        The source with the largest share of C's variance per condition ('noise' without a
        budget).
    quantities : dict
        name -> value of every derived quantity of :data:`sca.derived.QUANTITIES` at the
        condition (m^-1, the optical depths dimensionless; a dive's at its photos' median
        depth and distance, as the joint estimate reports them: without the optical depths).
    quantity_sd : dict
        name -> its Cramér-Rao standard deviation (m^-1; delta method with the bound's
        covariance; ``inf`` where the covariance is).
    fitted : dict
        A dive's: 'path_model' (the model fitted), 'chl', 'cdom' (its optimum on the
        noise-free photos: the truth for the water's own model), 'objective' (its chi^2
        there: 0, or the noncentrality of another model's misfit) and 'converged';
        ``quantities`` are then at that optimum. {} for single photos.
    chl_rel95, cdom_rel95 : ndarray or float
        (Properties) 1.96 sd / value of C and of a_CDOM.
    quantity_rel95 : dict
        (Property) name -> 1.96 sd / value of every derived quantity.
    """

    chl: np.ndarray
    cdom: np.ndarray
    depth: np.ndarray
    distance: np.ndarray
    chl_sd: np.ndarray  # mg m^-3
    cdom_sd: np.ndarray  # m^-1
    correlation: np.ndarray  # corr(C, a_CDOM) of the bound
    rrmse: np.ndarray  # expected RRMSE of k (eq 19, 31 bands of 10 nm)
    attained: np.ndarray  # bool: no flag raised
    flags: list  # N tuples
    gain: str
    fixed: dict
    sd: dict = field(default_factory=dict)
    uncertain: dict = field(default_factory=dict)
    budget: dict = field(default_factory=dict)
    limiting: list = field(default_factory=list)
    quantities: dict = field(default_factory=dict)
    quantity_sd: dict = field(default_factory=dict)
    fitted: dict = field(default_factory=dict)

    @property
    def quantity_rel95(self) -> dict:
        """name -> 95 % half-width of each derived quantity relative to its value (1.96 sd /
        value; floats for scalar conditions)."""
        out = {}
        with np.errstate(divide="ignore", invalid="ignore"):
            for k, v in self.quantities.items():
                r = Z95 * np.asarray(self.quantity_sd[k], float) / np.asarray(v, float)
                out[k] = float(r) if np.ndim(r) == 0 else r
        return out

    @property
    def chl_rel95(self) -> np.ndarray:
        """95 % half-width of C relative to C (1.96 sd / C)."""
        with np.errstate(divide="ignore", invalid="ignore"):
            return Z95 * self.chl_sd / self.chl

    @property
    def cdom_rel95(self) -> np.ndarray:
        """95 % half-width of a_CDOM relative to a_CDOM (1.96 sd / a_CDOM)."""
        with np.errstate(divide="ignore", invalid="ignore"):
            return Z95 * self.cdom_sd / self.cdom

    def __len__(self):
        return np.size(self.chl)


def precision(chl, cdom, *, depth, distance, camera=DEFAULT_CAMERA, illuminant=None,
              reflectances=None, wavelengths=None, sensor: SensorSettings | None = None,
              water: Water | None = None, gain: str = "known", fix=None, free=(),
              setup: ChartSetup | None = None, uncertain=None, dive: bool = False,
              auxiliary=None, path_model: str | None = None) -> Precision:
    """The Cramér-Rao bound of C, a_CDOM(440) and any free parameter for every condition.

    Parameters
    ----------
    chl : float or array_like
        C, mg m^-3.
    cdom : float or array_like
        a_CDOM(440), m^-1.
    depth, distance : float or array_like
        The path, m (keyword-only). All four broadcast to N conditions.
    camera, illuminant, reflectances, wavelengths, setup :
        As :func:`forward.simulate_chart`.
    sensor : forward.SensorSettings, optional
        The sensor whose noise model gives sigma (default ``forward.SensorSettings()``).
    water : forward.Water, optional
        The water (default the paper's).
    gain : {'known', 'free', 'channels'}
        The exposure: known, one unknown gain, or one unknown gain per channel.
    fix : dict, optional
        Parameters held known: 'cdom' (value None: known at the condition's value; a number
        replaces the condition's value, m^-1), 'backscatter' (any value, None included: known;
        M0 keeps the veiling light of :mod:`forward`), or a forward.Water coefficient (its
        value). 'chl' is refused (the bound is for C).
    free : sequence of str
        More parameters estimated: forward.Water coefficients (e.g. 'cdom_slope') or the
        geometry ('depth', 'distance'). ('gain' here has no effect: the exposure is set by
        ``gain``.)
    uncertain : dict, optional
        The uncertainty budget (:mod:`sca.budget`): its per-patch term joins the sensor's
        noise and its nuisances enter with their Gaussian priors, as in the estimators.
        Default (None): :data:`sca.budget.DEFAULT_UNCERTAIN`; ``{}``: the sensor's photon and
        read noise only (the camera's own limit).
    dive : bool, optional
        The conditions are the photos of one dive in one water (C and a_CDOM the same in
        all; each photo its own depth, distance and free exposure gain): the bound of the
        joint estimate (:func:`sca.joint.dive_precision`), whose budget's water, camera and
        per-patch terms are shared by the photos. ``chl_sd``, ``cdom_sd`` and ``correlation``
        are then floats (the dive's), ``depth`` and ``distance`` the photos'. Default False.
    auxiliary : dict, optional
        Auxiliary measurements planned (:func:`sca.auxiliary.auxiliary_observations`: 'cdom',
        'secchi', 'kd'; their values are the condition's, their sds as given): their
        information is added (for a dive, once).
    path_model : str, optional
        With ``dive=True`` only: the photos (made with the water's own path model) fitted with
        this path model of :data:`forward.water.PATH_MODELS` instead; the bound is then at
        its optimum (``fitted``: the values its estimate tends to and its chi^2 on the
        noise-free photos). What the estimators' span over path models the data cannot tell
        apart costs (:func:`sca.design` (:mod:`sca.protocols`)). Default: the water's own.

    Returns
    -------
    Precision
        Scalars where every condition was a scalar.

    Raises
    ------
    ValueError
        For an unknown ``gain``, a ``fix`` that is not a dict or holds 'chl', negative
        conditions, a sensor that is not a ``forward.SensorSettings``, a water whose
        phytoplankton basis has z > 1, or a ``path_model`` without ``dive=True``.

    References
    ----------
    S. M. Kay, Fundamentals of Statistical Signal Processing: Estimation Theory (1993), ch. 3.

    Examples
    --------
    >>> import sca
    >>> p = sca.precision(2.0, 0.1, depth=5, distance=1)
    >>> print(f"C: sd {p.chl_sd:.1f} mg m^-3; limited by {p.limiting!r}")
    C: sd 1.7 mg m^-3; limited by 'patch'
    """
    scalar = all(np.ndim(v) == 0 for v in (chl, cdom, depth, distance))
    if path_model is not None and not dive:
        raise InputError("path_model", "the bound under another path model is a dive's "
                         "(dive=True)")
    if gain not in GAINS:
        raise InputError("gain", f"must be one of {GAINS}, got {gain!r}")
    if fix is not None and not isinstance(fix, dict):
        raise InputError("fix", "expected a dict like {'cdom': None} (known at the condition's "
                         f"value) or {{'cdom': 0.1}}, got {type(fix).__name__}")
    fix = dict(fix or {})
    if "chl" in fix:
        raise InputError("fix", "the bound is for C; it cannot hold C known")
    if fix.get("backscatter") is not None:
        raise InputError("fix['backscatter']", "the bound holds s known at the condition's veiling "
                         "light; give None")
    free = tuple(free or ())
    if "gain" in free:  # free=('gain',) is gain='free'
        free = tuple(n for n in free if n != "gain")
        gain = "free" if gain == "known" else gain
    cond = {"chl": chl, "cdom": cdom}
    for k in ("cdom",):
        if fix.get(k) is not None:
            cond[k] = fix[k]
    chl, cdom, depth, distance = (np.array(x, float) for x in np.broadcast_arrays(
        np.atleast_1d(validate.nonnegative("chl", cond["chl"])),
        np.atleast_1d(validate.nonnegative("cdom", cond["cdom"])),
        np.atleast_1d(length("depth", depth)), np.atleast_1d(length("distance", distance))))
    sensor = SensorSettings() if sensor is None else sensor
    if not isinstance(sensor, SensorSettings):
        raise InputError("sensor", "expected a forward.SensorSettings")
    setup = resolve_setup(setup, camera, illuminant, reflectances, wavelengths)
    m = setup.sensitivities.shape[1]
    spec_fix = {k: (0.0 if v is None else v) for k, v in fix.items()}
    spec = fit_spec(free, spec_fix, "free" if gain == "free" else "known",
                    resolve_water(water), m)
    mdl = ChartModel(setup, water=spec.water)
    if mdl.z != 1:
        raise InputError("basis", "the bound is for one basis function (z = 1)")
    N, n = chl.size, mdl.n
    names = list(spec.names)
    if "chl" not in names:
        names.insert(0, "chl")
    budget = resolve_budget(uncertain, depth=depth, distance=distance, water=spec.water,
                            free=names, fixed=tuple(fix))
    mdl = budget.model(mdl)  # a reference shot's measured response
    extra = [nm for nm in budget.priors if nm not in names]
    params = {"chl": chl, "cdom": cdom, "depth": depth, "distance": distance}
    pred = mdl.predict(params, names + extra, chl_floor=CHL_DERIVATIVE_FLOOR)
    columns = list(pred.columns)
    prior = prior_arrays(budget.priors, columns, N)[1]
    s = veiling_light(setup.wavelengths, chl, cdom, depth, distance, illuminant=setup.illuminant,
                      water=spec.water) @ setup.sensitivities  # (N, m)
    M0 = pred.signal.reshape(N, m, n) + s[:, :, None]
    sigma_photon, saturation, _, _ = noise_model(M0, setup, sensor)
    if dive:
        return _dive(chl, cdom, depth, distance, setup, spec.water, uncertain, sigma_photon, s,
                     gain, fix, auxiliary, path_model)
    sigma = budget.noise_sd(M0, sigma_photon)
    J = pred.jacobian.reshape(N, m, n, -1)
    if gain == "channels":  # one gain per channel: d M0 / d g_c = M0 in channel c
        per = np.zeros((N, m, n, m))
        for c in range(m):
            per[:, c, :, c] = M0[:, c, :]
        J = np.concatenate([J, per], axis=-1)
    extra_cols = J.shape[-1] - len(columns)
    if gain == "free":
        extra_cols += 1
    prior_all = np.concatenate([prior, np.zeros((N, extra_cols))], axis=1)
    active = np.full((N, m), spec.free_s)
    F = profiled_information(J, 1.0 / sigma ** 2, active,
                             gain_column=M0 if gain == "free" else None, prior_weight=prior_all)
    for Ja in _observed(auxiliary, spec.water, params, columns):  # (N, G, p) whitened
        F[:, :Ja.shape[-1], :Ja.shape[-1]] += np.einsum("kgp,kgq->kpq", Ja, Ja)
    cov = covariance_from_information(F)
    qv, qsd = quantity_sd(spec.water, {**params, "chl": np.maximum(chl, CHL_DERIVATIVE_FLOOR)},
                          cov, list(columns) + [None] * (cov.shape[-1] - len(columns)))
    sd_all = np.sqrt(np.maximum(np.diagonal(cov, axis1=1, axis2=2), 0.0))
    sd = {nm: sd_all[:, j] for j, nm in enumerate(names)}
    if gain == "free":
        sd["gain"] = sd_all[:, -1]
    shares = {} if budget.exact else _shares(J, M0, columns, gain, spec.free_s, sigma,
                                             sigma_photon, prior_all)
    chl_sd = sd["chl"]
    cdom_free = "cdom" in names
    if cdom_free:
        i = names.index("cdom")
        cdom_sd = sd["cdom"]
        with np.errstate(invalid="ignore", divide="ignore"):
            corr = cov[:, 0, i] / (chl_sd * cdom_sd)
        sel = [0, i]
    else:
        cdom_sd, corr, sel = np.zeros(N), np.full(N, np.nan), [0]
    # the attenuation's delta-method variance from the (C[, a_CDOM]) block
    _, dtau = mdl.terms.optical_depth(chl, cdom, depth, distance,
                                      wrt=tuple(names[j] for j in sel), floor=CHL_DERIVATIVE_FLOOR)
    dk = -pred.attenuation[:, :, None] * np.stack([dtau[names[j]] for j in sel], axis=-1)
    cov_x = cov[:, sel][:, :, sel]
    bands = np.isin(setup.wavelengths, RRMSE_BANDS_NM)
    var_k = np.einsum("nlp,npq,nlq->nl", dk[:, bands], cov_x, dk[:, bands])
    k = pred.attenuation
    rrmse = np.sqrt(var_k.sum(axis=1)) / (np.sqrt(bands.sum()) * np.linalg.norm(k[:, bands], axis=1))
    flags, attained = _flags(chl, cdom, chl_sd, cdom_sd, M0, sigma, saturation, cdom_free)
    out = Precision(chl=chl, cdom=cdom, depth=depth, distance=distance, chl_sd=chl_sd,
                    cdom_sd=cdom_sd, correlation=corr, rrmse=rrmse, attained=attained,
                    flags=flags, gain=gain, fixed=fix, sd=sd,
                    uncertain={} if budget.exact else dict(budget.sd), budget=shares,
                    limiting=[limiting_source({k: v[i] for k, v in shares["chl"]["shares"].items()})
                              if shares.get("chl") else "noise" for i in range(N)],
                    quantities=qv, quantity_sd=qsd)
    if scalar:
        for name in ("chl", "cdom", "depth", "distance", "chl_sd", "cdom_sd", "correlation",
                     "rrmse"):
            setattr(out, name, float(getattr(out, name)[0]))
        out.attained = bool(out.attained[0])
        out.flags = out.flags[0]
        out.sd = {k_: float(v[0]) for k_, v in sd.items()}
        out.budget = {k_: {"sd": float(v["sd"][0]),
                           "shares": {a: float(b[0]) for a, b in v["shares"].items()}}
                      for k_, v in shares.items()}
        out.limiting = out.limiting[0]
        out.quantities = {k_: float(v[0]) for k_, v in qv.items()}
        out.quantity_sd = {k_: float(v[0]) for k_, v in qsd.items()}
    return out


def _observed(auxiliary, water, params, columns) -> list:
    """The whitened Jacobians (N, G, p) of each auxiliary measurement planned at the conditions
    (its value the condition's own: :func:`sca.auxiliary.planned`), by the fit's own term
    (:func:`sca.problem.observation_terms`) in the columns' own units."""
    from .auxiliary import auxiliary_observations, planned

    held = {}
    for j, c in enumerate(columns):
        held.setdefault(c, []).append(j)
    N = np.size(params["chl"])
    units, chain = np.arange(N), np.ones((N, len(columns)))
    terms = (observation_terms(obs, units, params, lambda n: held.get(n, []), chain, tuple(held))
             for obs in auxiliary_observations(planned(auxiliary, water, params), water))
    return [t[1] for t in terms if t is not None]


def _dive(chl, cdom, depth, distance, setup, water, uncertain, sigma_photon, s, gain, fix,
          auxiliary=None, path_model=None):
    """The joint bound of one water from the N photos (:func:`sca.joint.dive_precision`)."""
    from .joint import dive_precision

    if gain != "free" or fix:
        raise InputError("dive", "the joint bound frees each photo's exposure gain and holds "
                         "nothing: give gain='free' and no fix")
    if np.ptp(chl) > 0 or np.ptp(cdom) > 0:
        raise InputError("dive", "one water: chl and cdom must be the same for every photo")
    d = dive_precision(float(chl[0]), float(cdom[0]), depth=depth, distance=distance,
                       sigma=sigma_photon, setup=setup, water=water, uncertain=uncertain,
                       backscatter=s, auxiliary=auxiliary, path_model=path_model)
    flags = ("near-bound-chl",) * bool(Z95 * d["chl_sd"] >= chl[0]) + \
        ("near-bound-cdom",) * bool(Z95 * d["cdom_sd"] >= cdom[0])
    return Precision(chl=float(chl[0]), cdom=float(cdom[0]), depth=depth, distance=distance,
                     chl_sd=d["chl_sd"], cdom_sd=d["cdom_sd"], correlation=d["correlation"],
                     rrmse=np.nan, attained=not flags, flags=flags, gain=gain, fixed={},
                     sd={"chl": d["chl_sd"], "cdom": d["cdom_sd"]},
                     uncertain=dict(DEFAULT_UNCERTAIN if uncertain is None else uncertain),
                     budget={}, limiting="", quantities=d["quantities"],
                     quantity_sd=d["quantity_sd"],
                     fitted={"path_model": path_model or water.path_model, "chl": d["chl"],
                             "cdom": d["cdom"], "objective": d["objective"],
                             "converged": d["converged"]})


def _shares(J, M0, columns, gain, free_s, sigma, sigma_photon, prior):
    """The budget's variance shares of C and a_CDOM (:func:`sca.budget.variance_shares`) from
    the bound's Jacobian with the gain column(s) and the backscatter indicators appended."""
    N, m, n, p = J.shape
    cols = [J]
    names = list(columns) + ["gain"] * (p - len(columns))
    if gain == "free":
        cols.append(M0[..., None])
        names.append("gain")
    ind = np.zeros((N, m, n, m))
    for c in range(m):
        ind[:, c, :, c] = 1.0
    cols.append(ind)
    names += ["backscatter"] * m
    full = np.concatenate(cols, axis=-1).reshape(N, m * n, -1)
    active = np.ones((N, full.shape[-1]), bool)
    active[:, -m:] = free_s
    weight = np.concatenate([prior, np.zeros((N, m))], axis=1)
    return variance_shares(full, names, 1.0 / sigma.reshape(N, -1) ** 2,
                           1.0 / sigma_photon.reshape(N, -1) ** 2, active, weight)


def _flags(chl, cdom, chl_sd, cdom_sd, M0, sigma, saturation, cdom_free):
    table = input_flag_table(M0, sigma, saturation)
    table = {k: table[k] for k in ("dark", "saturated")}
    table["near-bound-chl"] = Z95 * chl_sd >= chl
    table["near-bound-cdom"] = cdom_free & (Z95 * cdom_sd >= cdom)
    flags, _ = flag_tuples(table)
    return flags, ~np.column_stack(list(table.values())).any(axis=1)
