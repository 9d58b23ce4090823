"""The acceptance experiment of "never a confident wrong answer": ``HONESTY.md``.

``python -m experiments.honesty [--quick] [--n N] [--seed S]`` renders sets of ColorChecker
photographs with the independent renderer (:mod:`experiments.independent_world`, which shares
no code with ``forward``), fits each set with :func:`sca.estimate_batch` (``gain='free'``: the
unknown exposure of a photograph) once with the default uncertainty budget
(:data:`sca.budget.DEFAULT_UNCERTAIN`, or the world's own budget) and, for the worlds the
estimator should handle, once with the paper's exact model (``uncertain={}``), and reports per
world and budget:

* n, the fraction ``reliable``;
* the coverage of the 95 % intervals among the reliable charts, for C, for a_CDOM(440) and
  jointly; "confident wrong" = reliable charts with the truth outside either interval (two 95 %
  intervals: nominally at most about 10 % of the reliable ones);
* the median relative half-width of the C interval, (hi - lo) / 2 / C_true, among reliable
  charts (the price of honesty);
* the median share of the largest source of the variance of C (and the most common one).

Every world draws the same chart conditions (a paired design): C log-uniform 0.05-10 mg m^-3,
a_CDOM log-uniform 0.01-1 m^-1, depth uniform 1-15 m, distance uniform 0.5-3 m, exposure
uniform 0.2-0.9, photon and read noise on. The worlds (:func:`worlds`):

1. ``clean``: realistic tolerances (PCHIP on a 0.5 nm grid, per-patch reflectance sd 0.5 %,
   camera curves shifted with sd 0.5 nm, channel gains sd 0.5 %, single-scattering veil);
2. ``priors``: the default budget's own priors (told depth and distance off by N(0, 0.2 m) and
   N(0, 5 %), slopes drawn N(0.014, 0.0025) and N(0.011, 0.0025) nm^-1, gains sd 1 %,
   reflectance sd 1 %);
3. the ends of the paper's ranges: S_NAP 0.006 and 0.014, S_CDOM 0.019, a yellowed chart, a
   1 % channel-balance error;
4. geometry told wrong within its stated sd: depth +0.3 m (budget depth sd 0.3 m), distance
   x 1.10 (budget distance sd 10 %);
5. garbage that must never be reliable: a sampling grid shifted half a patch, another camera,
   another illuminant, four occluded patches;

and, without a criterion, a diagnostic twin of each world 1-4 without its camera-curve shifts
(``<name>/no-shift``, default budget only), which separates the effect of those shifts from
the world's own.

Acceptance (:func:`acceptance`) tests the number of misses among the reliable charts against
the nominal rate with a binomial test at level :data:`CONSISTENCY_P`, one-sided or two-sided by
the world: :func:`test_of` is the one place that says which (:data:`TWO_SIDED_GROUPS`), and
every table, sentence and criterion reads it from there.

What the photos measure is named :data:`C_NAME`: tau / (depth + distance), the attenuation
coefficient of the light's path, not the beam attenuation a + b (REALWATER.md: the paper's c
behaves as mu_d K_d).

The reference-shot worlds (criterion 7). Issue 47, item 6. Each chart of a world (clear and coastal water,
:data:`experiments.honesty.C_WATERS`; depths 1-15 m, distances 0.5-3 m, the exposure unknown;
the other nuisances of the default budget drawn from their priors as in the ``priors`` world):

1. the surface daylight is drawn from the default budget's 30-mired prior;
2. the reference shot: the same chart and camera (its drawn channel gains, curve shifts and
   per-patch reflectances) photographed in air under that light by the independent renderer
   (:func:`experiments.independent_world.render_calibration`, with its noise), and the light
   fitted by :func:`sca.reference.measure_light`;
3. the sky changes between the shot and the dive: ``reference`` by a draw within the stated sd
   (:func:`sca.reference.sky_sd` at :data:`sca.reference.REFERENCE_MINUTES`), ``sky-beyond`` by
   :data:`BEYOND_SD` times the stated sd (sqrt(sd_fit^2 + sd_sky^2)), either sign;
4. the chart underwater rendered under the changed light and fitted with
   ``uncertain=with_reference(None, lights)`` (one batch, each chart its own measured prior) and, on
   the very same photos, with the default budget (``reference`` only).

:func:`run_reference` renders and fits; :func:`reference_text` is HONESTY.md's section.
Each world's coverage test is :func:`experiments.honesty.test_of` of its name (``reference``:
two-sided, inside its stated budget; ``sky-beyond``: one-sided, outside it); for
``sky-beyond`` honest means each chart flagged (not reliable) or covered, and the report says
how many are neither.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import sys
import time
from collections import Counter
from pathlib import Path
from types import SimpleNamespace

import numpy as np
from scipy import stats

from forward.files import write_atomic
import sca
from sca.budget import DEFAULT_UNCERTAIN
from sca.reference import REFERENCE_MINUTES, measure_light, sky_sd, with_reference

from . import independent_world as iw

__all__ = [
    "BEYOND_SD",
    "DTAU_BANDS",
    "DTAU_TARGET",
    "ILLUMINANT_SHOTS",
    "REFERENCE_LABELS",
    "dtau_half_widths",
    "illuminant_check",
    "reference_text",
    "run_reference",
    "CDOM_RANGE",
    "C_BANDS",
    "C_CHARTS_FULL",
    "C_CHARTS_QUICK",
    "C_DEPTH_BANDS",
    "C_MAX_HALF_WIDTH",
    "C_WATERS",
    "C_WATER_SPREAD",
    "C_WORLDS",
    "CHARTS_FULL",
    "CHARTS_QUICK",
    "CHL_RANGE",
    "CLEAN_OPTIONS",
    "CONSISTENCY_P",
    "AT_BOUND_LABEL",
    "AT_BOUND_WORLDS",
    "DEFAULT_LABEL",
    "DEPTH_RANGE",
    "DISTANCE_RANGE",
    "EXACT",
    "EXACT_LABEL",
    "EXPOSURE_RANGE",
    "HONEST_GROUPS",
    "MIN_RELIABLE_CLEAN",
    "NOMINAL_JOINT",
    "miss_p",
    "NOMINAL_SINGLE",
    "NOTHING_FACTOR",
    "PIXELS_PER_PATCH",
    "QUANTITIES",
    "TESTED",
    "JOINT_QUANTITIES",
    "TWO_SIDED_GROUPS",
    "SEED",
    "WRONG_CAMERA",
    "WRONG_ILLUMINANT",
    "World",
    "acceptance",
    "coverage_p",
    "draw_conditions",
    "fit_set",
    "true_quantities",
    "main",
    "render_set",
    "report",
    "run",
    "run_attenuation",
    "summarise",
    "worlds",
    "write_outputs",
]

ROOT = Path(__file__).resolve().parents[1]
#: Charts per world in the full run and with ``--quick``.
CHARTS_FULL = 200
CHARTS_QUICK = 30
#: Seed of the conditions and of every render.
SEED = 20240611
#: C range (log-uniform), mg m^-3.
CHL_RANGE = (0.05, 10.0)
#: a_CDOM(440) range (log-uniform), m^-1.
CDOM_RANGE = (0.01, 1.0)
#: Depth range (uniform), m.
DEPTH_RANGE = (1.0, 15.0)
#: Camera-to-chart distance range (uniform), m.
DISTANCE_RANGE = (0.5, 3.0)
#: Unknown exposure range (uniform).
EXPOSURE_RANGE = (0.2, 0.9)
#: Pixels averaged per patch (the renderer's default; a render takes ~30 ms).
PIXELS_PER_PATCH = 1000
#: The clean world's realistic tolerances (:class:`experiments.independent_world.WorldOptions`).
CLEAN_OPTIONS = {"step_nm": 0.5, "interpolation": "pchip", "reflectance_sd": 0.005,
                 "camera_shift_nm_sd": 0.5, "camera_gain_sd": 0.005,
                 "backscatter": "single_scatter", "noise": True,
                 "pixels_per_patch": PIXELS_PER_PATCH}
#: The camera of the wrong-camera world (the only other one in colour-science 0.4's
#: ``MSDS_CAMERA_SENSITIVITIES``); the estimator assumes 'Nikon 5100 (NPL)'.
WRONG_CAMERA = "Sigma SDMerill (NPL)"
#: The illuminant of the wrong-illuminant world (the estimator assumes D65).
WRONG_ILLUMINANT = "A"
#: Nominal coverage of one 95 % interval.
NOMINAL_SINGLE = 0.95
#: Nominal joint coverage of two 95 % intervals (Bonferroni: at least 90 %).
NOMINAL_JOINT = 0.90
#: Binomial p-value below which the coverage differs from the nominal rate (one-sided: too
#: many misses; two-sided: too many or too few).
CONSISTENCY_P = 0.01
#: Every reported quantity (the key of ``BatchEstimate.quantities`` or 'chl', 'cdom') and its
#: label: C, a_CDOM(440), the path's attenuation coefficient at the standard bands, the
#: non-water absorption at 440 nm and the optical depth of the path at the standard bands
#: (:mod:`sca.derived`; K_d(490) is not published: decision 0067-kd-not-published).
QUANTITIES = (("chl", "C"), ("cdom", "a_CDOM"), ("c_443", "c(443)"), ("c_490", "c(490)"),
              ("c_555", "c(555)"), ("c_670", "c(670)"), ("a_nw_440", "a_nw(440)"),
              ("tau_443", "tau(443)"), ("tau_490", "tau(490)"), ("tau_555", "tau(555)"),
              ("tau_670", "tau(670)"))
#: The quantities of a dive's joint fit: every one but the optical depth, which belongs to
#: each photo's own path (each photo's tau is its own fit's, the single chart's: tested here).
JOINT_QUANTITIES = tuple((k, label) for k, label in QUANTITIES if not k.startswith("tau_"))
#: The quantities whose coverage the acceptance tests: every one a user is shown.
TESTED = tuple(k for k, _ in QUANTITIES)
#: What the photos measure, as every sentence of the report names it: tau / path length, the
#: attenuation coefficient of the light's path; REALWATER.md finds the paper's c ~ mu_d K_d
#: (the diffuse attenuation times the mean cosine), not the beam attenuation a + b.
C_NAME = ("the attenuation coefficient of the light's path, tau_true / (true depth + true "
          "distance); not the beam attenuation a + b: on real water the paper's c behaves as "
          "mu_d K_d (REALWATER.md)")
#: Groups whose worlds are drawn from the budget's own priors: their coverage is tested on
#: both sides (too few misses is a failure too: the intervals are wider than the budget
#: says). Every other world is inside the budget but less perturbed (clean), deliberately at
#: or beyond its edges (ends, geometry) or outside it: too few misses is expected there and
#: only too many fail (one-sided). The reference-shot world (the budget's priors with the light
#: measured) is two-sided too. Read it with :func:`test_of`.
TWO_SIDED_GROUPS = ("priors", "reference")


def test_of(group: str) -> str:
    """The coverage test of a world's group: the one place a world's sidedness is defined
    (every table, sentence and criterion reads it from here or from :attr:`World.test`).

    Parameters
    ----------
    group : str
        The world's group (:class:`World`), 'reference' or 'sky-beyond' for the reference-shot
        worlds (the reference-shot worlds).

    Returns
    -------
    str
        'two-sided' for :data:`TWO_SIDED_GROUPS`, else 'one-sided'.
    """
    return "two-sided" if group in TWO_SIDED_GROUPS else "one-sided"


def world_test(name: str) -> str:
    """The coverage test of the world called ``name`` (:func:`worlds`)."""
    return {w.name: w.test for w in worlds()}[name]
#: The attenuation coefficient's criterion (issue 37): these bands, covered at the nominal rate
#: (each world's test, :func:`world_test`) in the clean and the budget-prior worlds, with a median relative half-width at
#: most C_MAX_HALF_WIDTH over clear and coastal water at depths 1-15 m.
C_BANDS = ("c_443", "c_490", "c_555")
C_MAX_HALF_WIDTH = 0.10
#: Worlds of the criterion, its water types (INSTRUMENT.md's: C mg m^-3, a_CDOM(440) m^-1;
#: each chart's C and a_CDOM log-uniform within a factor sqrt(10) of them) and depth bands (m).
C_WORLDS = ("clean", "priors")
C_WATERS = {"clear": (0.1, 0.01), "coastal": (1.0, 0.1)}
C_WATER_SPREAD = np.sqrt(10.0)
C_DEPTH_BANDS = ((1.0, 5.0), (5.0, 10.0), (10.0, 15.0))
#: Charts per world and water type in the criterion's run (full, --quick).
C_CHARTS_FULL, C_CHARTS_QUICK = 200, 30
#: Charts per water type (the first of the clean world's) refitted with each nuisance of the
#: budget left out, to show what sets c's width (the ablation).
C_ABLATION_CHARTS = 60
#: The clean world's acceptance: at least this fraction reliable with the default budget.
MIN_RELIABLE_CLEAN = 0.90
#: The paper's exact model (photon noise only).
EXACT: dict = {}
#: The groups fitted with the exact model too, and given diagnostic twins without the
#: camera-curve shifts (worlds 1-4).
HONEST_GROUPS = ("clean", "priors", "ends", "geometry")
#: Budget labels in the outputs.
DEFAULT_LABEL, EXACT_LABEL = "default", "exact"
#: The default budget's fit restricted to the charts whose C sits at its lower bound 0 (issue
#: 46: the intervals at a parameter's bound), in the worlds :data:`AT_BOUND_WORLDS`.
AT_BOUND_LABEL = "default, C at 0"
AT_BOUND_WORLDS = ("clean", "priors")


@dataclasses.dataclass(frozen=True)
class World:
    """One world: how its charts are rendered, what the estimator is told, and its budget.

    Parameters
    ----------
    name : str
        Short name (the row of the table).
    group : str
        'clean', 'priors', 'ends', 'geometry' or 'garbage' (the acceptance criterion),
        'limitation' (a stated limit of the model, no criterion), or
        'diagnostic' (no criterion: an ablation that locates a failure).
    description : str
        One line for the report.
    options : dict
        Renderer options on top of :data:`CLEAN_OPTIONS`.
    uncertain : dict or None
        The budget of the honest fit (None: the default budget).
    draw_slopes : bool
        Draw S_CDOM and S_NAP per chart from the default budget's priors.
    draw_daylight : bool
        Draw the surface daylight's colour temperature per chart from the default budget's
        prior (D65 moved by N(0, sd) mired).
    geometry_errors : bool
        Tell depth and distance with N(0, sd) errors of the default budget.
    depth_bias : float
        Added to the told depth, m.
    distance_factor : float
        Multiplies the told distance.
    occlude : int
        Random patches hidden by a hand per chart.
    """

    name: str
    group: str
    description: str
    options: dict = dataclasses.field(default_factory=dict)
    uncertain: dict | None = None
    draw_slopes: bool = False
    draw_daylight: bool = False
    geometry_errors: bool = False
    depth_bias: float = 0.0
    distance_factor: float = 1.0
    occlude: int = 0

    @property
    def garbage(self) -> bool:
        """True for a world whose charts must never be reliable."""
        return self.group == "garbage"

    @property
    def test(self) -> str:
        """'two-sided' for a world drawn from the budget's priors (:data:`TWO_SIDED_GROUPS`),
        else 'one-sided' (only too many misses fail)."""
        return test_of(self.group)


def worlds() -> list[World]:
    """The worlds of the experiment, in report order.

    Returns
    -------
    list of World
    """
    gains = (1.01, 1.0, 0.99)
    main = [
        World("clean", "clean", "realistic tolerances, single-scattering veil"),
        World("priors", "priors", "every term of the default budget drawn from its prior: told "
              "depth and distance, both slopes, the daylight's colour temperature, the channel "
              "gains (sd 1 %), the camera curves' shifts (sd 1 nm) and the per-patch "
              "reflectances (sd 1 %)", {"camera_gain_sd": DEFAULT_UNCERTAIN["balance"],
                                        "camera_shift_nm_sd": DEFAULT_UNCERTAIN["camera_shift"],
                                        "reflectance_sd": DEFAULT_UNCERTAIN["patch"]},
              draw_slopes=True, draw_daylight=True, geometry_errors=True),
        World("nap_slope_0.006", "ends", "S_NAP = 0.006 nm^-1", {"nap_slope": 0.006}),
        World("nap_slope_0.014", "ends", "S_NAP = 0.014 nm^-1", {"nap_slope": 0.014}),
        World("cdom_slope_0.019", "ends", "S_CDOM = 0.019 nm^-1", {"cdom_slope": 0.019}),
        World("yellowing_0.03", "ends", "aged chart, yellowing 0.03", {"yellowing": 0.03}),
        World("balance_1%", "ends", f"channel gains {gains}", {"camera_gains": gains}),
        World("path_split", "ends", "daylight attenuated by K_d on its way down (the "
              "renderer's own split path, b_bp/b_p 0.0183)", {"path": "split"}),
        World("depth_told_+0.3m", "geometry", "depth told +0.3 m; budget depth sd 0.3 m",
              uncertain={**DEFAULT_UNCERTAIN, "depth": 0.3}, depth_bias=0.3),
        World("distance_told_x1.10", "geometry", "distance told x 1.10; budget distance sd 10 %",
              uncertain={**DEFAULT_UNCERTAIN, "distance": "10%"}, distance_factor=1.10),
        World("corner_shift_0.5", "garbage", "sampling grid shifted half a patch",
              {"corner_shift": 0.5}),
        World("wrong_camera", "garbage", f"rendered with {WRONG_CAMERA}, fitted as Nikon 5100",
              {"camera": WRONG_CAMERA}),
        World("wrong_illuminant", "limitation", f"rendered under {WRONG_ILLUMINANT}, fitted as "
              "D65 (the light at the surface is an input, not a measurement)",
              {"illuminant": WRONG_ILLUMINANT}),
        World("occluded_4", "garbage", "4 random patches occluded by a hand", occlude=4),
    ]
    return main + [_without_shift(w) for w in main if w.group in HONEST_GROUPS]


def _without_shift(world: World) -> World:
    """The diagnostic twin of ``world`` without the camera-curve shifts."""
    return dataclasses.replace(
        world, name=f"{world.name}/no-shift", group="diagnostic",
        description=f"{world.description}; without camera-curve shifts",
        options={**world.options, "camera_shift_nm_sd": 0.0})


def _log_uniform(rng, lo_hi, n):
    return np.exp(rng.uniform(np.log(lo_hi[0]), np.log(lo_hi[1]), n))


def draw_conditions(rng: np.random.Generator, n: int) -> dict:
    """The conditions of ``n`` charts (shared by every world: a paired design).

    Parameters
    ----------
    rng : numpy.random.Generator
    n : int

    Returns
    -------
    dict
        (n,) arrays 'chl', 'cdom', 'depth', 'distance', 'exposure', 'cdom_slope' and
        'nap_slope' (drawn from the default budget's priors), 'depth_error' (m) and
        'distance_error' (relative) (drawn with the default budget's sds), 'daylight_mired'
        (the surface daylight's change from D65, mired, drawn with the budget's sd and kept
        inside the daylight series' 4000-25 000 K).
    """
    return {
        "chl": _log_uniform(rng, CHL_RANGE, n),
        "cdom": _log_uniform(rng, CDOM_RANGE, n),
        "depth": rng.uniform(*DEPTH_RANGE, n),
        "distance": rng.uniform(*DISTANCE_RANGE, n),
        "exposure": rng.uniform(*EXPOSURE_RANGE, n),
        "cdom_slope": rng.normal(iw.CDOM_SLOPE_PER_NM, DEFAULT_UNCERTAIN["cdom_slope"], n),
        "nap_slope": rng.normal(iw.NAP_SLOPE_PER_NM, DEFAULT_UNCERTAIN["nap_slope"], n),
        "depth_error": rng.normal(0.0, DEFAULT_UNCERTAIN["depth"], n),
        "distance_error": rng.normal(0.0, _percent(DEFAULT_UNCERTAIN["distance"]), n),
        "daylight_mired": _daylight_draws(rng, n),
    }


def _daylight_draws(rng, n):
    """N(0, the budget's daylight sd) mired changes from D65, redrawn where the temperature
    would leave the daylight series (4000-25 000 K: about 4 sd away on the warm side)."""
    sd = float(DEFAULT_UNCERTAIN["daylight"])
    lo, hi = 1e6 / 25000.0 - 1e6 / iw.D65_CCT, 1e6 / 4000.0 - 1e6 / iw.D65_CCT
    out = rng.normal(0.0, sd, n)
    bad = (out <= lo) | (out >= hi)
    while bad.any():
        out[bad] = rng.normal(0.0, sd, int(bad.sum()))
        bad = (out <= lo) | (out >= hi)
    return out


def _percent(text: str) -> float:
    return float(text.rstrip("%")) / 100.0


def _chart_options(world: World, cond: dict, i: int, rng) -> dict:
    """The renderer options of chart ``i`` of ``world``."""
    opts = {**CLEAN_OPTIONS, **world.options, "exposure": float(cond["exposure"][i])}
    if world.draw_slopes:
        opts.update(cdom_slope=float(cond["cdom_slope"][i]), nap_slope=float(cond["nap_slope"][i]))
    if world.draw_daylight:
        opts.update(daylight_mired=float(cond["daylight_mired"][i]))
    if world.occlude:
        opts["occluded"] = tuple(int(j) for j in rng.choice(24, world.occlude, replace=False))
    return opts


def render_set(world: World, cond: dict, rng: np.random.Generator, keep=()) -> dict:
    """Render every chart of ``cond`` in ``world``.

    Parameters
    ----------
    world : World
    cond : dict
        From :func:`draw_conditions`.
    rng : numpy.random.Generator
        The world's stream (one child per chart).
    keep : sequence of str, optional
        Keys of the renderer's per-chart ``truth`` (its draws, e.g. 'camera_gains') to return.

    Returns
    -------
    dict
        'rgb' and 'sigma' (N, 3, 24), the told 'depth' and 'distance' (N,), 'saturated' (N,),
        'truth' (the world's value of every quantity of :func:`reported_quantities`, (N,) each:
        :func:`true_quantities`), 'drawn' (per chart: the ``keep`` entries of its truth) and
        'render_s' (wall-clock seconds).
    """
    t0 = time.perf_counter()
    n = cond["chl"].size
    streams = rng.spawn(n)
    rgb, sigma, saturated, truth, drawn = [], [], [], [], []
    for i in range(n):
        opts = _chart_options(world, cond, i, streams[i])
        out = iw.render_chart(cond["chl"][i], cond["cdom"][i], cond["depth"][i],
                              cond["distance"][i], rng=streams[i], **opts)
        rgb.append(out["rgb"])
        sigma.append(out["sigma"])
        saturated.append(out["saturated"])
        truth.append(true_quantities(out, opts.get("path", "paper")))
        drawn.append({k: out["truth"][k] for k in keep})
    depth, distance = cond["depth"] + world.depth_bias, cond["distance"] * world.distance_factor
    if world.geometry_errors:
        depth = depth + cond["depth_error"]
        distance = distance * (1.0 + cond["distance_error"])
    return {"rgb": np.array(rgb), "sigma": np.array(sigma), "depth": depth, "distance": distance,
            "saturated": np.array(saturated),
            "truth": {k: np.array([t[k] for t in truth]) for k in truth[0]}, "drawn": drawn,
            "render_s": time.perf_counter() - t0}


def true_quantities(rendered: dict, path: str = "paper") -> dict:
    """The world's value of every reported quantity for one chart of the independent renderer.

    Parameters
    ----------
    rendered : dict
        :func:`experiments.independent_world.render_chart`'s result (its ``truth`` and
        ``optics``).
    path : {'paper', 'split'}, optional
        The renderer's path option.

    Returns
    -------
    dict
        'chl', 'cdom'; 'c_443' ... 'c_670': the path's attenuation coefficient tau_true /
        (depth + distance) at the band (:func:`experiments.independent_world.path_coefficient`;
        :data:`C_NAME`), m^-1; 'tau_443' ... where
        :func:`sca.derived.quantity_names` has them: the optical depth tau_true at the band;
        'a_nw_440': a - a_w at 440 nm; (K_d(490) is not published: decision
        0067-kd-not-published.)
    """
    t, o = rendered["truth"], rendered["optics"]
    wl = rendered["wavelengths"]
    coef = iw.path_coefficient(o, t["depth"], t["distance"], path)
    out = {"chl": float(t["chl"]), "cdom": float(t["cdom"]),
           "a_nw_440": float(np.interp(440.0, wl, o["a"] - o["a_w"]))}
    length = float(t["depth"]) + float(t["distance"])
    for key, _ in reported_quantities():
        band, scale = ((key[2:], 1.0) if key.startswith("c_") else
                       (key[4:], length) if key.startswith("tau_") else (None, 0.0))
        if band is not None:
            out[key] = scale * float(np.interp(float(band), wl, coef))
    return out


def reported_quantities() -> tuple:
    """(key, label) of every quantity a user is shown: :data:`QUANTITIES` and any other of
    :func:`sca.derived.quantity_names` (e.g. the optical depth 'tau_443', labelled by its
    key), read from the package so that a new quantity is scored where its truth is known."""
    known = {k for k, _ in QUANTITIES}
    return QUANTITIES + tuple((k, k) for k in sca.derived.quantity_names() if k not in known)


def fit_set(rendered: dict, uncertain):
    """Fit a rendered set with the free exposure gain and the budget ``uncertain``.

    Parameters
    ----------
    rendered : dict
        From :func:`render_set`.
    uncertain : dict or None
        The budget (None: :data:`sca.budget.DEFAULT_UNCERTAIN`; ``{}``: the exact model).

    Returns
    -------
    sca.batch.BatchEstimate
    """
    # a patch mean below the black level is read noise around 0: taken as 0, as measure does
    return sca.estimate_batch(np.maximum(rendered["rgb"], 0.0), depth=rendered["depth"],
                              distance=rendered["distance"], sigma=rendered["sigma"],
                              gain="free", uncertain=uncertain)


def _inside(ci, truth):
    """Truth inside a (N, 2) interval (NaN ends: outside)."""
    with np.errstate(invalid="ignore"):
        return (ci[:, 0] <= truth) & (truth <= ci[:, 1])


def _median(x):
    x = np.asarray(x, float)
    x = x[np.isfinite(x)]
    return float(np.median(x)) if x.size else None


def _largest_share(est, keep):
    """Median largest share of the variance of C among ``keep`` and the commonest source."""
    shares = (est.budget or {}).get("chl", {}).get("shares", {})
    if not shares or not keep.any():
        return None, None
    names = list(shares)
    S = np.column_stack([np.asarray(shares[k], float) for k in names])[keep]
    ok = np.all(np.isfinite(S), axis=1)
    if not ok.any():
        return None, None
    top = Counter(names[j] for j in np.argmax(S[ok], axis=1)).most_common(1)[0][0]
    return float(np.median(S[ok].max(axis=1))), top


def miss_p(misses, n, nominal):
    """One-sided binomial p-value of >= ``misses`` misses in ``n`` at the rate 1 - nominal."""
    return float(stats.binom.sf(misses - 1, n, 1.0 - nominal)) if n else None


def coverage_p(covered, n, nominal, test="one-sided"):
    """The binomial test of ``covered`` of ``n`` intervals holding the truth at the rate
    ``nominal``.

    Parameters
    ----------
    covered, n : int
    nominal : float
    test : {'one-sided', 'two-sided'}, optional
        'one-sided': P(at least this many misses) (:func:`miss_p`); 'two-sided': scipy's exact
        two-sided test (too many or too few misses).

    Returns
    -------
    float or None
        None when ``n`` is 0.
    """
    if not n:
        return None
    if test == "one-sided":
        return miss_p(n - covered, n, nominal)
    if test != "two-sided":
        raise ValueError(f"test: 'one-sided' or 'two-sided', got {test!r}")
    return float(stats.binomtest(int(covered), int(n), nominal).pvalue)


def _clopper_pearson(k, n, level=0.95):
    """Exact binomial interval of a proportion k / n."""
    if n == 0:
        return None
    a = (1.0 - level) / 2.0
    lo = stats.beta.ppf(a, k, n - k + 1) if k > 0 else 0.0
    hi = stats.beta.ppf(1 - a, k + 1, n - k) if k < n else 1.0
    return [float(lo), float(hi)]


def _estimates(est, truth) -> dict:
    """name -> (value (N,), interval (N, 2), truth (N,)) of every quantity ``est`` and
    ``truth`` both have."""
    q = getattr(est, "quantities", None) or {}
    qi = getattr(est, "quantity_intervals", None) or {}
    out = {"chl": (est.chl_ci, truth["chl"]), "cdom": (est.cdom_ci, truth["cdom"])}
    out.update({k: (np.asarray(qi[k], float), truth[k]) for k, _ in reported_quantities()
                if k in qi and k in q and k in truth})
    return out


def _coverage(covered, n_rel, nominal, test):
    return {"covered": covered, "fraction": covered / n_rel if n_rel else None,
            "misses": n_rel - covered, "nominal": nominal,
            "p_excess_misses": miss_p(n_rel - covered, n_rel, nominal),
            "p_two_sided": coverage_p(covered, n_rel, nominal, "two-sided"),
            "p": coverage_p(covered, n_rel, nominal, test), "ci95": _clopper_pearson(covered, n_rel)}


def summarise(est, cond: dict, path=None, truth=None, test: str = "one-sided") -> dict:
    """The numbers of one world and budget.

    Parameters
    ----------
    est : sca.batch.BatchEstimate
    cond : dict
        The true conditions (:func:`draw_conditions`).
    path : (N,) array, optional
        The told path depth + distance, m (for the a_CDOM optical-depth error).
    truth : dict, optional
        The world's value of every quantity (:func:`render_set`'s 'truth'); default C and
        a_CDOM from ``cond`` only.
    test : {'one-sided', 'two-sided'}, optional
        The world's coverage test (:attr:`World.test`): its p-value is each coverage's 'p'.

    Returns
    -------
    dict
        n, reliable (count, fraction), 'coverage' of every quantity (and 'joint': C and a_CDOM
        both) among the reliable charts with misses, one-sided ('p_excess_misses'),
        two-sided ('p_two_sided') and the world's ('p') binomial p-values, 'test',
        confident_wrong, 'median_rel_halfwidth' (quantity -> median (hi - lo) / 2 / truth
        among the reliable) and its C entry 'median_rel_halfwidth_chl', median largest C-budget
        share and source, the median error of the a_CDOM optical depth (a_CDOM - a_CDOM_true)
        x path among reliable charts (with ``path``), flag counts, non-converged and
        NaN-interval counts.
    """
    truth = {"chl": cond["chl"], "cdom": cond["cdom"]} if truth is None else truth
    rel = np.asarray(est.reliable, bool)
    n_rel = int(rel.sum())
    found = _estimates(est, truth)
    inside = {k: _inside(ci, t) for k, (ci, t) in found.items()}
    both = inside["chl"] & inside["cdom"]
    coverage = {k: _coverage(int((v & rel).sum()), n_rel, NOMINAL_SINGLE, test)
                for k, v in inside.items()}
    # two 95 % intervals: at least 90 % jointly (Bonferroni), not exactly: one-sided always
    coverage["joint"] = _coverage(int((both & rel).sum()), n_rel, NOMINAL_JOINT, "one-sided")
    with np.errstate(invalid="ignore", divide="ignore"):
        widths = {k: _median(((ci[:, 1] - ci[:, 0]) / 2.0 / t)[rel]) for k, (ci, t) in
                  found.items()}
    share, source = _largest_share(est, rel)
    nan_ci = ~np.all(np.isfinite(est.chl_ci) | np.isinf(est.chl_ci), axis=1) | \
        ~np.all(np.isfinite(est.cdom_ci) | np.isinf(est.cdom_ci), axis=1)
    return {"n": int(rel.size), "reliable": n_rel, "reliable_fraction": n_rel / rel.size,
            "reliable_ci95": _clopper_pearson(n_rel, int(rel.size)), "coverage": coverage,
            "test": test, "confident_wrong": n_rel - coverage["joint"]["covered"],
            "median_rel_halfwidth": widths,
            "median_rel_halfwidth_chl": widths["chl"],
            "median_largest_share_chl": share, "commonest_largest_source_chl": source,
            "median_cdom_path_error": None if path is None else _median(
                ((est.cdom - cond["cdom"]) * np.asarray(path, float))[rel]),
            "not_converged": int((~np.asarray(est.converged, bool)).sum()),
            "nan_intervals": int(nan_ci.sum()),
            "flags": dict(Counter(f for t in est.flags for f in t).most_common()),
            "fit_s": float(est.elapsed_s)}


def _charts(est, cond, rendered) -> dict:
    """The per-chart raw numbers of one fit (for the JSON)."""
    def r(a):
        return np.round(np.asarray(a, float), 6).tolist()
    return {"chl_true": r(cond["chl"]), "cdom_true": r(cond["cdom"]),
            "depth_told": r(rendered["depth"]), "distance_told": r(rendered["distance"]),
            "chl": r(est.chl), "cdom": r(est.cdom), "chl_ci": r(est.chl_ci),
            "cdom_ci": r(est.cdom_ci), "reliable": np.asarray(est.reliable, bool).tolist(),
            "truth": {k: r(v) for k, v in rendered["truth"].items()},
            "quantities": {k: r(v) for k, v in (getattr(est, "quantities", None) or {}).items()},
            "quantity_intervals": {k: r(v) for k, v in
                                   (getattr(est, "quantity_intervals", None) or {}).items()},
            "chi2_dof": r(est.chi2_dof), "flags": [list(t) for t in est.flags]}


def _budgets(world: World) -> list[tuple[str, object]]:
    """(label, uncertain) of the fits of ``world``: its budget, and the exact model (worlds
    1-4 only)."""
    out = [(DEFAULT_LABEL, world.uncertain)]
    return [*out, (EXACT_LABEL, EXACT)] if world.group in HONEST_GROUPS else out


def run(n: int = CHARTS_FULL, seed: int = SEED, *, charts: bool = True, only=None,
        log=None) -> dict:
    """Render and fit every world.

    Parameters
    ----------
    n : int
        Charts per world.
    seed : int
        Seed of the conditions and renders.
    charts : bool
        Keep the per-chart numbers.
    only : sequence of str, optional
        World names to run (default all).
    log : callable, optional
        Called with one progress line per world.

    Returns
    -------
    dict
        'config', 'results' (world name -> {'group', 'description', 'uncertain',
        'render_s', 'fits': {label: summary}, 'charts': {label: per-chart numbers}}) and
        'elapsed_s'.
    """
    t0 = time.perf_counter()
    root = np.random.default_rng(seed)
    cond_rng, render_root = root.spawn(2)
    cond = draw_conditions(cond_rng, n)
    chosen = [w for w in worlds() if only is None or w.name in only]
    streams = dict(zip([w.name for w in worlds()], render_root.spawn(len(worlds())), strict=True))
    results = {}
    for world in chosen:
        results[world.name] = _run_world(world, cond, streams[world.name], charts)
        if log:
            log(_progress(world.name, results[world.name]))
    return {"config": _config(n, seed), "results": results,
            "elapsed_s": time.perf_counter() - t0}


def _run_world(world: World, cond: dict, rng, charts: bool) -> dict:
    """Render ``world`` once and fit it with each of its budgets."""
    rendered = render_set(world, cond, rng)
    entry = {"group": world.group, "description": world.description, "test": world.test,
             "uncertain": _jsonable(world.uncertain), "render_s": rendered["render_s"],
             "fits": {}, "charts": {}}
    path = rendered["depth"] + rendered["distance"]
    for label, uncertain in _budgets(world):
        est = fit_set(rendered, uncertain)
        entry["fits"][label] = summarise(est, cond, path, rendered["truth"], world.test)
        at = np.asarray(est.chl, float) <= 0.0  # the charts whose C sits at its bound
        if label == DEFAULT_LABEL and world.name in AT_BOUND_WORLDS and at.any():
            entry["fits"][AT_BOUND_LABEL] = summarise(
                _rows_of(est, at), _rows_of(cond, at), path[at], _rows_of(rendered["truth"], at),
                world.test)
        if charts:
            entry["charts"][label] = _charts(est, cond, rendered)
    return entry


def _rows_of(obj, mask):
    """The charts ``mask`` of a batch estimate (as a namespace) or of a dict of (N,) arrays:
    every array whose first axis is the charts', dicts and per-chart lists alike."""
    mask = np.asarray(mask, bool)
    n = mask.size

    def take(v):
        if isinstance(v, dict):
            return {k: take(x) for k, x in v.items()}
        if isinstance(v, np.ndarray) and v.ndim and v.shape[0] == n:
            return v[mask]
        if isinstance(v, list) and len(v) == n:
            return [x for x, m in zip(v, mask) if m]
        return v
    if isinstance(obj, dict):
        return take(obj)
    return SimpleNamespace(**{f.name: (getattr(obj, f.name) if f.name == "wavelengths"
                                       else take(getattr(obj, f.name)))
                              for f in dataclasses.fields(obj)})


def _jsonable(uncertain):
    return "default" if uncertain is None else dict(uncertain)


def _progress(name, entry):
    parts = [f"{name}: render {entry['render_s']:.1f} s"]
    for label, s in entry["fits"].items():
        parts.append(f"{label} reliable {s['reliable']}/{s['n']} wrong {s['confident_wrong']} "
                     f"fit {s['fit_s']:.1f} s")
    return "; ".join(parts)


def _config(n, seed) -> dict:
    return {"charts_per_world": n, "seed": seed, "chl_range": CHL_RANGE,
            "cdom_range": CDOM_RANGE, "depth_range": DEPTH_RANGE,
            "distance_range": DISTANCE_RANGE, "exposure_range": EXPOSURE_RANGE,
            "clean_options": CLEAN_OPTIONS, "default_uncertain": DEFAULT_UNCERTAIN,
            "gain": "free", "nominal_single": NOMINAL_SINGLE, "nominal_joint": NOMINAL_JOINT,
            "consistency_p": CONSISTENCY_P, "min_reliable_clean": MIN_RELIABLE_CLEAN}


def _honest(summary) -> bool:
    """Every tested coverage (:data:`TESTED` and C and a_CDOM jointly) consistent with its
    nominal rate by the world's test (one-sided: not too many misses; two-sided: neither too
    many nor too few); vacuous with none reliable."""
    cov = summary["coverage"]
    return all(cov[k]["p"] is None or cov[k]["p"] >= CONSISTENCY_P
               for k in (*TESTED, "joint") if k in cov)


def acceptance(results: dict, attenuation: dict | None = None,
               reference: dict | None = None) -> list[dict]:
    """Each acceptance criterion: whether it holds, per world (default budget).

    Parameters
    ----------
    results : dict
        ``run(...)['results']``.
    attenuation : dict, optional
        :func:`run_attenuation`'s result: adds criterion 6, the attenuation coefficient's.
    reference : dict, optional
        :func:`experiments.honesty.run_reference`'s result: adds criterion 7, the
        reference shot's world covered at the nominal rate (its test, :func:`test_of`).

    Returns
    -------
    list of dict
        {'criterion', 'group', 'worlds': {name: bool}, 'holds': bool} in the order of the
        groups.
    """
    rules = {
        "clean": ("1. clean world: >= 90 % reliable and coverage consistent with nominal",
                  lambda s: s["reliable_fraction"] >= MIN_RELIABLE_CLEAN and _honest(s)),
        "priors": ("2. budget-prior world: covered at the nominal rate", _honest),
        "ends": ("3. ends of the paper's ranges: honest (reliable ones covered, or flagged)",
                 _honest),
        "geometry": ("4. geometry told wrong within its stated sd: truth inside the interval",
                     _honest),
        "garbage": ("5. garbage: never reliable", lambda s: s["reliable"] == 0),
    }
    out = []
    for group, (text, rule) in rules.items():
        # a world's criterion holds for its charts at the bound too (their own row)
        verdicts = {name: bool(rule(e["fits"][DEFAULT_LABEL]) and (
                        AT_BOUND_LABEL not in e["fits"] or _honest(e["fits"][AT_BOUND_LABEL])))
                    for name, e in results.items() if e["group"] == group}
        if verdicts:
            out.append({"criterion": text, "group": group, "worlds": verdicts,
                        "holds": all(verdicts.values())})
    if attenuation is not None:
        verdicts = {f"{w}: {b}": v["holds"] for w, bands in attenuation["criterion"].items()
                    for b, v in bands.items()}
        out.append({"criterion": "6. the attenuation coefficient c(443, 490, 555) on clear and "
                    "coastal water at 1-15 m: covered at the nominal rate with a "
                    f"median half-width <= {100 * C_MAX_HALF_WIDTH:.0f} %",
                    "group": "attenuation", "worlds": verdicts, "holds": all(verdicts.values())})
    if reference is not None:
        verdicts = holds(reference)
        out.append({"criterion": "7. the surface reference shot's world (the light measured in "
                    "air, the sky changed within its stated sd): every quantity covered at the "
                    "nominal rate", "group": "reference", "worlds": verdicts,
                    "holds": all(verdicts.values())})
    return out


# --------------------------------------------------------------------------- c(lambda)
def _water_conditions(rng, n, water):
    """:func:`draw_conditions` with C and a_CDOM log-uniform within a factor
    :data:`C_WATER_SPREAD` of the water type's."""
    cond = draw_conditions(rng, n)
    c0, a0 = C_WATERS[water]
    cond["chl"] = _log_uniform(rng, (c0 / C_WATER_SPREAD, c0 * C_WATER_SPREAD), n)
    cond["cdom"] = _log_uniform(rng, (a0 / C_WATER_SPREAD, a0 * C_WATER_SPREAD), n)
    return cond


def run_attenuation(n: int = C_CHARTS_FULL, seed: int = SEED, log=None) -> dict:
    """The attenuation coefficient's criterion: clear and coastal water, depths 1-15 m, in the
    clean and the budget-prior worlds (:data:`C_WORLDS`), default budget.

    Parameters
    ----------
    n : int
        Charts per world and water type.
    seed : int
        Seed of the conditions and renders (its own streams: not the main run's charts).
    log : callable, optional
        Called with one progress line per world and water.

    Returns
    -------
    dict
        'charts': world -> water -> per-chart lists ('depth' true, 'reliable', and per band
        of :data:`C_BANDS` 'inside' and 'half' (the relative half-width)); 'criterion': world
        -> band -> pooled numbers and 'holds'; 'breakdown': world -> water -> depth band ->
        band -> numbers; 'ablation' (:func:`_ablation`, on the clean world's first
        :data:`C_ABLATION_CHARTS` charts of each water); 'n', 'seed', 'elapsed_s'.
    """
    t0 = time.perf_counter()
    known = {w.name: w for w in worlds()}
    conds, streams = {}, {}
    for water, rng in zip(C_WATERS, np.random.default_rng([seed, 37]).spawn(len(C_WATERS))):
        cond_rng, render_rng = rng.spawn(2)
        conds[water] = _water_conditions(cond_rng, n, water)
        streams[water] = dict(zip(C_WORLDS, render_rng.spawn(len(C_WORLDS))))
    charts, ablation_sets = {}, {}
    for name in C_WORLDS:
        charts[name] = {}
        for water, cond in conds.items():
            rendered = render_set(known[name], cond, streams[water][name])
            est = fit_set(rendered, known[name].uncertain)
            charts[name][water] = _band_charts(est, cond, rendered)
            if log:
                log(f"c criterion {name}/{water}: {sum(charts[name][water]['reliable'])}/{n} "
                    f"reliable, fit {est.elapsed_s:.1f} s")
            if name == "clean":
                ablation_sets[water] = (cond, rendered)
    crit, breakdown = _attenuation_numbers(charts)
    return {"charts": charts, "criterion": crit, "breakdown": breakdown,
            "ablation": _ablation(ablation_sets, min(n, C_ABLATION_CHARTS)), "n": n,
            "seed": seed, "elapsed_s": time.perf_counter() - t0}


def _subset(rendered: dict, k: int) -> dict:
    """The first ``k`` charts of a :func:`render_set` result."""
    return {key: ({t: v[:k] for t, v in val.items()} if isinstance(val, dict) else
                  val[:k] if isinstance(val, np.ndarray) else val)
            for key, val in rendered.items()}


def _ablation(sets: dict, k: int) -> dict:
    """Median relative half-width of each band (pooled over the water types, reliable charts)
    with the whole default budget and with each of its nuisances left out (known exactly):
    term -> band -> median, and 'reliable' -> term -> count. The per-patch term stays (without
    it no chart of a world with tolerances fits)."""
    terms = [None] + [t for t in DEFAULT_UNCERTAIN if t != "patch"]
    out = {"charts": k * len(sets), "median_half_width": {}, "reliable": {}}
    for term in terms:
        budget = {t: v for t, v in DEFAULT_UNCERTAIN.items() if t != term}
        rows = []
        for cond, rendered in sets.values():
            sub = _subset(rendered, k)
            rows.append(_band_charts(fit_set(sub, budget), {"depth": cond["depth"][:k]}, sub))
        label = "none" if term is None else term
        test = world_test("clean")  # the ablation's charts are the clean world's
        out["median_half_width"][label] = {b: _band_numbers(rows, b, test)["median_half_width"]
                                           for b in C_BANDS}
        out["reliable"][label] = _band_numbers(rows, C_BANDS[0], test)["reliable"]
    return out


def _band_charts(est, cond, rendered) -> dict:
    """Per chart: the true depth, reliable, the relative half-width the geometry's budget alone
    gives c (1.96 sd(depth + distance) / (depth + distance), told values), and for each band
    whether the truth is inside and the relative half-width."""
    depth, distance = rendered["depth"], rendered["distance"]
    geometry = 1.96 * np.hypot(DEFAULT_UNCERTAIN["depth"],
                               _percent(DEFAULT_UNCERTAIN["distance"]) * distance) / (
        depth + distance)
    out = {"depth": np.asarray(cond["depth"], float).tolist(),
           "reliable": np.asarray(est.reliable, bool).tolist(), "geometry": geometry.tolist()}
    for band in C_BANDS:
        ci, truth = np.asarray(est.quantity_intervals[band], float), rendered["truth"][band]
        out[f"inside:{band}"] = _inside(ci, truth).tolist()
        out[f"half:{band}"] = ((ci[:, 1] - ci[:, 0]) / 2.0 / truth).tolist()
    return out


def _band_numbers(rows, band, test):
    """Coverage (by ``test``, the world's: :func:`world_test`) and median relative half-width
    of ``band`` among the reliable ``rows`` (dicts of :func:`_band_charts`' per-chart lists)."""
    rel = np.concatenate([np.asarray(r["reliable"], bool) for r in rows])
    inside = np.concatenate([np.asarray(r[f"inside:{band}"], bool) for r in rows])[rel]
    half = np.concatenate([np.asarray(r[f"half:{band}"], float) for r in rows])[rel]
    geometry = np.concatenate([np.asarray(r["geometry"], float) for r in rows])[rel]
    n = int(rel.sum())
    k = int(inside.sum())
    return {"n": int(rel.size), "reliable": n, "covered": k,
            "fraction": k / n if n else None,
            "test": test, "p": coverage_p(k, n, NOMINAL_SINGLE, test),
            "p_two_sided": coverage_p(k, n, NOMINAL_SINGLE, "two-sided"),
            "median_half_width": _median(half), "median_geometry_half_width": _median(geometry)}


def _rows_in(rows, lo, hi):
    """``rows`` restricted to the charts whose true depth is in [lo, hi)."""
    out = []
    for r in rows:
        keep = [lo <= d < hi or (hi == C_DEPTH_BANDS[-1][1] and d == hi) for d in r["depth"]]
        out.append({k: [v for v, ok in zip(vals, keep) if ok] for k, vals in r.items()})
    return out


def _attenuation_numbers(charts):
    """(criterion, breakdown) of :func:`run_attenuation` from its per-chart lists."""
    crit, breakdown = {}, {}
    for name, by_water in charts.items():
        crit[name], test = {}, world_test(name)
        for band in C_BANDS:
            v = _band_numbers(list(by_water.values()), band, test)
            v["holds"] = bool(v["reliable"] > 0 and v["p"] >= CONSISTENCY_P
                              and v["median_half_width"] <= C_MAX_HALF_WIDTH)
            crit[name][band] = v
        breakdown[name] = {
            water: {f"{lo:g}-{hi:g} m": {band: _band_numbers(_rows_in([rows], lo, hi), band, test)
                                         for band in C_BANDS} for lo, hi in C_DEPTH_BANDS}
            for water, rows in by_water.items()}
    return crit, breakdown


def _pct(x, digits=0):
    return "-" if x is None else f"{100 * x:.{digits}f} %"


def _num(x, fmt="{:.2f}"):
    return "-" if x is None else fmt.format(x)


def _cell(s, key) -> str:
    """'coverage · ±median half-width' of one quantity (bold where its test fails)."""
    cov = s["coverage"].get(key)
    if cov is None:
        return "-"
    text = f"{_pct(cov['fraction'])} · ±{_pct(s['median_rel_halfwidth'].get(key))}"
    fails = key in TESTED and cov["p"] is not None and cov["p"] < CONSISTENCY_P
    return f"**{text}**" if fails else text


def _row(name, label, s) -> str:
    share = "-" if s["median_largest_share_chl"] is None else (
        f"{s['median_largest_share_chl']:.2f} ({s['commonest_largest_source_chl']})")
    wrong = f"{s['confident_wrong']}" + (f" ({_pct(s['confident_wrong'] / s['reliable'])})"
                                          if s["reliable"] else "")
    cells = " | ".join(_cell(s, k) for k, _ in QUANTITIES)
    return (f"| {name} | {label} | {s.get('test', 'one-sided')} | {s['n']} | "
            f"{_pct(s['reliable_fraction'])} | {_pct(s['coverage']['joint']['fraction'])} | "
            f"{wrong} | {cells} | {share} |")


def _table(results) -> list[str]:
    header = ("| world | budget | test | n | reliable | C and a_CDOM both covered | confident "
              "wrong | " + " | ".join(label for _, label in QUANTITIES) +
              " | median largest C share (source) |")
    lines = [header, "|" + "---|" * (8 + len(QUANTITIES))]
    for name, e in results.items():
        for label, s in e["fits"].items():
            lines.append(_row(name, label, s))
    return lines


def _world_sentence(name, s) -> str:
    cov = s["coverage"]
    text = (f"`{name}`: {s['reliable']}/{s['n']} reliable ({_pct(s['reliable_fraction'])}); ")
    if not s["reliable"]:
        return text + "no reliable chart to cover."
    test = s.get("test", "one-sided")
    parts = [f"{label} {cov[k]['covered']}/{s['reliable']} (p = {cov[k]['p']:.2g})"
             for k, label in QUANTITIES if k in cov and k in TESTED]
    parts.append(f"both C and a_CDOM {cov['joint']['covered']}/{s['reliable']} "
                 f"(p = {cov['joint']['p']:.2g}, against 90 %)")
    return (text + f"covered ({test}): " + ", ".join(parts) +
            f"; {s['confident_wrong']} confident wrong.")


def _attenuation_text(att) -> list[str]:
    """HONESTY.md's section on the attenuation coefficient's criterion."""
    if att is None:
        return []
    waters = ", ".join(f"{w} (C {c:g} mg m^-3, a_CDOM(440) {a:g} m^-1)"
                       for w, (c, a) in C_WATERS.items())
    lines = ["", "## The attenuation coefficient c(lambda) (issue 37's criterion)", "",
             f"{att['n']} charts per world and water type (seed {att['seed']}, its own draws), "
             f"water types {waters}, each chart's C and a_CDOM log-uniform within a factor "
             f"{C_WATER_SPREAD:.2f} of its type's, depth 1-15 m, distance 0.5-3 m, exposure "
             "unknown; the `clean` and `priors` worlds above, fitted with the default budget "
             "(the geometry's terms included). The truth is the world's path coefficient "
             f"{C_NAME}; the estimate is `BatchEstimate.quantities['c_443']` etc. with its 95 % "
             "interval (`sca.derived`: the delta method on the logarithm, spanning the path "
             "models). Coverage among the reliable charts, tested by each world's test (the "
             f"column 'test'; **Coverage tests** above says which and why) at p < {CONSISTENCY_P}; half-width (hi - lo) / 2 / truth, median among the reliable. "
             f"Criterion: both tests pass and the median half-width is <= "
             f"{100 * C_MAX_HALF_WIDTH:.0f} % for each band, pooled over both water types and "
             f"all depths, in each world. Run time {att['elapsed_s']:.0f} s.", "",
             "| world | band | test | reliable | covered | p | median half-width | "
             "holds |", "|---|---|---|---|---|---|---|---|"]
    for name, bands in att["criterion"].items():
        for band, v in bands.items():
            lines.append(f"| {name} | {band} | {v['test']} | {v['reliable']}/{v['n']} | "
                         f"{_pct(v['fraction'])} | {_p(v['p'])} | "
                         f"±{_pct(v['median_half_width'], 1)} | "
                         f"{'yes' if v['holds'] else '**no**'} |")
    lines += ["", "By water type and depth band (coverage · median half-width; reliable "
              "charts):", "",
              "| world | water | depth | reliable | geometry's budget alone | " +
              " | ".join(C_BANDS) + " |", "|" + "---|" * (5 + len(C_BANDS))]
    for name, by_water in att["breakdown"].items():
        for water, by_depth in by_water.items():
            for depth, bands in by_depth.items():
                first = next(iter(bands.values()))
                cells = " | ".join(
                    f"{_pct(v['fraction'])} · ±{_pct(v['median_half_width'], 1)}"
                    for v in bands.values())
                lines.append(f"| {name} | {water} | {depth} | {first['reliable']}/"
                             f"{first['n']} | ±{_pct(first['median_geometry_half_width'], 1)} | "
                             f"{cells} |")
    return lines + _ablation_text(att.get("ablation")) + _attenuation_verdict(att)


def _ablation_text(abl) -> list[str]:
    """What sets c's width: the median half-width with each nuisance known."""
    if not abl:
        return []
    lines = ["", f"What sets the width (the `clean` world's first {abl['charts']} charts, both "
             "water types, refitted with each nuisance of the budget left out, i.e. known "
             "exactly; median half-width among the reliable):", "",
             "| budget | reliable | " + " | ".join(C_BANDS) + " |",
             "|" + "---|" * (2 + len(C_BANDS))]
    for term, bands in abl["median_half_width"].items():
        label = "the default" if term == "none" else f"without `{term}`"
        lines.append(f"| {label} | {abl['reliable'][term]} | " +
                     " | ".join(f"±{_pct(v, 1)}" for v in bands.values()) + " |")
    return lines


def _largest_term(abl, band) -> str:
    """'; with X known: ±w' for the nuisance whose removal narrows ``band`` most."""
    if not abl:
        return ""
    widths = {t: b[band] for t, b in abl["median_half_width"].items()
              if t != "none" and b[band] is not None}
    if not widths:
        return ""
    term = min(widths, key=widths.get)
    return (f"; the largest single cause is `{term}`: with it known the clean world's median "
            f"is ±{_pct(widths[term], 1)} instead of "
            f"±{_pct(abl['median_half_width']['none'][band], 1)}")


def _p(x) -> str:
    return "-" if x is None else f"{x:.2g}"


def _attenuation_verdict(att) -> list[str]:
    """Sentences: met or not, and by how much."""
    out = [""]
    for name, bands in att["criterion"].items():
        for band, v in bands.items():
            if v["holds"]:
                continue
            why = []
            if v["reliable"] and v["p"] < CONSISTENCY_P:
                side = "over" if v["fraction"] > NOMINAL_SINGLE else "under"
                why.append(f"coverage {_pct(v['fraction'], 1)} ({side}-coverage, {v['test']} "
                           f"p = {_p(v['p'])})")
            if v["median_half_width"] is not None and v["median_half_width"] > C_MAX_HALF_WIDTH:
                why.append(f"median half-width ±{_pct(v['median_half_width'], 1)}, "
                           f"{v['median_half_width'] / C_MAX_HALF_WIDTH:.2f} x the "
                           f"{100 * C_MAX_HALF_WIDTH:.0f} % asked (the geometry's budget "
                           "alone, depth 0.2 m and distance 5 %, gives "
                           f"±{_pct(v['median_geometry_half_width'], 1)}"
                           f"{_largest_term(att.get('ablation'), band)})")
            out.append(f"- **not met** — `{name}` {band}: " + "; ".join(why or ["none reliable"])
                       + ".")
    if len(out) == 1:
        out.append("- **met** in both worlds for every band.")
    return out


def _limitation_text(results, check=None) -> list[str]:
    """The illuminant told wrong: outside what one underwater photo can see, said plainly, and
    what prevents it (the reference shot: ``check``, :func:`experiments.honesty.
    illuminant_check`)."""
    rows = [(n, e) for n, e in results.items() if e["group"] == "limitation"]
    if not rows:
        return []
    lines = ["", "## Outside what one photo can see: the illuminant told wrong (no criterion)", "",
             f"Without a reference shot, a light other than the one given is **outside what one "
             f"underwater photo can see**, and the title's promise does not hold for it: under "
             f"tungsten light (illuminant {WRONG_ILLUMINANT}) told as D65, the light's red tilt is "
             "indistinguishable from CDOM absorption along the path, the fit is good, and most "
             "reliable charts are confidently wrong (the numbers below). The photos underwater "
             "cannot flag it; the result is conditional on the light given (`illuminant=`, "
             "`--illuminant`).", ""]
    for name, e in rows:
        s = e["fits"][DEFAULT_LABEL]
        lines.append(f"- `{name}`: {_world_sentence(name, s)}{_garbage_note(s)}")
    lines += ["", "**What prevents it: the reference shot** (decision 0069-reference-shot, "
              "`uw3p measure --reference PHOTO`): the chart photographed in air at the site "
              "measures the light itself (`sca.reference.measure_light`), and a light off the "
              "daylight series is refused (`sca.reference.check_daylight`: exit 2 naming "
              "`--reference`) instead of fitted as daylight; a light on the series is covered "
              "(the reference-shot world above). Alternatively give the light (`--illuminant`)."]
    if check:
        lines += [""] + [f"- reference shots under {light} (the independent renderer, "
                         f"{v['n']} charts): refused {v['refused']} of {v['n']}; measured CCT "
                         f"{v['cct_median']:.0f} K (median), chi2/dof {v['chi2_dof_median']:.2g}"
                         for light, v in check.items()]
    lines += ["", "A wrong illuminant in the in-air *calibration* is caught too: the "
              "calibration's per-patch systematic term is 13 % against at most 3 % "
              "(`systematic`, tests/test_budget.py)."]
    return lines


def _criteria_text(results, verdicts) -> list[str]:
    lines = []
    for v in verdicts:
        lines += ["", f"**{v['criterion']}** — {'holds' if v['holds'] else 'FAILS'}.", ""]
        if v["group"] in ("attenuation", "reference"):
            lines.append("- " + ", ".join(f"{name} {'holds' if ok else 'FAILS'}"
                                          for name, ok in v["worlds"].items()) +
                         " (the section below gives the numbers).")
            continue
        for name, ok in v["worlds"].items():
            s = results[name]["fits"][DEFAULT_LABEL]
            extra = (_garbage_note(s) if v["group"] == "garbage" else
                     _twin_note(results, name))
            lines.append(f"- {'holds' if ok else 'FAILS'} — {_world_sentence(name, s)}{extra}")
    return lines


def _garbage_note(s) -> str:
    text = f" Flags raised most: {_top_flags(s)}."
    if s["reliable"] and s.get("median_cdom_path_error") is not None:
        text += (" Median a_CDOM optical-depth error (a_CDOM - truth) x (depth + distance) "
                 f"among the reliable: {s['median_cdom_path_error']:.2f}.")
    return text


def _twin_note(results, name) -> str:
    twin = results.get(f"{name}/no-shift")
    if twin is None:
        return ""
    s = twin["fits"][DEFAULT_LABEL]
    if not s["reliable"]:
        return f" Without the camera-curve shifts (`{name}/no-shift`): none reliable."
    return (f" Without the camera-curve shifts (`{name}/no-shift`): {s['reliable']}/{s['n']} "
            f"reliable, both covered {s['coverage']['joint']['covered']}/{s['reliable']}, "
            f"{s['confident_wrong']} confident wrong ({'honest' if _honest(s) else 'NOT honest'}).")


def _top_flags(s, k=3) -> str:
    return ", ".join(f"{f} {c}" for f, c in list(s["flags"].items())[:k]) or "none"


def _contrast_text(results) -> list[str]:
    title = "**The exact model (`uncertain={}`) for contrast** (worlds 1-4, the old behaviour):"
    lines = ["", title, ""]
    for name, e in results.items():
        s = e["fits"].get(EXACT_LABEL)
        if s is not None:
            lines.append(f"- {_world_sentence(name, s)}")
    return lines


def _diagnostic_text(results) -> list[str]:
    rows = [(n, e) for n, e in results.items() if e["group"] == "diagnostic"]
    if not rows:
        return []
    title = ("**Diagnostic** (no criterion): worlds 1-4 again, the same conditions without the "
             "camera-curve shifts (`camera_shift_nm_sd` 0), default budget:")
    lines = ["", title, ""]
    for name, e in rows:
        s = e["fits"][DEFAULT_LABEL]
        verdict = "honest" if _honest(s) else "NOT honest"
        lines.append(f"- {verdict} — {_world_sentence(name, s)}")
    return lines


def _health_text(results) -> list[str]:
    bad = [(n, lab, s) for n, e in results.items() for lab, s in e["fits"].items()
           if s["not_converged"] or s["nan_intervals"]]
    if not bad:
        return ["", "Every fit converged and no interval is NaN."]
    return ["", "Fits that did not converge or returned NaN intervals:", ""] + [
        f"- `{n}` ({lab}): {s['not_converged']} not converged, {s['nan_intervals']} NaN "
        "intervals" for n, lab, s in bad]


def _intro(out) -> str:
    cfg = out["config"]
    return (
        f"{cfg['charts_per_world']} charts per world (seed {cfg['seed']}), rendered by the "
        "independent renderer (`experiments/independent_world.py`, no code shared with "
        "`forward`) and fitted by `sca.estimate_batch(..., gain='free')` with the default "
        "budget (`default`: `sca.budget.DEFAULT_UNCERTAIN`, or the world's stated budget in "
        "world 4) and with the paper's exact model (`exact`: `uncertain={}`). Every world "
        "uses the same conditions: C log-uniform 0.05-10 mg m^-3, a_CDOM log-uniform "
        "0.01-1 m^-1, depth 1-15 m, distance 0.5-3 m, exposure 0.2-0.9 (unknown to the fit), "
        f"{PIXELS_PER_PATCH} pixels per patch with photon and read noise. Every reported "
        "quantity is scored against the world's own value: C, a_CDOM(440), the path's "
        f"path's c at 443, 490, 555 and 670 nm ({C_NAME}) and the non-water absorption a_nw(440) "
        "(`sca.derived`). Coverage, confident wrong (truth outside the C or the "
        "a_CDOM interval) and half-widths are among the reliable charts; a half-width is "
        "(hi - lo) / 2 / truth, its median the headline beside the coverage. "
        f"Run time {out['elapsed_s']:.0f} s ({_timing(out['results'])}).")


def _tests_text() -> str:
    """Which worlds get which coverage test, and why."""
    return (
        "**Coverage tests.** Each coverage is tested against the nominal 95 % (a binomial test "
        f"at p < {CONSISTENCY_P}, the p-values below), one-sided or two-sided by the world, "
        "said here once (`experiments.honesty.test_of`; every table's 'test' column and every "
        "criterion below reads it). Tested **two-sided**: "
        + ", ".join(f"`{g}`" for g in TWO_SIDED_GROUPS) + " (the world drawn from the budget's "
        "own priors: every nuisance of `sca.budget.DEFAULT_UNCERTAIN` drawn from its prior, the "
        "chart's per-patch reflectances with the budget's 1 %; and the same with the light "
        "measured by a reference shot): there the intervals must hold the truth 95 % of the "
        "time, no less and no more, and over-coverage (intervals wider than the budget says) "
        "fails. Every other world is tested **one-sided** (only too many misses fail), in every "
        "section, the c(lambda) criterion's included: `clean` is inside the "
        "budget but less perturbed than it (tolerances half the budget's, no geometry or "
        "daylight error), so its intervals are expected to hold the truth more often than 95 "
        "%; the sky changed beyond its stated sd (`sky-beyond`) is outside its budget; the ends of the paper's ranges and the geometry told wrong are deliberately at or "
        "beyond the budget's edges; garbage must not be reliable at all. Both 95 % intervals "
        "of C and a_CDOM together are tested one-sided against 90 % (Bonferroni: their joint "
        "rate is only bounded). Every quantity a user is shown is tested; K_d(490) is not "
        "published (decision 0067-kd-not-published). The rows `default, C at 0` are the same "
        "fit's charts whose C sits at its lower bound, tested as their world (decision "
        "0066-derived-intervals-at-the-bounds); the world's criterion holds only if they pass "
        "too. A bold cell is a failed test.")


#: An interval from 0 to this many times the truth: its half-width is (this / 2) x the truth.
NOTHING_FACTOR = 3.0


def _width_text(results) -> str:
    """Why a coverage is read beside its width: what the clean and prior worlds' C and c(443)
    intervals hold and how wide they are (the default budget)."""
    parts = []
    for name in ("clean", "priors"):
        s = results.get(name, {}).get("fits", {}).get(DEFAULT_LABEL)
        if not s or not s["reliable"]:
            continue
        for key, label in (("chl", "C"), ("c_443", "c(443)")):
            cov, w = s["coverage"].get(key), s["median_rel_halfwidth"].get(key)
            if cov is None or w is None:
                continue
            parts.append(f"`{name}` {label} covered {_pct(cov['fraction'])}, median half-width "
                         f"±{_pct(w)}")
    return (
        "**Coverage and width together.** An interval is judged by both: whether it holds the "
        "truth at the nominal rate, and how wide it is (the median half-width, beside every "
        f"coverage below). An interval of [0, {NOTHING_FACTOR:g} x the truth] (a half-width of "
        f"±{100 * NOTHING_FACTOR / 2:.0f} %) is honest and says nothing: it holds the truth and "
        "does not measure the quantity. " + ("; ".join(parts) + ". " if parts else "") +
        "Where a median half-width is ±100 % or more, the typical interval reaches 0 or "
        "twice the truth: an upper bound, not a measurement (`sca.derived.verdict`: 'loosely "
        "measured', 'upper bound' or 'not constrained'). The c(lambda) section below tests the path's "
        "attenuation coefficient for width as well as coverage.")


def _world_list(results) -> str:
    return ("Worlds 2-5 add their change to the clean world's tolerances (camera-curve shifts "
            "included); each world 1-4 has a diagnostic twin `<name>/no-shift` without the "
            "camera-curve shifts (same conditions, default budget only). Worlds: " +
            "; ".join(f"`{w.name}` {w.description}" for w in worlds()
                      if w.name in results and w.group != "diagnostic") + ".")


def report(out: dict) -> str:
    """The text of ``HONESTY.md`` from :func:`run`'s result (a pure function of it).

    Parameters
    ----------
    out : dict
        ``run(...)``, with 'elapsed_s', and optionally 'attenuation'
        (:func:`run_attenuation`).

    Returns
    -------
    str
    """
    results = out["results"]
    att, ref = out.get("attenuation"), out.get("reference")
    head = ["# Honesty: never a confident wrong answer where the photos can see the error", "",
            "Every world below is one the photos (or their reference shot) can see; the one "
            "they cannot, a light other than the one given and no reference shot, is said "
            "plainly in its own section with what prevents it.", "",
            f"Generated by `{out.get('command', 'python -m experiments.honesty')}`; do not "
            "edit.", "",
            _intro(out), "", _tests_text(), "", _width_text(results), "",
            _world_list(results), "",
            "Each quantity's cell: coverage · ±median half-width.", ""]
    return "\n".join(head + _table(results) + ["", "## Acceptance"] +
                     _criteria_text(results, acceptance(results, att, ref)) +
                     _attenuation_text(att) + reference_text(ref) +
                     _limitation_text(results, out.get("illuminant_check")) +
                     _contrast_text(results) +
                     _diagnostic_text(results) + _health_text(results)) + "\n"


def _timing(results) -> str:
    render = sum(e["render_s"] for e in results.values())
    fit = sum(s["fit_s"] for e in results.values() for s in e["fits"].values())
    return f"rendering {render:.0f} s, fitting {fit:.0f} s"


def _write_atomic(path: Path, text: str):
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    write_atomic(path, text)


def write_outputs(out: dict, report_path, json_path):
    """Write ``HONESTY.md`` and the JSON, each whole or not at all (temporary file, then
    ``os.replace``).

    Parameters
    ----------
    out : dict
        :func:`run`'s result.
    report_path, json_path : str or pathlib.Path
    """
    text = report(out)
    data = json.dumps({**out, "acceptance": acceptance(out["results"], out.get("attenuation"),
                                                       out.get("reference"))}, indent=1)
    _write_atomic(Path(json_path), data)
    _write_atomic(Path(report_path), text)



# --------------------------------------------------------------------------- the reference-shot worlds
#: The sky's change of the ``sky-beyond`` world, in units of the stated sd (uniform).
BEYOND_SD = (3.0, 4.0)
#: The bands of the optical depth's criterion and its target: the 95 % half-width of
#: tau = c (depth + distance) at most 0.10 (issue 47).
DTAU_BANDS = ("443", "490", "555")
DTAU_TARGET = 0.10
#: Reference shots per light of :func:`illuminant_check` (each a render and a fit: ~0.5 s)
ILLUMINANT_SHOTS = 20

#: The fits of the reference worlds (row labels): the light measured in air (the reference's
#: default, decision 0069-reference-shot), the light and the chart's response (opt-in: decision
#: 0079-reference-patch-response) and the default budget.
WITH_REF, RESPONSE, REF_DEFAULT = ("with the reference", "the light and the chart's response "
                                   "(opt-in)", "default budget")
REFERENCE_LABELS = (WITH_REF, RESPONSE, REF_DEFAULT)
#: The renderer's per-chart draws the reference shot shares with the photo underwater.
SHARED_DRAWS = ("camera_shift_nm", "camera_gains", "reflectance_factors")


def _world():
    """The ``priors`` world (the budget's own priors) with the daylight of the conditions."""
    priors = {w.name: w for w in worlds()}["priors"]
    return dataclasses.replace(priors, name="reference", group="reference",
                               draw_daylight=True)


def _in_range(mired) -> np.ndarray:
    """Inside the daylight series (4000-25 000 K) as a shift from D65."""
    lo, hi = 1e6 / 25000.0 - 1e6 / iw.D65_CCT, 1e6 / 4000.0 - 1e6 / iw.D65_CCT
    return (mired > lo) & (mired < hi)


def _sky_change(rng, surface, sd) -> np.ndarray:
    """N(0, sd) changes of ``surface`` (mired), redrawn where the light would leave the
    daylight series."""
    out = rng.normal(0.0, sd, surface.size)
    while not (bad := ~_in_range(surface + out)).all() and bad.any():
        out[bad] = rng.normal(0.0, sd, int(bad.sum()))
    return out


def _beyond(rng, surface, stated) -> np.ndarray:
    """Changes of :data:`BEYOND_SD` x ``stated`` sd, either sign (the other where the first
    would leave the daylight series)."""
    size = rng.uniform(*BEYOND_SD, surface.size) * stated
    sign = rng.choice([-1.0, 1.0], surface.size)
    return np.where(_in_range(surface + sign * size), sign, -sign) * size


def _air_shots(world, cond, drawn, rng) -> list:
    """The reference shot of every chart: in air, under the surface light, the same camera and
    chart as the photo underwater; the light fitted by :func:`sca.reference.measure_light`."""
    lights = []
    for i, stream in enumerate(rng.spawn(cond["chl"].size)):
        opts = {**CLEAN_OPTIONS, **world.options, "exposure": float(cond["exposure"][i]),
                "daylight_mired": float(cond["surface_mired"][i])}
        opts.update({k: tuple(np.atleast_1d(drawn[i][k])) for k in SHARED_DRAWS})
        air = iw.render_calibration(rng=stream, **opts)
        lights.append(measure_light(np.maximum(air["rgb"], 0.0), air["sigma"]))
    return lights


def illuminant_check(n: int = ILLUMINANT_SHOTS, seed: int = SEED) -> dict:
    """What a reference shot says of the ``wrong_illuminant`` world's light.

    ``n`` charts photographed in air by the independent renderer (the clean world's tolerances,
    exposure 0.2-0.9) under :data:`experiments.honesty.WRONG_ILLUMINANT` and, for contrast,
    under D65, each light fitted by :func:`sca.reference.measure_light` and judged by
    :func:`sca.reference.check_daylight` (``uw3p measure --reference`` refuses a light it
    rejects).

    Returns
    -------
    dict
        light name -> {'n', 'refused' (count), 'cct_median' (K), 'chi2_dof_median'}.
    """
    from sca.reference import check_daylight

    from forward.errors import InputError

    rng = np.random.default_rng([seed, 50, 5])
    out = {}
    for light in (WRONG_ILLUMINANT, "D65"):
        refused, cct, chi2 = 0, [], []
        for stream in rng.spawn(n):
            opts = {**CLEAN_OPTIONS, "illuminant": light,
                    "exposure": float(stream.uniform(*EXPOSURE_RANGE))}
            air = iw.render_calibration(rng=stream, **opts)
            lt = measure_light(np.maximum(air["rgb"], 0.0), air["sigma"])
            cct.append(lt.cct)
            chi2.append(lt.chi2_dof)
            try:
                check_daylight(lt)
            except InputError:
                refused += 1
        out[light] = {"n": n, "refused": refused, "cct_median": float(np.median(cct)),
                      "chi2_dof_median": float(np.median(chi2))}
    return out


def dtau_half_widths(est, rendered) -> dict:
    """band -> (N,) 95 % half-width of the optical depth tau at the band: the estimate's
    'tau_<band>' interval where :func:`sca.derived.quantity_names` has it, else c's interval
    times the told depth + distance; and 'source' saying which."""
    qi = est.quantity_intervals
    told = np.asarray(rendered["depth"], float) + np.asarray(rendered["distance"], float)
    own = all(f"tau_{b}" in qi for b in DTAU_BANDS)
    out = {"source": "tau's interval" if own else "c's interval x (told depth + distance)"}
    for b in DTAU_BANDS:
        ci = np.asarray(qi[f"tau_{b}"] if own else qi[f"c_{b}"], float)
        out[b] = (ci[:, 1] - ci[:, 0]) / 2.0 * (1.0 if own else told)
    return out


def _flagged_or_covered(est, truth) -> dict:
    """Per quantity: charts covered (reliable, truth inside), flagged (not reliable) and
    neither (reliable and missed: confidently wrong)."""
    rel = np.asarray(est.reliable, bool)
    out = {}
    for k, (ci, t) in _estimates(est, truth).items():
        inside = _inside(ci, t)
        out[k] = {"covered": int((inside & rel).sum()), "flagged": int((~rel).sum()),
                  "neither": int((~inside & rel).sum())}
    return out


def _summary(est, cond, rendered, test) -> dict:
    s = summarise(est, cond, rendered["depth"] + rendered["distance"], rendered["truth"],
                    test)
    dtau = dtau_half_widths(est, rendered)
    rel = np.asarray(est.reliable, bool)
    s["dtau_source"] = dtau.pop("source")
    s["median_dtau95"] = {b: _median(v[rel]) for b, v in dtau.items()}
    s["flagged_or_covered"] = _flagged_or_covered(est, rendered["truth"])
    return s


def _fresh(seq) -> np.random.Generator:
    """A generator of ``seq``'s own state (its children the same every time)."""
    return np.random.default_rng(np.random.SeedSequence(seq.entropy, spawn_key=seq.spawn_key))


def _render(world, cond, rng):
    """:func:`experiments.honesty.render_set` keeping each chart's shared draws."""
    return render_set(world, cond, rng, keep=SHARED_DRAWS)


def _draw_set(water, n, rng):
    """One water type's charts: (world, conditions, the photos underwater, the reference
    shots' lights (with the chart's response), seconds spent in air, the seeds of sky-beyond
    and of the photos)."""
    world = _world()
    cond_seq, air_seq, sky_seq, beyond_seq, uw_seq = rng.bit_generator.seed_seq.spawn(5)
    cond = _water_conditions(np.random.default_rng(cond_seq), n, water)
    cond["surface_mired"] = cond["daylight_mired"]
    cond["daylight_mired"] = cond["surface_mired"] + _sky_change(
        np.random.default_rng(sky_seq), cond["surface_mired"], sky_sd(REFERENCE_MINUTES))
    rendered = _render(world, cond, _fresh(uw_seq))
    t0 = time.perf_counter()
    lights = _air_shots(world, cond, rendered["drawn"], np.random.default_rng(air_seq))
    return world, cond, rendered, lights, time.perf_counter() - t0, (beyond_seq, uw_seq)


def _water_set(water, n, rng, log, beyond=True):
    """Render and fit one water type's charts in both worlds (``beyond``: and sky-beyond)."""
    world, cond, rendered, lights, air_s, (beyond_seq, uw_seq) = _draw_set(water, n, rng)
    budgets = with_reference(None, lights, REFERENCE_MINUTES)
    test = test_of("reference")
    out = {"reference": {
        label: _summary(fit_set(rendered, budget), cond, rendered, test)
        for label, budget in ((WITH_REF, budgets), (RESPONSE, with_reference(
            None, lights, REFERENCE_MINUTES, response=True)), (REF_DEFAULT, None))}}
    stated = budgets["daylight"]["sd"]
    out["lights"] = {"sd_fit_median": float(np.median([lt.sd for lt in lights])),
                     "error_median_abs": float(np.median(np.abs(
                         [lt.centre for lt in lights] - cond["surface_mired"]))),
                     "sd_stated_median": float(np.median(stated)),
                     "sky_change_sd": sky_sd(REFERENCE_MINUTES)}
    out["render_s"] = rendered["render_s"] + air_s  # sky-beyond's renders: in 'elapsed_s'

    if beyond:
        out["sky-beyond"] = _sky_beyond(world, cond, budgets, beyond_seq, uw_seq)
    if log:
        log(f"reference/{water}: " + "; ".join(
            f"{w} {lab} reliable {s['reliable']}/{s['n']} fit {s['fit_s']:.1f} s"
            for w in ("reference", "sky-beyond") for lab, s in out.get(w, {}).items()))
    return out


def _sky_beyond(world, cond, budgets, beyond_seq, uw_seq) -> dict:
    """The same charts (camera draws and noise: the same streams) under a sky changed by
    :data:`BEYOND_SD` x each chart's stated sd, fitted with its reference."""
    stated = budgets["daylight"]["sd"]
    far = {**cond, "daylight_mired": cond["surface_mired"] + _beyond(
        np.random.default_rng(beyond_seq), cond["surface_mired"], stated)}
    beyond = _render(world, far, _fresh(uw_seq))
    return {WITH_REF: _summary(fit_set(beyond, budgets), far, beyond,
                                  test_of("sky-beyond"))}


def run_reference(n: int = C_CHARTS_FULL, seed: int = SEED, log=None, *, waters=None,
                  beyond: bool = True) -> dict:
    """The reference-shot worlds on clear and coastal water (:data:`experiments.honesty.C_WATERS`).

    Parameters
    ----------
    n : int
        Charts per water type.
    seed : int
        Seed of the conditions and renders (its own streams).
    log : callable, optional
        Called with one progress line per water type.
    waters : sequence of str, optional
        The water types to run (default all of :data:`experiments.honesty.C_WATERS`).
    beyond : bool, optional
        Run the ``sky-beyond`` world too (default True).

    Returns
    -------
    dict
        'waters': water -> {'reference': {label: summary}, 'sky-beyond': {label: summary},
        'lights', 'render_s'}; 'pooled': world -> label -> summary of both water types
        together; 'n', 'seed', 'minutes', 'elapsed_s'.
    """
    t0 = time.perf_counter()
    streams = np.random.default_rng([seed, 47, 6]).spawn(len(C_WATERS))
    waters = {w: _water_set(w, n, rng, log, beyond) for w, rng in zip(C_WATERS, streams)
              if waters is None or w in waters}
    return {"waters": waters, "pooled": _pooled(waters), "n": n, "seed": seed,
            "minutes": REFERENCE_MINUTES, "elapsed_s": time.perf_counter() - t0}


def _pooled(waters) -> dict:
    """world -> label -> both water types' counts added (:func:`_pool`)."""
    out = {}
    for world in ("reference", "sky-beyond"):
        if world not in next(iter(waters.values())):
            continue
        out[world] = {}
        for label in next(iter(waters.values()))[world]:
            parts = [w[world][label] for w in waters.values()]
            out[world][label] = _pool(parts)
    return out


def _pool(parts) -> dict:
    """Counts of ``parts`` (summaries) added and their coverages retested."""
    test = parts[0]["test"]
    n_rel = sum(p["reliable"] for p in parts)
    cov = {k: _coverage(sum(p["coverage"][k]["covered"] for p in parts), n_rel,
                          NOMINAL_SINGLE, test)
           for k in parts[0]["coverage"] if k != "joint"}
    foc = {k: {f: sum(p["flagged_or_covered"][k][f] for p in parts) for f in v}
           for k, v in parts[0]["flagged_or_covered"].items()}
    return {"n": sum(p["n"] for p in parts), "reliable": n_rel, "test": test, "coverage": cov,
            "flagged_or_covered": foc}


# --------------------------------------------------------------------------- the report
def _quantities(summary):
    return [(k, label) for k, label in reported_quantities() if k in summary["coverage"]]


def _ref_cell(s, key) -> str:
    cov = s["coverage"][key]
    text = (f"{_pct(cov['fraction'])} · ±{_pct(s['median_rel_halfwidth'].get(key))} "
            f"(p {_p(cov['p'])})")
    return f"**{text}**" if cov["p"] is not None and cov["p"] < CONSISTENCY_P else text


def _dtau_cells(s) -> str:
    return " | ".join(_num(s["median_dtau95"][b]) + (
        "" if s["median_dtau95"][b] is None or s["median_dtau95"][b] <= DTAU_TARGET else " ✗")
        for b in DTAU_BANDS)


def _ref_table(ref) -> list:
    first = next(iter(ref["waters"].values()))["reference"][WITH_REF]
    qs = _quantities(first)
    lines = ["| world | water | fit | test | reliable | " + " | ".join(lab for _, lab in qs) +
             " | " + " | ".join(f"Δτ({b})" for b in DTAU_BANDS) + " |",
             "|" + "---|" * (5 + len(qs) + len(DTAU_BANDS))]
    for world in ("reference", "sky-beyond"):
        for water, e in ref["waters"].items():
            for label, s in e.get(world, {}).items():
                lines.append(f"| {world} | {water} | {label} | {s['test']} | "
                             f"{s['reliable']}/{s['n']} | " +
                             " | ".join(_ref_cell(s, k) for k, _ in qs) + " | " +
                             _dtau_cells(s) + " |")
    return lines


def _beyond_text(ref) -> list:
    """Flagged or covered, per quantity, pooled: said plainly."""
    if "sky-beyond" not in ref["pooled"]:
        return []
    s = ref["pooled"]["sky-beyond"][WITH_REF]
    worst = {k: v["neither"] for k, v in s["flagged_or_covered"].items()}
    lines = [f"`sky-beyond` (pooled, {s['n']} charts, {s['reliable']} reliable): " + ", ".join(
        f"{lab} {v['covered']} covered, {v['flagged']} flagged, {v['neither']} neither"
        for k, lab in reported_quantities() if (v := s["flagged_or_covered"].get(k)))
        + "."]
    bad = [k for k in worst if s["coverage"][k]["p"] is not None
           and s["coverage"][k]["p"] < CONSISTENCY_P]
    if not bad:
        lines.append("Honest: the misses among the reliable charts are no more than the "
                     f"nominal 5 % ({s['test']} binomial test); the rest are flagged.")
    else:
        names = ", ".join(dict(reported_quantities()).get(k, k) for k in bad)
        lines.append(f"**Not honest** for {names}: a sky changed by {BEYOND_SD[0]:g}-"
                     f"{BEYOND_SD[1]:g} sd is neither flagged nor covered on more charts than "
                     f"the nominal 5 % ({s['test']} p < "
                     f"{CONSISTENCY_P}): the photo underwater hardly sees the light's colour. "
                     "The reference shot is honest only within its stated sky sd (decision "
                     "0069-reference-shot): give the time between the shot and the dive, and "
                     "shoot it under the same sun or shade.")
    return lines


def _reference_verdict(ref) -> list:
    pooled = ref["pooled"]["reference"]
    out = []
    for label, s in pooled.items():
        fails = [dict(reported_quantities()).get(k, k) for k, v in s["coverage"].items()
                 if v["p"] is not None and v["p"] < CONSISTENCY_P]
        out.append(f"`reference` {label} (pooled, {s['reliable']} reliable of {s['n']}): "
                   + (f"every quantity covered at the nominal rate ({s['test']})." if not fails
                      else f"**coverage fails** ({s['test']} p < "
                      f"{CONSISTENCY_P}) for " + ", ".join(fails) + "."))
    return out


def reference_text(ref) -> list:
    """HONESTY.md's section on the reference shot (lines); [] without it."""
    if not ref:
        return []
    first = next(iter(ref["waters"].values()))
    lights = ", ".join(
        f"{w}: median sd of the light measured {e['lights']['sd_fit_median']:.1f} mired, "
        f"median |error| {e['lights']['error_median_abs']:.1f} mired, stated sd "
        f"{e['lights']['sd_stated_median']:.1f} mired" for w, e in ref["waters"].items())
    src = first["reference"][WITH_REF]["dtau_source"]
    return ["", "## The surface reference shot (issue 47, item 6)", "",
            f"{ref['n']} charts per water type (seed {ref['seed']}, its own draws), the "
            "attenuation criterion's waters, depth 1-15 m, distance 0.5-3 m, exposure unknown, "
            "the other nuisances of the default budget drawn from their priors (the `priors` "
            "world). The surface daylight is drawn from the budget's 30-mired prior; the "
            "reference shot is the same chart and camera in air under it (the independent "
            "renderer, its noise), its light fitted by `sca.reference.measure_light`; the sky "
            "then changes by N(0, sky_sd) mired (`sca.reference.sky_sd` at "
            f"{ref['minutes']:g} min: {first['lights']['sky_change_sd']:.1f} mired) and the "
            "chart underwater is rendered under the changed light and fitted with "
            "`uncertain=with_reference(None, lights)` (one batch, each chart its own measured "
            "prior), and on the same photos with the default budget. `sky-beyond`: the same "
            f"charts, the sky changed by {BEYOND_SD[0]:g}-{BEYOND_SD[1]:g} x the stated sd "
            "(either sign); honest there means flagged or covered. " + lights + ". "
            f"Each cell: coverage · ±median half-width (binomial p; bold below "
            f"{CONSISTENCY_P}). Δτ(λ): the median 95 % half-width of the optical depth "
            f"tau = c (d + L) among the reliable charts ({src}), against the issue's target "
            f"<= {DTAU_TARGET:.2f} (✗: above it). Run time {ref['elapsed_s']:.0f} s.", ""] + \
        _ref_table(ref) + [""] + [f"- {t}" for t in _reference_verdict(ref)] + \
        [f"- {t}" for t in _beyond_text(ref)]


def holds(ref) -> dict:
    """The reference world's criterion per fit with the reference: covered at the nominal
    rate (its test, :func:`experiments.honesty.test_of`), pooled over both water types."""
    s = ref["pooled"]["reference"][WITH_REF]
    return {f"reference: {dict(reported_quantities()).get(k, k)}":
            bool(v["p"] is None or v["p"] >= CONSISTENCY_P) for k, v in s["coverage"].items()}


# --------------------------------------------------------------------------- the residual term
#: The per-patch terms tried by :func:`residual_patch` (relative).
RESIDUAL_GRID = (0.0015, 0.003, 0.006, 0.01, 0.015)


def residual_patch(n: int = 10, seed: int = SEED, grid=RESIDUAL_GRID) -> dict:
    """The per-patch term the chart's response measured in air leaves (decision
    0079-reference-patch-response): the reference world's charts (clear and coastal) fitted
    with their lights and responses at each per-patch term of ``grid``, the pooled chi^2/dof
    of each, and the term at which it is 1 (method of moments, interpolated in log-log:
    chi^2 falls as the term grows), with the light alone for comparison.

    Returns
    -------
    dict
        'grid', 'chi2_dof' {label: [pooled chi^2/dof per term]}, 'patch' {label: the term at
        chi^2/dof = 1 (NaN outside the grid)}, 'n', 'seed'.
    """
    streams = np.random.default_rng([seed, 47, 2]).spawn(len(C_WATERS))
    sets = [_draw_set(w, n, rng) for w, rng in zip(C_WATERS, streams)]
    chi2 = {}
    for label, response in ((RESPONSE, True), (WITH_REF, False)):
        chi2[label] = []
        for p in grid:
            num = den = 0.0
            for _, _, rendered, lights, _, _ in sets:
                budget = with_reference(None, lights, response=response)
                est = fit_set(rendered, budget | {"patch": p})
                num += float(np.nansum(est.chi2_dof * est.dof))
                den += float(np.sum(est.dof))
            chi2[label].append(num / den)
    x = np.log(np.asarray(grid, float))
    patch = {k: float(np.exp(np.interp(0.0, -np.log(v), x, left=np.nan, right=np.nan)))
             for k, v in chi2.items()}
    return {"grid": list(grid), "chi2_dof": chi2, "patch": patch, "n": n, "seed": seed}


def main(argv=None) -> int:
    """``python -m experiments.honesty [--quick] [--n N] [--c-n N] [--ref-n N] [--seed S] [--report P]
    [--json P] [--per-chart] [--strict]``.

    Parameters
    ----------
    argv : list of str, optional
        Arguments (default ``sys.argv[1:]``).

    Returns
    -------
    int
        0 (with ``--strict``: 1 when an acceptance criterion fails; the outputs are written
        either way).
    """
    parser = argparse.ArgumentParser(prog="python -m experiments.honesty",
                                     description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true",
                        help=f"{CHARTS_QUICK} charts per world instead of {CHARTS_FULL}")
    parser.add_argument("--n", type=int, default=None, help="charts per world")
    parser.add_argument("--c-n", type=int, default=None,
                        help="charts per world and water type of the attenuation coefficient's "
                             f"criterion (default {C_CHARTS_FULL}; --quick {C_CHARTS_QUICK})")
    parser.add_argument("--ref-n", type=int, default=None,
                        help="charts per water type of the reference-shot worlds (default "
                             f"{C_CHARTS_FULL}; --quick {C_CHARTS_QUICK}; 0: leave them out)")
    parser.add_argument("--seed", type=int, default=SEED)
    parser.add_argument("--report", default=str(ROOT / "HONESTY.md"))
    parser.add_argument("--json", default=str(ROOT / "benchmarks" / "honesty.json"))
    parser.add_argument("--strict", action="store_true",
                        help="exit 1 when an acceptance criterion fails")
    parser.add_argument("--per-chart", action="store_true",
                        help="also write every chart's truth and estimate into the JSON")
    args = parser.parse_args(argv)
    n = args.n or (CHARTS_QUICK if args.quick else CHARTS_FULL)
    def log(line):
        print(line, flush=True)

    out = run(n, args.seed, charts=args.per_chart, log=log)
    c_n = args.c_n or (C_CHARTS_QUICK if args.quick else C_CHARTS_FULL)
    out["attenuation"] = run_attenuation(c_n, args.seed, log=log)
    ref_n = C_CHARTS_QUICK if args.quick and args.ref_n is None else args.ref_n
    if ref_n != 0:
        out["reference"] = run_reference(ref_n or C_CHARTS_FULL, args.seed, log=log)
    out["illuminant_check"] = illuminant_check(seed=args.seed)
    out["command"] = "python -m experiments.honesty" + "".join(
        f" {flag} {v}" for flag, v in (("--n", args.n), ("--c-n", args.c_n),
                                      ("--ref-n", args.ref_n),
                                      ("--seed", None if args.seed == SEED else args.seed))
        if v is not None) + (" --quick" if args.quick else "")
    write_outputs(out, args.report, args.json)
    verdicts = acceptance(out["results"], out["attenuation"], out.get("reference"))
    for v in verdicts:
        print(f"{'holds' if v['holds'] else 'FAILS'}: {v['criterion']}")
    print(f"{out['elapsed_s']:.0f} s; wrote {args.report} and {args.json}")
    return 0 if all(v["holds"] for v in verdicts) or not args.strict else 1


if __name__ == "__main__":
    sys.exit(main())
