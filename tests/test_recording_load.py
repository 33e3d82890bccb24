"""``tactile.load_recording`` (issue 14, part 5): a recording as NumPy arrays in SI units,
with board time and, when the recording has it, host time."""

import json
import subprocess
import sys

import numpy as np
import pytest
from recorded import HOST_HEADER, LEGACY_HEADER, frame_line, variant

import tactile
from tactile.errors import InputError
from tactile_protocol import constants as C

WRAP = 2**32


def test_arrays_equal_the_capture_decoded_independently(recorded_run, recorded_msgs):
    rec = tactile.load_recording(recorded_run)
    assert len(rec) == len(recorded_msgs) > 1000 and rec.sensors == [0, 1, 2]
    np.testing.assert_array_equal(rec.seq, [m.seq for m in recorded_msgs])
    np.testing.assert_array_equal(rec.board_us, [m.timestamp_us for m in recorded_msgs])
    np.testing.assert_array_equal(rec.sensor, [m.sensor for m in recorded_msgs])
    counts = np.array([[m.fx, m.fy, m.fz, m.tx, m.ty, m.tz] for m in recorded_msgs])
    np.testing.assert_array_equal(rec.force_N, counts[:, :3] / 1e6)  # uN -> N, exactly
    np.testing.assert_array_equal(rec.torque_Nm, counts[:, 3:] / 1e6)
    np.testing.assert_array_equal(rec.wrench, counts / 1e6)
    contact = np.array([m.type_name == "CONTACT" for m in recorded_msgs])
    np.testing.assert_array_equal(rec.is_contact, contact)
    phase = [m.phase if m.type_name == "CONTACT" else -1 for m in recorded_msgs]
    np.testing.assert_array_equal(rec.phase, phase)
    np.testing.assert_array_equal(
        rec.contact_id, [getattr(m, "contact_id", -1) for m in recorded_msgs]
    )
    # one boot, no wrap: the board time is the stamp in seconds
    assert set(rec.segment) == {0}
    np.testing.assert_array_equal(rec.board_time_s, rec.board_us * 1e-6)
    assert rec.meta == json.loads((recorded_run / "meta.json").read_text())
    assert rec.lines[0] >= 2 and np.all(np.diff(rec.lines) == 1)


def test_contacts_are_the_csv_in_metres_with_unit_normals(recorded_run):
    rec = tactile.load_recording(recorded_run)
    # skip_header: with names=True, genfromtxt takes names from a leading comment line
    written = np.genfromtxt(recorded_run / "contacts.csv", delimiter=",", names=True, dtype=None,
                            skip_header=1, encoding="utf-8", comments="#")  # fmt: skip
    c = rec.contacts
    assert rec.contacts_why is None and c.file_unit == "m" and len(c.points_m) == len(written)
    np.testing.assert_array_equal(c.points_m, np.column_stack([written[k] for k in "xyz"]))
    raw = np.column_stack([written[k] for k in ("nx", "ny", "nz")])
    np.testing.assert_allclose(c.normals, raw / np.linalg.norm(raw, axis=1)[:, None], rtol=1e-15)
    np.testing.assert_allclose(np.linalg.norm(c.normals, axis=1), 1.0, rtol=1e-15)
    assert c.finger == [str(f) for f in written["finger"]]
    assert np.all(np.abs(c.points_m) < 0.1)  # the sphere is 5 cm: metres, not cm


def _text(recorded_msgs, host=None, header=None):
    head = header or (LEGACY_HEADER if host is None else HOST_HEADER)
    rows = [frame_line(m, None if host is None else host(i)) for i, m in enumerate(recorded_msgs)]
    return "\n".join([head, *rows]) + "\n"


def test_a_recording_without_host_time_says_so(recorded_run, recorded_msgs, tmp_path):
    legacy = variant(
        recorded_run, tmp_path / "legacy", _text(recorded_msgs), meta_change=lambda d: None
    )
    rec = tactile.load_recording(legacy)
    assert rec.host_utc_s is None and rec.host_monotonic_s is None
    assert rec.host_time_source is None and "did not map the board's clock" in rec.host_time_why


