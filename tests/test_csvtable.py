"""One CSV reader (issue 49 item 2, forward.csvtable): curves, a dive's metadata and patch files
under one set of dialect rules; what it cannot read is refused naming the file, line and column.
A semicolon-separated curve file with decimal commas was read as a (301, 6) camera."""

import numpy as np
import pytest

import forward
from forward.errors import InputError
from forward.spectra import read_spectral_csv


def _curves():
    wl = np.arange(400.0, 701.0)
    return wl, np.stack([np.exp(-((wl - c) / 40.0) ** 2) for c in (600, 540, 460)], axis=1)


def _write(path, sep, decimal, header=True):
    wl, v = _curves()
    lines = ["# a camera's curves", sep.join(["wavelength", "red", "green", "blue"])] if header else []
    lines += [sep.join([f"{w:g}"] + [f"{x:.6f}".replace(".", decimal) for x in row])
              for w, row in zip(wl, v)]
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return path


def test_a_semicolon_curve_file_with_decimal_commas_is_three_curves(tmp_path):
    plain = forward.camera_sensitivities(_write(tmp_path / "plain.csv", ",", "."))
    comma = forward.camera_sensitivities(_write(tmp_path / "semi.csv", ";", ","))
    assert comma.shape == plain.shape == (301, 3)
    np.testing.assert_array_equal(comma, plain)
    wl, v = read_spectral_csv(_write(tmp_path / "tab.txt", "\t", ",", header=False), name="camera")
    np.testing.assert_allclose(v, _curves()[1], atol=1e-6)


def test_a_curve_file_it_cannot_read_is_refused_naming_line_and_column(tmp_path):
    f = _write(tmp_path / "semi.csv", ";", ",")
    lines = f.read_text().splitlines()
    lines[4] = lines[4].replace(";", ";x", 1)  # line 5: a cell that is not a number
    f.write_text("\n".join(lines) + "\n")
    with pytest.raises(InputError, match=r"^camera: .*semi\.csv line 5 column 2: 'x"):
        forward.camera_sensitivities(f)
    lines[4] = "402;0,1;0,2"  # line 5: a field short
    f.write_text("\n".join(lines) + "\n")
    with pytest.raises(InputError, match=r"^camera: .*semi\.csv line 5: 3 fields"):
        forward.camera_sensitivities(f)
    # decimal commas in a comma-separated file: refused, not split into more curves
    f = _write(tmp_path / "mixed.csv", ",", ",")
    with pytest.raises(InputError, match=r"^camera: .*mixed\.csv line \d+"):
        forward.camera_sensitivities(f)


def test_the_three_readers_share_the_rules(tmp_path):
    """A `#` comment, a spreadsheet's sep= line and decimal commas read alike by the metadata
    and patch readers; a metadata file it cannot decode is refused naming it."""
    from measure.dive.metadata import read_metadata
    from uw3p.patchfile import read_patch_csv

    f = tmp_path / "dive.csv"
    f.write_text("sep=;\n# the dive\nimage;depth_m;distance_m\na.dng;5;1,5\n", encoding="utf-8")
    rows = read_metadata(f)
    assert rows["a.dng"]["distance_m"] == 1.5 and rows["a.dng"]["line"] == 4
    f.write_text("image,depth_m,distance_m\na.dng,5,1.5\n", encoding="utf-16")
    assert read_metadata(f)["a.dng"]["distance_m"] == 1.5
    f.write_bytes(b"image,depth_m\x00\x01\x02")
    with pytest.raises(InputError, match="^metadata: .*dive.csv is not a text CSV"):
        read_metadata(f)
    sim = forward.simulate_chart(1.0, 0.1, 5.0, 1.5, noise=False)
    p = tmp_path / "rgb.csv"
    p.write_text("sep=;\n# the chart\npatch;red;green;blue\n" + "".join(
        f"{i + 1};" + ";".join(f"{x:.9f}".replace(".", ",") for x in sim.rgb[:, i]) + "\n"
        for i in range(24)), encoding="utf-8")
    np.testing.assert_allclose(read_patch_csv(p)[0], sim.rgb, atol=1e-9)
