"""Calibration files: ATI .cal XML, CSV and JSON into the board's convention (issue 14, part 4).

Units are checked against NIST SP 811's conversion table (appendix B.9, 7 digits), not
against the definitions the code multiplies out; the ATI sample is read a second time with
``xml.etree`` to check which numbers the parser took.
"""

import json
import pathlib
import re
import xml.etree.ElementTree as ET

import numpy as np
import pytest

from tactile.calib import (
    SI,
    Units,
    board_matrix,
    canonical_torque,
    files,
    force_factor,
    parse,
    torque_factor,
)
from tactile.errors import InputError

DATA = pathlib.Path(__file__).parent / "data"
SAMPLE = DATA / "FT9999.cal"
VPC = 3.3 / (128 * 2**23)  # 3.3 V excitation, PGA 128, 24-bit: volts per count

# NIST SP 811 (2008), B.9: factors to SI, as printed there (7 significant digits)
NIST_FORCE = {"lbf": 4.448222, "klbf": 4.448222e3, "ozf": 2.780139e-1, "kgf": 9.80665,
              "gf": 9.80665e-3, "N": 1.0, "kN": 1e3, "mN": 1e-3}  # fmt: skip
NIST_TORQUE = {"lbf-in": 1.129848e-1, "lbf-ft": 1.355818, "ozf-in": 7.061552e-3,
               "kgf-cm": 9.80665e-2, "kgf-m": 9.80665, "N-m": 1.0, "N-mm": 1e-3,
               "N-cm": 1e-2, "klbf-in": 1.129848e2}  # fmt: skip


def _etree_user_axes(path):
    """The UserAxis rows by a second route (ElementTree), in Fx..Tz order."""
    cal = ET.parse(path).getroot().find("Calibration")
    rows = {
        e.get("Name"): [float(v) for v in e.get("values").split()] for e in cal.iter("UserAxis")
    }
    return [rows[a] for a in ("Fx", "Fy", "Fz", "Tx", "Ty", "Tz")], cal


def _write(tmp_path, name, text):
    path = tmp_path / name
    path.write_text(text)
    return str(path)


def _csv_text(matrix, head=""):
    return head + "".join(",".join(repr(float(v)) for v in row) + "\n" for row in matrix)


def _refused(path, match, **kw):
    with pytest.raises(InputError, match=match) as info:
        board_matrix.to_board(files.read(path, kw.pop("index", None)), **kw)
    assert "\n" not in str(info.value)
    return str(info.value)


# --- units ---------------------------------------------------------------------------------


@pytest.mark.parametrize("name, si", NIST_FORCE.items())
def test_force_units_agree_with_nist(name, si):
    assert force_factor(name) == pytest.approx(si, rel=1e-6)


@pytest.mark.parametrize("name, si", NIST_TORQUE.items())
def test_torque_units_agree_with_nist(name, si):
    assert torque_factor(name) == pytest.approx(si, rel=1e-6)


@pytest.mark.parametrize(
    "text, canon",
    [
        ("lb-in", "lbf-in"),
        ("N*m", "N-m"),
        ("Nm", "N-m"),
        ("N m", "N-m"),
        ("N\u00b7mm", "N-mm"),
        ("kg-cm", "kgf-cm"),
        ("klb-in", "klbf-in"),
        ("N.m", "N-m"),
    ],
)
def test_torque_spellings_of_ati_and_others(text, canon):
    assert canonical_torque(text) == canon


def test_units_line_grammar():
    assert parse("lbf, lbf-in per V") == Units("lbf", "lbf-in", "V")
    assert parse(" N , N-mm ") == Units("N", "N-mm", "count")
    bad = [
        ("N", "FORCE, TORQUE"),
        ("stone, N-m", "unknown force unit 'stone'"),
        ("N, N-furlong", "unknown torque unit"),
        ("N, N-m per A", "gauge unit"),
    ]
    for spec, why in bad:
        with pytest.raises(ValueError, match=why):
            parse(spec)


# --- ATI .cal -------------------------------------------------------------------------------


def test_ati_sample_gives_the_user_axis_rows_and_units():
    mf = files.read(str(SAMPLE))
    rows, cal = _etree_user_axes(SAMPLE)
    assert mf.matrix == rows  # the UserAxis rows, not the Axis rows
    assert (
        cal.find("Axis").get("values").split()[0] != cal.find("UserAxis").get("values").split()[0]
    )
    assert mf.units == Units("lbf", "lbf-in", "V")
    assert (mf.cal_id, mf.id_from) == (9999, "Serial FT9999")
    assert "US-6-1" in mf.label and mf.kind == "ATI"


