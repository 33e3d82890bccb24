"""One module owns the robot logs' format (issue 15): every simulator robot writes through
``tactile.logs`` and each log reads back through the host's reader bit for bit."""

import numpy as np
import pytest

from tactile import logs, units
from tactile.files.tabular import read_csv
from tactile.localize.posed import sensor_poses
from tactile.localize.world import pose_from_quaternion
from tactile.logs.read import read_pose_log, read_probe_log
from tactile_sim.emulator.device import build_motion
from tactile_sim.emulator.scene import load_scene


def _motion(scene):
    return build_motion(load_scene(scene))


def _exact(a, b):
    """Equal to the last bit (and of one dtype kind: whole numbers stay whole)."""
    a, b = np.asarray(a), np.asarray(b)
    assert a.shape == b.shape and np.array_equal(a, b), (a, b)


def _end_us(motion):
    return round(motion.duration_s * 1e6)


@pytest.mark.parametrize("scene", ["ch5_convex", "ch5_concave"])
def test_the_rigs_scara_log_reads_back_bit_for_bit(tmp_path, scene):
    motion = _motion(scene)
    path = tmp_path / "poses.csv"
    motion.write_pose_log(path)
    log = read_pose_log(path)
    rows = motion.poses()
    assert log.kind == "scara" and log.clock == "board" and len(log) == len(rows) == 36
    _exact(log.t_start, [r[0] for r in rows])
    _exact(log.t_end, [r[1] for r in rows])
    _exact(log.finger, [r[2] for r in rows])
    _exact(log.joints, [r[3:] for r in rows])
    assert log.lengths == tuple(motion.lengths) and log.end_us == _end_us(motion)
    assert path.read_text().startswith(units.line(logs.UNITS["scara"]))


@pytest.mark.parametrize("scene", ["ep2_sweep_sphere", "ep2_sweep_saddle", "ep2_sweep_wrist"])
def test_the_sweeps_pose_log_reads_back_bit_for_bit(tmp_path, scene):
    motion = _motion(scene)
    path = tmp_path / "poses.csv"
    motion.write_pose_log(path)
    log = read_pose_log(path)
    rows = np.array(motion.poses())
    assert log.kind == "pose" and len(log) == len(rows) > 0
    _exact(log.t_start, rows[:, 0].astype(np.int64))
    _exact(log.t_end, rows[:, 1].astype(np.int64))
    _exact(log.finger, rows[:, 2].astype(int))
    _exact(log.position, rows[:, 3:6])
    _exact(log.quaternion, rows[:, 6:])  # as written; the rotation is localize's
    R, t = sensor_poses(log, np.arange(len(log)))
    _exact(R, pose_from_quaternion(rows[:, 3:6], rows[:, 6:], scalar_first=True)[0])
    _exact(t, rows[:, 3:6])
    centre, radius, axis = motion.probe()
    assert log.probe["radius"] == radius
    _exact(log.probe["centre"], centre)
    _exact(log.probe["axis"], np.asarray(axis, float))
    _exact(log.noise, motion.noise)
    assert log.end_us == _end_us(motion)


def test_the_roll_probe_log_reads_back_bit_for_bit(tmp_path):
    motion = _motion("ep1_roll")
    path = tmp_path / "probes_log.csv"
    motion.write_probe_log(path)
    log = read_probe_log(path)
    rows = motion.probe_log()
    assert len(rows) == 8 and log.clock == "board"
    _exact(log.probe, [r[0] for r in rows])
    _exact(log.t_start_us, [r[1] for r in rows])
    _exact(log.t_end_us, [r[2] for r in rows])
    _exact(log.dtheta, [r[3:5] for r in rows])
    attitude = read_csv(path, logs.ATTITUDE).array(*logs.ATTITUDE)
    _exact(attitude, [r[5:] for r in rows])  # each hold's orientation, as written
    assert log.radius_m == motion.geometry["radius_m"]
    _exact(log.centre_m, motion.geometry["centre_m"])
    assert log.half_width_us == motion.half_width_us() and log.end_us == _end_us(motion)


@pytest.mark.parametrize("clock", ["utc", "monotonic"])
def test_a_log_in_a_host_clock_reads_back_in_that_clock(tmp_path, clock):
    """The same writer stamps in a robot's own clock (s); the reader holds whole us."""
    rows = [(1_765_000_000.25, 1_765_000_000.5, 0, 0.1, -0.2, 0.3, 0.0, 1.0, 0.0, 0.0)]
    rows.append((1_765_000_001.0, 1_765_000_001.125, 1, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0))
    path = tmp_path / "poses.csv"
    logs.write_log(
        path, "pose", rows, clock, probe=(0.01, (0.02, 0.0, 0.0)), end_us=1_765_000_002_000_000
    )
    header = path.read_text().splitlines()[3]
    assert header.split(",")[:2] == list(logs.CLOCKS[clock][:2])
    log = read_pose_log(path)
    assert log.clock == clock and log.end_us == 1_765_000_002_000_000
    _exact(log.t_start, [1_765_000_000_250_000, 1_765_000_001_000_000])
    _exact(log.t_end, [1_765_000_000_500_000, 1_765_000_001_125_000])
    _exact(log.position, [r[3:6] for r in rows])


def test_every_kinds_units_line_is_what_the_readers_accept():
    for kind, spec in logs.UNITS.items():
        words = {w.strip() for w in spec.split(",")}
        assert words <= units.LOG_WORDS, (kind, words)
        assert set(logs.columns(kind)) >= set(logs.CLOCKS["board"][:2])


def _second_copies(sim_dir):
    text = "\n".join(p.read_text() for p in sim_dir.rglob("*.py"))
    found = [
        c
        for kind in logs.KINDS
        for c in (",".join(logs.COLUMNS[kind][:3]), '", "'.join(logs.COLUMNS[kind][:3]))
        if c in text
    ]
    return found + [name for name in logs.TAGS if f'"{logs.tag(name)} ' in text]


def test_the_simulator_writes_no_log_of_its_own():
    """No second copy of the columns or the comment lines in the simulator's writers."""
    from conftest import ROOT

    assert not _second_copies(ROOT / "sim")
