"""The uw3p CLI (simulate) and the appearance figure scripts."""

import csv
import io
import json

import numpy as np
import pytest

import forward
from forward.cli import main


def run(argv):
    out, err = io.StringIO(), io.StringIO()
    code = main(argv, out, err)
    return code, out.getvalue(), err.getvalue()


def test_cli_simulate_csv_and_json(tmp_path):
    code, out, _ = run(["simulate", "--chl", "1", "--cdom", "0.1", "--depth", "10", "--distance", "5",
                        "--no-noise"])
    assert code == 0
    rows = list(csv.reader(io.StringIO(out)))
    assert rows[0] == ["patch", "red", "green", "blue"] and len(rows) == 25
    sim = forward.simulate_chart(1, 0.1, 10, 5, noise=False)
    np.testing.assert_allclose(np.array(rows[1:], float)[:, 1:].T, sim.rgb, rtol=1e-15)
    f = tmp_path / "s.json"
    code, _, err = run(["simulate", "--chl", "1", "--cdom", "0.1", "--depth", "10", "--distance", "5",
                        "--seed", "4", "--out", str(f)])
    assert code == 0 and json.loads(f.read_text())["seed"] == 4


@pytest.mark.parametrize("argv,word", [
    (["--chl", "-1", "--cdom", "0.1", "--depth", "10", "--distance", "5"], "chl"),
    (["--chl", "1", "--cdom", "0.1", "--depth", "10", "--distance", "5", "--camera", "Sigma SDMerill (NPL)"], "camera"),
    (["--chl", "1", "--cdom", "0.1", "--depth", "nan", "--distance", "5"], "depth"),
])
def test_cli_bad_input_exits_2(argv, word):
    code, out, err = run(["simulate"] + argv)
    assert code == 2 and err.startswith("uw3p simulate: error: " + word)


def test_appearance_figures_and_hue_trend(tmp_path):
    from experiments import fig05_06_appearance_sites, fig07_depth_distance, fig08_chlorophyll

    fig05_06_appearance_sites.main(tmp_path)
    res7 = fig07_depth_distance.main(tmp_path)
    fig08_chlorophyll.main(tmp_path)
    for name in ("fig05_06_sites", "fig07_depth_distance", "fig08_chlorophyll"):
        for ext in ("png", "pdf"):
            assert (tmp_path / f"{name}.{ext}").stat().st_size > 1000
    # hue moves from blue toward green as C rises: camera G/B of the white patch increases
    ratios = []
    for c in fig08_chlorophyll.CHL_MG_M3:
        rgb = forward.simulate_chart(c, 0.1, 10, 1, noise=False).rgb[:, 18]
        ratios.append(rgb[1] / rgb[2])
    assert np.all(np.diff(ratios) > 0) and ratios[0] < 1.5 < ratios[-1]
    # colours fade with depth: the spread of the patches' camera chromaticities shrinks
    spread = {}
    for cond, _ in res7:
        if cond["distance"] == 1.0:
            rgb = forward.simulate_chart(cond["chl"], cond["cdom"], cond["depth"], 1.0, noise=False).rgb
            spread[cond["depth"]] = (rgb / rgb.sum(0)).std(1).sum()
    depths = sorted(spread)
    assert len(depths) == 4
    assert all(spread[a] > spread[b] for a, b in zip(depths, depths[1:])), spread


def test_cli_estimate_round_trip(tmp_path):
    f = tmp_path / "m.csv"
    code, _, _ = run(["simulate", "--chl", "2", "--cdom", "0.3", "--depth", "10", "--distance", "5",
                      "--no-noise", "--out", str(f)])
    assert code == 0
    code, out, err = run(["estimate", str(f), "--depth", "10", "--distance", "5", "--json"])
    assert code == 0, err
    res = json.loads(out)
    assert res["converged"] and abs(res["chl"] / 2 - 1) < 1e-6 and abs(res["cdom"] / 0.3 - 1) < 1e-6
    code, out, _ = run(["estimate", str(f), "--depth", "10", "--distance", "5", "--mode", "paper"])
    assert "chl (C)" in out and "wavelength_nm,attenuation_k" in out and code in (0, 1)
    bad = tmp_path / "bad.csv"
    bad.write_text("patch,red,green,blue\n1,0.1,0.2\n")
    code, _, err = run(["estimate", str(bad), "--depth", "10", "--distance", "5"])
    assert code == 2 and "measurements" in err
    code, _, err = run(["estimate", str(f), "--depth", "-1", "--distance", "5"])
    assert code == 2 and "depth" in err


def test_cli_estimate_batch(tmp_path):
    f = tmp_path / "batch.csv"
    lines = ["chart,patch,red,green,blue,depth_m"]
    truth = [(1.0, 0.1, 5.0), (3.0, 0.5, 10.0)]
    for j, (c, a, d) in enumerate(truth):
        rgb = forward.simulate_chart(c, a, d, 2.0, noise=False).rgb
        lines += [f"{j},{p + 1},{rgb[0, p]!r},{rgb[1, p]!r},{rgb[2, p]!r},{d}" for p in range(24)]
    f.write_text("\n".join(lines) + "\n")
    code, out, err = run(["estimate", "--batch", str(f), "--distance", "2"])
    assert code == 0, err
    rows = list(csv.DictReader(io.StringIO(out)))
    assert len(rows) == 2
    for row, (c, a, _) in zip(rows, truth):
        assert abs(float(row["chl"]) / c - 1) < 1e-6 and abs(float(row["cdom"]) / a - 1) < 1e-6
        assert row["converged"] == "True"
    code, _, err = run(["estimate", "--batch", str(f)])
    assert code == 2 and "--distance" in err
