"""An adversarial test of the dive workflow (issue 35, "Every run keeps what it had"), written as a
hostile user would attack it, from the outside: the ``uw3p`` command in a subprocess (its exit
status, stderr and the files it leaves), and the README's public API only to make test photos.

One test per attack. A test that passes shows a promise that holds; a defect is a test that
asserts the promised behaviour, marked ``xfail(strict=True)`` with the defect as the reason (so
the suite stays green while it documents the defect, and turns red the day it is fixed, to be
unmarked).

Photos are small (360 x 240 px) synthetic DNGs; every fit uses ``--exact`` and ``--tiff none`` and
``--scheduler synchronous`` unless a scheduler or a TIFF is the point.

Cost: the default run keeps the attacks that fail before anything is measured and those that
reuse one dive measured once for the whole run (:func:`measured`: restored in its own place for
each test, one test at a time across xdist workers); the attacks that measure photos of their
own, interrupt or kill runs, or start clusters are marked ``adversarial`` (``make
test-adversarial``; ``make test`` deselects them).
"""

import contextlib
import csv
import dataclasses
import fcntl
import hashlib
import json
import os
import shutil
import signal
import subprocess
import sys
import time
import unicodedata
from pathlib import Path

import numpy as np
import pytest

import forward
import measure
from measure.synthetic_photo import Scene, default_corners, render_mosaic, write_dng

W, H = 360, 240
_BIN = Path(sys.executable).with_name("uw3p")
UW3P = [str(_BIN)] if _BIN.exists() else [sys.executable, "-m", "uw3p"]
FAST = ["--exact", "--tiff", "none", "--scheduler", "synchronous"]
#: The shared dive's defaults: b.dng's depth and distance (a.dng's come from its metadata row)
SHARED = ["--depth", 6, "--distance", 1.5]
adversarial = pytest.mark.adversarial


# --------------------------------------------------------------------------- photos
@pytest.fixture(scope="module")
def src(tmp_path_factory):
    """An air photo and its profile, three underwater DNGs of one water at other depths (all the
    same size in bytes), the first as a linear TIFF, a frame without a chart, a camera CSV."""
    import tifffile

    tmp = tmp_path_factory.mktemp("adv_src")
    setup = forward.chart_setup(channel_gains=(0.55, 1.0, 0.7))
    corners = default_corners(W, H)

    def shot(path, depth, distance, seed, chl=2.0, cdom=0.1, gain=30000):
        return Path(write_dng(render_mosaic(Scene(chl=chl, cdom=cdom, depth=depth,
                                                  distance=distance, gain=gain, width=W,
                                                  height=H, seed=seed), corners, setup=setup),
                              path))

    air = shot(tmp / "air.dng", 0, 0, 1, chl=0, cdom=0, gain=9000)
    profile = measure.calibrate(measure.sample_patches(measure.read_image(air), corners),
                                image=air)
    (tmp / "profile.json").write_text(json.dumps(dataclasses.asdict(profile)))
    a = shot(tmp / "a.dng", 5.0, 1.5, 2)
    b = shot(tmp / "b.dng", 6.0, 1.5, 3)
    c = shot(tmp / "c.dng", 4.0, 1.2, 4)
    rgb = np.clip(np.rint(measure.demosaic(measure.read_image(a))), 0, 65535).astype(np.uint16)
    tifffile.imwrite(tmp / "a.tif", rgb, photometric="rgb")
    mosaic = render_mosaic(Scene(chl=2.0, cdom=0.1, depth=5, distance=1.5, gain=30000,
                                 width=W, height=H, seed=9), corners, setup=setup)
    rng = np.random.default_rng(0)
    blank = np.clip(rng.normal(np.median(mosaic), 20, mosaic.shape), 0, None)
    write_dng(blank.astype(mosaic.dtype), tmp / "blank.dng")
    wl = forward.wavelength_grid()
    cam = forward.spectra.camera_sensitivities(wavelengths=wl)
    (tmp / "camera.csv").write_text("wavelength,red,green,blue\n" + "".join(
        f"{w:.1f},{r:.6f},{g:.6f},{b_:.6f}\n" for w, (r, g, b_) in zip(wl, cam)))
    ill = forward.spectra.illuminant_spd(wavelengths=wl)
    (tmp / "illum.csv").write_text("wavelength,power\n" + "".join(
        f"{w:.1f},{p:.6f}\n" for w, p in zip(wl, ill)))
    assert a.stat().st_size == b.stat().st_size == c.stat().st_size
    return {"dir": tmp, "air": air, "a": a, "b": b, "c": c, "tif": tmp / "a.tif",
            "blank": tmp / "blank.dng", "profile": tmp / "profile.json",
            "camera": tmp / "camera.csv", "illum": tmp / "illum.csv",
            "corners": " ".join(f"{x:.2f},{y:.2f}" for x, y in corners)}


def dive(tmp_path, src, files, rows=None, name="dive", header="image,depth_m,distance_m"):
    """A dive folder: ``files`` maps a file name to a source key of ``src``; ``rows`` are the
    lines of dive.csv after its header (written as given), or None for no metadata."""
    d = tmp_path / name
    d.mkdir()
    for fname, key in files.items():
        shutil.copy(src[key], os.path.join(os.fsencode(d), os.fsencode(fname))
                    if isinstance(fname, bytes) else d / fname)
    if rows is not None:
        (d / "dive.csv").write_text(header + "\n" + "".join(r + "\n" for r in rows),
                                    encoding="utf-8")
    return d


def uw3p(*args, cwd=None, timeout=600, env=None, **kw):
    return subprocess.run(UW3P + [str(a) for a in args], capture_output=True, text=True,
                          cwd=cwd, timeout=timeout, env=env, **kw)


def run_dive(d, out, src, *extra, metadata=True, profile=True, fast=True, **kw):
    args = ["measure", d, "--out", out]
    if metadata and (Path(d) / "dive.csv").exists():
        args += ["--metadata", Path(d) / "dive.csv"]
    if profile:
        args += ["--profile", src["profile"]]
    return uw3p(*args, *(FAST if fast else []), *extra, **kw)


def _shared_root(tmp_path_factory) -> Path:
    """A folder every xdist worker of this run shares (the run's base temporary folder)."""
    base = tmp_path_factory.getbasetemp()
    root = (base.parent if os.environ.get("PYTEST_XDIST_WORKER") else base) / "adv_shared"
    root.mkdir(exist_ok=True)
    return root


