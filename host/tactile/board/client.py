"""Talking to a board (or the emulator) over an open serial port: PROTOCOL.md §4.

``BoardClient`` wraps any pyserial-like object (``read``, ``write``,
``in_waiting``).  Every byte read goes first to the optional ``capture``
callable (the recorder appends it to disk) and then to the decoder, so
nothing received is lost whatever happens next.  Messages that arrive while
a command waits for its ACK are kept in ``backlog`` and returned by the next
``read``: commands never swallow the stream.

``handshake`` waits for the HELLO a board sends when its port opens; a board
without DTR (MicroPython's USB stdio on the Pico) may not notice the open, so
after half the timeout the client asks with GET_INFO.

The client is the one place the host does I/O on an open port, so it is
where a port that dies (pyserial's ``SerialException``, an ``OSError`` such
as EIO from ``in_waiting``) becomes ``PortLost``: one line, exit 4.

A device that lies (a frame outside the protocol's field limits, which the
decoder delivers as ``Invalid``) is refused where its answer was awaited: an
invalid HELLO or INFO ends ``handshake``/``get_info`` and an invalid ACK or NAK
ends ``command``, each with one line naming the field (``DeviceLied``, exit 4).
Invalid frames in a stream are passed on, counted, never acted on.
"""

import logging
import math
import time

from tactile.board.serial_port import describe_lost
from tactile.board.stream_decoder import INVALID, StreamDecoder
from tactile.errors import (
    BoardError,
    BoardTimeout,
    InputError,
    PortLost,
    ProtocolVersionError,
    TactileError,
)
from tactile_protocol import constants as C
from tactile_protocol import settings as board_settings
from tactile_protocol.framing import FrameEncoder

log = logging.getLogger(__name__)

NAK_REASONS = {
    C.NAK_UNKNOWN_COMMAND: "unknown command",
    C.NAK_BAD_LENGTH: "bad length",
    C.NAK_OUT_OF_RANGE: "out of range",
    C.NAK_BAD_STATE: "bad state",
    C.NAK_HARDWARE: "hardware fault",
    C.NAK_BAD_VERSION: "bad version",
    C.NAK_STORAGE: "storage error",
    C.NAK_LOADED: "loaded",
}
COMMAND_NAMES = {
    C.CMD_PING: "PING",
    C.CMD_GET_INFO: "GET_INFO",
    C.CMD_CONFIG: "CONFIG",
    C.CMD_TARE: "TARE",
    C.CMD_START: "START",
    C.CMD_STOP: "STOP",
    C.CMD_SET_CAL: "SET_CAL",
}
# Payload field names per command, for naming the field a NAK's ``detail`` points at.
COMMAND_FIELDS = {
    C.CMD_CONFIG: ("rate_hz", "enter_threshold", "exit_threshold", "debounce", "flags"),
    C.CMD_TARE: ("sensor", "n_samples"),
    C.CMD_SET_CAL: ("sensor", "cal_id") + tuple(f"c{r}{c}" for r in range(6) for c in range(6)),
}
GATE_CEILING = 2**31 - 1  # the largest enter threshold (uN): what 'tare --force' gates at
WRAP = 2**32  # the board's µs stamps wrap
MAX_READ = 65536  # bytes per read call: bounded whatever the device claims to have
ASK_AFTER_S = 0.2  # handshake: ask GET_INFO if no HELLO came this soon after opening


class CommandRefused(BoardError):
    """The board answered NAK; the message names the command, the reason and the field."""


class DeviceLied(BoardError):
    """The device sent a frame outside the protocol's field limits where an answer was due."""


def nak_message(nak, info=None):
    """One line for a NAK; ``info`` (the board's HELLO/INFO) adds the gate to NAK_LOADED."""
    name = COMMAND_NAMES.get(nak.cmd_type, f"command 0x{nak.cmd_type:02x}")
    if nak.reason == C.NAK_LOADED:
        gate = "" if info is None else f" {board_settings.to_newtons(info.enter_threshold):g} N"
        return (
            f"board refused {name}: sensor {nak.detail} is loaded (force above the{gate} contact"
            " gate); unload the fingers and retry (if nothing touches it, its own offset exceeds"
            " the gate: 'tactile tare --force')"
        )
    reason = NAK_REASONS.get(nak.reason, f"reason {nak.reason}")
    fields = COMMAND_FIELDS.get(nak.cmd_type, ())
    if nak.detail != C.NAK_DETAIL_NONE:
        field = fields[nak.detail] if nak.detail < len(fields) else f"field {nak.detail}"
        return f"board refused {name}: {reason} ({field})"
    return f"board refused {name}: {reason}"


