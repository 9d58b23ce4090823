"""The cruise-blocked split of the NOMAD stations and the cruise-clustered bootstrap (REALWATER.md).

Stations of one cruise share their water (consecutive rows' log C correlate at 0.83), so a
split by row holds out stations, not waters. :func:`cruise_split` draws random halves of the
cruises (fixed seed :data:`SPLIT_SEED`, chosen before any result was seen; decision
0081-cruise-blocked-realwater): no test station's cruise has a training station. Everything
learned from NOMAD for a comparison is learned on the training cruises only.

:func:`cluster_bootstrap` gives a 95 % percentile interval of a statistic by resampling whole
cruises with replacement (:data:`BOOTSTRAP_RESAMPLES` resamples, seed :data:`BOOTSTRAP_SEED`):
stations of one cruise are not independent, so resampling stations would understate the
uncertainty.
"""

from __future__ import annotations

import numpy as np

from forward.errors import InputError

__all__ = ["BOOTSTRAP_RESAMPLES", "BOOTSTRAP_SEED", "SPLIT_SEED", "cluster_bootstrap",
           "cruise_split"]

#: The seed of the cruise split (fixed before any result was seen).
SPLIT_SEED = 20240
#: Resamples of the cruise-clustered bootstrap, and its seed.
BOOTSTRAP_RESAMPLES = 1000
BOOTSTRAP_SEED = 0


def cruise_split(cruise, seed: int = SPLIT_SEED) -> np.ndarray:
    """Random halves of the cruises: True for a station of a training cruise.

    Parameters
    ----------
    cruise : array_like of str, (N,)
        Each station's cruise.
    seed : int, optional
        The permutation's seed (default :data:`SPLIT_SEED`).

    Returns
    -------
    ndarray of bool, (N,)
        The training stations: those of the first floor(n / 2) cruises of a random permutation
        of the n distinct cruises (sorted first, so the split depends on the names only).

    Raises
    ------
    InputError
        Naming ``cruise`` when there are fewer than two cruises.
    """
    cruise = np.asarray(cruise).astype(str)
    names = np.unique(cruise)
    if names.size < 2:
        raise InputError("cruise", f"{names.size} distinct cruise(s); a split needs at least 2")
    order = np.random.default_rng(seed).permutation(names.size)
    return np.isin(cruise, names[order[: names.size // 2]])


def cluster_bootstrap(statistic, clusters, n_resamples: int = BOOTSTRAP_RESAMPLES,
                      seed: int = BOOTSTRAP_SEED, level: float = 0.95) -> tuple:
    """Percentile interval of ``statistic`` under resampling of whole clusters.

    Parameters
    ----------
    statistic : callable
        ``statistic(index) -> float`` of the stations ``index`` (an index array, repeats
        allowed).
    clusters : array_like, (N,)
        Each station's cluster (its cruise).
    n_resamples : int, optional
        Bootstrap resamples (default :data:`BOOTSTRAP_RESAMPLES`).
    seed : int, optional
        The resampling's seed.
    level : float, optional
        The interval's coverage (default 0.95).

    Returns
    -------
    tuple of float
        (lower, upper); NaN, NaN without stations.
    """
    _, inverse = np.unique(np.asarray(clusters).astype(str), return_inverse=True)
    if inverse.size == 0:
        return np.nan, np.nan
    order = np.argsort(inverse, kind="stable")  # the stations cluster by cluster
    sizes = np.bincount(inverse)
    starts = np.cumsum(sizes) - sizes
    draws = np.random.default_rng(seed).integers(0, sizes.size, size=(n_resamples, sizes.size))
    values = np.array([statistic(order[_members(starts[d], sizes[d])]) for d in draws])
    tail = 100 * (1 - level) / 2
    lo, hi = np.nanpercentile(values, [tail, 100 - tail])
    return float(lo), float(hi)


def _members(starts, sizes) -> np.ndarray:
    """Positions in the cluster-sorted stations of the clusters starting at ``starts`` with
    ``sizes`` members (repeats allowed), concatenated."""
    ends = np.cumsum(sizes)
    return np.repeat(starts - (ends - sizes), sizes) + np.arange(ends[-1] if ends.size else 0)
