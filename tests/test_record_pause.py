"""``record`` survives its own host standing still (Ctrl-Z then ``fg``, a paused VM, a slow
disk) and a host clock that steps back: silence is judged on what the board sends and what
waits on the port, never across the host's own stall; elapsed time never goes back.

On a simulated host clock (``StallingPort``): no real sleep, no wall-clock luck.
"""

import json

import pytest
from stalling_port import StallingPort

from tactile.board.stream_decoder import decode_bytes
from tactile.errors import BoardError
from tactile.recording.session import SILENT_S, Session
from tactile_sim.emulator import load_scene


@pytest.fixture
def scene(tmp_path):
    """The press scene at 200 Hz: a stall of 20 s overflows the board's 64 KB link."""
    text = load_scene("press").path.read_text().replace("rate_hz = 1000", "rate_hz = 200")
    path = tmp_path / "press200.toml"
    path.write_text(text)
    return load_scene(str(path))


def _session(port, out, **kw):
    return Session("/dev/ttyACM0", out, opener=lambda name: port, clock=port.clock,
                   sleep=port.sleep, tare=False, **kw)  # fmt: skip


def _stall_after(port, samples, seconds):
    def on_progress(session):
        if session.stats.samples >= samples and not port.stalled and not port.stall_s:
            port.stall_s = seconds

    return on_progress


def _kept(out, port):
    """Every byte the port handed over is in capture.bin, and every reading in frames.csv."""
    capture = (out / "capture.bin").read_bytes()
    assert capture == bytes(port.delivered)
    messages, counters = decode_bytes(capture)
    rows = (out / "frames.csv").read_text().splitlines()[2:]  # below units, header
    assert len(rows) == sum(m.type_name in ("SAMPLE", "CONTACT") for m in messages)
    return json.loads((out / "meta.json").read_text()), counters


@pytest.mark.parametrize("stall_s", [6.0, 25.0])
def test_a_host_that_stood_still_reads_what_waited_and_goes_on(scene, tmp_path, stall_s):
    port = StallingPort(scene)
    out = tmp_path / "run"
    stall, said = _stall_after(port, 200, stall_s), []
    session = _session(port, out, duration_s=stall_s + 4, on_progress=stall,
                       on_notice=lambda session, line: said.append(line))  # fmt: skip
    meta = session.run()
    assert port.stalled and meta["ended"] == "duration"  # not "board silent", not exit 4
    saved, counters = _kept(out, port)
    assert saved["ended"] == "duration"
    assert meta["device_time_s"] >= stall_s + 3.5  # the board's time: the whole run
    (pause,) = meta["pauses"]
    assert pause["clock_step_s"] == pytest.approx(stall_s, abs=0.1)
    assert pause["bytes_waiting"] >= 40_000  # what the board sent meanwhile, read first
    # what the board could not send while the host stood still: its count and the gaps agree
    assert meta["tx_dropped"] == meta["decoder"]["lost_frames"] == counters.lost_frames
    assert pause["lost_frames_before"] == 0  # the gaps came after the stall
    assert said == [
        f"the host stood still for {stall_s:.1f} s at {pause['at_s']:.1f} s (suspended? a slow"
        f" disk?); read the {pause['bytes_waiting']:,} bytes that waited on the port;"
        " recording goes on"
    ]
    assert counters.lost_frames > 0  # 64 KB hold about 5 s of this stream


def test_a_board_that_stays_silent_after_the_stall_is_given_up_on_after_a_real_window(
    scene, tmp_path
):
    port = StallingPort(scene)
    out = tmp_path / "run"
    stall = _stall_after(port, 200, 10.0)

    def on_progress(session):
        stall(session)
        if port.stalled and not port.hung:
            port.hang()  # the firmware hangs during the stall: what it sent before still waits

    session = _session(port, out, duration_s=60, on_progress=on_progress)
    with pytest.raises(BoardError, match="said nothing for 5 s"):
        session.run()
    meta, _ = _kept(out, port)
    assert port.unread == 0  # everything that waited on the port was read first
    assert meta["ended"] == "board silent" and len(meta["pauses"]) == 1
    assert meta["pauses"][0]["bytes_waiting"] > 0
    pause = meta["pauses"][0]
    back_at = pause["at_s"] + pause["clock_step_s"]  # the host runs again
    assert meta["elapsed_s"] - back_at == pytest.approx(SILENT_S, abs=0.3)


def test_a_host_clock_that_steps_back_never_gives_negative_elapsed_time(scene, tmp_path):
    port = StallingPort(scene)
    seen = []

    def on_progress(session):
        if session.stats.samples >= 200 and not port.clock_offset:
            port.clock_offset = -18.8  # the host's clock steps back; the board's goes on
        seen.append(session.meta()["elapsed_s"])

    meta = _session(port, tmp_path / "run", duration_s=3.0, on_progress=on_progress).run()
    _kept(tmp_path / "run", port)
    assert port.clock_offset and min(seen) >= 0 and seen == sorted(seen)
    assert meta["ended"] == "duration" and meta["elapsed_s"] == pytest.approx(3.0, abs=0.1)
    assert meta["device_time_s"] == pytest.approx(3.0, abs=0.2)  # not 3 s + 18.8 s
    assert meta["pauses"][0]["clock_step_s"] == pytest.approx(-18.8, abs=0.1)
