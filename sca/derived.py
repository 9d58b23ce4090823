"""What the photos measure: quantities derived from the fitted water, each with its own 95 %
interval, and a verdict in words for every reported quantity.

C and a_CDOM(440) are the model's parameters, but a camera measures their combination: the
attenuation of the light along its path. The quantities reported beside them are functions
h(theta) of the fitted parameters, computed by the one physics (:mod:`forward.water`):

* ``c_443``, ``c_490``, ``c_555``, ``c_670``, and the spectrum on the model's grid: the
  attenuation coefficient of the light's path, tau / (depth + distance) (eqs 3, 13, 14), m^-1.
  For the paper's path model ('beam') it is the beam attenuation c = a + b (eq 4), for
  'absorption' the absorption a, for 'split' the path-weighted mean of K_d (down) and c (along
  the view). It is what the photo measures, whatever the path model: every supported model
  fits the same transmittance;
* ``tau_443``, ``tau_490``, ``tau_555``, ``tau_670``: the optical depth of the light's path
  tau = c (depth + distance) (k = exp(-tau), eq 14), dimensionless, at the fitted water and the
  fitted (or known) depth and distance: what the photo measures directly, to a roughly fixed
  absolute precision whatever the water (c's relative error is large on a short path in clear
  water where tau is small and well measured). Its interval holds the depth's and the distance's
  uncertainty where the budget frees them;
* ``a_nw_440``: the absorption by everything but water at 440 nm (a_phi + a_CDOM + a_NAP), m^-1.

K_d(490) is not published (decision 0067-kd-not-published): the model's K_d rests on eq 12 taken
as the particles' backscattering and on K_d = (a + b_b) / mu_d, it is 1.26x the measured K_d in
real water (REALWATER.md), and its intervals missed the truth of the independent renderer's
dives in 22-78 % of them; a photo on the paper's path does not see it. A radiometer's K_d is
still an input (:mod:`sca.auxiliary`).

Intervals: the delta method on the logarithm (h > 0): sd(ln h) = sqrt(grad h^T Sigma grad h) / h,
with Sigma the covariance of the fitted parameters (the uncertainty budget's nuisances included)
from the one rule (:func:`sca.model.covariance_from_information`), the 95 % interval
h exp(-/+ 1.96 sd(ln h)); where C or a_CDOM sits at its lower bound, widened to hold h at the
profile points of their upper ends (:func:`bound_points`, decision
0066-derived-intervals-at-the-bounds). For a well determined quantity (a few percent) this is the profile
likelihood's interval to second order; its coverage is tested on worlds the estimator did not
make (HONESTY.md). Where several path models are supported the intervals span them, as C's.

Verdicts (:func:`verdict`, decision 0072-verdicts-loosely-measured): *measured* (a closed
interval with hi / lo <= :data:`MEASURED_RATIO`; for tau also one of half-width at most
:data:`TAU_MEASURED_HALF_WIDTH`), *loosely measured* (a closed interval with a lower end clearly
above 0, but wider), *an upper bound only* (finite upper end, the lower end 0: below
:data:`ZERO_FRACTION` of the upper end) or *not constrained* (an open interval).
"""

from __future__ import annotations

import numpy as np
from scipy import special

from forward.water import COEFFICIENT_PARAMS, NONWATER_ABSORPTION_TERMS

__all__ = ["BANDS_NM", "BOUND_POINT_MAX_ITER", "CONFIDENCE", "MEASURED_RATIO", "OPTICAL_DEPTH",
           "PATH_CF", "QUANTITIES", "SPECTRUM_BLOCK", "TAU_MEASURED_HALF_WIDTH", "VERDICTS",
           "ZERO_FRACTION", "bound_points", "delta_interval", "derived_from_fit", "describe",
           "is_optical_depth", "quantity_names", "quantity_sd", "quantity_values",
           "spectrum_values", "verdict", "verdicts_of"]

