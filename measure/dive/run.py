"""A dive: every photo of a folder measured with its own inputs, on Dask, resumable, with
survey outputs (:func:`measure_dive`).

The run, in order: the inputs are read and every path made absolute (Dask workers may run in
another folder); the output folder is created and locked (:func:`measure.dive.files.locked`);
the options are checked against the run that wrote the folder (run.json,
:mod:`measure.dive.manifest`) and every photo is planned (:mod:`measure.dive.plan`) -- a run
that would replace results of other options or of another photo is refused here, before it
writes anything; then run.json is written, the photos are measured
(:mod:`measure.dive.execute`) and summary.csv, survey.nc, joint.json and survey.png are written
for this run (a joint.json or survey.png this run does not make is removed: the four files
always describe one run).
"""

from __future__ import annotations

import contextlib
import datetime
import difflib
import json
import math
import os
import posixpath
import re
import signal
import socket
import threading
import warnings
from dataclasses import dataclass, field
from pathlib import Path

import forward
from forward.spectra import is_path

from ..image import photo_extensions
from ..chart import parse_corners
from ..output import image_options, read_marker, result_owner, strict_json
from .chartless import correct_frames
from .execute import execute
from .files import atomic, clean_temp, locked
from .ifdo import write_ifdo
from .manifest import FILE_OPTIONS, check_manifest, manifest, manifest_digest, write_manifest
from .metadata import exif_info, read_metadata
from .names import LOCK_FILE, NOT_UTF8, RUN_FILES, dive_files, output_names
from .plan import holds_results, plan_photo, run_setup
from .plot import plot_survey
from .summary import MEASURED, STATUSES, dive_code, summary_row, write_summary
from .survey import survey_dataset, write_survey
from forward.errors import InputError

__all__ = ["DiveWarning", "DiveResult", "check_scheduler", "measure_dive"]

#: Statuses of rows that are not a photo of the folder (left out of survey.nc)
NOT_PHOTOS = ("not an image", "no such photo")
#: Conflicts listed in the refusal's message (the rest counted)
MAX_CONFLICTS_SHOWN = 5
#: Seconds to wait for a scheduler's address to accept a connection before the run starts
SCHEDULER_CONNECT_S = 10
#: A scheduler address without a protocol: host:port (Dask takes it as tcp://)
_HOST_PORT = re.compile(r"^\[?[A-Za-z0-9_.:-]*\]?:\d+$")


class DiveWarning(UserWarning):
    """A metadata row that names no photo, or a photo without a metadata row."""


@dataclass
class DiveResult:
    """The result of :func:`measure_dive`.

    Attributes
    ----------
    rows : list of dict
        One per file of the folder and per metadata row naming no photo
        (:data:`measure.dive.SUMMARY_COLUMNS`; ``status`` one of :data:`measure.dive.STATUSES`).
    code : int
        The exit status (:func:`measure.dive.summary.dive_code`): 0 every photo measured is
        reliable, 1 one is not, 2 one could not be measured or none was, 130 interrupted.
    summary, survey, figure, joint, ifdo : pathlib.Path or None
        summary.csv, survey.nc, survey.png, joint.json and ifdo.json (None when not written).
    interrupted : bool
        The run was interrupted (Ctrl-C); the outputs list what was done.
    counts : dict
        status -> number of rows.
    joint_error : str
        Why the joint fit was not made, when asked for and not made.
    joint_estimate : sca.joint.JointEstimate or None
        The joint fit (joint.json holds its content), None when not made.
    warnings : list of str
        Metadata rows that name no photo, photos without a row (also issued as
        :class:`DiveWarning`).
    """

    rows: list
    code: int
    summary: Path | None = None
    survey: Path | None = None
    figure: Path | None = None
    joint: Path | None = None
    ifdo: Path | None = None
    interrupted: bool = False
    counts: dict = field(default_factory=dict)
    joint_error: str = ""
    joint_estimate: object = None
    warnings: list = field(default_factory=list)


def _absolute(options: dict) -> dict:
    """The options with every file path absolute (a Dask worker may run in another folder)."""
    return {k: os.path.abspath(v) if k in FILE_OPTIONS and is_path(v) else v
            for k, v in options.items()}


