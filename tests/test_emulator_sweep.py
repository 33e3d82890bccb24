"""EP2 sweep scenes through the emulator: CONTACT frames + the pose log -> world contacts -> EP2.

The scenes stream CONTACT frames of three fingertip sensors (no TARE: bias 0).  The host
places each frame in the world through the robot's pose log (``tactile.logs.read``)
and the contacts go to ``analyze_patch``.  The checks against the truth go by other routes:
the simulator's own stations (``tactile_sim.ep2.sweep``), the closed-form sphere, and a
finite-difference propagation of the sensor noise.
"""

import json
import re

import numpy as np
import pytest
from sweep_record import record_sweep

from tactile.ep2 import analyze_patch
from tactile.errors import InputError
from tactile.localize.posed import (
    MAX_NORMAL_SD_DEG,
    normal_sd,
    posed_world_contacts,
    sensor_poses,
)
from tactile.localize.probes import sphere_contact
from tactile.logs.read import read_pose_log
from tactile_protocol import constants as C
from tactile_sim.emulator.scene import SCENE_DIR, SceneError, load_scene
from tactile_sim.urlhandler import register

register()

GATE_N = 1.39  # the scenes' enter threshold (5 ozf)
SIGMA = np.array([0.0556, 0.0556, 0.1112, 0.00282, 0.00282, 0.00282])  # the scenes' noise


def _scene_file(tmp_path, name, noiseless=False, **motion):
    """A copy of a shipped scene, optionally noiseless or with [motion] keys replaced."""
    text = (SCENE_DIR / f"{name}.toml").read_text(encoding="utf-8")
    if noiseless:
        text = re.sub(r"(?m)^noise_(force_N|torque_Nm) = .*$", r"noise_\1 = [0.0, 0.0, 0.0]", text)
    for key, value in motion.items():
        text, n = re.subn(rf"(?m)^{key} = .*$", f"{key} = {value!r}", text)
        text += "" if n else f"{key} = {value!r}\n"  # [motion] is the last section
    path = tmp_path / f"{name}.toml"
    path.write_text(text, encoding="utf-8")
    return path


_record = record_sweep


def _world(motion, tmp_path, t, sensor, wrench):
    path = tmp_path / "poses.csv"
    motion.write_pose_log(path)
    return posed_world_contacts(read_pose_log(path), t, sensor, wrench, GATE_N)


@pytest.fixture(scope="module")
def sphere_run():
    return _record("sim://ep2_sweep_sphere")


def test_scene_loads_and_builds_only_the_sweep():
    scene = load_scene("ep2_sweep_sphere")
    assert scene.board["sensors"] == 3 and scene.sensor["bias_counts"] == 0.0
    assert scene.board["streams"] == ["contacts"]
    from tactile_sim.emulator.device import build_motion

    motion = build_motion(scene)
    assert motion.points.shape == (3, 21, 3)
    t = np.linspace(0.0, motion.duration_s, 50)
    assert motion.wrench_at(t, 0).shape == (6, 50)
    assert not np.any(motion.wrench_at(t, 3))  # no finger on a 4th sensor
    assert not np.any(motion.wrench_at(0.0, 1)) and not np.any(motion.wrench_at(t[-1], 1))


@pytest.mark.parametrize(
    "key, value, says",
    [("fingers", 4, "fingers"), ("samples", 1, "samples"), ("mu", -0.1, "mu"),
     ("object", "cube", "object"), ("speed", 1.0, "unknown key"), ("settle_s", 0.5, "settle_s")],
)  # fmt: skip
def test_bad_motion_keys_are_one_line_scene_errors(tmp_path, key, value, says):
    from tactile_sim.emulator.device import build_motion

    path = _scene_file(tmp_path, "ep2_sweep_sphere", **{key: value})
    with pytest.raises(SceneError) as err:
        build_motion(load_scene(path))
    msg = str(err.value)
    assert "\n" not in msg and str(path) in msg and says in msg


