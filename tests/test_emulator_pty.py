"""Host <-> emulator over a real pseudo-terminal (issue 6), with real-time pacing.

Unplugging and replugging, on both firmware cores: ``test_board_suite.py``.
"""

import time

import pytest
import serial

from tactile.board.stream_decoder import StreamDecoder
from tactile_protocol import constants as C
from tactile_sim.emulator import load_scene
from tactile_sim.emulator.device import EmulatedBoard
from tactile_sim.emulator.pty_server import PtyServer

pytestmark = pytest.mark.realtime  # on the wall clock: bench/realtime_soak.py


def _read_for(port, decoder, seconds):
    """The low-latency read idiom: read(1) blocks, then read(in_waiting)."""
    out = []
    end = time.monotonic() + seconds
    while time.monotonic() < end:
        data = port.read(1)
        if data:
            data += port.read(port.in_waiting)
            out += decoder.feed(data)
    return out


@pytest.mark.slow
def test_ten_seconds_at_1khz_lose_nothing():
    decoder = StreamDecoder()
    with PtyServer(EmulatedBoard(load_scene("press")), duration_s=10.5) as server:
        with serial.Serial(server.path, timeout=0.05) as port:
            msgs = _read_for(port, decoder, 10.0)
    samples = [m for m in msgs if m.type_name == "SAMPLE"]
    seqs = [m.seq for m in msgs]
    assert seqs == list(range(seqs[0], seqs[0] + len(seqs)))  # contiguous: nothing lost
    # Every millisecond has its sample, except where the emulator fell behind the wall clock
    # (a loaded machine): then it skipped ahead, as an overloaded board does, and the sample
    # after the gap says so (FLAG_LATE: taken when the board got to it, off the 1 ms grid,
    # so the step after it is short), and the host can tell.
    for a, b in zip(samples, samples[1:]):
        assert b.timestamp_us - a.timestamp_us == 1000 or (a.flags | b.flags) & C.FLAG_LATE, (a, b)
    assert samples[-1].timestamp_us - samples[0].timestamp_us >= 9_000_000
    assert decoder.counters.lost_frames == 0 and decoder.counters.damaged == 0


def _drain(port, decoder, server, slow_reads=0):
    """Read until the server is done and the pty is empty; the first reads lag (a slow host)."""
    msgs = []
    while server.serving or port.in_waiting:
        data = port.read(1)
        if data:
            msgs += decoder.feed(data + port.read(port.in_waiting))
            if slow_reads > 0:
                slow_reads -= 1
                time.sleep(0.02)  # meanwhile the board fills the pty (about 20 kB)
    return msgs


def test_fast_mode_waits_for_the_host_and_loses_nothing():
    board = EmulatedBoard(load_scene("press"))
    decoder = StreamDecoder()
    # (the hold outlasts any stall a loaded machine gives this reader)
    with PtyServer(board, realtime=False, duration_s=2.0, hold_limit_s=60.0) as server:
        time.sleep(0.1)
        assert board.t_us == 0  # nobody is reading: simulated time holds
        with serial.Serial(server.path, timeout=0.05) as port:
            msgs = _drain(port, decoder, server, slow_reads=10)
    assert msgs[0].type_name == "HELLO" and msgs[0].timestamp_us == 0  # the scene from its start
    seqs = [m.seq for m in msgs]
    assert seqs == list(range(seqs[0], seqs[0] + len(seqs)))
    times = [m.timestamp_us for m in msgs if m.type_name == "SAMPLE"]
    assert times == list(range(1000, 2_000_001, 1000))  # every sample, to the last one
    assert decoder.counters.lost_frames == 0 and decoder.counters.damaged == 0
