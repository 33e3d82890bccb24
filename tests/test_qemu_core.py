"""The C core cross-compiled for a Cortex-M0, running in QEMU (issue 16, part 5).

The image (``firmware/c/qemu``) runs in ``qemu-system-arm -M microbit`` behind a pty
(``tactile emulate --core qemu``), its ADCs served by the emulator over semihosting.  The
host reads it as it reads a board; on a steady load it reports the same integers as the
MicroPython firmware (the fixed-point calibration on real ARMv6-M code, libgcc's 64-bit
helpers included); a sensor fault reaches it at its own time.  Skipped, with the reason,
without ``arm-none-eabi-gcc`` (and newlib) or ``qemu-system-arm``.
"""

import json
import shutil
import subprocess
import sys
import time

import pytest
import serial
from toolchain import arm_gcc, missing

from tactile.board.stream_decoder import StreamDecoder
from tactile_protocol import constants as C
from tactile_sim.emulator import load_scene
from tactile_sim.emulator.device import EmulatedBoard

pytestmark = pytest.mark.realtime  # on the wall clock: bench/realtime_soak.py

STEADY = """
[scene]
name = "steady"
seed = 3
[board]
rate_hz = 1000
streams = ["samples", "contacts"]
[sensor]
bias_counts = 0.0
[motion]
kind = "press"
keyframes = [[0.0, 3.2, 2.4, -1.0, 0.01, -0.02, 0.005], [1.0, 3.2, 2.4, -1.0, 0.01, -0.02, 0.005]]
[[sensor_fault]]
at_s = 0.15
kind = "i2c_timeout"
count = 3
"""
# At rest for 1 s (time for record's TARE, as the shipped scenes rest: under load the host
# may take a few hundred ms of the board's time to send it), one contact, then rest.
QUICK_PRESS = """
[scene]
name = "quick"
[board]
streams = ["samples", "contacts"]
[sensor]
bias_counts = 0.0
[motion]
kind = "press"
keyframes = [[0.0, 0, 0, 0, 0, 0, 0], [1.0, 0, 0, 0, 0, 0, 0], [1.05, 3.2, 2.4, 0, 0, 0, 0],
             [1.1, 3.2, 2.4, 0, 0, 0, 0], [1.15, 0, 0, 0, 0, 0, 0], [5.0, 0, 0, 0, 0, 0, 0]]
"""


@pytest.fixture(scope="module")
def elf():
    from tactile_sim.emulator.qemu_core import QEMU, QemuUnavailable, image

    if shutil.which(QEMU) is None:
        missing(f"{QEMU}: apt-get install qemu-system-arm")
    arm_gcc()  # (the micro:bit image is cross-compiled against newlib)
    try:
        return image()
    except QemuUnavailable as exc:
        missing(str(exc))


def _scene(tmp_path, text, name="scene"):
    path = tmp_path / f"{name}.toml"
    path.write_text(text)
    return load_scene(path)


def _serve(scene, seconds, fast=True):
    """Every message the QEMU board sent in ``seconds`` of its time, read through its pty."""
    from tactile_sim.emulator.qemu_server import QemuServer

    board = EmulatedBoard(scene, core="qemu", boot_id=5, board_id=b"qemu-id5")
    server = QemuServer(board, realtime=not fast, duration_s=seconds)
    decoder, msgs = StreamDecoder(), []
    deadline = time.monotonic() + 120
    with server, serial.Serial(server.path, timeout=0.05) as port:  # (raises what it raised)
        while (server.serving or port.in_waiting) and time.monotonic() < deadline:
            data = port.read(1)
            if data:
                msgs += decoder.feed(data + port.read(port.in_waiting))
    return msgs, decoder.counters, server


def test_the_image_fits_a_micro_bit(elf):
    from tactile_fw_tools import cross

    flash, ram = cross.size(elf)
    assert 8_000 < flash < 256 * 1024 and ram < 16 * 1024
    attrs = subprocess.run(
        ["arm-none-eabi-readelf", "-A", str(elf)], capture_output=True, text=True, check=True
    ).stdout
    assert "Tag_CPU_arch: v6S-M" in attrs and "Tag_THUMB_ISA_use: Thumb-1" in attrs