def test_one_contact_per_finger_during_the_ramps(sphere_run):
    motion, t, sensor, _, phase, counters = sphere_run
    assert counters.lost_frames == 0
    first, last = motion.windows_us[0], motion.windows_us[-1]
    ramp = round(motion.cfg["ramp_s"] * 1e6)
    for s in range(3):
        mine = sensor == s
        assert np.sum(phase[mine] == C.PHASE_BEGIN) == 1
        assert np.sum(phase[mine] == C.PHASE_END) == 1
        begin = t[mine & (phase == C.PHASE_BEGIN)][0]
        end = t[mine & (phase == C.PHASE_END)][0]
        assert first[0] < begin <= first[0] + ramp  # the gate trips while the load ramps up
        assert last[1] - ramp < end <= last[1] + 2000  # and lets go as it ramps down


def test_noiseless_world_contacts_are_the_simulators_contacts(tmp_path):
    """Through firmware, wire and pose log, each frame lands on the station's true contact."""
    url = f"sim://{_scene_file(tmp_path, 'ep2_sweep_sphere', noiseless=True)}"
    motion, t, sensor, wrench, _, _ = _record(url)
    points, normals, finger, report = _world(motion, tmp_path, t, sensor, wrench)
    assert report.usable > 1200 and report.outside == 0 and report.unusable == 0
    assert report.usable + report.no_contact == report.frames
    true_p = np.empty_like(points)
    true_n = np.empty_like(normals)
    for f in range(3):
        rows = finger == f
        true_p[rows], true_n[rows], station = motion.true_contact(t[report.kept][rows], f)
        assert np.all(station >= 0)
    np.testing.assert_array_equal(finger, sensor[report.kept])
    # 1 uN / 1 uN*m wire LSBs and 24-bit codes: sub-micrometre, sub-0.1 mrad
    assert np.abs(points - true_p).max() < 2e-6
    assert np.abs(normals - true_n).max() < 1e-4


def test_noisy_contacts_lie_on_the_sphere_as_the_noise_predicts(sphere_run, tmp_path):
    motion, t, sensor, wrench, _, _ = sphere_run
    points, _, finger, report = _world(motion, tmp_path, t, sensor, wrench)
    assert report.usable > 1200 and report.outside == 0
    kept = report.kept
    R, r = motion.cfg["radius_m"], motion.cfg["fingertip_radius_m"]
    true_p = np.empty_like(points)
    for f in range(3):
        true_p[finger == f] = motion.true_contact(t[kept][finger == f], f)[0]
    delta = np.linalg.norm(points - true_p, axis=1)
    # Closed form: a point on the fingertip at chord delta from the tangency point s is
    # sqrt(R^2 + (1 + R/r) delta^2) - R off a sphere of radius R (centre below the apex).
    centre = motion.tilt @ np.array([0.0, 0.0, -R])
    dist = np.linalg.norm(points - centre, axis=1) - R
    np.testing.assert_allclose(dist, np.sqrt(R * R + (1 + R / r) * delta**2) - R, atol=2e-6)
    assert np.median(np.abs(dist)) < 1e-4  # ~1 mm along the surface is < 0.1 mm off it
    # Noise: first-order propagation of the sensor's sigmas by finite differences of the
    # localiser at the noiseless load; mean squared error within 15-20 % of it (1300 frames).
    w0 = np.array([motion.wrench_at(ti * 1e-6, s) for ti, s in zip(t[kept], sensor[kept])])
    centre_s, radius, _ = motion.probe()
    base = sphere_contact(w0[:, :3], w0[:, 3:], centre_s, radius).point
    predicted = np.zeros(len(w0))
    for k in range(6):
        w = w0.copy()
        w[:, k] += 1e-6
        d = (sphere_contact(w[:, :3], w[:, 3:], centre_s, radius).point - base) / 1e-6
        predicted += SIGMA[k] ** 2 * np.sum(d * d, axis=1)
    assert 0.85 < np.mean(delta**2) / np.mean(predicted) < 1.2


def _normal_error_model(motion, t, sensor):
    """Per frame, from the simulator's true load: the true normal (sensor frame), a tangent
    basis (n, 2, 3) there and the 2x2 covariance of the normal's error from SIGMA, by
    forward differences of the localiser (first order; a Monte Carlo test checks it)."""
    w0 = np.array([motion.wrench_at(ti * 1e-6, s) for ti, s in zip(t, sensor)])
    centre, radius, _ = motion.probe()
    n0 = sphere_contact(w0[:, :3], w0[:, 3:], centre, radius).normal
    J = np.zeros((len(w0), 3, 6))
    for k in range(6):
        w = w0.copy()
        w[:, k] += 1e-7
        J[:, :, k] = (sphere_contact(w[:, :3], w[:, 3:], centre, radius).normal - n0) / 1e-7
    a = np.where(np.abs(n0[:, :1]) < 0.9, [[1.0, 0.0, 0.0]], [[0.0, 1.0, 0.0]])
    e1 = np.cross(n0, a)
    e1 /= np.linalg.norm(e1, axis=1, keepdims=True)
    T = np.stack([e1, np.cross(n0, e1)], axis=1)
    Jt = T @ J
    return n0, T, np.einsum("nik,k,njk->nij", Jt, SIGMA**2, Jt)