def test_host_time_columns_are_used_as_written_and_empty_cells_are_nan(
    recorded_run, recorded_msgs, tmp_path
):
    t = np.array([m.timestamp_us for m in recorded_msgs]) * 1e-6

    def host(i):  # 50 ppm fast, 1.7e9 s Unix time; row 7 unknown
        mono = 1000.0 + t[i] * (1 + 50e-6)
        return (None, None) if i == 7 else (mono, mono + 1.7e9)

    cols = variant(
        recorded_run, tmp_path / "cols", _text(recorded_msgs, host), meta_change=lambda d: None
    )
    rec = tactile.load_recording(cols)
    assert rec.host_time_source == "frames.csv"
    mono = 1000.0 + t * (1 + 50e-6)
    expect = np.array([float(f"{v:.6f}") for v in mono])  # as written, to the microsecond
    expect_utc = np.array([float(f"{v:.6f}") for v in mono + 1.7e9])
    expect[7] = expect_utc[7] = np.nan
    np.testing.assert_array_equal(rec.host_monotonic_s, expect)
    np.testing.assert_array_equal(rec.host_utc_s, expect_utc)
    assert rec.host_time_why.startswith(f"1 of {len(recorded_msgs)} rows have no host time")
    assert "row 7: frames.csv has no host time (meta.json has no time_base)" in rec.host_time_why
    # the board's own columns are unchanged by the extra ones
    np.testing.assert_array_equal(rec.board_us, [m.timestamp_us for m in recorded_msgs])
    np.testing.assert_array_equal(rec.force_N[:, 0], [m.fx / 1e6 for m in recorded_msgs])


def _time_base(usable=True, first_row=0, rows=None, ref_us=500_000, drift=50.0):
    seg = {"boot_id": 1, "first_row": first_row, "rows": rows, "usable": usable}
    if usable:
        seg |= {
            "board_ref_us": ref_us,
            "host_monotonic_ref_s": 2000.0,
            "host_utc_ref_s": 1.7e9 + 0.25,
            "drift_ppm": drift,
        }
    else:
        seg["why"] = "the board clock ran 40 x as fast as the host's (an emulator in fast mode?)"
    return seg


def _with_segments(*segments):
    def change(doc):
        doc["sessions"][0]["time_base"] = {"segments": list(segments)}

    return change


def test_without_columns_the_mapping_in_meta_json_gives_host_time(
    recorded_run, recorded_msgs, tmp_path
):
    n = len(recorded_msgs)
    mapped = variant(
        recorded_run, tmp_path / "mapped", _text(recorded_msgs), _with_segments(_time_base(rows=n))
    )
    rec = tactile.load_recording(mapped)
    us = np.array([m.timestamp_us for m in recorded_msgs], dtype=float)
    d = (us - 500_000) * 1e-6 * (1 + 50e-6)
    assert rec.host_time_source == "meta.json" and rec.host_time_why is None
    np.testing.assert_allclose(rec.host_monotonic_s, 2000.0 + d, rtol=0, atol=1e-9)
    np.testing.assert_allclose(rec.host_utc_s, 1.7e9 + 0.25 + d, rtol=0, atol=1e-6)


def test_empty_host_columns_fall_back_to_meta_json_and_its_reason(
    recorded_run, recorded_msgs, tmp_path
):
    empty = _text(recorded_msgs, lambda i: (None, None))
    unusable = _with_segments(_time_base(usable=False, rows=len(recorded_msgs)))
    rec = tactile.load_recording(variant(recorded_run, tmp_path / "fast", empty, unusable))
    assert rec.host_utc_s is None and rec.host_time_source is None
    assert "emulator in fast mode" in rec.host_time_why