def test_on_a_steady_load_it_reports_the_python_firmwares_integers(elf, tmp_path):
    """Same calibration and codes, same integers: fixed point on ARMv6-M equals Python's.
    Then an I2C fault at 0.15 s of the board's own time: STATUS, and recovery.

    QEMU's UART drains on its own thread: on a loaded machine the firmware's TX ring can
    overflow even as fast as possible.  Then every frame lost is one the board says it
    dropped: the run lasts past a STATUS period (1.2 s), and the frames missing before the
    last STATUS are its ``tx_dropped``.  A fault's STATUS can be one of them (seen once under
    load); the later STATUS frames still count the I2C error."""
    scene = _scene(tmp_path, STEADY)
    msgs, counters, server = _serve(scene, 1.2)
    samples = [m for m in msgs if m.type_name == "SAMPLE"]
    assert msgs[0].type_name == "HELLO" and msgs[0].boot_id == 5
    assert msgs[0].board_id == b"qemu-id5"  # the id the emulator served the image
    assert len(samples) > 600 and counters.damaged == 0
    assert samples[-1].timestamp_us >= 1_199_000  # the run's end reached the host, however loaded
    last = [m for m in msgs if m.type_name == "STATUS"][-1]
    missing = last.seq - msgs[0].seq + 1 - sum(1 for m in msgs if m.seq <= last.seq)
    assert missing == last.tx_dropped  # what was lost, the board counted and said
    run = _consecutive(msgs, 91)  # (a stretch the ring kept whole)
    times = [m.timestamp_us for m in run]
    steps = {b - a for a, b in zip(times, times[1:])}
    assert steps <= {999, 1000, 1001}  # TIMER0's microseconds: the poll after the WFI wakes
    assert abs(times[-1] - times[0] - 90_000) <= 2  # ... on fixed deadlines: 1 kHz exactly
    py = EmulatedBoard(scene, core="python", boot_id=5, board_id=b"qemu-id5")
    py.run_until(300_000)
    values = lambda m: (m.fx, m.fy, m.fz, m.tx, m.ty, m.tz)  # noqa: E731
    ref = {
        values(m)
        for m in StreamDecoder().feed(py.read_host())
        if m.type_name == "SAMPLE" and 5_000 < m.timestamp_us < 100_000
    }
    assert len(ref) == 1 and {values(m) for m in samples[5:100]} == ref  # one reading, same
    said = {(bool(m.faults & C.FAULT_I2C), bool(m.faults & C.FAULT_RECOVERED))
            for m in msgs if m.type_name == "STATUS"}  # fmt: skip
    if last.tx_dropped == 0:  # nothing lost: the fault and its recovery were both said
        assert {(True, False), (True, True)} <= said
    else:  # the fault's own STATUS may be among the dropped: its counter still tells
        assert last.i2c_errors >= 1
    assert server.exit_status is None  # QEMU was stopped, the image never exited


def _consecutive(msgs, n):
    """``n`` SAMPLEs from a stretch of messages with no sequence number missing (from the
    11th sample on)."""
    run, skip, prev = [], 10, None
    for m in msgs:
        if prev is not None and m.seq != prev + 1:
            run = []
        prev = m.seq
        if m.type_name == "SAMPLE":
            if skip:
                skip -= 1
                continue
            run.append(m)
            if len(run) == n:
                return run
    raise AssertionError(f"no {n} samples in a row")


def test_record_reads_the_qemu_board_as_it_reads_a_board(elf, cli, tmp_path):
    """'tactile emulate --core qemu' in one process, 'tactile record' in another."""
    scene = tmp_path / "quick.toml"
    scene.write_text(QUICK_PRESS)
    emulate = subprocess.Popen(
        [sys.executable, "-m", "tactile.cli.main", "emulate", str(scene), "--core", "qemu",
         "--fast", "--duration", "30"],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
    )  # fmt: skip
    try:
        path = emulate.stdout.readline().strip()
        assert path.startswith("/dev/"), emulate.stderr.read()
        code, _, err = cli("record", "--port", path, "--contacts", "1", "-o", tmp_path / "run",
                           "--quiet")  # fmt: skip
    finally:
        emulate.terminate()
        _, said = emulate.communicate(timeout=10)
    assert code == 0, err
    assert "on the qemu core" in said
    meta = json.loads((tmp_path / "run" / "meta.json").read_text())
    assert meta["contacts_ended"] == 1 and meta["decoder"]["lost_frames"] == 0
    assert meta["tared"] and meta["device"]["sensor_model"] == "FT6/ADS122C04x6"


def test_a_scene_with_disconnects_is_refused_for_qemu(cli, tmp_path):
    scene = tmp_path / "unplug.toml"
    scene.write_text(QUICK_PRESS + "[link]\ndisconnect = [[0.5, 0.7]]\n")
    code, out, err = cli("emulate", scene, "--core", "qemu")
    assert code == 2 and out == "" and err.count("\n") == 1
    assert "[link] disconnect: not served with --core qemu" in err


def test_without_the_cross_compiler_qemu_is_refused_in_one_line(cli, mocker):
    from tactile_fw_tools import cross

    mocker.patch.object(cross.shutil, "which", return_value=None)
    code, out, err = cli("emulate", "press", "--core", "qemu")
    assert code == 4 and out == "" and err.count("\n") == 1 and "Traceback" not in err
    assert "core 'qemu': no arm-none-eabi-gcc on PATH: apt-get install gcc-arm-none-eabi" in err
