"""Every input gets a clear answer (issue 22): spreadsheet CSV dialects, columns by name,
conflicting inputs, quoted chart ids, big batches, every built-in camera, bad values refused
with the argument named, error messages that name the real cause, glints left out pixel by
pixel, and a concise default output."""

import csv
import io
import json
from pathlib import Path

import numpy as np
import pytest

import forward
import measure
import sca
from measure.chart import CLIP_SIGMA, sample_patches
from measure.image import Photo
from uw3p import cmd_estimate, patchfile
from uw3p.cli import COMMANDS, build_parser, main

#: the 49 measured camera curves (for tests only: never copied into the project)
CURVES = Path(__file__).resolve().parents[2] / "shared" / "realdata" / "camera_sensitivities"
GROUND_TRUTHS = CURVES / "ground-truths"
needs_curves = pytest.mark.skipif(not GROUND_TRUTHS.is_dir(),
                                  reason=f"the measured camera curves ({GROUND_TRUTHS}) are absent")
SIGMA_CAMERA = "Sigma SDMerill (NPL)"
TRUTH = (2.0, 0.3, 10.0, 5.0)


def run(argv):
    out, err = io.StringIO(), io.StringIO()
    code = main([str(a) for a in argv], out, err)
    return code, out.getvalue(), err.getvalue()


@pytest.fixture(scope="module")
def sim():
    return forward.simulate_chart(*TRUTH, noise=False)


def _rows(sim, names=("patch", "red", "green", "blue", "red_sd", "green_sd", "blue_sd")):
    """Rows of a chart under the given column names (the channel of each by its canonical
    name), patches in reverse order."""
    canon = {"patch": "patch", "r": "red", "g": "green", "b": "blue"}
    idx = {"red": 0, "green": 1, "blue": 2}
    rows = []
    for p in reversed(range(24)):
        row = []
        for n in names:
            c = n.lower().replace(" ", "_")
            base = canon.get(c[:-3] if c.endswith("_sd") else c, c[:-3] if c.endswith("_sd") else c)
            if base == "patch":
                row.append(str(p + 1))
            else:
                arr = sim.rgb_sigma if c.endswith("_sd") else sim.rgb
                row.append(repr(float(arr[idx[base], p])))
        rows.append(row)
    return [list(names)] + rows


def _write(path, rows, delimiter=",", decimal_comma=False, encoding="utf-8", prefix=""):
    buf = io.StringIO()
    w = csv.writer(buf, delimiter=delimiter, lineterminator="\r\n")
    for r in rows:
        w.writerow([x.replace(".", ",") if decimal_comma else x for x in r])
    path.write_text(prefix + buf.getvalue(), encoding=encoding)
    return path


def _estimate_json(path, *extra):
    code, out, err = run(["estimate", path, "--depth", TRUTH[2], "--distance", TRUTH[3], "--json",
                          "--exact", *extra])
    assert code in (0, 1), err
    return json.loads(out)


# --------------------------------------------------------------------------- dialects
@pytest.mark.parametrize("dialect", ["utf-8 BOM", "semicolon + decimal comma", "tab",
                                     "sep= line", "utf-16 BOM", "comments and blank lines"])
def test_spreadsheet_dialects_read_like_plain_csv(tmp_path, sim, dialect):
    rows = _rows(sim)
    plain = patchfile.read_patch_csv(_write(tmp_path / "plain.csv", rows))
    kw = {"utf-8 BOM": dict(encoding="utf-8-sig"),
          "semicolon + decimal comma": dict(delimiter=";", decimal_comma=True,
                                            encoding="utf-8-sig"),
          "tab": dict(delimiter="\t", decimal_comma=True),
          "sep= line": dict(delimiter=";", prefix="sep=;\r\n"),
          "utf-16 BOM": dict(delimiter="\t", encoding="utf-16"),
          "comments and blank lines": dict(prefix="# exported 2024-06-01\r\n\r\n")}[dialect]
    f = _write(tmp_path / "x.csv", rows, **kw)
    M, sd = patchfile.read_patch_csv(f)
    np.testing.assert_array_equal(M, plain[0])
    np.testing.assert_array_equal(sd, plain[1])
    np.testing.assert_array_equal(M, sim.rgb)


