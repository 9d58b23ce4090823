"""One water from a dive's photographs: :func:`sca.joint.estimate_joint` on the measurements
(measurement.json records) of ``uw3p measure``.

Each photo brings its sampled patches and their standard errors, its depth and distance with
their sds, its light field and its own fit (the starting point); the camera setup (with the
profile's balance) and the water model are the run's. Photos whose own fit cannot be trusted as
data (:data:`EXCLUDED_FLAGS`) are left out, each with its reason.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np

import sca.joint
from forward.water import resolve_water
from sca.budget import parse_sd

from .auxiliary import dive_auxiliary
from .measurement import CLIPPED_SIGMA

__all__ = ["CARRIED_FLAGS", "EXCLUDED_FLAGS", "PER_PHOTO_TERMS", "fit_joint"]

#: A photo whose own measurement has one of these flags does not enter the joint fit.
EXCLUDED_FLAGS = ("misfit", "not-converged", "saturated", "orientation-unverified",
                  "noise-unknown")
#: Terms of the uncertainty budget that are each photo's own (its depth and distance sds);
#: the others (the water's constants, the camera's, the chart's) are shared by the photos
PER_PHOTO_TERMS = ("depth", "distance")
#: Flags of the photos' measurements that hold for the joint estimate too (the camera's).
CARRIED_FLAGS = ("uncalibrated-camera", "unreliable-profile")


def _arrays(rec):
    """(M, sigma) of one record: clipped or unmeasured values left out (sigma inf)."""
    p = rec["patches"]
    M = np.maximum(np.asarray(p["rgb"], float), 0.0)
    sig = np.asarray([[np.nan if v is None else v for v in row] for row in p["sigma"]], float)
    clipped = np.asarray(p.get("clipped", np.zeros(M.shape)), float) > 0
    ok = np.isfinite(sig) & (sig > 0) & ~clipped & (sig < CLIPPED_SIGMA * max(M.max(), 1e-300))
    return M, np.where(ok, sig, np.inf)


def _sd(name, value, reference) -> float:
    """A recorded sd (m, or a percentage string) as metres; 0 where none was applied."""
    return 0.0 if value is None else float(parse_sd(name, value, reference))


def _shared_budget(budgets):
    """The budget the photos share: each photo's own depth and distance sds
    (:data:`PER_PHOTO_TERMS`) may differ, every other term must be the same."""
    shared = [{k: v for k, v in (b or {}).items() if k not in PER_PHOTO_TERMS} for b in budgets]
    differ = sorted({k for b in shared[1:] for k in set(b) | set(shared[0])
                     if b.get(k) != shared[0].get(k)})
    if differ:
        raise ValueError("records: the photos were measured with different values of the "
                         f"budget's shared term(s) {', '.join(differ)}; for one water they must "
                         "be the same (only depth and distance may differ from photo to photo): "
                         "measure the photos again with the same budget options and profile, "
                         "or give uncertain= to fit them with one budget")
    return budgets[0]  # its depth and distance are replaced by each photo's own sds


def _name(rec, i):
    path = (rec.get("image") or {}).get("path")
    return Path(path).name if path else f"photo {i + 1}"


def fit_joint(records, *, setup, water=None, uncertain=None, path_models=None,
              patch_correlation: float = sca.joint.PATCH_CORRELATION,
              auxiliary=None) -> sca.joint.JointEstimate:
    """The water shared by a dive's photographs.

    Parameters
    ----------
    records : sequence of dict or Measurement
        measurement.json contents (or :class:`measure.Measurement` objects) of the photos.
    setup : forward.ChartSetup
        The camera (the profile's balance applied), illuminant and chart of the run
        (:func:`measure.camera_setup`); each photo's light field is applied to it.
    water : forward.Water, optional
        The water model (default the paper's).
    uncertain : dict, optional
        The budget, its 'depth' and 'distance' for every photo; default: the one the photos
        were measured with (their ``inputs``: the shared terms, which must agree, and each
        photo's own depth and distance sds).
    path_models, patch_correlation :
        As :func:`sca.joint.estimate_joint`.
    auxiliary : dict, optional
        What was measured of the dive's water besides the photos (:mod:`sca.auxiliary`'s form),
        fused in the joint fit. Default: every reading the photos' fits used (their
        ``inputs['auxiliary']``, photos left out of the fit included: a reading of the water is
        not the photo's fit), each counted once and several readings of one quantity combined
        (:func:`measure.auxiliary.dive_auxiliary`); ``{}``: none.

    Returns
    -------
    sca.joint.JointEstimate
        With ``photos`` keyed by image name; photos left out are listed in ``notes`` and in
        the attribute ``excluded`` (name -> reason).

    Raises
    ------
    ValueError
        Naming ``records`` when there is no usable photo, or when the photos were measured
        with budgets that differ in a shared term (anything but :data:`PER_PHOTO_TERMS`) and
        ``uncertain`` is not given.
    """
    recs = [r.to_dict() if hasattr(r, "to_dict") else r for r in records]
    if not recs:
        raise ValueError("records: no measurement to combine")
    used, excluded = [], {}
    for i, rec in enumerate(recs):
        flags = set((rec.get("estimate") or {}).get("flags", []))
        bad = sorted(flags & set(EXCLUDED_FLAGS))
        if bad:
            excluded[_name(rec, i)] = "its own fit is flagged " + ", ".join(bad)
        else:
            used.append((i, rec))
    if not used:
        raise ValueError("records: no photo can enter the joint fit (" + "; ".join(
            f"{k}: {v}" for k, v in excluded.items()) + ")")
    given = uncertain is not None  # an explicit budget replaces the photos' own sds
    if not given:
        uncertain = _shared_budget([(r.get("inputs") or {}).get("uncertain") for _, r in used])
    M, sigma, setups, depth, distance, dsd, rsd = [], [], [], [], [], [], []
    start = {"chl": [], "cdom": [], "gain": [], "backscatter": []}
    for _, rec in used:
        m_, s_ = _arrays(rec)
        M.append(m_)
        sigma.append(s_)
        field = (rec.get("light_field") or {}).get("field")
        setups.append(setup if not field or (rec.get("light_field") or {}).get("model") == "none"
                      else dataclasses.replace(setup, reflectances=setup.reflectances
                                               * np.asarray(field, float)[None, :]))
        inp = rec.get("inputs") or {}
        depth.append(float(inp["depth_m"]))
        distance.append(float(inp["distance_m"]))
        dsd.append(_sd("depth", inp.get("depth_sd"), depth[-1]))
        rsd.append(_sd("distance", inp.get("distance_sd"), distance[-1]))
        est = rec["estimate"]
        for k in start:
            start[k].append(est[k])
    names = [_name(rec, i) for i, rec in used]
    if len(set(names)) < len(names):  # same file name in two folders: the full paths
        names = [(rec.get("image") or {}).get("path") or f"photo {i + 1}" for i, rec in used]
    if len(set(names)) < len(names):
        names = [f"{nm} (#{i + 1})" for i, nm in enumerate(names)]
    joint = sca.joint.estimate_joint(
        np.array(M), depth=np.array(depth), distance=np.array(distance), sigma=np.array(sigma),
        setup=setups, water=resolve_water(water), uncertain=uncertain,
        depth_sd=None if given else np.array(dsd),
        distance_sd=None if given else np.array(rsd), names=names,
        path_models=path_models, patch_correlation=patch_correlation,
        start={k: np.array(v, float) for k, v in start.items()},
        auxiliary=dive_auxiliary(recs) if auxiliary is None else auxiliary)
    carried = sorted({f for _, r in used for f in (r.get("estimate") or {}).get("flags", [])
                      if f in CARRIED_FLAGS})
    if carried:
        joint.flags = tuple(dict.fromkeys(joint.flags + tuple(carried)))
        joint.reliable = False
        joint.notes.append("the camera's calibration is not trusted (" + ", ".join(carried)
                           + "): the joint estimate is not reliable either")
    for k, v in excluded.items():
        joint.notes.append(f"{k} left out: {v}")
    joint.excluded = excluded
    return joint