def test_ati_to_si_per_count_by_an_independent_route():
    """C[r][j] = UserAxis[r][j] x (NIST factor of the row's unit) x volts per count."""
    bm = board_matrix.to_board(files.read(str(SAMPLE)), volts_per_count=VPC)
    rows, _ = _etree_user_axes(SAMPLE)
    expect = np.array(rows) * np.array([4.448222] * 3 + [1.129848e-1] * 3)[:, None] * VPC
    got = np.array(bm.coeffs).reshape(6, 6)
    assert got == pytest.approx(expect, rel=2e-6)  # NIST's 7 digits; float32 adds 6e-8
    assert got.dtype == np.float64 and np.array_equal(np.float32(got), got)  # float32 values
    assert 1 < bm.condition < 10  # a real transducer's matrix: ATI's come out near 1-3


def test_the_same_matrix_as_cal_csv_and_json_is_the_same_on_the_board(tmp_path):
    rows, _ = _etree_user_axes(SAMPLE)
    csv_path = _write(tmp_path, "m.csv", _csv_text(rows, "# units: lbf, lbf-in per V\n"))
    doc = {"id": 9999, "matrix": rows, "units": "lbf, lbf-in per V"}
    json_path = _write(tmp_path, "m.json", json.dumps(doc))
    got = {
        p: board_matrix.to_board(files.read(p), volts_per_count=VPC, cal_id=9999)
        for p in (str(SAMPLE), csv_path, json_path)
    }
    assert len({bm.coeffs for bm in got.values()}) == 1
    assert len({bm.crc for bm in got.values()}) == 1
    # ... and the result written back in SI per count is the same matrix again (no factors)
    si = np.array(got[csv_path].coeffs).reshape(6, 6)
    back = _write(tmp_path, "si.csv", _csv_text(si, "# units: N, N-m per count\n# id: 9999\n"))
    again = board_matrix.to_board(files.read(back))
    assert again.coeffs == got[csv_path].coeffs and again.cal_id == 9999


def _sample_text():
    return SAMPLE.read_text()


@pytest.mark.parametrize(
    "edit, match",
    [
        (
            lambda s: s.replace(
                '<?xml version="1.0" encoding="utf-8"?>',
                '<?xml version="1.0"?><!DOCTYPE l [<!ENTITY a "aaaaaaaaaa">'
                '<!ENTITY b "&a;&a;&a;&a;&a;&a;&a;&a;&a;&a;">]>',
            ),
            r"FT\.cal:1: column \d+: a <!DOCTYPE> .* refused",
        ),
        (
            lambda s: s.replace("</Calibration>", "</Calibratio>"),
            r"FT\.cal:21: column 4: not well-formed XML: mismatched tag",
        ),
        (
            lambda s: s.replace('ForceUnits="lbf"', 'ForceUnits="stone"'),
            r"FT\.cal:7: column 2: <Calibration> attribute 'ForceUnits': unknown force unit"
            r" 'stone'",
        ),
        (
            lambda s: s.replace('TorqueUnits="lbf-in"', ""),
            r"<Calibration> attribute 'TorqueUnits': missing",
        ),
        (lambda s: s.replace('<UserAxis Name="Tz"', '<Other Name="Tz"'), r"no UserAxis row for Tz"),
        (
            lambda s: s.replace('<UserAxis Name="Ty"', '<UserAxis Name="Tx"'),
            r'FT\.cal:19: column 3: <UserAxis Name="Tx">: a second Tx row'
            r" \(the first is at line 18\)",
        ),
        (
            lambda s: s.replace('<UserAxis Name="Fz"', '<UserAxis Name="Mz"'),
            r"'Mz' is not one of Fx",
        ),
        (
            lambda s: s.replace("   0.82216 ", " "),
            r'FT\.cal:17: column 3: <UserAxis Name="Fz"> attribute \'values\': 5 numbers, need 6',
        ),
        (
            lambda s: s.replace("   0.82216 ", " 0.8x216 "),
            r"attribute 'values': number 1 \(gauge 0\): '0.8x216' is not a finite number",
        ),
        (lambda s: s.replace("   0.82216 ", " nan "), r"'nan' is not a finite number"),
        (
            lambda s: s.replace("<UserAxis", "<!-- x --><Ignored"),
            r"only <Axis> rows, .*CalFileVersion 1.0",
        ),
        (lambda s: s.replace('NumGages="6"', 'NumGages="8"'), r"NumGages': '8'; the board reads 6"),
        (lambda s: s.replace("FTSensor", "Sensor"), r"not an ATI calibration file"),
    ],
)
def test_ati_refusals_name_line_column_and_field(tmp_path, edit, match):
    path = _write(tmp_path, "FT.cal", edit(_sample_text()))
    _refused(path, match, volts_per_count=VPC)


