"""The camera a correction uses and the check that the photo was taken with it.

A measurement (measurement.json) and a dive's joint fit (joint.json) record their camera
(:func:`measure.camera.camera_record`): the curves' name and digest, the photo's EXIF Make and
Model and the calibration profile (its gains, path and digest). A correction

- applies that calibration (:func:`correction_setup`): the profile given (``profile``,
  ``uw3p correct --profile``), else the recorded one, read again from its recorded path and
  refused (naming ``profile``) when it is not there or is no longer the same calibration (its
  digest); a record from before profiles were recorded by path keeps its recorded gains;
- refuses a photo whose EXIF Make and Model differ from the recorded camera's
  (:func:`check_photo_camera`, naming ``camera``) unless other curves are given (``camera``);
- says which camera and calibration it applied (:func:`CameraUse.to_dict`), and when the
  record is older than these fields, that the photo's camera could not be checked.
"""

from __future__ import annotations

import os
from dataclasses import dataclass, field
from pathlib import Path

import forward
from forward.errors import InputError

__all__ = ["CameraUse", "check_photo_camera", "correction_setup"]


@dataclass
class CameraUse:
    """The camera and calibration a correction applied.

    Attributes
    ----------
    recorded : dict
        The water's recorded camera (``{}``: none recorded).
    curves : str
        The curves' name used.
    profile : dict or None
        The calibration applied: ``path`` (None: recorded gains), ``sha256``, ``gains``.
    notes : list of str
    """

    recorded: dict
    curves: str
    profile: dict | None = None
    notes: list = field(default_factory=list)

    def to_dict(self) -> dict:
        """correction.json's ``camera``."""
        return {"recorded": self.recorded or None, "curves": self.curves,
                "profile": self.profile}


def _recorded_profile(prof: dict):
    """The recorded calibration: (Profile or None, its gains, path); refused naming
    ``profile`` when it was recorded by path and is not found there as it was."""
    from .camera import load_profile, profile_digest

    if not prof.get("sha256"):  # recorded before profiles were recorded by path: its gains
        return None, prof.get("gains") or None, None
    path = prof.get("path")
    if not (path and Path(path).is_file()):
        raise InputError("profile", f"the water was measured with the calibration "
                         f"{path or '(given in memory)'}, which is not there: give it")
    loaded = load_profile(path)
    if profile_digest(loaded) != prof["sha256"]:
        raise InputError("profile", f"{path} is no longer the calibration the water was "
                         "measured with (its digest differs): give that one")
    return loaded, loaded.gains, path


def _given_profile(profile):
    from .camera import load_profile

    if isinstance(profile, (str, bytes, os.PathLike)):
        return load_profile(profile), os.path.abspath(os.fsdecode(profile))
    return profile, None


def correction_setup(recorded: dict, *, camera=None, quantal=None, illuminant=None,
                     profile=None):
    """The set-up a correction uses: the recorded camera with its calibration, the
    options given over it.

    Parameters
    ----------
    recorded : dict
        The water's ``camera`` (``{}`` when none is recorded: the default camera).
    camera, quantal, illuminant : optional
        Other curves, their kind and illuminant (default the recorded ones).
    profile : Profile, str or os.PathLike, optional
        Another calibration (default the recorded one, for the recorded curves).

    Returns
    -------
    (forward.ChartSetup, CameraUse)

    Raises
    ------
    InputError
        Naming ``profile`` (the recorded calibration not found) or ``setup`` (custom curves
        recorded and none given).
    """
    from .camera import camera_setup, profile_digest

    name = recorded.get("name", forward.DEFAULT_CAMERA)
    if camera is None and name == "custom":
        raise InputError("setup", "the measurement used custom camera curves; give the camera "
                         "(setup=, or --camera)")
    use = CameraUse(dict(recorded), str(camera or name))
    prof, gains, path = None, None, None
    if profile is not None:
        prof, path = _given_profile(profile)
        gains = prof.gains
    elif recorded.get("profile") and (camera is None or str(camera) == name):
        prof, gains, path = _recorded_profile(recorded["profile"])
    elif recorded.get("profile"):
        use.notes.append(f"the water's calibration is for {name}: not applied to {camera}")
    if gains is not None:
        use.profile = {"path": path, "sha256": None if prof is None else profile_digest(prof),
                       "gains": list(gains)}
        rec_sha = (recorded.get("profile") or {}).get("sha256")
        if profile is not None and rec_sha and use.profile["sha256"] != rec_sha:
            use.notes.append("the calibration given is not the one the water was measured with")
    ill = illuminant if illuminant is not None else recorded.get("illuminant")
    if isinstance(ill, str) and ill == "custom":
        raise InputError("illuminant", "the water was measured under an illuminant given as "
                         "spectra, which its record does not hold: give it again "
                         "(--illuminant)")
    q = bool(recorded.get("quantal", False)) if quantal is None else bool(quantal)
    setup = camera_setup(camera or name, quantal=q, gains=gains,
                         illuminant=None if ill in (None, "D65") else ill)
    return setup, use


def check_photo_camera(photo_camera: dict, use: CameraUse, *, other_curves: bool) -> None:
    """Refuse a photo taken with another camera than the water's (EXIF Make and Model), or
    note that it could not be checked (``use.notes``).

    Parameters
    ----------
    photo_camera : dict
        The photo's ``make`` and ``model`` (:attr:`measure.Photo.camera`).
    use : CameraUse
        The correction's camera (its ``recorded`` Make and Model).
    other_curves : bool
        Other curves were given (``camera``): a difference is noted, not refused.

    Raises
    ------
    InputError
        Naming ``camera``, when the two differ and no other curves were given.
    """
    rec = tuple(use.recorded.get(k) for k in ("make", "model"))
    own = tuple((photo_camera or {}).get(k) for k in ("make", "model"))
    if not all(rec) or not all(own):
        use.notes.append("the photo's camera could not be checked against the water's "
                         "(EXIF Make and Model not recorded in both)")
        return
    if own == rec:
        return
    said = f"the photo was taken with {' '.join(own)}, the water measured with {' '.join(rec)}"
    if not other_curves:
        raise InputError("camera", f"{said}: its gain and veiling light do not hold for this "
                         "camera (give --camera with this camera's curves to correct anyway)")
    use.notes.append(f"{said}: corrected with {use.curves}'s curves")
