"""The files of ``uw3p measure``: measurement.json, the full-resolution sRGB image (corrected.jpg
by default, or corrected_srgb.tif: :func:`image_options`), corrected.tiff (linear, on request),
corrected.png, report.png, complete.json.

A photo's folder is written whole or not at all: the files go to a temporary folder beside it
(its name starts with :data:`TEMP_PREFIX`), ``complete.json`` (:data:`MARKER`) is written last,
and the temporary folder is then renamed into place. A folder that holds another photo's
results is not replaced unless asked (``overwrite``).
"""

from __future__ import annotations

import json
import os
from concurrent.futures import ThreadPoolExecutor
import shutil
import tempfile
from pathlib import Path

import numpy as np

import forward
from forward.spectra import WHITE_PATCH, srgb_8bit

from .filemodes import follow_umask
from .image import demosaic
from forward.errors import InputError

__all__ = ["MARKER", "PREVIEW_PIXELS", "REPORT_TEXT_ROWS", "TEMP_PREFIX", "TIFF_MODES",
           "check_out", "corrected_image", "encode_srgb_8bit", "image_options", "read_marker", "report_figure",
           "result_owner", "srgb_preview", "strict_json", "write_folder", "write_outputs"]

#: Longest side of the PNG previews, pixels
PREVIEW_PIXELS = 1000
#: PNG compression level of the previews (zlib 1: fast; they are previews)
PNG_OPTIONS = {"compress_level": 1}
#: ``tiff=`` of :func:`write_outputs` and :func:`measure.correct_output.write_corrected`: the
#: TIFFs asked for (``output_format='tiff16'``, ``linear``) deflate-compressed (default) or
#: uncompressed; 'none': no TIFF at all (then neither may be asked for)
TIFF_MODES = ("compressed", "full", "none")
#: The file written last into a photo's folder: its presence says the folder is complete; it
#: names the image and (in a dive) the key of the inputs and options used
MARKER = "complete.json"
#: Name prefix of the temporary folders a photo's results are written into before the rename
TEMP_PREFIX = ".uw3p-tmp-"
#: Without a given white, the preview's white (Y = 1) is this percentile of the image's Y
WHITE_PERCENTILE = 99.5


def image_options(output_format: str = "jpeg", linear: bool = False, tiff: str = "compressed",
                  method: str = "matrix") -> dict:
    """The images a corrected photo's folder gets, checked: ``output_format``
    (:data:`measure.imagefiles.OUTPUT_FORMATS`), ``linear``, ``tiff`` (:data:`TIFF_MODES`) and
    the correction's ``method`` (:data:`measure.correct_matrix.METHODS`).

    Raises
    ------
    forward.errors.InputError
        Naming the bad argument; naming ``tiff`` when it is 'none' and a TIFF is asked for.
    """
    from .correct_matrix import check_method
    from .imagefiles import OUTPUT_FORMATS

    if output_format not in OUTPUT_FORMATS:
        raise InputError("output_format", f"one of {', '.join(OUTPUT_FORMATS)}, got "
                         f"{output_format!r}")
    if tiff not in TIFF_MODES:
        raise InputError("tiff", f"must be one of {TIFF_MODES}, got {tiff!r}")
    if tiff == "none" and (linear or output_format == "tiff16"):
        raise InputError("tiff", "'none' writes no TIFF, yet "
                         + ("the linear TIFF" if linear else "a 16-bit sRGB TIFF")
                         + " was asked for")
    return {"output_format": output_format, "linear": bool(linear), "tiff": tiff,
            "method": check_method(method)}


