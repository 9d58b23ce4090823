"""Eq 1's integral on a few nodes: the certified spectral quadrature of the chart model.

The chart model's signals are linear functionals of the path attenuation k(lambda):
vec(G) = B k with B = (P (x) R) diag(i) on the model's grid (1 nm: q = 301), and the camera
curves' shift D k likewise (:class:`sca.model.ChartModel`). k = exp(-tau) is smooth enough that
its values on a 5 nm lattice (:data:`QUADRATURE_STEP_NM`, r = 61 nodes of the grid) determine
B k to a few parts in 10^5: a quadrature rule B_r (m n x r) with B k ~ B_r k[nodes] for every
water the estimators meet. The rule's weights are not an interpolation formula (the pure-water
table has kinks every 10 nm that a spline through 5 nm nodes misses by 1 %) but a weighted
least-squares fit, output by output, of the full-grid integrals of snapshots of k drawn over
:data:`SNAPSHOT_DOMAIN` (every path model; C, a_CDOM, depth, distance, the CDOM and NAP slopes,
the two chlorophyll-specific scales and the surface light's colour over their ranges; charts
brighter than :data:`DARKEST`), each output weighted by 1 / (its value + :data:`WEIGHT_FLOOR` of the chart's brightest
value): the error is relative, as the sensor's noise is.

The rule is **certified twice**: on independent validation snapshots when it is built (its
``error``, the largest relative error; ``tests/test_quadrature.py`` holds it below
:data:`CERTIFIED_ERROR`), and at every fit's optimum by the estimators, which compare the reduced
prediction with the full grid's and refit on the full grid where they differ by more than
:data:`CERTIFY_SIGMA` of a patch's standard deviation (decision 0003-spectral-quadrature).

A rule depends only on the setup's numbers (P, i, the shape of R, grid, the daylight reference),
the paper's water and this module's settings: it is cached by their content (never by object
identity), in-process and on disk (:func:`cache_dir`; the install step builds the default
camera's), so it cannot outlive the numbers it was built from. Building one takes about half a
second. It is built on the chart's shape -- each patch's reflectance divided by its largest
value (:func:`_chart_shape`) -- and applied to the chart with each patch's rows times that value:
the weights are linear in each patch's reflectance, so a per-patch factor changes no relative
error. A light field over the chart (:mod:`measure.lightfield`: a factor per patch, another at
every fit step and photo) therefore uses the camera's and chart's one rule: a rule per camera,
chart and light, never per depth, distance or photo (decision 0068-quadrature-per-chart-shape).

References
----------
Blasinski & Farrell, eqs 1, 14 and 15 (the discrete model). P. J. Davis & P. Rabinowitz, Methods
of Numerical Integration, 2nd ed., Academic Press (1984), sec. 2.5 (quadrature rules fitted to a
class of integrands).
"""

from __future__ import annotations

import dataclasses
import functools
import hashlib
import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from forward.files import atomic_open
from forward.water import PAPER_WATER, PATH_MODELS, resolve_water

__all__ = ["CACHE_ENV", "CERTIFIED_ERROR", "CERTIFY_SIGMA", "QUADRATURE_STEP_NM",
           "SNAPSHOT_DOMAIN", "SNAPSHOTS", "QuadratureRule", "cache_dir", "quadrature_nodes",
           "quadrature_rule", "reduction_error"]

#: Spacing of the quadrature's nodes, nm (every 5th point of the 1 nm grid). Measured on
#: validation snapshots of :data:`SNAPSHOT_DOMAIN` (decision 0003-spectral-quadrature): 10 nm
#: leaves 1e-2 relative
#: error, 6 nm 2.5e-4, 5 nm 5e-5, 3 nm 5e-6.
QUADRATURE_STEP_NM = 5.0
#: Snapshots of k per path model for the fit of the weights (and as many for validation).
SNAPSHOTS = 1200
#: Snapshots whose brightest value is below this (model units: a white reflector in air = 1)
#: are left out: a chart 10^4 times darker than in air is beyond a camera's range (and is
#: flagged ``dark`` long before).
DARKEST = 1e-4
#: The domain of the snapshots: log-uniform C (mg m^-3) and a_CDOM(440) (m^-1) with a tenth at
#: exactly 0, uniform depth and distance (m), and the budget's nuisances: the slopes of eqs 6-7
#: (nm^-1) uniform over the water's value +/- the half-width given, the scales of eqs 8 and 10
#: log-uniform over the factor given, the daylight's temperature uniform over +/- the mired
#: given (:class:`forward.daylight.DaylightTilt`).
SNAPSHOT_DOMAIN = {"chl": (1e-3, 100.0), "cdom": (1e-4, 5.0), "depth": (0.0, 30.0),
                   "distance": (0.0, 10.0), "cdom_slope": 0.01, "nap_slope": 0.01,
                   "phyto_scale": 4.0, "nap_scale": 4.0, "daylight": 120.0}