def test_bom_and_semicolon_files_estimate_like_the_plain_one(tmp_path, sim):
    rows = _rows(sim)
    ref = _estimate_json(_write(tmp_path / "plain.csv", rows))
    for f in (_write(tmp_path / "bom.csv", rows, encoding="utf-8-sig"),
              _write(tmp_path / "semi.csv", rows, ";", True, "utf-8-sig")):
        res = _estimate_json(f)
        assert res["chl"] == ref["chl"] and res["noise_known"]
    assert abs(ref["chl"] / TRUTH[0] - 1) < 1e-6


def test_headerless_semicolon_decimal_comma(tmp_path, sim):
    rows = [r[:4] for r in _rows(sim)[1:]]
    M, sd = patchfile.read_patch_csv(_write(tmp_path / "h.csv", rows, ";", True))
    np.testing.assert_array_equal(M, sim.rgb)
    assert sd is None


def test_quoted_cells_may_hold_line_breaks(tmp_path, sim):
    """A spreadsheet cell with line breaks (Alt+Enter), blank lines included, is one cell,
    in the header as in the rows (issue 35: the header was split into lines before the csv
    module saw it, and a blank line inside a quoted chart id was dropped)."""
    rows = _rows(sim)
    rows[0][0] = "patch\n"  # a header cell ending in a line break
    M, sd = patchfile.read_patch_csv(_write(tmp_path / "h.csv", rows))
    np.testing.assert_array_equal(M, sim.rgb)
    rows = _batch_rows([("dive 3\n\nnorth", 1.0, 0.1, 5.0), ("dive 3\nnorth", 3.0, 0.5, 10.0)])
    ids, M, *_ = patchfile.read_batch_csv(_write(tmp_path / "b.csv", rows))
    assert ids == ["dive 3\n\nnorth", "dive 3\nnorth"] and M.shape == (2, 3, 24)
    rows[30][2] = "x"  # the line named is the row's own, after the rows of three lines
    with pytest.raises(ValueError, match="line 84: 'x' in red is not a number"):
        patchfile.read_batch_csv(_write(tmp_path / "b.csv", rows))


def test_a_trailing_separator_adds_no_column(tmp_path, sim):
    """An Excel-style trailing separator on every line: ignored with a header or without
    one; a value under it is refused, never silently dropped (issue 35)."""
    for header in (True, False):
        rows = [r[:4] + [""] for r in _rows(sim)[0 if header else 1:]]
        M, sd = patchfile.read_patch_csv(_write(tmp_path / "t.csv", rows))
        np.testing.assert_array_equal(M, sim.rgb)
        rows[5][4] = "0.7"
        with pytest.raises(ValueError, match=r"line 6: '0.7' in column 5, which has no name"):
            patchfile.read_patch_csv(_write(tmp_path / "t.csv", rows))


# --------------------------------------------------------------------------- columns by name
def test_channel_order_comes_from_the_header(tmp_path, sim):
    ref = patchfile.read_patch_csv(_write(tmp_path / "rgb.csv", _rows(sim)))
    for names in (("B", "G", "R", "patch"), ("patch", "blue", "green", "red"),
                  ("Patch", "b", "R", "g", "B_sd", "red_sd", "G SD")):
        M, sd = patchfile.read_patch_csv(_write(tmp_path / "x.csv", _rows(sim, names)))
        np.testing.assert_array_equal(M, ref[0])
        if any(n.lower().replace(" ", "_").endswith("_sd") for n in names):
            np.testing.assert_array_equal(sd, ref[1])


def test_R_G_B_with_red_sd_keeps_the_noise(tmp_path, sim):
    f = _write(tmp_path / "x.csv", _rows(sim, ("patch", "R", "G", "B", "red_sd", "green_sd",
                                                "blue_sd")))
    res = _estimate_json(f)
    assert res["noise_known"] and "noise-unknown" not in res["flags"]
    f = _write(tmp_path / "y.csv", _rows(sim, ("patch", "R", "G", "B", "R_sd", "G_sd", "B_sd")))
    assert patchfile.read_patch_csv(f)[1] is not None


