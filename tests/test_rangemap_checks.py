"""Issue 45 items 4 and 7: a range map is read right or refused naming ``range`` (its units
checked for plausibility, its aspect against the photo's, a file that is no map of its kind),
and every value that is no plain range (NaN, +inf, -inf, 0, negative) is counted and reported
as what was done to its pixels."""

import json

import numpy as np
import pytest

import measure
from forward.errors import InputError
from measure.correct import correct_image
from measure.rangemap import (ASPECT_TOLERANCE, FLOAT_MM_MEDIAN_M, PNG_METRES_BELOW_MM,
                              read_range)
from uw3p.cli import main

W, H = 360, 240
SIZE = (40, 30)  # a small photo's (width, height) for the reader's own checks


@pytest.fixture(scope="module")
def shot(tmp_path_factory, fast_shot):
    """The measured photo (tests/conftest.py's fast_shot) and its measurement.json."""
    tmp = tmp_path_factory.mktemp("rangemap")
    measure.write_outputs(fast_shot["meas"], tmp / "m", report=False)
    return {"dng": fast_shot["dng"], "meas": fast_shot["meas"],
            "json": tmp / "m" / "measurement.json"}


def refusal(value, size=SIZE) -> InputError:
    """The one-line InputError naming ``range`` that reading ``value`` raises."""
    with pytest.raises(InputError) as info:
        read_range(value, size)
    assert info.value.argument == "range" and "\n" not in str(info.value)
    return info.value


def png(path, values):
    from PIL import Image

    Image.fromarray(np.asarray(values, np.uint16)).save(path)
    return path


def test_a_16_bit_png_written_in_metres_is_refused(tmp_path):
    """Values 1-9 in a 16-bit PNG (documented as mm) are metres: refused, saying so; the same
    map in millimetres is read."""
    metres = np.tile(np.arange(1, 10, dtype=np.uint16), (30, 5))[:, :40]
    err = refusal(png(tmp_path / "m.png", metres))
    assert "metres" in err.reason and f"{PNG_METRES_BELOW_MM}" in err.reason
    got = read_range(png(tmp_path / "mm.png", metres * 1000), SIZE)
    assert np.nanmin(got) == pytest.approx(1.0) and np.nanmax(got) == pytest.approx(9.0)


def test_a_float_map_written_in_millimetres_is_refused(tmp_path):
    """A float TIFF, a .npy or an array (documented as m) whose median is beyond
    FLOAT_MM_MEDIAN_M are millimetres: refused; a far but plausible map is read."""
    import tifffile

    mm = np.full((30, 40), 2500.0, np.float32)
    mm[:5] = np.nan
    tifffile.imwrite(tmp_path / "mm.tif", mm)
    np.save(tmp_path / "mm.npy", mm)
    for value in (tmp_path / "mm.tif", tmp_path / "mm.npy", mm):
        assert "millimetres" in refusal(value).reason
    far = np.full((30, 40), FLOAT_MM_MEDIAN_M * 0.9, np.float32)
    assert read_range(far, SIZE)[0, 0] == pytest.approx(FLOAT_MM_MEDIAN_M * 0.9)


def test_a_map_of_another_aspect_is_refused_one_of_the_same_is_resampled(tmp_path):
    """A portrait map for a landscape photo is refused naming the aspects; a smaller map of the
    same aspect, or one within ASPECT_TOLERANCE of it, is resampled to the photo."""
    np.save(tmp_path / "portrait.npy", np.full((40, 30), 2.0, np.float32))
    assert "aspect" in refusal(tmp_path / "portrait.npy").reason
    assert "aspect" in refusal(np.full((30, 60), 2.0, np.float32)).reason
    assert read_range(np.full((15, 20), 2.0, np.float32), SIZE).shape == (30, 40)
    near = (300, round(400 * (1 + ASPECT_TOLERANCE / 2)))  # within the tolerance
    assert read_range(np.full(near, 2.0, np.float32), (400, 300)).shape == (300, 400)


