"""Faults through a mocked bus: the right STATUS, retry with backoff, recovery, no death."""

import errno

import pytest
from fw_rig import Rig, name

from tactile_fw.ads122c04 import ADS122C04
from tactile_fw.board import BACKOFF_MAX_US, BACKOFF_MIN_US
from tactile_protocol.constants import (
    CFG_STREAM_SAMPLES,
    CMD_START,
    FAULT_DRDY_STUCK,
    FAULT_I2C,
    FAULT_NO_CALIBRATION,
    FAULT_OVERRUN,
    FAULT_RECOVERED,
    FAULT_SATURATION,
    FAULT_TX_DROPPED,
    FLAG_LATE,
    SENSOR_ALL,
)

STATUS_FIELDS = (
    "faults",
    "sensor",
    "last_error",
    "i2c_errors",
    "drdy_timeouts",
    "saturations",
    "overruns",
    "tx_dropped",
    "samples",
)


def statuses(frames):
    return [dict(zip(STATUS_FIELDS, f[3], strict=True)) for f in frames if name(f) == "STATUS"]


def samples(frames, sensor=0):
    return [f for f in frames if name(f) == "SAMPLE" and f[3][0] == sensor]


def streaming_rig(n=1):
    rig = Rig(n)
    rig.board.boot()
    rig.config(rate=1000, flags=CFG_STREAM_SAMPLES)
    rig.command(CMD_START)
    rig.run(10_000)
    rig.frames()
    assert [s["faults"] for s in statuses(rig.log)] == [FAULT_NO_CALIBRATION] * n
    return rig


def failing_window(rig, real, t0, t1, err):
    """A bus method that raises OSError(err) while t0 <= simulated time < t1."""

    def call(*args, **kw):
        if t0 <= rig.clock.t_us < t1:
            raise OSError(err)
        return real(*args, **kw)

    return call


@pytest.mark.parametrize("err", [errno.ENODEV, errno.ETIMEDOUT, errno.EIO])
def test_i2c_error_reports_retries_and_recovers(mocker, err):
    rig = streaming_rig()
    bus = rig.buses[0]
    t0 = rig.clock.t_us
    mocker.patch.object(
        bus,
        "readfrom_mem_into",
        side_effect=failing_window(rig, bus.readfrom_mem_into, t0, t0 + 20_000, err),
    )
    rig.run(60_000)
    frames = rig.frames()
    st = statuses(frames)
    assert st[0]["faults"] == FAULT_I2C and st[0]["sensor"] == 0
    assert st[0]["last_error"] == err and st[0]["i2c_errors"] == 1
    assert st[-1]["faults"] == FAULT_I2C | FAULT_RECOVERED
    assert len(st) == 2  # one on entry, one on recovery: retries do not flood the link
    # retries at +1, +2 (doubling) ... ms: 1 + 2 + 4 + 8 + 16 > 20 ms -> 5 failed retries
    assert rig.board.i2c_errors == st[-1]["i2c_errors"] == 1 + 4
    during = [f for f in samples(frames) if f[2] < t0 + 20_000]
    after = [f[2] for f in samples(frames)]
    assert not during and min(after) <= t0 + 33_000  # retry at +31 ms succeeds
    assert rig.board.backoff_us[0] == BACKOFF_MIN_US  # reset after recovery


def test_backoff_doubles_up_to_the_cap(mocker):
    rig = streaming_rig()
    rig.buses[0].nack.update(range(0x40, 0x50))
    real_init = rig.sensors[0].init
    t0 = rig.clock.t_us
    times = []

    def init():
        times.append(rig.clock.t_us - t0)
        real_init()

    mocker.patch.object(rig.sensors[0], "init", side_effect=init)
    rig.run(5_000_000, step=500)
    gaps = [b - a for a, b in zip(times, times[1:])]
    assert times[0] == pytest.approx(BACKOFF_MIN_US, abs=500)
    expected = [min(BACKOFF_MIN_US << (k + 1), BACKOFF_MAX_US) for k in range(len(gaps))]
    assert gaps == pytest.approx(expected, abs=500)
    assert gaps[-1] == BACKOFF_MAX_US
    assert len(statuses(rig.frames())) <= 3  # entry (+ periodic), not one per retry


def test_stuck_data_ready(mocker):
    rig = streaming_rig()
    stuck = mocker.patch.object(ADS122C04, "ready", return_value=False)
    rig.run(10_000)
    st = statuses(rig.frames())
    assert st[0]["faults"] == FAULT_DRDY_STUCK and st[0]["drdy_timeouts"] == 1
    assert rig.board.state[0] == 1
    mocker.stop(stuck)
    rig.run(30_000)
    frames = rig.frames()
    st = statuses(frames)
    assert st[-1]["faults"] == FAULT_DRDY_STUCK | FAULT_RECOVERED
    assert samples(frames)