#: Relative weight floor: an output's error counts relative to its value plus this fraction of
#: the snapshot's brightest value (a black patch in a bright chart is not held to 1e-5 of
#: nothing).
WEIGHT_FLOOR = 1e-3
#: The largest relative error (of value + 1e-4 of the brightest value) a rule may show on its
#: validation snapshots (the test of the rule; 5 nm measures 5e-5).
CERTIFIED_ERROR = 2e-4
#: At an optimum the reduced prediction must agree with the full grid's within this many
#: standard deviations of every patch value (the sensor's, or the residual's RMS where that is
#: smaller: a noise-free chart is fitted exactly); else the fit is redone on the full grid.
CERTIFY_SIGMA = 0.05
#: Grids with at most this many points are not reduced (a 10 nm grid is already coarse).
MIN_REDUCED = 80


def quadrature_nodes(wavelengths, step_nm: float = QUADRATURE_STEP_NM) -> np.ndarray | None:
    """The indices of the quadrature's nodes in a grid: every k-th point (k = step / the grid's
    median spacing, rounded), the last point always; None where the grid is not worth reducing
    (at most :data:`MIN_REDUCED` points, or k < 2).

    Parameters
    ----------
    wavelengths : array_like, (q,)
        The model grid, nm (increasing).
    step_nm : float, optional
        The nodes' spacing, nm.

    Returns
    -------
    ndarray of int, (r,), or None
    """
    wl = np.asarray(wavelengths, float)
    if wl.size <= MIN_REDUCED:
        return None
    k = int(round(step_nm / float(np.median(np.diff(wl)))))
    if k < 2:
        return None
    idx = np.arange(0, wl.size, k)
    return idx if idx[-1] == wl.size - 1 else np.append(idx, wl.size - 1)


@dataclass(frozen=True, eq=False)
class QuadratureRule:
    """B k ~ B_r k[index] and D k ~ D_r k[index] on one setup's grid.

    Attributes
    ----------
    index : ndarray of int, (r,)
        The nodes (indices into the full grid).
    B : ndarray, (m n, r)
        The signals' weights (unit gain, model units).
    D : ndarray, (m n, r)
        The camera curves' shift's weights (per nm).
    white : ndarray, (r,)
        A white reflector in air's reference-channel signal (the normalisation of model
        units, :attr:`sca.ChartModel.white`).
    error : float
        Largest relative error of B_r on the validation snapshots.
    """

    index: np.ndarray
    B: np.ndarray
    D: np.ndarray
    white: np.ndarray
    error: float


def _snapshots(model, rng, count):
    """k (rows) on the full grid for ``count`` draws of each path model, the charts darker
    than :data:`DARKEST` left out."""
    rows = []
    lo_c, hi_c = SNAPSHOT_DOMAIN["chl"]
    lo_a, hi_a = SNAPSHOT_DOMAIN["cdom"]
    for pm in PATH_MODELS:
        water = resolve_water(PAPER_WATER, path_model=pm)
        terms = water.on_grid(model.wavelengths)
        chl = np.where(rng.random(count) < 0.1, 0.0,
                       10 ** rng.uniform(np.log10(lo_c), np.log10(hi_c), count))
        cdom = np.where(rng.random(count) < 0.1, 0.0,
                        10 ** rng.uniform(np.log10(lo_a), np.log10(hi_a), count))
        depth = rng.uniform(*SNAPSHOT_DOMAIN["depth"], count)
        distance = rng.uniform(*SNAPSHOT_DOMAIN["distance"], count)
        values = {}
        for name in ("cdom_slope", "nap_slope"):
            v = float(getattr(water, name))
            values[name] = np.maximum(v + rng.uniform(-1, 1, count) * SNAPSHOT_DOMAIN[name], 0.0)
        for name in ("phyto_scale", "nap_scale"):
            f = SNAPSHOT_DOMAIN[name]
            values[name] = float(getattr(water, name)) * f ** rng.uniform(-1, 1, count)
        tau, _ = terms.optical_depth(chl, cdom, depth, distance, values=values)
        shift = rng.uniform(-1, 1, count) * SNAPSHOT_DOMAIN["daylight"]
        rows.append(np.exp(-tau + model.daylight_tilt.log_ratio(shift)))
    K = np.concatenate(rows)
    return K[np.abs(K @ model.Bt).max(axis=1) >= DARKEST]


