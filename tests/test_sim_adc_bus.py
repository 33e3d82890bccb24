"""The simulated ADS122C04 and I2C bus: cached settings follow every change, fast path = slow.

The model derives period, gain and reference once per configuration (speed, issue 6);
these tests change the configuration after the cached values were used and check the
output follows, and that the bus's combined-transaction shortcut answers exactly as the
generic write-then-read does.
"""

import errno

import pytest

from tactile_fw import frontend
from tactile_fw.ads122c04 import CMD_RDATA, CMD_START, rreg, wreg
from tactile_fw.timing import ManualClock
from tactile_sim.adc_model import CODE_MAX, CODE_MIN, ADS122C04Model
from tactile_sim.i2c_bus import SimI2C

ADDR = 0x40
GAIN_128_EXT_2000SPS = (0x0E, 0xDA)  # CONFIG0 gain 128; CONFIG1 DR 6, turbo, continuous, ext ref


class GenericOnly:
    """The model seen only through write() and read_into(), as a device without the shortcut."""

    def __init__(self, model):
        self.model = model

    def write(self, data):
        self.model.write(data)

    def read_into(self, buf):
        self.model.read_into(buf)


def rig(volts=0.001, generic=False):
    clock = ManualClock(0)
    bus = SimI2C()
    model = ADS122C04Model(lambda: clock.t_us, source=lambda t: volts)
    bus.attach(ADDR, GenericOnly(model) if generic else model)
    return clock, bus, model


def configure(bus, c0, c1):
    bus.writeto_mem(ADDR, wreg(0), bytes((c0,)))
    bus.writeto_mem(ADDR, wreg(1), bytes((c1,)))
    bus.writeto(ADDR, bytes((CMD_START,)))


def rdata(bus):
    b = bytearray(3)
    bus.readfrom_mem_into(ADDR, CMD_RDATA, b)
    v = (b[0] << 16) | (b[1] << 8) | b[2]
    return v - (1 << 24) if v & 0x800000 else v


def drdy(bus):
    b = bytearray(1)
    bus.readfrom_mem_into(ADDR, rreg(2), b)
    return bool(b[0] & 0x80)


def test_a_gain_write_after_reads_changes_the_code():
    clock, bus, model = rig(volts=0.001)
    configure(bus, 0x00, 0xDA)  # gain 1, external 3.3 V reference
    clock.t_us = 1000
    at_gain_1 = rdata(bus)
    assert at_gain_1 == round(0.001 / 3.3 * (1 << 23))
    bus.writeto_mem(ADDR, wreg(0), bytes((0x0E,)))  # gain 128
    clock.t_us = 2000
    assert rdata(bus) == round(0.001 / (3.3 / 128) * (1 << 23)) != at_gain_1
    assert model.gain() == 128


def test_a_reference_write_after_reads_changes_the_code():
    clock, bus, model = rig(volts=0.001)
    configure(bus, 0x0E, 0xDA)  # external 3.3 V
    clock.t_us = 1000
    external = rdata(bus)
    bus.writeto_mem(ADDR, wreg(1), bytes((0xD8,)))  # internal 2.048 V, still continuous
    clock.t_us = 2000
    internal = rdata(bus)
    assert internal == round(0.001 / (2.048 / 128) * (1 << 23)) != external
    bus.writeto_mem(ADDR, wreg(1), bytes((0xDA,)))
    clock.t_us = 3000
    assert rdata(bus) == external
    model.vref_external = 1.0  # a property outside the registers: re-derives too
    clock.t_us = 4000
    assert rdata(bus) == round(0.001 / (1.0 / 128) * (1 << 23))
    bus.writeto_mem(ADDR, wreg(1), bytes((0xDC,)))  # reference AVDD (3.3 V)
    clock.t_us = 5000
    assert rdata(bus) == external
    model.avdd = 5.0
    clock.t_us = 6000
    assert rdata(bus) == round(0.001 / (5.0 / 128) * (1 << 23))


def test_a_rate_write_after_reads_changes_when_drdy_sets():
    clock, bus, model = rig()
    configure(bus, *GAIN_128_EXT_2000SPS)  # 2000 SPS: a conversion every 500 us
    clock.t_us = 500
    assert drdy(bus)
    rdata(bus)
    bus.writeto_mem(ADDR, wreg(1), bytes((0xC8,)))  # DR 6 without turbo: 1000 SPS
    bus.writeto(ADDR, bytes((CMD_START,)))  # restart at t = 500
    clock.t_us = 1000  # would be the next 2000 SPS conversion; not yet at 1000 SPS
    assert not drdy(bus)
    clock.t_us = 1500
    assert drdy(bus)
    assert model.period_us() == 1000.0 and model.rate_sps() == 1000


