"""A dive: every photo of a folder measured with its own inputs, on Dask, resumable, with
survey outputs (:func:`measure_dive`)."""

from __future__ import annotations

import datetime
import json
import os
from dataclasses import dataclass, field
from pathlib import Path

import forward

from ..image import RAW_EXTENSIONS, TIFF_EXTENSIONS
from ..output import TIFF_MODES, read_marker, strict_json
from .execute import execute
from .files import atomic, clean_temp
from .metadata import exif_info, read_metadata
from .names import dive_files, output_names
from .plan import plan_photo
from .plot import plot_survey
from .summary import STATUSES, exit_code, summary_row, write_summary
from .survey import survey_dataset, write_survey

__all__ = ["DiveResult", "measure_dive"]


@dataclass
class DiveResult:
    """The result of :func:`measure_dive`.

    Attributes
    ----------
    rows : list of dict
        One per file of the folder (:data:`SUMMARY_COLUMNS`; ``status`` one of
        :data:`STATUSES`).
    code : int
        0 every photo reliable, 1 one not reliable, 2 one not measurable, 130 interrupted.
    summary, survey, figure, joint : pathlib.Path or None
        summary.csv, survey.nc, survey.png and joint.json (None when not written).
    interrupted : bool
        The run was interrupted (Ctrl-C); the outputs list what was done.
    counts : dict
        status -> number of rows.
    joint_error : str
        Why the joint fit was not made, when asked for and not made.
    """

    rows: list
    code: int
    summary: Path | None = None
    survey: Path | None = None
    figure: Path | None = None
    joint: Path | None = None
    interrupted: bool = False
    counts: dict = field(default_factory=dict)
    joint_error: str = ""



def measure_dive(paths_or_folder, *, out, metadata=None, depth=None, distance=None,
                 corners=None, overwrite: bool = False, tiff: str = "compressed",
                 joint: bool = False, scheduler=None, progress=None, bar=None,
                 report: bool = True, figure: bool = True, version: str = "",
                 command: str = "",
                 **measure_options) -> DiveResult:
    """Measure every photo of a dive, each with its own inputs, and write the survey.

    Parameters
    ----------
    paths_or_folder : path or list of paths
        The dive's folder (every file is listed in the summary: :func:`dive_files`) or the
        photos.
    out : str or os.PathLike
        The output folder (created if missing): one folder per photo (:func:`output_names`),
        summary.csv, survey.nc, survey.png and, with ``joint``, joint.json.
    metadata : str or os.PathLike, optional
        The metadata CSV (:func:`read_metadata`); then a photo without a row is an error row.
    depth, distance : float, optional
        Defaults (m) for the photos whose row (or, for the depth, EXIF: :func:`exif_info`) does
        not give them; a photo without either is an error row.
    corners : str or array_like, optional
        Default corners (pixels); None: detected (where a row gives none).
    overwrite : bool, optional
        Replace folders that hold another photo's results or other inputs' results.
    tiff : {'compressed', 'full', 'none'}, optional
        corrected.tiff (:func:`measure.write_outputs`).
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
        Draw survey.png (:func:`plot_survey`).
    version, command : str, optional
        uw3p's version and the command line, recorded in the outputs.
    **measure_options
        Passed to :func:`measure.measure`: ``camera``, ``quantal``, ``profile``,
        ``illuminant``, ``layout``, ``water``, ``black_level``, ``white_level``,
        ``light_field``, ``uncertain``.

    Returns
    -------
    DiveResult
        The rows, the exit status and the files written.

    Raises
    ------
    ValueError
        Naming the argument: no photos, a bad ``metadata`` file, a ``tiff`` not in
        :data:`measure.output.TIFF_MODES`, an ``out`` that cannot be created.
    """
    from tqdm import tqdm

    if tiff not in TIFF_MODES:
        raise ValueError(f"tiff: must be one of {TIFF_MODES}, got {tiff!r}")
    meta = read_metadata(metadata) if metadata is not None else {}
    src = paths_or_folder
    if isinstance(src, (str, os.PathLike)) and Path(src).is_dir():
        photos, others = dive_files(src, exclude=[metadata] if metadata else [])
    else:
        photos, others = [Path(p) for p in ([src] if isinstance(src, (str, os.PathLike))
                                            else src)], []
    if not photos:
        raise ValueError(f"image: no RAW or TIFF files in {src} "
                         f"({', '.join(RAW_EXTENSIONS + TIFF_EXTENSIONS)})")
    root = Path(out)
    try:
        root.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise ValueError(f"out: cannot create {root}: {exc.strerror}") from None
    clean_temp(root)
    names = output_names(photos)
    options = {"camera": forward.DEFAULT_CAMERA} | dict(measure_options)
    rows, records, jobs = {}, {}, []
    for p in photos:
        job, row = plan_photo(p, names[p], root, meta, metadata, exif_info(p),
                         (depth, distance, corners), options, (tiff, report), overwrite,
                         version)
        if row is not None:
            rows[p] = row
            continue
        job, plan = job
        job["command"] = command
        job["plan"] = plan
        jobs.append(job)
    for p, row in rows.items():
        if row["status"] == "done earlier":
            records[str(p)] = json.loads((Path(row["out"]) / "measurement.json").read_text())
    by_key = {}
    with tqdm(total=len(jobs), file=bar, desc="measuring", unit="photo",
              disable=bar is None or not jobs) as pbar:
        def on_result(job, result):
            p = Path(job["image"])
            row = summary_row(p, job["plan"], result["status"], result.get("record"),
                       result.get("error", ""))
            rows[p] = row
            if result.get("record") is not None:
                records[str(p)] = result["record"]
            by_key[job["key"]] = row
            pbar.update(1)
            if progress is not None:
                progress(row)
        left = execute(jobs, scheduler, on_result) if jobs else set()
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
    all_rows = [rows[p] for p in photos] + [summary_row(p, {}, "not an image", error=why)
                                            for p, why in others]
    all_rows.sort(key=lambda r: Path(r["image"]).name)
    return _finish(all_rows, records, root, bool(left), joint, measure_options, version,
                   command, figure)


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