@pytest.mark.parametrize("header,words", [
    ("patch,red,green,blue,notes", ["unknown column 'notes'", "known columns: patch, red"]),
    ("patch,red,green,blue,temperature,depth", ["unknown columns 'temperature', 'depth'"]),
    ("chart,patch,red,green,blue", ["'chart'", "use --batch"]),
    ("patch,R,red,green,blue", ["'red' is given twice"]),
    ("patch,red,green", ["no blue column"]),
    ("red,green,blue", ["no 'patch' column"]),
    ("patch,red,green,blue,red_sd", ["missing", "every channel or for none"]),
])
def test_unknown_or_missing_columns_are_refused_with_the_known_ones(tmp_path, header, words):
    n = header.count(",") + 1
    f = tmp_path / "x.csv"
    f.write_text(header + "\n" + "".join(f"{p}" + ",0.1" * (n - 1) + "\n" for p in range(1, 25)))
    code, _, err = run(["estimate", f, "--depth", 1, "--distance", 1])
    assert code == 2 and err.startswith("uw3p estimate: error: measurements:"), err
    for w in words:
        assert w in err, err


def _batch_rows(charts, header=("chart", "patch", "red", "green", "blue", "red_sd", "green_sd",
                                "blue_sd", "depth_m"), distance=2.0):
    """Rows of a batch file: charts = [(id, chl, cdom, depth)]."""
    rows = [list(header)]
    idx = {"red": 0, "green": 1, "blue": 2, "r": 0, "g": 1, "b": 2}
    for cid, c, a, d in charts:
        s = forward.simulate_chart(c, a, d, distance, noise=False)
        for p in range(24):
            row = []
            for h in header:
                if h == "chart":
                    row.append(cid)
                elif h == "patch":
                    row.append(str(p + 1))
                elif h == "depth_m":
                    row.append(repr(d))
                elif h.endswith("_sd"):
                    row.append(repr(float(s.rgb_sigma[idx[h[:-3].lower()], p])))
                else:
                    row.append(repr(float(s.rgb[idx[h.lower()], p])))
            rows.append(row)
    return rows


def test_batch_columns_in_any_order_and_rows_shuffled(tmp_path, monkeypatch):
    charts = [("a", 1.0, 0.1, 5.0), ("b", 3.0, 0.5, 10.0), ("c", 0.5, 0.05, 3.0)]
    rows = _batch_rows(charts, ("depth_m", "B", "patch", "G", "chart", "R"))
    body = rows[1:]
    np.random.default_rng(0).shuffle(body)
    monkeypatch.setattr(patchfile, "BLOCK_ROWS", 7)  # many blocks
    ids, M, sd, depth, dist = patchfile.read_batch_csv(
        _write(tmp_path / "b.csv", [rows[0]] + body, ";", True))
    assert sorted(ids) == ["a", "b", "c"] and sd is None and np.isnan(dist).all()
    for cid, c, a, d in charts:
        j = ids.index(cid)
        np.testing.assert_array_equal(M[j], forward.simulate_chart(c, a, d, 2.0, noise=False).rgb)
        assert depth[j] == d


# --------------------------------------------------------------------------- conflicts
def test_a_flag_that_conflicts_with_a_file_column_is_refused(tmp_path):
    f = _write(tmp_path / "b.csv", _batch_rows([("a", 1.0, 0.1, 5.0)]))
    code, _, err = run(["estimate", "--batch", f, "--depth", 12, "--distance", 2])
    assert code == 2 and err.startswith("uw3p estimate: error: --depth:") and "depth_m" in err
    code, _, err = run(["estimate", "--batch", f])
    assert code == 2 and "--distance: required unless" in err
    code, out, err = run(["estimate", "--batch", f, "--distance", 2, "--exact"])
    assert code == 0, err


# --------------------------------------------------------------------------- output
def test_chart_ids_are_quoted_in_the_output(tmp_path):
    ids = ['dive 3, north', 'say "hi"', "plain", "#7 (not a comment)"]
    f = _write(tmp_path / "b.csv", _batch_rows([(i, 1.0, 0.1, 5.0) for i in ids]))
    code, out, err = run(["estimate", "--batch", f, "--distance", 2, "--exact"])
    assert code == 0, err
    rows = list(csv.reader(io.StringIO(out)))
    assert [r[0] for r in rows[1:]] == ids
    assert {len(r) for r in rows} == {len(rows[0])}
    k = tmp_path / "k.csv"
    code, out, err = run(["estimate", "--batch", f, "--distance", 2, "--exact", "--json",
                          "--attenuation", k])
    data = json.loads(out)
    assert [c["chart"] for c in data["charts"]] == ids
    krows = list(csv.reader(k.open()))
    assert [r[0] for r in krows[1:]] == ids and len(krows[0]) == 1 + len(data["wavelengths"])
    np.testing.assert_allclose(np.array(krows[2][1:], float), data["charts"][1]["attenuation"],
                               rtol=1e-15)
    # comments are read before the header only
    g = tmp_path / "c.csv"
    g.write_text("# made by hand\n" + f.read_text())
    assert patchfile.read_batch_csv(g)[0] == ids


