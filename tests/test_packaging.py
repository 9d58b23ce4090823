"""The package as users get it (issue 40): an sdist and a wheel built from the checkout, both
accepted by ``twine check``, and the wheel alone (not the checkout) importable with its data
tables, running ``uw3p measure`` on a generated DNG (the dependencies from the environment the
tests run in: a fresh environment would download them all)."""

import importlib.util
import json
import shutil
import subprocess
import sys
import zipfile
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
needs = pytest.mark.skipif(
    importlib.util.find_spec("build") is None or importlib.util.find_spec("twine") is None,
    reason="build and twine are not installed (pip install -e '.[docs]')")


def _build(tmp_path):
    """sdist and wheel of a copy of the checkout's files (tracked or not ignored)."""
    src, out = tmp_path / "src", tmp_path / "dist"
    files = subprocess.run(["git", "ls-files", "--cached", "--others", "--exclude-standard"],
                           cwd=ROOT, capture_output=True, text=True, check=True).stdout.split("\n")
    for name in filter(None, files):
        if (ROOT / name).is_file():
            (src / name).parent.mkdir(parents=True, exist_ok=True)
            shutil.copy2(ROOT / name, src / name)
    res = subprocess.run([sys.executable, "-m", "build", "--no-isolation", "--outdir", str(out),
                          str(src)], capture_output=True, text=True)
    assert res.returncode == 0, res.stdout[-2000:] + res.stderr[-2000:]
    return out


@needs
@pytest.mark.release
def test_sdist_and_wheel_pass_twine_check_and_the_wheel_alone_works(tmp_path):
    dist = _build(tmp_path)
    files = sorted(dist.iterdir())
    assert {f.suffix for f in files} == {".whl", ".gz"}, files
    res = subprocess.run([sys.executable, "-m", "twine", "check", "--strict",
                          *map(str, files)], capture_output=True, text=True)
    assert res.returncode == 0, res.stdout + res.stderr
    _wheel_alone(dist, tmp_path)


def _wheel_alone(dist, tmp_path):
    """The wheel unpacked alone: its data tables all there, it imports from itself (not the
    checkout), and ``uw3p measure`` measures a generated DNG with it."""
    wheel = next(dist.glob("*.whl"))
    with zipfile.ZipFile(wheel) as z:
        names = z.namelist()
        z.extractall(tmp_path / "site")
    data = {Path(n).name for n in names if n.startswith("uw3p_data/")}
    tracked = {Path(p).name for p in subprocess.run(
        ["git", "ls-files", "data"], cwd=ROOT, capture_output=True, text=True,
        check=True).stdout.split() if p.endswith((".csv", ".md"))}
    assert tracked and tracked <= data, sorted(tracked - data)
    packages = {str(p.parent.relative_to(ROOT)) for top in ("forward", "sca", "measure",
                "experiments", "uw3p") for p in (ROOT / top).rglob("__init__.py")}
    in_wheel = {str(Path(n).parent) for n in names if n.endswith("/__init__.py")}
    assert packages <= in_wheel, sorted(packages - in_wheel)
    code = ("import forward, sca, measure, uw3p, uw3p_data, experiments, pathlib, sys;"
            "root = pathlib.Path(sys.argv[1]).resolve();"
            "assert all(root in pathlib.Path(m.__file__).resolve().parents "
            "for m in (forward, sca, measure, uw3p, uw3p_data, experiments)), "
            "'imported from the checkout';"
            "from experiments.synthetic_photo import Scene, default_corners, render_mosaic, "
            "write_dng;"
            "c = default_corners(360, 240);"
            "write_dng(render_mosaic(Scene(chl=2.0, cdom=0.1, depth=5.0, distance=1.5, "
            "gain=30000, width=360, height=240, seed=2), c), 'reef.dng');"
            "print(' '.join(f'{x:g},{y:g}' for x, y in c))")
    env = {"PYTHONPATH": str(tmp_path / "site"), "PATH": "/usr/bin:/bin",
           "OPENBLAS_NUM_THREADS": "1", "HOME": str(tmp_path)}
    run = tmp_path / "run"
    run.mkdir()
    res = subprocess.run([sys.executable, "-c", code, str(tmp_path / "site")], cwd=run,
                         env=env, capture_output=True, text=True, timeout=600)
    assert res.returncode == 0, res.stderr[-2000:]
    corners = res.stdout.strip().splitlines()[-1]
    res = subprocess.run([sys.executable, "-c", "import sys; from uw3p.cli import main; "
                          "sys.exit(main())", "measure", "reef.dng", "--depth", "5",
                          "--distance", "1.5", "--corners", corners, "--exact", "--tiff", "none",
                          "--out", "result"],
                         cwd=run, env=env, capture_output=True, text=True, timeout=900)
    # exit 1: measured, not reliable (no calibration profile: 'uncalibrated-camera')
    assert res.returncode == 1, res.stdout[-2000:] + res.stderr[-2000:]
    m = json.loads((run / "result" / "measurement.json").read_text())
    assert m["estimate"]["verdicts"]["c_490"] == "measured"
    lo, hi = m["estimate"]["quantity_intervals"]["c_490"]
    assert lo < 0.130 < hi  # the generated water's c(490), m^-1


def test_ci_fails_when_the_real_data_are_missing(tmp_path):
    """.ci/run stops with a message naming ../shared/realdata rather than letting the real-data
    tests skip (issue 50); with the folder beside the clone it goes on to ``make test``."""
    clone = tmp_path / "clone"
    (clone / ".ci").mkdir(parents=True)
    shutil.copy2(ROOT / ".ci" / "run", clone / ".ci" / "run")
    (clone / "Makefile").write_text("test:\n\t@echo made-test; exit 3\n")
    run = subprocess.run(["bash", str(clone / ".ci" / "run")], capture_output=True, text=True)
    assert run.returncode == 1 and "../shared/realdata is missing" in run.stderr
    assert "made-test" not in run.stdout
    (tmp_path / "shared" / "realdata").mkdir(parents=True)
    run = subprocess.run(["bash", str(clone / ".ci" / "run")], capture_output=True, text=True)
    assert run.returncode != 0 and "made-test" in run.stdout and "realdata" not in run.stderr