@contextlib.contextmanager
def _exclusive(root: Path):
    with open(root / ".lock", "w") as fh:
        fcntl.flock(fh, fcntl.LOCK_EX)
        try:
            yield
        finally:
            fcntl.flock(fh, fcntl.LOCK_UN)


@pytest.fixture(scope="module")
def pristine(src, tmp_path_factory):
    """One dive measured once for the whole run (the first worker to need it measures it):
    a.dng (depth and distance from its metadata row) and b.dng (from ``SHARED``'s --depth and
    --distance), with a profile of its own; kept as it was measured in ``pristine/``."""
    root = _shared_root(tmp_path_factory)
    with _exclusive(root):
        if not (root / "pristine" / "done").exists():
            shutil.rmtree(root / "work", ignore_errors=True)
            (root / "work").mkdir()
            d = dive(root / "work", src, {"a.dng": "a", "b.dng": "b"},
                     rows=["a.dng,5,1.5", "b.dng,,"])
            shutil.copy(src["profile"], root / "work" / "profile.json")
            p = uw3p("measure", d, "--metadata", d / "dive.csv", "--profile",
                     root / "work" / "profile.json", "--out", root / "work" / "out", *FAST,
                     *SHARED)
            assert p.returncode == 0, p.stderr[-2000:]
            shutil.rmtree(root / "pristine", ignore_errors=True)
            shutil.copytree(root / "work", root / "pristine", symlinks=True)
            (root / "pristine" / "done").write_text("")
    return root


@pytest.fixture
def measured(pristine):
    """The shared dive as it was measured, restored in its own place (the paths its run
    recorded) for this test alone: (dive folder, out folder, profile)."""
    with _exclusive(pristine):
        work = pristine / "work"
        shutil.rmtree(work, ignore_errors=True)
        shutil.copytree(pristine / "pristine", work, symlinks=True)
        (work / "done").unlink()
        yield work / "dive", work / "out", work / "profile.json"


def rerun(measured, *extra, **kw):
    """The shared dive's command again, with ``extra`` options (later ones win)."""
    d, out, prof = measured
    return uw3p("measure", d, "--metadata", d / "dive.csv", "--profile", prof, "--out", out,
                *FAST, *SHARED, *extra, **kw)


def summary(out):
    with open(Path(out) / "summary.csv", encoding="utf-8", newline="") as fh:
        return list(csv.DictReader(fh))


def by_name(rows):
    return {os.path.basename(r["image"]): r for r in rows}


def snapshot(root):
    """Every file under root: its bytes' hash and its modification time."""
    root = Path(root)
    return {str(p.relative_to(root)): (hashlib.sha256(p.read_bytes()).hexdigest(),
                                       p.stat().st_mtime_ns)
            for p in root.rglob("*") if p.is_file()}


def no_traceback(proc_or_text):
    text = proc_or_text if isinstance(proc_or_text, str) else proc_or_text.stderr
    return "Traceback" not in text and "Exception ignored" not in text


def error_lines(stderr):
    return [ln for ln in stderr.splitlines() if ln.strip() and "measuring:" not in ln
            and "photo/s]" not in ln]


def hidden_leftovers(out):
    return sorted(p.name for p in Path(out).iterdir()
                  if p.name.startswith(".") and p.name != ".uw3p.lock")


def popen(args, **kw):
    return subprocess.Popen(UW3P + [str(a) for a in args], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, start_new_session=True, **kw)


def start_three(tmp_path, src):
    """A dive of three photos with their metadata rows, its run started: (dive, out, process)."""
    d = dive(tmp_path, src, {"a.dng": "a", "b.dng": "b", "c.dng": "c"},
             rows=["a.dng,5,1.5", "b.dng,6,1.5", "c.dng,4,1.2"])
    out = tmp_path / "out"
    return d, out, popen(["measure", d, "--metadata", d / "dive.csv", "--profile",
                          src["profile"], "--out", out, *FAST])


def wait_for(proc, pattern, timeout=300):
    """Read the process's stderr until ``pattern`` appears; returns what was read."""
    os.set_blocking(proc.stderr.fileno(), False)
    buf, t0 = b"", time.monotonic()
    while pattern.encode() not in buf:
        chunk = proc.stderr.read()
        if chunk:
            buf += chunk
        if proc.poll() is not None or time.monotonic() - t0 > timeout:
            raise AssertionError(f"{pattern!r} never appeared: {buf.decode()[-2000:]}")
        time.sleep(0.01)
    return buf


def finish(proc, buf=b"", timeout=300):
    out, err = proc.communicate(timeout=timeout)
    return proc.returncode, out.decode(), (buf + err).decode()


# =========================================================================== names
NAMES = ["A.dng", "A.nef", "A_dng.dng", "a.dng", "A.b.dng", "A_b.dng", "-x.dng", "my photo.dng",
         "café.dng", "=1+2.dng", "a+b=c.dng", "new\nline.dng", "x" * 200 + ".dng",
         "summary.csv.dng", "joint.json.dng", "run.json.dng", "survey.png.dng"]


@adversarial
def test_names_of_every_kind_get_distinct_folders_that_name_their_photo(tmp_path, src):
    d = dive(tmp_path, src, {n: "a" for n in NAMES} | {"survey.nc.tif": "tif"})
    out = tmp_path / "out"
    p = run_dive(d, out, src, "--depth", 5, "--distance", 1.5, "--joint")
    assert p.returncode in (0, 1), p.stderr[-2000:]  # 1: the demosaiced TIFF is not reliable
    assert no_traceback(p)
    rows = summary(out)
    assert sorted(os.path.basename(r["image"]) for r in rows) == sorted(NAMES + ["survey.nc.tif"])
    assert all(r["status"] == "measured" for r in rows), [(r["image"], r["error"]) for r in rows]
    outs = [r["out"] for r in rows]
    assert len(set(outs)) == len(outs)
    assert len({o.lower() for o in outs}) == len(outs)  # safe on a case-insensitive disk too
    for r in rows:
        stem = os.path.basename(r["image"]).split(".")[0].lower()
        assert os.path.basename(r["out"]).lower().startswith(stem.replace(".", "_")[:50])
        assert json.loads((Path(r["out"]) / "measurement.json").read_text())
    for own in ("summary.csv", "survey.nc", "survey.png", "joint.json", "run.json"):
        assert (out / own).is_file(), own


@adversarial
@pytest.mark.parametrize("names", [["L" * 240 + ".dng"],
                                   ["M" * 226 + ".dng", "m" * 226 + ".dng"]],
                         ids=["one-long-name", "long-case-twins"])