def test_ati_with_two_calibrations_needs_index(tmp_path):
    text = _sample_text()
    start, end = text.index("\t<Calibration"), text.index("</FTSensor>")
    second = text[start:end].replace("US-6-1", "SI-25-0.25").replace('"lbf"', '"N"')
    path = _write(tmp_path, "FT.cal", text[:end] + second + text[end:])
    _refused(path, r"2 calibrations \(US-6-1, SI-25-0.25\): choose one with --index 1..2")
    _refused(path, r"--index: 3, but .* holds 2", index=3)
    one, two = files.read(path, 1), files.read(path, 2)
    assert (one.units.force, two.units.force) == ("lbf", "N") and one.matrix == two.matrix


def test_ati_serial_without_digits_needs_an_id(tmp_path):
    path = _write(tmp_path, "FT.cal", _sample_text().replace('Serial="FT9999"', 'Serial="FT"'))
    _refused(path, r"--id: needed: .* carries no calibration id", volts_per_count=VPC)
    assert board_matrix.to_board(files.read(path), VPC, cal_id=5).cal_id == 5


def test_gain_multiplier_is_told(tmp_path):
    path = _write(
        tmp_path, "FT.cal", _sample_text().replace('GainMultiplier="1"', 'GainMultiplier="2"')
    )
    assert any("GainMultiplier=2" in n for n in files.read(path).notes)


# --- CSV and JSON ----------------------------------------------------------------------------

GOOD = [[1e-6 * (1 + (r == c)) + 1e-8 * r * c for c in range(6)] for r in range(6)]


def test_csv_variants_read_the_same(tmp_path):
    plain = _csv_text(GOOD, "# id: 7\n")
    variants = [
        plain,
        "\ufeff" + plain.replace("\n", "\r\n"),  # Excel's BOM and CR LF
        "# a comment: with a colon\n" + plain.replace(",", " "),  # numpy.savetxt's spaces
        "# id: 7\n" + _csv_text(GOOD).replace("\n", ",\n"),  # a trailing comma
        "\n# units: N, N-m per count\n\n" + plain,
    ]
    got = [files.read(_write(tmp_path, f"v{i}.csv", t)) for i, t in enumerate(variants)]
    assert all(mf.matrix == GOOD and mf.cal_id == 7 for mf in got)
    assert all(mf.units == SI for mf in got)


@pytest.mark.parametrize(
    "text, match",
    [
        (
            _csv_text(GOOD).replace(repr(GOOD[2][3]), "abc", 1),
            r"m\.csv:3: row 3 \(fz\), column 4 \(g3\): not a number: 'abc'",
        ),
        (
            _csv_text(GOOD).replace(repr(GOOD[4][4]), "inf", 1),
            r"m\.csv:5: row 5 \(ty\), column 5 .*finite",
        ),
        ("g0,g1,g2,g3,g4,g5\n" + _csv_text(GOOD), r"m\.csv:1: row 1 .*no header row"),
        (
            _csv_text(GOOD).replace("," + repr(GOOD[1][5]), "", 1),
            r"m\.csv:2: row 2 \(fy\) has 5 values, need 6",
        ),
        (_csv_text(GOOD + [GOOD[0]]), r"m\.csv:7: a 7th row"),
        (_csv_text(GOOD[:5]), r"m\.csv: 5 rows of numbers, need 6"),
        ("# units: N, lbf\n" + _csv_text(GOOD), r"m\.csv:1: units: unknown torque unit 'lbf'"),
        ("# id: 0\n" + _csv_text(GOOD), r"m\.csv:1: id: 0 is not a calibration id"),
        ("# id: 12a\n" + _csv_text(GOOD), r"m\.csv:1: id: not a whole number: '12a'"),
        ("# id: 4294967296\n" + _csv_text(GOOD), r"id: 4294967296 is not a calibration id"),
    ],
)
def test_csv_refusals(tmp_path, text, match):
    _refused(_write(tmp_path, "m.csv", text), match, cal_id=1 if "# id" not in text else None)


