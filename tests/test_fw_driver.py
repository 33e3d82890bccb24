"""ADS122C04 driver against the register-level model; the front end's I2C budget."""

import pytest

from tactile_fw import ads122c04, board, frontend, gate
from tactile_fw.ads122c04 import ADS122C04, config_bytes, to_signed24
from tactile_fw.timing import ManualClock
from tactile_protocol import constants as C
from tactile_sim.adc_model import ADS122C04Model
from tactile_sim.i2c_bus import SimI2C


def test_config_bits_follow_the_datasheet():
    # CONFIG0: MUX[7:4] GAIN[3:1] PGA_BYPASS[0]; CONFIG1: DR[7:5] MODE[4] CM[3] VREF[2:1] TS[0]
    c0, c1 = config_bytes(ads122c04.MUX_AIN0_AIN1, 128, 6, True, True, ads122c04.VREF_EXTERNAL)
    assert c0 == 0b0000_1110
    assert c1 == 0b110_1_1_01_0
    assert ads122c04.data_rate_sps(c1) == 2000
    c0, c1 = config_bytes(ads122c04.MUX_AIN2_AIN3, 1, 0, False, False, ads122c04.VREF_INTERNAL)
    assert (c0, c1) == (0x60, 0x00) and ads122c04.data_rate_sps(c1) == 20
    assert ads122c04.rreg(2) == 0x28 and ads122c04.wreg(1) == 0x44
    with pytest.raises(ValueError):
        config_bytes(0, 3, 6, True, True, 0)


@pytest.mark.parametrize(
    "raw, value",
    [
        ((0x7F, 0xFF, 0xFF), 8388607),
        ((0x80, 0, 0), -8388608),
        ((0xFF, 0xFF, 0xFF), -1),
        ((0, 0, 1), 1),
        ((0, 0, 0), 0),
    ],
)
def test_two_complement_24_bit(raw, value):
    assert to_signed24(*raw) == value


def setup(volts=0.0):
    clock = ManualClock(0)
    bus = SimI2C()
    model = bus.attach(0x40, ADS122C04Model(lambda: clock.t_us, source=lambda t: volts))
    return clock, bus, model, ADS122C04(bus, 0x40)


def test_init_writes_and_verifies_the_configuration():
    clock, bus, model, adc = setup()
    adc.init()
    assert model.regs[:2] == [adc.config0, adc.config1] and model.running
    assert model.rate_sps() == adc.rate_sps == 2000


def test_readback_mismatch_is_an_oserror(mocker):
    clock, bus, model, adc = setup()
    mocker.patch.object(model, "write", side_effect=lambda data: None)  # writes get lost
    with pytest.raises(OSError):
        adc.init()


def test_missing_device_is_enodev():
    clock, bus, model, adc = setup()
    bus.nack.add(0x40)
    with pytest.raises(OSError) as e:
        adc.init()
    assert e.value.args[0] == 19
    with pytest.raises(ValueError):
        ADS122C04(bus, 0x3F)


def test_data_ready_timing_and_codes():
    volts = 0.01
    clock, bus, model, adc = setup(volts)
    adc.init()
    assert not adc.ready()
    clock.advance(499)
    assert not adc.ready()
    clock.advance(1)  # one conversion at 2 kSPS: 500 us
    assert adc.ready()
    full_scale = 3.3 / 128  # external reference / gain
    assert adc.read() == round(volts / full_scale * 2**23)
    assert not adc.ready()  # RDATA clears DRDY
    clock.advance(500)
    assert adc.ready()


def test_saturation_codes_and_mask():
    clock = ManualClock(0)
    bus = SimI2C()
    models = [bus.attach(a, ADS122C04Model(lambda: clock.t_us)) for a in frontend.ADDRESS_PLAN[0]]
    models[1].source = lambda t: 1.0  # far above 3.3 V / 128
    models[4].source = lambda t: -1.0
    sensor = frontend.make_sensor(bus, 0)
    sensor.init()
    clock.advance(600)
    assert sensor.poll()
    assert sensor.counts[1] == ads122c04.CODE_MAX and sensor.counts[4] == ads122c04.CODE_MIN
    assert sensor.saturated == 0b010010


def test_poll_reads_only_fresh_converters_and_costs_96_bits_each():
    clock = ManualClock(0)
    bus = SimI2C()
    models = [bus.attach(a, ADS122C04Model(lambda: clock.t_us)) for a in frontend.ADDRESS_PLAN[0]]
    sensor = frontend.make_sensor(bus, 0)
    sensor.init()
    models[5].stuck_drdy = True
    clock.advance(600)
    assert not sensor.poll() and sensor.fresh == 0b011111
    models[5].stuck_drdy = False
    bits = bus.bits
    assert sensor.poll() and sensor.fresh == 0
    assert bus.bits - bits == frontend.BITS_PER_CONVERTER  # only the missing one was read
    clock.advance(600)
    bits = bus.bits
    assert sensor.poll()
    assert bus.bits - bits == 6 * frontend.BITS_PER_CONVERTER


@pytest.mark.parametrize(
    "n_on_bus, bus_hz, dr_code, turbo, ceiling",
    [
        (1, 1_000_000, 6, True, 1730),  # bus: 1e6 / 576 = 1736 < 2000 SPS
        (1, 400_000, 6, True, 690),  # fast mode: 694
        (2, 1_000_000, 6, True, 860),  # two sensors share a bus: 868
        (1, 1_000_000, 6, False, 1000),  # normal mode: the converter binds
        (1, 1_000_000, 4, False, 330),
    ],
)
def test_sample_rate_ceiling(n_on_bus, bus_hz, dr_code, turbo, ceiling):
    bus = SimI2C()
    sensors = [
        frontend.make_sensor(bus, k, 0, bus_hz, dr_code=dr_code, turbo=turbo)
        for k in range(n_on_bus)
    ]
    assert frontend.max_rate_hz(sensors) == ceiling


def test_two_buses_keep_the_single_bus_ceiling():
    sensors = [frontend.make_sensor(SimI2C(), 0, key) for key in (0, 1)]
    assert frontend.max_rate_hz(sensors) == 1730


def test_firmware_constants_agree_with_the_protocol():
    assert (gate.BEGIN, gate.IN, gate.END) == (C.PHASE_BEGIN, C.PHASE_IN, C.PHASE_END)
    assert board._SENSOR_FAULTS == C.FAULT_I2C | C.FAULT_DRDY_STUCK
    assert frontend.ALL_FRESH == C.FLAG_SAT_MASK
