"""The bias on the host: a tare at any pose, drift tracked between contacts, never a contact
(tactile.payload.drift, tactile.payload.compensator)."""

import numpy as np
import pytest
from conftest import load_bench
from scipy.spatial.transform import Rotation

from tactile.payload import BiasTracker, Compensator, Orientations, Tool
from tactile.payload.apply import ANY
from tactile.payload.drift import MAX_RATE_N_S, TAU_S

synth = load_bench("payload_synth")
RATE = 500
TOOL = Tool(0.03, [0.02, 0.0, 0.0])
GATE = {"enter_threshold_N": 1.0, "exit_threshold_N": 0.8, "debounce": 3, "gate": "3d",
        "streams": ["samples"]}  # fmt: skip
DRIFT = np.r_[np.array([0.6, -0.48, 0.64]) * 0.02 / 60, 0, 0, 0]  # 0.02 N/min


def held(rpy=(30, -60, 0), end_s=400.0):
    """One pose held throughout: the orientations of a log with one window."""
    rot = Rotation.from_euler("xyz", [rpy], degrees=True)
    return Orientations({ANY: ([0], [round(end_s * 1e6)], rot)}), rot.as_matrix()[0]


def stream(duration_s, press, R, bias=(0.05, -0.03, 0.02, 0.001, 0, 0), drift=DRIFT, sd=0.01):
    """(t_s, readings, contact wrench) of a sensor carrying TOOL at R; ``press(t)`` -> (n,)
    normal force (N along the sensor's +z)."""
    t = np.arange(0.0, duration_s, 1.0 / RATE)
    contact = np.zeros((len(t), 6))
    contact[:, 2] = press(t)
    R = np.broadcast_to(R, (len(t), 3, 3))
    sd = np.r_[[sd] * 3, [sd / 20] * 3]
    return t, synth.readings(t, R, TOOL.mass_kg, TOOL.com_m, bias, drift, sd, contact), contact


def run(comp, t, W):
    n = len(t)
    comp.prime(np.zeros(n, int), np.ones(n, bool), np.rint(t * 1e6), W)
    return comp.arrays(np.zeros(n, int), np.ones(n, bool), np.rint(t * 1e6), W,
                       np.full(n, -1), np.zeros(n))  # fmt: skip


def ramp_press(starts, length_s, force=5.0, ramp_s=0.1):
    def f(t):
        out = np.zeros_like(t)
        for a in starts:
            up = np.clip((t - a) / ramp_s, 0, 1) * np.clip((a + length_s - t) / ramp_s, 0, 1)
            out = np.maximum(out, force * up)
        return out

    return f


def test_the_host_tares_at_a_tilted_pose():
    """The bias is the reading less the tool's weight there: compensated readings at the
    same pose are zero and a press reads as itself."""
    orient, R = held()
    t, W, contact = stream(8.0, ramp_press([4.0], 2.0), R, drift=0.0)
    comp = Compensator(TOOL, orient, GATE)
    W2, phase, cid = run(comp, t, W)
    rep = comp.report()[0]
    assert rep["bias_from"] == "the host's tare" and rep["contacts"] == 1
    assert np.allclose(rep["bias"], [0.05, -0.03, 0.02, 0.001, 0, 0], atol=3e-3)
    pressing = (t > 4.5) & (t < 5.5)
    assert np.mean(W2[pressing, 2]) == pytest.approx(5.0, abs=5e-3)
    assert np.abs(np.mean(W2[t < 3.5, :3], axis=0)).max() < 3e-3
    # the weight alone is 0.29 N: without the tool the free readings would be off by it
    assert np.linalg.norm(np.mean(W[t < 3.5, :3], axis=0) - rep["bias"][:3]) > 0.25


def test_a_long_press_is_not_eaten():
    """A 60 s press with the gauges drifting: the bias does not move while it lasts, so the
    press reads 5 N to its end and stays one contact."""
    orient, R = held()
    t, W, contact = stream(80.0, ramp_press([10.0], 60.0), R)
    comp = Compensator(TOOL, orient, GATE)
    W2, phase, cid = run(comp, t, W)
    rep = comp.report()[0]
    assert rep["contacts"] == 1 and np.all(phase[(t > 10.2) & (t < 69.8)] >= 0)
    late = (t > 65) & (t < 69.5)
    drifted = DRIFT[2] * 60  # what the gauges moved during the press: 0.013 N
    assert np.mean(W2[late, 2]) == pytest.approx(5.0 + drifted, abs=4e-3)
    for entry in rep["rebias"][1:]:  # no move while in contact (a guard after its end)
        assert entry["to_s"] < 10.0 or entry["from_s"] > 70.0, entry


def test_drift_is_tracked_between_contacts():
    """5 min of 0.02 N/min drift with a 2 s press every 3 s: each press reads its force
    within a few mN with tracking; 0.1 N off by the end without."""
    orient, R = held()
    starts = np.arange(3.0, 298.0, 3.0)
    t, W, contact = stream(300.0, ramp_press(starts, 2.0), R)
    err = {}
    for track in (True, False):
        W2, _, _ = run(Compensator(TOOL, orient, GATE, track=track), t, W)
        last = [(t > a + 0.5) & (t < a + 1.5) for a in starts[-10:]]
        err[track] = np.array([np.mean(W2[m, :3] - contact[m, :3], axis=0) for m in last])
    assert np.abs(err[True]).max() < 5e-3
    assert np.linalg.norm(err[False], axis=1).min() > 0.08


def test_the_bias_moves_no_faster_than_its_bound():
    """A steady load under the gate (0.3 N) is absorbed at the bound, not at 1/tau."""
    tracker = BiasTracker(np.zeros(6))
    t = np.arange(0.0, 10.0, 1.0 / RATE)
    x = np.zeros((len(t), 6))
    x[:, 0] = 0.3
    tracker.add(t, x, np.ones(len(t), bool))
    tracker.flush()
    moved = tracker.bias[0]
    assert 0.8 * MAX_RATE_N_S * 10 < moved <= MAX_RATE_N_S * 10 + 1e-9
    assert 0.3 * (1 - np.exp(-10 / TAU_S)) > 5 * moved  # the filter alone would take most
    assert len(tracker.log) == 1 and tracker.log[0]["moves"] > 90


def test_no_tare_without_a_steady_stretch_and_the_tools_bias_is_used():
    orient, R = held()
    t = np.arange(0.0, 2.0, 1.0 / RATE)
    W = synth.readings(t, np.broadcast_to(R, (len(t), 3, 3)), 0.03, TOOL.com_m, 0.0)
    W[:, 0] += 2.0 * t  # never steady
    comp = Compensator(TOOL, orient, GATE)
    run(comp, t, W)
    assert comp.report()[0]["bias_from"] == "the tool's identified bias"