def test_normal_sd_is_the_closed_form_at_the_pole_and_weak_frames_are_dropped(tmp_path):
    """A press on the pole of a fingertip (centre c on the sensor's x axis, radius r): a
    moment error dM shifts the line of action by dM/f, a force error dF tilts it about the
    sensor origin, moving the point by (c + r) dF/f; the normal turns by the shift / r."""
    c, r = 0.03, 0.012
    f = np.array([1.5, 5.0])
    F = np.column_stack([-f, 0 * f, 0 * f])
    closed = np.hypot(np.hypot(SIGMA[4], SIGMA[5]), (c + r) * np.hypot(SIGMA[1], SIGMA[2])) / (
        f * r
    )
    np.testing.assert_allclose(normal_sd(F, 0 * F, (c, 0, 0), r, SIGMA), closed, rtol=1e-5)
    assert np.degrees(closed[0]) > MAX_NORMAL_SD_DEG > np.degrees(closed[1])  # 21.0, 6.3 deg
    head = "# probe: sphere radius_m=0.012 centre_m=0.03,0,0 axis=1,0,0\n"
    rows = GOOD + "0,10,0,0,0,0,1,0,0,0\n"
    sensor = (
        "# sensor: noise_force_N=0.0556,0.0556,0.1112 noise_torque_Nm=0.00282,0.00282,0.00282\n"
    )
    plain, stated = tmp_path / "plain.csv", tmp_path / "stated.csv"
    plain.write_text(head + rows, encoding="utf-8")
    stated.write_text(head + sensor + rows, encoding="utf-8")
    W = np.column_stack([F, 0 * F])
    kept_all = posed_world_contacts(read_pose_log(plain), [5, 6], [0, 0], W, 1.39)
    assert kept_all.report.usable == 2 and kept_all.report.imprecise == 0
    assert kept_all.normal_sd is None  # no noise known: nothing to judge by
    for res in (
        posed_world_contacts(read_pose_log(plain), [5, 6], [0, 0], W, 1.39, noise=SIGMA),
        posed_world_contacts(read_pose_log(stated), [5, 6], [0, 0], W, 1.39),
    ):
        assert res.report.imprecise == 1 and res.report.kept.tolist() == [1]
        assert res.report.status == {"imprecise": 1, "ok": 1}
        np.testing.assert_allclose(res.normal_sd, closed[1:], rtol=1e-5)
    loose = posed_world_contacts(read_pose_log(stated), [5, 6], [0, 0], W, 1.39,
                                 max_normal_sd_deg=25.0)  # fmt: skip
    assert loose.report.usable == 2


def test_normal_sd_agrees_with_monte_carlo_on_sweep_loads():
    """First order against 20000 noisy localisations of real sweep loads (friction, off the
    pole) at 3.1 N, where the 10 deg limit falls: the rms angles agree to 3 %."""
    from tactile_sim.emulator.device import build_motion

    motion = build_motion(load_scene("ep2_sweep_sphere"))
    centre, radius, _ = motion.probe()
    rng = np.random.default_rng(5)
    for finger, station in ((0, 0), (1, 10), (2, 20)):
        w = 0.6 * motion.wrench_stations[finger, station]
        n0 = sphere_contact(w[:3], w[3:], centre, radius).normal
        noisy = w + rng.normal(size=(20000, 6)) * SIGMA
        n = sphere_contact(noisy[:, :3], noisy[:, 3:], centre, radius).normal
        mc = np.sqrt(np.mean(np.arccos(np.clip(n @ n0, -1.0, 1.0)) ** 2))
        sd = normal_sd(w[:3], w[3:], centre, radius, SIGMA)[0]
        assert sd == pytest.approx(mc, rel=0.03)


