"""EP1 through the F/T path: the ``roll`` scene on the emulator, probes from CONTACT frames.

Tolerances come from the scene's noise: each hold's averaged wrench has covariance
diag(sigma^2) / n (n frames), which the localiser's Jacobian (central differences) maps to
the contact's (u, v); a probe's dp is the difference of two holds and the curvature is a
function of all nine holds, so both get a propagated standard deviation and must lie within
5 of them.  Without noise the chain's own floor is one ADC count of force and one wire LSB
(1 uN*m) of torque, over the lever arm.
"""

import pathlib
import re
import time

import numpy as np
import pytest
import serial

from tactile.board.stream_decoder import StreamDecoder
from tactile.ep1.estimator import estimate
from tactile.ep1.probes import fingertip_uv, probe_report, probes_from_frames
from tactile.errors import InputError
from tactile.localize.probes import sphere_contact
from tactile.logs.read import read_probe_log
from tactile_protocol import constants as C
from tactile_sim.emulator import SceneError, load_scene
from tactile_sim.emulator.device import build_motion
from tactile_sim.emulator.scene import SCENE_DIR
from tactile_sim.urlhandler import register

register()
SHIPPED = SCENE_DIR / "ep1_roll.toml"
TOL_SIGMA = 5.0


def _variant(tmp_path, name, **subs):
    """The shipped scene with whole lines replaced (key = value), as a new file."""
    text = SHIPPED.read_text()
    for key, value in subs.items():
        text, n = re.subn(rf"(?m)^{key} = .*$", f"{key} = {value}", text)
        assert n == 1, key
    path = tmp_path / f"{name}.toml"
    path.write_text(text)
    return path


def _record(url):
    """Run a scene through sim:// to its end; CONTACT frames as (t_us, wrench N/N*m)."""
    port = serial.serial_for_url(url, timeout=0.005)
    decoder, msgs = StreamDecoder(), []
    end = port.emulator.motion.duration_s * 1e6
    while port.emulator.t_us < end:
        msgs += decoder.feed(port.read(65536))
    contacts = [m for m in msgs if m.type_name == "CONTACT"]
    t = np.array([m.timestamp_us for m in contacts], np.int64)
    w = np.array([[m.fx, m.fy, m.fz, m.tx, m.ty, m.tz] for m in contacts], float)
    w[:, :3] *= C.FORCE_LSB_N
    w[:, 3:] *= C.TORQUE_LSB_NM
    return port.emulator, contacts, t, w, decoder.counters


@pytest.fixture(scope="module")
def noisy():
    return _record("sim://ep1_roll")


@pytest.fixture(scope="module")
def quiet(tmp_path_factory):
    zero = "[0.0, 0.0, 0.0]"
    path = _variant(
        tmp_path_factory.mktemp("quiet"), "quiet", noise_force_N=zero, noise_torque_Nm=zero
    )
    return _record(f"sim://{path}")


def _log(emu, tmp_path):
    path = tmp_path / "probes_log.csv"
    emu.motion.write_probe_log(path)
    return read_probe_log(path)


def _hold_uv(log, w):
    """Contact (u, v) on the fingertip for wrenches (..., 6), by the host's localiser."""
    c = sphere_contact(w[..., :3], w[..., 3:], log.centre_m, log.radius_m, axis=(1, 0, 0))
    return fingertip_uv(c.point - log.centre_m, log.radius_m)


def _hold_covariances(emu, log, t_us):
    """Per hold: covariance (2, 2) of the averaged contact (u, v) under the scene's noise."""
    sigma = np.array(emu.scene.sensor["noise_force_N"] + emu.scene.sensor["noise_torque_Nm"])
    times = np.append(log.t_start_us, log.t_end_us[-1])
    out = []
    for tc in times:
        w0 = emu.motion.wrench_at(tc / 1e6)
        n = np.count_nonzero(np.abs(t_us - tc) <= log.half_width_us)
        J = np.empty((2, 6))
        for k, step in enumerate([1e-5] * 3 + [1e-7] * 3):
            d = np.zeros(6)
            d[k] = step
            J[:, k] = (_hold_uv(log, w0 + d) - _hold_uv(log, w0 - d)) / (2 * step)
        out.append(J @ np.diag(sigma**2) @ J.T / n)
    return np.array(out)


def test_the_roll_stays_in_one_contact_and_loses_nothing(noisy):
    emu, contacts, t, _, counters = noisy
    phases = [m.phase for m in contacts]
    assert phases.count(C.PHASE_BEGIN) == 1 and phases.count(C.PHASE_END) == 1
    assert counters.lost_frames == 0 and counters.crc_errors == 0
    holds = emu.motion.holds * 1e6
    assert t[0] < holds[0, 0] and t[-1] > holds[-1, 1]  # the whole EP1 run inside one contact


