"""One water from a dive's photographs: :func:`sca.joint.estimate_joint` on the measurements
(measurement.json records) of ``uw3p measure``.

Each photo brings its sampled patches and their standard errors, its depth and distance with
their sds, its light field and its own fit (the starting point); the camera setup (with the
profile's balance) and the water model are the run's. Photos whose own fit cannot be trusted as
data (:data:`EXCLUDED_FLAGS`) are left out, each with its reason.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from pathlib import Path

import numpy as np

import sca.joint
from forward.errors import InputError
from forward.water import resolve_water
from sca.budget import parse_sd

from .auxiliary import dive_auxiliary
from .measurement import CLIPPED_SIGMA
from .output import strict_json

__all__ = ["CARRIED_FLAGS", "EXCLUDED_FLAGS", "PER_PHOTO_TERMS", "READING_DEPENDENT", "JointPhoto",
           "fit_joint", "joint_photo"]

#: A photo whose own measurement has one of these flags does not enter the joint fit.
EXCLUDED_FLAGS = ("misfit", "not-converged", "saturated", "orientation-unverified",
                  "noise-unknown")
#: Of those, the flags a wrong auxiliary reading can raise on a good photo's own fit: a photo
#: whose reading contradicts it (``reading-conflict``) is not left out for them, so that the
#: joint fit never drops photos to agree with a reading (it tests the reading itself).
READING_DEPENDENT = ("misfit", "not-converged")
#: Terms of the uncertainty budget that are each photo's own (its depth and distance sds);
#: the others (the water's constants, the camera's, the chart's) are shared by the photos
PER_PHOTO_TERMS = ("depth", "distance")
#: Flags of the photos' measurements that hold for the joint estimate too (the camera's).
CARRIED_FLAGS = ("uncalibrated-camera", "unreliable-profile")
#: Each photo's own fit, the joint fit's start: C, a_CDOM(440), the gain, the veiling light.
START = ("chl", "cdom", "gain", "backscatter")


@dataclass(frozen=True, eq=False)  # arrays: compared field by field where needed
class JointPhoto:
    """One photograph as the joint fit takes it: typed, made from a :class:`measure.Measurement`
    in the run that measured it (:meth:`from_measurement`) or from its measurement.json when
    an earlier run did (:meth:`from_record`); the two give the same photo.

    Attributes
    ----------
    name : str
        The image's path ('' when unknown).
    M : numpy.ndarray, (3, 24)
        The sampled patch values, raw units (negative means at 0).
    sigma : numpy.ndarray, (3, 24)
        Their standard errors, raw units; ``inf`` where a value is left out (clipped or not
        measured).
    field : numpy.ndarray, (24,) or None
        The light field's factor on each patch (:mod:`measure.lightfield`); None: uniform.
    depth_m, distance_m : float
        The depth and the chart's distance the photo was measured with (m).
    depth_sd, distance_sd : float
        Their standard deviations as the photo's budget applied them (m; 0: none).
    budget : dict or None
        The uncertainty budget the photo was measured with (``inputs['uncertain']``).
    start : dict
        The photo's own fit: 'chl' (mg m^-3), 'cdom' (m^-1), 'gain', 'backscatter' (raw units).
    flags : tuple of str
        The photo's measurement's flags.
    auxiliary : tuple of dict
        The readings of the water its fit used (:func:`measure.auxiliary.auxiliary_record`'s
        entries).
    """

    name: str
    M: np.ndarray
    sigma: np.ndarray
    field: np.ndarray | None
    depth_m: float
    distance_m: float
    depth_sd: float
    distance_sd: float
    budget: dict | None
    start: dict
    flags: tuple
    auxiliary: tuple = ()

    @classmethod
    def from_measurement(cls, meas) -> "JointPhoto":
        """The photo of a :class:`measure.Measurement` (no measurement.json made or read)."""
        e, s, inp = meas.estimate, meas.sample, meas.inputs
        return cls._made(getattr(meas.photo, "path", None), s.rgb, s.sigma, s.clipped,
                         meas.light_field, inp, {k: getattr(e, k) for k in START}, meas.flags)

    @classmethod
    def from_record(cls, rec: dict) -> "JointPhoto":
        """The photo of a measurement.json's content."""
        p, est = rec["patches"], rec["estimate"]
        return cls._made((rec.get("image") or {}).get("path"), p["rgb"], p["sigma"],
                         p.get("clipped"), rec.get("light_field"), rec.get("inputs") or {},
                         {k: est.get(k) for k in START}, est.get("flags", ()))

    @classmethod
    def _made(cls, path, rgb, sigma, clipped, light_field, inputs, start, flags):
        M = np.maximum(np.asarray(rgb, float), 0.0)
        sig = np.asarray(sigma, float)  # None (JSON's NaN) -> nan
        clip = np.zeros(M.shape, bool) if clipped is None else np.asarray(clipped, float) > 0
        ok = np.isfinite(sig) & (sig > 0) & ~clip & (sig < CLIPPED_SIGMA * max(M.max(), 1e-300))
        lf = light_field or {}
        raw = lf.get("field")
        field = None if raw is None or lf.get("model") == "none" or np.size(raw) == 0 \
            else np.asarray(raw, float)
        depth, distance = float(inputs["depth_m"]), float(inputs["distance_m"])
        return cls(str(path or ""), M, np.where(ok, sig, np.inf), field, depth, distance,
                   _sd("depth", inputs.get("depth_sd"), depth),
                   _sd("distance", inputs.get("distance_sd"), distance),
                   inputs.get("uncertain"),
                   {k: (np.asarray(v, float) if k == "backscatter" else v)
                    for k, v in start.items()},
                   tuple(flags), tuple(inputs.get("auxiliary") or ()))


