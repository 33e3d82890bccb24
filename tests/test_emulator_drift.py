"""The gauges' drift beyond the linear one (docs/emulator.md): a seeded random walk that is a
function of the instant alone, a temperature effect from keyframes, each per gauge, and
neither touching the noise's random stream."""

import numpy as np
import pytest

from tactile.board.stream_decoder import StreamDecoder
from tactile_protocol import constants as C
from tactile_sim.emulator import load_scene
from tactile_sim.emulator.device import EmulatedBoard
from tactile_sim.emulator.ft_model import sensitivity_matrix
from tactile_sim.emulator.gauge_drift import BLOCK, STEP_S, GaugeDrift

PRESS = """
[scene]
seed = {seed}
[board]
rate_hz = 500
streams = ["samples"]
[sensor]
bias_counts = 0.0
noise_force_N = {noise}
{more}
[motion]
kind = "press"
keyframes = [[0.0, 0.5, -0.2, 1.0, 0.01, 0.0, -0.02]]
"""


def _board(tmp_path, more="", seed=3, noise="[0.0556, 0.0556, 0.1112]"):
    path = tmp_path / f"s{abs(hash((more, seed, noise)))}.toml"
    path.write_text(PRESS.format(seed=seed, noise=noise, more=more))
    return EmulatedBoard(load_scene(path), boot_id=1, core="python")


def test_the_walk_is_a_function_of_the_instant_not_of_the_asking():
    times = np.linspace(0, 3 * BLOCK * STEP_S * 1e6, 500).astype(np.int64)
    forward = [GaugeDrift(20.0, [], 0.0, seed=5).counts(int(t)) for t in times]
    one = GaugeDrift(20.0, [], 0.0, seed=5)
    backward = [one.counts(int(t)) for t in times[::-1]][::-1]
    shuffled = GaugeDrift(20.0, [], 0.0, seed=5)
    order = np.random.default_rng(0).permutation(len(times))
    mixed = {int(k): shuffled.counts(int(times[k])) for k in order}
    np.testing.assert_array_equal(forward, backward)
    np.testing.assert_array_equal(forward, [mixed[k] for k in range(len(times))])
    # continuous across a block's edge, zero at the start, per gauge and per sensor apart
    edge = BLOCK * STEP_S * 1e6
    a, b = one.counts(int(edge) - 1), one.counts(int(edge) + 1)
    assert np.all(np.abs(a - b) < 1.0) and not np.any(one.counts(0))
    assert len(set(np.round(forward[-1], 9))) == 6
    other = GaugeDrift(20.0, [], 0.0, seed=5, sensor=1).counts(int(times[-1]))
    assert not np.any(other == forward[-1])
    assert not np.any(GaugeDrift(20.0, [], 0.0, seed=6).counts(int(times[-1])) == forward[-1])


def test_the_walk_spreads_as_s_squared_t():
    s, t1, t2 = 20.0, 30.0, 60.0
    walks = [GaugeDrift(s, [], 0.0, seed=k) for k in range(300)]
    w1 = np.array([w.counts(int(t1 * 1e6)) for w in walks]).ravel()
    w2 = np.array([w.counts(int(t2 * 1e6)) for w in walks]).ravel()
    assert np.var(w2) / (s * s * t2) == pytest.approx(1.0, abs=0.12)  # 1800 gauges: sd 3 %
    assert np.var(w1) / (s * s * t1) == pytest.approx(1.0, abs=0.12)
    assert abs(np.corrcoef(w1, w2 - w1)[0, 1]) < 0.1  # independent steps


def test_the_temperature_effect_follows_the_keyframes_per_gauge():
    k = np.array([40.0, -25.0, 10.0, 0.0, 30.0, -15.0])
    drift = GaugeDrift(0.0, [[1.0, 25.0], [11.0, 35.0], [21.0, 30.0]], k.tolist())
    for t_s, dT in ((0.0, 0.0), (1.0, 0.0), (6.0, 5.0), (11.0, 10.0), (16.0, 7.5), (99.0, 5.0)):
        np.testing.assert_allclose(drift.counts(int(t_s * 1e6)), k * dT, atol=1e-9)
    assert GaugeDrift.from_sensor(
        {"bias_walk_counts_per_sqrt_s": 0.0, "temperature_C": [[0.0, 20.0]],
         "bias_counts_per_C": 0.0}, 0, 0) is None  # fmt: skip


def test_drift_adds_to_the_gauges_and_leaves_the_noise_as_it_was(tmp_path):
    plain = _board(tmp_path)
    more = "bias_walk_counts_per_sqrt_s = [5.0, 10.0, 15.0, 20.0, 25.0, 30.0]\n"
    more += "temperature_C = [[0.0, 20.0], [2.0, 24.0]]\nbias_counts_per_C = 12.5\n"
    more += "drift_counts_per_s = [1.0, -2.0, 3.0, -4.0, 5.0, -6.0]\n"
    drifting = _board(tmp_path, more)
    d = drifting.models[0].more_drift
    linear = np.array([1.0, -2.0, 3.0, -4.0, 5.0, -6.0])
    for t in range(0, 3_000_000, 12_345):
        got = drifting.models[0].gauges(t) - plain.models[0].gauges(t)
        np.testing.assert_allclose(got, linear * t * 1e-6 + d.counts(t), atol=1e-6)
    assert plain.models[0].more_drift is None


def test_a_temperature_step_reaches_the_decoded_wrench(tmp_path):
    """Through converters, firmware and wire: +10 degC at 0.2 N per degree of force along z
    (per gauge, A [0, 0, 0.2, 0, 0, 0] counts/degC) moves fz by 2 N and nothing else."""
    per_c = sensitivity_matrix(50.0, 2.0) @ [0.0, 0.0, 0.2, 0.0, 0.0, 0.0]
    more = f"temperature_C = [[0.2, 20.0], [0.6, 30.0]]\nbias_counts_per_C = {per_c.tolist()}"
    board = _board(tmp_path, more, noise="[0.0, 0.0, 0.0]")
    board.host_opened()
    decoder, msgs = StreamDecoder(), []
    while board.t_us < 1_000_000:
        board.run_until(board.t_us + 10_000)
        msgs += decoder.feed(board.read_host())
    samples = [m for m in msgs if m.type_name == "SAMPLE"]
    t = np.array([m.timestamp_us for m in samples])
    w = np.array([[m.fx, m.fy, m.fz, m.tx, m.ty, m.tz] for m in samples], float) * 1e-6
    before, after = w[t < 150_000].mean(axis=0), w[t > 700_000].mean(axis=0)
    np.testing.assert_allclose(after - before, [0, 0, 2.0, 0, 0, 0], atol=5e-5)
    assert C.FORCE_LSB_N == C.TORQUE_LSB_NM == 1e-6  # (the scaling above)


def test_the_shipped_drift_is_two_hundredths_of_a_newton_a_minute():
    scene = load_scene("ep1_roll_weighted")
    d = np.array(scene.sensor["drift_counts_per_s"])
    rate = np.linalg.solve(sensitivity_matrix(50.0, 2.0), d) * 60.0  # N/min, N*m/min
    assert np.linalg.norm(rate[:3]) == pytest.approx(0.02, rel=0.01)
    assert np.linalg.norm(rate[3:]) < 1e-6
    for name in ("ep2_sweep_wrist", "payload_poses"):
        assert load_scene(name).sensor["drift_counts_per_s"] == list(d)
