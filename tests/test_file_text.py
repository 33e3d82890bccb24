"""Strings from files reach the terminal escaped, as a device's strings do
(``tactile.output.text.printable``), and plot labels are drawn without matplotlib warnings:
patch ids, finger labels, a calibration file's serial, and any error quoting them."""

import math
import warnings

import pytest

from tactile.calib import ati

EVIL = "\x1b[31mred\u202e$x^{$\u4e00"  # ESC, a right-to-left override, mathtext, a CJK glyph
RAW = ("\x1b", "\u202e")


def contacts(tmp_path, patch=EVIL, finger=EVIL, n=30):
    rows = ["x,y,z,nx,ny,nz,finger,patch"]
    for i in range(n):
        a = 0.02 * i  # a 33 deg arc of a cylinder: one patch (a whole turn is not)
        c, s = math.cos(a), math.sin(a)
        rows.append(f"{6.6 * c!r},{i % 5},{6.6 * s!r},{c!r},0,{s!r},{finger},{patch}")
    path = tmp_path / "c.csv"
    path.write_text("\n".join(rows) + "\n")
    return path


def clean(text):
    assert not any(ch in text for ch in RAW), repr(text)


def test_ep2_analyze_escapes_a_patch_id(tmp_path, cli):
    code, out, err = cli("ep2", "analyze", contacts(tmp_path))
    assert code == 0, err
    clean(out + err)
    assert "\\x1b[31mred\\u202e" in out


def test_an_error_quoting_a_patch_id_is_escaped(tmp_path, cli):
    path = contacts(tmp_path, n=3)  # too few contacts: the error names the patch
    code, out, err = cli("ep2", "analyze", path)
    assert code in (2, 3) and err.count("\n") == 1
    clean(out + err)


def test_plot_draws_file_text_without_warnings(tmp_path, cli):
    pytest.importorskip("matplotlib")
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # a missing glyph or a mathtext error fails here
        code, out, err = cli("plot", contacts(tmp_path), "-o", tmp_path / "p")
    assert code == 0 and not err, err
    clean(out)
    assert len(out.split()) == 3


def test_plain_text_escapes_what_the_font_cannot_draw():
    pytest.importorskip("matplotlib")
    from tactile.output.plots import plain_text

    got = plain_text(EVIL)
    assert got.startswith("\\x1b[31mred\\u202e\\$x^{\\$") and "\u4e00" not in got
    assert plain_text("finger 2 é") == "finger 2 é"


def test_calibrate_escapes_the_files_serial(tmp_path, cli):
    eye = [[float(i == j) for j in range(6)] for i in range(6)]
    path = tmp_path / "m.cal"
    path.write_text(ati.format_cal(eye, "FT12\u202e\u2028\x85"))  # XML 1.0 has no ESC
    code, out, err = cli("calibrate", "--dry-run", path, "--volts-per-count", "3e-9")
    assert code == 0, err
    clean(out + err)
    assert "FT12\\u202e" in out
