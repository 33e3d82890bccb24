"""``tactile.recording.timebase``: the board's clock segment by segment, unwrapped, mapped to host
time."""

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from tactile.board.stream_decoder import Hello, Invalid, Sample
from tactile.errors import DataError
from tactile.recording.timebase import (
    WRAP,
    BoardClock,
    RecordingClock,
    mapping_from_meta,
    recorded_times,
    segment_meta,
)


def hello(t, boot):
    return Hello(
        0, t, 0, 1, 0, 3, b"X", 1, 1000, 0, 0, 0, 0, 1000, 1, 1, 1, 0, boot, 0, 0, 0, 0, bytes(8)
    )


def sample(t, seq=1):
    return Sample(seq, t % WRAP, 0, 0, 0, 0, 0, 0, 0, 0)


def test_wraps_are_unwrapped_and_a_late_frame_stays_before_its_successor():
    clock = BoardClock()
    raw = [WRAP - 3000, WRAP - 1000, 500, WRAP - 2000, 2500]  # the 4th comes late
    got = [clock.stamp(sample(t)) for t in raw]
    assert [g[0] for g in got] == [0] * 5
    assert [g[1] for g in got] == [WRAP - 3000, WRAP - 1000, WRAP + 500, WRAP - 2000, WRAP + 2500]
    assert clock.segments[0].last_us == WRAP + 2500


def test_a_new_boot_or_a_hello_whose_clock_went_back_starts_a_segment():
    clock = BoardClock()
    stream = [hello(10, 7), sample(2000), hello(5000, 7), sample(6000), hello(40, 8)]
    stream += [sample(900), hello(20, 8), sample(100)]
    got = [clock.stamp(m) for m in stream]
    assert [g[0] for g in got] == [0, 0, 0, 0, 1, 1, 2, 2]
    assert [s.boot_id for s in clock.segments] == [7, 8, 8]
    assert got[-1][1] == 100 and clock.stamp(Invalid(3, 99, "SAMPLE", "bad")) is None


@given(st.lists(st.integers(0, 2**31 - 1), min_size=1, max_size=50), st.integers(0, WRAP - 1))
def test_forward_steps_below_half_the_wrap_always_unwrap_exactly(steps, start):
    clock, t = BoardClock(), start
    for step in steps:
        t += step
        assert clock.stamp(sample(t))[1] == t


def test_host_times_of_rows_follow_their_segment_and_wraps():
    rc = RecordingClock(rows_offset=10, utc_minus_mono=1_700_000_000.0)
    board = [WRAP - 200_000, WRAP - 100_000, 0, 100_000]  # wraps after the second row
    msgs = [hello(WRAP - 300_000, 5)] + [sample(t) for t in board]
    arrive = [100.0 + 0.1 * k + 0.0002 for k in range(5)]  # board s 0.1 apart, 0.2 ms late
    host = rc.take(msgs, arrive)
    assert host[0] is None and rc.rows == 4
    seg = rc.board.segments[0]
    assert (seg.first_row, seg.rows, seg.row_wraps) == (10, 4, [(0, 0), (2, 1)])
    rc.refit()
    mono, utc = rc.host_of(np.arange(4), np.array(board, dtype=np.int64))
    np.testing.assert_allclose(mono, 100.1002 + 0.1 * np.arange(4), atol=1e-6)
    np.testing.assert_allclose(utc - mono, 1_700_000_000.0)
    entry = segment_meta(seg, rc.utc_minus_mono)
    m = mapping_from_meta(entry)
    assert entry["usable"] and entry["rows"] == 4 and entry["boot_id"] == 5
    np.testing.assert_allclose(m.host(WRAP + 100_000, "monotonic"), mono[-1], atol=1e-6)
    np.testing.assert_allclose(m.host(WRAP + 100_000, "utc"), utc[-1], atol=1e-6)


def test_a_clock_that_outruns_the_host_is_not_a_time_base():
    rc = RecordingClock()
    msgs = [sample(k * 100_000) for k in range(30)]  # 0.1 board s per 0.01 host s
    rc.take(msgs, [5.0 + 0.01 * k for k in range(30)])
    rc.refit()
    (entry,) = rc.meta()["segments"]
    assert not entry["usable"] and "10 x as fast" in entry["why"]
    mono, _ = rc.host_of(np.arange(30), np.array([m.timestamp_us for m in msgs]))
    assert np.all(np.isnan(mono)) and mapping_from_meta(entry) is None


def test_a_simulated_clock_paced_like_the_wall_clock_is_still_no_time_base():
    # a loaded machine can run sim:// at about real time: the port's word decides, not the fit
    rc = RecordingClock()
    rc.board.simulated = True
    msgs = [sample(k * 100_000) for k in range(30)]
    rc.take(msgs, [5.0 + 0.1 * k for k in range(30)])  # 0.1 board s per 0.1 host s
    rc.refit()
    (entry,) = rc.meta()["segments"]
    assert entry["drift_ppm"] == 0 and not entry["usable"]
    assert entry["why"].startswith("simulated time: board time only")
    mono, _ = rc.host_of(np.arange(30), np.array([m.timestamp_us for m in msgs]))
    assert np.all(np.isnan(mono)) and mapping_from_meta(entry) is None


def test_a_recording_without_a_time_base_cannot_join_a_host_clock_log():
    with pytest.raises(DataError, match="no time base .recorded by an older tactile"):
        recorded_times(b"", {"sessions": [{"bytes": 0}]}, "utc", "run1")


def _summary(board_step_us, host_step_s, n):
    """``record``'s time base line for ``n`` samples a board step and a host step apart."""
    from tactile.cli.cmd_record import time_summary

    rc = RecordingClock()
    arrivals = [5.0 + host_step_s * k for k in range(n)]
    rc.take([sample(k * board_step_us) for k in range(n)], arrivals)
    rc.refit()
    return time_summary(rc.meta())


def test_fast_mode_says_board_time_only_not_that_something_is_wrong():
    line = _summary(100_000, 0.035, 30)  # the board's clock 2.86 x the host's
    assert line == (
        "time base: fast mode: board time only (the board's clock ran 2.86 x as fast as the"
        " host's, as an emulator's --fast does)"
    )
    assert "not usable" not in _summary(100_000, 0.01, 30)  # (10 x)
    assert _summary(100_000, 0.3, 30).startswith("time base: not usable: the board clock ran")


def test_a_fit_of_one_bin_claims_no_drift():
    """Frames within one bin (a run that recorded nothing): no "drift +0.0 ppm, 1 bins"."""
    assert _summary(1_000, 0.001, 2) == (
        "time base: an offset only (2 frames, too few to measure the board clock's drift)"
    )
    assert "ppm, " in _summary(100_000, 0.1, 30)  # a real fit says its drift