class BoardClient:
    """See the module docstring.  ``name`` is used in messages (the port's path)."""

    def __init__(self, port, name="board", capture=None, clock=time.monotonic):
        self.port = port
        self.name = name
        self.capture = capture
        self.clock = clock
        self.decoder = StreamDecoder()
        self.encoder = FrameEncoder()
        self.backlog = []
        self.backlog_times = []  # arrival (``clock``) of each backlog message
        self.pulled_at = None  # ``clock`` when the latest bytes were read
        self.info = None  # the latest HELLO or INFO
        self.lie = None  # the latest invalid HELLO or INFO

    # -- the byte stream -------------------------------------------------------
    def _pull(self):
        """Read what the port has (waiting up to its timeout for the first byte)."""
        try:
            waiting = self.port.in_waiting
            data = self.port.read(min(max(waiting, 1), MAX_READ))
        except TactileError:
            raise
        except OSError as exc:  # pyserial's SerialException is an OSError
            raise PortLost(describe_lost(self.name, exc, "reading")) from None
        if data:
            self.pulled_at = self.clock()  # before anything else: the frames' arrival time
            if self.capture is not None:
                self.capture(data)
            msgs = self.decoder.feed(data)
            for m in msgs:
                if m.type_code in (C.MSG_HELLO, C.MSG_INFO):
                    self.info = m
                elif m.type_code == INVALID and m.message in ("HELLO", "INFO"):
                    self.lie = m
            return msgs
        return []

    def waiting(self):
        """Bytes waiting on the port (a dead port raises PortLost)."""
        try:
            return self.port.in_waiting
        except TactileError:
            raise
        except OSError as exc:
            raise PortLost(describe_lost(self.name, exc, "reading")) from None

    def read(self):
        """Messages received since the last call (the backlog first)."""
        return self.read_timed()[0]

    def read_timed(self):
        """(messages, their arrival times) received since the last call, the backlog first.
        A message's arrival is the ``clock`` reading taken as the read that completed it
        returned: what ``tactile.recording.timebase`` fits the board's clock to."""
        out, times = self._take_backlog()
        new = self._pull()
        return out + new, times + [self.pulled_at] * len(new)

    def _take_backlog(self):
        out, times = self.backlog, self.backlog_times
        self.backlog, self.backlog_times = [], []
        return out, times

    def _keep(self, msgs):
        self.backlog += msgs
        self.backlog_times += [self.pulled_at] * len(msgs)

    def send(self, mtype, values=()):
        """Send one command; return its sequence number."""
        seq = self.encoder.seq
        try:
            frame = bytes(self.encoder.encode(mtype, 0, values))
        except (ValueError, OverflowError, TypeError) as exc:
            name = COMMAND_NAMES.get(mtype, f"0x{mtype:02x}")
            raise InputError(f"{name}: a value does not fit the protocol: {exc}") from None
        try:
            self.port.write(frame)
        except TactileError:
            raise
        except OSError as exc:
            raise PortLost(describe_lost(self.name, exc, "writing")) from None
        return seq

    def close(self):
        """Close the port; a port that already died closes without complaint."""
        try:
            self.port.close()
        except OSError:  # nothing is lost: everything read went to the capture first
            pass

    # -- request / reply --------------------------------------------------------
    def command(self, mtype, values=(), timeout=1.0):
        """Send a command and wait for its ACK; raise CommandRefused on NAK, BoardTimeout."""
        seq = self.send(mtype, values)
        name = COMMAND_NAMES.get(mtype, f"0x{mtype:02x}")
        log.info("%s: %s %s (seq %d)", self.name, name, values, seq)
        deadline = self.clock() + timeout
        while True:  # one read at least after the deadline: what waits (a host that stalled)
            past = self.clock() >= deadline
            reply = None
            for m in self._pull():  # keep everything else, including what follows the reply
                if reply is None and m.type_code in (C.MSG_ACK, C.MSG_NAK) and m.cmd_seq == seq:
                    reply = m
                else:
                    self._keep([m])
                if reply is None and m.type_code == INVALID and m.message in ("ACK", "NAK"):
                    reply = m  # the answer, but a lie: which command it answers is unknown
            if reply is not None and reply.type_code == INVALID:
                raise self._lied(reply)
            if reply is not None and reply.type_code == C.MSG_NAK:
                raise CommandRefused(f"{self.name}: {nak_message(reply, self.info)}")
            if reply is not None:
                log.debug("%s: ACK for %s (seq %d)", self.name, name, seq)
                return reply
            if past:
                break
        raise BoardTimeout(f"{self.name}: no answer to {name} within {timeout:g} s")

    def handshake(self, timeout=2.0, ask_after=None):
        """Wait for HELLO (asking with GET_INFO after ``ask_after`` s: by default
        ``ASK_AFTER_S``, or half the timeout if that is shorter); return the HELLO/INFO
        message.  A board that announces itself on open (the emulator, a Linux controller)
        answers first; a Pico, whose USB port gives no open signal, answers GET_INFO."""
        if ask_after is None:
            ask_after = min(ASK_AFTER_S, timeout / 2)
        start = self.clock()
        asked = False
        self.lie = None
        while self.clock() - start < timeout:
            self._keep(self._pull())
            if self.info is not None:
                return self.info
            if self.lie is not None:
                raise self._lied(self.lie)
            self._check_version()
            if not asked and self.clock() - start >= ask_after:
                self.send(C.CMD_GET_INFO)
                asked = True
        self._check_version()
        raise BoardTimeout(
            f"{self.name}: no HELLO within {timeout:g} s (is the tactile firmware running? "
            "'tactile flash' installs it)"
        )

    def _lied(self, invalid):
        return DeviceLied(f"{self.name}: device sent an invalid {invalid.message}: {invalid.error}")

    def _check_version(self):
        c = self.decoder.counters
        if c.version_mismatch and c.frames == 0:
            raise ProtocolVersionError(
                f"{self.name}: the device speaks protocol version {c.last_version}, "
                f"this host speaks version {C.PROTOCOL_VERSION} (update the "
                f"{'firmware' if c.last_version < C.PROTOCOL_VERSION else 'host'})"
            )

    # -- the commands -------------------------------------------------------------
    def get_info(self, timeout=1.0):
        self.info = self.lie = None
        self.command(C.CMD_GET_INFO, timeout=timeout)
        if self.info is None and self.lie is not None:
            raise self._lied(self.lie)
        if self.info is None:
            raise BoardTimeout(f"{self.name}: ACK to GET_INFO without INFO")
        return self.info

    def tare(self, sensor=C.SENSOR_ALL, n_samples=64, timeout=5.0, force=False):
        """Bias the F/T sensor(s); the ACK comes once the bias is captured.

        The board refuses a loaded sensor (NAK_LOADED).  ``force`` raises the gate to its
        ceiling for the TARE and restores it after, for a sensor whose own offset exceeds
        the gate (the first TARE after power-up); needs the board's HELLO/INFO.
        """
        if not force:
            return self.command(C.CMD_TARE, (sensor, n_samples), timeout=timeout)
        info = self.info or self.get_info()
        keep = (info.rate_hz, info.enter_threshold, info.exit_threshold, info.debounce)
        flags = info.flags & C.CFG_WRITABLE & ~C.CFG_PERSIST
        self.command(C.CMD_CONFIG, (keep[0], GATE_CEILING, *keep[2:], flags))
        try:
            return self.command(C.CMD_TARE, (sensor, n_samples), timeout=timeout)
        finally:
            self.command(C.CMD_CONFIG, (*keep, flags))

    def configure(self, rate_hz, enter, exit_, debounce, flags, timeout=1.0):
        """CONFIG (thresholds in N); values are checked by the board (NAK names the field)."""
        values = (
            int(rate_hz),
            board_settings.to_counts(enter),
            board_settings.to_counts(exit_),
            int(debounce),
            int(flags),
        )
        return self.command(C.CMD_CONFIG, values, timeout=timeout)

    def set_calibration(self, sensor, cal_id, coeffs, timeout=2.0):
        """SET_CAL: 36 coefficients (row-major, N and N*m per ADC count), stored on the board.

        The board writes flash before it ACKs, hence the longer timeout.
        """
        return self.command(C.CMD_SET_CAL, (sensor, cal_id, *coeffs), timeout=timeout)

    def start(self, timeout=1.0):
        return self.command(C.CMD_START, timeout=timeout)

    def stop(self, timeout=1.0):
        return self.command(C.CMD_STOP, timeout=timeout)


