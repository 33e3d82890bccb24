"""The board as the host sees it, on every target of the ``board`` fixture (issue 16, part 4).

One suite, its board chosen by a parameter (``tests/board_target.py``): the emulator on
the MicroPython firmware, the emulator on the C core, and a real board with
``pytest --port /dev/ttyACM0`` (``hardware``; skipped, with the reason, without it).
Handshake, config, tare, reconnect and record talk only to a port, so they run on all
three and leave a real board as they found it (CONFIG without persist, restored).  The
gate, sensor faults and unplugs need a scripted load, injected faults or a pulled cable:
those run on both emulated cores only (``EMULATED``).
"""

import json
import os
import re
import time

import numpy as np
import pytest
import serial
from board_target import EMULATED, read_for, run_emulated

from tactile.board.client import BoardClient, CommandRefused
from tactile.board.serial_port import open_port
from tactile.board.stream_decoder import StreamDecoder, decode_bytes
from tactile_protocol import constants as C
from tactile_sim.emulator import load_scene
from tactile_sim.urlhandler import register

pytestmark = pytest.mark.realtime  # on the wall clock: bench/realtime_soak.py

register()
emulated = pytest.mark.parametrize("board", EMULATED, indirect=True)


def _scene(tmp_path, extra="", noise=True, bias_counts=0.0, name="scene"):
    """The press scene, optionally without noise, offset, with more sections (``extra``)."""
    text = load_scene("press").path.read_text()
    if not noise:
        text = re.sub(r"noise_force_N = .*", "noise_force_N = [0.0, 0.0, 0.0]", text)
    text = re.sub(r"bias_counts = .*", f"bias_counts = {bias_counts!r}", text)
    path = tmp_path / f"{name}.toml"
    path.write_text(text + "\n" + extra + "\n")
    return str(path)


def _samples(msgs, after=None):
    """The SAMPLE frames of ``msgs`` (those sent after the reply ``after``)."""
    first = -1 if after is None else after.seq
    return [m for m in msgs if m.type_name == "SAMPLE" and m.seq > first]


def _read_samples(client, n, after=None, seconds=5.0):
    """The first ``n`` SAMPLE frames read (sent after the reply ``after``)."""
    msgs = read_for(client, seconds, until=lambda m: len(_samples(m, after)) >= n)
    return _samples(msgs, after)[:n]


def _settings(info):
    """What CONFIG sets, as INFO reports it."""
    return (info.rate_hz, info.enter_threshold, info.exit_threshold, info.debounce,
            info.flags & C.CFG_WRITABLE)  # fmt: skip


def _restore(client, info):
    """Put back the settings INFO ``info`` reported (RAM only: nothing is persisted)."""
    flags = info.flags & C.CFG_WRITABLE & ~C.CFG_PERSIST
    client.command(C.CMD_CONFIG, (info.rate_hz, info.enter_threshold, info.exit_threshold,
                                  info.debounce, flags))  # fmt: skip
    if info.flags & C.CFG_STREAMING:
        client.start()
    else:
        client.stop()


# --- on every target ------------------------------------------------------------------------


def test_handshake_then_info_describe_the_same_board(board):
    client = board.client()
    try:
        first = client.info
        info = client.get_info()
    finally:
        client.close()
    assert first.type_name in ("HELLO", "INFO") and info.type_name == "INFO"
    assert first.protocol_version == info.protocol_version == C.PROTOCOL_VERSION
    assert info.boot_id == first.boot_id and info.n_sensors == first.n_sensors >= 1
    assert 0 < info.rate_hz <= info.max_rate_hz
    if board.emulated:
        assert first.type_name == "HELLO" and info.sensor_model.rstrip(b"\0") == b"FT6/ADS122C04x6"


def test_config_is_applied_and_a_refused_one_changes_nothing(board):
    client = board.client()
    before = client.get_info()
    try:
        applied = client.configure(500, 2.0, 1.0, 2, C.CFG_STREAM_SAMPLES)
        client.start()
        info = client.get_info()
        assert _settings(info) == (500, 2_000_000, 1_000_000, 2, C.CFG_STREAM_SAMPLES)
        with pytest.raises(CommandRefused, match=r"refused CONFIG: out of range \(exit_thr"):
            client.configure(1000, 1.0, 2.0, 3, C.CFG_STREAM_SAMPLES)  # exit above enter
        with pytest.raises(CommandRefused, match=r"refused CONFIG: out of range \(rate_hz\)"):
            client.configure(info.max_rate_hz + 10, 2.0, 1.0, 2, C.CFG_STREAM_SAMPLES)
        assert _settings(client.get_info()) == _settings(info)
        got = _read_samples(client, 30, after=applied)
    finally:
        _restore(client, before)
        client.close()
    steps = [b.timestamp_us - a.timestamp_us for a, b in zip(got, got[1:])]
    # A running clock stamps a sample when its poll took it: a command handled in the same
    # poll (the refused CONFIGs above) moves it by a fraction of the period, never the phase.
    # (On a chip, when a command lands in a poll depends on the host: up to a quarter.)
    jitter = 0 if board.core else 2000 // 4  # us
    assert len(got) == 30 and max(abs(d - 2000) for d in steps) <= jitter  # 500 Hz
    assert abs(got[-1].timestamp_us - got[0].timestamp_us - 29 * 2000) <= jitter  # no drift