def _no_photo_reason(folder, name: str, line: int, listed) -> str:
    """Why a metadata row's image is not a photo of the folder."""
    p = Path(folder) / name if folder is not None else Path(name)
    if Path(name).parent != Path("."):
        why = "not in the folder itself (photos in sub-folders are not measured)"
    elif p.is_symlink() and not p.exists():
        why = f"a link to a missing file ({os.readlink(p)})"
    elif p.is_dir():
        why = "a folder"
    elif p.exists():
        why = "not among the photos measured (a hidden file, or not given)"
    else:
        why = f"no such file in {folder}" if folder is not None else "not among the photos given"
        near = difflib.get_close_matches(name, listed, n=1)
        if near:
            why += f" (did you mean {near[0]}?)"
    return f"metadata: line {line}: {name}: {why}"


def _conflicts(root: Path, conflicts: list) -> InputError:
    shown = "; ".join(conflicts[:MAX_CONFLICTS_SHOWN])
    more = len(conflicts) - MAX_CONFLICTS_SHOWN
    return InputError("out", f"{root}: {shown}" + (f"; and {more} more" if more > 0 else "")
                      + "; nothing was written: give --overwrite to replace them, or a new "
                      "--out")


def _check_defaults(depth, distance, corners) -> None:
    """Refuse a bad default depth, distance or corners up front (naming it)."""
    for name, value, low in (("depth", depth, ">= 0"), ("distance", distance, "> 0")):
        if value is None:
            continue
        try:
            x = float(value)
        except (TypeError, ValueError):
            raise InputError(name, f"must be a number (m), got {value!r}") from None
        if not math.isfinite(x) or x < 0 or (low == "> 0" and x == 0):
            raise InputError(name, f"must be finite and {low} (m), got {value!r}")
    if corners is not None:
        parse_corners(corners)


def check_scheduler(scheduler) -> None:
    """Refuse a ``scheduler`` that is neither 'synchronous' nor an address, or whose TCP address
    does not accept a connection (within :data:`SCHEDULER_CONNECT_S`), before the run writes
    anything.

    Parameters
    ----------
    scheduler : str or None

    Raises
    ------
    ValueError
        Naming ``scheduler``.
    """
    if scheduler is None or scheduler == "synchronous":
        return
    s = str(scheduler)
    proto, sep, rest = s.partition("://")
    if not sep:
        if not _HOST_PORT.match(s):
            near = difflib.get_close_matches(s, ["synchronous"], n=1)
            raise InputError("scheduler", f"{s!r} is neither 'synchronous' nor a Dask scheduler's "
                             "address (tcp://host:port)"
                             + (f"; did you mean {near[0]!r}?" if near else ""))
        proto, rest = "tcp", s
    if proto not in ("tcp", "tls"):
        return  # another transport (ucx, inproc): Dask connects or says why
    host, _, port = rest.split("/")[0].rpartition(":")
    if not port.isdigit():
        raise InputError("scheduler", f"{s!r}: no port number (tcp://host:port)")
    try:
        socket.create_connection((host.strip("[]") or "localhost", int(port)),
                                 timeout=SCHEDULER_CONNECT_S).close()
    except OSError as exc:
        raise InputError("scheduler", f"cannot connect to {s}: "
                         f"{getattr(exc, 'strerror', None) or exc or 'timed out'}") from None


def _normal_name(name: str) -> str:
    """A metadata row's image name as a photo's: ``./a.dng`` is ``a.dng``."""
    norm = posixpath.normpath(name.replace("\\", "/")) if name else name
    return norm if norm not in (".", "") else name


def _match_rows(meta: dict, names) -> dict:
    """The metadata rows keyed by the photo each names: a row's cell as written (a name with a
    leading or trailing space) where that is a photo's name, else stripped, ``./`` removed."""
    if meta is None:
        return None
    names = set(names)
    out = {}
    for name, row in meta.items():
        raw = row.get("raw_name", name)
        key = next((n for n in (raw, name, _normal_name(name)) if n in names), name)
        if key in out:
            raise InputError("metadata", f"line {row['line']}: image {raw!r} names the photo of "
                             f"line {out[key]['line']} again")
        out[key] = row
    return out


@contextlib.contextmanager
def _one_ctrl_c():
    """While the block runs (the photos measured, then the run's files written): a Ctrl-C
    raises KeyboardInterrupt until one has (it interrupts the measuring) or the measuring
    ends (``state["armed"] = False``, set by the block); later ones are ignored, so the
    summary, survey and joint of the run are written whole. Outside the main thread, nothing
    changes."""
    state = {"armed": True}
    if threading.current_thread() is not threading.main_thread():
        yield state
        return

    def once(signum, frame):
        if state["armed"]:
            state["armed"] = False
            raise KeyboardInterrupt

    old = signal.signal(signal.SIGINT, once)
    try:
        yield state
    finally:
        signal.signal(signal.SIGINT, old)