def _doc(**over):
    doc = {"id": 3, "matrix": GOOD, "units": "N, N-m per count"}
    doc.update(over)
    return json.dumps(doc)


@pytest.mark.parametrize(
    "text, match",
    [
        (
            '{"id": 3,\n "matrix": [1, 2,]}',
            r"m\.json:2: column 18: not valid JSON: Expecting value",
        ),
        (_doc(matrix=[[float("nan")] * 6] * 6), r"NaN is not a finite number"),
        (_doc(matrix=GOOD[:5]), r"field 'matrix': 5 rows, need a list of 6"),
        (_doc(matrix=GOOD[:2] + [GOOD[2][:5]] + GOOD[3:]), r"field matrix\[2\] \(fz\): 5 values"),
        (
            _doc(matrix=[[True] * 6] + GOOD[1:]),
            r"field matrix\[0\]\[0\] \(fx, g0\): not a number: 'true'",
        ),
        (_doc(matrix=[["1"] * 6] + GOOD[1:]), r"matrix\[0\]\[0\] \(fx, g0\): not a number"),
        (
            _doc(matrix=[[10**400] * 6] + GOOD[1:]),
            r"matrix\[0\]\[0\] \(fx, g0\): not a finite number",
        ),
        (_doc(matix=GOOD), r"field 'matix': unknown \(a calibration JSON has id, matrix, units\)"),
        ('{"matrix": [], "matrix": []}', r"field 'matrix': given twice"),
        (_doc(units="N, N-m per Pa"), r"field 'units': unknown gauge unit 'Pa'"),
        (_doc(id=3.0), r"field 'id': 3.0 is not a calibration id"),
        (_doc(id=True), r"field 'id': True is not a calibration id"),
        ("[1, 2]", r"must be an object"),
        ("{" * 100000, r"nested more than 64 deep|not valid JSON"),
    ],
)
def test_json_refusals(tmp_path, text, match):
    _refused(_write(tmp_path, "m.json", text), match)


def test_json_reads_like_csv(tmp_path):
    mf = files.read(_write(tmp_path, "m.json", _doc(units="kN, kN-m per mV")))
    assert mf.matrix == GOOD and mf.cal_id == 3 and mf.units == Units("kN", "kN-m", "mV")
    bm = board_matrix.to_board(mf, volts_per_count=1e-9)
    expect = np.array(GOOD) * 1e3 * 1e-3 * 1e-9  # kN -> N, per mV -> per V, x V per count
    assert np.array(bm.coeffs).reshape(6, 6) == pytest.approx(expect, rel=1e-7)


# --- the matrix itself ---------------------------------------------------------------------


def test_condition_number_is_svd_of_the_row_scaled_matrix():
    rng = np.random.default_rng(3)
    for _ in range(20):
        a = rng.normal(size=(6, 6)) * rng.uniform(1e-9, 1e3, (6, 1))
        kappa, rank = board_matrix.condition(a)
        scaled = a / np.linalg.norm(a, axis=1, keepdims=True)
        assert kappa == pytest.approx(np.linalg.cond(scaled), rel=1e-9) and rank == 6
    # independent of the rows' units: N vs lbf, N*m vs N*mm
    units = np.array([4.45] * 3 + [1e-3] * 3)[:, None]
    assert board_matrix.condition(a * units)[0] == pytest.approx(kappa, rel=1e-9)


def _matrix_with_condition(kappa):
    q1, _ = np.linalg.qr(np.random.default_rng(5).normal(size=(6, 6)))
    return (q1 @ np.diag(np.geomspace(1, 1 / kappa, 6))).tolist()