def test_a_period_override_set_after_construction_is_used():
    clock, bus, model = rig()
    configure(bus, *GAIN_128_EXT_2000SPS)
    clock.t_us = 1000
    assert model.conversions() == 2
    model.conv_period_override = 200.0  # the emulator sets it after building the models
    assert model.conversions() == 5 and model.period_us() == 200.0
    model.conv_period_override = None
    assert model.conversions() == 2


def test_reset_forgets_the_configuration():
    clock, bus, model = rig(volts=0.001)
    configure(bus, *GAIN_128_EXT_2000SPS)
    bus.writeto(ADDR, bytes((0x06,)))  # RESET
    assert model.regs == [0, 0, 0, 0] and model.gain() == 1 and model.rate_sps() == 20
    assert model.vref() == 2.048 and not model.running


def test_single_shot_gives_one_conversion_then_stops():
    clock, bus, model = rig(volts=0.001)
    configure(bus, 0x0E, 0xD2)  # CONFIG1 without CM: single shot
    clock.t_us = 5000
    assert model.conversions() == 1 and drdy(bus)
    rdata(bus)
    clock.t_us = 10000
    assert not drdy(bus)


def transcript(generic, volts_at):
    """Every register and data read of a run with faults, over one path."""
    clock = ManualClock(0)
    bus = SimI2C()
    model = ADS122C04Model(lambda: clock.t_us, source=volts_at)
    bus.attach(ADDR, GenericOnly(model) if generic else model)
    configure(bus, *GAIN_128_EXT_2000SPS)
    out = []
    buf3, buf2, buf1 = bytearray(3), bytearray(2), bytearray(1)
    for k in range(400):
        clock.t_us = 137 * k
        model.stuck_drdy = 100 <= k < 120
        model.saturate = 1 if 200 <= k < 210 else -1 if 210 <= k < 215 else 0
        for reg in range(4):
            bus.readfrom_mem_into(ADDR, rreg(reg), buf1)
            out.append(buf1[0])
        bus.readfrom_mem_into(ADDR, CMD_RDATA, buf3 if k % 3 else buf2)
        out.append(bytes(buf3 if k % 3 else buf2))
        if k % 50 == 7:  # a plain read repeats what the last command pointed at
            bus.readfrom_into(ADDR, buf3)
            out.append(bytes(buf3))
        if k == 300:
            bus.writeto_mem(ADDR, wreg(0), bytes((0x08,)))  # gain 16
        if k == 333:
            bus.readfrom_mem_into(ADDR, CMD_START, buf1)  # an odd command on the combined path
            out.append(buf1[0])
    return out, bus.transactions, bus.bits


def test_the_bus_shortcut_answers_as_write_then_read():
    volts_at = lambda t: 0.02 * ((t % 7919) / 7919.0 - 0.5)  # noqa: E731
    fast = transcript(False, volts_at)
    slow = transcript(True, volts_at)
    assert fast == slow
    codes = [v for v in fast[0] if isinstance(v, bytes)]
    assert len(set(codes)) > 100  # the run did exercise changing codes
    assert bytes((0x7F, 0xFF, 0xFF)) in codes and bytes((0x80, 0, 0)) in codes  # saturation


def test_bit_accounting_matches_the_firmware_budget():
    clock, bus, model = rig()
    configure(bus, *GAIN_128_EXT_2000SPS)
    bits = bus.bits
    drdy(bus)
    assert bus.bits - bits == frontend.BITS_STATUS
    bits = bus.bits
    rdata(bus)
    assert bus.bits - bits == frontend.BITS_RDATA
    bits = bus.bits
    bus.writeto_mem(ADDR, wreg(0), bytes((0x0E,)))  # addr+W, cmd, value: 3 bytes + start/stop
    bus.writeto(ADDR, bytes((CMD_START,)))  # addr+W, cmd
    assert bus.bits - bits == (9 * 3 + 2) + (9 * 2 + 2)


def test_bus_faults_apply_on_the_shortcut():
    clock, bus, model = rig()
    configure(bus, *GAIN_128_EXT_2000SPS)
    bus.fail_next(2)
    for _ in range(2):
        with pytest.raises(OSError) as e:
            drdy(bus)
        assert e.value.args[0] == errno.ETIMEDOUT
    drdy(bus)
    bus.nack.add(ADDR)
    with pytest.raises(OSError) as e:
        rdata(bus)
    assert e.value.args[0] == errno.ENODEV
    with pytest.raises(OSError):
        bus.readfrom_mem_into(0x41, rreg(2), bytearray(1))  # nothing at that address


def test_codes_clamp_at_full_scale():
    clock, bus, model = rig(volts=10.0)
    configure(bus, *GAIN_128_EXT_2000SPS)
    clock.t_us = 500
    assert rdata(bus) == CODE_MAX
    model.source = lambda t: -10.0
    clock.t_us = 1000
    assert rdata(bus) == CODE_MIN