def measure_dive(paths_or_folder, *, out, metadata=None, depth=None, distance=None,
                 corners=None, overwrite: bool = False, tiff: str = "compressed",
                 output_format: str = "jpeg", linear: bool = False, method: str = "matrix",
                 joint: bool = False, scheduler=None, progress=None, bar=None,
                 report: bool = True, figure: bool = True, version: str = "",
                 command: str = "",
                 **measure_options) -> DiveResult:
    """Measure every photo of a dive, each with its own inputs, and write the survey.

    Parameters
    ----------
    paths_or_folder : path or list of paths
        The dive's folder (every file is listed in the summary:
        :func:`measure.dive.dive_files`) or the photos.
    out : str or os.PathLike
        The output folder (created if missing; locked while the run writes it): one folder per
        photo (:func:`measure.dive.output_names`), summary.csv, survey.nc, survey.png, run.json
        and, with ``joint``, joint.json.
    metadata : str or os.PathLike, optional
        The metadata CSV (:func:`measure.dive.read_metadata`). A photo without a row is a row
        ``not in metadata``; a row naming no photo of the folder is a row ``no such photo``;
        both are warned about (:class:`DiveWarning`, and ``DiveResult.warnings``) and neither
        changes the exit status.
    depth, distance : float, optional
        Defaults (m) for the photos whose row (or, for the depth, EXIF:
        :func:`measure.dive.exif_info`) does not give them; a photo without either is an error
        row.
    corners : str or array_like, optional
        Default corners (pixels); None: detected (where a row gives none). ``depth``,
        ``distance`` and ``corners`` are recorded in run.json: a rerun with others is refused.
    overwrite : bool, optional
        Redo every photo (complete ones too), even when the folder holds results of other
        options or of other photos: those are replaced.
    tiff, output_format, linear, method : optional
        Each photo's images (:func:`measure.write_outputs`): the full-resolution sRGB image
        (corrected.jpg by default, or corrected_srgb.tif), corrected.tiff with ``linear``, the
        TIFFs' compression and the correction's method ('matrix' or 'diagonal'); the frames
        without a chart corrected with the dive's water get the same (recorded in run.json).
    joint : bool, optional
        Also fit the dive's photos as one water (``measure.joint.fit_joint``): joint.json.
    scheduler : str, optional
        None: a ``distributed.LocalCluster`` of min(photos, cores) single-threaded worker
        processes; an address ('tcp://host:8786'): that cluster; 'synchronous': in this
        process, one photo after another (no Dask).
    progress : callable, optional
        ``progress(row)`` after each photo measured (a KeyboardInterrupt raised in it
        interrupts the run like Ctrl-C).
    bar : text stream, optional
        Where a tqdm progress bar is drawn (None: no bar).
    report : bool, optional
        Draw each photo's report.png (:func:`measure.write_outputs`).
    figure : bool, optional
        Draw survey.png (:func:`measure.dive.plot_survey`).
    version, command : str, optional
        uw3p's version and the command line, recorded in the outputs.
    **measure_options
        Passed to :func:`measure.measure`: ``camera``, ``quantal``, ``profile``,
        ``illuminant``, ``layout``, ``water``, ``black_level``, ``white_level``,
        ``light_field``, ``uncertain``, ``chart_reflectance``, and ``auxiliary``: the default
        of every photo whose metadata row gives no reading of its own (kind by kind, band by
        band); the joint fit gets every reading of the dive once
        (:func:`measure.auxiliary.dive_auxiliary`).

    Returns
    -------
    DiveResult
        The rows, the exit status and the files written.

    Raises
    ------
    ValueError
        Naming the argument, before anything is written: no photos, a bad ``metadata`` file,
        a bad ``tiff``, ``output_format`` or ``method`` (:func:`measure.output.image_options`), a ``depth``, ``distance`` or
        ``corners`` out of range or unreadable, an unknown ``camera`` or ``illuminant``, an
        option's file that cannot be read, an empty ``out``, a ``scheduler`` that is not
        'synchronous' nor an address that accepts a connection (:func:`check_scheduler`); naming
        ``out``: it cannot be created or written, another run is writing it, or it holds
        results this run would replace (of other options, of another photo; without
        ``overwrite``) -- refused before anything is written.
    KeyboardInterrupt
        Ctrl-C before the photos are measured (while the folder is checked and the photos
        hashed): nothing was written. Ctrl-C later ends the run with ``interrupted`` set.

    Examples
    --------
    Two generated photos of one water at two depths, told in a metadata CSV, measured into a
    results folder and fitted as one water (depths and distances taken as exact, ``uncertain={}``,
    to keep the example quick; a real dive keeps the default budget):

    >>> import tempfile, pathlib, measure
    >>> from measure.synthetic_photo import Scene, default_corners, render_mosaic, write_dng
    >>> dive = pathlib.Path(tempfile.mkdtemp())
    >>> corners = default_corners(360, 240)
    >>> for name, depth in [("a.dng", 4.0), ("b.dng", 8.0)]:
    ...     _ = write_dng(render_mosaic(Scene(chl=2.0, cdom=0.1, depth=depth, distance=1.5,
    ...                                       gain=30000, width=360, height=240, seed=3), corners),
    ...                   dive / name)
    >>> _ = (dive / "dive.csv").write_text("image,depth_m,distance_m\\na.dng,4,1.5\\nb.dng,8,1.5\\n")
    >>> res = measure.measure_dive(dive, out=dive / "results", metadata=dive / "dive.csv",
    ...                            corners=corners, joint=True, scheduler="synchronous",
    ...                            tiff="none", uncertain={}, light_field="none")
    >>> res.code, [r["status"] for r in res.rows], [r["flags"] for r in res.rows]
    (1, ['measured', 'measured'], ['uncalibrated-camera', 'uncalibrated-camera'])
    >>> sorted(p.name for p in (dive / "results").glob("*.*") if not p.name.startswith("."))
    ['ifdo.json', 'joint.json', 'run.json', 'summary.csv', 'survey.nc', 'survey.png']

    Exit status 1: both photos measured, neither reliable, for the camera was not calibrated (a
    profile from a photo of the chart in air, :func:`measure.calibrate`, removes the flag).
    """
    images = image_options(output_format, linear, tiff, method)
    if not str(out):
        raise InputError("out", "empty; give the output folder (created if missing)")
    _check_defaults(depth, distance, corners)
    check_scheduler(scheduler)
    metadata = None if metadata is None else Path(os.path.abspath(metadata))
    meta = read_metadata(metadata) if metadata is not None else None
    src = paths_or_folder
    folder = None
    root = Path(os.path.abspath(out))
    if isinstance(src, (str, os.PathLike)) and Path(src).is_dir():
        folder = Path(os.path.abspath(src))
        own = [root / n for n in RUN_FILES + (LOCK_FILE,)]  # --out the photos' folder itself
        photos, others = dive_files(folder, exclude=([metadata] if metadata else []) + own)
    else:
        photos = [Path(os.path.abspath(p)) for p in ([src] if isinstance(
            src, (str, os.PathLike)) else src)]
        others = []
    if not photos:
        raise InputError("image", f"no RAW or TIFF files in {src} "
                         f"({', '.join(photo_extensions())})")
    meta = _match_rows(meta, [p.name for p in photos])
    options = _absolute({"camera": forward.DEFAULT_CAMERA} | dict(measure_options))
    run_setup(options)  # a bad camera, illuminant, profile or chart: refused up front
    run = manifest(options, images, report, version, defaults={
        "depth": depth, "distance": distance,
        "corners": None if corners is None else parse_corners(corners).tolist()})
    digest = manifest_digest(run)
    with locked(root):
        return _locked_run(root, photos, others, folder, meta, metadata, run, digest, options,
                           (depth, distance, corners), overwrite, (images, report), joint,
                           scheduler, progress, bar, figure, version, command)


