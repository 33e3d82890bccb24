"""The chapter 5 rig scenes through the emulator: TARE, then one contact per probed point."""

import numpy as np
import pytest
import serial

from tactile.board.stream_decoder import StreamDecoder
from tactile_protocol import constants as C
from tactile_protocol.framing import FrameEncoder
from tactile_sim.urlhandler import register

register()


def _session(scene, tare, core="python", contacts=None):
    """The scene's stream to its end (or until ``contacts`` contacts have ended)."""
    port = serial.serial_for_url(f"sim://{scene}?core={core}", timeout=0.005)
    decoder, msgs = StreamDecoder(), []
    if tare:
        port.write(bytes(FrameEncoder().encode(C.CMD_TARE, 0, (C.SENSOR_ALL, 64))))
    end = port.emulator.motion.duration_s * 1e6
    ended = 0
    while port.emulator.t_us < end and (contacts is None or ended < contacts):
        got = decoder.feed(port.read(65536))
        ended += sum(1 for m in got if m.type_name == "CONTACT" and m.phase == C.PHASE_END)
        msgs += got
    return port, msgs, decoder.counters


# (one scene on each firmware core: the scene is what is tested, both cores run it)
@pytest.mark.slow
@pytest.mark.parametrize("kind, core, expect", [("convex", "python", 36), ("concave", "c", 36)])
def test_each_probed_point_is_one_contact(kind, core, expect):
    port, msgs, counters = _session(f"ch5_{kind}", tare=True, core=core)
    acks = [m for m in msgs if m.type_name == "ACK" and m.cmd_type == C.CMD_TARE]
    assert len(acks) == 1
    begins = [m for m in msgs if m.type_name == "CONTACT" and m.phase == C.PHASE_BEGIN]
    motion = port.emulator.motion
    assert len(begins) == len(motion.onset) == expect
    assert counters.lost_frames == 0
    # The gate fires on the rising load of each touch, after its geometric onset.
    times = np.array([m.timestamp_us for m in begins]) / 1e6
    assert np.all(times > motion.onset) and np.all(times < motion.release)
    # x-y load at the gate crossing is the 5 ozf threshold within the sensor noise.
    fxy = np.array([np.hypot(m.fx, m.fy) for m in begins]) * C.FORCE_LSB_N
    assert np.all(np.abs(fxy - 1.39) < 0.4)


@pytest.mark.parametrize("tare", [False, True])
def test_tare_removes_the_transducer_bias(tare):
    """Measured load at each contact minus the scene's true load: the bias, or ~0 after TARE
    (over the first eight probed points)."""
    port, msgs, _ = _session("ch5_plane", tare=tare, contacts=8)
    emu = port.emulator
    model = emu.models[0]
    contacts = [m for m in msgs if m.type_name == "CONTACT"]
    assert contacts and not [m for m in msgs if m.type_name == "SAMPLE"]  # contacts-only stream
    measured = np.array([[m.fx, m.fy, m.fz, m.tx, m.ty, m.tz] for m in contacts]) * 1e-6
    truth = np.array([emu.motion.wrench_at(m.timestamp_us / 1e6) for m in contacts])
    error = (measured - truth).mean(axis=0)
    offset = model.C @ model.bias  # what an untared transducer reads at rest
    assert np.linalg.norm(offset[:3]) > 0.1
    expect = np.zeros(6) if tare else offset
    np.testing.assert_allclose(error[:3], expect[:3], atol=0.03)


def test_pose_log_matches_the_schedule(tmp_path):
    port = serial.serial_for_url("sim://ch5_plane", timeout=0.005)
    motion = port.emulator.motion
    path = tmp_path / "poses.csv"
    motion.write_pose_log(path)
    text = path.read_text()
    assert text.startswith("# units: us, rad, m\n# rig: scara L1=0.35 L2=0.3 L3=0.12 L4=0.015\n")
    assert f"\n# end: t_us={round(motion.duration_s * 1e6)}\n" in text  # the scene's end
    rows = np.loadtxt(path, delimiter=",", skiprows=4)
    assert rows.shape == (36, 7)
    assert np.all(np.diff(rows[:, 0]) > 0) and np.all(rows[:, 1] > rows[:, 0])
    assert sorted(set(rows[:, 2].astype(int))) == [0, 1, 2]