#: The standard bands of the beam attenuation, nm (ocean-colour bands: SeaWiFS/MODIS 443, 490,
#: 555, 670).
BANDS_NM = (443.0, 490.0, 555.0, 670.0)
#: Confidence level of every interval.
CONFIDENCE = 0.95
#: A closed interval whose ends differ by at most this factor is a measurement (about a
#: factor 1.7 either side of its centre); a wider one with a lower end clearly above 0 is
#: loosely measured, one reaching 0 an upper bound (decision 0072-verdicts-loosely-measured).
MEASURED_RATIO = 3.0
#: The optical depth tau is measured when its 95 % interval's half-width is at most this
#: (absolute: the photo measures tau to a roughly fixed precision whatever the water), or by
#: :data:`MEASURED_RATIO` as any quantity (decision 0072-verdicts-loosely-measured).
TAU_MEASURED_HALF_WIDTH = 0.1
#: A lower end below this fraction of the upper end is 0 for the verdicts (the interval spans
#: more than a factor 100: the delta method on the logarithm never reaches 0 exactly).
ZERO_FRACTION = 0.01
#: The verdicts, in order of knowledge.
VERDICTS = ("measured", "loosely measured", "upper bound", "not constrained")
#: The first field of an optical depth's entry in :data:`QUANTITIES`.
OPTICAL_DEPTH = "tau"
#: CF standard names of the path's attenuation coefficient, by path model
PATH_CF = {"beam": "volume_beam_attenuation_coefficient_of_radiative_flux_in_sea_water",
           "absorption": "volume_absorption_coefficient_of_radiative_flux_in_sea_water",
           "split": ""}
#: Each quantity: (its terms of c(x), None for the path's coefficient or
#: :data:`OPTICAL_DEPTH` for the path's optical depth; wavelength nm; description; units (CF:
#: "1" dimensionless); CF standard name, "" where none or the path model's).
QUANTITIES = {
    **{f"c_{b:.0f}": (None, b, f"attenuation coefficient of the light's path at {b:.0f} nm",
                      "m-1", "") for b in BANDS_NM},
    **{f"tau_{b:.0f}": (OPTICAL_DEPTH, b, f"optical depth of the light's path at {b:.0f} nm, "
                        "c (depth + distance)", "1", "") for b in BANDS_NM},
    "a_nw_440": (NONWATER_ABSORPTION_TERMS, 440.0,
                 "absorption by everything but water at 440 nm", "m-1", ""),
}


def quantity_names() -> tuple:
    """The names of :data:`QUANTITIES`, in order."""
    return tuple(QUANTITIES)


def is_optical_depth(name) -> bool:
    """Whether ``name`` is an optical depth of :data:`QUANTITIES` (``tau_443`` ...)."""
    return name in QUANTITIES and QUANTITIES[name][0] == OPTICAL_DEPTH


def _consts(params):
    return {k: v for k, v in params.items() if k in COEFFICIENT_PARAMS}


def _spectral(wrt) -> tuple:
    return tuple(n for n in wrt if n in ("chl", "cdom") + COEFFICIENT_PARAMS)


def _optical_depth(water, wavelengths, params, wrt):
    """tau on ``wavelengths``, its derivatives (geometry included) and the path's length
    depth + distance (N, 1)."""
    chl = np.atleast_1d(np.asarray(params["chl"], float))
    cdom = np.atleast_1d(np.asarray(params.get("cdom", 0.0), float))
    depth = np.atleast_1d(np.asarray(params["depth"], float))
    distance = np.atleast_1d(np.asarray(params["distance"], float))
    wrt = _spectral(wrt) + tuple(n for n in wrt if n in ("depth", "distance"))
    tau, d = water.on_grid(wavelengths).optical_depth(chl, cdom, depth, distance,
                                                      values=_consts(params), wrt=wrt,
                                                      floor=1e-300)
    return tau, d, np.maximum(depth + distance, 1e-300)[..., None]


def _path_coefficient(water, wavelengths, params, wrt, tau_d=None):
    """tau / (depth + distance) on ``wavelengths`` and its derivatives (geometry included);
    ``tau_d``: :func:`_optical_depth`'s result there, where already computed."""
    tau, d, L = tau_d or _optical_depth(water, wavelengths, params, wrt)
    out = {k: v / L for k, v in d.items()}
    for g in ("depth", "distance"):
        if g in out:
            out[g] = out[g] - tau / L ** 2
    return tau / L, out