def test_tare_takes_the_offset_out_of_the_readings(board, tmp_path):
    """Offset gauges read as a force until TARE; the ACK comes once the bias is captured."""
    client = board.client(_scene(tmp_path, bias_counts=40000.0))
    try:
        before = _read_samples(client, 50)
        ack = client.tare(n_samples=64)  # (what arrived meanwhile is read next: skipped)
        after = _read_samples(client, 50, after=ack)
    finally:
        client.close()
    f_before = np.mean([[m.fx, m.fy, m.fz] for m in before], axis=0) * 1e-6  # N
    f_after = np.mean([[m.fx, m.fy, m.fz] for m in after], axis=0) * 1e-6
    assert len(before) == len(after) == 50
    assert np.all(np.abs(f_after) < 0.05)  # N: the bias of 64 readings, 50 readings later
    if board.emulated:  # 40,000 counts on every gauge read as 0.97 N (below the gate)
        assert np.linalg.norm(f_before) > 0.5


def test_reopening_the_port_gives_hello_again_from_the_same_boot(board):
    with board.serve("press") as path:
        client = BoardClient(open_port(path), path)
        first = client.handshake(2.0)
        seen = _read_samples(client, 20)
        client.close()
        client = BoardClient(open_port(path), path)
        try:
            again = client.handshake(2.0)
        finally:
            client.close()
    assert len(seen) == 20
    assert again.boot_id == first.boot_id  # the same board, not a reboot
    assert again.seq > max(m.seq for m in seen)  # and it kept counting


def test_record_writes_capture_frames_and_meta_that_agree(board, cli, tmp_path):
    out = tmp_path / "run"
    code, stdout, err = cli("record", "--port", board.url("press"), "--duration", "0.5",
                            "-o", out, "--quiet")  # fmt: skip
    assert code == 0 and "Traceback" not in err, err
    capture = (out / "capture.bin").read_bytes()
    units, *rows = (out / "frames.csv").read_text().splitlines()
    assert units.startswith("# units:")
    meta = json.loads((out / "meta.json").read_text())
    messages, counters = decode_bytes(capture)
    data = [m for m in messages if m.type_name in ("SAMPLE", "CONTACT")]
    assert len(rows) - 1 == len(data) == meta["samples"] > 20
    assert meta["ended"] == "duration" and meta["tared"]
    assert meta["decoder"]["lost_frames"] == counters.lost_frames == 0
    assert meta["bytes"] == len(capture) and f"recorded {meta['samples']:,} reading" in stdout


# --- on the emulated cores: what only a simulation can script --------------------------------


@emulated
def test_contact_begin_and_end_land_where_the_scene_puts_them(board, tmp_path):
    scene_path = _scene(tmp_path, noise=False)
    port, msgs, counters = run_emulated(board.url(scene_path), 4.0)
    assert port.emulator.core == board.core
    scene = port.emulator.scene
    enter, exit_ = scene.board["enter_threshold_N"], scene.board["exit_threshold_N"]
    debounce = scene.board["debounce"]
    ts = np.arange(0, 4.0, 1e-5)
    f = np.hypot(*port.emulator.motion.wrench_at(ts)[:2])
    above, below = f > enter, f < exit_
    onsets = ts[1:][above[1:] & ~above[:-1]]
    ends = ts[1:][below[1:] & ~below[:-1] & (ts[1:] > onsets[0])]
    contacts = [m for m in msgs if m.type_name == "CONTACT"]
    begins = [m.timestamp_us for m in contacts if m.phase == C.PHASE_BEGIN]
    finishes = [m.timestamp_us for m in contacts if m.phase == C.PHASE_END]
    assert len(begins) == len(onsets) == 2 and len(finishes) == 2
    for got, want in [*zip(begins, onsets), *zip(finishes, ends)]:
        expect = want * 1e6 + (debounce - 1) * 1000  # first sample past the level + debounce
        assert abs(got - expect) <= 1000 + 500, (got, expect)  # one sample + ADC latency
    assert counters.lost_frames == 0