def joint_photo(source) -> JointPhoto:
    """A :class:`JointPhoto` from a JointPhoto, a :class:`measure.Measurement` or a
    measurement.json's content (dict)."""
    if isinstance(source, JointPhoto):
        return source
    if isinstance(source, dict):
        return JointPhoto.from_record(source)
    if hasattr(source, "estimate") and hasattr(source, "sample"):
        return JointPhoto.from_measurement(source)
    raise InputError("records", "each must be a measure.Measurement, a measurement.json's "
                     f"content (dict) or a measure.joint.JointPhoto, got {type(source)!r}")


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
        raise InputError("records", "the photos were measured with different values of the "
                         f"budget's shared term(s) {', '.join(differ)}; for one water they must "
                         "be the same (only depth and distance may differ from photo to photo): "
                         "measure the photos again with the same budget options and profile, "
                         "or give uncertain= to fit them with one budget")
    return budgets[0]  # its depth and distance are replaced by each photo's own sds


def _name(photo: JointPhoto, i: int) -> str:
    return Path(photo.name).name if photo.name else f"photo {i + 1}"


def fit_joint(records, *, setup, water=None, uncertain=None, path_models=None,
              patch_correlation: float = sca.joint.PATCH_CORRELATION,
              auxiliary=None) -> sca.joint.JointEstimate:
    """The water shared by a dive's photographs.

    Parameters
    ----------
    records : sequence of Measurement, JointPhoto or dict
        The photos: :class:`measure.Measurement` objects, :class:`JointPhoto` objects, or
        measurement.json contents (an earlier run's); each is read as a :class:`JointPhoto`.
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
    forward.InputError
        Naming ``records`` when there is no usable photo, or when the photos were measured
        with budgets that differ in a shared term (anything but :data:`PER_PHOTO_TERMS`) and
        ``uncertain`` is not given.
    """
    photos = [joint_photo(r) for r in records]
    if not photos:
        raise InputError("records", "no measurement to combine")
    used, excluded = [], {}
    for i, ph in enumerate(photos):
        bad = sorted(set(ph.flags) & set(EXCLUDED_FLAGS))
        if "reading-conflict" in ph.flags:  # its misfit may be the reading's: the dive decides
            bad = [b for b in bad if b not in READING_DEPENDENT]
        if bad:
            excluded[_name(ph, i)] = "its own fit is flagged " + ", ".join(bad)
        else:
            used.append((i, ph))
    if not used:
        raise InputError("records", "no photo can enter the joint fit (" + "; ".join(
            f"{k}: {v}" for k, v in excluded.items()) + ")")
    given = uncertain is not None  # an explicit budget replaces the photos' own sds
    if not given:
        uncertain = _shared_budget([strict_json(ph.budget) for _, ph in used])
    names = [_name(ph, i) for i, ph in used]
    if len(set(names)) < len(names):  # same file name in two folders: the full paths
        names = [ph.name or f"photo {i + 1}" for i, ph in used]
    if len(set(names)) < len(names):
        names = [f"{nm} (#{i + 1})" for i, nm in enumerate(names)]
    ph = [q for _, q in used]
    joint = sca.joint.estimate_joint(
        np.array([q.M for q in ph]), depth=np.array([q.depth_m for q in ph]),
        distance=np.array([q.distance_m for q in ph]), sigma=np.array([q.sigma for q in ph]),
        setup=[setup if q.field is None else dataclasses.replace(
            setup, reflectances=setup.reflectances * q.field[None, :]) for q in ph],
        water=resolve_water(water), uncertain=uncertain,
        depth_sd=None if given else np.array([q.depth_sd for q in ph]),
        distance_sd=None if given else np.array([q.distance_sd for q in ph]), names=names,
        path_models=path_models, patch_correlation=patch_correlation,
        start={k: np.array([q.start[k] for q in ph], float) for k in START},
        auxiliary=dive_auxiliary(photos) if auxiliary is None else auxiliary)
    carried = sorted({f for _, q in used for f in q.flags if f in CARRIED_FLAGS})
    if carried:
        joint.flags = tuple(dict.fromkeys(joint.flags + tuple(carried)))
        joint.reliable = False
        joint.notes.append("the camera's calibration is not trusted (" + ", ".join(carried)
                           + "): the joint estimate is not reliable either")
    for k, v in excluded.items():
        joint.notes.append(f"{k} left out: {v}")
    joint.excluded = excluded
    return joint