def quantity_values(water, params, wrt=()) -> dict:
    """Every quantity of :data:`QUANTITIES` and its derivatives at the fitted parameters.

    Parameters
    ----------
    water : forward.Water
        The water model of the fit (its path model gives the path's coefficient).
    params : dict
        'chl' (mg m^-3), 'cdom' (m^-1), 'depth' and 'distance' (m) and any fitted coefficient
        of the water, each (N,).
    wrt : sequence of str
        Names to differentiate by (among 'chl', 'cdom', 'depth', 'distance' and the water's
        coefficients).

    Returns
    -------
    dict
        name -> (value (N,), {parameter: d value / d parameter (N,)}).
    """
    chl = np.atleast_1d(np.asarray(params["chl"], float))
    cdom = np.atleast_1d(np.asarray(params.get("cdom", 0.0), float))
    consts, spectral = _consts(params), _spectral(wrt)
    bands = np.array(BANDS_NM)
    grid = np.sort(np.concatenate([bands, bands + 1.0]))  # a grid of the bands (>= 3 points)
    tau_d = _optical_depth(water, grid, params, wrt)
    along = {None: _path_coefficient(water, grid, params, wrt, tau_d),
             OPTICAL_DEPTH: tau_d[:2]}
    at = np.searchsorted(grid, bands)
    out = {}
    for name, (terms, band, *_) in QUANTITIES.items():
        if terms in along:
            j = at[BANDS_NM.index(band)]
            path, dpath = along[terms]
            out[name] = (path[..., j], {k: v[..., j] for k, v in dpath.items()})
            continue
        g = water.on_grid(np.array([band - 1.0, band, band + 1.0]))
        c, d = g.path_coefficient(chl, cdom, values=consts, wrt=spectral, floor=1e-300,
                                  terms=terms)
        out[name] = (c[..., 1], {k: v[..., 1] for k, v in d.items()})
    return out


def spectrum_values(water, params, wavelengths, wrt=()):
    """The path's attenuation coefficient tau / (depth + distance) on ``wavelengths`` and its
    derivatives.

    Parameters
    ----------
    water : forward.Water
        The water model.
    params : dict
        As :func:`quantity_values`.
    wavelengths : array_like, (q,)
        nm.
    wrt : sequence of str
        Names to differentiate by.

    Returns
    -------
    c : ndarray, (N, q)
        m^-1.
    derivatives : dict
        name -> (N, q).
    """
    return _path_coefficient(water, wavelengths, params, wrt)


def delta_interval(value, grad, cov, confidence: float = CONFIDENCE):
    """The delta method's interval of a positive quantity, on its logarithm.

    Parameters
    ----------
    value : array_like, S
        The quantity at the fit (> 0; 0 or less gives a linear interval clipped at 0).
    grad : array_like, S + (p,)
        Its gradient by the fitted parameters (the covariance's coordinates).
    cov : array_like, S[:1] + (p, p) or (p, p)
        The parameters' covariance (``inf`` entries: undetermined).
    confidence : float, optional
        Default :data:`CONFIDENCE`.

    Returns
    -------
    ndarray, S + (2,)
        Lower and upper ends (``inf`` upper end where the covariance is infinite).
    """
    value = np.asarray(value, float)
    grad = np.asarray(grad, float)
    cov = np.asarray(cov, float)
    z = special.ndtri(0.5 + confidence / 2)
    with np.errstate(invalid="ignore", over="ignore"):
        if cov.ndim == 2:
            var = np.einsum("...p,pq,...q->...", grad, cov, grad)
        else:
            var = np.einsum("n...p,npq,n...q->n...", grad, cov, grad)
        sd = np.sqrt(np.maximum(np.where(np.isfinite(var), var, np.inf), 0.0))
        rel = np.where(value > 0, sd / np.where(value > 0, value, 1.0), np.inf)
        lo = np.where(value > 0, value * np.exp(-z * rel), np.maximum(value - z * sd, 0.0))
        hi = np.where(value > 0, value * np.exp(z * rel), value + z * sd)
    hi = np.where(np.isfinite(hi), hi, np.inf)
    lo = np.where(np.isfinite(hi), lo, 0.0)
    return np.stack([lo, hi], axis=-1)


