"""The board: one non-blocking ``poll()`` that samples, gates, streams and obeys.

Everything is injected: the sensors (``frontend.Sensor``, each on its bus),
the byte link (``link``), the clock (``timing``), the storage for settings
and calibration, and ``boot_id``, a 32-bit number that differs from one
power-up to the next (the entry point draws it: ``boot_id_from(os.urandom(8))``),
which HELLO and INFO carry so the host can tell a reboot from lost frames, and
``board_id``, 8 bytes that name the board for its life (the entry point reads the chip's
unique id: ``tactile_fw.identity``), so that a host can tell its board from another.
``poll()`` does one bounded step and returns; a real board calls it forever
(``run``), the emulator calls it on simulated time.  Per-sample work reuses
preallocated lists and the encoder's buffers.

Faults (PROTOCOL STATUS): an I2C error or a converter whose DRDY does not
come within ``drdy_timeout_us`` puts that sensor in a fault state; a STATUS
goes out at once, the sensor is re-initialised after a backoff that doubles
from ``BACKOFF_MIN_US`` to ``BACKOFF_MAX_US``, and its first good sample
sends STATUS with FAULT_RECOVERED.  The other sensors keep streaming.
Saturation is reported per sample (flags) and by STATUS on entry and exit.
Overruns and frames dropped for a host that is not reading are counted and
reported by a STATUS at most once per ``status_period_us``.
"""

from tactile_fw import calibration, frontend, gate, settings
from tactile_fw.commands import dispatch
from tactile_fw.identity import FW_VERSION, NO_BOARD_ID, board_id_from
from tactile_fw.link import TxRing
from tactile_fw.timing import Scheduler
from tactile_protocol.constants import (
    CFG_AUTOSTART,
    CFG_GATE_3D,
    CFG_STREAM_CONTACTS,
    CFG_STREAM_SAMPLES,
    CFG_STREAMING,
    CMD_TARE,
    FAULT_DRDY_STUCK,
    FAULT_I2C,
    FAULT_NO_CALIBRATION,
    FAULT_OVERRUN,
    FAULT_RECOVERED,
    FAULT_SATURATION,
    FAULT_TX_DROPPED,
    FLAG_IN_CONTACT,
    FLAG_LATE,
    MAX_SENSORS,
    MSG_ACK,
    MSG_CONTACT,
    MSG_HELLO,
    MSG_INFO,
    MSG_NAK,
    MSG_SAMPLE,
    MSG_STATUS,
    NAK_DETAIL_NONE,
    NAK_HARDWARE,
    NAK_LOADED,
    PROTOCOL_VERSION,
    SENSOR_ALL,
    const,
)
from tactile_protocol.framing import FRAME_OK, FrameAssembler, FrameEncoder

SENSOR_MODEL = b"FT6/ADS122C04x6"
BACKOFF_MIN_US = const(1000)
BACKOFF_MAX_US = const(1000000)
STATUS_PERIOD_US = const(1000000)
RX_CHUNK = const(64)  # bytes taken from the link per poll
_SENSOR_FAULTS = const(0x03)  # FAULT_I2C | FAULT_DRDY_STUCK (const() needs a literal)

# sensor states
S_OK = const(0)
S_FAULT = const(1)  # waiting for the retry time