def test_an_output_is_written_whole_or_not_at_all(tmp_path):
    f = _write(tmp_path / "b.csv", _batch_rows([("a", 1.0, 0.1, 5.0)]))
    k = tmp_path / "k.csv"
    k.write_text("old\n")
    code, out, err = run(["estimate", "--batch", f, "--distance", 2, "--exact", "--saturation",
                          -1, "--attenuation", k])
    assert code == 2 and out == "" and k.read_text() == "old\n"
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".k.csv")]


# --------------------------------------------------------------------------- big batches
def test_big_batch_is_fitted_in_blocks_with_progress_and_the_same_answers(tmp_path, monkeypatch):
    charts = [(f"c{j}", c, a, d) for j, (c, a, d) in
              enumerate([(1.0, 0.1, 5.0), (3.0, 0.5, 10.0), (0.5, 0.05, 3.0)] * 3)]
    f = _write(tmp_path / "b.csv", _batch_rows(charts))
    code, one, err = run(["estimate", "--batch", f, "--distance", 2, "--exact"])
    assert code == 0 and "fitting" not in err
    monkeypatch.setattr(cmd_estimate, "FIT_BLOCK", 2)
    monkeypatch.setattr(cmd_estimate, "PROGRESS_CHARTS", 4)
    monkeypatch.setattr(cmd_estimate, "PROGRESS_BYTES", 1)
    code, blocks, err = run(["estimate", "--batch", f, "--distance", 2, "--exact"])
    assert code == 0 and "fitting" in err and "reading" in err and "9 charts" in err
    a, b = (list(csv.DictReader(io.StringIO(t))) for t in (one, blocks))
    assert [r["chart"] for r in a] == [r["chart"] for r in b]
    for x, y in zip(a, b):
        assert float(x["chl"]) == pytest.approx(float(y["chl"]), rel=1e-9)
        assert x["reliable"] == y["reliable"] == "True"


def test_batch_reader_is_exact_over_many_blocks(tmp_path, monkeypatch):
    # correctness of the linear reader (its speed is measured, not tested: no timed tests)
    rng = np.random.default_rng(1)
    N = 300
    vals = rng.random((N, 3, 24))
    lines = ["chart,patch,red,green,blue,distance_m"]
    order = [(j, p) for j in range(N) for p in range(24)]
    rng.shuffle(order)
    lines += [f"chart {j},{p + 1},{vals[j, 0, p]!r},{vals[j, 1, p]!r},{vals[j, 2, p]!r},{j % 7}"
              for j, p in order]
    f = tmp_path / "big.csv"
    f.write_text("\n".join(lines) + "\n")
    monkeypatch.setattr(patchfile, "BLOCK_ROWS", 1000)
    ids, M, sd, depth, dist = patchfile.read_batch_csv(f)
    perm = [int(i.split()[1]) for i in ids]
    np.testing.assert_array_equal(M, vals[perm])
    np.testing.assert_array_equal(dist, np.array(perm) % 7)
    assert sd is None and np.isnan(depth).all()


@pytest.mark.parametrize("edit,words", [
    (lambda r: r[30].__setitem__(2, "nan"), ["line 31", "chart 'b'", "NaN"]),
    (lambda r: r[30].__setitem__(2, "x"), ["line 31", "'x' in red is not a number"]),
    (lambda r: r[30].__setitem__(2, ""), ["line 31", "an empty cell"]),
    (lambda r: r[30].__setitem__(2, "-0.1"), ["line 31", "chart 'b'", "negative"]),
    (lambda r: r.pop(30), ["chart 'b' has 23 patches"]),
    (lambda r: r[30].__setitem__(1, "3"), ["chart 'b'", "patch 3 is given more than once"]),
    (lambda r: r[30].__setitem__(8, "7"), ["chart 'b' has more than one depth_m"]),
    (lambda r: r[30].append("1"), ["line 31 has 10 fields, the header 9"]),
])
def test_a_bad_chart_in_a_batch_file_is_named(tmp_path, edit, words):
    rows = _batch_rows([("a", 1.0, 0.1, 5.0), ("b", 3.0, 0.5, 10.0)])
    edit(rows)
    f = _write(tmp_path / "b.csv", rows)
    code, _, err = run(["estimate", "--batch", f, "--distance", 2])
    assert code == 2 and err.startswith("uw3p estimate: error: --batch:"), err
    for w in words:
        assert w in err, err