def test_singular_and_ill_conditioned_matrices_are_refused(tmp_path):
    dup = [list(r) for r in GOOD]
    dup[4] = list(dup[1])
    msg = _refused(
        _write(tmp_path, "dup.csv", _csv_text(dup)), r"singular \(rank 5 of 6\)", cal_id=1
    )
    assert "inf" not in msg and "nan" not in msg
    zero = [list(r) for r in GOOD]
    zero[3] = [0.0] * 6
    _refused(_write(tmp_path, "zero.csv", _csv_text(zero)), r"singular \(rank 5 of 6\)", cal_id=1)
    bad = _matrix_with_condition(1e6)
    kappa = board_matrix.condition(bad)[0]
    _refused(
        _write(tmp_path, "ill.csv", _csv_text(bad)),
        re.escape(f"ill-conditioned: condition number {kappa:.3g} (rows scaled to unit length)")
        + " is above 10000: refused",
        cal_id=1,
    )
    ok = _matrix_with_condition(5e3)  # under the bound: accepted
    assert board_matrix.to_board(files.read(_write(tmp_path, "ok.csv", _csv_text(ok))), cal_id=1)


def test_a_coefficient_float32_cannot_hold_is_refused(tmp_path):
    tiny = [list(r) for r in GOOD]
    tiny[3][2] = 1e-50
    _refused(
        _write(tmp_path, "t.csv", _csv_text(tiny)),
        r"t\.csv:4: row 4 \(tx\), column 3 \(g2\): 1e-50 N\*m per count underflows float32",
        cal_id=1,
    )
    huge = [[v * 1e45 for v in r] for r in GOOD]
    _refused(
        _write(tmp_path, "h.csv", _csv_text(huge)), r"row 1 \(fx\), column 1 .*float32", cal_id=1
    )


def test_volts_per_count_is_needed_exactly_for_a_matrix_per_volt(tmp_path):
    per_count = _write(tmp_path, "c.csv", _csv_text(GOOD, "# id: 1\n"))
    _refused(per_count, r"--volts-per-count: .* per ADC count already", volts_per_count=1e-9)
    _refused(str(SAMPLE), r"--volts-per-count: needed")
    for bad in (-1.0, 0.0, float("nan"), float("inf")):
        msg = _refused(str(SAMPLE), r"--volts-per-count: must be a positive", volts_per_count=bad)
        assert "nan" not in msg and "inf" not in msg


def test_files_that_are_not_files(tmp_path):
    _refused(str(tmp_path), r"a directory")
    _refused(str(tmp_path / "none.cal"), r"none\.cal: cannot read: No such file")
    big = tmp_path / "big.cal"
    big.write_bytes(b"<FTSensor>" + b" " * (files.MAX_BYTES + 1))
    _refused(str(big), r"larger than 1 MiB")
    _refused(_write(tmp_path, "empty.csv", "\n\n"), r"empty file")


def test_format_cal_reads_back_to_the_same_floats_and_agrees_with_etree(tmp_path):
    from tactile.calib.ati import format_cal

    rng = np.random.default_rng(7)
    per_volt = rng.normal(size=(6, 6)) * 10.0 ** rng.integers(-3, 6, size=(6, 1))
    path = _write(tmp_path, "FT4242.cal", format_cal(per_volt, "FT4242"))
    mf = files.read(path)
    assert mf.cal_id == 4242 and np.array_equal(np.array(mf.matrix), per_volt)
    assert np.array_equal(np.array(_etree_user_axes(path)[0]), per_volt)  # a second reader


def test_the_emulators_cal_file_holds_the_calibration_its_board_holds(tmp_path):
    """``emulate --cal-file``'s matrix, read through the README's --volts-per-count, is the
    emulated board's own calibration (counts -> N), as the right file is on a real sensor."""
    from tactile.calib.ati import format_cal
    from tactile_sim.emulator import load_scene
    from tactile_sim.emulator.ft_model import VOLTS_PER_COUNT, per_volt_matrix, sensitivity_matrix

    sensor = load_scene("ch5_convex").sensor
    path = _write(tmp_path, "FT9999.cal", format_cal(per_volt_matrix(sensor), "FT9999"))
    si = board_matrix.si_per_count(files.read(path), VOLTS_PER_COUNT)
    board = np.linalg.inv(sensitivity_matrix(sensor["force_range_N"], sensor["torque_range_Nm"]))
    assert np.allclose(si, board, rtol=1e-12, atol=0)


def test_emulate_cal_file_that_cannot_be_written_is_one_line_exit_2(tmp_path, cli):
    code, out, err = cli("emulate", "press", "--cal-file", tmp_path / "no" / "FT1.cal")
    assert code == 2 and out == "" and err.count("\n") == 1 and "Traceback" not in err
    assert f"{tmp_path / 'no' / 'FT1.cal'}: cannot write: no directory" in err
