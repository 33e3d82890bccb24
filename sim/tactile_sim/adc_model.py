"""Register-level model of the TI ADS122C04 on a simulated clock.

What the firmware's driver relies on, after the datasheet (SBAS752):
commands RESET/START/POWERDOWN/RDATA/RREG/WREG, four config registers,
DRDY (CONFIG2 bit 7) set when a conversion completes and cleared by RDATA,
continuous and single-shot modes, data rate 20-1000 SPS (x2 in turbo),
PGA gain 1-128, 24-bit two's complement codes clamped at full scale.

The analog input is ``source(t_us) -> volts`` (differential, at the
selected mux), sampled at each conversion's end.  Faults: ``stuck_drdy``
(conversions stop, DRDY never sets), ``saturate`` (+1/-1 forces positive or
negative full scale).  ``conv_period_us`` overrides the data rate (emulator
benches beyond the part's 2 kSPS; not the real part).
"""

CMD_RESET = 0x06
CMD_START = 0x08
CMD_POWERDOWN = 0x02
CODE_MAX = 0x7FFFFF
CODE_MIN = -0x800000
DATA_RATES = (20, 45, 90, 175, 330, 600, 1000)
VREF_INTERNAL_V = 2.048


class ADS122C04Model:
    def __init__(self, clock_us, source=None, vref_external=3.3, avdd=3.3, conv_period_us=None):
        self.clock_us = clock_us
        self.source = source or (lambda t: 0.0)
        self.vref_external = vref_external
        self.avdd = avdd
        self.conv_period_override = conv_period_us
        self.stuck_drdy = False
        self.saturate = 0
        self.reset()

    # --- state --------------------------------------------------------------------
    def reset(self):
        self.regs = [0, 0, 0, 0]
        self.running = False
        self.t_start = 0
        self.n_read = 0  # conversions consumed by RDATA
        self.code = 0
        self._ptr = None  # what the next read returns: a register index or "data"

    def gain(self):
        return 1 << ((self.regs[0] >> 1) & 0x7)

    def rate_sps(self):
        sps = DATA_RATES[min((self.regs[1] >> 5) & 0x7, 6)]
        return sps * 2 if self.regs[1] & 0x10 else sps

    def period_us(self):
        return self.conv_period_override or 1e6 / self.rate_sps()

    def vref(self):
        sel = (self.regs[1] >> 1) & 0x3
        return VREF_INTERNAL_V if sel == 0 else self.vref_external if sel == 1 else self.avdd

    def conversions(self):
        """Conversions completed since START (single-shot stops after one)."""
        if not self.running:
            return self.n_read
        n = int((self.clock_us() - self.t_start) // self.period_us())
        if not self.regs[1] & 0x08:
            n = min(n, 1)
        if self.stuck_drdy:
            return self.n_read  # no conversion completes: DRDY stays low
        return n

    def code_for(self, volts):
        fs = self.vref() / self.gain()
        c = round(volts / fs * (1 << 23))
        return max(CODE_MIN, min(CODE_MAX, c))

    def volts_for_code(self, code):
        return code * self.vref() / self.gain() / (1 << 23)

    def _latest_code(self, n):
        if self.saturate:
            return CODE_MAX if self.saturate > 0 else CODE_MIN
        t_end = self.t_start + n * self.period_us()
        return self.code_for(self.source(t_end))

    # --- I2C transactions ---------------------------------------------------------
    def write(self, data):
        cmd = data[0]
        if cmd & 0xFE == CMD_RESET:
            self.reset()
        elif cmd & 0xFE == CMD_START:
            self.running = True
            self.t_start = self.clock_us()
            self.n_read = 0
        elif cmd & 0xFE == CMD_POWERDOWN:
            self.running = False
        elif cmd & 0xF0 == 0x10:  # RDATA
            self._ptr = "data"
        elif cmd & 0xF0 == 0x20:  # RREG
            self._ptr = (cmd >> 2) & 0x3
        elif cmd & 0xF0 == 0x40 and len(data) == 2:  # WREG
            reg = (cmd >> 2) & 0x3
            value = data[1]
            if reg == 2:
                value &= 0x7F  # DRDY is read-only
            self.regs[reg] = value
        # anything else: the part ignores it

    def read_into(self, buf):
        if self._ptr == "data":
            n = self.conversions()
            if n > 0 and n != self.n_read:
                self.code = self._latest_code(n)
            self.n_read = n
            u = self.code & 0xFFFFFF
            out = (u >> 16, (u >> 8) & 0xFF, u & 0xFF)
            for k in range(min(3, len(buf))):
                buf[k] = out[k]
            return
        reg = self._ptr if self._ptr is not None else 0
        value = self.regs[reg]
        if reg == 2 and self.conversions() > self.n_read:
            value |= 0x80
        for k in range(len(buf)):
            buf[k] = value
