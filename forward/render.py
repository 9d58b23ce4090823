"""Render simulated chart captures as sRGB images (the appearance figures, Figs 5-8).

The camera's raw values (mean ADC codes over full scale, so auto-exposure and its cap are
visible) are mapped to CIE XYZ with a 3x3 matrix fitted by least squares on the chart in air
under the surface illuminant (a standard camera characterisation), then encoded to sRGB with
colour-science. No white balance is applied: the water's colour cast is the point.
"""

from __future__ import annotations

import functools

import numpy as np

from .imaging import ChartSetup
from .spectra import cie_1931_cmfs, quadrature_weights
from forward.errors import InputError

__all__ = ["camera_to_xyz_matrix", "chart_image", "chart_xyz", "patch_srgb", "patches_image"]


@functools.lru_cache(maxsize=16)
def chart_xyz(setup: ChartSetup) -> np.ndarray:
    """CIE 1931 XYZ of the setup's chart under its illuminant in air: the colorimetric truth.

    Cached per setup.

    Parameters
    ----------
    setup : forward.ChartSetup
        The grid (nm), illuminant i and reflectances R.

    Returns
    -------
    numpy.ndarray, shape (n, 3)
        X, Y, Z of each patch, normalised so that Y of a perfect white = 1; read-only.

    References
    ----------
    CIE 1931 2-degree standard observer; the integral of eq 1 by the trapezoid rule.
    """
    cmfs = cie_1931_cmfs(setup.wavelengths)
    light = setup.illuminant * quadrature_weights(setup.wavelengths)
    xyz = (cmfs.T @ (light[:, None] * setup.reflectances)).T
    out = xyz / (cmfs[:, 1] @ light)
    out.setflags(write=False)
    return out


@functools.lru_cache(maxsize=16)
def camera_to_xyz_matrix(setup: ChartSetup) -> np.ndarray:
    """The 3 x m matrix from the camera's model-unit values to CIE XYZ (Y of a white in air = 1).

    Least-squares fitted on the setup's chart under its illuminant in air (a standard camera
    characterisation); cached per setup.

    Parameters
    ----------
    setup : forward.ChartSetup
        The camera's P, the illuminant i and the chart R.

    Returns
    -------
    numpy.ndarray, shape (3, m)
        XYZ = M @ camera values; read-only.
    """
    cam = setup.sensitivities.T @ (setup.illuminant[:, None] * setup.reflectances)  # (m, n)
    M, *_ = np.linalg.lstsq(cam.T, chart_xyz(setup), rcond=None)
    out = np.ascontiguousarray(M.T)  # (3, m)
    out.setflags(write=False)  # cached: read-only
    return out


def patch_srgb(sim, *, normalise: str = "exposure", encode: bool = True) -> np.ndarray:
    """sRGB values (n, 3) in [0, 1] of a :class:`forward.ChartSimulation`'s patches.

    The camera values are mapped to XYZ with :func:`camera_to_xyz_matrix` and encoded with
    colour-science (``colour.XYZ_to_sRGB``); no white balance. Values are clipped to [0, 1].

    Parameters
    ----------
    sim : forward.ChartSimulation
        The simulated capture.
    normalise : {'exposure', 'absolute', 'max'}, optional
        ``'exposure'`` (default): the raw codes over full scale (what the camera recorded, so
        deep scenes whose exposure hit its cap get darker); ``'absolute'``: the
        exposure-normalised ``rgb`` (a white reflector in air = 1), so everything fades with
        depth; ``'max'``: scaled so the brightest patch value is 1.
    encode : bool, optional
        Apply the sRGB transfer function (default True); ``False`` gives linear sRGB (the
        paper's Figs 5-6 are "not gamma encoded").

    Returns
    -------
    numpy.ndarray, shape (n, 3)
        sRGB in [0, 1], one row per patch.

    Raises
    ------
    ValueError
        For an unknown ``normalise``.

    References
    ----------
    IEC 61966-2-1 (sRGB); Blasinski & Farrell, Figs 5-8.
    """
    import colour

    if normalise == "exposure":
        cam = np.asarray(sim.codes) / (2 ** int(sim.sensor.adc_bits) - 1)
    elif normalise == "absolute":
        cam = np.asarray(sim.rgb)
    elif normalise == "max":
        cam = np.asarray(sim.rgb) / max(float(np.max(sim.rgb)), 1e-300)
    else:
        raise InputError("normalise", f"must be 'exposure', 'absolute' or 'max', got {normalise!r}")
    xyz = (camera_to_xyz_matrix(sim.setup) @ cam).T
    rgb = colour.XYZ_to_sRGB(xyz, apply_cctf_encoding=encode)
    return np.clip(rgb, 0.0, 1.0)


def chart_image(sim, *, rows: int = 4, cols: int = 6, patch_px: int = 20, gap_px: int = 3,
                **kwargs) -> np.ndarray:
    """An image (H, W, 3) of the chart, patches in reading order, black gaps between them.

    Parameters
    ----------
    sim : forward.ChartSimulation
        The simulated capture.
    rows, cols : int, optional
        The chart's layout (default 4 x 6, a ColorChecker); rows x cols must be its patch count.
    patch_px : int, optional
        Side of a patch, pixels (default 20).
    gap_px : int, optional
        Width of the black gaps and border, pixels (default 3).
    **kwargs
        Passed to :func:`patch_srgb` (``normalise``, ``encode``).

    Returns
    -------
    numpy.ndarray, shape (rows * (patch_px + gap_px) + gap_px, cols * (patch_px + gap_px) + gap_px, 3)
        sRGB image in [0, 1].
    """
    return patches_image(patch_srgb(sim, **kwargs), rows=rows, cols=cols, patch_px=patch_px,
                         gap_px=gap_px)


def patches_image(srgb, *, rows: int = 4, cols: int = 6, patch_px: int = 20,
                  gap_px: int = 3) -> np.ndarray:
    """Lay out patch colours (n, 3) as a chart image (H, W, 3).

    Parameters
    ----------
    srgb : array_like, shape (n, 3)
        Patch colours in reading order (row by row), n = rows x cols.
    rows, cols : int, optional
        The layout (default 4 x 6).
    patch_px : int, optional
        Side of a patch, pixels (default 20).
    gap_px : int, optional
        Width of the black gaps and border, pixels (default 3).

    Returns
    -------
    numpy.ndarray, shape (rows * (patch_px + gap_px) + gap_px, cols * (patch_px + gap_px) + gap_px, 3)
        The image (black background, patches filled with their colour).

    Raises
    ------
    ValueError
        If rows x cols is not the number of patches.
    """
    srgb = np.asarray(srgb, dtype=float)
    if srgb.shape[0] != rows * cols:
        raise InputError("rows, cols", f"{rows} x {cols} does not match {srgb.shape[0]} patches")
    step = patch_px + gap_px
    img = np.zeros((rows * step + gap_px, cols * step + gap_px, 3))
    for p, colour_value in enumerate(srgb):
        r, c = divmod(p, cols)
        y, x = gap_px + r * step, gap_px + c * step
        img[y:y + patch_px, x:x + patch_px] = colour_value
    return img
