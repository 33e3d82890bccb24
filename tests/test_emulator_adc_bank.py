"""The C core's converters answered in C (``tactile_sim.emulator.adc_bank``, issue 29): the
same stream, counters and model state as through a Python callback per I2C transaction,
sensor faults and host commands included; and the same answer, read for read, as the
Python model at awkward periods, times and rounding ties."""

import ctypes
import random

import pytest
from toolchain import missing

from tactile_fw_tools import ccore
from tactile_protocol import constants as C
from tactile_protocol.framing import FrameEncoder
from tactile_sim.adc_model import CMD_RDATA, CMD_RREG, CMD_START, ADS122C04Model
from tactile_sim.emulator import cores, load_scene
from tactile_sim.emulator.adc_bank import AdcBank, library
from tactile_sim.emulator.device import EmulatedBoard
from tactile_sim.i2c_bus import SimI2C

FAULTS = """
[[sensor_fault]]
at_s = 0.1
kind = "i2c_timeout"
count = 3
[[sensor_fault]]
at_s = 0.15
kind = "i2c_timeout"
sensor = 3
count = 1
[[sensor_fault]]
at_s = 0.2
kind = "stuck_drdy"
sensor = 2
for_s = 0.03
[[sensor_fault]]
at_s = 0.3
kind = "i2c_nack"
sensor = 1
for_s = 0.02
[[sensor_fault]]
at_s = 0.4
kind = "saturate"
for_s = 0.01
"""


@pytest.fixture(scope="module")
def bank_lib():
    try:
        cores.c_library()
    except cores.CoreUnavailable as exc:
        missing(str(exc))
    return library()


def _scene(tmp_path, board, extra=""):
    text = load_scene("press").path.read_text()  # a noisy transducer: the draws' order counts
    text = text.replace("[board]\n", "[board]\n" + board + "\n", 1).replace(
        "\nrate_hz = 1000\n", "\n", 1
    )
    path = tmp_path / "bank.toml"
    path.write_text(text + "\n" + extra)
    return load_scene(path)


def _host():
    enc = FrameEncoder()
    return [
        (60_000, bytes(enc.encode(C.CMD_TARE, 0, (C.SENSOR_ALL, 20)))),
        (250_000, bytes(enc.encode(C.CMD_STOP, 0, ()))),
        (270_000, bytes(enc.encode(C.CMD_START, 0, ()))),
    ]


def _run(scene, i2c, monkeypatch, untagged=()):
    monkeypatch.setattr(cores, "C_I2C", i2c)
    emu = EmulatedBoard(scene, boot_id=0x29C, core="c", board_id=b"bank-id1")
    assert (emu.board._i2c is not None) == (i2c == "bank")
    for k in untagged:  # a source the bank cannot mirror: its reads go through Python
        emu.adcs[k].source = lambda t, f=emu.adcs[k].source: f(t)
    out, t, plan = bytearray(), 0, _host()
    while t < 500_000:
        t += 5_000
        while plan and plan[0][0] <= t:
            emu.write_host(plan.pop(0)[1])
        emu.run_until(t)
        out += emu.read_host()
    state = [(a.n_read, a.code, a._ptr, a.t_start, a.running, a.regs) for a in emu.adcs]
    buses = [(b.transactions, b.bits) for b in emu.buses]
    stats = [
        emu.board.stat(name) for name in ("samples", "i2c_errors", "drdy_timeouts", "saturations")
    ]
    return bytes(out), state, buses, stats


@pytest.mark.parametrize(
    "board, untagged",
    [
        ("sensors = 4\nrate_hz = 5000\nmax_rate_hz = 5000", ()),
        ("sensors = 4\nrate_hz = 700", ()),
        ("sensors = 4\nrate_hz = 800", (3, 13)),  # two converters left to Python mid-sample
    ],
)
def test_the_bank_gives_the_callbacks_stream_to_the_byte(
    bank_lib, tmp_path, monkeypatch, board, untagged
):
    scene = _scene(tmp_path, board, FAULTS)
    slow = _run(scene, "callbacks", monkeypatch, untagged)
    fast = _run(scene, "bank", monkeypatch, untagged)
    assert len(slow[0]) > 20_000
    assert fast[0] == slow[0]
    assert fast[1:] == slow[1:]
    samples, i2c_errors, drdy_timeouts, saturations = slow[3]
    assert i2c_errors >= 2 and drdy_timeouts >= 1 and saturations >= 1  # the faults acted


def _pair(period, gauges):
    """Two converters on one clock and source: one read through Python, one through C."""
    clock = [0]
    pair = []
    for _ in range(2):
        bus, adc = SimI2C(), ADS122C04Model(lambda: clock[0], conv_period_us=period)
        src = EmulatedBoard._gauge_source(
            type("M", (), {"gauge_values": staticmethod(gauges)}), adc, 2
        )
        adc.source = src
        bus.attach(0x40, adc)
        bus.writeto(0x40, bytes([0x40 | 1 << 2, 0x08 | 0x10 | 0x02]))  # continuous, turbo, ext ref
        bus.writeto(0x40, bytes([CMD_START]))
        pair.append((bus, adc))
    return clock, pair


@pytest.mark.parametrize("period", [1e6 / 3000, 1e6 / 7, 200.0, 0.1 + 0.2, 0.1])  # 1 // 0.1 == 9
def test_every_read_answers_as_the_python_model(bank_lib, period):
    rng = random.Random(int(period * 1000))
    ties = [k + 0.5 for k in range(-4, 4)] + [1e12, -1e12, 0.49999999999999994, 8388606.5]

    def gauges(t):
        return [0.0, 0.0, rng.choice(ties) if int(t) % 3 else t * 1e3, 0.0, 0.0, 0.0]

    clock, ((pbus, padc), (cbus, cadc)) = _pair(period, lambda t: gauges(t))
    bank, fallbacks = AdcBank([cbus]), []

    def py_read(ctx, bus, addr, cmd, buf, n):  # what C leaves to Python (none here)
        fallbacks.append(cmd)
        cbus.readfrom_mem_into(addr, cmd, (ctypes.c_uint8 * n).from_address(buf))
        return 0

    keep = ccore.I2C_WRITE(), ccore.I2C_READ(py_read)
    ctx, _, read = bank.attach(*keep)
    c_read = ccore.I2C_READ(read)
    for _ in range(3000):
        clock[0] += rng.choice(
            [0, 1, int(period), int(period) + 1, rng.randrange(5 * int(period) + 1)]
        )
        cmd = rng.choice([CMD_RREG | 2 << 2, CMD_RDATA, CMD_RDATA, CMD_RREG | 1 << 2])
        n = rng.choice([1, 3, 3, 4])
        pbuf, cbuf = bytearray(n), (ctypes.c_uint8 * n)()
        rng_state = rng.getstate()
        pbus.readfrom_mem_into(0x40, cmd, pbuf)
        rng.setstate(rng_state)  # the C side's gauges draw the same choice
        bank.enter()
        assert c_read(ctx, 0, 0x40, cmd, ctypes.addressof(cbuf), n) == 0
        bank.leave()
        assert bytes(cbuf) == bytes(pbuf), (clock[0], cmd, n)
        assert (cadc.n_read, cadc.code, cadc._ptr) == (padc.n_read, padc.code, padc._ptr)
    assert (cbus.transactions, cbus.bits) == (pbus.transactions, pbus.bits)
    assert not fallbacks