# --------------------------------------------------------------------------- cameras
@pytest.mark.parametrize("camera", sorted(__import__("colour").MSDS_CAMERA_SENSITIVITIES))
def test_every_built_in_camera_works_on_the_default_grid(tmp_path, camera):
    f = tmp_path / "m.csv"
    code, _, err = run(["simulate", "--chl", 2, "--cdom", 0.3, "--depth", 10, "--distance", 5,
                        "--no-noise", "--camera", camera, "--out", f])
    assert code == 0, err
    res = _estimate_json(f, "--camera", camera)
    assert abs(res["chl"] / 2 - 1) < 1e-6 and len(res["wavelengths"]) == 301
    code, out, err = run(["design", "--depth", 5, "--distance", 1, "--chl", 1, "--cdom", 0.1,
                          "--camera", camera])
    assert code in (0, 1) and "verdict" in out, err


def test_a_camera_that_stops_short_is_zero_beyond_its_data_and_said_so():
    sens = forward.camera_sensitivities(SIGMA_CAMERA)
    wl = forward.wavelength_grid()
    assert np.all(sens[wl > 680] == 0) and np.all(sens[wl <= 680].max(axis=0) == 1)
    code, out, err = run(["simulate", "--chl", 1, "--cdom", 0.1, "--depth", 5, "--distance", 1,
                          "--camera", SIGMA_CAMERA])
    assert code == 0 and "taken as 0 from 680 nm to 700 nm" in err


def test_a_camera_csv_that_does_not_fall_to_zero_names_the_range_and_the_options(tmp_path):
    f = tmp_path / "cam.csv"
    wl = np.arange(450, 701, 10)
    f.write_text("wavelength,red,green,blue\n" + "".join(
        f"{w},{np.exp(-((w - 600) / 40) ** 2)},{np.exp(-((w - 530) / 40) ** 2)},"
        f"{np.exp(-((w - 460) / 40) ** 2)}\n" for w in wl))
    code, _, err = run(["design", "--depth", 5, "--distance", 1, "--chl", 1, "--cdom", 0.1,
                        "--camera", f])
    assert code == 2 and err.startswith("uw3p design: error: --camera: data cover 450-700 nm")
    assert "--wl-min/--wl-max" in err and "wavelengths=" not in err
    code, out, err = run(["design", "--depth", 5, "--distance", 1, "--chl", 1, "--cdom", 0.1,
                          "--camera", f, "--wl-min", 450])
    assert code in (0, 1), err


@needs_curves
def test_the_measured_camera_curves_load_on_the_default_grid():
    files = sorted(GROUND_TRUTHS.glob("*.csv"))
    assert len(files) == 49
    for f in files:
        sens = forward.camera_sensitivities(f)
        assert sens.shape == (301, 3) and np.allclose(sens.max(axis=0), 1), f.name


@needs_curves
def test_every_measured_camera_works_from_the_command_line(tmp_path):
    for f in sorted(GROUND_TRUTHS.glob("*.csv")):
        code, out, err = run(["design", "--depth", 5, "--distance", 1, "--chl", 1, "--cdom", 0.1,
                              "--camera", f, "--exact"])
        assert code in (0, 1) and "verdict" in out, (f.name, err)


# --------------------------------------------------------------------------- bad values
@pytest.mark.parametrize("call,word", [
    (lambda s: sca.estimate(s.rgb * (1 + 0j), depth=10, distance=5), "rgb"),
    (lambda s: sca.estimate(s.rgb, depth=10 + 1j, distance=5), "depth"),
    (lambda s: sca.estimate(s.rgb, depth=10, distance=5, sigma=s.rgb_sigma + 0j), "sigma"),
    (lambda s: sca.estimate_batch(s.rgb[None] * (1 + 1e-9j), depth=10, distance=5), "rgb_stack"),
    (lambda s: forward.simulate_chart(1 + 1j, 0.1, 10, 5), "chl"),
])
def test_complex_input_is_refused(sim, call, word):
    with pytest.raises(ValueError, match=f"^{word}: complex values are not accepted"):
        call(sim)