class Board:
    def __init__(
        self,
        sensors,
        link,
        clock,
        storage,
        max_rate_hz=None,
        drdy_timeout_us=None,
        status_period_us=STATUS_PERIOD_US,
        tx_size=4096,
        boot_id=0,
        board_id=NO_BOARD_ID,
    ):
        if not 1 <= len(sensors) <= MAX_SENSORS:
            raise ValueError("a board reads 1..%d sensors" % MAX_SENSORS)
        self.sensors = sensors
        self.n = len(sensors)
        self.link = link
        self.clock = clock
        self.storage = storage
        # max_rate_hz overrides the hardware ceiling (emulator benches only).
        self.max_rate_hz = max_rate_hz or frontend.max_rate_hz(sensors)
        slowest = min(s.rate_sps() for s in sensors)
        self.drdy_timeout_us = drdy_timeout_us or 4 * (1000000 // slowest)
        self.status_period_us = status_period_us
        self.boot_id = boot_id & 0xFFFFFFFF
        self.board_id = board_id_from(board_id)
        self.enc = FrameEncoder()
        self.asm = FrameAssembler()
        self.tx = TxRing(link, tx_size)
        self._rx = bytearray(RX_CHUNK)
        self.settings = settings.Settings(rate_hz=min(settings.DEFAULT_RATE_HZ, self.max_rate_hz))
        self.cals = [calibration.Calibration() for _ in range(self.n)]
        s = self.settings
        self.gates = [gate.ContactGate(s.enter, s.exit, s.debounce) for _ in range(self.n)]
        self.sched = Scheduler(clock, 1000000 // s.rate_hz)
        self.streaming = False
        # fault bookkeeping, per sensor
        self.state = [S_OK] * self.n
        self.faults = [0] * self.n
        self.retry_at = [0] * self.n
        self.backoff_us = [BACKOFF_MIN_US] * self.n
        self.pending = [False] * self.n
        self.pending_since = [0] * self.n
        # counters (STATUS)
        self.i2c_errors = 0
        self.drdy_timeouts = 0
        self.saturations = 0
        self.samples = 0
        self.rx_errors = 0
        self.last_error = 0
        self._reported = (0, 0)  # (overruns, tx_dropped) at the last STATUS
        self._status_due = 0
        # tare: sensor mask, samples left, sums, the command to answer
        self.tare_mask = 0
        self.tare_all = 0
        self.tare_left = [0] * self.n
        self.tare_n = 0
        self.tare_sums = [[0] * frontend.N_GAUGES for _ in range(self.n)]
        self.tare_seq = -1
        self.tare_loaded = [0] * self.n  # consecutive tare samples above the gate
        self._tare_ft = [0] * 6
        # 32-bit device time from the wrapping tick counter
        now = clock.ticks_us()
        self._ticks_base = now
        self.time_us = 0
        # preallocated per-sample values
        self.ft = [0] * 6
        self._sample_vals = [0] * 8
        self._contact_vals = [0] * 10
        self._status_vals = [0] * 9
        self._late = False

    # --- start-up -----------------------------------------------------------------
    def boot(self):
        """Load settings and calibration, bring up the sensors, HELLO, autostart."""
        self.settings = settings.load(self.storage, self.max_rate_hz)
        self._apply_settings()
        for i in range(self.n):
            self.cals[i] = calibration.load(self.storage, i)
        self.send_info(MSG_HELLO)  # first frame after power-up, seq 0
        now = self.clock.ticks_us()
        for i in range(self.n):
            self._init_sensor(i, now)
        if self.settings.flags & CFG_AUTOSTART:
            self.start_streaming()

    def _apply_settings(self):
        s = self.settings
        three_d = bool(s.flags & CFG_GATE_3D)
        for g in self.gates:
            g.configure(s.enter, s.exit, s.debounce, three_d)
        self.sched.set_period(1000000 // s.rate_hz, self.clock.ticks_us())

    def _init_sensor(self, i, now):
        try:
            self.sensors[i].init()
        except OSError as exc:
            self._fault(i, FAULT_I2C, exc, now)
            return False
        return True

    # --- the loop -------------------------------------------------------------------
    def poll(self):
        """One bounded step: commands, due samples, pending reads, transmit."""
        clock = self.clock
        now = clock.ticks_us()
        self.time_us = (self.time_us + clock.ticks_diff(now, self._ticks_base)) & 0xFFFFFFFF
        self._ticks_base = now
        link = self.link
        if link.opened():
            # A new host session: frames queued for a host that went away are stale (the
            # host counts them as a sequence gap); HELLO must not wait behind them.
            self.tx.clear()
            self.send_info(MSG_HELLO)
        self._receive()
        if self.streaming or self.tare_mask:
            missed = self.sched.check(now)
            if missed >= 0:
                self._tick(now, missed)
            for i in range(self.n):
                if self.pending[i]:
                    self._read_sensor(i, now)
            self._periodic_status(now)
        else:
            for i in range(self.n):
                if self.state[i] == S_FAULT and clock.ticks_diff(now, self.retry_at[i]) >= 0:
                    self._retry(i, now)
        self.tx.flush()

    def idle_us(self):
        """Microseconds until the next sample is due (0: poll again now)."""
        if not (self.streaming or self.tare_mask):
            return 1000
        for i in range(self.n):
            if self.pending[i]:
                return 0
        d = self.sched.until_due(self.clock.ticks_us())
        return d if d > 0 else 0

    def run(self, feed=None, sleep_us=None):
        """Poll forever (real boards); the loop survives any exception."""
        while True:
            try:
                self.poll()
                if sleep_us is not None:
                    d = self.idle_us()
                    if d > 200:
                        sleep_us(d - 100)
            except Exception as exc:  # the loop never dies
                self.last_error = _errno(exc)
            if feed is not None:
                feed()

    def _receive(self):
        n = self.link.readinto(self._rx)
        if not n:
            return
        asm = self.asm
        buf = self._rx
        for k in range(n):
            r = asm.feed(buf[k])
            if r == FRAME_OK:
                dispatch(self)
            elif r > FRAME_OK:
                self.rx_errors += 1

    # --- sampling -----------------------------------------------------------------
    def _tick(self, now, missed):
        self._late = missed > 0
        clock = self.clock
        for i in range(self.n):
            if self.state[i] == S_FAULT:
                if clock.ticks_diff(now, self.retry_at[i]) >= 0:
                    self._retry(i, now)
                continue
            if self.pending[i]:
                # the previous sample never completed within a period
                self.sched.overruns += 1
                continue
            self.pending[i] = True
            self.pending_since[i] = now

    def _read_sensor(self, i, now):
        sensor = self.sensors[i]
        try:
            done = sensor.poll()
        except OSError as exc:
            self.pending[i] = False
            self._fault(i, FAULT_I2C, exc, now)
            return
        if not done:
            if self.clock.ticks_diff(now, self.pending_since[i]) > self.drdy_timeout_us:
                self.pending[i] = False
                self.drdy_timeouts += 1
                self._fault(i, FAULT_DRDY_STUCK, None, now)
            return
        self.pending[i] = False
        self.samples += 1
        if self.faults[i] & _SENSOR_FAULTS:
            self._recovered(i, self.faults[i] & _SENSOR_FAULTS)
        sat = sensor.saturated
        if sat and not self.faults[i] & FAULT_SATURATION:
            self.saturations += 1
            self.faults[i] |= FAULT_SATURATION
            self.send_status(FAULT_SATURATION, i)
        elif not sat and self.faults[i] & FAULT_SATURATION:
            self.faults[i] &= ~FAULT_SATURATION
            self.send_status(FAULT_SATURATION | FAULT_RECOVERED, i)
        if self.tare_mask & (1 << i):
            self._tare_accumulate(i, sensor.counts)
        if self.streaming:
            self._emit(i, sat)

    def _emit(self, i, sat):
        ft = self.ft
        self.cals[i].apply(self.sensors[i].counts, ft)
        flags = sat
        if self._late:
            flags |= FLAG_LATE
        phase = self.gates[i].update(ft[0], ft[1], ft[2])
        if phase == gate.BEGIN or phase == gate.IN:
            flags |= FLAG_IN_CONTACT
        streams = self.settings.flags
        ts = self.time_us
        if streams & CFG_STREAM_SAMPLES:
            v = self._sample_vals
            v[0] = i
            v[1] = flags
            for k in range(6):
                v[2 + k] = ft[k]
            self.tx.send(self.enc.encode(MSG_SAMPLE, ts, v, False))
        if phase != gate.NONE and streams & CFG_STREAM_CONTACTS:
            v = self._contact_vals
            v[0] = i
            v[1] = phase
            v[2] = self.gates[i].contact_id
            v[3] = flags
            for k in range(6):
                v[4 + k] = ft[k]
            self.tx.send(self.enc.encode(MSG_CONTACT, ts, v, False))

    # --- faults -------------------------------------------------------------------
    def _fault(self, i, bit, exc, now):
        if bit == FAULT_I2C:
            self.i2c_errors += 1
        self.last_error = _errno(exc) if exc is not None else 0
        if self.faults[i] & _SENSOR_FAULTS:  # failed again before a good sample
            self.backoff_us[i] = min(self.backoff_us[i] * 2, BACKOFF_MAX_US)
        new = not self.faults[i] & bit
        self.faults[i] |= bit
        self.state[i] = S_FAULT
        self.retry_at[i] = self.clock.ticks_add(now, self.backoff_us[i])
        if self.gates[i].in_contact:
            self.gates[i].reset()  # a contact cannot continue through a dead sensor
        if new:
            self.send_status(bit, i)
        if self.tare_mask & (1 << i):
            self._tare_nak(NAK_HARDWARE, NAK_DETAIL_NONE)

    def _retry(self, i, now):
        self.pending[i] = False
        try:
            self.sensors[i].init()
        except OSError as exc:
            self._fault(i, FAULT_I2C, exc, now)
            return
        self.state[i] = S_OK  # FAULT_RECOVERED goes out with the first good sample

    def _recovered(self, i, bits):
        self.faults[i] &= ~bits
        self.backoff_us[i] = BACKOFF_MIN_US
        self.send_status(bits | FAULT_RECOVERED, i)

    def _periodic_status(self, now):
        if self.clock.ticks_diff(now, self._status_due) < 0:
            return
        self._status_due = self.clock.ticks_add(now, self.status_period_us)
        over = self.sched.overruns
        drop = self.tx.dropped
        bits = 0
        if over != self._reported[0]:
            bits |= FAULT_OVERRUN
        if drop != self._reported[1]:
            bits |= FAULT_TX_DROPPED
        if bits:
            self.send_status(bits, SENSOR_ALL)

    # --- messages -----------------------------------------------------------------
    def send_status(self, bits, sensor):
        v = self._status_vals
        faults = bits
        if sensor == SENSOR_ALL:
            for f in self.faults:
                faults |= f
        elif not bits & FAULT_RECOVERED:
            faults |= self.faults[sensor]
        v[0] = faults
        v[1] = sensor
        v[2] = self.last_error & 0xFF
        v[3] = self.i2c_errors & 0xFFFFFFFF
        v[4] = self.drdy_timeouts & 0xFFFFFFFF
        v[5] = self.saturations & 0xFFFFFFFF
        v[6] = self.sched.overruns & 0xFFFFFFFF
        v[7] = self.tx.dropped & 0xFFFFFFFF
        v[8] = self.samples & 0xFFFFFFFF
        self._reported = (self.sched.overruns, self.tx.dropped)
        self.tx.send(self.enc.encode(MSG_STATUS, self.time_us, v, False))

    def info_values(self):
        s = self.settings
        ids = [0, 0, 0, 0]
        crcs = [0, 0, 0, 0]
        for i in range(self.n):
            ids[i] = self.cals[i].cal_id
            crcs[i] = self.cals[i].crc
        flags = s.flags | (CFG_STREAMING if self.streaming else 0)
        return (
            FW_VERSION[0],
            FW_VERSION[1],
            FW_VERSION[2],
            PROTOCOL_VERSION,
            SENSOR_MODEL,
            self.n,
            self.max_rate_hz,
            ids[0],
            ids[1],
            ids[2],
            ids[3],
            s.rate_hz,
            s.enter,
            s.exit,
            s.debounce,
            flags,
            self.boot_id,
            crcs[0],
            crcs[1],
            crcs[2],
            crcs[3],
            self.board_id,
        )

    def send_info(self, mtype=MSG_INFO):
        self.tx.send(self.enc.encode(mtype, self.time_us, self.info_values()))

    def ack(self, cmd, seq):
        self.tx.send(self.enc.encode(MSG_ACK, self.time_us, (cmd, seq)))

    def nak(self, cmd, seq, reason, detail=NAK_DETAIL_NONE):
        self.tx.send(self.enc.encode(MSG_NAK, self.time_us, (cmd, seq, reason, detail)))

    # --- state changes used by commands ----------------------------------------------
    def configure(self, new):
        self.settings = new
        self._apply_settings()

    def start_streaming(self):
        if self.streaming:
            return
        now = self.clock.ticks_us()
        if not self.tare_mask:
            self.sched.start(now)
        self.streaming = True
        self._status_due = self.clock.ticks_add(now, self.status_period_us)
        for g in self.gates:
            g.reset()
        hook = getattr(self.link, "streaming", None)
        if hook is not None:
            hook(True)
        for i in range(self.n):
            if not self.cals[i].present:
                self.send_status(FAULT_NO_CALIBRATION, i)

    def stop_streaming(self):
        self.streaming = False
        for i in range(self.n):
            self.pending[i] = False
        hook = getattr(self.link, "streaming", None)
        if hook is not None:
            hook(False)

    def start_tare(self, mask, n_samples, seq):
        if not (self.streaming or self.tare_mask):
            self.sched.start(self.clock.ticks_us())
        self.tare_mask = mask
        self.tare_all = mask
        self.tare_n = n_samples
        self.tare_seq = seq
        for i in range(self.n):
            self.tare_left[i] = n_samples if mask & (1 << i) else 0
            self.tare_loaded[i] = 0
            sums = self.tare_sums[i]
            for k in range(frontend.N_GAUGES):
                sums[k] = 0

    def _checks_load(self, i):
        """Whether TARE checks sensor i for load: calibrated (else its forces mean nothing
        yet) and gated (an enter level of 0 gates nothing)."""
        return self.cals[i].present and self.settings.enter > 0

    def loaded_sensor(self, mask):
        """The first sensor of ``mask`` that the gate has in contact now, else -1."""
        if not self.streaming:
            return -1  # no recent sample: the tare's own samples are checked
        for i in range(self.n):
            if mask & (1 << i) and self.gates[i].in_contact and self._checks_load(i):
                return i
        return -1

    def _tare_accumulate(self, i, counts):
        if self._checks_load(i):
            ft = self._tare_ft
            self.cals[i].apply(counts, ft)  # under the bias in force
            if self.gates[i].loaded(ft[0], ft[1], ft[2]):
                self.tare_loaded[i] += 1
                if self.tare_loaded[i] >= self.settings.debounce:
                    self._tare_nak(NAK_LOADED, i)
                    return
            else:
                self.tare_loaded[i] = 0
        sums = self.tare_sums[i]
        for k in range(frontend.N_GAUGES):
            sums[k] += counts[k]
        self.tare_left[i] -= 1
        if self.tare_left[i] == 0:
            self.tare_mask &= ~(1 << i)
            if not self.tare_mask:  # every sensor done: the new biases apply together
                for j in range(self.n):
                    if self.tare_all & (1 << j):
                        self.cals[j].set_bias_sums(self.tare_sums[j], self.tare_n)
                self.ack(CMD_TARE, self.tare_seq)
                self.tare_seq = -1

    def _tare_nak(self, reason, detail):
        """The TARE ends refused (a loaded sensor, a failed read): the old bias kept everywhere."""
        self.tare_mask = 0
        if self.tare_seq >= 0:
            self.nak(CMD_TARE, self.tare_seq, reason, detail)
        self.tare_seq = -1


def _errno(exc):
    args = getattr(exc, "args", ())
    if args and isinstance(args[0], int):
        return args[0] & 0xFF
    return 0xFF
