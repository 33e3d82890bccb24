"""``tactile record``'s loop: read a board into a ``Recording`` until a stop condition.

Opens the port, waits for HELLO, TAREs when asked, starts streaming if the
board is not already, then appends everything it reads.  When the port
vanishes (cable pulled, board reset) it records a gap, waits for the port to
come back (``reconnect_s``) and carries on with the same decoder, so frames
lost in the gap are counted from the sequence numbers.  A board that
rebooted (the decoder sees a new boot id) is counted in ``reboots``, not as
lost frames, and TAREd again.  Ctrl-C ends the recording
normally.  Port and clock are injectable for tests.  ``on_frames(session, msgs, host_times)``
sees every batch once it is written (``tactile.foxglove.live`` serves it live).

A run that fails before the board sent a byte (no such port, nothing answering) is undone
(``Recording.discard``): no meta.json, no file of it left.

A write that fails (a full disk) ends the run: the files are settled (torn rows cut, the
counts taken from the files: ``Recording.settle``), meta.json says how it ended (``disk
full``, ``file too large`` or ``write failed``) if it can still be written, and ``run``
raises ``HostFileError`` (exit 5): one line naming the file and what was kept.

Time: every frame's arrival (the ``clock`` reading as its read returned) feeds the board ->
host fit of ``tactile.recording.timebase.RecordingClock``; frames.csv gets each row's host time as
the
fit stands, and is rewritten with the final fit at the end; meta.json holds the mapping.

A board silent for half a second is PINGed: its ACK's stamp is a point of the fit too.
One that answers nothing for ``SILENT_S`` (a firmware hung after its HELLO) ends the run:
a ``BoardError`` (exit 4) saying so, ``ended`` "board silent", everything received kept.
``until`` = (clock, us, how): stop once that time of the pose log's clock has passed (the
board's as its frames say, or the host's own clocks).
"""

import time
from datetime import UTC, datetime

from tactile import __version__
from tactile.board.client import BoardClient, info_dict
from tactile.board.serial_port import open_port
from tactile.errors import BoardError, HostFileError, PortError, PortLost
from tactile.recording.files import Recording, WriteFailed
from tactile.recording.timebase import RecordingClock
from tactile_protocol import constants as C

META_EVERY_S = 1.0
PING_AFTER_S = 0.5  # silence after which the board is PINGed for its clock
SILENT_S = 5.0  # silence, PINGs unanswered, after which the board is given up on (exit 4)
REFIT_EVERY_S = 1.0  # and at least 100 fit durations


def _stop_meta(until):
    clock, us, how = until
    return {"clock": clock, "time_us": us, "from": f"the pose log: {how}"}


def _span_s(first_us, last_us):
    """Device time covered, across one wrap of the u32 microsecond timestamp."""
    if first_us is None:
        return 0.0
    return ((last_us - first_us) % C.TIMESTAMP_MODULO) / 1e6


class Stats:
    """What the progress display shows; also the counters in meta.json."""

    def __init__(self):
        self.frames = 0
        self.samples = 0  # SAMPLE and CONTACT frames (one per sensor reading sent)
        self.late_samples = 0  # ... of them flagged late by the board (it missed a period)
        self.contacts_begun = 0
        self.contacts_ended = 0
        self.first_ts = None
        self.last_ts = None
        self.status = {}  # the latest STATUS per sensor (0xFF: the board)

    def add(self, msgs):
        for m in msgs:
            self.frames += 1
            if m.type_code in (C.MSG_SAMPLE, C.MSG_CONTACT):
                self.samples += 1
                self.late_samples += bool(m.flags & C.FLAG_LATE)
                self.first_ts = m.timestamp_us if self.first_ts is None else self.first_ts
                self.last_ts = m.timestamp_us
            elif m.type_code == C.MSG_STATUS:
                self.status[m.sensor] = m.to_dict()
            if m.type_code == C.MSG_CONTACT:
                self.contacts_begun += m.phase == C.PHASE_BEGIN
                self.contacts_ended += m.phase == C.PHASE_END