def verdict(lo, hi, name=None) -> np.ndarray:
    """What an interval says, in :data:`VERDICTS`' words (arrays allowed; decision
    0072-verdicts-loosely-measured).

    Parameters
    ----------
    lo, hi : float or array_like
        The interval's ends (``inf``: open).
    name : str, optional
        The quantity's name: any quantity is measured when hi / lo <= :data:`MEASURED_RATIO`
        (the lower end above 0), an optical depth (:func:`is_optical_depth`) also when the
        interval's half-width is at most :data:`TAU_MEASURED_HALF_WIDTH` (tau near 0 is then
        measured to that absolute precision).

    Returns
    -------
    ndarray of str (a str for scalars)
        'measured', 'loosely measured' (closed, the lower end clearly above 0, wider than
        'measured'), 'upper bound' (closed, the lower end 0: below :data:`ZERO_FRACTION` of the
        upper end) or 'not constrained' (open).
    """
    lo, hi = np.asarray(lo, float), np.asarray(hi, float)
    with np.errstate(divide="ignore", invalid="ignore"):
        closed = np.isfinite(hi)
        above_zero = closed & (lo > 0) & (lo >= ZERO_FRACTION * hi)
        measured = above_zero & (hi <= MEASURED_RATIO * lo)
        if is_optical_depth(name):
            measured |= closed & (hi - lo <= 2 * TAU_MEASURED_HALF_WIDTH)
    out = np.select([~closed, measured, above_zero], [VERDICTS[3], VERDICTS[0], VERDICTS[1]],
                    VERDICTS[2])
    return str(out) if out.ndim == 0 else out


def describe(label: str, value, lo, hi, units: str, *, where: str = "these data",
             narrow: str = "", name=None) -> str:
    """One plain sentence: what the data say of a quantity.

    Parameters
    ----------
    label : str
        The quantity's name for people ('C', 'a_CDOM(440)', 'c(490)', 'tau(490)').
    value, lo, hi : float
        The estimate and its 95 % interval (``inf``: open).
    units : str
        Its units ('' for a dimensionless one).
    where : str, optional
        What was measured ('this photo', 'this dive').
    narrow : str, optional
        What would narrow it (appended unless it is measured).
    name : str, optional
        The quantity's name in :data:`QUANTITIES` (its verdict's rule: :func:`verdict`).

    Returns
    -------
    str
    """
    v = verdict(lo, hi, name)
    tail = f"; {narrow}" if narrow and v != "measured" else ""
    u = f" {units}" if units else ""
    if v == "measured":
        return f"{label}: measured, {value:.3g}{u} (95 %: {lo:.3g}-{hi:.3g})"
    if v == "loosely measured":
        return (f"{label}: loosely measured by {where}, {value:.3g}{u} (95 %: {lo:.3g}-"
                f"{hi:.3g}){tail}")
    if v == "upper bound":
        return (f"{label}: only an upper bound from {where}: at most {hi:.3g}{u} "
                f"(95 %: {lo:.3g}-{hi:.3g}){tail}")
    return f"{label}: not constrained by {where} (at least {lo:.3g}{u}){tail}"


#: Fits per block of the spectrum's intervals (their gradients are fits x wavelengths x
#: parameters).
SPECTRUM_BLOCK = 512


def _gradient(prob, names, chain, derivs, shape):
    """d h / d theta (shape + (p,)) from h's derivatives by name (natural units)."""
    grad = np.zeros(shape + (len(names),))
    for j, n in enumerate(names):
        if n in derivs:
            d = np.asarray(derivs[n], float)
            grad[..., j] = d * chain[:, j].reshape((-1,) + (1,) * (d.ndim - 1))
    return grad


#: Levenberg-Marquardt iterations of each profile point at a parameter's interval end
#: (:func:`bound_points`).
BOUND_POINT_MAX_ITER = 100