def _fit(K, Y, YD, index):
    """Weighted least squares of every output (rows of the result) on the nodes' values: the
    outputs ``Y`` (S, o) each relative to itself, ``YD`` (S, o) with ``Y``'s weights."""
    scale = np.maximum(np.abs(Y).max(axis=1, keepdims=True), 1e-300)
    X, Yn, YDn = K[:, index] / scale, Y / scale, YD / scale
    W2 = (1.0 / (np.abs(Yn) + WEIGHT_FLOOR)) ** 2  # (S, o)
    # one orthonormal basis of the nodes' values: every output's normal equations in it are
    # well conditioned (the nodes' values are strongly correlated)
    U, s, Vt = np.linalg.svd(X, full_matrices=False)
    A = np.matmul(U.T[None] * W2.T[:, None, :], U[None])  # (o, r, r)
    coef = [np.linalg.solve(A, np.einsum("so,si->oi", W2 * T, U)[..., None])[..., 0]
            for T in (Yn, YDn)]
    return [(c / s) @ Vt for c in coef]


def _chart_shape(setup):
    """The setup with each patch's reflectance divided by its largest value (rounded to float32:
    the same shape whatever the patch's scale) and those values (1 for a black patch): the
    chart a rule is built on and the per-patch factors it is applied with."""
    R = np.asarray(setup.reflectances, float)
    peak = np.abs(R).max(axis=0)
    peak = np.where(peak > 0, peak, 1.0)
    shape = (R / peak).astype(np.float32).astype(float)
    return dataclasses.replace(setup, reflectances=shape), peak


def _fingerprint(setup) -> str:
    """The setup's numbers (grid, P, i, the shape of R, the daylight reference) as one hash: the
    rule's cache key (a per-patch factor of R is not in it, :func:`_chart_shape`)."""
    h = hashlib.sha256(_settings_key().encode())
    for a in (setup.wavelengths, setup.sensitivities, setup.illuminant,
              _chart_shape(setup)[0].reflectances, setup.daylight_cct):
        h.update(np.ascontiguousarray(a, float).tobytes())
        h.update(str(np.shape(a)).encode())
    return h.hexdigest()


#: The environment variable naming the folder of the rules' disk cache (default
#: ``$XDG_CACHE_HOME/uw3p/quadrature``, else ``~/.cache/uw3p/quadrature``); empty: no disk cache.
CACHE_ENV = "UW3P_CACHE_DIR"


def cache_dir() -> Path | None:
    """The folder of the rules' disk cache (:data:`CACHE_ENV`), or None (no disk cache)."""
    given = os.environ.get(CACHE_ENV)
    if given is not None:
        return Path(given) / "quadrature" if given else None
    base = os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache"
    return Path(base) / "uw3p" / "quadrature"


@functools.lru_cache(maxsize=1)
def _settings_key() -> str:
    """What else a rule depends on: this module's source (its settings and method) and the
    paper's water (the snapshots' domain)."""
    h = hashlib.sha256(Path(__file__).read_bytes())
    h.update(PAPER_WATER._fingerprint().encode())
    return h.hexdigest()


def _load(path: Path) -> QuadratureRule | None:
    try:
        with np.load(path) as z:
            arrays = {k: z[k] for k in ("index", "B", "D", "white", "error")}
    except (OSError, ValueError, KeyError):
        return None
    for a in arrays.values():
        a.setflags(write=False)
    return QuadratureRule(arrays["index"], arrays["B"], arrays["D"], arrays["white"],
                          float(arrays["error"]))


#: The disk cache keeps the most recently used rules, at most this many (each ~80 kB).
CACHE_KEEP = 64


