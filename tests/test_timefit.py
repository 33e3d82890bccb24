"""``tactile.recording.timefit``: the board -> host line under frame arrivals (issue 14, part 2)."""

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from tactile.recording.timefit import TAU, BinMinima, fit


def _bins(b, h, **kw):
    bins = BinMinima(**kw)
    for x, y in zip(b, h):
        bins.add(float(x), float(y))
    return bins


def _stream(seconds, rate_hz, drift_ppm, delay, seed=0, offset=1234.5):
    """Board stamps of a stream and their arrival times with ``delay(rng, n)`` >= 0."""
    rng = np.random.default_rng(seed)
    b = np.arange(0.0, seconds, 1.0 / rate_hz) + 0.013
    true = offset + b * (1.0 + drift_ppm * 1e-6)
    return b, true, true + delay(rng, len(b))


offsets = st.floats(-1e6, 1e9)
drifts = st.floats(-500.0, 500.0)  # ppm: crystals are tens of ppm apart


@given(offsets, drifts, st.floats(0.0, 1e4), st.integers(2, 400))
def test_points_on_a_line_give_that_line(offset, drift, start, n):
    b = start + np.linspace(0.0, 30.0, n)
    rate = 1.0 + drift * 1e-6
    f = fit(_bins(b, offset + rate * b))
    ulp = np.spacing(max(1.0, abs(offset) + start))  # the host times' own rounding
    assert f.drift_ppm == pytest.approx(drift, abs=1e-6 + 1e6 * 8 * ulp / 30.0)
    assert np.max(np.abs(f.to_host(b) - (offset + rate * b))) < 8 * ulp + 1e-12
    assert abs(f.floor_s) < 8 * ulp + 1e-12 and abs(f.delay_max_s) < 8 * ulp + 1e-12


@given(st.lists(st.floats(0.0, 0.01), min_size=2, max_size=15), drifts)
def test_with_fewer_bins_than_one_over_tau_no_minimum_lies_below(delays, drift):
    """Under 20 bins the 5% line is the lower envelope: every bin minimum on or above it."""
    b = np.arange(len(delays)) * 0.5
    h = 7.0 + b * (1.0 + drift * 1e-6) + np.array(delays)
    f = fit(_bins(b, h))
    assert np.all(h - f.to_host(b) >= -1e-9)
    assert np.sum(np.abs(h - f.to_host(b)) < 1e-9) >= 1  # it rests on the envelope
    # ... and is an optimum: no line through two minima (where an optimum always lies) has a
    # smaller 5% loss.  When it is not unique (e.g. delays d, d, 0, d, d: every slope in
    # [-2d, 2d] through the middle one) the fit may sit inside the optimal face, on one point.
    lag = h - b
    loss = lambda line: float(np.sum(np.maximum(TAU * (lag - line), (TAU - 1) * (lag - line))))  # noqa: E731
    pairs = [(i, j) for i in range(len(b)) for j in range(i + 1, len(b))]
    best = min(loss(lag[i] + (lag[j] - lag[i]) / (b[j] - b[i]) * (b - b[i])) for i, j in pairs)
    assert loss(f.to_host(b) - b) <= best + 1e-9


@given(st.lists(st.floats(0.0, 0.02), min_size=3, max_size=60), st.floats(-100.0, 100.0))
def test_a_delay_never_makes_the_host_time_late_beyond_it(delays, drift):
    """Points above the true line by at most D: at the bins' minima the fit is within
    [-D, D] of the truth (it rests on minima that are)."""
    b = np.arange(len(delays)) * 0.3
    true = 50.0 + b * (1.0 + drift * 1e-6)
    d = np.array(delays)
    f = fit(_bins(b, true + d))
    assert np.all(np.abs(f.to_host(b) - true) <= d.max() + 1e-9)


@given(st.permutations(list(range(40))), st.floats(-50.0, 50.0), st.floats(-1e3, 1e3))
def test_order_and_a_shift_of_both_clocks_do_not_matter(order, shift_b, shift_h):
    b, _, h = _stream(4.0, 10, 30.0, lambda r, n: r.exponential(1e-3, n))
    ref = fit(_bins(b, h))
    i = np.array(order)
    moved = fit(_bins(b[i] + shift_b, h[i] + shift_h))
    assert moved.drift_ppm == pytest.approx(ref.drift_ppm, abs=1e-6)
    assert np.allclose(moved.to_host(b + shift_b) - shift_h, ref.to_host(b), atol=1e-9)


def test_50_ppm_and_5_ms_of_usb_jitter_leave_microseconds():
    """The issue's case at 500 Hz for a minute: far under one sample period (2 ms)."""
    b, true, h = _stream(60.0, 500, 50.0, lambda r, n: r.uniform(0.0, 5e-3, n))
    f = fit(_bins(b, h))
    err = np.abs(f.to_host(b) - true)
    assert err.max() < 0.1e-3  # 0.1 ms
    assert f.drift_ppm == pytest.approx(50.0, abs=2.0)
    assert f.delay_mean_s == pytest.approx(2.5e-3, abs=0.2e-3)
    assert 4.5e-3 < f.delay_max_s < 5.2e-3


def test_a_few_early_outliers_do_not_drag_the_line():
    """A host clock step of -30 ms for 3 bins in 200: the 5% line ignores them, where a
    lower envelope would follow them."""
    b, true, h = _stream(20.0, 200, -20.0, lambda r, n: r.exponential(1e-3, n))
    early = (b > 10.0) & (b < 10.3)
    h = np.where(early, h - 0.030, h)
    f = fit(_bins(b, h))
    assert np.abs(f.to_host(b) - true).max() < 0.2e-3
    envelope = fit(_bins(b, h), tau=1e-6)
    assert np.abs(envelope.to_host(b) - true).max() > 5e-3


def test_bins_merge_beyond_the_limit_and_keep_every_frame():
    b, true, h = _stream(100.0, 100, 50.0, lambda r, n: r.uniform(0.0, 5e-3, n))
    bins = _bins(b, h, bin_s=0.1, max_bins=64)
    assert len(bins) <= 64 and bins.width >= 100.0 / 64
    f = fit(bins)
    assert f.frames == len(b)
    assert np.abs(f.to_host(b) - true).max() < 0.5e-3


def test_one_bin_is_an_offset_and_no_bin_is_no_fit():
    assert fit(BinMinima()) is None
    f = fit(_bins([1.0, 1.01, 1.02], [11.004, 11.011, 11.03]))
    assert f.rate == 1.0 and f.bins == 1
    assert float(f.to_host(1.01)) == pytest.approx(11.011, abs=1e-12)  # the least lag
    assert float(f.to_board(f.to_host(3.0))) == pytest.approx(3.0)


def test_bad_parameters_are_refused():
    with pytest.raises(ValueError):
        BinMinima(bin_s=0.0)
    with pytest.raises(ValueError):
        fit(_bins([0.0, 1.0], [0.0, 1.0]), tau=0.7)
