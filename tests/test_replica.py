"""The chapter 5 replica through the emulator's serial path (issue 7, in part)."""

import numpy as np

from tactile import replica


def test_joints_come_from_the_pose_window_covering_each_sample():
    poses = [(0, 100, 0, 0.1, 0.2, 0.3, 0.0), (200, 300, 2, 1.1, 1.2, 1.3, 0.05)]
    joints, finger = replica.joints_at([50, 150, 250], poses)
    assert finger.tolist() == [0, -1, 2]
    np.testing.assert_allclose(joints[[0, 2]], [[0.1, 0.2, 0.3, 0.0], [1.1, 1.2, 1.3, 0.05]])
    assert np.isnan(joints[1]).all()


def test_two_samples_per_contact_are_taken():
    from tactile.messages import Contact

    def c(ts, phase, cid):
        return Contact(0, ts, 0, phase, cid, 0x40, 1_000_000, 0, 0, 0, 0, 0)

    msgs = [c(1, 0, 1), c(2, 1, 1), c(3, 1, 1), c(4, 2, 1), c(9, 0, 2), c(10, 2, 2)]
    t, w, ids = replica.contact_samples(msgs)
    assert t.tolist() == [1, 2, 9] and ids.tolist() == [1, 1, 2]
    np.testing.assert_allclose(w[:, 0], 1.0)


def test_demo_prints_the_replica_beside_the_thesis(cli):
    code, out, err = cli("demo", "--object", "convex")
    assert code == 0 and err == ""
    lines = out.splitlines()
    ours = [ln for ln in lines if ln.startswith("convex") and "ours" in ln]
    assert len(ours) == 2
    for line in ours:
        s, radius = float(line.split()[3]), float(line.split()[-1])
        assert abs(s - 0.5) < 0.05 and abs(radius - 6.6) / 6.6 < 0.15
    assert "label 'cylinder'" in out and "0 frames lost" in out
