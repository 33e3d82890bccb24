"""Every motion knows the sensor's orientation in the world, and the robot logs carry it
(docs/emulator.md, "The tool's weight, the sensor's orientation and the gauges' drift"): the
poses motion and its pose log, the wrist following the surface normal, the EP1 probe log's
quaternions, each kind's R(t), and the turns between knots.  Rotations are checked against
ones written out by hand (``rotations.py``) or the host's own kinematics."""

import math

import numpy as np
import pytest
from rotations import angle, rx, ry, rz
from scene_golden import strip_columns

from tactile import logs
from tactile.files.tabular import read_csv
from tactile.localize.posed import sensor_poses
from tactile.localize.world import pose_from_quaternion, scara_pose
from tactile.logs.read import read_pose_log, read_probe_log
from tactile_sim.emulator import load_scene
from tactile_sim.emulator.device import build_motion
from tactile_sim.emulator.orientation import Track, turn


def test_the_poses_motion_holds_each_orientation_and_logs_it(tmp_path):
    motion = build_motion(load_scene("payload_poses"))
    path = tmp_path / "poses.csv"
    motion.write_pose_log(path)
    log = read_pose_log(path)
    rpy = load_scene("payload_poses").motion["orientations_deg"]
    assert log.kind == "pose" and len(log) == len(rpy) == 9
    logged, _ = sensor_poses(log, np.arange(len(log)))
    assert log.end_us == round(motion.duration_s * 1e6) == 13_000_000
    np.testing.assert_array_equal(log.t_start, np.arange(9) * 1_500_000)
    np.testing.assert_array_equal(log.t_end, np.arange(9) * 1_500_000 + 1_000_000)
    for k, (roll, pitch, yaw) in enumerate(rpy):
        R = rz(yaw) @ ry(pitch) @ rx(roll)
        np.testing.assert_allclose(logged[k], R, atol=1e-12)
        for t_us in (log.t_start[k], log.t_end[k], (log.t_start[k] + log.t_end[k]) // 2):
            np.testing.assert_allclose(motion.orientation_at(t_us * 1e-6), R, atol=1e-12)
        assert not np.any(motion.wrench_at(t_us * 1e-6))  # touching nothing
    # between holds the hand turns along the shortest arc: half of it half-way (in time)
    for k in range(8):
        mid = 0.5 * (log.t_end[k] + log.t_start[k + 1]) * 1e-6
        whole = angle(logged[k], logged[k + 1])
        half = pytest.approx(whole / 2, abs=1e-3)
        assert angle(logged[k], motion.orientation_at(mid)) == half
        assert angle(motion.orientation_at(mid), logged[k + 1]) == half


def test_the_ep1_probe_log_states_each_holds_orientation(tmp_path):
    motion = build_motion(load_scene("ep1_roll_weighted"))
    path = tmp_path / "probes_log.csv"
    motion.write_probe_log(path)
    table = read_csv(path, logs.ATTITUDE)
    q0 = table.array("qw", "qx", "qy", "qz")
    q1 = table.array("qw_end", "qx_end", "qy_end", "qz_end")
    np.testing.assert_allclose(np.linalg.norm(q0, axis=1), 1.0, atol=1e-12)
    R0, R1 = (_rotations(q) for q in (q0, q1))
    # the finger starts pointing straight down (its pole, sensor +x, along world -z)
    np.testing.assert_allclose(R0[0][:, 0], [0.0, 0.0, -1.0], atol=1e-12)
    # each probe turns the finger by its commanded 0.5 rad (on a sphere: net = commanded)
    for a, b in zip(R0, R1):
        assert angle(a, b) == pytest.approx(0.5, abs=1e-6)
    np.testing.assert_allclose(R1[:-1], R0[1:], atol=1e-15)  # probes chain hold to hold
    mids = motion.holds.mean(axis=1)
    for k, R in enumerate(R0):
        np.testing.assert_allclose(motion.orientation_at(mids[k]), R, atol=1e-12)
    # today's reader reads it (the new columns are optional) and a log without them
    log = read_probe_log(path)
    assert len(log.probe) == 8 and log.dtheta.shape == (8, 2)
    old = tmp_path / "old_log.csv"
    old.write_text(strip_columns(path.read_text(), logs.ATTITUDE))
    np.testing.assert_array_equal(read_probe_log(old).dtheta, log.dtheta)


def _rotations(q):
    """Rotations (n, 3, 3) from scalar-first quaternions, by the host's own routine."""
    return pose_from_quaternion(np.zeros((len(q), 3)), q, scalar_first=True)[0]


def test_the_wrist_following_the_normal_points_each_finger_along_it(tmp_path):
    motion = build_motion(load_scene("ep2_sweep_wrist"))
    path = tmp_path / "poses.csv"
    motion.write_pose_log(path)
    log = read_pose_log(path)
    k, m = motion.normals.shape[:2]
    assert len(log) == k * m
    logged, _ = sensor_poses(log, np.arange(len(log)))
    for row in range(len(log)):
        f, t0, t1 = log.finger[row], log.t_start[row], log.t_end[row]
        j = int(np.flatnonzero(motion.windows_us[:, 0] == t0)[0])
        n = motion.normals[f, j]  # the world's outward normal at the contact
        for t_us in (t0, t1):
            R = motion.orientation_at(t_us * 1e-6, f)
            np.testing.assert_allclose(R[:, 0], -n, atol=1e-12)  # the pole into the surface
            np.testing.assert_allclose(R, logged[row], atol=1e-12)  # as logged
        # the contact is at the pole: the load pushes straight back along it, plus friction
        F = motion.wrench_at(0.5 * (t0 + t1) * 1e-6, f)[:3]
        assert F[0] == pytest.approx(-5.0, abs=1e-9)
        assert np.hypot(F[1], F[2]) == pytest.approx(0.3 * 5.0, abs=1e-9)
    # the normals differ across the sphere, so the hand really turns (47 deg across it)
    poles = np.array([motion.orientation_at(w * 1e-6, 0)[:, 0] for w in motion.windows_us[:, 0]])
    assert np.degrees(np.arccos(np.clip(poles @ poles.T, -1, 1)).max()) > 20.0
    fixed = build_motion(load_scene("ep2_sweep_sphere"))
    turns = [fixed.orientation_at(w * 1e-6, 0) for w in fixed.windows_us[:, 0]]
    assert all(np.array_equal(turns[0], R) for R in turns)  # wrist = "fixed": it never turns


def test_every_motion_kind_knows_the_sensors_orientation():
    press = build_motion(load_scene("press"))
    assert np.array_equal(press.orientation_at(0.3), np.eye(3))
    rig = build_motion(load_scene("ch5_convex"))  # the host's own SCARA kinematics agree
    for t0, t1, _, q1, q2, q3, z in rig.poses():
        R = scara_pose(q1, q2, q3, z)[0]
        for t_us in (t0 + 1, (t0 + t1) // 2, t1):  # (t0: the touch's start, cut to whole us)
            np.testing.assert_allclose(rig.orientation_at(t_us * 1e-6), R, atol=1e-12)
    roll = build_motion(load_scene("ep1_roll"))
    down = roll.orientation_at(0.0)
    np.testing.assert_allclose(down[:, 0], [0.0, 0.0, -1.0], atol=1e-12)
    for t_s in np.linspace(0.0, roll.duration_s, 97):  # a rotation at every instant
        R = roll.orientation_at(t_s)
        np.testing.assert_allclose(R.T @ R, np.eye(3), atol=1e-12)
        assert np.linalg.det(R) == pytest.approx(1.0, abs=1e-12)
    poses = build_motion(load_scene("payload_turn"))  # the half turn, point by point
    for t_s in np.linspace(0.0, poses.duration_s, 181):
        assert np.linalg.det(poses.orientation_at(t_s)) == pytest.approx(1.0, abs=1e-12)


def test_a_half_turn_between_knots_stays_within_2_mrad_of_the_exact_turn():
    R0, R1 = ry(90), ry(-85)  # (exactly half a turn has no one shortest arc)
    t, q = turn(R0, R1, 0.0, 1.0)
    track = Track(t, q)
    worst = 0.0
    for x in np.linspace(0.0, 1.0, 1001):
        exact = ry(90.0 - 175.0 * 0.5 * (1.0 - math.cos(math.pi * x)))
        worst = max(worst, angle(exact, track.at(x)))
    assert 1e-4 < worst < 2e-3
    assert angle(track.at(0.0), R0) < 1e-12 and angle(track.at(1.0), R1) < 1e-7