def test_a_long_file_name_is_measured(tmp_path, src, names):
    d = dive(tmp_path, src, {n: "a" for n in names})
    out = tmp_path / "out"
    p = run_dive(d, out, src, "--depth", 5, "--distance", 1.5)
    rows = summary(out)
    assert [r["status"] for r in rows] == ["measured"] * len(names), [r["error"] for r in rows]
    assert p.returncode == 0
    assert all(len(os.fsencode(r["out"]).split(b"/")[-1]) <= 200 for r in rows)


@adversarial
def test_a_file_name_that_is_not_utf8_does_not_abort_the_run(tmp_path, src):
    d = dive(tmp_path, src, {"ok.dng": "a", b"bad\xff\xfename.dng": "b"})
    out = tmp_path / "out"
    p = run_dive(d, out, src, "--depth", 5, "--distance", 1.5)
    assert (out / "summary.csv").exists(), p.stderr[-500:]
    statuses = sorted(r["status"] for r in summary(out))
    assert statuses == ["measured", "measured"] or statuses == ["error", "measured"], statuses
    assert "surrogates" not in p.stderr
    bad = [r for r in summary(out) if r["status"] == "error"]
    assert all("UTF-8" in r["error"] for r in bad), bad


@pytest.mark.slow
def test_a_case_twin_added_later_does_not_redo_or_orphan_a_finished_photo(measured, src):
    """A.dng added beside the shared dive's a.dng (without a metadata row, so that nothing is
    measured: the folder names are made for every photo of the folder all the same)."""
    d, out, _ = measured
    first = by_name(summary(out))["a.dng"]["out"]
    folders = sorted(q.name for q in out.iterdir() if q.is_dir())
    shutil.copy(src["c"], d / "A.dng")
    p = rerun(measured)
    rows = by_name(summary(out))
    assert rows["a.dng"]["status"] == "done earlier", p.stdout
    assert rows["a.dng"]["out"] == first
    assert rows["A.dng"]["status"] == "not in metadata"
    assert sorted(q.name for q in out.iterdir() if q.is_dir()) == folders


@adversarial
def test_out_inside_the_photo_folder_is_not_read_back_as_input(tmp_path, src):
    d = dive(tmp_path, src, {"a.dng": "a", "b.dng": "b"})
    for _ in range(2):
        p = run_dive(d, d, src, "--depth", 5, "--distance", 1.5)
    names = sorted(os.path.basename(r["image"]) for r in summary(d))
    assert names == ["a.dng", "b.dng"], names
    assert p.returncode in (0, 1) and {r["status"] for r in summary(d)} == {"done earlier"}


# =========================================================================== resume
@adversarial
def test_a_different_photo_with_the_same_size_and_time_is_redone(measured, src):
    d, out, _ = measured
    before = by_name(summary(out))
    st = (d / "a.dng").stat()
    shutil.copyfile(src["c"], d / "a.dng")  # cp -p: another photo, same size and mtime
    os.utime(d / "a.dng", ns=(st.st_atime_ns, st.st_mtime_ns))
    assert (d / "a.dng").stat().st_size == st.st_size
    rerun(measured)
    after = by_name(summary(out))
    assert after["a.dng"]["status"] == "measured"
    assert after["b.dng"]["status"] == "done earlier"
    assert float(after["a.dng"]["chl"]) != float(before["a.dng"]["chl"])
    meas = json.loads((Path(after["a.dng"]["out"]) / "measurement.json").read_text())
    assert meas["estimate"]["chl"] == pytest.approx(float(after["a.dng"]["chl"]))


@pytest.mark.slow
def test_an_edited_profile_with_the_same_size_and_time_is_refused(measured):
    d, out, prof = measured
    snap = snapshot(out)
    st = prof.stat()
    text = prof.read_text()
    g = json.loads(text)["gains"][0]
    new = text.replace(repr(g), repr(g)[:-1] + ("1" if repr(g)[-1] != "1" else "2"), 1)
    assert len(new) == len(text) and new != text
    prof.write_text(new)
    os.utime(prof, ns=(st.st_atime_ns, st.st_mtime_ns))
    p = rerun(measured)
    assert p.returncode == 2
    assert "--out" in p.stderr and "profile" in p.stderr and "--overwrite" in p.stderr
    assert snapshot(out) == snap


@pytest.mark.slow
@pytest.mark.parametrize("option", [["--tiff", "compressed"], ["--depth-sd", "0.3"],
                                    pytest.param(["--path-model", "absorption"],
                                                 marks=adversarial),
                                    pytest.param(["--illuminant", "D50"], marks=adversarial),
                                    pytest.param(["--quantal"], marks=adversarial),
                                    pytest.param(["--black-level", "10"], marks=adversarial),
                                    pytest.param(["--cdom-slope", "0.015"], marks=adversarial)])
def test_a_rerun_with_other_options_is_refused_before_anything_is_written(measured, option):
    d, out, _ = measured
    snap = snapshot(out)
    p = rerun(measured, *option)
    assert p.returncode == 2
    lines = error_lines(p.stderr)
    assert len(lines) == 1 and lines[0].startswith("uw3p measure: error: --out: "), p.stderr
    assert "--overwrite" in lines[0]
    assert snapshot(out) == snap


@pytest.mark.slow
@pytest.mark.parametrize("option", [["--depth", "12"],
                                    ["--corners", "10,10 100,10 100,60 10,60"]],
                         ids=["depth", "corners"])
def test_a_rerun_with_another_depth_or_corners_does_not_replace_good_results(measured, option):
    """b.dng's depth is the shared run's --depth (its metadata row leaves it empty)."""
    d, out, _ = measured
    rows = by_name(summary(out))
    assert rows["b.dng"]["reliable"] == "True"
    assert rows["b.dng"]["depth_source"] == "'--depth"  # a cell a spreadsheet cannot run
    snap = snapshot(out)
    p = rerun(measured, *option)
    assert p.returncode == 2, (p.returncode, p.stdout)
    lines = error_lines(p.stderr)
    assert len(lines) == 1 and lines[0].startswith("uw3p measure: error: --out: "), lines
    assert option[0] in lines[0] and "--overwrite" in lines[0]
    assert snapshot(out) == snap


@adversarial
def test_an_edited_metadata_row_redoes_that_photo_only(measured):
    d, out, _ = measured
    b_meas = (out / "b_dng" / "measurement.json").read_bytes()
    (d / "dive.csv").write_text("image,depth_m,distance_m\na.dng,5.2,1.5\nb.dng,,\n")
    p = rerun(measured)
    rows = by_name(summary(out))
    assert rows["a.dng"]["status"] == "measured" and rows["a.dng"]["depth_m"] == "5.2"
    assert rows["b.dng"]["status"] == "done earlier"
    assert (out / "b_dng" / "measurement.json").read_bytes() == b_meas
    assert p.returncode in (0, 1) and no_traceback(p)  # 1: a at 5.2 m may misfit


