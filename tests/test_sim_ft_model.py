"""The transducer model's per-instant cache: the same gauges and noise stream as computed fresh."""

import numpy as np

from tactile_sim.emulator.ft_model import FTModel

SENSOR = {
    "force_range_N": 50.0,
    "torque_range_Nm": 2.0,
    "bias_counts": [100.0, -250.5, 0.0, 7.0, 1e4, -3.25],
    "drift_counts_per_s": 12.5,
    "noise_force_N": [0.0556, 0.0556, 0.111],
    "noise_torque_Nm": [0.001, 0.002, 0.0],
}


def wrench(t_s):
    return np.array([3.0 * np.sin(7 * t_s), 2.0, -1.0 + t_s, 0.01, -0.02 * t_s, 0.003])


def reference(model, seed, times):
    """g = A w + bias + drift t + noise, drawn in order from a fresh generator (ch. 5 model)."""
    rng = np.random.default_rng(seed)
    out = []
    for t_us in times:
        w = wrench(t_us * 1e-6) + rng.normal(0.0, 1.0, 6) * model.sigma
        out.append(model.A @ w + model.bias + model.drift * t_us * 1e-6)
    return out


def test_gauges_are_computed_once_per_instant_with_the_seeded_noise():
    # (more instants than one block of noise drawn ahead)
    model = FTModel(SENSOR, wrench, seed=42)
    times = [0, 500.0, 1000.0, 1500.0, 2500.0, 2500.0, 4000.0] + [500.0 * k for k in range(9, 700)]
    want = reference(model, 42, sorted(set(times)))
    got = {}
    for t in times:
        values = model.gauge_values(t)
        assert values == model.gauge_values(t) == model.gauges(t).tolist()  # cached: no new draw
        got[t] = values
    for t, w in zip(sorted(set(times)), want):
        assert np.array_equal(np.array(got[t]), w)  # bit for bit, not approximately


def test_a_noiseless_model_draws_nothing():
    quiet = {"noise_force_N": [0.0] * 3, "noise_torque_Nm": [0.0] * 3, "drift_counts_per_s": 0.0}
    sensor = dict(SENSOR, **quiet)
    model = FTModel(sensor, wrench)
    assert model.rng is None
    for t in (0.0, 123.0, 1e6):
        assert model.gauge_values(t) == (model.A @ wrench(t * 1e-6) + model.bias).tolist()