def _locked_run(root, photos, others, folder, meta, metadata, run, digest, options, defaults,
                overwrite, outputs, joint, scheduler, progress, bar, figure, version, command):
    """The run, the output folder locked: check, plan, write run.json, measure, finish."""
    # a folder that holds no photo's results (a run that measured nothing) refuses nothing
    check_manifest(root, run, overwrite or not holds_results(root))
    names = output_names(photos, owner=lambda name: _owner(root / name))
    rows, records, jobs, conflicts, notes = {}, {}, [], [], []
    for p in photos:  # a Ctrl-C here stops the run with nothing written (KeyboardInterrupt)
        job, row, conflict = plan_photo(p, names[p], root, meta, exif_info(p), defaults,
                                        options, outputs, digest, overwrite)
        if conflict is not None:
            conflicts.append(conflict)
        elif row is not None:
            rows[p] = row
            if row["status"] == "done earlier":
                records[str(p)] = json.loads((Path(row["out"]) / "measurement.json")
                                             .read_text(encoding="utf-8"))
            if row["status"] == "not in metadata":
                notes.append(f"{p.name}: no row in {metadata}; not measured")
        else:
            jobs.append(job | {"command": command, "version": version})
    if conflicts:
        raise _conflicts(root, conflicts)
    others_rows, extra, more = _unmatched_rows(folder, meta, photos, others)
    notes += more
    for text in notes:
        warnings.warn(text, DiveWarning, stacklevel=3)
    clean_temp(root)
    write_manifest(root, run)
    with _one_ctrl_c() as ctrl_c:
        return _measure_and_finish(root, photos, others_rows, extra, rows, records, jobs, notes,
                                   scheduler, progress, bar, joint, options, version, command,
                                   figure, outputs, ctrl_c)


