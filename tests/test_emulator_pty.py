"""Host <-> emulator over a real pseudo-terminal (issue 6), with real-time pacing."""

import os
import threading
import time

import pytest
import serial

from tactile.stream_decoder import StreamDecoder
from tactile_sim.emulator import load_scene
from tactile_sim.emulator.device import EmulatedBoard
from tactile_sim.emulator.pty_server import PtyServer


def _serve(server, duration):
    thread = threading.Thread(target=server.serve, args=(duration,), daemon=True)
    thread.start()
    return thread


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
    server = PtyServer(EmulatedBoard(load_scene("press")), realtime=True)
    path = server.open()
    port = serial.Serial(path, timeout=0.05)
    thread = _serve(server, 10.5)
    decoder = StreamDecoder()
    try:
        msgs = _read_for(port, decoder, 10.0)
    finally:
        port.close()
        server.stop = True
        thread.join(5)
        server.close()
    samples = [m for m in msgs if m.type_name == "SAMPLE"]
    assert len(samples) >= 9000
    seqs = [m.seq for m in msgs]
    assert seqs == list(range(seqs[0], seqs[0] + len(seqs)))  # contiguous: nothing lost
    times = [m.timestamp_us for m in samples]
    assert all(b - a == 1000 for a, b in zip(times, times[1:]))
    assert decoder.counters.lost_frames == 0 and decoder.counters.damaged == 0


def _scene_file(tmp_path, extra):
    text = (load_scene("press").path.read_text()) + "\n" + extra
    path = tmp_path / "scene.toml"
    path.write_text(text)
    return path


def _read_through_unplugs(link, decoder, thread, seconds, drain):
    """Read the symlinked port while the server runs, reopening it after each unplug."""
    msgs, reopened = [], 0
    deadline = time.monotonic() + seconds
    port = serial.Serial(link, timeout=0.05)
    while (thread.is_alive() or (drain and port.in_waiting)) and time.monotonic() < deadline:
        try:
            data = port.read(1)
            msgs += decoder.feed(data + port.read(port.in_waiting))
        except (serial.SerialException, OSError):
            port.close()
            while not os.path.exists(link) and time.monotonic() < deadline:
                time.sleep(0.01)
            port = serial.Serial(link, timeout=0.05)
            reopened += 1
    port.close()
    return msgs, reopened


@pytest.mark.slow
def test_disconnect_and_reconnect_resumes_and_counts_the_gap(tmp_path):
    scene = load_scene(_scene_file(tmp_path, "[link]\ndisconnect = [[1.0, 1.4]]\n"))
    link = str(tmp_path / "ttyTACTILE")
    server = PtyServer(
        EmulatedBoard(scene), link_path=link, realtime=True, disconnects=[[1.0, 1.4]]
    )
    server.open()
    thread = _serve(server, 2.5)
    decoder = StreamDecoder()
    msgs, reopened = _read_through_unplugs(link, decoder, thread, 6, drain=False)
    thread.join(5)
    server.close()
    assert reopened >= 1 and server.reconnects == 1
    hellos = [m for m in msgs if m.type_name == "HELLO"]
    again = [m for m in hellos if m.timestamp_us >= 1_400_000]
    assert len(again) == 1 and again[0].seq > 0  # announced on reconnect; the board kept counting
    assert again[0].boot_id == hellos[0].boot_id and decoder.counters.reboots == 0  # unplugged
    after = [m for m in msgs if m.timestamp_us > 1_450_000 and m.type_name == "SAMPLE"]
    assert len(after) > 500  # the stream resumed
    assert decoder.counters.seq_gaps >= 1
    # Every frame the board produced while unplugged is counted lost (~400 samples + contacts).
    gap = again[0].seq - max(m.seq for m in msgs if m.seq < again[0].seq)
    assert decoder.counters.lost_frames >= 380 and decoder.counters.lost_frames >= gap - 1


def _drain(port, decoder, thread, slow_reads=0):
    """Read until the server is done and the pty is empty; the first reads lag (a slow host)."""
    msgs = []
    while thread.is_alive() or port.in_waiting:
        data = port.read(1)
        if data:
            msgs += decoder.feed(data + port.read(port.in_waiting))
            if slow_reads > 0:
                slow_reads -= 1
                time.sleep(0.02)  # meanwhile the board fills the pty (about 20 kB)
    return msgs


def test_fast_mode_waits_for_the_host_and_loses_nothing():
    board = EmulatedBoard(load_scene("press"))
    server = PtyServer(board, realtime=False)
    path = server.open()
    thread = _serve(server, 2.0)
    time.sleep(0.1)
    assert board.t_us == 0  # nobody is reading: simulated time holds
    port = serial.Serial(path, timeout=0.05)
    decoder = StreamDecoder()
    try:
        msgs = _drain(port, decoder, thread, slow_reads=10)
    finally:
        port.close()
        server.stop = True
        thread.join(5)
        server.close()
    assert msgs[0].type_name == "HELLO" and msgs[0].timestamp_us == 0  # the scene from its start
    seqs = [m.seq for m in msgs]
    assert seqs == list(range(seqs[0], seqs[0] + len(seqs)))
    times = [m.timestamp_us for m in msgs if m.type_name == "SAMPLE"]
    assert times == list(range(1000, 2_000_001, 1000))  # every sample, to the last one
    assert decoder.counters.lost_frames == 0 and decoder.counters.damaged == 0


def test_fast_mode_unplugs_on_time_and_resumes_where_it_was(tmp_path):
    scene = load_scene(_scene_file(tmp_path, "[link]\ndisconnect = [[0.5, 0.7]]\n"))
    link = str(tmp_path / "ttyTACTILE")
    board = EmulatedBoard(scene)
    server = PtyServer(board, link_path=link, realtime=False, disconnects=[[0.5, 0.7]])
    server.open()
    thread = _serve(server, 1.2)
    decoder = StreamDecoder()
    msgs, _ = _read_through_unplugs(link, decoder, thread, 10, drain=True)
    thread.join(5)
    server.close()
    assert server.reconnects == 1
    samples = [m.timestamp_us for m in msgs if m.type_name == "SAMPLE"]
    before = [t for t in samples if t < 700_000]
    after = [t for t in samples if t >= 700_000]
    assert before == list(range(1000, 500_001, 1000))  # all up to the unplug, none after it
    hello = [m for m in msgs if m.type_name == "HELLO" and m.timestamp_us >= 700_000]
    assert len(hello) == 1 and hello[0].timestamp_us < 702_000  # held for the new host
    assert after == list(range(701_000, 1_200_001, 1000))  # then nothing skipped
    assert decoder.counters.lost_frames >= 199  # the board's frames while unplugged
    assert decoder.counters.reboots == 0  # the same board, replugged: not a reboot
