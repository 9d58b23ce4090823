"""The worlds of a dive drawn from the default budget's own priors (DIVE.md): one water, chart,
camera and light per dive, each photo its own depth, distance, exposure and its own part of the
per-patch error (:data:`sca.joint.PATCH_CORRELATION`), the depths and distances told with the
budget's errors. Used by :mod:`experiments.dive_honesty` (the statistics) and
:mod:`experiments.dive_acceptance` (whole photographs).
"""

from __future__ import annotations

import numpy as np

from . import independent_world as iw
from .honesty import CDOM_RANGE, CHL_RANGE, CLEAN_OPTIONS, EXPOSURE_RANGE, _daylight_draws

__all__ = ["DIVE_DEPTHS", "DIVE_DISTANCES", "MIXED_FACTOR", "PHOTOS", "draw_dive",
           "photo_options"]

#: Photos per budget-prior dive.
PHOTOS = 4
#: C of the odd photo of a mixed dive, times the dive's.
MIXED_FACTOR = 5.0
#: Depth and distance ranges of a dive's photos (uniform), m: the issue's 2-15 m x 1-3 m.
DIVE_DEPTHS, DIVE_DISTANCES = (2.0, 15.0), (1.0, 3.0)


def _log_uniform(rng, lo_hi):
    return float(np.exp(rng.uniform(np.log(lo_hi[0]), np.log(lo_hi[1]))))


def _percent(text) -> float:
    return float(str(text).rstrip("%")) / 100.0


def draw_dive(rng: np.random.Generator, n: int = PHOTOS, mixed: bool = False, *, water=None,
              photos=None, patch_factor: float = 1.0) -> dict:
    """The truth of one budget-prior dive: its water, chart, camera, light, slopes and photos.

    Parameters
    ----------
    rng : numpy.random.Generator
    n : int
        Photos (ignored where ``photos`` is given).
    mixed : bool
        The last photo's C is ``MIXED_FACTOR`` times the others'.
    water : (float, float), optional
        The water's (C, a_CDOM(440)); default drawn log-uniform in the honesty ranges.
    photos : sequence of (depth, distance), optional
        The photos' true depths and distances, m; default drawn uniform in
        :data:`DIVE_DEPTHS` x :data:`DIVE_DISTANCES`.
    patch_factor : float
        The per-patch reflectance error's sd times the budget's (1: within the budget).

    Returns
    -------
    dict
        'chl', 'cdom' (the water), 'chl_photo' (n,), 'options' (renderer options shared by
        the photos), 'photo_factors' (n, 24) each photo's own per-patch reflectance factors,
        'depth', 'distance', 'exposure' (n,) true, 'depth_told', 'distance_told' (n,),
        'mixed'.
    """
    from sca.budget import DEFAULT_UNCERTAIN
    from sca.joint import PATCH_CORRELATION

    u = DEFAULT_UNCERTAIN
    chl, cdom = water if water is not None else (_log_uniform(rng, CHL_RANGE),
                                                 _log_uniform(rng, CDOM_RANGE))
    shared = np.sqrt(PATCH_CORRELATION) * u["patch"] * patch_factor
    own = np.sqrt(1.0 - PATCH_CORRELATION) * u["patch"] * patch_factor
    opts = {**CLEAN_OPTIONS,
            "reflectance_factors": tuple(1 + rng.normal(0, shared, 24)),
            "camera_gains": tuple(1 + rng.normal(0, u["balance"], 3)),
            "camera_shift_nm": tuple(rng.normal(0, u["camera_shift"], 3)),
            "daylight_mired": float(_daylight_draws(rng, 1)[0]),
            "cdom_slope": float(rng.normal(iw.CDOM_SLOPE_PER_NM, u["cdom_slope"])),
            "nap_slope": float(rng.normal(iw.NAP_SLOPE_PER_NM, u["nap_slope"]))}
    if photos is None:
        depth, distance = rng.uniform(*DIVE_DEPTHS, n), rng.uniform(*DIVE_DISTANCES, n)
    else:
        depth, distance = (np.array(x, float) for x in zip(*photos))
        n = depth.size
    chl_photo = np.full(n, chl)
    if mixed:
        chl_photo[-1] *= MIXED_FACTOR
    rel = _percent(u["distance"])
    return {"chl": chl, "cdom": cdom, "chl_photo": chl_photo, "options": opts,
            "photo_factors": 1 + rng.normal(0, own, (n, 24)), "depth": depth,
            "distance": distance, "exposure": rng.uniform(*EXPOSURE_RANGE, n),
            "depth_told": depth + rng.normal(0, u["depth"], n),
            "distance_told": distance * (1 + rng.normal(0, rel, n)), "mixed": mixed}


def photo_options(dive: dict, i: int, **extra) -> dict:
    """The renderer options of photo ``i`` of ``dive``: the dive's, its exposure, and its own
    reflectance factors (times the chart's) where the dive has them."""
    opts = {**dive["options"], "exposure": float(dive["exposure"][i]), **extra}
    if dive.get("photo_factors") is not None:
        opts["reflectance_factors"] = tuple(np.asarray(dive["options"]["reflectance_factors"])
                                            * np.asarray(dive["photo_factors"][i]))
    return opts