class Session:
    """One recording run; ``run()`` returns the final meta dictionary."""

    def __init__(
        self,
        port_name,
        outdir,
        duration_s=None,
        contacts=None,
        tare=True,
        reconnect_s=30.0,
        handshake_s=2.0,
        opener=None,
        clock=time.monotonic,
        sleep=time.sleep,
        on_progress=None,
        stop_when=None,
        append=False,
        argv=None,
        utc=time.time,
        until=None,
        on_frames=None,
    ):
        self.port_name = port_name
        self.duration_s = duration_s
        self.contacts = contacts
        self.want_tare = tare
        self.tared = False  # a TARE the board acknowledged
        self.reconnect_s = reconnect_s
        self.handshake_s = handshake_s
        self.opener = opener or (lambda name: open_port(name))
        self.clock = clock
        self.sleep = sleep
        self.on_progress = on_progress or (lambda session: None)
        self.stop_when = stop_when or (lambda session: None)
        self.on_frames = on_frames or (lambda session, msgs, host_times: None)
        try:
            self.rec = Recording(outdir, append)
        except WriteFailed as exc:
            raise HostFileError(f"{exc}: nothing recorded") from None
        self.failed = None  # the WriteFailed that ended the run
        self._meta_failed = None  # ... and the one that kept meta.json from saying so
        self.stats = Stats()
        self.gaps = []
        self.ended = "running"
        self.client = None
        self.started = None
        self.argv = argv
        self.started_at = None
        self._meta_at = 0.0
        self._reboots_prepared = 0  # the decoder's reboot count when last TAREd
        self.utc = utc
        self.until = until
        self.timing = RecordingClock(self.rec.rows_offset)
        self._heard_at = None  # clock of the latest frame (or of the start)
        self._pinged_at = None
        self._fit_at = 0.0

    # -- connection ------------------------------------------------------------
    def _connect(self):
        port = self.opener(self.port_name)
        if self.client is None:
            self.client = BoardClient(port, self.port_name, capture=self.rec.raw, clock=self.clock)
        else:
            self.client.port = port
            self.client.info = None
        hello = self.client.handshake(self.handshake_s)
        self._reboots_prepared = self.client.decoder.counters.reboots
        if self.client.info.protocol_version != C.PROTOCOL_VERSION:
            raise BoardError(
                f"{self.port_name}: HELLO says protocol version {hello.protocol_version}, "
                f"this host speaks {C.PROTOCOL_VERSION}"
            )
        self._prepare()
        self._heard_at = self.clock()  # (its HELLO and the replies just now)

    def _prepare(self):
        if self.want_tare:
            self.client.tare()
            self.tared = True
        if not self.client.info.flags & C.CFG_STREAMING:
            self.client.start()

    def _close_port(self):
        self.client.close()

    def _reconnect(self, why):
        gap = {
            "lost_at_s": round(self.clock() - self.started, 3),
            "why": why,
            "last_timestamp_us": self.stats.last_ts,
            "lost_frames_before": self.client.decoder.counters.lost_frames,
        }
        self.gaps.append(gap)
        self._close_port()
        self._write_meta()
        deadline = self.clock() + self.reconnect_s
        while self.clock() < deadline:
            self.sleep(0.2)
            try:
                self._connect()
            except PortLost as exc:  # opened, then gone again (a board still booting)
                gap.setdefault("retries", []).append(str(exc))
                self._close_port()
                continue
            except PortError:  # not there yet
                continue
            except BoardError as exc:  # there, but not answering (yet)
                gap.setdefault("retries", []).append(str(exc))
                self._close_port()
                continue
            gap["back_at_s"] = round(self.clock() - self.started, 3)
            return True
        gap["back_at_s"] = None
        return False

    # -- the loop ----------------------------------------------------------------
    def _done(self):
        if self.duration_s is not None and self.clock() - self.started >= self.duration_s:
            return "duration"
        if self.contacts is not None and self.stats.contacts_ended >= self.contacts:
            return "contacts"
        if self.until is not None and self._now_us(self.until[0]) >= self.until[1]:
            return "pose log end"
        return self.stop_when(self)

    def _now_us(self, clock):
        """Now in ``clock`` (us): the board's latest stamp heard, or a host clock's reading."""
        if clock == "board":
            now = self.timing.board_us()
            return -1 if now is None else now
        return round((self.clock() if clock == "monotonic" else self.utc()) * 1e6)

    def waiting_for(self):
        """What the run waits for, in words (None: a duration, a count or Ctrl-C)."""
        if self.until is None:
            return None
        from tactile.logs.clock import show_time

        clock, end, _ = self.until
        left = self.until_left_s()
        if left is None:
            return f"pose log end ({show_time(clock, end)}); no board time heard yet"
        return f"pose log end in {left:.1f} s ({show_time(clock, end)})"

    def until_left_s(self):
        """Seconds until the pose log's end; None without a log or before any board time."""
        if self.until is None:
            return None
        clock, end, _ = self.until
        now = self._now_us(clock)
        seg = self.timing.board.segments[-1] if self.timing.board.segments else None
        if clock == "board" and seg is not None and seg.usable():  # between frames: the fit
            now = max(now, round(float(seg.fitted.to_board(self.clock())) * 1e6))
        return None if now < 0 else max(0.0, (end - now) / 1e6)

    def _handle(self, msgs, times=None):
        host_times = self.timing.take(msgs, times)
        self.rec.messages(msgs, host_times)
        self.on_frames(self, msgs, host_times)  # after the files: a live view never delays them
        self.stats.add(msgs)
        if msgs:
            self._heard_at = self.clock()
        reboots = self.client.decoder.counters.reboots
        if reboots > self._reboots_prepared:  # rebooted behind an open port: TARE again
            self._reboots_prepared = reboots
            self._prepare()

    def run(self):
        self.started = self._heard_at = self.clock()
        self.started_at = datetime.now(UTC).isoformat(timespec="seconds")
        self.timing.utc_minus_mono = self.utc() - self.clock()
        try:
            try:
                self._connect()
                self._write_meta()
                self._loop()
            except KeyboardInterrupt:
                self.ended = "interrupted"
            except WriteFailed as exc:
                self._fail(exc)
        finally:
            self._finish()
        if self.failed is not None:
            raise HostFileError(self._kept()) from None
        return self.meta()

    def _fail(self, exc):
        if self.failed is None:
            self.failed, self.ended = exc, exc.ended

    def _finish(self):
        """Keep the backlog, rewrite the host times, write meta.json, close: after a failed
        write, the files are settled first and nothing more is attempted but meta.json."""
        if self.ended == "running":
            self.ended = "error"
        if self.ended == "error" and not self.rec.bytes and self.failed is None:
            self._discard()  # no byte from a board: the run leaves nothing behind
            return
        try:
            self._keep_backlog()
        except WriteFailed as exc:
            self._fail(exc)
        self._final_times(rewrite=self.failed is None)
        if self.failed is not None:
            self.rec.settle()
        try:
            self._write_meta()
        except WriteFailed as exc:
            self._meta_failed = exc
            self._fail(exc)
        if self.client is not None:
            self._close_port()
        self.rec.close()

    def _discard(self):
        if self.client is not None:
            self._close_port()
        self.rec.discard()
        self.rec.close()

    def _kept(self):
        """The one line of a run a failed write ended: the file, what was kept, meta.json."""
        rec = self.rec
        kept = (
            f"{self.failed}: recording stopped after {self.clock() - self.started:.1f} s; this"
            f" run kept {rec.rows:,} readings (frames.csv) and {rec.bytes:,} bytes (capture.bin)"
            f" in {rec.dir}"
        )
        if self._meta_failed is None:
            return kept + f"; meta.json says ended '{self.ended}'"
        return kept + "; meta.json not updated (tactile.load_recording reads capture.bin)"

    def _keep_backlog(self):
        """Frames decoded while a command waited (a TARE the port died during) into the files:
        they are in capture.bin already, and frames.csv must hold them too."""
        if self.client is not None and self.client.backlog:
            msgs, times = self.client._take_backlog()
            self.rec.messages(msgs, self.timing.take(msgs, times))
            self.stats.add(msgs)

    def _final_times(self, rewrite=True):
        """The final fit; this session's frames.csv rows rewritten with it.  A failed rewrite
        (a full disk) keeps the rows as written, and meta.json says which they hold."""
        self.timing.refit()
        self.timing.utc_minus_mono_end = self.utc() - self.clock()
        if not rewrite:
            return
        if not self.timing.rows:
            self.timing.final = True  # nothing to rewrite
            return
        try:
            self.rec.rewrite_host(self.timing.host_of)
            self.timing.final = True
        except OSError:
            pass

    def _loop(self):
        while True:
            try:
                self._handle(*self.client.read_timed())  # a reboot's TARE writes: can fail
                self._keep_time()
            except PortLost as exc:
                if not self._reconnect(str(exc)):
                    self.ended = "port lost"
                    raise PortError(
                        f"{self.port_name}: port lost and not back within {self.reconnect_s:g} s"
                        f" (everything received is in {self.rec.dir})"
                    ) from None
                continue
            self.on_progress(self)
            if self.clock() - self._meta_at >= META_EVERY_S:
                self._write_meta()
            why = self._done()
            if why:
                self.ended = why
                return

    def _keep_time(self):
        """Refit now and then; PING a silent board: its ACK carries the board's clock, for
        the fit (a contacts-only stream is silent between contacts) and for a pose log that
        waits on the board's time."""
        now = self.clock()
        if now - self._fit_at >= max(REFIT_EVERY_S, 100 * self.timing.fit_s):
            self._fit_at = now
            self.timing.refit()
        if now - self._heard_at >= SILENT_S:
            self.ended = "board silent"
            raise BoardError(
                f"{self.port_name}: the board said nothing for {SILENT_S:g} s, not even to PING"
                f" (a hung firmware? everything received is in {self.rec.dir})"
            )
        silent = now - max(self._heard_at, self._pinged_at or self._heard_at)
        if silent >= PING_AFTER_S:
            self._pinged_at = now
            self.client.send(C.CMD_PING)  # its ACK carries the board's clock

    # -- metadata -------------------------------------------------------------------
    def meta(self):
        """This session's entry in meta.json (``tactile.recording.meta`` adds the totals)."""
        client = self.client
        info = client.info if client is not None else None
        s = self.stats
        return {
            "tactile_version": __version__,
            "protocol_version": C.PROTOCOL_VERSION,
            "port": self.port_name,
            "command": self.argv,
            "started_at": self.started_at,
            "ended": self.ended,
            "elapsed_s": round(self.clock() - self.started, 3) if self.started else 0.0,
            "device": info_dict(info) if info is not None else None,
            "tared": self.tared,
            "frames": s.frames,
            "samples": self.rec.rows,  # = s.samples, or what frames.csv kept of a failed write
            "late_samples": s.late_samples,
            "contacts_begun": s.contacts_begun,
            "contacts_ended": s.contacts_ended,
            "device_time_s": _span_s(s.first_ts, s.last_ts),
            "device_status": list(s.status.values()),
            "reboots": client.decoder.counters.reboots if client is not None else 0,
            "gaps": self.gaps,
            "bytes": self.rec.bytes,
            "capture_offset": self.rec.capture_offset,
            "rows_offset": self.rec.rows_offset,
            "decoder": client.decoder.counters.as_dict() if client is not None else None,
            "stops_at": None if self.until is None else _stop_meta(self.until),
            "time_base": self.timing.meta(),
        }

    def _write_meta(self):
        self._meta_at = self.clock()
        self.rec.write_meta(self.meta())