@pytest.mark.parametrize("seed", [11, 21, 28])
def test_recorded_sweep_normals_follow_the_noise_and_analyse_as_a_sphere(tmp_path, capsys, seed):
    """``tactile record`` + ``tactile ep2 analyze`` over the whole sweep, load ramps included.

    Before the pose log stated the sensor noise, the first and last frames of each finger
    (~1.6 N while the load ramps, normals ~19 deg rms) were kept; with the sweep's own 34 deg
    of normal spread they broke EP2's 70 deg limit (seed 21 here, the shipped seed over a
    pty).  Now: every kept normal is within chi^2_2 = 30 (P = 3e-7 per frame) of the truth
    under its own propagated noise, the mean chi^2 is the 2 it should be, and the frames
    dropped are exactly the low-force ramp frames.
    """
    from tactile.cli.main import main
    from tactile_sim.emulator.device import build_motion

    scene = _scene_file(tmp_path, "ep2_sweep_sphere", seed=seed)
    motion = build_motion(load_scene(scene))
    poses, out = tmp_path / "poses.csv", tmp_path / "rec"
    motion.write_pose_log(poses)
    argv = ["record", "--port", f"sim://{scene}", "--no-tare", "--contacts", "3",
            "--pose-log", str(poses), "-o", str(out), "--quiet"]  # fmt: skip
    assert main(argv) == 0
    capsys.readouterr()
    assert main(["ep2", "analyze", str(out / "contacts.csv"), "--json"]) == 0
    rec = json.loads(capsys.readouterr().out.splitlines()[0])
    # F/T-localised contacts carry errors that vary over the sweep: where the 4-jet sees
    # them, the intervals widen and the label may be 'uncertain' (docs/ep2.md, Limits)
    assert (
        rec["shape"] in ("sphere", "uncertain")
        and max(rec["votes"], key=rec["votes"].get) == "sphere"
    )
    assert rec["S_interval"][0] <= 1.0 <= rec["S_interval"][1]

    frames = np.genfromtxt(out / "frames.csv", delimiter=",", names=True, dtype=None,
                           skip_header=1, encoding="utf-8")  # fmt: skip
    frames = frames[(frames["type"] == "CONTACT") & (frames["phase"] <= C.PHASE_IN)]
    t, sensor = frames["timestamp_us"].astype(np.int64), frames["sensor"].astype(int)
    wrench = np.column_stack([frames[c] for c in ("fx_N", "fy_N", "fz_N", "tx_Nm", "ty_Nm",
                                                  "tz_Nm")])  # fmt: skip
    res = posed_world_contacts(read_pose_log(poses), t, sensor, wrench, GATE_N)
    written = np.genfromtxt(out / "contacts.csv", delimiter=",", names=True, skip_header=1)
    written = np.column_stack([written[c] for c in ("nx", "ny", "nz")])
    np.testing.assert_allclose(written, res.normals, atol=1e-12)  # frames.csv: 1 uN text
    kept = res.report.kept
    assert res.report.outside == res.report.unusable == 0
    assert res.report.usable + res.report.imprecise == len(t)

    n0, T, cov = _normal_error_model(motion, t, sensor)
    rms = np.degrees(np.sqrt(np.trace(cov, axis1=1, axis2=2)))
    true_n = np.empty_like(res.normals)
    for f in range(3):
        rows = res.finger == f
        true_n[rows], _, station = motion.true_contact(t[kept][rows], f)
        assert np.all(station >= 0)
    # world error -> sensor frame (R: sensor -> world) -> the true normal's tangent plane
    err = np.einsum("nji,nj->ni", motion.sensor_R[res.finger], res.normals - true_n)
    e2 = np.einsum("nij,nj->ni", T[kept], err)
    chi2 = np.einsum("ni,nij,nj->n", e2, np.linalg.inv(cov[kept]), e2)
    assert chi2.max() < 30.0
    assert 1.7 < chi2.mean() < 2.3  # chi^2_2 has mean 2; sd of this mean ~0.06

    ramp = round(motion.cfg["ramp_s"] * 1e6)
    (first_start, _), (_, last_end) = motion.windows_us[0], motion.windows_us[-1]
    in_ramp = (t < first_start + ramp) | (t > last_end - ramp)
    dropped = np.setdiff1d(np.arange(len(t)), kept)
    # Every kept normal's rms error is within the limit, and only the ramp frames at or
    # above it are dropped (the host judges the measured load, a few % off the true one).
    assert rms[kept].max() < 1.1 * MAX_NORMAL_SD_DEG
    assert dropped.size and np.all(in_ramp[dropped])
    assert rms[dropped].min() > 0.9 * MAX_NORMAL_SD_DEG
    for f in range(3):
        mine = np.flatnonzero(sensor == f)
        first, last = mine[0], mine[-1]  # BEGIN and the last IN frame: mid-ramp, ~1.6 N
        assert first in dropped and last in dropped and min(rms[first], rms[last]) > 15.0
        mine_kept = kept[sensor[kept] == f]
        assert in_ramp[mine_kept[0]] and in_ramp[mine_kept[-1]]  # the ramps are still used