def bound_points(prob, theta, ends: dict) -> list:
    """The profile points at the upper ends of parameters whose estimate sits at its lower
    bound: for each column j of ``ends``, theta with column j held at its upper end and every
    other column at its optimum there (the one Levenberg-Marquardt), for the units where a
    column of ``ends`` is at its bound; theta itself elsewhere.

    A derived quantity h is, at such a point, a value the data allow (the point lies on the
    boundary of the parameter's 95 % profile-likelihood region), and the delta method at the
    bound cannot see it: at C = 0 the terms of C that grow faster than u = C^e0 (b_p, a_NAP)
    have no derivative, so c(670)'s interval collapsed to the water's own (decision
    0066-derived-intervals-at-the-bounds).

    Parameters
    ----------
    prob : sca.problem.Problem
    theta : ndarray, (N, p)
        The optima.
    ends : dict
        Column j -> (N,) its upper interval end (theta's coordinates; non-finite: none).

    Returns
    -------
    list of ndarray, (N, p)
        One point per column of ``ends``.
    """
    from .lm import LM_TOL, levenberg_marquardt

    theta = np.asarray(theta, float)
    at = np.zeros(theta.shape[0], bool)
    for j in ends:
        at |= theta[:, j] <= prob.lower[j]
    out = []
    for j, upper in ends.items():
        upper = np.asarray(upper, float).reshape(-1)
        rows = np.flatnonzero(at & np.isfinite(upper) & (upper > theta[:, j]))
        point = theta.copy()
        if rows.size:
            start = theta[rows].copy()
            start[:, j] = upper[rows]
            hold = np.zeros(start.shape, bool)
            hold[:, j] = True
            point[rows], _, _, _ = levenberg_marquardt(
                prob, start, max_iter=BOUND_POINT_MAX_ITER, tol=LM_TOL,
                f_exact=np.zeros(rows.size), hold=hold, rows=rows)
        out.append(point)
    return out


def _widen(ci, values):
    """``ci`` (S + (2,)) widened to hold ``values`` (S) where they are finite."""
    ok = np.isfinite(values)
    lo = np.where(ok, np.minimum(ci[..., 0], values), ci[..., 0])
    hi = np.where(ok, np.maximum(ci[..., 1], values), ci[..., 1])
    return np.stack([lo, hi], axis=-1)


def _water_params(prob, theta, geometry):
    """The water's parameters (and the geometry) of the units at ``theta``."""
    N = theta.shape[0]
    params = prob.params(np.arange(N), theta)
    out = {k: np.asarray(v, float).reshape(N) for k, v in params.items()
           if k in ("chl", "cdom") or k in COEFFICIENT_PARAMS}
    if geometry is None:
        out.update({k: np.asarray(params[k], float).reshape(N) for k in ("depth", "distance")})
    else:
        out.update({k: np.broadcast_to(np.asarray(v, float), (N,)) for k, v in geometry.items()})
    return params, out


def derived_from_fit(prob, theta, H, water, wavelengths, sigma2=1.0, *, geometry=None,
                     ends=None) -> dict:
    """Every derived quantity of the fits of ``prob`` at ``theta`` with its 95 % interval.

    Parameters
    ----------
    prob : sca.problem.Problem
        The fitted units (any layout whose parameters include 'chl' and 'cdom', or hold them
        in ``fixed``).
    theta : ndarray, (N, p)
        The optima (theta's coordinates).
    H : ndarray, (N, p, p)
        The Gauss-Newton matrices there (:meth:`sca.problem.Problem.evaluate`: J^T J plus the
        priors): their inverse is the parameters' covariance.
    water : forward.Water
        The water model of the fit (its path model gives the path's coefficient).
    wavelengths : array_like, (q,)
        The spectrum's grid, nm (the full grid of the fit's model).
    sigma2 : float or array_like, (N,), optional
        The noise variance in the objective's units (1 where the noise is known).
    geometry : dict, optional
        'depth' and 'distance' (N,) at which the path's coefficient is evaluated, held (a
        dive's photos each have their own: its median); default the fits' own, free or not.
    ends : dict, optional
        Column j -> (N,) the upper end of its 95 % interval (theta's coordinates): where a
        column of ``ends`` sits at its lower bound, every interval also holds the quantity at
        the profile points of those ends (:func:`bound_points`).

    Returns
    -------
    dict
        'quantities': name -> (value (N,), ci (N, 2)); 'c': (N, q) the path's attenuation
        coefficient, 'c_ci': (N, q, 2); 'wavelengths': (q,).
    """
    from .model import covariance_from_information

    N = theta.shape[0]
    names = prob.names
    params, water_params = _water_params(prob, theta, geometry)
    chain = prob.chain(params)
    cov = covariance_from_information(H) * np.asarray(sigma2, float).reshape(-1, 1, 1)
    wrt = prob.free if geometry is None else tuple(n for n in prob.free if n not in geometry)
    points = [_water_params(prob, t, geometry)[1] for t in bound_points(prob, theta, ends)] \
        if ends else []
    out = {"quantities": {}, "wavelengths": np.asarray(wavelengths, float)}
    at_points = [quantity_values(water, p) for p in points]
    for name, (value, derivs) in quantity_values(water, water_params, wrt).items():
        value = np.broadcast_to(value, (N,)).astype(float)
        grad = _gradient(prob, names, chain, derivs, (N,))
        ci = delta_interval(value, grad, cov)
        for q in at_points:
            ci = _widen(ci, np.broadcast_to(q[name][0], (N,)))
        out["quantities"][name] = (value, ci)
    q = np.size(wavelengths)
    c = np.empty((N, q))
    ci = np.empty((N, q, 2))
    for lo in range(0, N, SPECTRUM_BLOCK):
        sl = slice(lo, min(N, lo + SPECTRUM_BLOCK))
        block = {k: np.asarray(v)[sl] for k, v in water_params.items()}
        val, derivs = spectrum_values(water, block, wavelengths, wrt)
        n = val.shape[0]
        grad = _gradient(prob, names, chain[sl], derivs, (n, q))
        c[sl] = val
        ci[sl] = delta_interval(val, grad, cov[sl])
        for p in points:
            at, _ = spectrum_values(water, {k: np.asarray(v)[sl] for k, v in p.items()},
                                    wavelengths)
            ci[sl] = _widen(ci[sl], at)
    out["c"], out["c_ci"] = c, ci
    return out


