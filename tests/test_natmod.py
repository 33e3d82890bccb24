"""The C core as a MicroPython native module (``tactile_native.mpy``) on the Pico.

- The module shipped in the package is what ``tactile_fw_tools.natmod`` builds from
  ``firmware/c`` today, byte for byte (skipped with the missing tool named, failing under
  ``CI=true``), and is an armv6m native .mpy of the Pico image's version (6.3).
- On the emulated Pico, the Python ``Board`` and the module's ``Board`` run one scenario
  (``fw_mpy_pico_scenario.py``) on the same deterministic stand-in: every byte they send, their
  counters and their stored calibration are the same, and the same as CPython's.
- On the emulated Pico as ``tactile flash`` leaves it, the firmware runs the module on the
  chip's own USB, I2C controller, timer and flash: 1 kHz without a late sample, and the
  host's break-in gets the REPL.
"""

import pathlib
import subprocess
import sys
import time

import fw_mpy_pico_scenario
import pytest
import serial
from pico_target import serve, wait_booted
from toolchain import missing

from tactile.board.client import BoardClient
from tactile.board.stream_decoder import decode_bytes
from tactile_fw import calibration
from tactile_fw_tools import natmod
from tactile_protocol import constants as C

pytestmark = pytest.mark.realtime  # on the wall clock: bench/realtime_soak.py

HERE = pathlib.Path(__file__).parent
SIM = HERE.parent / "sim" / "tactile_sim"
MPY_OF_THE_IMAGE = 4870  # sys.implementation._mpy of the Pico image (../shared/rp2/NOTES.md)


@pytest.mark.slow
def test_the_shipped_module_is_what_firmware_c_builds_today(tmp_path):
    """Rebuilt from firmware/c with MicroPython's natmod build: the same bytes as the .mpy that
    ``tactile flash`` copies (after a change to firmware/c: ``make natmod``)."""
    try:
        built = natmod.build(tmp_path)
    except natmod.NoToolchain as exc:
        missing(str(exc))
    assert built.read_bytes() == natmod.SHIPPED.read_bytes(), (
        "firmware/tactile_fw/tactile_native.mpy is not built from the current firmware/c: "
        "run 'make natmod' and commit it"
    )


def test_the_module_is_armv6m_machine_code_for_the_pico_image():
    head = natmod.SHIPPED.read_bytes()[:4]
    assert head[:1] == b"M" and head[1] | head[2] << 8 == MPY_OF_THE_IMAGE  # version 6.3
    assert head[2] >> 2 == 4  # MP_NATIVE_ARCH_ARMV6M: Thumb-1, runs on the RP2040's M0+


def _mpremote(port, *args, timeout=120):
    r = subprocess.run([sys.executable, "-m", "mpremote", "connect", port, *args],
                       capture_output=True, text=True, timeout=timeout)  # fmt: skip
    assert r.returncode == 0, r.stderr[-2000:]
    return r.stdout


# port_mpy takes the module only when it is built from this firmware: a module whose
# contract number differs (as one left from another version would) is not taken.
PICKS = (
    "import tactile_fw.port_mpy as p; a = p.native_module(); p.NATIVE_API += 1; "
    "print('picks', 'native' if a else 'python', 'then', 'native' if p.native_module() else "
    "'python')"
)


@pytest.mark.slow
def test_both_boards_send_the_same_bytes_on_the_emulated_pico(pico_flashed):
    """What this proves: the module's armv6m code, loaded by stock MicroPython on the RP2040,
    gives for the same commands, clock and converter answers the same frames, counters and
    flash files as the Python firmware on the same chip and as CPython (its float32 build
    included).  The stand-in is Python on the chip (ManualClock, SimI2C, ADS122C04Model,
    PipeLink, MemoryStorage), so the module's machine.I2C, USB and timer paths are not
    in it: the next test runs those."""
    expected = fw_mpy_pico_scenario.scenario(fw_mpy_pico_scenario.python_board)  # CPython
    sim = [str(SIM / n) for n in ("__init__.py", "adc_model.py", "i2c_bus.py")]
    with serve(flash=pico_flashed) as server:
        out = _mpremote(server.path, "fs", "mkdir", ":lib/tactile_sim", "+", "fs", "cp", *sim,
                        ":lib/tactile_sim/", "+", "run", str(HERE / "fw_mpy_pico_scenario.py"),
                        "+", "exec", PICKS)  # fmt: skip
    records = {}
    for line in out.splitlines():
        name, _ms, record = (line.split(" ", 2) + ["", ""])[:3]
        if name in ("python", "native"):
            records[name] = record.split("|")
    assert "picks native then python" in out  # port_mpy.native_module(): matching or not
    assert records.get("python") == expected
    assert records.get("native") == expected
    # what the scenario covers
    msgs = decode_bytes(b"".join(bytes.fromhex(h) for h in expected[:-2]))
    msgs = msgs[0] if isinstance(msgs, tuple) else msgs
    kinds = {m.type_code for m in msgs}
    assert kinds >= {C.MSG_HELLO, C.MSG_SAMPLE, C.MSG_CONTACT, C.MSG_STATUS, C.MSG_ACK,
                     C.MSG_NAK, C.MSG_INFO}  # fmt: skip
    assert {m.phase for m in msgs if m.type_code == C.MSG_CONTACT} == {0, 1, 2}
    assert any(m.faults & C.FAULT_RECOVERED for m in msgs if m.type_code == C.MSG_STATUS)
    assert any(m.cmd_type == C.CMD_TARE for m in msgs if m.type_code == C.MSG_ACK)


