"""Shared pieces of the estimation figures (Figs 9-13, noise study): conditions and plotting."""

from __future__ import annotations

import itertools

import numpy as np

from . import sweep
from .grids import grid as get_grid

__all__ = ["fig10_conditions", "fig12_conditions", "distance_conditions", "condition_kw",
           "mean_se", "resolve", "fit_header", "fit_row"]


def condition_kw(s: dict) -> dict:
    """The keyword arguments of :func:`experiments.sweep.condition` for a setting of
    :data:`experiments.grids.SETTINGS` (light, exposure, the estimator's grid, the world).

    Parameters
    ----------
    s : dict
        A setting (:func:`experiments.grids.setting`).

    Returns
    -------
    dict
        ``illuminance_lux``, ``exposure``, ``estimation_step_nm``, ``world`` and, for the
        independent world, ``world_options``.
    """
    from .grids import INDEPENDENT_OPTIONS

    kw = dict(illuminance_lux=s["illuminance_lux"], exposure=s["exposure"],
              estimation_step_nm=s["estimation_step_nm"], world=s.get("world", "forward"))
    if kw["world"] == "independent":
        kw["world_options"] = INDEPENDENT_OPTIONS
    return kw


def fig10_conditions(g, illuminance_lux=20000.0, exposure="capped", estimation_step_nm=1.0,
                     **world):
    """The conditions of Fig 10 on grid ``g`` (``world``: :func:`experiments.sweep.condition`'s
    ``world`` and ``world_options``)."""
    return [sweep.condition(c, a, d, r, s, illuminance_lux=illuminance_lux, exposure=exposure,
                            estimation_step_nm=estimation_step_nm, **world)
            for d, r, c, a, s in itertools.product(g["fig10_depths_m"], g["fig10_distances_m"],
                                                   g["fig10_chl"], g["fig10_cdom"],
                                                   range(g["fig10_seeds"]))]


def fig12_conditions(g, depths=None, illuminance_lux=20000.0, exposure="capped",
                     estimation_step_nm=1.0, **world):
    """The conditions of Figs 12-13 on grid ``g`` at distance ``fig12_distance_m``."""
    depths = g["fig12_depths_m"] if depths is None else depths
    return [sweep.condition(c, a, d, g["fig12_distance_m"], s, illuminance_lux=illuminance_lux,
                            exposure=exposure, estimation_step_nm=estimation_step_nm, **world)
            for d, c, a, s in itertools.product(depths, g["fig12_chl"], g["fig12_cdom"],
                                                range(g["fig12_seeds"]))]


def distance_conditions(g, illuminance_lux=20000.0, exposure="capped", estimation_step_nm=1.0,
                        **world):
    """The conditions of Figs 12-13 against distance: the Fig 12 grid of C x a_CDOM x seeds at
    depth ``distance_depth_m`` and each distance of ``distance_study_m``."""
    return [sweep.condition(c, a, g["distance_depth_m"], r, s, illuminance_lux=illuminance_lux,
                            exposure=exposure, estimation_step_nm=estimation_step_nm, **world)
            for r, c, a, s in itertools.product(g["distance_study_m"], g["fig12_chl"],
                                                g["fig12_cdom"], range(g["fig12_seeds"]))]


def mean_se(values):
    v = np.asarray(values, float)
    se = v.std(ddof=1) / np.sqrt(v.size) if v.size > 1 else float("nan")
    return float(v.mean()), float(se)


def resolve(grid_name):
    return get_grid(grid_name)


def fit_header():
    """Columns of the per-fit CSVs (``*_fits.csv``)."""
    return ["chl", "cdom", "depth_m", "distance_m", "illuminance_lux", "exposure",
            "estimation_step_nm", "world", "seed", "chl_hat", "cdom_hat", "rrmse_k", "converged",
            "iterations", "status"]


def fit_row(x):
    """One sweep result as a row of :func:`fit_header`."""
    return [x["chl"], x["cdom"], x["depth"], x["distance"], x["illuminance_lux"],
            x.get("exposure", "capped"), f"{x.get('estimation_step_nm', 1.0):g}",
            x.get("world", "forward"), x["seed"],
            f"{x['chl_hat']:.8g}", f"{x['cdom_hat']:.8g}", f"{x['rrmse_k']:.6g}", x["converged"],
            x["iterations"], x["status"]]