def strict_json(x):
    """A copy of ``x`` that ``json.dumps(..., allow_nan=False)`` accepts.

    Parameters
    ----------
    x : object
        Nested dicts, lists and tuples of numbers, strings, booleans and None (numpy scalars
        allowed).

    Returns
    -------
    object
        The same structure (tuples as lists) with inf written ``"inf"`` / ``"-inf"``, NaN as
        None and numpy scalars as Python ones.
    """
    if isinstance(x, dict):
        return {k: strict_json(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [strict_json(v) for v in x]
    if isinstance(x, (float, np.floating)):
        x = float(x)
        if np.isnan(x):
            return None
        if np.isinf(x):
            return "inf" if x > 0 else "-inf"
    if isinstance(x, np.integer):
        return int(x)
    if isinstance(x, np.bool_):
        return bool(x)
    return x


def corrected_image(meas) -> np.ndarray:
    """The whole photo, demosaiced and colour-corrected.

    Parameters
    ----------
    meas : Measurement
        A result of :func:`measure.measure` (its photo, gains and offset).

    Returns
    -------
    numpy.ndarray, uint16, (H, W, 3)
        gains * (raw - offset), rounded and clipped to 0..65535.
    """
    return demosaic(meas.photo, meas.gains, meas.offset, uint16=True)


def _stride(shape):
    return max(1, int(np.ceil(max(shape[:2]) / PREVIEW_PIXELS)))


def srgb_preview(rgb_linear, setup, white=None) -> np.ndarray:
    """An 8-bit sRGB preview of linear camera RGB.

    The image is subsampled to at most :data:`PREVIEW_PIXELS` on its long side, mapped by the
    camera's 3 x 3 matrix to XYZ (:func:`forward.camera_to_xyz_matrix`) and colour-science's
    XYZ -> linear sRGB matrix (D65) as one matrix, scaled so that ``white`` has Y = 1, clipped
    to 0-1 and encoded with the sRGB transfer function to 8 bits (rounded). colour-science's
    matrix and encoding come from the package data (:func:`forward.spectra.srgb_8bit`: the
    linear levels where the 8-bit code steps up), so a preview does not import it.

    Parameters
    ----------
    rgb_linear : numpy.ndarray, (H, W, 3)
        Linear camera RGB (any units).
    setup : forward.ChartSetup
        The camera and illuminant (for the XYZ matrix).
    white : array_like, (3,), optional
        Camera RGB shown as white (Y = 1); default the :data:`WHITE_PERCENTILE`-th percentile
        of Y.

    Returns
    -------
    numpy.ndarray, uint8, (h, w, 3)
        sRGB, 0-255.

    References
    ----------
    IEC 61966-2-1:1999, Multimedia systems and equipment - Colour measurement and management -
    Default RGB colour space - sRGB.
    """
    s = _stride(rgb_linear.shape)
    small = np.asarray(rgb_linear[::s, ::s], np.float32)
    to_xyz = forward.camera_to_xyz_matrix(setup)
    xyz_to_srgb, _ = srgb_8bit()
    A = xyz_to_srgb @ to_xyz
    if white is not None:
        ref = float((to_xyz @ np.asarray(white, float))[1])
    else:
        ref = float(np.percentile(small.reshape(-1, 3) @ to_xyz[1], WHITE_PERCENTILE))
    lin = small @ (A / (ref if ref > 0 else 1.0)).T.astype(np.float32)
    return encode_srgb_8bit(lin)


def encode_srgb_8bit(linear) -> np.ndarray:
    """8-bit sRGB codes of linear values: colour-science's sRGB encoding of the values clipped
    to 0-1, times 255, rounded (from the encoding's levels in the package data,
    :func:`forward.spectra.srgb_8bit`; to the last bit for float32 values); NaN gives 0.

    Parameters
    ----------
    linear : array_like
        Linear sRGB, 1 = white.

    Returns
    -------
    numpy.ndarray, uint8
        The codes, 0-255, shaped as ``linear``.

    References
    ----------
    IEC 61966-2-1:1999 (sRGB).
    """
    _, levels = srgb_8bit()
    lin = np.asarray(linear)
    codes = np.searchsorted(levels, lin, side="right").astype(np.uint8)
    codes[np.isnan(lin)] = 0
    return codes


def _save_png(path, rgb8) -> None:
    """An 8-bit RGB image as PNG (Pillow, :data:`PNG_OPTIONS`)."""
    from PIL import Image

    Image.fromarray(np.ascontiguousarray(rgb8, np.uint8)).save(path, format="PNG", **PNG_OPTIONS)


def _quick_rgb(photo) -> np.ndarray:
    """Camera RGB at the preview's resolution without a full demosaic: a 2 x 2-periodic CFA
    is averaged per channel over each 2 x 2 cell (half the size); other CFAs are demosaiced,
    RGB photos taken as they are."""
    if photo.kind == "rgb":
        return photo.data
    ch = photo.channel
    H, W = (ch.shape[0] // 2) * 2, (ch.shape[1] // 2) * 2
    tile = ch[:2, :2]
    if not (set(tile.ravel().tolist()) == {0, 1, 2}
            and np.array_equal(ch[:4, :4], np.tile(tile, (2, 2)))):
        return demosaic(photo)
    out = np.zeros((H // 2, W // 2, 3), np.float32)
    count = np.zeros(3)
    for dy in range(2):
        for dx in range(2):
            c = tile[dy, dx]
            out[..., c] += photo.data[dy:H:2, dx:W:2]
            count[c] += 1
    return out / count.astype(np.float32)


def report_figure(meas, raw_preview):
    """report.png's figure: the photo with the sampled boxes; the residuals in units of the
    standard error chi^2 uses; the attenuation coefficient of the light's path in m^-1 with its
    own 95 % band; what the photo measures and what it does not, in words.

    Parameters
    ----------
    meas : Measurement
        A result of :func:`measure.measure`.
    raw_preview : numpy.ndarray, (h, w, 3)
        An 8-bit preview of the photo (:func:`srgb_preview`).

    Returns
    -------
    matplotlib.figure.Figure
        Four panels (axes in the order photo, residuals, coefficient, words).
    """
    # matplotlib's object interface: no pyplot (its import, its global figures and backend)
    import textwrap

    from matplotlib.figure import Figure

    from sca.derived import BANDS_NM

    from .statements import statements

    e = meas.estimate
    fig = Figure(figsize=(11, 8.5), dpi=90)
    ax = fig.subplots(2, 2)
    s = meas.photo.size[0] / raw_preview.shape[1]  # image pixels per preview pixel
    a = ax[0, 0]
    a.imshow(raw_preview)
    for j, box in enumerate(meas.sample.boxes):
        b = np.vstack([box, box[:1]]) / s
        a.plot(b[:, 0], b[:, 1], color="yellow", lw=0.8)
        a.text(*(box.mean(axis=0) / s), str(j + 1), color="yellow", fontsize=6, ha="center",
               va="center")
    a.set_title(f"photo (sampled boxes; orientation: {meas.orientation})", fontsize=9)
    a.axis("off")
    a = ax[0, 1]
    # residuals in units of the standard error chi^2 uses (photon noise with the budget's
    # per-patch term): the panel and chi^2/dof say the same thing
    patches = np.arange(1, meas.fitted.shape[1] + 1)
    with np.errstate(divide="ignore", invalid="ignore"):
        z = (meas.sample.rgb - meas.fitted) / meas.residual_sd
    for c, col in enumerate("rgb"):
        a.plot(patches + (c - 1) * 0.2, z[c], "o", ms=3, color=col, label="RGB"[c])
    a.axhline(0, color="k", lw=0.8)
    for v in (-2, 2):
        a.axhline(v, color="k", lw=0.6, ls=":")
    patch = meas.patch_term
    se = ("SE: photon noise" + (f" with the budget's {100 * patch:.2g} % per patch"
                                if patch else " only (no per-patch term)") + ", as in chi²")
    a.set_xlabel("patch")
    a.set_ylabel("(measured - fitted) / SE")
    a.set_title(f"residuals: chi²/dof {e.chi2_dof:.3g}, fit_rms {e.fit_rms:.3g}\n{se}",
                fontsize=9)
    a.legend(fontsize=8)
    a = ax[1, 0]
    wl = e.wavelengths
    c = np.asarray(e.beam_attenuation, float)
    ci = np.asarray(e.beam_attenuation_ci, float)
    finite = np.isfinite(ci[:, 1])
    a.fill_between(wl[finite], ci[finite, 0], ci[finite, 1], color="C0", alpha=0.3,
                   label="95 % interval (its own)")
    a.plot(wl, c, color="C0", label="estimate")
    at = [e.quantities.get(f"c_{b:.0f}") for b in BANDS_NM]
    if all(v is not None for v in at):
        lo = [e.quantity_intervals[f"c_{b:.0f}"][0] for b in BANDS_NM]
        hi = [e.quantity_intervals[f"c_{b:.0f}"][1] for b in BANDS_NM]
        a.errorbar(BANDS_NM, at, yerr=[np.subtract(at, lo), np.where(
            np.isfinite(hi), np.subtract(hi, at), np.nan)], fmt="o", color="C3", ms=3,
            capsize=3, label="443, 490, 555, 670 nm")
    top = np.nanmax(np.where(finite, ci[:, 1], c))
    a.set_ylim(0, 1.05 * top if np.isfinite(top) and top > 0 else None)
    a.set_xlabel("wavelength (nm)")
    a.set_ylabel("attenuation coefficient c (m⁻¹)")
    a.legend(fontsize=8)
    kind = {"beam": "beam attenuation c = a + b", "absorption": "absorption a",
            "split": "path-weighted K_d and c"}.get(e.path_model, e.path_model)
    span = ("; intervals span " + ", ".join(e.path_models)) if len(e.path_models) > 1 else ""
    a.set_title(f"attenuation coefficient of the light's path, m⁻¹\n(path model "
                f"{e.path_model}: {kind}{span})", fontsize=9)
    _tau_axis(a, e)
    a = ax[1, 1]
    a.axis("off")
    hi = lambda v: "inf" if not np.isfinite(v) else f"{v:.4g}"  # noqa: E731
    lines = statements(e, "photo", meas.auxiliary_kinds)
    lines += [f"gain = {e.gain:.4g}  [{e.gain_ci[0]:.4g}, {hi(e.gain_ci[1])}] raw / model unit",
              "veiling light = " + ", ".join(f"{v:.4g}" for v in e.backscatter) + " raw units",
              f"reliable: {meas.reliable}",
              "flags: " + (", ".join(meas.flags) if meas.flags else "none")]
    inp = meas.inputs
    if inp:
        lines.append(f"depth {inp.get('depth_m')} m (sd {inp.get('depth_sd', '-')}), distance "
                     f"{inp.get('distance_m')} m (sd {inp.get('distance_sd', '-')})")
        for r in inp.get("auxiliary") or []:
            band = f" at {r['band_nm']:g} nm" if "band_nm" in r else ""
            lines.append(f"fused: {r['kind']}{band} {r['value']:.4g} ± {r['sd']:.2g} "
                         f"{r['units']} ({r['source']})")
        if inp.get("chart_reflectance"):
            lines.append("chart: measured spectra (" + str(inp["chart_reflectance"]["path"])
                         + ")")
    for name, label in (("chl", "C"), ("cdom", "a_CDOM")):
        shares = e.budget.get(name, {}).get("shares", {})
        if shares:
            top = sorted(shares.items(), key=lambda kv: -kv[1])[:4]
            lines.append(f"budget of {label}: " + ", ".join(f"{k} {100 * v:.0f} %"
                                                           for k, v in top))
    if not e.budget:
        lines.append("budget: none (the paper's exact model)")
    lines += [f"note: {n}" for n in meas.notes]
    text = "\n".join(textwrap.fill(x, 66, subsequent_indent="  ") for x in lines)
    rows = text.count("\n") + 1
    a.text(0, 1, text, va="top", fontsize=7.5 * min(1.0, REPORT_TEXT_ROWS / rows),
           family="monospace")
    a.set_title("what this photo measures (95 % intervals)", fontsize=9)
    fig.subplots_adjust(left=0.07, right=0.98, bottom=0.07, top=0.93, wspace=0.25, hspace=0.35)
    return fig


#: report.png's words panel holds this many lines at its 7.5 pt; more are set smaller to fit.
REPORT_TEXT_ROWS = 30


def _tau_axis(a, e):
    """The coefficient panel's right axis: the optical depth of the path tau = c (depth +
    distance) (:mod:`sca.derived`'s ``tau_<band>`` over ``c_<band>``: the fitted path)."""
    c, tau = e.quantities.get("c_490"), e.quantities.get("tau_490")
    if not (c and tau and np.isfinite(tau / c)):
        return
    length = tau / c
    ax = a.secondary_yaxis("right", functions=(lambda x: x * length, lambda t: t / length))
    ax.set_ylabel(f"optical depth τ = c × {length:.3g} m")


def _report(meas, path, raw_preview):
    report_figure(meas, raw_preview).savefig(path, pil_kwargs=PNG_OPTIONS)


def read_marker(outdir) -> dict | None:
    """The content of a result folder's :data:`MARKER`, or None when it has none (or an
    unreadable one).

    Parameters
    ----------
    outdir : str or os.PathLike
        A photo's result folder.

    Returns
    -------
    dict or None
        ``image`` (the photo's path), ``version``, and what the writer added (a dive's ``key``).
    """
    try:
        data = json.loads((Path(outdir) / MARKER).read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None
    return data if isinstance(data, dict) else None


def result_owner(outdir) -> str | None:
    """The photo whose results a folder holds: the image named by its :data:`MARKER` or, for a
    folder written before the marker existed, by its measurement.json.

    Parameters
    ----------
    outdir : str or os.PathLike
        A folder.

    Returns
    -------
    str or None
        The image's path as recorded; None when the folder holds no results ('' when it holds
        results whose image is not recorded).
    """
    marker = read_marker(outdir)
    if marker is not None:
        return str(marker.get("image", ""))
    try:
        data = json.loads((Path(outdir) / "measurement.json").read_text(encoding="utf-8"))
    except OSError:
        return None
    except ValueError:
        return ""
    return str(data.get("image", {}).get("path", "")) if isinstance(data, dict) else ""


def _same_file(a, b) -> bool:
    try:
        return Path(a).resolve() == Path(b).resolve()
    except (OSError, RuntimeError):
        return str(a) == str(b)


def check_out(outdir, image, overwrite: bool = False) -> None:
    """Refuse an output folder that :func:`write_outputs` may not replace (checked before the
    photo is measured, too, so that a refusal comes first).

    Parameters
    ----------
    outdir : str or os.PathLike
        The photo's output folder.
    image : str or os.PathLike
        The photo.
    overwrite : bool, optional
        Another photo's results may be replaced.

    Raises
    ------
    ValueError
        Naming ``out``: the folder is a file, holds files that are not uw3p results, or holds
        another photo's results (without ``overwrite``).
    """
    out = Path(outdir)
    if not out.exists():
        return
    if not out.is_dir():
        raise InputError("out", f"{out} is a file; give a folder")
    if not any(out.iterdir()):
        return
    owner = result_owner(out)
    if owner is None and (out / "run.json").is_file():
        raise InputError("out", f"{out} holds a dive's results (run.json, one folder per photo); "
                         "a photo's results go in a folder of their own: give a new or empty "
                         "folder")
    if owner is None:
        raise InputError("out", f"{out} exists and holds files that are not uw3p results; give a "
                         "new or empty folder")
    if not overwrite and not _same_file(owner, image):
        raise InputError("out", f"{out} holds the results of another photo ({owner or 'unknown'}); "
                         "give another folder or --overwrite (overwrite=True) to replace them")


def _swap(tmp: Path, out: Path) -> None:
    """Rename the finished temporary folder to ``out``; an older ``out`` is moved aside first
    and removed after, so ``out`` is at every moment the old results or the new, never a mix."""
    if out.exists():
        old = Path(tempfile.mkdtemp(dir=out.parent, prefix=f"{TEMP_PREFIX}old-{out.name}-"))
        os.replace(out, old / "x")
        os.replace(tmp, out)
        shutil.rmtree(old, ignore_errors=True)
    else:
        os.replace(tmp, out)


def write_outputs(meas, outdir, version: str = "", report: bool = True, *,
                  tiff: str = "compressed", overwrite: bool = False,
                  marker: dict | None = None, range=None,  # noqa: A002
                  method: str = "matrix", output_format: str = "jpeg",
                  linear: bool = False) -> dict:
    """Write the files of ``uw3p measure``, whole or not at all.

    The files are written into a temporary folder beside ``outdir``, :data:`MARKER` last, and
    the folder is renamed to ``outdir`` (replacing the results there, if any, in one step).

    Parameters
    ----------
    meas : Measurement
        A result of :func:`measure.measure`.
    outdir : str or os.PathLike
        The folder (its parent is created if missing). It may be missing, empty, or hold
        results of the same photo (replaced); results of another photo are replaced only with
        ``overwrite``.
    version : str, optional
        uw3p's version, recorded in measurement.json and complete.json.
    report : bool, optional
        Also draw report.png (the photo with the sampled boxes, the fit, k and the estimate).
    tiff : {'compressed', 'full', 'none'}, optional
        The TIFFs asked for deflate-compressed and lossless
        (:data:`measure.imagefiles.TIFF_COMPRESSION`; default) or uncompressed; 'none': no
        TIFF (:func:`image_options`).
    overwrite : bool, optional
        Replace a folder that holds another photo's results.
    marker : dict, optional
        More entries of complete.json (a dive records the key of its inputs and options).
    range : float, str or os.PathLike, optional
        What the full-resolution sRGB image is corrected along (:func:`measure.correct_image`:
        a distance in m, a range map or a plane); default the chart's distance.
    method : 'matrix' or 'diagonal', optional
        Its correction (:func:`measure.correct_image`; default the colour matrix per range),
        recorded as ``correction_method`` in complete.json.
    output_format : {'jpeg', 'tiff16'}, optional
        The full-resolution sRGB image with its ICC profile: corrected.jpg (8-bit, default) or
        corrected_srgb.tif (16-bit) (decision 0084-output-format).
    linear : bool, optional
        Also corrected.tiff: 16-bit linear camera RGB, von Kries-corrected at the chart.

    Returns
    -------
    dict
        {file name: path} of measurement.json, the sRGB image (corrected.jpg or
        corrected_srgb.tif), corrected.tiff (with ``linear``), corrected.png (sRGB preview),
        report.png and complete.json (which records every file's size in bytes).

    Raises
    ------
    ValueError
        Naming ``tiff``, ``output_format`` or ``method`` (:func:`image_options`); naming
        ``out`` when the folder cannot be created or written, is a file, holds files that are
        not uw3p results, or holds another photo's results without ``overwrite``.
    """
    opts = image_options(output_format, linear, tiff, method)
    marker = (marker or {}) | {"correction_method": method, "output_format": output_format,
                               "linear": bool(linear)}
    return write_folder(outdir, meas.photo.path, overwrite,
                        lambda tmp: _write_files(meas, tmp, version, report, marker, range,
                                                 opts))


def write_folder(outdir, image, overwrite: bool, write) -> dict:
    """A result folder written whole or not at all: ``write(tmp)`` fills a temporary folder
    beside ``outdir`` (:data:`MARKER` last) and returns the names written; the folder is then
    swapped into place.

    Parameters
    ----------
    outdir : str or os.PathLike
        The folder.
    image : str or os.PathLike
        The photo whose results it holds (:func:`check_out`).
    overwrite : bool
        Another photo's results may be replaced.
    write : callable
        ``write(tmp) -> list of file names``.

    Returns
    -------
    dict
        file name -> path.

    Raises
    ------
    ValueError
        Naming ``out``: see :func:`check_out`; the folder cannot be created or written.
    """
    out = Path(outdir)
    check_out(out, image, overwrite)
    try:
        out.parent.mkdir(parents=True, exist_ok=True)
        tmp = Path(tempfile.mkdtemp(dir=out.parent, prefix=f"{TEMP_PREFIX}{out.name}-"))
        follow_umask(tmp, folder=True)  # the folder renamed into place: not mkdtemp's 0700
    except OSError as exc:
        raise InputError("out", f"cannot create {out}: {exc.strerror}") from None
    try:
        names = write(tmp)
        _swap(tmp, out)
    except OSError as exc:
        raise InputError("out", f"cannot write {out}: {exc.strerror}") from None
    finally:
        if tmp.exists():
            shutil.rmtree(tmp, ignore_errors=True)
    return {k: str(out / k) for k in names}


def _write_files(meas, folder: Path, version, report, marker, rng, opts) -> list:
    """Every file into ``folder``, :data:`MARKER` last; returns their names."""
    from .correct import correct_image
    from .imagefiles import SRGB_BITS, submit_images

    names = ["measurement.json"]
    (folder / "measurement.json").write_text(
        json.dumps(strict_json(meas.to_dict(version)), indent=1, allow_nan=False) + "\n",
        encoding="utf-8")
    img = corrected_image(meas) if opts["linear"] else None
    # the preview's pixels of the linear image (only they, without corrected.tiff)
    step = _stride(meas.photo.data.shape)
    small = img[::step, ::step] if img is not None else demosaic(
        meas.photo, meas.gains, meas.offset, uint16=True, step=step)
    # full resolution sRGB: the per-pixel correction (measure.correct) at the chart's distance
    srgb = correct_image(meas.photo, meas, float(meas.inputs.get("distance_m") or 1.0)
                         if rng is None else rng, linear=False, method=opts["method"],
                         srgb_bits=SRGB_BITS[opts["output_format"]]).srgb
    # the images are encoded (imagecodecs and Pillow outside the GIL) while this thread draws
    # the previews and the report; an error is raised before the marker is written
    with ThreadPoolExecutor(max_workers=2) as pool:
        jobs = submit_images(pool, folder, srgb, img, opts["output_format"], opts["tiff"])
        white = meas.gains * (meas.sample.rgb[:, WHITE_PATCH] - meas.offset)  # the corrected white
        _save_png(folder / "corrected.png", srgb_preview(small, meas.setup, white))
        if report:
            _report(meas, folder / "report.png", srgb_preview(_quick_rgb(meas.photo), meas.setup,
                                                              meas.sample.rgb[:, WHITE_PATCH]))
        for name, job in jobs:
            job.result()
            names.append(name)
    names.append("corrected.png")
    if report:
        names.append("report.png")
    sizes = {n: (folder / n).stat().st_size for n in names}
    names.append(MARKER)
    done = {"image": str(meas.photo.path), "version": version, "files": names,
            "sizes": sizes} | (marker or {})
    (folder / MARKER).write_text(json.dumps(strict_json(done), indent=1, allow_nan=False)
                                 + "\n", encoding="utf-8")
    return names