def test_sphere_sweep_analyses_as_a_sphere_of_the_right_radius(sphere_run, tmp_path):
    motion, t, sensor, wrench, _, _ = sphere_run
    points, normals, finger, _ = _world(motion, tmp_path, t, sensor, wrench)
    res = analyze_patch(points, normals, finger=finger)
    R = motion.cfg["radius_m"]
    assert res.shape == "sphere" and res.S > 0.95
    # Radius at the centre within 8 % and the truth inside its 95 % interval.
    assert abs(res.radius - R) < 0.08 * R
    assert res.radius_interval[0] < R < res.radius_interval[1]


def test_saddle_sweep_analyses_as_a_saddle(tmp_path):
    motion, t, sensor, wrench, _, _ = _record("sim://ep2_sweep_saddle")
    points, normals, finger, report = _world(motion, tmp_path, t, sensor, wrench)
    res = analyze_patch(points, normals, finger=finger)
    assert res.shape in ("saddle", "uncertain") and abs(res.S) < 0.05
    assert max(res.votes, key=res.votes.get) == "saddle"  # (uncertain: docs/ep2.md, Limits)
    assert res.S_interval[0] <= 0.0 <= res.S_interval[1]
    # A quadric saddle's curvature falls off the apex: compare with the same analysis of the
    # simulator's exact contacts (seeds 1-12: within 6 %), not with 1/R at the apex.
    k = motion.points.shape[1]
    exact = analyze_patch(
        motion.points.reshape(-1, 3), motion.normals.reshape(-1, 3), finger=np.repeat(range(3), k)
    )
    np.testing.assert_allclose((res.k1, res.k2), (exact.k1, exact.k2), rtol=0.1)
    assert exact.k1 == pytest.approx(1 / motion.cfg["radius_m"], rel=0.2)


def test_frames_during_moves_are_dropped_and_counted(tmp_path):
    """A 7 ms move between stations at 500 Hz: frames stamped inside it have no pose."""
    url = f"sim://{_scene_file(tmp_path, 'ep2_sweep_sphere', settle_s=0.007)}"
    motion, t, sensor, wrench, _, _ = _record(url)
    _, _, _, report = _world(motion, tmp_path, t, sensor, wrench)
    w = motion.windows_us
    held = np.zeros(len(t), bool)
    for a, b in w:
        held |= (t >= a) & (t <= b)
    assert report.outside == np.sum(~held) > 0
    assert report.frames == (
        report.outside + report.no_contact + report.unusable + report.imprecise + report.usable
    )


def test_pose_log_round_trips(tmp_path):
    from tactile_sim.emulator.device import build_motion

    motion = build_motion(load_scene("ep2_sweep_sphere"))
    path = tmp_path / "poses.csv"
    motion.write_pose_log(path)
    log = read_pose_log(path)
    k, m = motion.points.shape[:2]
    assert log.kind == "pose" and len(log) == k * m
    for f in range(k):
        rows = np.flatnonzero(log.finger == f)
        np.testing.assert_array_equal(np.column_stack([log.t_start, log.t_end])[rows],
                                      motion.windows_us)  # fmt: skip
        R, t = sensor_poses(log, rows)
        np.testing.assert_allclose(t, motion.sensor_t[f], atol=1e-15)
        np.testing.assert_allclose(R, np.broadcast_to(motion.sensor_R[f], (m, 3, 3)),
                                   atol=1e-12)  # fmt: skip
    centre, radius, axis = motion.probe()
    assert log.probe["radius"] == radius
    np.testing.assert_array_equal(log.probe["centre"], centre)
    np.testing.assert_array_equal(log.probe["axis"], axis)
    np.testing.assert_array_equal(log.noise, SIGMA)  # the scene's [sensor] noise, stated