@adversarial
def test_an_edited_camera_csv_is_noticed(tmp_path, src):
    cam = tmp_path / "camera.csv"
    shutil.copy(src["camera"], cam)
    prof = tmp_path / "profile.json"  # calibrated with the CSV by its absolute path
    assert uw3p("calibrate", src["air"], "--camera", cam, "--out", prof).returncode == 0
    d = dive(tmp_path, src, {"a.dng": "a"}, rows=["a.dng,5,1.5"])
    out = tmp_path / "out"
    common = ["measure", d, "--metadata", d / "dive.csv", "--profile", prof, "--camera", cam,
              "--out", out, *FAST]
    p = uw3p(*common)
    assert summary(out)[0]["status"] == "measured", (p.stderr, summary(out)[0]["error"])
    snap = snapshot(out)
    st = cam.stat()
    lines = cam.read_text().splitlines(keepends=True)
    last = lines[150][-2]  # the last digit of a row's blue value: the same size
    lines[150] = lines[150][:-2] + ("1" if last != "1" else "2") + "\n"
    cam.write_text("".join(lines))
    os.utime(cam, ns=(st.st_atime_ns, st.st_mtime_ns))
    assert cam.stat().st_size == st.st_size
    p = uw3p(*common)
    assert p.returncode == 2 and "camera" in p.stderr and "--out" in p.stderr, p.stderr
    assert snapshot(out) == snap