def _owner(folder: Path):
    """The photo whose results ``folder`` holds (absolute), or None."""
    if not folder.is_dir():
        return None
    owner = result_owner(folder)
    return os.path.abspath(owner) if owner else None


def _measure_and_finish(root, photos, others_rows, extra, rows, records, jobs, notes, scheduler,
                        progress, bar, joint, options, version, command, figure, outputs,
                        ctrl_c):
    """Measure the jobs, then write the run's files (a first Ctrl-C interrupts the measuring;
    the files are written whatever follows: ``ctrl_c`` disarmed, :func:`_one_ctrl_c`)."""
    from tqdm import tqdm

    left, measured = set(), {}  # measured: image -> JointPhoto, made in this run
    with tqdm(total=len(jobs), file=bar, desc="measuring", unit="photo",
              disable=bar is None or not jobs) as pbar:
        def on_result(job, result):
            p = Path(job["image"])
            rows[p] = summary_row(p, job["plan"], result["status"], result.get("record"),
                                  result.get("error", ""))
            if result.get("record") is not None:
                records[str(p)] = result["record"]
            if result.get("photo") is not None:
                measured[str(p)] = result["photo"]
            pbar.update(1)
            if progress is not None:
                progress(rows[p])
        if jobs:
            left = execute(jobs, scheduler, on_result)
    ctrl_c["armed"] = False
    if scheduler is None or scheduler == "synchronous":
        clean_temp(root)  # the local workers are gone: what they left half-written
    for job in jobs:
        if job["key"] in left:
            p = Path(job["image"])
            record = _finished(job)
            rows[p] = summary_row(p, job["plan"], "interrupted",
                                  error="interrupted before this photo was measured") \
                if record is None else summary_row(p, job["plan"], "measured", record)
            if record is not None:
                records[str(p)] = record
    all_rows = [rows[p] for p in photos] + others_rows + extra
    all_rows.sort(key=lambda r: Path(r["image"]).name)
    res = _finish(all_rows, records, root, bool(left), joint, options, version, command,
                  figure, {job["image"]: job for job in jobs}, outputs[0], measured)
    res.warnings = notes
    return res


def _unmatched_rows(folder, meta, photos, others) -> tuple:
    """The rows of the files that are not photos and of the metadata rows that name no photo
    (each of the latter, and each broken link, with a warning's text)."""
    notes = []
    gone = {p.name for p, _ in others if p.is_symlink() and not p.exists()}
    extra = []
    if meta is not None:  # every metadata row accounted for
        listed = ({p.name for p in photos} | {p.name for p, _ in others}) - gone
        for name, mrow in meta.items():
            if name in listed:
                continue
            why = _no_photo_reason(folder, name, mrow["line"], sorted(listed))
            notes.append(why)
            extra.append(summary_row((folder or Path()) / name, {"inputs": {
                "depth_m": mrow["depth_m"], "distance_m": mrow["distance_m"],
                "corners": mrow["corners"]}}, "no such photo", error=why))
    others_rows = []
    for p, why in others:
        if p.name in gone and meta is not None and p.name in meta:
            continue  # its metadata row says it (above)
        if p.name in gone or why == NOT_UTF8:
            notes.append(f"{p.name}: {why}")
        status = "no such photo" if p.name in gone else "error" if why == NOT_UTF8 \
            else "not an image"
        others_rows.append(summary_row(p, {}, status, error=why))
    return others_rows, extra, notes


