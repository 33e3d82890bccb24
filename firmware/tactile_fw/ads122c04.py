"""TI ADS122C04 driver: 24-bit delta-sigma ADC, 4 inputs, PGA 1-128, I2C.

Register map and commands from the datasheet (SBAS752, §8.5-8.6); every bus
access goes through the injected ``machine.I2C``-style object:

- a command byte followed by a repeated-start read is ``readfrom_mem_into(addr,
  cmd, buf)`` (RREG, RDATA);
- WREG is ``writeto_mem(addr, WREG | reg << 2, value)``;
- RESET, START/SYNC and POWERDOWN are ``writeto(addr, cmd)``.

Bus errors propagate as ``OSError`` (MicroPython raises ENODEV on a NACK and
ETIMEDOUT on a bus timeout); the front end turns them into faults.
"""

try:
    from micropython import const
except ImportError:  # CPython

    def const(x):
        return x


# --- commands (datasheet table 16) ----------------------------------------------
CMD_RESET = const(0x06)  # 0000 011x
CMD_START = const(0x08)  # 0000 100x  START/SYNC
CMD_POWERDOWN = const(0x02)  # 0000 001x
CMD_RDATA = const(0x10)  # 0001 xxxx  then read 3 bytes, MSB first
CMD_RREG = const(0x20)  # 0010 rrxx  rr = register
CMD_WREG = const(0x40)  # 0100 rrxx  then the value

# --- registers ----------------------------------------------------------------------
REG_CONFIG0 = const(0)  # MUX[3:0] | GAIN[2:0] | PGA_BYPASS
REG_CONFIG1 = const(1)  # DR[2:0] | MODE | CM | VREF[1:0] | TS
REG_CONFIG2 = const(2)  # DRDY (read-only) | DCNT | CRC[1:0] | BCS | IDAC[2:0]
REG_CONFIG3 = const(3)  # I1MUX[2:0] | I2MUX[2:0] | 00

# CONFIG0
MUX_SHIFT = const(4)
MUX_AIN0_AIN1 = const(0x0)
MUX_AIN2_AIN3 = const(0x6)
MUX_SHORTED = const(0xE)  # inputs shorted to mid-supply: offset check
GAIN_SHIFT = const(1)
PGA_BYPASS = const(0x01)  # 1 = PGA bypassed (only gains 1, 2, 4)

# CONFIG1
DR_SHIFT = const(5)
MODE_TURBO = const(0x10)  # doubles every data rate
CM_CONTINUOUS = const(0x08)
VREF_INTERNAL = const(0x00)  # 2.048 V
VREF_EXTERNAL = const(0x02)  # REFP - REFN (ratiometric bridge excitation)
VREF_AVDD = const(0x04)

# CONFIG2
DRDY = const(0x80)

CODE_MAX = const(0x7FFFFF)  # positive full scale
CODE_MIN = const(-0x800000)  # negative full scale

# normal-mode data rates by DR code; turbo mode doubles them (datasheet table 12)
DATA_RATES = (20, 45, 90, 175, 330, 600, 1000)
GAINS = (1, 2, 4, 8, 16, 32, 64, 128)
ADDRESSES = tuple(range(0x40, 0x50))  # A1, A0 each strapped to DGND/DVDD/SDA/SCL


def rreg(reg):
    return CMD_RREG | (reg << 2)


def wreg(reg):
    return CMD_WREG | (reg << 2)


def config_bytes(mux, gain, dr_code, turbo, continuous, vref):
    """CONFIG0 and CONFIG1 values; ValueError on a setting the part lacks."""
    if gain not in GAINS:
        raise ValueError("ADS122C04: gain %r not in %r" % (gain, GAINS))
    if not 0 <= dr_code < len(DATA_RATES):
        raise ValueError("ADS122C04: data-rate code %r out of range" % (dr_code,))
    c0 = (mux << MUX_SHIFT) | (GAINS.index(gain) << GAIN_SHIFT)
    c1 = (dr_code << DR_SHIFT) | vref
    if turbo:
        c1 |= MODE_TURBO
    if continuous:
        c1 |= CM_CONTINUOUS
    return c0, c1


def data_rate_sps(config1):
    """Output data rate in samples/s for a CONFIG1 value."""
    sps = DATA_RATES[(config1 >> DR_SHIFT) & 0x07]
    return sps * 2 if config1 & MODE_TURBO else sps


def to_signed24(b0, b1, b2):
    """24-bit two's complement, MSB first, to a Python int."""
    v = (b0 << 16) | (b1 << 8) | b2
    return v - 0x1000000 if v & 0x800000 else v


class ADS122C04:
    """One converter on an injected I2C bus; buffers preallocated."""

    def __init__(
        self, bus, addr, mux=MUX_AIN0_AIN1, gain=128, dr_code=6, turbo=True, vref=VREF_EXTERNAL
    ):
        if addr not in ADDRESSES:
            raise ValueError("ADS122C04: address 0x%02x not in 0x40-0x4F" % addr)
        self.bus = bus
        self.addr = addr
        self.config0, self.config1 = config_bytes(mux, gain, dr_code, turbo, True, vref)
        self.rate_sps = data_rate_sps(self.config1)
        self._b1 = bytearray(1)
        self._b3 = bytearray(3)
        self._cmd = bytearray(1)

    def _command(self, cmd):
        self._cmd[0] = cmd
        self.bus.writeto(self.addr, self._cmd)

    def write_reg(self, reg, value):
        self._b1[0] = value
        self.bus.writeto_mem(self.addr, wreg(reg), self._b1)

    def read_reg(self, reg):
        self.bus.readfrom_mem_into(self.addr, rreg(reg), self._b1)
        return self._b1[0]

    def init(self):
        """RESET, write and verify CONFIG0/1, START continuous conversions."""
        self._command(CMD_RESET)
        self.write_reg(REG_CONFIG0, self.config0)
        self.write_reg(REG_CONFIG1, self.config1)
        if self.read_reg(REG_CONFIG0) != self.config0 or self.read_reg(REG_CONFIG1) != (
            self.config1
        ):
            raise OSError(5, "ADS122C04 at 0x%02x: config readback mismatch" % self.addr)
        self._command(CMD_START)

    def powerdown(self):
        self._command(CMD_POWERDOWN)

    def ready(self):
        """DRDY: a conversion finished since the last RDATA."""
        self.bus.readfrom_mem_into(self.addr, rreg(REG_CONFIG2), self._b1)
        return self._b1[0] & DRDY != 0

    def read(self):
        """RDATA: the latest conversion as a signed 24-bit code."""
        b = self._b3
        self.bus.readfrom_mem_into(self.addr, CMD_RDATA, b)
        return to_signed24(b[0], b[1], b[2])