def _finish(rows, records, root, interrupted, joint, options, version, command, figure):
    """Write summary.csv, joint.json, survey.nc and survey.png; the DiveResult."""
    counts = {s: sum(r["status"] == s for r in rows) for s in STATUSES}
    codes = [c for c in (exit_code(r) for r in rows) if c is not None]
    code = 130 if interrupted else max(codes, default=0)
    res = DiveResult(rows, code, interrupted=interrupted, counts=counts)
    res.summary = write_summary(rows, root / "summary.csv")
    joint_data = None
    if joint:
        if interrupted:
            res.joint_error = "not fitted: the run was interrupted"
        else:
            joint_data, res.joint, res.joint_error = _joint(rows, records, root, options)
    photo_rows = [r for r in rows if r["status"] != "not an image"]
    now = datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds")
    ds = survey_dataset(photo_rows, records, {
        "history": f"{now} {command or 'uw3p measure_dive'}", "uw3p_version": version,
        "command": command, "interrupted": int(interrupted)})
    res.survey = write_survey(ds, root / "survey.nc")
    if records and figure:
        res.figure = plot_survey(ds, root / "survey.png", joint_data)
    return res


def _joint(rows, records, root, options):
    """Fit the dive as one water (measure.joint); (content, path, error)."""
    try:
        from .. import joint as joint_mod
    except ImportError as exc:
        return None, None, f"not fitted: measure.joint is not available ({exc})"
    from ..camera import camera_setup, load_profile

    good = [records[r["image"]] for r in rows
            if r["status"] in ("measured", "done earlier") and r["image"] in records]
    if not good:
        return None, None, "not fitted: no photo was measured"
    prof = options.get("profile")
    prof = load_profile(prof) if isinstance(prof, (str, os.PathLike)) else prof
    setup = camera_setup(options.get("camera", forward.DEFAULT_CAMERA),
                         quantal=options.get("quantal", False),
                         illuminant=options.get("illuminant"),
                         gains=None if prof is None else (prof.gains or None))
    try:
        fit = joint_mod.fit_joint(good, setup=setup, water=options.get("water"),
                                  uncertain=options.get("uncertain"))
    except ValueError as exc:
        return None, None, f"not fitted: {exc}"
    data = strict_json(fit.to_dict())
    path = root / "joint.json"
    with atomic(path) as tmp:
        tmp.write_text(json.dumps(data, indent=1, allow_nan=False) + "\n", encoding="utf-8")
    return data, path, ""
