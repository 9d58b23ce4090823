"""CSV cells a spreadsheet cannot run (issue 35): the one rule (measure.csvsafe) and every
writer of the package that applies it; the dive's summary.csv is tested in test_dive.py."""

import csv

import numpy as np

import forward
from uw3p.cli import main


def test_csv_cells_cannot_run_in_a_spreadsheet():
    from measure.csvsafe import neutralise, safe_row

    for text in ("=1+2", "+1+2x", "-2+3x", "@SUM(A1)", "\tx", "\rx", "=HYPERLINK(\"x\")",
                 "-inf", "-"):
        assert neutralise(text) == "'" + text
    for keep in ("-1.5", "+2", "-1e-3", "3", "a=b", "", "IMG_1.dng", "'=x"):
        assert neutralise(keep) == keep
    for number in (-1.5, float("-inf"), -3, np.float64(-2.0), True, None):
        assert neutralise(number) is number
    assert safe_row({"a": "=x", "b": -1}) == {"a": "'=x", "b": -1}
    assert safe_row(["@x", 2]) == ["'@x", 2]


def test_patch_and_batch_csvs_cells_cannot_run(tmp_path):
    import io

    from experiments.common import write_csv
    from uw3p.patchfile import patch_csv

    text = patch_csv(-np.ones((3, 24)))
    assert "'" not in text and "-1.0" in text  # numbers stay numbers
    path = write_csv(tmp_path / "t.csv", ["name", "=x"], [["@a", -2.5, "-b"]])
    rows = list(csv.reader(open(path, encoding="utf-8")))
    assert rows == [["name", "'=x"], ["'@a", "-2.5", "'-b"]]
    # uw3p estimate --batch: the chart names come from the user's file
    sim = forward.simulate_chart(1.0, 0.1, 5.0, 1.5, seed=0)
    batch = tmp_path / "charts.csv"
    batch.write_text("chart,patch,red,green,blue\n" + "".join(
        f"=cmd|x,{p + 1}," + ",".join(repr(float(v)) for v in sim.rgb[:, p]) + "\n"
        for p in range(24)))
    out, err = io.StringIO(), io.StringIO()
    kfile = tmp_path / "k.csv"
    code = main(["estimate", "--batch", str(batch), "--depth", "5", "--distance", "1.5",
                 "--attenuation", str(kfile)], out=out, err=err)
    assert code in (0, 1), err.getvalue()
    got = list(csv.reader(io.StringIO(out.getvalue())))
    assert got[1][0] == "'=cmd|x", got[:2]
    assert list(csv.reader(open(kfile, encoding="utf-8")))[1][0] == "'=cmd|x"