def _finished(job):
    """measurement.json's content when the job's folder is complete with the job's key (a
    worker finished it while the run was being interrupted), else None."""
    marker = read_marker(job["out"])
    if marker is None or marker.get("key") != job["key"]:
        return None
    try:
        return json.loads((Path(job["out"]) / "measurement.json").read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None


def _finish(rows, records, root, interrupted, joint, options, version, command, figure,
            jobs=None, images=None, measured=None):
    """Write joint.json, correct the chartless frames with it, then summary.csv, survey.nc,
    ifdo.json and survey.png of this run (removing a joint.json or survey.png it does not
    make); the DiveResult."""
    fit, joint_data, joint_path, joint_error = None, None, None, ""
    if joint:
        if interrupted:
            joint_error = "not fitted: the run was interrupted"
        else:
            fit, joint_data, joint_path, joint_error = _joint(rows, records, root, options,
                                                              measured or {})
    if not interrupted:
        correct_frames(rows, records, jobs or {}, joint_data if joint else None,
                       run_setup(options), water=options.get("water"), version=version,
                       command=command, images=images)
    counts = {s: sum(r["status"] == s for r in rows) for s in STATUSES}
    res = DiveResult(rows, dive_code(rows, interrupted), interrupted=interrupted, counts=counts)
    res.joint, res.joint_error, res.joint_estimate = joint_path, joint_error, fit
    res.summary = write_summary(rows, root / "summary.csv")
    res.ifdo = write_ifdo(rows, records, joint_data, root / "ifdo.json", version)
    if res.joint is None:
        _remove(root / "joint.json")
    photo_rows = [r for r in rows if r["status"] not in NOT_PHOTOS]
    now = datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds")
    ds = survey_dataset(photo_rows, records, {
        "history": f"{now} {command or 'uw3p measure_dive'}", "uw3p_version": version,
        "command": command, "interrupted": int(interrupted)}, joint=joint_data)
    res.survey = write_survey(ds, root / "survey.nc")
    if records and figure:
        res.figure = plot_survey(ds, root / "survey.png", joint_data)
    else:
        _remove(root / "survey.png")
    return res


def _remove(path: Path) -> None:
    """Remove a run file an earlier run wrote and this one does not."""
    try:
        path.unlink(missing_ok=True)
    except OSError as exc:
        raise InputError("out", f"cannot remove {path}: {exc.strerror or exc}") from None


def _joint(rows, records, root, options, measured):
    """Fit the dive as one water (measure.joint): the photos this run measured as the
    JointPhoto objects its workers made (``measured``), an earlier run's from their
    measurement.json; (JointEstimate, joint.json's content, path, error)."""
    from .. import joint as joint_mod

    good = [measured.get(r["image"]) or records[r["image"]] for r in rows
            if r["status"] in MEASURED and r["image"] in records]
    if not good:
        return None, None, None, "not fitted: no photo was measured"
    from ..auxiliary import auxiliary_record, dive_auxiliary

    setup = run_setup(options)
    aux = dive_auxiliary(good)  # every measurement of the dive's water, each reading once
    try:
        # each photo's own budget, as it was measured: the run's, its own depth and distance sds
        fit = joint_mod.fit_joint(good, setup=setup, water=options.get("water"), auxiliary=aux)
    except ValueError as exc:
        return None, None, None, f"not fitted: {exc}"
    # the camera the dive was measured with (every photo's record holds the run's)
    camera = next((records[r["image"]].get("camera") for r in rows
                   if r["status"] in MEASURED and r["image"] in records), None)
    data = strict_json(fit.to_dict() | {"camera": camera, "auxiliary": auxiliary_record(
        aux, dict.fromkeys(["cdom", "secchi"] + [f"kd {float(b):g}" for b in aux.get("kd", {})],
                           "the dive's readings combined"))})
    path = root / "joint.json"
    with atomic(path) as tmp:
        tmp.write_text(json.dumps(data, indent=1, allow_nan=False) + "\n", encoding="utf-8")
    return fit, data, path, ""