def test_scales_the_solver_cannot_represent_are_refused(sim):
    with pytest.raises(ValueError, match="^rgb: .*too small for the solver"):
        sca.estimate(sim.rgb * 1e-150, depth=10, distance=5, gain="free")
    with pytest.raises(ValueError, match="^sigma: .*too small for the solver"):
        sca.estimate(sim.rgb, depth=10, distance=5, sigma=sim.rgb_sigma * 1e-150)
    with pytest.raises(ValueError, match=r"^rgb_stack: .*too small for the solver in chart 1 "):
        sca.estimate_batch(np.stack([sim.rgb, sim.rgb * 1e-150]), depth=10, distance=5,
                           gain="free")


@pytest.mark.parametrize("kw,word", [
    (dict(depth=np.full(9, 10.0)), "depth: expected a scalar or 10 values"),
    (dict(distance=np.full(11, 5.0)), "distance: expected a scalar or 10 values"),
    (dict(saturation=np.ones(9)), "saturation: expected a scalar or 10 values"),
    (dict(sigma="stack9"), "sigma: expected a scalar"),
])
def test_mismatched_batch_lengths_name_the_argument(sim, kw, word):
    kw = {"depth": 10.0, "distance": 5.0, **kw}
    if kw.get("sigma") == "stack9":
        kw["sigma"] = np.stack([sim.rgb_sigma] * 9)
    with pytest.raises(ValueError, match=f"^{word}"):
        sca.estimate_batch(np.stack([sim.rgb] * 10), **kw)


def test_a_bad_chart_in_a_python_batch_is_named_by_its_index(sim):
    M = np.stack([sim.rgb] * 10)
    M[3, 1, 5] = np.nan
    with pytest.raises(ValueError, match=r"^rgb_stack: NaN or infinite values in chart 3 "):
        sca.estimate_batch(M, depth=10, distance=5)
    M[3, 1, 5] = -1
    with pytest.raises(ValueError, match=r"^rgb_stack: negative values in chart 3 "):
        sca.estimate_batch(M, depth=10, distance=5)
    with pytest.raises(ValueError, match=r"^depth: .*nan at charts 7, 8, 9 "):
        sca.estimate_batch(np.stack([sim.rgb] * 10), depth=[10] * 7 + [np.nan] * 3, distance=5)


# --------------------------------------------------------------------------- messages
def test_error_messages_name_the_real_cause(tmp_path):
    code, _, err = run(["estimate", tmp_path, "--depth", 1, "--distance", 1])
    assert code == 2 and "is a folder, not a CSV file" in err
    binary = tmp_path / "b.csv"
    binary.write_bytes(b"\x00\x01\x02binary")
    code, _, err = run(["estimate", binary, "--depth", 1, "--distance", 1])
    assert code == 2 and "binary" in err
    latin = tmp_path / "l.csv"
    latin.write_bytes("patch,red,green,blue\n1,0.1,0.1,0.1 # \xe9t\xe9\n".encode("latin-1"))
    code, _, err = run(["estimate", latin, "--depth", 1, "--distance", 1])
    assert code == 2 and "not UTF-8" in err
    code, _, err = run(["measure", tmp_path / "x.dng", "--profile", tmp_path / "nope.json",
                        "--depth", 1, "--distance", 1, "--corners", "1,1 9,1 9,9 1,9", "--out",
                        tmp_path / "o"])
    assert code == 2 and err.startswith("uw3p measure: error: --profile: file not found"), err
    code, _, err = run(["simulate", "--chl", 1, "--cdom", 0.1, "--depth", 1, "--distance", 1,
                        "--camera", tmp_path])
    assert code == 2 and "--camera:" in err and "is a folder" in err
    code, _, err = run(["design", "--depth", 5, "--distance", 1, "--chl", 1, "--cdom", 0.1,
                        "--lux", 0])
    assert code == 2 and err.startswith("uw3p design: error: --lux:"), err
    code, _, err = run(["design", "--depth", 5, "--distance", 1, "--chl", 0, "--cdom", 0.1])
    assert code == 2 and err.startswith("uw3p design: error: --chl: must be > 0"), err


