"""The figure pipeline end to end on the reduced grid: files, CSVs, cache, resume, trends."""

import csv
import json
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from experiments import estimation, grids, sweep
from experiments.__main__ import main as run_all

ROOT = Path(__file__).resolve().parents[1]
ESTIMATION_FIGURES = ["fig09_attenuation", "fig10_rrmse", "fig11_colour_correction",
                      "fig12_chlorophyll", "fig13_cdom", "noise_study"]


def read_csv(path):
    with open(path, newline="") as f:
        rows = list(csv.reader(line for line in f if not line.startswith("#")))
    return rows[0], rows[1:]


@pytest.fixture(scope="module")
def reduced_run(tmp_path_factory):
    out = tmp_path_factory.mktemp("figures")
    cache = tmp_path_factory.mktemp("cache")
    run_all(["--grid", "reduced", "--out", str(out), "--cache", str(cache)])
    return out, cache


def test_files_written_and_csvs_parse(reduced_run):
    out, _ = reduced_run
    for name in ESTIMATION_FIGURES:
        for ext in ("png", "pdf", "csv"):
            assert (out / f"{name}.{ext}").stat().st_size > 100, f"{name}.{ext}"
        header, rows = read_csv(out / f"{name}.csv")
        assert rows and all(len(r) == len(header) for r in rows)
        for r in rows:  # every numeric cell is finite
            for cell in r:
                try:
                    assert np.isfinite(float(cell)), (name, r)
                except ValueError:
                    pass


def test_cached_rerun_recomputes_nothing(reduced_run):
    _, cache = reduced_run
    g = grids.grid("reduced")
    results, computed = sweep.run(estimation.fig10_conditions(g), cache_dir=cache, progress=False)
    assert computed == 0 and len(results) == len(estimation.fig10_conditions(g))


def test_trends_on_reduced_sweep(reduced_run):
    out, _ = reduced_run
    _, rows = read_csv(out / "fig10_rrmse.csv")
    by_depth = {}
    for depth, _dist, mean, *_ in rows:
        by_depth.setdefault(float(depth), []).append(float(mean))
    assert np.mean(by_depth[20.0]) > np.mean(by_depth[5.0])
    _, rows = read_csv(out / "noise_study.csv")
    rrmse = {float(r[0]): float(r[1]) for r in rows}
    assert rrmse[20.0] > 5 * rrmse[20000.0]  # less light, more noise, larger error
    _, rows = read_csv(out / "fig11_colour_correction.csv")
    for r in rows:  # colour correction reduces the colour error
        assert float(r[3]) < 0.5 * float(r[2])


def test_figures_reproducible_bit_for_bit(reduced_run, tmp_path):
    out, _ = reduced_run
    run_all(["fig09_attenuation", "--grid", "reduced", "--out", str(tmp_path),
             "--cache", str(tmp_path / "cache")])
    assert (tmp_path / "fig09_attenuation.csv").read_bytes() == (out / "fig09_attenuation.csv").read_bytes()


def test_killed_run_resumes(tmp_path):
    g = grids.grid("reduced")
    conds = estimation.fig12_conditions(g)
    cache = tmp_path / "cache"
    code = ("import sys; from experiments import sweep, estimation, grids; "
            "sweep.run(estimation.fig12_conditions(grids.grid('reduced')), cache_dir=sys.argv[1], "
            "workers=1, progress=False)")
    proc = subprocess.Popen([sys.executable, "-c", code, str(cache)], cwd=ROOT)
    try:
        deadline = time.time() + 120
        while time.time() < deadline and proc.poll() is None:
            if cache.exists() and len(list(cache.glob("*.json"))) >= 3:
                break
            time.sleep(0.05)
        proc.kill()
    finally:
        proc.wait()
    done_before = len(list(cache.glob("*.json")))
    assert 0 < done_before < len(conds), "the run was not interrupted mid-way"
    for p in cache.glob("*.json"):  # every finished file is complete (atomic writes)
        json.loads(p.read_text())
    results, computed = sweep.run(conds, cache_dir=cache, workers=1, progress=False)
    assert computed == len(conds) - done_before
    assert len(results) == len(conds)
    assert all(r["chl"] == c["chl"] and r["seed"] == c["seed"] for r, c in zip(results, conds))
