"""The package as users get it (issues 40, 49): an sdist and a wheel built from the checkout, both
accepted by ``twine check``; the wheel holds what a user imports and runs (``forward``, ``sca``,
``measure``, ``uw3p``, ``uw3p_data``; not ``experiments``, the replication side, which runs from
the repository: decision 0082-installed-packages), and installed alone in a clean venv (not the
checkout) it imports with its data tables and runs ``uw3p calibrate``, ``measure``, ``correct``
and ``design`` on generated DNGs (the dependencies from the environment the tests run in, by a
path file: a fresh environment would download them all)."""

import importlib.util
import json
import shutil
import subprocess
import sys
import sysconfig
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
    _wheel_alone(next(dist.glob("*.whl")), tmp_path)


#: What the wheel installs at the top level (decision 0082-installed-packages).
INSTALLED = {"forward", "sca", "measure", "uw3p", "uw3p_data"}


def _wheel_alone(wheel, tmp_path):
    """The wheel's contents, then installed alone in a clean venv: it imports from itself, has no
    ``experiments``, and its ``uw3p`` command runs calibrate, measure, correct and design."""
    with zipfile.ZipFile(wheel) as z:
        names = z.namelist()
    top = {n.split("/")[0] for n in names if not n.split("/")[0].endswith(".dist-info")}
    assert top == INSTALLED, sorted(top ^ INSTALLED)
    data = {Path(n).name for n in names if n.startswith("uw3p_data/")}
    tracked = {Path(p).name for p in subprocess.run(
        ["git", "ls-files", "data"], cwd=ROOT, capture_output=True, text=True,
        check=True).stdout.split() if p.endswith((".csv", ".md"))}
    assert tracked and tracked <= data, sorted(tracked - data)
    packages = {str(p.parent.relative_to(ROOT)) for top in INSTALLED - {"uw3p_data"}
                for p in (ROOT / top).rglob("__init__.py")}
    in_wheel = {str(Path(n).parent) for n in names if n.endswith("/__init__.py")}
    assert packages <= in_wheel, sorted(packages - in_wheel)
    venv = _venv(wheel, tmp_path)
    run = tmp_path / "run"
    run.mkdir()
    _installed_alone(venv, run, tmp_path)
    _commands(venv, run, tmp_path)


def _venv(wheel, tmp_path) -> Path:
    """A clean venv with the wheel installed (no dependencies: they come from this environment's
    site-packages by a path file, whose own path files -- an editable install -- are not run)."""
    venv = tmp_path / "venv"
    subprocess.run([sys.executable, "-m", "venv", "--without-pip", str(venv)], check=True)
    py = venv / "bin" / "python"
    res = subprocess.run([sys.executable, "-m", "pip", "--python", str(py), "install", "--quiet",
                          "--no-deps", "--no-index", str(wheel)], capture_output=True, text=True)
    assert res.returncode == 0, res.stdout[-2000:] + res.stderr[-2000:]
    site = subprocess.run([str(py), "-c", "import sysconfig; print(sysconfig.get_paths()['purelib'])"],
                          capture_output=True, text=True, check=True).stdout.strip()
    (Path(site) / "uw3p_test_deps.pth").write_text(sysconfig.get_paths()["purelib"] + "\n")
    return venv


def _run(venv, args, run, tmp_path, timeout=900):
    env = {"PATH": f"{venv / 'bin'}:/usr/bin:/bin", "OPENBLAS_NUM_THREADS": "1",
           "HOME": str(tmp_path)}
    return subprocess.run([str(a) for a in args], cwd=run, env=env, capture_output=True,
                          text=True, timeout=timeout)