def test_design_never_says_to_not_bounded_or_nan():
    # a chart at the surface with the camera on it crosses no water: refused up front, naming
    # the distance (issue 45: a distance <= 0 is bad input), never planned as "not bounded"
    code, out, err = run(["design", "--depth", 0, "--distance", 0, "--chl", 1, "--cdom", 0.1])
    assert code == 2 and err.startswith("uw3p design: error: --distance:"), err
    assert out == ""
    code, out, _ = run(["design", "--depth", 30, "--distance", 5, "--chl", 1, "--cdom", 0.1,
                        "--lux", 20])
    assert "more than ±1000 %" in out


@pytest.mark.parametrize("command", [None] + [c.NAME for c in COMMANDS])
def test_help_has_no_restructuredtext_markup(command, capsys):
    with pytest.raises(SystemExit):
        build_parser().parse_args(["--help"] if command is None else [command, "--help"])
    text = capsys.readouterr().out
    assert "``" not in text and "usage" in text


# --------------------------------------------------------------------------- default output
def test_default_estimate_output_is_the_result_and_its_budget(tmp_path, sim):
    f = _write(tmp_path / "m.csv", _rows(sim))
    code, out, err = run(["estimate", f, "--depth", TRUTH[2], "--distance", TRUTH[3]])
    assert code == 0, err
    from sca.derived import QUANTITIES  # a line per derived quantity, tau's included
    assert len(out.splitlines()) <= 15 + len(QUANTITIES) and "budget of C" in out
    assert "--spectrum" in out
    assert "what this chart measures" in out
    assert "wavelength_nm" not in out


# --------------------------------------------------------------------------- glints and snow
def _photo(values, white=1000.0, size=(240, 360), seed=0):
    """A demosaiced photo of a 6 x 4 chart filling (24, 336) x (24, 216): patch values (3, 24),
    Gaussian pixel noise of 1 % of each value, clipped at ``white``."""
    H, W = size
    rng = np.random.default_rng(seed)
    data = np.zeros((H, W, 3), np.float32)
    x0, y0, pitch = 24, 24, 52
    for j in range(24):
        r, c = divmod(j, 6)
        sl = (slice(y0 + r * pitch, y0 + (r + 1) * pitch), slice(x0 + c * pitch, x0 + (c + 1) * pitch))
        data[sl] = values[:, j]
    data *= (1 + 0.01 * rng.standard_normal(data.shape)).astype(np.float32)
    corners = np.array([[x0, y0], [x0 + 6 * pitch, y0], [x0 + 6 * pitch, y0 + 4 * pitch],
                        [x0, y0 + 4 * pitch]], float)
    return data, corners


def _as_photo(data, white):
    data = np.minimum(data, white)
    clipped = np.any(data >= white, axis=-1)
    return Photo("synthetic", "rgb", data, None, clipped, np.full(3, white), np.zeros(3))


def test_glints_are_left_out_pixel_by_pixel():
    values = np.tile(np.linspace(100, 800, 24), (3, 1))
    data, corners = _photo(values)
    clean = sample_patches(_as_photo(data, 1000.0), corners)
    rng = np.random.default_rng(2)
    glint = data.copy()
    glint[rng.random(data.shape[:2]) < 0.005] = 5000.0  # 0.5 % of the pixels: glints and snow
    s = sample_patches(_as_photo(glint, 1000.0), corners)
    assert np.all(s.clipped == 0) and s.excluded.max() > 0
    # the robust mean of the unclipped pixels: the clean value within its standard error
    assert np.all(np.abs(s.rgb - clean.rgb) < 4 * clean.sigma)
    assert np.all(np.abs(s.rgb / values - 1) < 0.002)


def test_a_patch_clipped_in_its_body_is_still_clipped():
    values = np.tile(np.linspace(100, 800, 24), (3, 1))
    values[1, 18] = 1000.0 * (1 - CLIP_SIGMA * 0.01 / 2)  # the white patch's green near the clip
    data, corners = _photo(values)
    s = sample_patches(_as_photo(data, 1000.0), corners)
    assert s.clipped[1, 18] > 0 and s.excluded[1, 18] == 0
    assert np.count_nonzero(s.clipped) == 1