def quantity_sd(water, params, cov, names):
    """The value and the standard deviation of every derived quantity (:data:`sca.derived.
    QUANTITIES`) by the delta method: sqrt(grad h^T Sigma grad h).

    Parameters
    ----------
    water : forward.Water
        The water model (its path model gives the path's coefficient).
    params : dict
        'chl' (mg m^-3), 'cdom' (m^-1), 'depth' and 'distance' (m) and any water coefficient
        held at another value than the water's, each (N,).
    cov : array_like, (N, p, p) or (p, p)
        The parameters' covariance in their own units (C in mg m^-3).
    names : sequence of str or None, (p,)
        The name of each column of ``cov`` (None, or a repeated name such as a per-photo
        geometry held by the caller, for a column no quantity depends on).

    Returns
    -------
    values, sds : dict
        name -> (N,) arrays (m^-1); the sd is ``inf`` where the covariance is not finite.
    """
    cov = np.asarray(cov, float)
    N = np.size(np.atleast_1d(params["chl"]))
    cov = np.broadcast_to(cov, (N,) + cov.shape[-2:])
    finite = np.isfinite(cov).all(axis=(1, 2))
    cov = np.where(finite[:, None, None], cov, 0.0)
    counts = {n: list(names).count(n) for n in names if n is not None}
    wrt = tuple(n for n, k in counts.items() if k == 1)  # a repeated name: held by the caller
    values, sds = {}, {}
    with np.errstate(divide="ignore", invalid="ignore"):  # a path of 0 m: no quantity
        derived = quantity_values(water, params, wrt)
    for q, (value, derivs) in derived.items():
        value = np.broadcast_to(np.asarray(value, float), (N,)).copy()
        grad = np.zeros((N, cov.shape[-1]))
        for j, n in enumerate(names):
            if n in wrt and n in derivs:
                grad[:, j] = derivs[n]
        var = np.einsum("np,npq,nq->n", grad, cov, grad)
        values[q] = value
        sds[q] = np.where(finite, np.sqrt(np.maximum(var, 0.0)), np.inf)
    return values, sds


def verdicts_of(chl_ci, cdom_ci, quantity_intervals) -> dict:
    """name -> (N,) verdict (:func:`sca.derived.verdict`) of C, a_CDOM and every quantity."""
    out = {"chl": verdict(chl_ci[:, 0], chl_ci[:, 1]),
           "cdom": verdict(cdom_ci[:, 0], cdom_ci[:, 1])}
    out.update({k: verdict(v[:, 0], v[:, 1], k) for k, v in quantity_intervals.items()})
    return out