def _installed_alone(venv, run, tmp_path):
    """Every package from the venv (not the checkout); no ``experiments`` importable; the air
    and underwater DNGs written with the installed :mod:`measure.synthetic_photo`."""
    code = ("import importlib.util, pathlib, sys, forward, sca, measure, uw3p, uw3p_data;"
            "root = pathlib.Path(sys.prefix).resolve();"
            "assert all(root in pathlib.Path(m.__file__).resolve().parents "
            "for m in (forward, sca, measure, uw3p, uw3p_data)), 'imported from the checkout';"
            "assert importlib.util.find_spec('experiments') is None, 'experiments installed';"
            "from measure.synthetic_photo import Scene, default_corners, render_mosaic, "
            "write_dng;"
            "c = default_corners(360, 240);"
            "write_dng(render_mosaic(Scene(chl=0, cdom=0, depth=0, distance=0, gain=9000, "
            "width=360, height=240, seed=1), c), 'air.dng');"
            "write_dng(render_mosaic(Scene(chl=2.0, cdom=0.1, depth=5.0, distance=1.5, "
            "gain=30000, width=360, height=240, seed=2), c), 'reef.dng');"
            "print(' '.join(f'{x:g},{y:g}' for x, y in c))")
    res = _run(venv, [venv / "bin" / "python", "-c", code], run, tmp_path, timeout=600)
    assert res.returncode == 0, res.stderr[-2000:]
    (run / "corners.txt").write_text(res.stdout.strip().splitlines()[-1])


def _commands(venv, run, tmp_path):
    """The installed ``uw3p``: calibrate, measure, correct, design; figures says where it runs."""
    uw3p = venv / "bin" / "uw3p"
    corners = (run / "corners.txt").read_text()
    res = _run(venv, [uw3p, "calibrate", "air.dng", "--corners", corners, "--out",
                      "profile.json"], run, tmp_path)
    assert res.returncode == 0, res.stdout[-2000:] + res.stderr[-2000:]
    res = _run(venv, [uw3p, "measure", "reef.dng", "--depth", "5", "--distance", "1.5",
                      "--corners", corners, "--profile", "profile.json", "--exact", "--tiff",
                      "none", "--out", "result"], run, tmp_path)
    assert res.returncode in (0, 1), res.stdout[-2000:] + res.stderr[-2000:]
    m = json.loads((run / "result" / "measurement.json").read_text())
    assert m["estimate"]["verdicts"]["c_490"] == "measured"
    lo, hi = m["estimate"]["quantity_intervals"]["c_490"]
    assert lo < 0.130 < hi  # the generated water's c(490), m^-1
    res = _run(venv, [uw3p, "correct", "reef.dng", "--water", "result/measurement.json",
                      "--range", "1.5", "--out", "corrected"], run, tmp_path)
    assert res.returncode == 0, res.stdout[-2000:] + res.stderr[-2000:]
    assert any((run / "corrected").iterdir())
    res = _run(venv, [uw3p, "design", "--depth", "5", "--distance", "1", "--chl", "1", "--cdom",
                      "0.1", "--gain", "known", "--exact"], run, tmp_path)
    assert res.returncode == 0 and "verdict" in res.stdout, res.stdout[-2000:] + res.stderr[-2000:]
    res = _run(venv, [uw3p, "figures", "--grid", "reduced"], run, tmp_path)
    assert res.returncode == 2 and "experiments: not installed" in res.stderr \
        and "repository" in res.stderr, \
        res.stderr[-2000:]
    assert not (run / "figures").exists()


def test_no_installed_package_imports_experiments():
    """What the wheel installs (pyproject's package list: not experiments) never imports
    experiments: library code, commands and doctests (decision 0082-installed-packages);
    ``uw3p figures`` and ``uw3p bench`` find the checkout through uw3p.common.replication_root."""
    import re
    import tomllib

    listed = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["setuptools"]["packages"]
    assert {p.split(".")[0] for p in listed} == INSTALLED, listed
    pattern = re.compile(r"^\s*(>>> )?(from|import) experiments\b", re.M)
    found = [str(f.relative_to(ROOT)) for top in INSTALLED - {"uw3p_data"}
             for f in (ROOT / top).rglob("*.py") if pattern.search(f.read_text())]
    assert found == ["uw3p/cmd_figures.py"], found  # after replication_root: the checkout's


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