def test_the_probe_log_round_trips(noisy, tmp_path):
    emu = noisy[0]
    log = _log(emu, tmp_path)
    rows = np.array(emu.motion.probe_log(), float)
    np.testing.assert_array_equal(log.probe, rows[:, 0])
    np.testing.assert_array_equal(log.t_start_us, rows[:, 1])
    np.testing.assert_array_equal(log.t_end_us, rows[:, 2])
    np.testing.assert_array_equal(log.dtheta, rows[:, 3:5])
    assert log.radius_m == 0.01 and list(log.centre_m) == [0.05, 0.0, 0.0]
    assert log.half_width_us == emu.motion.half_width_us()
    # each logged time lies in its hold, with the half-width on both sides
    holds = emu.motion.holds * 1e6
    starts = np.append(log.t_start_us, log.t_end_us[-1])
    assert np.all(starts - log.half_width_us >= holds[:, 0])
    assert np.all(starts + log.half_width_us <= holds[:, 1])
    # the commanded rotations: out and back along +x, -x, +y, -y (fig. 12), eq. 29's frame
    d = 0.5 * np.array([[1, 0], [-1, 0], [-1, 0], [1, 0], [0, 1], [0, -1], [0, -1], [0, 1]])
    np.testing.assert_allclose(log.dtheta, d, atol=1e-15)


def test_noiseless_probes_equal_the_simulators_to_the_chains_resolution(quiet, tmp_path):
    emu, _, t, w, _ = quiet
    log = _log(emu, tmp_path)
    rows, ok = probes_from_frames(log, t, w, threshold=1.0)
    assert ok.all()
    true = emu.motion.true_rows()
    np.testing.assert_allclose(rows[:, :2], true[:, :2], atol=1e-12)  # commanded == net here
    # one ADC count of force (full scale / 0.6 * 2^23) and one wire LSB of torque, per end
    fs = emu.scene.sensor["force_range_N"]
    eps_f, eps_m = fs / (0.6 * 2**23), C.TORQUE_LSB_NM
    lever = 0.05 + 0.01
    bound = 2 * (eps_m + lever * eps_f) / 5.0 / 0.01
    err = np.abs(rows[:, 2:] - true[:, 2:])
    assert err.max() < bound
    assert err.max() > 0  # the chain does quantise


def test_noisy_probes_match_the_simulators_within_the_propagated_noise(noisy, tmp_path):
    emu, _, t, w, _ = noisy
    log = _log(emu, tmp_path)
    rows, ok = probes_from_frames(log, t, w, threshold=1.0)
    assert ok.all() and np.all(np.isfinite(rows))
    cov = _hold_covariances(emu, log, t)
    sd = np.sqrt(np.diagonal(cov[:-1] + cov[1:], axis1=1, axis2=2))  # dp = end - start
    err = rows[:, 2:] - emu.motion.true_rows()[:, 2:]
    assert np.all(np.abs(err) < TOL_SIGMA * sd)
    # the noise is real: the errors are of the predicted size, not far below it
    assert np.sqrt(np.mean((err / sd) ** 2)) > 0.3


def _curvature(log, uv):
    dp = uv[1:] - uv[:-1]
    e = estimate(log.dtheta, dp, log.radius_m)
    return np.array([e.kx, e.ky]), e


def test_curvature_from_the_frames_is_within_noise_of_the_truth(noisy, quiet, tmp_path):
    # noiseless: equal to the estimate from the simulator's exact probes; that one differs
    # from the truth only by eq. 29's constant-curvature approximation (ky varies on the
    # ellipse along y; kx is on a circle and exact)
    emu, _, t, w, _ = quiet
    log = _log(emu, tmp_path)
    truth = emu.motion.true_curvature()
    exact = estimate(emu.motion.true_rows()[:, :2], emu.motion.true_rows()[:, 2:], 0.01)
    assert exact.status == "ok"
    assert abs(exact.kx - truth["kx"]) < 1e-9 * truth["kx"]
    assert 0 < abs(exact.ky - truth["ky"]) < 0.01 * truth["ky"]
    rows, _ = probes_from_frames(log, t, w, threshold=1.0)
    got = estimate(rows[:, :2], rows[:, 2:], log.radius_m)
    np.testing.assert_allclose([got.kx, got.ky], [exact.kx, exact.ky], rtol=2e-4)
    assert got.k1 == pytest.approx(truth["k1"], rel=1e-3)

    # thesis noise: within 5 sigma (propagated from all nine holds) of the exact-probe estimate
    emu, _, t, w, _ = noisy
    log = _log(emu, tmp_path)
    rows, _ = probes_from_frames(log, t, w, threshold=1.0)
    got = estimate(rows[:, :2], rows[:, 2:], log.radius_m)
    assert got.status == "ok"
    cov = _hold_covariances(emu, log, t)
    times = np.append(log.t_start_us, log.t_end_us[-1])
    uv0 = _hold_uv(log, np.array([emu.motion.wrench_at(tc / 1e6) for tc in times]))
    G = np.empty((2, uv0.size))  # d(kx, ky) / d(u, v of each hold), central differences
    for k in range(uv0.size):
        d = np.zeros(uv0.size)
        d[k] = 1e-6
        G[:, k] = (
            _curvature(log, uv0 + d.reshape(uv0.shape))[0]
            - _curvature(log, uv0 - d.reshape(uv0.shape))[0]
        ) / 2e-6
    block = np.zeros((uv0.size, uv0.size))
    for h in range(len(uv0)):
        block[2 * h : 2 * h + 2, 2 * h : 2 * h + 2] = cov[h]
    var = np.diag(G @ block @ G.T)
    sd = np.sqrt(var)
    err = np.array([got.kx, got.ky]) - [exact.kx, exact.ky]
    assert np.all(np.abs(err) < TOL_SIGMA * sd)
    # and so within 25 % of the true curvature (§3.3.3's criterion)
    assert abs(got.kx - truth["kx"]) < 0.25 * truth["kx"]
    assert abs(got.ky - truth["ky"]) < 0.25 * truth["ky"]