@pytest.mark.slow
def test_a_photo_with_glints_is_measured_like_the_clean_one(tmp_path, chart_photos, uw_measured):
    """Glints (0.5 % of the pixels saturated) on tests/conftest.py's underwater photo: measured
    like the clean photo (``uw_measured``, measured once for the run, not here again)."""
    import rawpy

    from measure.synthetic_photo import write_dng

    with rawpy.imread(str(chart_photos["uw"])) as raw:
        glint = raw.raw_image_visible.copy()  # the clean photo's mosaic
    glint[np.random.default_rng(3).random(glint.shape) < 0.005] = 2 ** 14 - 1
    out = {"clean": uw_measured,
           "glint": measure.measure(write_dng(glint, tmp_path / "glint.dng"),
                                    corners=chart_photos["corners"], depth=5.0, distance=1.5,
                                    profile=chart_photos["profile"])}
    g, c = out["glint"], out["clean"]
    info = {"path-model-span"}  # information: the intervals span two path models
    assert set(g.flags) <= info and set(c.flags) <= info and g.reliable and g.estimate.converged
    assert "saturated" not in g.flags and "dark" not in g.flags
    assert g.estimate.chl_ci[0] <= 2.0 <= g.estimate.chl_ci[1]
    assert g.estimate.chl == pytest.approx(c.estimate.chl, rel=0.05)


@pytest.mark.slow
def test_the_short_camera_calibrates_and_measures_from_the_command_line(tmp_path):
    from measure.synthetic_photo import Scene, default_corners, render_mosaic, write_dng

    W, H = 360, 240
    corners = default_corners(W, H)
    text = " ".join(f"{x:.2f},{y:.2f}" for x, y in corners)
    setup = forward.chart_setup(SIGMA_CAMERA)
    air = write_dng(render_mosaic(Scene(chl=0, cdom=0, depth=0, distance=0, gain=9000, width=W,
                                        height=H, seed=1), corners, setup=setup),
                    tmp_path / "air.dng")
    uw = write_dng(render_mosaic(Scene(chl=2.0, cdom=0.1, depth=5.0, distance=1.5, gain=30000,
                                       width=W, height=H, seed=2), corners, setup=setup),
                   tmp_path / "uw.dng")
    prof = tmp_path / "profile.json"
    code, out, err = run(["calibrate", air, "--camera", SIGMA_CAMERA, "--corners", text,
                          "--out", prof])
    assert code in (0, 1) and prof.is_file(), err
    code, out, err = run(["measure", uw, "--camera", SIGMA_CAMERA, "--profile", prof,
                          "--depth", 5, "--distance", 1.5, "--corners", text,
                          "--out", str(tmp_path / "res") + "/"])
    assert code in (0, 1), err
    assert "//" not in out and f"{tmp_path / 'res' / 'measurement.json'}" in out
    assert "taken as 0 from 680 nm" in err


def test_input_errors_carry_the_arguments_name():
    """Bad input is a forward.InputError: a ValueError with the argument's name and the reason
    as attributes (the command line names its option from them, not from the message), and it
    survives a trip to another process."""
    import pickle

    import forward
    from uw3p.common import option_message

    with pytest.raises(forward.InputError) as info:
        forward.simulate_chart(1.0, 0.1, depth=-2, distance=1)
    exc = info.value
    assert isinstance(exc, ValueError) and exc.argument == "depth"
    assert str(exc) == f"depth: {exc.reason}" and "must be >= 0" in exc.reason
    back = pickle.loads(pickle.dumps(exc))
    assert (type(back), back.argument, back.reason) == (type(exc), exc.argument, exc.reason)
    assert option_message(exc, {"depth": "--depth"}) == f"--depth: {exc.reason}"
    # the name comes from the attribute even where the reason holds a colon
    odd = forward.InputError("max_iter", "expected a count: got 'x'")
    assert option_message(odd, {"max_iter": "--max-iter"}) == "--max-iter: expected a count: got 'x'"


def test_every_input_error_of_the_package_carries_its_argument():
    """No ``ValueError(...)`` is made in the package (raised or returned): bad input is a
    forward.InputError, so the command line never reads an argument out of a message (a plain
    ValueError's text is said as it is)."""
    import ast
    from pathlib import Path

    from uw3p.common import option_message

    root = Path(__file__).resolve().parent.parent
    left = []
    for pkg in ("forward", "sca", "measure", "uw3p"):
        for path in sorted((root / pkg).rglob("*.py")):
            for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
                if isinstance(node, ast.Call) and getattr(node.func, "id", None) == "ValueError":
                    left.append(f"{path.relative_to(root)}:{node.lineno}")
    assert not left, left
    assert option_message(ValueError("depth: odd"), {"depth": "--depth"}) == "depth: odd"