@adversarial
@pytest.mark.parametrize("damage", ["lost", "truncated"])
def test_a_folder_missing_a_result_file_is_redone(measured, damage):
    """A file its complete.json lists (corrected.jpg; the shared dive has no TIFF) lost, or cut
    to another size: the photo is redone, the other one is not."""
    d, out, _ = measured
    jpg = out / "a_dng" / "corrected.jpg"
    size = jpg.stat().st_size
    if damage == "lost":
        jpg.unlink()
    else:
        jpg.write_bytes(jpg.read_bytes()[: size // 2])
    rerun(measured)
    rows = by_name(summary(out))
    assert rows["a.dng"]["status"] == "measured" and rows["b.dng"]["status"] == "done earlier"
    assert jpg.stat().st_size == size


@adversarial
def test_overwrite_redoes_every_photo(measured):
    d, out, _ = measured
    (out / "a_dng" / "corrected.png").write_bytes(b"")  # a damaged result
    p = rerun(measured, "--overwrite")
    assert p.returncode == 0, p.stderr[-500:]
    assert [r["status"] for r in summary(out)] == ["measured", "measured"]
    assert (out / "a_dng" / "corrected.png").stat().st_size > 0


@adversarial
def test_a_run_that_measured_nothing_does_not_block_a_corrected_rerun(tmp_path, src):
    d = dive(tmp_path, src, {"x.dng": "blank", "y.dng": "blank"})
    out = tmp_path / "out"
    run_dive(d, out, src, "--depth", 5, "--distance", 1.5)
    assert {r["status"] for r in summary(out)} == {"no chart"}
    p = run_dive(d, out, src, "--depth", 5, "--distance", 1.5, "--tiff", "compressed")
    assert "holds the results" not in p.stderr, p.stderr


@pytest.mark.slow
def test_a_rerun_on_another_scheduler_and_from_another_cwd_is_not_refused(measured):
    d, out, prof = measured
    elsewhere = d.parent / "elsewhere"
    elsewhere.mkdir()
    p = uw3p("measure", "../dive", "--metadata", "../dive/dive.csv", "--out", "../out",
             "--profile", "../profile.json", "--exact", "--tiff", "none", *SHARED,
             cwd=elsewhere)  # the default local cluster (nothing to measure: never started)
    assert p.returncode == 0, p.stderr[-1000:]
    assert [r["status"] for r in summary(out)] == ["done earlier", "done earlier"]


# =========================================================================== metadata
@adversarial
def test_every_metadata_row_is_accounted_for(tmp_path, src):
    d = dive(tmp_path, src, {"a.dng": "a", "nometa.dng": "b"},
             rows=["a.dng,5,1.5", "sub/c.dng,4,1.2", "dangling.dng,4,1.2", "A.DNG,4,1.2",
                   "IMG_O101.dng,4,1.2"])
    (d / "sub").mkdir()
    shutil.copy(src["c"], d / "sub" / "c.dng")
    os.symlink("/nonexistent/x.dng", d / "dangling.dng")
    out = tmp_path / "out"
    p = run_dive(d, out, src)
    assert p.returncode == 0, p.stderr
    rows = by_name(summary(out))
    assert rows["a.dng"]["status"] == "measured"
    assert rows["nometa.dng"]["status"] == "not in metadata" and rows["nometa.dng"]["error"]
    for name in ("c.dng", "dangling.dng", "A.DNG", "IMG_O101.dng"):
        assert rows[name]["status"] == "no such photo" and rows[name]["error"], rows[name]
        assert name in p.stderr
    assert "warning" in p.stderr


@pytest.mark.parametrize("cells,word", [
    ("a.dng,-5,1.5", "depth_m"), ('a.dng,"1,5",1.5', "depth_m"),
    ("a.dng,5,1.5,extra", "more cells"), ("a.dng,5,1.5\na.dng,5,1.5", "repeats"),
    *[pytest.param(*c, marks=adversarial) for c in [
        ("a.dng,nan,1.5", "depth_m"), ("a.dng,inf,1.5", "depth_m"),
        ("a.dng,1e999,1.5", "depth_m"), ("a.dng,5,0", "distance_m"),
        ("a.dng,5,1.5,-1", "depth_sd_m")]]])
def test_bad_metadata_is_refused_with_the_file_and_line(tmp_path, src, cells, word):
    header = "image,depth_m,distance_m" + (",depth_sd_m" if word == "depth_sd_m" else "")
    d = dive(tmp_path, src, {"a.dng": "a"}, rows=[cells], header=header)
    out = tmp_path / "out"
    p = run_dive(d, out, src)
    assert p.returncode == 2 and no_traceback(p)
    lines = error_lines(p.stderr)
    assert len(lines) == 1 and lines[0].startswith("uw3p measure: error: --metadata: "), lines
    assert "dive.csv" in lines[0] and "line " in lines[0] and word in lines[0], lines[0]
    assert not out.exists()


@adversarial
def test_metadata_as_a_spreadsheet_writes_it_is_accepted(tmp_path, src):
    """A byte-order mark, a trailing comma on every line, blank lines and rows of empty cells,
    a quoted corners cell with a line break in it."""
    corners = src["corners"].replace(" ", "\n", 1)
    text = ("\ufeffimage,depth_m,distance_m,corners,\n\n"
            f'a.dng,5,1.5,"{corners}",\n,,,,\n\nb.dng,6,1.5,,\n')
    d = dive(tmp_path, src, {"a.dng": "a", "b.dng": "b"})
    (d / "dive.csv").write_text(text, encoding="utf-8")
    out = tmp_path / "out"
    p = run_dive(d, out, src)
    assert p.returncode == 0, p.stderr
    rows = by_name(summary(out))
    assert rows["a.dng"]["corners_source"] != "detected"
    assert [rows[n]["status"] for n in ("a.dng", "b.dng")] == ["measured", "measured"]


@adversarial
@pytest.mark.parametrize("sep", [";", "\t"], ids=["semicolon", "tab"])
def test_metadata_with_another_separator_gets_a_true_message(tmp_path, src, sep):
    """The separator is the header's; with it not a comma, a decimal comma is read."""
    d = dive(tmp_path, src, {"a.dng": "a"})
    (d / "dive.csv").write_text(sep.join(["image", "depth_m", "distance_m"]) + "\n"
                                + sep.join(["a.dng", "5", "1,5"]) + "\n")
    p = run_dive(d, tmp_path / "out", src)
    assert p.returncode in (0, 2)
    assert "missing column" not in p.stderr, p.stderr
    row = summary(tmp_path / "out")[0]
    assert row["status"] == "measured" and float(row["distance_m"]) == 1.5, row["error"]


def test_a_short_metadata_row_is_refused_with_its_line(tmp_path, src):
    d = dive(tmp_path, src, {"a.dng": "a"}, rows=["a.dng,5"])
    p = run_dive(d, tmp_path / "out", src, "--distance", 3)
    assert p.returncode == 2 and "line 2" in p.stderr, (p.returncode, p.stderr[-500:])
    assert not (tmp_path / "out").exists()


@adversarial
def test_a_dot_slash_metadata_name_names_its_photo(tmp_path, src):
    d = dive(tmp_path, src, {"a.dng": "a"}, rows=["./a.dng,5,1.5"])
    out = tmp_path / "out"
    p = run_dive(d, out, src)
    assert "hidden file" not in p.stderr
    assert by_name(summary(out))["a.dng"]["status"] == "measured"


@adversarial
def test_a_quoted_metadata_name_with_a_leading_space_names_its_photo(tmp_path, src):
    d = dive(tmp_path, src, {" lead.dng": "a"}, rows=['" lead.dng",5,1.5'])
    out = tmp_path / "out"
    run_dive(d, out, src)
    rows = summary(out)
    assert [r["status"] for r in rows] == ["measured"], [(r["image"], r["error"]) for r in rows]


# =========================================================================== spreadsheet cells
DANGEROUS = ("=", "+", "-", "@", "\t", "\r")


def _is_number(cell):
    try:
        float(cell)
    except ValueError:
        return False
    return all(ch in "0123456789.eE+-" for ch in cell.strip())


def _unsafe_cells(path):
    with open(path, encoding="utf-8", newline="") as fh:
        return [c for row in csv.reader(fh) for c in row
                if c.startswith(DANGEROUS) and not _is_number(c)]


@adversarial
def test_summary_csv_cells_cannot_run(tmp_path, src):
    rows = ["a.dng,5,1.5,", 'b.dng,6,1.5,"=HYPERLINK(""http://evil"",""x"")"',
            "=cmd|' /C calc'!A0,4,1.2,", "-2+3,4,1.2,", "@SUM(1),4,1.2,", "+1+1,4,1.2,",
            '"-5,10 300,10 300,200 -5,200",4,1.2,']
    d = dive(tmp_path, src, {"a.dng": "a", "b.dng": "b", "-x.dng": "c", "=1+2.dng": "c"},
             rows=rows + ["-x.dng,4,1.2,\"-5,10 300,10 300,200 -5,200\"", "=1+2.dng,4,1.2,"],
             header="image,depth_m,distance_m,corners")
    out = tmp_path / "out"
    run_dive(d, out, src)
    assert _unsafe_cells(out / "summary.csv") == []
    assert len(summary(out)) == 9


@pytest.fixture(scope="module")
def patch_csv(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("adv_patches")
    p = uw3p("simulate", "--chl", 1, "--cdom", 0.1, "--depth", 10, "--distance", 5, "--seed", 0,
             "--out", tmp / "m.csv")
    assert p.returncode == 0, p.stderr
    with open(tmp / "m.csv", newline="") as fh:
        return list(csv.DictReader(fh))


def _batch(path, patch_rows, ids):
    with open(path, "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(["chart", *patch_rows[0].keys(), "depth_m"])
        for cid in ids:
            for r in patch_rows:
                w.writerow([cid, *r.values(), 10])


@pytest.mark.parametrize("ids", [["=1+1", "+SUM(A1)", "-2+3", "@cmd", "-inf", "-5", "1e3",
                                  '=HYPERLINK("http://e","c")']])
def test_estimate_batch_and_attenuation_cells_cannot_run(tmp_path, patch_csv, ids):
    _batch(tmp_path / "batch.csv", patch_csv, ids)
    p = uw3p("estimate", "--batch", tmp_path / "batch.csv", "--distance", 5, "--attenuation",
             tmp_path / "k.csv")
    assert p.returncode == 0, p.stderr[-500:]
    (tmp_path / "stdout.csv").write_text(p.stdout, encoding="utf-8")
    assert _unsafe_cells(tmp_path / "stdout.csv") == []
    assert _unsafe_cells(tmp_path / "k.csv") == []
    with open(tmp_path / "stdout.csv", newline="") as fh:
        first = [r[0] for r in csv.reader(fh)][1:]
    assert "-5" in first and "1e3" in first  # numbers stay numbers


def test_a_python_only_number_is_neutralised(tmp_path, patch_csv):
    _batch(tmp_path / "batch.csv", patch_csv, ["-1_0"])
    p = uw3p("estimate", "--batch", tmp_path / "batch.csv", "--distance", 5)
    (tmp_path / "stdout.csv").write_text(p.stdout, encoding="utf-8")
    assert _unsafe_cells(tmp_path / "stdout.csv") == []


# =========================================================================== concurrency
@adversarial
def test_a_second_run_into_the_same_out_is_refused_while_the_first_runs(tmp_path, src):
    d = dive(tmp_path, src, {"a.dng": "a", "b.dng": "b", "c.dng": "c"},
             rows=["a.dng,5,1.5", "b.dng,6,1.5", "c.dng,4,1.2"])
    out = tmp_path / "out"
    os.symlink(out, tmp_path / "link")
    first = popen(["measure", d, "--metadata", d / "dive.csv", "--profile", src["profile"],
                   "--out", out, *FAST])
    buf = wait_for(first, "measuring:")
    for target in (out, tmp_path / "link"):
        p = run_dive(d, target, src)
        assert p.returncode == 2 and no_traceback(p)
        lines = error_lines(p.stderr)
        assert len(lines) == 1 and lines[0].startswith("uw3p measure: error: --out: "), lines
    code, stdout, stderr = finish(first, buf)
    assert code == 0, stderr[-1000:]
    assert [r["status"] for r in summary(out)] == ["measured"] * 3
    assert hidden_leftovers(out) == []


@adversarial
def test_a_killed_runs_lock_and_temporary_files_do_not_block_or_stay(tmp_path, src):
    """Each run killed while it measures the photo after its first: a resumed run measures only
    the photos left, so its bar counts them ('1/2', not '1/3'): the test waits for the first
    photo of each run, whatever the total (it waited for '1/3', which a resumed run never
    prints: the failure on main was the test's own)."""
    d = dive(tmp_path, src, {"a.dng": "a", "b.dng": "b", "c.dng": "c"},
             rows=["a.dng,5,1.5", "b.dng,6,1.5", "c.dng,4,1.2"])
    out = tmp_path / "out"
    args = ["measure", d, "--metadata", d / "dive.csv", "--profile", src["profile"], "--out",
            out, "--exact", "--tiff", "compressed", "--linear", "--scheduler", "synchronous"]
    killed = 0
    for extra in (0.0, 0.3, 0.7):  # SIGKILL at several moments of the photo after the first
        proc = popen(args)
        try:
            wait_for(proc, "| 1/")
        except AssertionError:  # this run had one photo left and finished it
            proc.wait()
            break
        time.sleep(extra)
        os.killpg(proc.pid, signal.SIGKILL)
        proc.wait()
        killed += 1
    assert killed >= 1
    p = uw3p(*args)
    assert p.returncode == 0, p.stderr[-1000:]
    assert hidden_leftovers(out) == []
    for r in summary(out):
        assert r["status"] in ("measured", "done earlier")
        files = sorted(q.name for q in Path(r["out"]).iterdir())
        assert {"measurement.json", "corrected.tiff", "corrected.png", "complete.json"} <= set(
            files), files
        json.loads((Path(r["out"]) / "measurement.json").read_text())


# =========================================================================== file systems
@pytest.mark.parametrize("where", [pytest.param("a-file", marks=adversarial),
                                   pytest.param("under-a-file", marks=adversarial),
                                   "lock-is-a-folder", "summary-is-a-folder"])
def test_an_out_that_cannot_be_written_is_a_one_line_error(tmp_path, src, where):
    d = dive(tmp_path, src, {"a.dng": "a"}, rows=["a.dng,5,1.5"])
    f = tmp_path / "file"
    f.write_text("x")
    out = {"a-file": f, "under-a-file": f / "out"}.get(where, tmp_path / "out")
    if where == "lock-is-a-folder":
        (out / ".uw3p.lock").mkdir(parents=True)
    if where == "summary-is-a-folder":
        (out / "summary.csv").mkdir(parents=True)
    p = run_dive(d, out, src)
    assert p.returncode == 2 and no_traceback(p)
    lines = error_lines(p.stderr)
    assert lines and lines[-1].startswith("uw3p measure: error: --out: "), lines


def test_a_blocked_lock_is_named_in_the_message(tmp_path, src):
    d = dive(tmp_path, src, {"a.dng": "a"}, rows=["a.dng,5,1.5"])
    out = tmp_path / "out"
    (out / ".uw3p.lock").mkdir(parents=True)
    p = run_dive(d, out, src)
    assert ".uw3p.lock" in p.stderr, p.stderr


def test_an_empty_out_is_refused(tmp_path, src):
    d = dive(tmp_path, src, {"a.dng": "a"}, rows=["a.dng,5,1.5"])
    cwd = tmp_path / "cwd"
    cwd.mkdir()
    p = uw3p("measure", d, "--metadata", d / "dive.csv", "--profile", src["profile"], "--out",
             "", *FAST, cwd=cwd)
    assert list(cwd.iterdir()) == []
    assert p.returncode == 2 and "--out" in p.stderr


def test_a_read_only_out_is_a_one_line_error(tmp_path, src):
    """A read-only file system (tmpfs mounted read-only in a private mount namespace)."""
    if not shutil.which("unshare"):
        pytest.skip("no unshare")
    d = dive(tmp_path, src, {"a.dng": "a"}, rows=["a.dng,5,1.5"])
    ro = tmp_path / "ro"
    ro.mkdir()
    cmd = " ".join(["mount -t tmpfs -o ro,size=1m tmpfs", str(ro), "&&", "exec",
                    *[f"'{a}'" for a in UW3P], "measure", f"'{d}'", "--metadata",
                    f"'{d / 'dive.csv'}'", "--profile", f"'{src['profile']}'", "--out",
                    f"'{ro / 'out'}'", *FAST])
    p = subprocess.run(["unshare", "-rm", "sh", "-c", cmd], capture_output=True, text=True,
                       timeout=300)
    if "mount:" in p.stderr or "unshare:" in p.stderr:
        pytest.skip(f"cannot mount here: {p.stderr.strip()}")
    assert p.returncode == 2 and no_traceback(p)
    lines = error_lines(p.stderr)
    assert len(lines) == 1 and lines[0].startswith("uw3p measure: error: --out: "), lines
    assert "Read-only" in lines[0]


@adversarial
def test_a_full_disk_leaves_no_half_written_results(tmp_path, src):
    """RLIMIT_FSIZE makes every write beyond 200 kB fail (EFBIG) as a full disk would."""
    import resource

    d = dive(tmp_path, src, {"a.dng": "a", "b.dng": "b"}, rows=["a.dng,5,1.5", "b.dng,6,1.5"])
    out = tmp_path / "out"
    fast = ["--exact", "--tiff", "compressed", "--linear", "--scheduler", "synchronous"]

    def limit():
        resource.setrlimit(resource.RLIMIT_FSIZE, (200_000, 200_000))

    p = run_dive(d, out, src, *fast, fast=False, preexec_fn=limit)
    assert p.returncode == 2 and no_traceback(p)
    assert {r["status"] for r in summary(out)} == {"error"}
    assert hidden_leftovers(out) == []
    assert not any(q.is_dir() for q in out.iterdir())  # no folder of partial results
    p = run_dive(d, out, src, *fast, fast=False)
    assert p.returncode == 0, p.stderr[-500:]
    assert [r["status"] for r in summary(out)] == ["measured", "measured"]


# =========================================================================== schedulers
@adversarial
def test_a_real_scheduler_with_relative_paths_from_another_cwd(tmp_path, src):
    from distributed import Client, LocalCluster

    d = dive(tmp_path, src, {"a.dng": "a", "b.dng": "b"}, rows=["a.dng,5,1.5", "b.dng,6,1.5"])
    for key in ("profile", "illum"):
        shutil.copy(src[key], tmp_path / src[key].name)
    here = tmp_path / "here"
    here.mkdir()
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    with LocalCluster(n_workers=1, threads_per_worker=1, processes=True,
                      dashboard_address=":0") as cluster, Client(cluster) as client:
        client.run(os.chdir, str(elsewhere))
        p = uw3p("measure", "../dive", "--metadata", "../dive/dive.csv", "--out", "../out",
                 "--profile", "../profile.json", "--illuminant", "../illum.csv", "--exact",
                 "--tiff", "none", "--scheduler", cluster.scheduler_address, cwd=here)
        assert client.submit(sum, [1, 2]).result(timeout=30) == 3  # the cluster is left alive
    assert p.returncode == 0, p.stderr[-1500:]
    assert [r["status"] for r in summary(tmp_path / "out")] == ["measured", "measured"]


def test_an_unreachable_scheduler_is_a_one_line_error(tmp_path, src):
    d = dive(tmp_path, src, {"a.dng": "a"}, rows=["a.dng,5,1.5"])
    p = uw3p("measure", d, "--metadata", d / "dive.csv", "--profile", src["profile"], "--out",
             tmp_path / "out", "--exact", "--tiff", "none", "--scheduler", "tcp://127.0.0.1:1",
             timeout=300)
    assert no_traceback(p), p.stderr[-800:]
    assert p.returncode == 2
    lines = error_lines(p.stderr)
    assert lines and lines[-1].startswith("uw3p measure: error: --scheduler: "), lines
    assert not (tmp_path / "out").exists()


def test_a_misspelled_scheduler_names_the_option_and_writes_nothing(tmp_path, src):
    d = dive(tmp_path, src, {"a.dng": "a"}, rows=["a.dng,5,1.5"])
    out = tmp_path / "out"
    p = uw3p("measure", d, "--metadata", d / "dive.csv", "--profile", src["profile"], "--out",
             out, "--exact", "--tiff", "none", "--scheduler", "synchronus")
    assert p.returncode == 2
    assert p.stderr.strip().startswith("uw3p measure: error: --scheduler: "), p.stderr
    assert "synchronous" in p.stderr
    assert not out.exists()


@adversarial
def test_a_camera_csv_and_its_profile_measure_a_dive(tmp_path, src):
    shutil.copy(src["camera"], tmp_path / "cam.csv")
    shutil.copy(src["air"], tmp_path / "air.dng")
    c = uw3p("calibrate", "air.dng", "--camera", "cam.csv", "--out", "profile.json",
             cwd=tmp_path)
    assert c.returncode == 0, c.stderr
    dive(tmp_path, src, {"a.dng": "a"}, rows=["a.dng,5,1.5"])
    p = uw3p("measure", "dive", "--metadata", "dive/dive.csv", "--camera", "cam.csv",
             "--profile", "profile.json", "--out", "out", *FAST, cwd=tmp_path)
    rows = summary(tmp_path / "out")
    assert rows[0]["status"] == "measured", rows[0]["error"]
    assert p.returncode == 0


# =========================================================================== interrupts
@adversarial
def test_ctrl_c_mid_run_exits_130_with_a_summary_and_the_rerun_finishes(tmp_path, src):
    d, out, proc = start_three(tmp_path, src)
    buf = wait_for(proc, "1/3")
    os.killpg(proc.pid, signal.SIGINT)  # Ctrl-C: the whole foreground process group
    code, stdout, stderr = finish(proc, buf)
    assert code == 130 and no_traceback(stderr), stderr[-1500:]
    statuses = [r["status"] for r in summary(out)]
    assert statuses.count("measured") >= 1 and "interrupted" in statuses
    assert (out / "survey.nc").exists()
    p = run_dive(d, out, src)
    assert p.returncode == 0
    assert sorted(r["status"] for r in summary(out)).count("done earlier") >= 1
    assert all(r["status"] in ("measured", "done earlier") for r in summary(out))


@pytest.mark.xfail(strict=False, reason="a Ctrl-C in CPython's own start (its io and site "
                   "imports, the first ~20-40 ms, more on a loaded machine) prints CPython's "
                   "KeyboardInterrupt traceback before any of uw3p's code runs; uw3p's own "
                   "imports and argument parsing are covered (the console script uw3p.console:main: "
                   "'uw3p: interrupted', exit 130). Not strict: whether a delay lands in "
                   "CPython's window depends on the machine's speed and load")
@adversarial
def test_ctrl_c_at_start_up_has_no_traceback(tmp_path, src):
    d = dive(tmp_path, src, {"a.dng": "a"}, rows=["a.dng,5,1.5"])
    tracebacks = []
    for i, delay in enumerate(np.arange(0.02, 0.62, 0.04)):
        proc = popen(["measure", d, "--metadata", d / "dive.csv", "--profile", src["profile"],
                      "--out", tmp_path / f"out{i}", *FAST])
        time.sleep(float(delay))
        os.killpg(proc.pid, signal.SIGINT)
        code, _, stderr = finish(proc)
        if not no_traceback(stderr):
            tracebacks.append((round(float(delay), 2), stderr.strip().splitlines()[-1]))
    assert tracebacks == []


@pytest.mark.xfail(strict=True, reason="Ctrl-C (SIGINT to the process group, as a terminal "
                   "sends it) while the default local cluster starts prints the workers' "
                   "tracebacks (KeyboardInterrupt in their imports, 'AssertionError: Queue ... "
                   "not closed' in distributed/nanny.py), though the run exits 130")
@adversarial
def test_ctrl_c_while_the_local_cluster_starts_has_no_traceback(tmp_path, src):
    d = dive(tmp_path, src, {"a.dng": "a", "b.dng": "b"}, rows=["a.dng,5,1.5", "b.dng,6,1.5"])
    results = []
    for i, extra in enumerate((0.0, 0.3, 0.7, 1.2, 2.0, 3.0)):
        proc = popen(["measure", d, "--metadata", d / "dive.csv", "--profile", src["profile"],
                      "--out", tmp_path / f"out{i}", "--exact", "--tiff", "none"])
        buf = wait_for(proc, "measuring:")
        time.sleep(extra)
        os.killpg(proc.pid, signal.SIGINT)
        results.append(finish(proc, buf))
    assert all(no_traceback(err) for _, _, err in results), [
        err[-600:] for _, _, err in results if not no_traceback(err)]
    assert all(code in (130, 0) for code, _, _ in results)


@adversarial
def test_ctrl_c_pressed_repeatedly_still_leaves_summary_and_survey(tmp_path, src):
    d, out, proc = start_three(tmp_path, src)
    buf = wait_for(proc, "1/3")
    for _ in range(30):
        if proc.poll() is not None:
            break
        os.killpg(proc.pid, signal.SIGINT)
        time.sleep(0.03)
    code, _, stderr = finish(proc, buf)
    assert no_traceback(stderr)
    assert (out / "summary.csv").exists() == (out / "survey.nc").exists()
    assert "measured" in [r["status"] for r in summary(out)]


@adversarial
def test_ctrl_c_before_the_first_photo_leaves_nothing_that_blocks_a_rerun(tmp_path, src):
    d = dive(tmp_path, src, {"a.dng": "a", "b.dng": "b"}, rows=["a.dng,5,1.5", "b.dng,6,1.5"])
    out = tmp_path / "out"
    proc = popen(["measure", d, "--metadata", d / "dive.csv", "--profile", src["profile"],
                  "--out", out, *FAST])
    buf = wait_for(proc, "measuring:")
    os.killpg(proc.pid, signal.SIGINT)
    code, _, stderr = finish(proc, buf)
    assert code == 130
    p = run_dive(d, out, src, "--tiff", "compressed")
    assert "holds the results" not in p.stderr, p.stderr


# =========================================================================== no confident wrong answer
@adversarial
def test_a_frame_without_a_chart_is_not_bad_input(tmp_path, src):
    d = dive(tmp_path, src, {"a.dng": "a", "blank.dng": "blank"},
             rows=["a.dng,5,1.5", "blank.dng,5,1.5"])
    out = tmp_path / "out"
    p = run_dive(d, out, src)
    assert p.returncode == 0, p.stderr
    rows = by_name(summary(out))
    assert rows["blank.dng"]["status"] == "no chart" and rows["blank.dng"]["depth_m"] == "5.0"
    assert rows["blank.dng"]["chl"] == ""


@pytest.mark.parametrize("argv,suggestion", [
    (["--metdata", "x.csv"], "--metadata"), (["--ovewrite"], "--overwrite"),
    (["--jiont"], "--joint"), (["--tiff", "nne"], "'none'"), (["--layout", "crad"], "'card'")])
def test_a_misspelled_option_gets_did_you_mean(tmp_path, src, argv, suggestion):
    p = uw3p("measure", src["a"], "--out", tmp_path / "out", *argv)
    assert p.returncode == 2 and no_traceback(p)
    last = p.stderr.strip().splitlines()[-1]
    assert last.startswith("uw3p measure: error: ") and "did you mean" in last
    assert suggestion in last
    assert not (tmp_path / "out").exists()


def test_a_misspelled_option_is_a_one_line_error(tmp_path, src):
    """Changed from "the whole stderr is one line": a usage error shows the subcommand's usage
    first (argparse's convention, kept on purpose by issue 35: tests/test_cli.py asserts it, so
    the user sees the options beside the suggestion); the error itself is the one last line."""
    p = uw3p("measure", src["a"], "--out", tmp_path / "out", "--metdata", "x.csv")
    lines = p.stderr.strip().splitlines()
    assert p.returncode == 2 and lines[0].startswith("usage: uw3p measure ")
    errors = [ln for ln in lines if "error" in ln]
    assert errors == [lines[-1]] and lines[-1].startswith("uw3p measure: error: "), p.stderr


@pytest.mark.parametrize("bad", [pytest.param(["--depth", "-1"], id="depth"),
                                 pytest.param(["--camera", "nonexistent"], id="camera"),
                                 pytest.param(["--illuminant", "nonexistent"], id="illuminant",
                                              marks=adversarial),
                                 pytest.param(["--corners", "garbage"], id="corners",
                                              marks=adversarial)])
def test_a_bad_option_with_a_folder_is_a_one_line_error(tmp_path, src, bad):
    d = dive(tmp_path, src, {"a.dng": "a"})
    out = tmp_path / "out"
    args = ["--depth", 5, "--distance", 1.5]
    args = (bad + args[2:]) if bad[0] == "--depth" else args + bad
    p = run_dive(d, out, src, *args)
    assert p.returncode == 2
    lines = error_lines(p.stderr)
    assert len(lines) == 1 and lines[0].startswith(f"uw3p measure: error: {bad[0]}: "), lines
    assert not out.exists()


def test_a_negative_cdom_slope_is_refused_naming_the_option(tmp_path, patch_csv):
    with open(tmp_path / "m.csv", "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=list(patch_csv[0]))
        w.writeheader()
        w.writerows(patch_csv)
    p = uw3p("estimate", tmp_path / "m.csv", "--depth", 10, "--distance", 5, "--cdom-slope", -1)
    assert p.returncode == 2 and "--cdom-slope" in p.stderr, (p.returncode, p.stderr[-300:])


@pytest.mark.slow
def test_one_photo_into_a_dives_out_gets_a_true_message(measured, src):
    d, out, prof = measured
    snap = snapshot(out)
    p = uw3p("measure", src["b"], "--profile", prof, "--out", out, "--depth", 6,
             "--distance", 1.5, "--exact", "--tiff", "none")
    assert p.returncode == 2
    assert "not uw3p results" not in p.stderr and "dive" in p.stderr, p.stderr
    assert snapshot(out) == snap


@pytest.mark.slow
def test_the_refusal_names_the_changed_field_only(measured):
    p = rerun(measured, "--path-model", "absorption")
    assert p.returncode == 2 and "absorption" in p.stderr
    assert "water_scattering_exponent" not in p.stderr and len(p.stderr) < 400, p.stderr