def test_a_probe_without_frames_is_reported_not_nan(noisy, tmp_path):
    emu, _, t, w, _ = noisy
    log = _log(emu, tmp_path)
    gap = np.abs(t - log.t_end_us[2]) <= log.half_width_us  # the hold between probes 2 and 3
    rows, ok = probes_from_frames(log, t[~gap], w[~gap], threshold=1.0)
    assert list(np.flatnonzero(~ok)) == [2, 3]
    assert np.all(rows[~ok] == 0.0) and np.all(np.isfinite(rows))
    report = probe_report(log, t[~gap], w[~gap], threshold=1.0)
    assert "no frames" in report[2] and "t_end_us" in report[2] and "t_start_us" in report[3]
    assert report[0].startswith("probe 0 (line 6): ok")  # after # units, probe, hold, end
    # a window averaged from fewer, nearest frames still localises
    rows8, ok8 = probes_from_frames(log, t, w, threshold=1.0, average=8)
    assert ok8.all() and "frames 8+8" in probe_report(log, t, w, 1.0, average=8)[0]


def test_sphere_scene_path_matches_the_closed_form(tmp_path):
    """Independent route: sphere on sphere (eq. 38 integrated) at the holds and mid-roll."""
    from tactile_sim.ep1.rolling import sphere_on_sphere

    path = _variant(
        tmp_path, "sphere", surface='"sphere"', surface_params="{ radius = 0.03 }", mu="0.0"
    )
    motion = build_motion(load_scene(path))
    R1, R2, d = 0.01, 0.03, 0.5
    log = motion.probe_log()
    for k, phi in enumerate(np.radians([0.0, 180.0, 90.0, 270.0])):
        i = 2 * k  # the roll out; its middle in time is half the rotation ((1 - cos)/2)
        t_mid = 0.5 * (motion.holds[i, 1] + motion.holds[i + 1, 0])
        for t_s, frac in ((log[i][2] / 1e6, 1.0), (t_mid, 0.5)):
            wx, wy = frac * d * np.cos(phi), frac * d * np.sin(phi)
            u, v, _ = sphere_on_sphere(R1, R2, 0.0, 0.0, wx, wy)
            wr = motion.wrench_at(t_s)
            # frictionless: F = -fn g(u, v) and the moment about the sensor is offset x F
            g = np.array([np.cos(u) * np.cos(v), -np.cos(u) * np.sin(v), np.sin(u)])
            np.testing.assert_allclose(wr[:3], -5.0 * g, atol=1e-9)
            np.testing.assert_allclose(wr[3:], np.cross([0.05, 0, 0], -5.0 * g), atol=1e-9)
    truth = motion.true_curvature()
    np.testing.assert_allclose([truth["k1"], truth["k2"]], [1 / R2, 1 / R2])


HEAD = "# probe: sphere radius_m=0.01 centre_m=0,0,0"
COLS = "probe,t_start_us,t_end_us,dtheta_x,dtheta_y"


