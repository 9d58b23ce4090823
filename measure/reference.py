"""The surface reference shot read from a photo: the light at the site measured from a chart
photographed in air (:mod:`sca.reference`; decision 0069-reference-shot)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from forward.errors import InputError
from sca.reference import (REFERENCE_MINUTES, bracket, check_daylight, measure_light, sky_sd,
                           with_reference)

from .chart import LAYOUTS, orientations, sample_patches
from .detect import find_chart

__all__ = ["parse_reference", "reference_budget", "reference_light"]


def parse_reference(text, base=None, argument: str = "--reference") -> tuple:
    """(photo, minutes) of ``PHOTO[:MINUTES]`` (minutes :data:`sca.reference.REFERENCE_MINUTES`
    when not given), the photo relative to ``base`` (a folder) where given.

    Raises
    ------
    forward.errors.InputError
        Naming ``argument``: a malformed text, negative minutes, a missing file.
    """
    text = str(text).strip()
    photo, minutes = text, REFERENCE_MINUTES
    head, sep, tail = text.rpartition(":")
    if sep and head and not Path(base or ".", text).exists():
        try:
            minutes = float(tail)
        except ValueError:
            raise InputError(argument, f"expected PHOTO[:MINUTES], got {text!r}") from None
        photo = head
    try:
        sky_sd(minutes)
    except InputError as exc:
        raise InputError(argument, exc.reason) from None
    path = Path(base or ".", photo)
    if not path.is_file():
        raise InputError(argument, f"file not found: {path}")
    return str(path), minutes


def reference_budget(uncertain, shots, read, setup, layout="patches"):
    """``uncertain`` with the daylight measured by one reference shot or two bracketing the
    dive (:func:`sca.reference.bracket`): ``shots`` a list of (photo, minutes), ``read`` the
    function that reads a photo (:func:`measure.read_image` with the run's levels).

    Raises
    ------
    forward.errors.InputError
        Naming '--reference' for more than two shots or a chart not found the right way.
    """
    if not shots or uncertain == {}:
        return uncertain
    if len(shots) > 2:
        raise InputError("--reference", f"at most two reference shots (before and after the "
                         f"dive), got {len(shots)}")
    lights = [reference_light(read(photo), setup, layout) for photo, _ in shots]
    light = lights[0] if len(lights) == 1 else bracket(lights, [t for _, t in shots])
    return with_reference(uncertain, light, shots[0][1], "measured at the site by "
                          + " and ".join(str(photo) for photo, _ in shots))


def reference_light(photo, setup, layout="patches"):
    """The surface light measured from a photo of the chart in air at the site (a reference
    shot, :func:`sca.reference.measure_light`; decision 0069-reference-shot): the chart found
    (:func:`measure.find_chart`), its patches sampled (clipped values left out) and the
    daylight's colour fitted against ``setup`` (the camera as the photos underwater are fitted).

    Parameters
    ----------
    photo : measure.image.Photo
        The reference shot.
    setup : forward.ChartSetup
        Camera, illuminant and chart (:func:`camera_setup`).
    layout : str, optional
        The chart's layout (:data:`measure.LAYOUTS`).

    Returns
    -------
    sca.reference.Light

    Raises
    ------
    forward.errors.InputError
        Naming '--reference' when the chart's grey row does not fall from white to black, or
        when the light is not daylight (:func:`sca.reference.check_daylight`).
    """
    lay = LAYOUTS[layout]
    found = find_chart(photo, lay)
    found.check_in_frame(photo.size)
    corners, _, ok = orientations(photo, found.corners, lay)["as given"]
    if not ok:
        raise InputError("--reference", "the chart found in the reference shot does not run "
                         "from white to black along its grey row")
    s = sample_patches(photo, corners, lay)
    sigma = np.where(np.asarray(s.clipped) > 0, np.nan, np.asarray(s.sigma, float))
    return check_daylight(measure_light(s.rgb, sigma, setup))
