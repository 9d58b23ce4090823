"""The package as users get it (issue 40): an sdist and a wheel built from the checkout, both
accepted by ``twine check``, and the wheel alone (not the checkout) importable with its data
tables, simulating and estimating a chart."""

import importlib.util
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
@pytest.mark.slow
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
    checkout) and estimates a chart."""
    wheel = next(dist.glob("*.whl"))
    with zipfile.ZipFile(wheel) as z:
        names = z.namelist()
        z.extractall(tmp_path / "site")
    data = {Path(n).name for n in names if n.startswith("uw3p_data/")}
    tracked = {Path(p).name for p in subprocess.run(
        ["git", "ls-files", "data"], cwd=ROOT, capture_output=True, text=True,
        check=True).stdout.split() if p.endswith((".csv", ".md"))}
    assert tracked and tracked <= data, sorted(tracked - data)
    code = ("import forward, sca, measure, uw3p, uw3p_data, pathlib, sys;"
            "root = pathlib.Path(sys.argv[1]).resolve();"
            "assert all(root in pathlib.Path(m.__file__).resolve().parents "
            "for m in (forward, sca, measure, uw3p, uw3p_data)), 'imported from the checkout';"
            "sim = forward.simulate_chart(2.0, 0.1, depth=5, distance=1, seed=0, noise=False);"
            "est = sca.estimate_batch(sim.rgb[None], depth=5, distance=1, intervals=False,"
            " uncertain={});"
            "print(round(float(est.chl[0]), 3))")
    env = {"PYTHONPATH": str(tmp_path / "site"), "PATH": "/usr/bin:/bin",
           "OPENBLAS_NUM_THREADS": "1", "HOME": str(tmp_path)}
    res = subprocess.run([sys.executable, "-c", code, str(tmp_path / "site")], cwd=tmp_path,
                         env=env, capture_output=True, text=True, timeout=600)
    assert res.returncode == 0, res.stderr[-2000:]
    assert float(res.stdout.split()[-1]) == pytest.approx(2.0, rel=1e-3)
