"""uw3p measure: photographs of a ColorChecker in, measurements of the water and corrected
images out (read -> sample -> calibrate -> measure -> correct).

Above :mod:`forward` and :mod:`sca`; the ``uw3p calibrate`` and ``uw3p measure`` commands are
thin wrappers of these functions.

The public names are loaded on first use (PEP 562 module ``__getattr__``, as :mod:`sca`): one
photo's measurement does not import the dive's machinery (Dask, the joint fit and scipy's
optimisers and statistics) it does not use (decision 0007-start-up).
"""

from __future__ import annotations

from forward.lazy import lazy_exports

#: Where each public name lives (submodule of ``measure``).
_HOME = {
    "Profile": "camera", "calibrate": "camera", "camera_setup": "camera",
    "reference_light": "reference",
    "load_profile": "camera",
    "LAYOUTS": "chart", "ChartLayout": "chart", "PatchSample": "chart",
    "orientations": "chart", "parse_corners": "chart", "sample_patches": "chart",
    "ChartNotFound": "detect", "Detection": "detect", "find_chart": "detect",
    "DiveResult": "dive", "measure_dive": "dive", "read_metadata": "dive",
    "JointPhoto": "joint", "fit_joint": "joint",
    "Photo": "image", "demosaic": "image", "read_image": "image",
    "MEASURE_BLOCKING": "measurement", "Measurement": "measurement", "budget_for": "measurement",
    "correction": "correct", "measure": "measurement",
    "corrected_image": "output", "srgb_preview": "output", "write_outputs": "output",
    "Corrected": "correct", "CorrectionTable": "correct", "correct_image": "correct",
    "correction_table": "correct", "seathru_coefficients": "correct",
    "CorrectionWater": "correctwater", "correction_water": "correctwater",
    "correction_spread": "correct_uncertainty", "read_range": "rangemap",
    "write_corrected": "correct_output",
}
#: The public names: every name of :data:`_HOME`.
__all__ = list(_HOME)

__getattr__, __dir__ = lazy_exports(__name__, globals(), _HOME, __all__)