@pytest.mark.parametrize(
    "lines, line, needle",
    [
        ([COLS, "0,1,2,0.5,0"], 1, "# probe:"),
        ([HEAD.replace("0.01", "-1"), COLS, "0,1,2,0.5,0"], 1, "radius_m"),
        ([HEAD.replace("0,0,0", "0,0"), COLS, "0,1,2,0.5,0"], 1, "centre_m"),
        ([HEAD.replace("sphere", "wheel"), COLS, "0,1,2,0.5,0"], 1, "sphere"),
        ([HEAD, "probe,t_start_us,t_end_us,dtheta_x", "0,1,2,0.5"], 2, "dtheta_y"),
        ([HEAD, COLS, "0,1,2,0.5,0", "1,2,3,x,0"], 4, "dtheta_x"),
        ([HEAD, COLS, "0,1,2,0.5,0", "1.5,2,3,0.5,0"], 4, "probe"),
        ([HEAD, COLS, "1e19,1,2,0.5,0"], 3, "'probe': must be a whole number in 0..2147483647"),
        ([HEAD, COLS, "0,1e308,1e308,0.5,0"], 3, "'t_start_us': must be a whole number in 0.."),
        ([HEAD, COLS, "0,1,2,1e300,0"], 3, "'dtheta_x': must be within +-1e+06"),
        ([HEAD.replace("0.01", "1e-320"), COLS, "0,1,2,0.5,0"], 1, "radius_m"),
        (["\ufeff" + HEAD, COLS, "0,1,2,0.5,0", "1,2,3,x,0"], 4, "dtheta_x"),  # Excel's BOM
        ([HEAD, "# hold: half_width_us=abc", COLS, "0,1,2,0.5,0"], 2, "half_width_us"),
        ([HEAD, COLS, "0,5,2,0.5,0"], 3, "t_end_us"),
        ([HEAD + " axis=0,0,1", COLS, "0,1,2,0.5,0"], 1, "pole on the sensor's +x"),
        ([HEAD + " sphere=1", COLS, "0,1,2,0.5,0"], 1, "unknown field 'sphere=1'"),
    ],
)
def test_bad_probe_logs_give_one_line_with_file_and_line(tmp_path, lines, line, needle):
    path = tmp_path / "bad.csv"
    path.write_text("\n".join(lines) + "\n")
    with pytest.raises(InputError) as info:
        read_probe_log(path)
    msg = str(info.value)
    assert msg.startswith(f"{path}:{line}") and "\n" not in msg and needle in msg


def test_bad_roll_scenes_name_the_key(tmp_path):
    for subs, key in (
        ({"surface": '"blob"'}, "surface"),
        ({"dtheta_rad": "-0.5"}, "dtheta_rad"),
        ({"dtheta_rad": "2.0"}, "dtheta_rad"),  # the finger would leave its hemisphere
    ):
        path = _variant(tmp_path, "bad", **subs)
        with pytest.raises(SceneError, match=key):
            build_motion(load_scene(path))
    text = SHIPPED.read_text().replace("mu = 0.2", "mu = 0.2\nspeed = 3")
    (tmp_path / "typo.toml").write_text(text)
    with pytest.raises(SceneError, match="speed"):
        build_motion(load_scene(tmp_path / "typo.toml"))


def test_a_start_outside_the_chart_is_refused_at_once(tmp_path):
    """It never crosses the chart's edge, so the roll used to integrate for a minute."""
    text = SHIPPED.read_text().replace("mu = 0.2", "mu = 0.2\nobject_uv = [58.0, 0.0]")
    (tmp_path / "far.toml").write_text(text)
    start = time.process_time()
    with pytest.raises(SceneError, match=r"\[motion\] object_uv\[0\]: must lie inside the "):
        build_motion(load_scene(tmp_path / "far.toml"))
    assert time.process_time() - start < 2.0


def test_a_noiseless_roll_scene_draws_no_random_numbers(tmp_path):
    zero = "[0.0, 0.0, 0.0]"
    path = _variant(tmp_path, "q", noise_force_N=zero, noise_torque_Nm=zero)
    port = serial.serial_for_url(f"sim://{pathlib.Path(path)}", timeout=0.005)
    assert all(m.rng is None for m in port.emulator.models)


def test_the_probes_csv_is_ready_for_tactile_ep1_estimate(quiet, tmp_path, cli):
    import json

    from tactile.ep1.probes import format_probes

    emu, _, t, w, _ = quiet
    log = _log(emu, tmp_path)
    rows, ok = probes_from_frames(log, t, w, threshold=1.0)
    path = tmp_path / "probes.csv"
    path.write_text(format_probes(rows[ok]))
    code, out, err = cli("ep1", "estimate", path, "--finger-radius", log.radius_m, "--json")
    assert code == 0, err
    got = json.loads(out)
    direct = estimate(rows[:, :2], rows[:, 2:], log.radius_m)
    assert got["n_probes"] == 8 and got["status"] == "ok"
    assert got["kx"] == pytest.approx(direct.kx) and got["ky"] == pytest.approx(direct.ky)
    assert got["k1"] == pytest.approx(emu.motion.true_curvature()["k1"], rel=1e-3)
