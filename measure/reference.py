"""The surface reference shot read from a photo: the light at the site measured from a chart
photographed in air (:mod:`sca.reference`; decision 0069-reference-shot)."""

from __future__ import annotations

import numpy as np

from forward.errors import InputError
from sca.reference import measure_light

from .chart import LAYOUTS, orientations, sample_patches
from .detect import find_chart

__all__ = ["reference_light"]


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
        Naming '--reference' when the chart's grey row does not fall from white to black.
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
    return measure_light(s.rgb, sigma, setup)