def info_dict(info):
    """HELLO/INFO as plain JSON-ready values (thresholds in N, flags named)."""
    d = info.to_dict()
    d["enter_threshold_N"] = board_settings.to_newtons(info.enter_threshold)
    d["exit_threshold_N"] = board_settings.to_newtons(info.exit_threshold)
    d["streams"] = board_settings.stream_names(info.flags)
    d["gate"] = board_settings.gate_name(info.flags)
    d["autostart"] = bool(info.flags & C.CFG_AUTOSTART)
    d["streaming"] = bool(info.flags & C.CFG_STREAMING)
    d["cal_ids"] = [getattr(info, f"cal_id_{i}") for i in range(info.n_sensors)]
    d["cal_crcs"] = [getattr(info, f"cal_crc_{i}") for i in range(info.n_sensors)]
    return d


def hold_wrench(batches, window, gate_N):
    """Mean wrench (6 floats) in N, N*m of the SAMPLE frames of a hold whose force exceeds
    ``gate_N``, and their count; (None, 0) if none.  ``batches`` yields lists of messages;
    ``window`` the hold's board-clock (t0, t1) µs (stamps wrap at 2^32), read until a frame
    past it arrives; None: every frame of every batch."""
    rows = []
    for msgs in batches:
        past = False
        for m in msgs:
            if m.type_code != C.MSG_SAMPLE:
                continue
            if window is not None:
                since = (m.timestamp_us - window[0]) % WRAP
                if since > (window[1] - window[0]) % WRAP:
                    past |= since < WRAP // 2  # after the hold (before it: an old frame)
                    continue
            w = board_settings.wrench_si(m.fx, m.fy, m.fz, m.tx, m.ty, m.tz)
            if math.hypot(*w[:3]) > gate_N:
                rows.append(w)
        if past:
            break
    if not rows:
        return None, 0
    return tuple(math.fsum(col) / len(rows) for col in zip(*rows)), len(rows)