def test_stuck_data_ready_in_the_converter_model():
    rig = streaming_rig()
    rig.models[0][3].stuck_drdy = True
    rig.run(10_000)
    st = statuses(rig.frames())
    assert [s["faults"] for s in st] == [FAULT_DRDY_STUCK]
    rig.models[0][3].stuck_drdy = False
    rig.run(10_000)
    assert statuses(rig.frames())[-1]["faults"] == FAULT_DRDY_STUCK | FAULT_RECOVERED


def test_saturation_flags_samples_and_reports_entry_and_exit():
    rig = streaming_rig()
    rig.models[0][2].saturate = 1
    rig.run(5_000)
    frames = rig.frames()
    st = statuses(frames)
    assert st[0]["faults"] == FAULT_SATURATION and st[0]["saturations"] == 1
    sat = [f for f in samples(frames) if f[3][1] & 0x3F]
    assert sat and all(f[3][1] & 0x3F == 1 << 2 for f in sat)
    rig.models[0][2].saturate = 0
    rig.run(5_000)
    frames = rig.frames()
    assert statuses(frames)[-1]["faults"] == FAULT_SATURATION | FAULT_RECOVERED
    assert samples(frames)[-1][3][1] & 0x3F == 0


def test_host_not_reading_drops_whole_frames_and_counts_them():
    rig = streaming_rig()
    rig.link.paused = True
    rig.run(1_500_000, step=100)
    rig.link.paused = False
    rig.run(1_100_000, step=100)
    frames = rig.frames()
    dropped = rig.board.tx.dropped
    assert dropped > 1000
    seqs = [f[1] for f in frames]
    lost = sum(b - a - 1 for a, b in zip(seqs, seqs[1:]))
    assert lost == dropped  # every dropped frame is a sequence gap at the host
    st = [s for s in statuses(frames) if s["faults"] & FAULT_TX_DROPPED]
    assert st and st[-1]["tx_dropped"] == dropped and st[-1]["sensor"] == SENSOR_ALL


def test_overrun_marks_the_late_sample_and_is_counted():
    rig = streaming_rig()
    rig.board.poll()
    until = rig.board.sched.until_due(rig.clock.ticks_us())
    rig.clock.advance(until + 5_500)  # the loop stalls: 5.5 periods past a deadline
    rig.run(1_100_000)
    frames = rig.frames()
    late = [f for f in samples(frames) if f[3][1] & FLAG_LATE]
    assert len(late) == 1
    assert rig.board.sched.overruns == 5
    st = [s for s in statuses(frames) if s["faults"] & FAULT_OVERRUN]
    assert st and st[0]["overruns"] == 5


def test_fault_on_one_sensor_leaves_the_other_streaming():
    rig = streaming_rig(n=2)
    rig.buses[1].nack.update(range(0x40, 0x50))  # sensor 1 is alone on bus 1
    rig.run(50_000)
    frames = rig.frames()
    assert len(samples(frames, 0)) >= 49 and not samples(frames, 1)
    assert statuses(frames)[0]["sensor"] == 1


def test_fault_at_boot_comes_after_hello():
    rig = Rig()
    rig.buses[0].nack.add(0x42)
    rig.board.boot()
    frames = rig.frames()
    assert name(frames[0]) == "HELLO" and frames[0][1] == 0
    assert statuses(frames)[0]["faults"] == FAULT_I2C
    rig.buses[0].nack.clear()
    rig.command(CMD_START)
    rig.run(20_000)
    assert statuses(rig.frames())[-1]["faults"] == FAULT_I2C | FAULT_RECOVERED


def test_run_loop_survives_exceptions_and_feeds_the_watchdog(mocker):
    rig = streaming_rig()
    boom = mocker.patch.object(
        rig.board, "poll", side_effect=[ZeroDivisionError()] * 3 + [None] * 7
    )
    fed = []

    def feed():
        fed.append(1)
        if len(fed) == 10:
            raise KeyboardInterrupt  # how a test (or Ctrl-C) ends run()

    with pytest.raises(KeyboardInterrupt):
        rig.board.run(feed=feed)
    assert boom.call_count == 10 and rig.board.last_error == 0xFF


def test_host_reopening_gets_hello_first_and_exact_drop_counts():
    """Frames queued for a host that went away are dropped and counted, not resent."""
    rig = streaming_rig()
    rig.link.paused = True  # the old host stopped reading
    rig.run(300_000)
    queued = rig.board.tx.used
    assert queued > 3000  # the ring is full of frames for nobody
    rig.link.paused = False
    rig.link.host_open()
    rig.board.poll()
    frames = rig.frames()
    assert name(frames[0]) == "HELLO"
    rig.run(1_100_000)
    rig.frames()
    frames = rig.log
    seqs = [f[1] for f in frames]
    lost = sum(b - a - 1 for a, b in zip(seqs, seqs[1:]))
    assert lost == rig.board.tx.dropped
    st = [s for s in statuses(frames) if s["faults"] & FAULT_TX_DROPPED]
    assert st and st[-1]["tx_dropped"] == rig.board.tx.dropped