def test_a_file_that_is_no_map_of_its_kind_is_refused_naming_range(tmp_path):
    """A text file named .tif, a truncated .npy, empty files, a 3-channel image and a .npy of
    records: each an InputError naming ``range`` (not a bare ValueError of the reader)."""
    import tifffile
    from PIL import Image

    (tmp_path / "text.tif").write_text("not a TIFF\n")
    np.save(tmp_path / "whole.npy", np.full((30, 40), 2.0, np.float32))
    data = (tmp_path / "whole.npy").read_bytes()
    (tmp_path / "cut.npy").write_bytes(data[: len(data) // 2])
    for name in ("empty.npy", "empty.tif", "empty.png"):
        (tmp_path / name).write_bytes(b"")
    Image.fromarray(np.full((30, 40, 3), 200, np.uint8)).save(tmp_path / "rgb.png")
    tifffile.imwrite(tmp_path / "rgb.tif", np.full((30, 40, 3), 2.0, np.float32),
                    photometric="rgb")
    np.save(tmp_path / "records.npy", np.zeros((30, 40), [("a", "f4"), ("b", "f4")]))
    for name in ("text.tif", "cut.npy", "empty.npy", "empty.tif", "empty.png", "rgb.png",
                 "rgb.tif", "records.npy"):
        assert name in str(refusal(tmp_path / name)), name


def test_cli_an_unreadable_range_map_exits_2_naming_the_option(shot, tmp_path, capsys):
    """uw3p correct with a text file named .tif as --range: exit 2, one error line naming
    --range, nothing written."""
    (tmp_path / "text.tif").write_text("not a TIFF\n")
    code = main(["correct", str(shot["dng"]), "--water", str(shot["json"]), "--range",
                 str(tmp_path / "text.tif"), "--out", str(tmp_path / "c")])
    lines = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(lines) == 1
    assert lines[0].startswith("uw3p correct: error: --range:") and "text.tif" in lines[0]
    assert not (tmp_path / "c").exists()


def odd_map():
    """A photo-sized map with bands of NaN, +inf, -inf, 0, negative and far values."""
    rmap = np.tile(np.linspace(1.0, 4.0, W, dtype=np.float32), (H, 1))
    bands = {"nan": np.nan, "+inf": np.inf, "-inf": -np.inf, "zero": 0.0, "negative": -2.0,
             "far": 1e4}
    for i, value in enumerate(bands.values()):
        rmap[10 + 20 * i: 10 + 20 * i + 5 + i] = value  # 5 + i rows: every count differs
    return rmap


def test_the_reported_fractions_are_what_was_done_to_the_pixels(shot, tmp_path, capsys):
    """Every odd value is counted on its own in correction.json; the unknown fraction is the
    NaN, -inf, 0 and negative pixels, corrected as at --unknown; the capped fraction is the
    +inf and far pixels, corrected as at the cap; the CLI prints both."""
    m = shot["meas"]
    rmap = odd_map()
    out = correct_image(m.photo, m, rmap, float_output=True)
    counts = {"nan": np.isnan(rmap), "+inf": np.isposinf(rmap), "-inf": np.isneginf(rmap),
              "zero": rmap == 0, "negative": np.isfinite(rmap) & (rmap < 0)}
    assert {k: out.ranges["map_values"][k] for k in counts} == \
        {k: int(v.sum()) for k, v in counts.items()}
    unknown = counts["nan"] | counts["-inf"] | counts["zero"] | counts["negative"]
    capped = rmap > out.table.cap
    assert out.ranges["unknown_fraction"] == pytest.approx(unknown.mean())
    assert out.ranges["capped_fraction"] == pytest.approx(capped.mean())
    rgb = measure.demosaic(m.photo)
    for mask, at in ((unknown, out.table.unknown), (capped, out.table.cap)):
        assert out.values[mask] == pytest.approx(out.table.apply(rgb[mask], at), rel=1e-4,
                                                  abs=1e-6)
    np.save(tmp_path / "odd.npy", rmap)
    main(["correct", str(shot["dng"]), "--water", str(shot["json"]), "--range",
          str(tmp_path / "odd.npy"), "--out", str(tmp_path / "c"), "--tiff", "none"])
    rec = json.loads((tmp_path / "c" / "correction.json").read_text())["range"]
    assert rec["unknown_fraction"] == pytest.approx(unknown.mean())
    assert rec["capped_fraction"] == pytest.approx(capped.mean())
    assert np.isfinite(rec["max_m"]) and rec["map_values"]["+inf"] == int(counts["+inf"].sum())
    printed = capsys.readouterr().out
    for frac in (unknown.mean(), capped.mean()):
        assert f"{100 * frac:.1f} %" in printed


def test_a_resampled_infinite_range_stays_beyond_the_cap(shot):
    """+inf in a map smaller than the photo: the photo's pixels it touches are corrected as at
    the cap and counted as capped (resampling made them unknown before)."""
    m = shot["meas"]
    small = np.full((H // 4, W // 4), 2.0, np.float32)
    small[:, : W // 8] = np.inf
    out = correct_image(m.photo, m, small, float_output=True)
    rng = read_range(small, m.photo.size)
    far = np.isposinf(rng)
    assert far[:, : W // 2 - 4].all() and not far[:, W // 2 + 4:].any()
    assert out.ranges["capped_fraction"] == pytest.approx(far.mean())
    assert out.ranges["unknown_fraction"] == 0
    rgb = measure.demosaic(m.photo)
    assert out.values[far] == pytest.approx(out.table.apply(rgb[far], out.table.cap), rel=1e-4,
                                            abs=1e-6)