def _synthetic(tmp_path, stamps, sessions=None, segments=None):
    """A recording of one sensor whose board stamps are ``stamps``."""
    tmp_path.mkdir()
    rows = [f"{i},{us},SAMPLE,0,,,0,{i}.5,0,0,0,0,0" for i, us in enumerate(stamps)]
    (tmp_path / "frames.csv").write_text("\n".join([LEGACY_HEADER, *rows]) + "\n")
    doc = {"sessions": sessions or [{"rows_offset": 0, "samples": len(stamps)}]}
    if segments is not None:
        doc["sessions"][-1]["time_base"] = {"segments": segments}
    (tmp_path / "meta.json").write_text(json.dumps(doc))
    return tmp_path


def test_board_time_unwraps_the_32_bit_clock_and_restarts_at_a_reboot(tmp_path):
    stamps = [WRAP - 2000, WRAP - 1000, 500, 3_000_000, 2_999_000, 3_001_000, 10, 1010]
    rec = tactile.load_recording(_synthetic(tmp_path / "r", stamps))
    # the wrap carries on; a frame 1 ms back is out of order, not a reboot; 3 s back is
    np.testing.assert_array_equal(rec.segment, [0, 0, 0, 0, 0, 0, 1, 1])
    expect_us = [WRAP - 2000, WRAP - 1000, WRAP + 500, WRAP + 3_000_000, WRAP + 2_999_000,
                 WRAP + 3_001_000, 10, 1010]  # fmt: skip
    np.testing.assert_array_equal(rec.board_time_s, np.array(expect_us) * 1e-6)
    np.testing.assert_array_equal(rec.board_us, stamps)
    np.testing.assert_array_equal(rec.force_N[:, 0], np.arange(8) + 0.5)


def test_each_appended_session_starts_a_segment(tmp_path):
    sessions = [{"rows_offset": 0, "samples": 3}, {"rows_offset": 3, "samples": 2}]
    rec = tactile.load_recording(_synthetic(tmp_path / "r", [0, 10, 20, 25, 35], sessions))
    np.testing.assert_array_equal(rec.segment, [0, 0, 0, 1, 1])


def test_a_segment_without_a_usable_mapping_has_nan_host_time_and_says_why(tmp_path):
    stamps = [1_000_000, 1_001_000, 1_002_000, 5, 1005]  # a reboot at row 3
    segments = [_time_base(rows=3), _time_base(usable=False, first_row=3, rows=2)]
    rec = tactile.load_recording(_synthetic(tmp_path / "r", stamps, segments=segments))
    np.testing.assert_array_equal(rec.segment, [0, 0, 0, 1, 1])
    d = (np.array(stamps[:3]) - 500_000) * 1e-6 * (1 + 50e-6)
    np.testing.assert_allclose(rec.host_monotonic_s[:3], 2000.0 + d, rtol=0, atol=1e-9)
    assert np.isnan(rec.host_utc_s[3:]).all() and np.isnan(rec.host_monotonic_s[3:]).all()
    assert rec.host_time_why.startswith("2 of 5 rows have no host time (NaN), the first at row 3")
    assert "fast mode" in rec.host_time_why


def test_a_units_line_is_read_and_a_wrong_one_refused(recorded_run, recorded_msgs, tmp_path):
    body = _text(recorded_msgs)
    ok = variant(recorded_run, tmp_path / "ok", "# units: N, N*m, s\n" + body)
    rec = tactile.load_recording(ok)
    np.testing.assert_array_equal(rec.force_N, tactile.load_recording(recorded_run).force_N)
    bad = variant(recorded_run, tmp_path / "bad", "# units: mN\n" + body)
    with pytest.raises(InputError, match=r"frames\.csv:1: units 'mN': frames\.csv holds N"):
        tactile.load_recording(bad)


def _contacts_variant(recorded_run, dest, first_line, scale):
    out = variant(recorded_run, dest)
    lines = (recorded_run / "contacts.csv").read_text().splitlines()[1:]  # below its "# units: m"
    rows = [",".join(str(float(v) * scale) if i < 3 else v for i, v in enumerate(ln.split(",")))
            for ln in lines[1:]]  # fmt: skip
    head = [first_line] if first_line else []
    (out / "contacts.csv").write_text("\n".join([*head, lines[0], *rows]) + "\n")
    return out