def test_scara_pose_log_places_the_rig_frames(tmp_path):
    """The ch. 5 rig's joint log: frames at each touch land on the schedule's true contacts."""
    from tactile_sim.emulator.device import build_motion
    from tactile_sim.rig.geometry import FREDDY

    motion = build_motion(load_scene("ch5_convex"))
    path = tmp_path / "rig.csv"
    motion.write_pose_log(path)
    log = read_pose_log(path)
    assert log.kind == "scara" and log.joints.shape == (len(log), 4)
    mid = (log.t_start + log.t_end) // 2
    wrench = motion.wrench_at(mid * 1e-6).T
    lengths = (FREDDY.L1, FREDDY.L2, FREDDY.L3, FREDDY.L4)
    points, _, finger, report = posed_world_contacts(
        log, mid, np.zeros(len(mid), int), wrench, GATE_N, lengths=lengths
    )
    touch = np.unique(motion.touch[motion.touch >= 0])[report.kept]
    assert report.usable > 30
    np.testing.assert_allclose(points, motion.schedule["point"][touch], atol=1e-9)
    np.testing.assert_array_equal(finger, motion.schedule["finger"][touch])


def test_window_lookup_respects_finger_and_latency(tmp_path):
    path = tmp_path / "p.csv"
    path.write_text(
        "# probe: sphere radius_m=0.01 centre_m=0.02,0,0\n"
        "t_start_us,t_end_us,finger,px,py,pz,qw,qx,qy,qz\n"
        "1000,2000,0,0,0,0,1,0,0,0\n"
        "3000,4000,0,1,0,0,1,0,0,0\n"
        "1000,4000,1,0,0,1,1,0,0,0\n",
        encoding="utf-8",
    )
    log = read_pose_log(path)
    wrench = np.tile([-3.0, 0.0, 0.0, 0.0, 0.0, 0.0], (6, 1))  # press on the pole
    t = np.array([999, 1000, 2500, 3100, 3100, 4000])
    sensor = np.array([0, 0, 0, 0, 1, 2])
    points, normals, finger, report = posed_world_contacts(log, t, sensor, wrench, 1.0)
    assert report.outside == 3  # before the first window, between windows, unknown sensor
    np.testing.assert_allclose(points, [[0.03, 0, 0], [1.03, 0, 0], [0.03, 0, 1]])
    np.testing.assert_allclose(normals, np.tile([-1.0, 0, 0], (3, 1)))
    np.testing.assert_array_equal(finger, [0, 0, 1])
    late = posed_world_contacts(log, t, sensor, wrench, 1.0, latency_us=200)
    assert late.report.outside == 5  # t=1000 and 3100 may hold samples taken before the window


GOOD = "t_start_us,t_end_us,finger,px,py,pz,qw,qx,qy,qz\n"


