"""From recorded CONTACT frames and a pose log to contacts.csv (``tactile.commands.derive``),
with the reading rule of ``tactile.localize.contact``."""

import numpy as np
import pytest

from tactile.board.stream_decoder import Contact
from tactile.commands import derive
from tactile.errors import InputError
from tactile.localize.contact import contact_frames


def _c(ts, phase, cid, fx=1_000_000, sensor=0):
    return Contact(0, ts, sensor, phase, cid, 0x40, fx, 0, 0, 0, 0, 0)


def test_the_first_readings_of_each_contact_are_taken_per_sensor():
    msgs = [_c(1, 0, 1), _c(2, 1, 1), _c(3, 1, 1), _c(4, 2, 1), _c(9, 0, 2), _c(10, 2, 2)]
    msgs += [_c(5, 0, 1, sensor=1), _c(6, 1, 1, sensor=1)]  # same id on another sensor
    t, sensor, w, ids = contact_frames(msgs, per_contact=2)
    assert t.tolist() == [1, 2, 9, 5, 6] and ids.tolist() == [1, 1, 2, 1, 1]
    assert sensor.tolist() == [0, 0, 0, 1, 1]
    np.testing.assert_allclose(w[:, 0], 1.0)
    assert len(contact_frames(msgs)[0]) == 6  # all BEGIN/IN readings, never END


def test_readings_inside_the_hysteresis_are_skipped_when_a_floor_is_given():
    # §5.1: a sample is taken when the x-y force exceeds the gate; a dip to 0.9 N inside
    # the contact (allowed by the exit threshold) is not a sample.
    msgs = [_c(1, 0, 1, 1_500_000), _c(2, 1, 1, 900_000), _c(3, 1, 1, 1_600_000), _c(4, 1, 1)]
    t, *_ = contact_frames(msgs, per_contact=2, above_N=1.39)
    assert t.tolist() == [1, 3]


def _recording(tmp_path):
    (tmp_path / "capture.bin").write_bytes(b"")
    (tmp_path / "meta.json").write_text("{}")


def test_a_scara_log_without_its_rig_lengths_is_refused(tmp_path):
    _recording(tmp_path)
    log = tmp_path / "poses.csv"
    log.write_text("t_start_us,t_end_us,finger,q1,q2,q3,z\n0,10,0,0,0,0,0\n")
    with pytest.raises(InputError, match="poses.csv: a SCARA pose log needs its link lengths"):
        derive.derive(tmp_path, log)


def test_an_unknown_pose_log_names_the_file(tmp_path):
    _recording(tmp_path)
    log = tmp_path / "log.csv"
    log.write_text("# a comment\na,b,c\n1,2,3\n")
    with pytest.raises(InputError, match="log.csv:2: expected columns"):
        derive.derive(tmp_path, log)
