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

Speed: what the registers imply (period, gain, reference, full scale) is
derived once per change, in ``_configure``, after RESET and WREG (the only
ways the part's registers change) and when one of the three analog settings
outside them (``conv_period_override``, ``vref_external``, ``avdd``, all
properties) is set.  Runs on MicroPython too (tests/test_fw_micropython.py).

``watch``: None or ``f(model)``, called when something outside the I2C transactions
changes the model (a fault knob, the source, an analog setting, a RESET or WREG): the
emulator's C mirror of the converters (``emulator/adc_bank``) takes the change then.
"""

CMD_RESET = 0x06
CMD_START = 0x08
CMD_POWERDOWN = 0x02
CMD_RDATA = 0x10
CMD_RREG = 0x20
CODE_MAX = 0x7FFFFF
CODE_MIN = -0x800000
DATA_RATES = (20, 45, 90, 175, 330, 600, 1000)
VREF_INTERNAL_V = 2.048
FULL_SCALE_CODES = 1 << 23
_DATA = -1  # ``_ptr`` value: the next read returns the conversion result


class ADS122C04Model:
    def __init__(self, clock_us, source=None, vref_external=3.3, avdd=3.3, conv_period_us=None):
        self.watch = None
        self.clock_us = clock_us
        self._source = source or (lambda t: 0.0)
        self._vref_external = vref_external
        self._avdd = avdd
        self._override = conv_period_us
        self._stuck = False
        self._saturate = 0
        self.reset()

    def _changed(self):
        if self.watch is not None:
            self.watch(self)

    # --- fault knobs and the analog input: a change is reported to ``watch`` ----------
    @property
    def stuck_drdy(self):
        return self._stuck

    @stuck_drdy.setter
    def stuck_drdy(self, stuck):
        self._stuck = stuck
        self._changed()

    @property
    def saturate(self):
        return self._saturate

    @saturate.setter
    def saturate(self, sign):
        self._saturate = sign
        self._changed()

    @property
    def source(self):
        return self._source

    @source.setter
    def source(self, fn):
        self._source = fn
        self._changed()

    # --- settings outside the registers: changing one re-derives the cache ------------
    @property
    def conv_period_override(self):
        return self._override

    @conv_period_override.setter
    def conv_period_override(self, period_us):
        self._override = period_us
        self._configure()

    @property
    def vref_external(self):
        return self._vref_external

    @vref_external.setter
    def vref_external(self, volts):
        self._vref_external = volts
        self._configure()

    @property
    def avdd(self):
        return self._avdd

    @avdd.setter
    def avdd(self, volts):
        self._avdd = volts
        self._configure()

    # --- state --------------------------------------------------------------------
    def reset(self):
        self.regs = [0, 0, 0, 0]  # changed by WREG (then _configure), as on the part
        self.running = False
        self.t_start = 0
        self.n_read = 0  # conversions consumed by RDATA
        self.code = 0
        self._ptr = None  # what the next read returns: a register index or _DATA
        self._configure()

    def _configure(self):
        """Derive period, gain and reference from the registers (after RESET or WREG)."""
        c0, c1 = self.regs[0], self.regs[1]
        self.pga_gain = 1 << ((c0 >> 1) & 0x7)
        sps = DATA_RATES[min((c1 >> 5) & 0x7, 6)]
        self._rate_sps = sps * 2 if c1 & 0x10 else sps
        self.period = self._override or 1e6 / self._rate_sps
        self.continuous = bool(c1 & 0x08)
        sel = (c1 >> 1) & 0x3
        self.vref_v = (
            VREF_INTERNAL_V if sel == 0 else self._vref_external if sel == 1 else self._avdd
        )
        self._fs = self.vref_v / self.pga_gain
        self._changed()

    def gain(self):
        return self.pga_gain

    def rate_sps(self):
        return self._rate_sps

    def period_us(self):
        return self.period

    def vref(self):
        return self.vref_v

    def conversions(self):
        """Conversions completed since START (single-shot stops after one)."""
        if not self.running or self._stuck:  # stuck: no conversion completes
            return self.n_read
        n = int((self.clock_us() - self.t_start) // self.period)
        if n > 1 and not self.continuous:
            return 1
        return n

    def code_for(self, volts):
        c = round(volts / self._fs * FULL_SCALE_CODES)
        return CODE_MAX if c > CODE_MAX else CODE_MIN if c < CODE_MIN else c

    def volts_for_code(self, code):
        return code * self.vref_v / self.pga_gain / FULL_SCALE_CODES

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
            self._ptr = _DATA
        elif cmd & 0xF0 == 0x20:  # RREG
            self._ptr = (cmd >> 2) & 0x3
        elif cmd & 0xF0 == 0x40 and len(data) == 2:  # WREG
            reg = (cmd >> 2) & 0x3
            value = data[1]
            if reg == 2:
                value &= 0x7F  # DRDY is read-only
            self.regs[reg] = value
            self._configure()
        # anything else: the part ignores it
        self._changed()

    def read_into(self, buf):
        """A plain read: what the last RDATA or RREG pointed at (CONFIG0 after RESET)."""
        ptr = self._ptr
        self.read_mem_into(CMD_RDATA if ptr == _DATA else CMD_RREG | (ptr or 0) << 2, buf)

    def read_mem_into(self, cmd, buf):
        """A command byte, repeated start, then a read: ``write(bytes((cmd,)))`` + ``read_into``.

        RDATA and RREG, the sampling loop's two, are answered here without building
        the command's bytes; any other command goes through ``write``.
        """
        kind = cmd & 0xF0
        if kind == 0x20:  # RREG
            reg = self._ptr = (cmd >> 2) & 0x3
            value = self.regs[reg]
            if reg == 2 and self.conversions() > self.n_read:
                value |= 0x80  # DRDY
            if len(buf) == 1:
                buf[0] = value
            else:
                for k in range(len(buf)):
                    buf[k] = value
        elif kind == 0x10:  # RDATA: the latest conversion, sampled at its end; clears DRDY
            self._ptr = _DATA
            n = self.conversions()
            if n > 0 and n != self.n_read:
                if self._saturate:
                    self.code = CODE_MAX if self._saturate > 0 else CODE_MIN
                else:
                    self.code = self.code_for(self._source(self.t_start + n * self.period))
            self.n_read = n
            u = self.code & 0xFFFFFF
            if len(buf) >= 3:
                buf[0] = u >> 16
                buf[1] = (u >> 8) & 0xFF
                buf[2] = u & 0xFF
            else:
                for k in range(len(buf)):
                    buf[k] = (u >> (16 - 8 * k)) & 0xFF
        else:
            self.write(bytes((cmd,)))
            self.read_into(buf)