@pytest.mark.parametrize(
    "text, line, says",
    [
        (GOOD + "0,10,0,0,0,0,1,0,0,0\n0,10,0,0,0,x,1,0,0,0\n", 3, "'pz': not a number"),
        (GOOD + "10,5,0,0,0,0,1,0,0,0\n", 2, "ends before"),
        (GOOD + "0,10,0.5,0,0,0,1,0,0,0\n", 2, "'finger': must be a whole number"),
        # issue 12: once accepted with garbage ids after a cast warning
        (GOOD + "0,10,1e19,0,0,0,1,0,0,0\n", 2, "'finger': must be a whole number in 0..2147"),
        (GOOD + "1e308,2e308,0,0,0,0,1,0,0,0\n", 2, "'t_end_us': not a finite number"),
        (GOOD + "1e308,1e308,0,0,0,0,1,0,0,0\n", 2, "'t_start_us': must be a whole number in 0..4"),
        (GOOD + "0,4294967296,0,0,0,0,1,0,0,0\n", 2, "'t_end_us': must be a whole number in 0..42"),
        (GOOD + "0,10,0,0,0,0,2e5,0,0,0\n", 2, "not unit length"),
        (GOOD + "0,10,0,0,0,0,1e200,0,0,0\n", 2, "'qw': must be within +-1e+06"),
        (GOOD + "0,10,0,1e300,0,0,1,0,0,0\n", 2, "'px': must be within +-1e+06"),
        ("# probe: sphere radius_m=1e300 centre_m=0,0,0\n" + GOOD + "0,10,0,0,0,0,1,0,0,0\n", 1,
         "radius_m: need 1 number(s) within"),
        ("# rig: scara L1=1 L2=1 L3=1 L4=1e308\nt_start_us,t_end_us,finger,q1,q2,q3,z\n"
         "0,1,0,0,0,0,0\n", 1, "rig: lengths must be > 0 and <= 1e+06 m"),
        ("\ufeff" + GOOD + "0,10,-1,0,0,0,1,0,0,0\n", 2, "'finger': must be a whole number"),
        (GOOD + "0,10,0,0,0,0,2,0,0,0\n", 2, "not unit length"),
        (GOOD + "0,10,0,0,0,0,1,0,0,0\n5,20,0,0,0,0,1,0,0,0\n", 3, "overlaps the one on line 2"),
        (GOOD + "0,10,0,0,0,0,1,0,0\n", 2, "'qz': missing value"),
        ("# a comment\nt_start_us,t_end_us,finger,x,y\n", 2, "expected columns"),
        ("# probe: sphere radius_m=0.01 centre_m=0,0\n" + GOOD + "0,10,0,0,0,0,1,0,0,0\n", 1,
         "centre_m: need 3"),
        ("# probe: cube side=1\n" + GOOD + "0,10,0,0,0,0,1,0,0,0\n", 1, "only 'sphere'"),
        ("# rig: scara L1=0.3\nt_start_us,t_end_us,finger,q1,q2,q3,z\n0,1,0,0,0,0,0\n", 1,
         "rig: need"),
        ("# sensor: noise_force_N=0.1,0.1 noise_torque_Nm=0,0,0\n" + GOOD
         + "0,10,0,0,0,0,1,0,0,0\n", 1, "noise_force_N: need 3"),
        ("# sensor: noise_force_N=0.1,0.1,0.2\n" + GOOD + "0,10,0,0,0,0,1,0,0,0\n", 1,
         "sensor: need noise_force_N"),
        ("# sensor: noise_force_N=0.1,0.1,-0.2 noise_torque_Nm=0,0,0\n" + GOOD
         + "0,10,0,0,0,0,1,0,0,0\n", 1, ">= 0"),
        ("# probe: sphere radius_m=0.01 centre_m=0,0,0 colour=red\n" + GOOD
         + "0,10,0,0,0,0,1,0,0,0\n", 1, "probe: unknown field 'colour=red' (radius_m=R"),
        ("# probe: sphere radius_m=0.01 centre_m=0,0,z\n" + GOOD + "0,10,0,0,0,0,1,0,0,0\n", 1,
         "probe: centre_m: not numbers: '0,0,z'"),
        ("# sensor: noise_force_N=0.1,0.1,0.1 noise_torque_Nm\n" + GOOD
         + "0,10,0,0,0,0,1,0,0,0\n", 1, "sensor: unknown field 'noise_torque_Nm'"),
        ("# sensor: noise_force_N=0.1,0.1,nan noise_torque_Nm=0,0,0\n" + GOOD
         + "0,10,0,0,0,0,1,0,0,0\n", 1, "noise_force_N: need 3 number(s) >= 0 and <= 1e+06"),
    ],
)  # fmt: skip
def test_bad_pose_log_is_one_line_naming_file_and_line(tmp_path, text, line, says):
    path = tmp_path / "bad.csv"
    path.write_text(text, encoding="utf-8")
    with pytest.raises(InputError) as err:
        read_pose_log(path)
    msg = str(err.value)
    assert "\n" not in msg and msg.startswith(f"{path}:{line}") and says in msg


def test_missing_pose_log_and_probe_are_input_errors(tmp_path):
    with pytest.raises(InputError, match="cannot read"):
        read_pose_log(tmp_path / "nope.csv")
    path = tmp_path / "p.csv"
    path.write_text(GOOD + "0,10,0,0,0,0,1,0,0,0\n", encoding="utf-8")
    with pytest.raises(InputError, match="no '# probe: sphere"):
        posed_world_contacts(read_pose_log(path), [5], [0], np.ones((1, 6)), 0.0)