def _save(path: Path, rule: QuadratureRule) -> None:
    """Written whole or not at all, the least recently used rules beyond :data:`CACHE_KEEP`
    removed; an unwritable cache is no cache."""
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        with atomic_open(path, "wb") as fh:
            np.savez(fh, index=rule.index, B=rule.B, D=rule.D, white=rule.white,
                     error=rule.error)
        rules = sorted(path.parent.glob("*.npz"), key=lambda f: f.stat().st_mtime, reverse=True)
        for old in rules[CACHE_KEEP:]:
            old.unlink(missing_ok=True)
    except OSError:
        return


@functools.lru_cache(maxsize=16)
def _rule(key, setup_ref) -> QuadratureRule | None:
    folder = cache_dir()
    path = None if folder is None else folder / f"{key}.npz"
    if path is not None and path.is_file():
        rule = _load(path)
        if rule is not None:
            try:
                os.utime(path)  # recently used
            except OSError:
                pass
            return rule
    rule = _build(*setup_ref())
    if path is not None and rule is not None:
        _save(path, rule)
    return rule


def _build(setup, model_type) -> QuadratureRule | None:
    """The rule of ``setup``, fitted on snapshots of a ``model_type`` (:class:`sca.ChartModel`,
    passed in by the model that asks: this module sits below it) in the paper's water."""
    index = quadrature_nodes(setup.wavelengths)
    if index is None:
        return None
    model = model_type(setup, water=PAPER_WATER)  # the domain is the paper's water's
    rng = np.random.default_rng(20161)  # fixed: the same rule on every run and machine
    K = _snapshots(model, rng, SNAPSHOTS)
    # the patches' signals and the white's (its shift rows unused), one fit
    Y = np.column_stack([K @ model.Bt, K @ model.white])
    YD = np.column_stack([K @ model.Dt, K @ model.white])
    BW, DW = _fit(K, Y, YD, index)
    B_r, D_r, white = BW[:-1], DW[:-1], BW[-1]
    Kv = _snapshots(model, rng, SNAPSHOTS)
    Yv = Kv @ model.Bt
    err = np.abs(Kv[:, index] @ B_r.T - Yv) / (
        np.abs(Yv) + 1e-4 * np.abs(Yv).max(axis=1, keepdims=True))
    for a in (B_r, D_r, white, index):
        a.setflags(write=False)
    return QuadratureRule(index, B_r, D_r, white, float(err.max()))


class _Ref:
    """A strong reference passed through the cache without being part of its key."""

    def __init__(self, obj):
        self.obj = obj

    def __call__(self):
        return self.obj

    def __hash__(self):
        return 0

    def __eq__(self, other):
        return isinstance(other, _Ref)


def quadrature_rule(model) -> QuadratureRule | None:
    """The quadrature rule of a chart model's setup (cached by the setup's content).

    Parameters
    ----------
    model : sca.ChartModel
        A model on its full grid.

    Returns
    -------
    QuadratureRule or None
        None where the grid is not reduced (:func:`quadrature_nodes`).
    """
    if quadrature_nodes(model.wavelengths) is None:
        return None
    chart, scale = _chart_shape(model.setup)
    return _scaled(_rule(_fingerprint(chart), _Ref((chart, type(model)))), tuple(scale))


@functools.lru_cache(maxsize=64)
def _scaled(rule, scale) -> QuadratureRule:
    """The rule of a chart's shape applied to the chart: patch j's rows (signals and shift)
    times its factor ``scale[j]`` (the weights are linear in each patch's reflectance)."""
    rows = np.tile(np.asarray(scale, float), rule.B.shape[0] // len(scale))[:, None]
    B, D = rule.B * rows, rule.D * rows
    for a in (B, D):
        a.setflags(write=False)
    return QuadratureRule(rule.index, B, D, rule.white, rule.error)


def reduction_error(full, reduced, params, sigma) -> np.ndarray:
    """How far a reduced model's prediction is from the full grid's, in standard deviations.

    Parameters
    ----------
    full, reduced : sca.ChartModel
        The model on its full grid and :meth:`sca.ChartModel.reduced`.
    params : dict
        The parameters (leading shape S), as :meth:`sca.ChartModel.predict`.
    sigma : array_like, broadcastable to S + (m n,)
        The values' standard deviations (data units of the models).

    Returns
    -------
    ndarray, S
        max over the values of |reduced - full| / sigma.
    """
    a = full.predict(params, jacobian=False).values
    b = reduced.predict(params, jacobian=False).values
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = np.abs(b - a) / np.asarray(sigma, float)
    return np.nanmax(np.where(np.isfinite(ratio), ratio, np.inf), axis=-1)
