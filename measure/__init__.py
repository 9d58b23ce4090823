"""uw3p measure: photographs of a ColorChecker in, measurements of the water and corrected
images out (read -> sample -> calibrate -> measure -> correct).

Above :mod:`forward` and :mod:`sca`; the ``uw3p calibrate`` and ``uw3p measure`` commands are
thin wrappers of these functions.
"""

from .camera import Profile, calibrate, camera_setup, load_profile
from .chart import LAYOUTS, ChartLayout, PatchSample, orientations, parse_corners, sample_patches
from .detect import ChartNotFound, Detection, find_chart
from .dive import DiveResult, measure_dive, read_metadata
from .image import Photo, demosaic, read_image
from .measurement import MEASURE_BLOCKING, Measurement, correction, measure
from .output import corrected_image, srgb_preview, write_outputs

__all__ = ["Photo", "read_image", "demosaic", "ChartLayout", "LAYOUTS", "PatchSample",
           "parse_corners", "sample_patches", "orientations", "find_chart", "Detection",
           "ChartNotFound", "Profile", "calibrate",
           "camera_setup", "load_profile", "Measurement", "measure", "correction",
           "MEASURE_BLOCKING", "write_outputs", "corrected_image", "srgb_preview",
           "measure_dive", "read_metadata", "DiveResult"]
