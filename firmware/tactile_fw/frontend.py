"""Gauge front end: six ADS122C04 per F/T sensor, one converter per gauge.

Each strain-gauge bridge of the transducer (ATI-style, six gauges, thesis
ch. 5) has its own converter running continuously, so every sample needs no
multiplexer settling: the ceiling is the converter's data rate or the I2C
time to poll DRDY and read six results, whichever is lower (docs/firmware.md).

A ``Sensor`` gathers the six codes of one sample without blocking: ``poll()``
reads each converter whose DRDY is set and returns True once all six are
fresh.  Bus errors propagate as ``OSError``.
"""

from tactile_fw.ads122c04 import CODE_MAX, CODE_MIN
from tactile_protocol.constants import const

N_GAUGES = const(6)
ALL_FRESH = const(0x3F)

# I2C bit-times per converter per sample, start/stop/ack included:
# RREG CONFIG2 (addr+W, cmd, Sr, addr+R, 1 byte) and RDATA (addr+W, cmd, Sr, addr+R, 3 bytes).
BITS_STATUS = const(39)
BITS_RDATA = const(57)
BITS_PER_CONVERTER = const(96)


class Sensor:
    """Six converters (gauge order g0..g5) on one bus, read without blocking."""

    def __init__(self, adcs, bus_key=0, bus_hz=1000000):
        if len(adcs) != N_GAUGES:
            raise ValueError("a sensor needs %d converters, got %d" % (N_GAUGES, len(adcs)))
        self.adcs = adcs
        self.bus_key = bus_key
        self.bus_hz = bus_hz
        self.counts = [0] * N_GAUGES
        self.fresh = 0  # bit j: counts[j] holds this sample's code
        self.saturated = 0  # bit j: gauge j at a full-scale code

    def init(self):
        for adc in self.adcs:
            adc.init()
        self.fresh = 0

    def poll(self):
        """Read every converter with DRDY set; True once all six are fresh."""
        adcs = self.adcs
        counts = self.counts
        fresh = self.fresh
        for j in range(N_GAUGES):
            bit = 1 << j
            if fresh & bit:
                continue
            adc = adcs[j]
            if adc.ready():
                counts[j] = adc.read()
                fresh |= bit
        if fresh != ALL_FRESH:
            self.fresh = fresh
            return False
        self.fresh = 0
        sat = 0
        for j in range(N_GAUGES):
            c = counts[j]
            if c >= CODE_MAX or c <= CODE_MIN:
                sat |= 1 << j
        self.saturated = sat
        return True

    def rate_sps(self):
        r = self.adcs[0].rate_sps
        for adc in self.adcs:
            if adc.rate_sps < r:
                r = adc.rate_sps
        return r


def max_rate_hz(sensors):
    """Sample-rate ceiling: converter data rate and I2C time per bus, whichever binds.

    Rounded down to 10 Hz.  CPU time is not included (see bench/fw_sample_cost.py).
    """
    if not sensors:
        return 0
    load = {}
    for s in sensors:
        key = s.bus_key
        load[key] = load.get(key, 0) + N_GAUGES * BITS_PER_CONVERTER
    ceiling = min(s.rate_sps() for s in sensors)
    for s in sensors:
        bus_rate = s.bus_hz // load[s.bus_key]
        if bus_rate < ceiling:
            ceiling = bus_rate
    return (ceiling // 10) * 10


# Address plan: up to two sensors per bus (12 of the part's 16 addresses).
ADDRESS_PLAN = (
    (0x40, 0x41, 0x42, 0x43, 0x44, 0x45),
    (0x46, 0x47, 0x48, 0x49, 0x4A, 0x4B),
)


def make_sensor(bus, slot=0, bus_key=0, bus_hz=1000000, **adc_settings):
    """A sensor of six ADS122C04 at ``ADDRESS_PLAN[slot]`` on ``bus``."""
    from tactile_fw.ads122c04 import ADS122C04

    adcs = [ADS122C04(bus, a, **adc_settings) for a in ADDRESS_PLAN[slot]]
    return Sensor(adcs, bus_key, bus_hz)