@emulated
def test_sensor_faults_give_status_and_recovery(board, tmp_path):
    extra = (
        '[[sensor_fault]]\nat_s = 0.5\nkind = "i2c_timeout"\ncount = 4\n'
        '[[sensor_fault]]\nat_s = 1.2\nkind = "stuck_drdy"\nfor_s = 0.05\n'
        '[[sensor_fault]]\nat_s = 2.5\nkind = "saturate"\nfor_s = 0.02\n'
    )
    _, msgs, _ = run_emulated(board.url(_scene(tmp_path, extra=extra)), 3.5)
    faults = [m.faults for m in msgs if m.type_name == "STATUS"]
    assert any(f & C.FAULT_I2C and not f & C.FAULT_RECOVERED for f in faults)
    assert any(f & C.FAULT_DRDY_STUCK and not f & C.FAULT_RECOVERED for f in faults)
    assert any(f & C.FAULT_SATURATION for f in faults)
    assert sum(1 for f in faults if f & C.FAULT_RECOVERED) >= 2
    late = [m for m in msgs if m.type_name == "SAMPLE" and m.timestamp_us > 3_000_000]
    assert len(late) > 400  # the board kept running


@emulated
def test_tare_under_load_is_refused_and_force_takes_it(board):
    """In contact, TARE is NAK 8 naming the sensor; --force's raised gate lets it through."""
    client = board.client("press")  # 4 N in x-y from 1.0 to 1.5 s: above the 1.39 N gate
    try:
        got = _samples(read_for(client, 10.0, until=lambda m: _held(_samples(m))))
        assert _held(got)
        with pytest.raises(CommandRefused, match=r"refused TARE: sensor 0 is loaded \(force"):
            client.tare(n_samples=20)
        ack = client.tare(n_samples=20, force=True)
        after = _read_samples(client, 20, after=ack)
    finally:
        client.close()
    assert all(np.hypot(m.fx, m.fy) < 0.3e6 for m in after)  # uN: the load went into the bias


def _held(samples):
    """In contact, and into the press scene's steady hold."""
    return any(m.flags & C.FLAG_IN_CONTACT and m.timestamp_us > 1_050_000 for m in samples)


def _read_through_unplugs(link, decoder, alive, seconds, drain):
    """Read the symlinked port while the server runs, reopening it after each unplug."""
    msgs, reopened = [], 0
    deadline = time.monotonic() + seconds
    port = serial.Serial(link, timeout=0.05)
    while (alive() or (drain and port.in_waiting)) and time.monotonic() < deadline:
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


@emulated
@pytest.mark.slow
def test_disconnect_and_reconnect_resumes_and_counts_the_gap(board, tmp_path):
    scene = load_scene(_scene(tmp_path, extra="[link]\ndisconnect = [[1.0, 1.4]]\n"))
    link = str(tmp_path / "ttyTACTILE")
    decoder = StreamDecoder()
    with board.serve(scene, link_path=link, disconnects=[[1.0, 1.4]], duration_s=2.5):
        msgs, reopened = _read_through_unplugs(link, decoder, board.serving, 6, drain=False)
        reconnects = board.server.reconnects
    assert reopened >= 1 and reconnects == 1
    hellos = [m for m in msgs if m.type_name == "HELLO"]
    again = [m for m in hellos if m.timestamp_us >= 1_400_000]
    assert len(again) == 1 and again[0].seq > 0  # announced on reconnect; the board kept counting
    assert again[0].boot_id == hellos[0].boot_id and decoder.counters.reboots == 0  # unplugged
    after = [m for m in msgs if m.timestamp_us > 1_450_000 and m.type_name == "SAMPLE"]
    assert len(after) > 500  # the stream resumed
    # Every frame the board produced while unplugged is counted lost (~400 samples + contacts).
    gap = again[0].seq - max(m.seq for m in msgs if m.seq < again[0].seq)
    assert decoder.counters.lost_frames >= 380 and decoder.counters.lost_frames >= gap - 1


@emulated
def test_fast_mode_unplugs_on_time_and_resumes_where_it_was(board, tmp_path):
    scene = load_scene(_scene(tmp_path, extra="[link]\ndisconnect = [[0.5, 0.7]]\n"))
    link = str(tmp_path / "ttyTACTILE")
    decoder = StreamDecoder()
    with board.serve(scene, False, link, disconnects=[[0.5, 0.7]], duration_s=1.2):
        msgs, _ = _read_through_unplugs(link, decoder, board.serving, 10, drain=True)
        reconnects = board.server.reconnects
    assert reconnects == 1
    samples = [m.timestamp_us for m in msgs if m.type_name == "SAMPLE"]
    before = [t for t in samples if t < 700_000]
    after = [t for t in samples if t >= 700_000]
    assert before == list(range(1000, 500_001, 1000))  # all up to the unplug, none after it
    hello = [m for m in msgs if m.type_name == "HELLO" and m.timestamp_us >= 700_000]
    assert len(hello) == 1 and hello[0].timestamp_us < 702_000  # held for the new host
    assert after == list(range(701_000, 1_200_001, 1000))  # then nothing skipped
    assert decoder.counters.lost_frames >= 199  # the board's frames while unplugged
    assert decoder.counters.reboots == 0  # the same board, replugged: not a reboot
