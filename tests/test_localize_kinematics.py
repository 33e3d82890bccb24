"""Sensor frame to world: SCARA FK (eq. 62) against composed planar transforms, pose logs,
and the rig's inverse kinematics."""

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from tactile.localize import eq62, pose_from_matrix, pose_from_quaternion, scara_pose, to_world
from tactile_sim.rig.geometry import FREDDY, Rig, fk, ik, ik_fixed_wrist, planar

L = (FREDDY.L1, FREDDY.L2, FREDDY.L3, FREDDY.L4)


def test_scara_pose_matches_composed_planar_transforms():
    rng = np.random.default_rng(0)
    q = rng.uniform(-np.pi, np.pi, (500, 4))
    R, t = scara_pose(q[:, 0], q[:, 1], q[:, 2], q[:, 3], L[0], L[1])
    for k in range(500):
        Rk, tk = fk(FREDDY, q[k])
        assert np.abs(R[k] - Rk).max() < 1e-14 and np.abs(t[k] - tk).max() < 1e-14


def test_wheel_point_through_the_pose_is_eq62():
    rng = np.random.default_rng(1)
    q = rng.uniform(-np.pi, np.pi, (1000, 4))
    theta = rng.uniform(-np.pi, np.pi, 1000)
    R, t = scara_pose(q[:, 0], q[:, 1], q[:, 2], q[:, 3], L[0], L[1])
    local = np.stack([L[2] + L[3] * np.cos(theta), L[3] * np.sin(theta), 0 * theta], -1)
    world = to_world(R, t, local)
    x, y = eq62(q[:, 0], q[:, 1], q[:, 2], theta, *L)
    np.testing.assert_allclose(world[:, 0], x, atol=1e-14)
    np.testing.assert_allclose(world[:, 1], y, atol=1e-14)
    np.testing.assert_allclose(world[:, 2], q[:, 3])
    # and against a 2-D homogeneous chain written out link by link, including the probe
    T = planar(q[0, 0], L[0]) @ planar(q[0, 1], L[1]) @ planar(q[0, 2], L[2])
    T = T @ planar(theta[0], L[3])
    np.testing.assert_allclose([x[0], y[0]], T[:2, 2], atol=1e-14)


def test_pose_from_quaternion_matches_scipy_in_both_orders():
    rng = np.random.default_rng(2)
    quat = rng.standard_normal((300, 4)) * 3.0  # unnormalised on purpose
    pos = rng.standard_normal((300, 3))
    R, t = pose_from_quaternion(pos, quat)
    np.testing.assert_allclose(R, Rotation.from_quat(quat).as_matrix(), atol=1e-13)
    R2, _ = pose_from_quaternion(pos, np.roll(quat, 1, axis=1), scalar_first=True)
    np.testing.assert_allclose(R2, R, atol=1e-15)
    with pytest.raises(ValueError, match="zero length"):
        pose_from_quaternion(pos[:1], np.zeros((1, 4)))


def test_pose_from_matrix_and_world_normals():
    rng = np.random.default_rng(3)
    Rs = Rotation.random(50, random_state=4).as_matrix()
    T = np.zeros((50, 4, 4))
    T[:, :3, :3], T[:, :3, 3], T[:, 3, 3] = Rs, rng.standard_normal((50, 3)), 1.0
    R, t = pose_from_matrix(T)
    n = rng.standard_normal((50, 3))
    _, nw = to_world(R, t, np.zeros((50, 3)), n)
    np.testing.assert_allclose(np.linalg.norm(nw, axis=1), np.linalg.norm(n, axis=1))
    bad = T.copy()
    bad[0, :3, :3] *= 2.0
    with pytest.raises(ValueError, match="rigid"):
        pose_from_matrix(bad)
    mirror = T.copy()
    mirror[0, :3, 0] *= -1.0
    with pytest.raises(ValueError, match="rigid"):
        pose_from_matrix(mirror)


@pytest.mark.parametrize("elbow", [1, -1])
def test_ik_round_trip_places_the_wheel_centre(elbow):
    rig = Rig(elbow=elbow)
    rng = np.random.default_rng(5)
    for _ in range(200):
        r = rng.uniform(0.2, 0.7)
        a = rng.uniform(-np.pi, np.pi)
        centre = np.array([r * np.cos(a), r * np.sin(a), rng.uniform(0, 0.3)])
        heading = rng.uniform(-np.pi, np.pi)
        try:
            q = ik(rig, centre, heading)
        except ValueError:
            w = centre[:2] - rig.L3 * np.array([np.cos(heading), np.sin(heading)])
            assert not abs(rig.L1 - rig.L2) <= np.hypot(*w) <= rig.L1 + rig.L2
            continue
        R, t = fk(rig, q)
        np.testing.assert_allclose(R @ rig.centre + t, centre, atol=1e-13)
        assert np.isclose(np.arctan2(R[1, 0], R[0, 0]), heading) or abs(abs(heading) - np.pi) < 1e-9


def test_fixed_wrist_ik_keeps_q3():
    centre = np.array([0.55, 0.02, 0.1])
    q3 = ik(FREDDY, centre, 0.0)[2]
    for dy in (-0.03, 0.0, 0.03):
        target = centre + [0.01, dy, 0.0]
        q = ik_fixed_wrist(FREDDY, target, q3, 0.0)
        R, t = fk(FREDDY, q)
        assert abs(q[2] - q3) < 1e-12
        np.testing.assert_allclose(R @ FREDDY.centre + t, target, atol=1e-12)
    with pytest.raises(ValueError, match="reach|solution"):
        ik_fixed_wrist(FREDDY, np.array([2.0, 0.0, 0.0]), q3, 0.0)