LOADED = (
    "import sys; print(sorted(m for m in sys.modules if m.startswith('tactile')), "
    "open('cal0.bin', 'rb').read().hex())"
)
# the ceiling each board would report with 1 and 2 sensors: what the chip keeps with a tenth
# of its CPU spare (port_mpy.chip_ceiling: converters, bus and the board's own CPU time)
CEILINGS = (
    "from tactile_fw.port_mpy import chip_ceiling as c; "
    "print([c(n, 1000000, k) for k in ('native', 'python') for n in (1, 2)])"
)


@pytest.mark.slow
def test_the_module_runs_on_the_chips_usb_i2c_timer_and_flash(pico_flashed):
    """The firmware as flashed (main.py, the module in /lib) streams at 1 kHz on the chip's
    own I2C controller at 1 MHz, with the emulator charging each byte its bus time: every
    sample 1000 us after the last and none late.  SET_CAL goes to flash through the
    module's storage calls; the host's break-in stops it with the REPL's Ctrl-A left for
    mpremote, whose REPL finds the module ran and the Python board was never imported."""
    cal = [2e-6 if r == c else 0.0 for r in range(6) for c in range(6)]
    with serve(flash=pico_flashed) as server:
        wait_booted(server)
        client = BoardClient(serial.Serial(server.path, timeout=0.05), server.path)
        try:
            client.handshake(timeout=10.0)
            client.set_calibration(0, 4242, cal, timeout=10.0)
            flags = C.CFG_STREAM_SAMPLES | C.CFG_STREAM_CONTACTS
            client.command(C.CMD_CONFIG, (1000, 5_000_000, 4_000_000, 3, flags), timeout=5.0)
            client.start(timeout=5.0)
            samples, end = [], time.monotonic() + 20.0
            while len(samples) < 150 and time.monotonic() < end:
                samples += [m for m in client.read() if m.type_code == C.MSG_SAMPLE]
            client.stop(timeout=5.0)
            info = client.get_info(timeout=5.0)
        finally:
            client.close()
        said = _mpremote(server.path, "resume", "exec", LOADED)  # no soft reset
        ceilings = _mpremote(server.path, "resume", "exec", CEILINGS)
    assert len(samples) >= 150
    steps = [(b.timestamp_us - a.timestamp_us) & 0xFFFFFFFF for a, b in zip(samples, samples[1:])]
    # (a sample's time is the poll's that took it: the loop's wake-up moves it by microseconds,
    # on the emulator up to 15 us, its busy-wait skipping; the deadlines keep their phase)
    assert all(abs(d - 1000) <= 20 for d in steps), [d for d in steps if abs(d - 1000) > 20]
    assert abs(sum(steps) - 1000 * len(steps)) <= 20
    assert not any(m.flags & C.FLAG_LATE for m in samples)
    assert [b.seq - a.seq for a, b in zip(samples, samples[1:])] == [1] * len(steps)  # no STATUS
    assert all(abs(m.fz) < 2_000_000 for m in samples)  # the press scene's first 0.5 s: unloaded
    assert info.cal_id_0 == 4242 and info.max_rate_hz == 1100  # (the converters and bus: 1730)
    assert ceilings.split()[-4:] == ["[1100,", "550,", "130,", "60]"]  # Hz: 1 kHz native only
    assert "'tactile_native'" in said and "'tactile_fw.board'" not in said
    assert said.split()[-1] == calibration.Calibration(cal, 4242).to_bytes(0).hex()  # as Python