def test_contacts_in_cm_by_their_units_line_are_given_in_metres(recorded_run, tmp_path):
    metres = tactile.load_recording(recorded_run).contacts.points_m
    rec = tactile.load_recording(
        _contacts_variant(recorded_run, tmp_path / "cm", "# units: cm, 1", 100.0)
    )
    assert rec.contacts.file_unit == "cm"
    np.testing.assert_allclose(rec.contacts.points_m, metres, rtol=1e-14, atol=1e-18)
    bad = _contacts_variant(recorded_run, tmp_path / "in", "# units: inch", 1.0)
    with pytest.raises(InputError, match=r"contacts\.csv:1: units 'inch': not a length unit"):
        tactile.load_recording(bad)


def test_contacts_without_a_units_line_take_the_unit_of_their_pose_log(recorded_run, tmp_path):
    """Files written before the units line: a SCARA joint log meant cm, a sensor-pose log m."""
    metres = tactile.load_recording(recorded_run).contacts.points_m
    scara = tmp_path / "joints.csv"
    scara.write_text("# rig: scara L1=0.35 L2=0.3 L3=0.12 L4=0.015\nt_start_us,t_end_us,finger,"
                     "q1,q2,q3,z\n0,10,0,0.1,0.2,0.3,0.1\n")  # fmt: skip
    cm = _contacts_variant(recorded_run, tmp_path / "cm", None, 100.0)
    meta = json.loads((cm / "meta.json").read_text())
    meta["command"] = ["tactile", "record", "--pose-log", str(scara), "-o", str(cm)]
    (cm / "meta.json").write_text(json.dumps(meta))
    rec = tactile.load_recording(cm)
    assert rec.contacts.file_unit == "cm"
    np.testing.assert_allclose(rec.contacts.points_m, metres, rtol=1e-14, atol=1e-18)
    scara.unlink()  # the log is gone: the unit cannot be told, and the loader says so
    rec = tactile.load_recording(cm)
    assert rec.contacts is None and "add '# units: cm' or '# units: m'" in rec.contacts_why
    assert len(rec) > 1000  # the frames still load


def test_bad_input_is_one_error_naming_the_file_line_and_column(
    recorded_run, recorded_msgs, tmp_path
):
    with pytest.raises(InputError, match="not a directory"):
        tactile.load_recording(tmp_path / "nothing")
    (tmp_path / "empty").mkdir()
    with pytest.raises(InputError, match=r"meta\.json: no such file"):
        tactile.load_recording(tmp_path / "empty")
    text = _text(recorded_msgs).splitlines()
    nan = text[:]
    nan[5] = nan[5].rsplit(",", 1)[0] + ",nan"  # line 6: tz_Nm
    with pytest.raises(InputError, match=r"frames\.csv:6: column 'tz_Nm': not a finite number"):
        tactile.load_recording(variant(recorded_run, tmp_path / "nan", "\n".join(nan) + "\n"))
    cells = text[3].split(",")
    cells[3] = str(C.MAX_SENSORS)  # line 4: a sensor index beyond the protocol's
    sensor = [*text[:3], ",".join(cells), *text[4:]]
    with pytest.raises(InputError, match=r"frames\.csv:4: column 'sensor': must be a whole"):
        tactile.load_recording(variant(recorded_run, tmp_path / "sensor", "\n".join(sensor) + "\n"))


def test_import_tactile_stays_light_and_the_loader_needs_no_mcap():
    code = (
        "import sys, tactile\n"
        "light = 'numpy' not in sys.modules\n"
        "load = tactile.load_recording\n"
        "print(light, 'numpy' in sys.modules, 'mcap' in sys.modules, load.__module__)\n"
    )
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert done.stdout.split() == [
        "True",
        "True",
        "False",
        "tactile.payload.apply",
    ]  # (payload= there)
    with pytest.raises(AttributeError, match="no attribute 'nonesuch'"):
        tactile.nonesuch  # noqa: B018
