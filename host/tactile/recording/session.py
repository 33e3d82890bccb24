"""``tactile record``'s loop: read a board into a ``Recording`` until a stop condition.

Opens the port, waits for HELLO, TAREs when asked, starts streaming if the board is not
already, then appends everything it reads.  When the port vanishes (cable pulled, board
reset) it records a gap, says so (``on_notice``), waits for the port to come back
(``reconnect_s``) and carries on with the same decoder, so frames lost in the gap are
counted from the sequence numbers, but only with the same board: the board id of the run's
first HELLO (``tactile.recording.run_state``); another board ends the run
(``OtherBoard``, exit 4, ``ended`` "other board"), none of its bytes in the files.  A board
that rebooted (a new boot id) is counted in ``reboots``, not as lost frames, and TAREd
again.  Ctrl-C ends the recording normally.  Port and clock are injectable for tests.
``on_frames(session, msgs, host_times)`` sees every batch once it is written
(``tactile.foxglove.live``); ``on_notice(session, line)`` gets a line for the user
about what the run goes on through (a stall of the host, a port lost and waited for).

A run that fails before the board sent a byte (no such port, nothing answering) is undone
(``Recording.discard``): no meta.json, no file of it left.

A write that fails (a full disk) ends the run: the files are settled (torn rows cut, the
counts taken from the files: ``Recording.settle``), meta.json says how it ended (``disk
full``, ``file too large`` or ``write failed``) if it can still be written, and ``run``
raises ``HostFileError`` (exit 5): one line naming the file and what was kept.

Time: every frame's arrival (the ``clock`` reading as its read returned) feeds the board ->
host fit of ``tactile.recording.timebase.RecordingClock``; frames.csv gets each row's host
time as the fit stands, rewritten with the final fit at the end; meta.json holds the mapping.

A board silent for half a second is PINGed: its ACK's stamp is a point of the fit too.
One that answers nothing for ``SILENT_S`` of the host's running time while the port holds
nothing (a firmware hung after its HELLO) ends the run: a ``BoardError`` (exit 4),
``ended`` "board silent", everything received kept.  Silence is never judged across the
host's own stall (``tactile.recording.run_state``: Ctrl-Z, a paused VM, a slow disk): the
loop first reads what waits on the port, notes the stall in ``pauses``, and starts the
silence window again.  Times in meta.json are ``RunClock``'s: they never go back.
``until`` = (clock, us, how): stop once the pose log's end has passed (``LogEnd``); or a
function giving it, called once the board has answered (a robot's log written as its run
starts: an emulator's, for the session that has just opened the port).
"""

import time
from datetime import UTC, datetime

from tactile import __version__
from tactile.board.client import BoardClient
from tactile.board.serial_port import open_port
from tactile.errors import BoardError, HostFileError, PortError, PortLost
from tactile.recording.files import Recording, WriteFailed
from tactile.recording.layout import session_entry
from tactile.recording.run_state import (
    BoardIdentity,
    Held,
    LogEnd,
    OtherBoard,
    RunClock,
    Stats,
    stall_words,
)
from tactile.recording.timebase import RecordingClock
from tactile_protocol import constants as C

META_EVERY_S = 1.0
PING_AFTER_S = 0.5  # silence after which the board is PINGed for its clock
SILENT_S = 5.0  # silence, PINGs unanswered, after which the board is given up on (exit 4)
REFIT_EVERY_S = 1.0  # and at least 100 fit durations
DRAIN_READS = 1000  # reads at most, after a host stall, of what waits on the port


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
        on_notice=None,
        payload=None,
    ):
        self.port_name = port_name
        self.payload = payload  # a tactile.payload.apply.OnBoard: record --payload
        self.duration_s = duration_s
        self.contacts = contacts
        self.want_tare = tare
        self.version = __version__  # meta.json's tactile_version
        self.tared = False  # a TARE the board acknowledged
        self.reconnect_s = reconnect_s
        self.handshake_s = handshake_s
        self.opener = opener or (lambda name: open_port(name))
        self.clock = clock
        self.run_clock = RunClock(clock)
        self.sleep = sleep
        self.on_progress = on_progress or (lambda session: None)
        self.stop_when = stop_when or (lambda session: None)
        self.on_frames = on_frames or (lambda session, msgs, host_times: None)
        self.on_notice = on_notice or (lambda session, line: None)
        try:
            self.rec = Recording(outdir, append)
        except WriteFailed as exc:
            raise HostFileError(f"{exc}: nothing recorded") from None
        self.failed = None  # the WriteFailed that ended the run
        self._meta_failed = None  # ... and the one that kept meta.json from saying so
        self.stats = Stats()
        self.gaps = []
        self.pauses = []  # the host's stalls, and what waited on the port after each
        self.ended = "running"
        self.client = None
        self.identity = BoardIdentity()
        self.started = None
        self.argv = argv
        self.started_at = None
        self._meta_at = 0.0
        self._reboots_prepared = 0  # the decoder's reboot count when last TAREd
        self.utc = utc
        self.until = until
        self.timing = RecordingClock(self.rec.rows_offset)
        self._until_of = until if callable(until) else None
        self.log_end = None if until is None or self._until_of else self._log_end(until)
        self._heard_at = 0.0  # elapsed() at the latest frame (or the start, or a stall)
        self._pinged_at = None
        self._fit_at = 0.0

    def _log_end(self, until):
        return LogEnd(until, self.timing, self.clock, self.utc)

    # -- connection ------------------------------------------------------------
    def _connect(self):
        port = self.opener(self.port_name)
        # a port whose board runs on simulated time (sim://, not paced) says so: its clock is
        # no wall clock's, however near one a loaded machine paces it
        self.timing.board.simulated = bool(getattr(port, "simulated_time", False))
        held = None
        if self.client is None:
            self.client = BoardClient(port, self.port_name, capture=self.rec.raw, clock=self.clock)
        else:  # a reconnection: its bytes wait until the board says who it is
            self.client.port = port
            held = Held(self.client, self.rec.raw)
            self.client.info = None
        try:
            hello = self.client.handshake(self.handshake_s)
        except BaseException:
            if held is not None:
                held.release()
            raise
        if self._until_of is not None:  # (the log as it is now the board has answered)
            self.until = until = self._until_of()
            self.log_end, self._until_of = self._log_end(until), None
        if held is not None:
            self._same_board(hello, held)
        self.identity.seen(hello)
        reboots = self.client.decoder.counters.reboots
        if reboots > self._reboots_prepared:
            self.stats.new_boot()
        self._reboots_prepared = reboots
        if self.client.info.protocol_version != C.PROTOCOL_VERSION:
            raise BoardError(
                f"{self.port_name}: HELLO says protocol version {hello.protocol_version}, "
                f"this host speaks {C.PROTOCOL_VERSION}"
            )
        if self.payload and held is None:
            self.payload.check(self.client)
        self._prepare()
        self._heard_at = self.elapsed()  # (its HELLO and the replies just now)

    def _prepare(self):
        if self.payload:
            self.payload.samples_on(self.client)
        if self.want_tare:  # with tools, at any pose: their weight may be above the gate
            self.client.tare(force=bool(self.payload))  # (the host re-tares less the weight)
            self.tared = True
        if not self.client.info.flags & C.CFG_STREAMING:
            self.client.start()
        self.run_clock.waited()  # (the handshake and the commands: waits, not a stall)

    def _same_board(self, hello, held):
        """After a reconnection: carry on with this run's board, end the run on another."""
        gap = self.gaps[-1]
        if self.identity.same(hello):
            gap["rebooted"] = self.identity.rebooted(hello)
            return held.accept()
        refused = {"board_id": hello.to_dict()["board_id"], "boot_id": hello.boot_id}
        gap["other_board"] = {**refused, "bytes_refused": held.refuse()}
        self.ended = "other board"
        raise self.identity.refusal(self.port_name, hello, self.rec.dir)

    def _reconnect(self, why):
        gap = {
            "lost_at_s": round(self.elapsed(), 3),
            "why": why,
            "last_timestamp_us": self.stats.last_ts,
            "lost_frames_before": self.client.decoder.counters.lost_frames,
            "back_at_s": None,  # (not back yet)
        }
        self.gaps.append(gap)
        self.client.close()
        self._write_meta()
        wait = f"waiting up to {self.reconnect_s:g} s for it to come back"
        self.on_notice(self, f"port lost at {gap['lost_at_s']:.1f} s; {wait}")
        deadline = self.elapsed() + self.reconnect_s
        while self.elapsed() < deadline:
            self.sleep(0.2)
            try:
                self._connect()
            except OtherBoard:
                raise
            except PortLost as exc:  # opened, then gone again (a board still booting)
                gap.setdefault("retries", []).append(str(exc))
                self.client.close()
                continue
            except PortError:  # not there yet
                continue
            except BoardError as exc:  # there, but not answering (yet)
                gap.setdefault("retries", []).append(str(exc))
                self.client.close()
                continue
            gap["back_at_s"] = round(self.elapsed(), 3)
            self.run_clock.waited()
            again = "rebooted" if gap.get("rebooted") else "not rebooted"
            self.on_notice(self, f"port back at {gap['back_at_s']:.1f} s: the same board ({again})")
            return True
        return False

    # -- the loop ----------------------------------------------------------------
    def elapsed(self):
        """Seconds since the run started, on the host's clock; never going back."""
        return self.run_clock.elapsed()

    def _done(self):
        if self.duration_s is not None and self.elapsed() >= self.duration_s:
            return "duration"
        if self.contacts is not None and self.stats.contacts_ended >= self.contacts:
            return "contacts"
        if self.log_end is not None and self.log_end.passed():
            return "pose log end"
        return self.stop_when(self)

    def waiting_for(self):
        """What the run waits for, in words (None: a duration, a count or Ctrl-C)."""
        return None if self.log_end is None else self.log_end.words()

    def until_left_s(self):
        """Seconds until the pose log's end; None without a log or before any board time."""
        return None if self.log_end is None else self.log_end.left_s()

    def _handle(self, msgs, times=None):
        host_times = self.timing.take(msgs, times)
        self.rec.messages(msgs, host_times)
        self.on_frames(self, msgs, host_times)  # after the files: a live view never delays them
        self.stats.add(msgs)
        if msgs:
            self._heard_at = self.elapsed()
        reboots = self.client.decoder.counters.reboots
        if reboots > self._reboots_prepared:  # rebooted behind an open port: TARE again
            self._reboots_prepared = reboots
            self.stats.new_boot()
            self.identity.seen(self.client.info)
            self._prepare()

    def run(self):
        self.started = self.clock()
        self.run_clock.start()
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
        if (
            self.ended == "error"
            and self.failed is None
            and (not self.rec.bytes or self._refused())
        ):
            self._discard()  # no byte from a board, or not the tools' board: nothing left
            return
        if self.payload:
            self.payload.put_back(self.client)
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
            self.client.close()
        self.rec.close()

    def _refused(self):
        return bool(self.payload) and self.payload.refused

    def _discard(self):
        if self.client is not None:
            self.client.close()
        self.rec.discard()
        self.rec.close()

    def _kept(self):
        """The one line of a run a failed write ended: the file, what was kept, meta.json."""
        rec = self.rec
        kept = (
            f"{self.failed}: recording stopped after {self.elapsed():.1f} s; this"
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
            if self.elapsed() - self._meta_at >= META_EVERY_S:
                self._write_meta()
            why = self._done()
            if why:
                self.ended = why
                return

    def _keep_time(self):
        """Refit now and then; PING a silent board: its ACK carries the board's clock, for
        the fit (a contacts-only stream is silent between contacts) and for a pose log that
        waits on the board's time.  After a stall of the host, read what waits first."""
        step = self.run_clock.stall()
        if step is not None:
            self._after_stall(step)
        now = self.elapsed()
        if now - self._fit_at >= max(REFIT_EVERY_S, 100 * self.timing.fit_s):
            self._fit_at = now
            self.timing.refit()
        if now - self._heard_at >= SILENT_S and not self.client.waiting():
            self.ended = "board silent"
            raise BoardError(
                f"{self.port_name}: the board said nothing for {SILENT_S:g} s, not even to PING"
                f" (a hung firmware? everything received is in {self.rec.dir})"
            )
        silent = now - max(self._heard_at, self._pinged_at or self._heard_at)
        if silent >= PING_AFTER_S:
            self._pinged_at = now
            self.client.send(C.CMD_PING)  # its ACK carries the board's clock

    def _after_stall(self, step):
        """The host stood still (or its clock stepped back by -``step`` s): the board went
        on, and what it sent waits on the port.  Read it all and judge silence afresh from
        now.  What the board could not send meanwhile shows as a sequence gap once its next
        frames come, and in its STATUS ``tx_dropped``."""
        pause = {
            "at_s": round(self.elapsed() - max(0.0, step), 3),  # when it stood still
            "clock_step_s": round(step, 3),
            "lost_frames_before": self.client.decoder.counters.lost_frames,
        }
        before = self.rec.bytes
        for _ in range(DRAIN_READS):
            if not self.client.waiting():
                break
            self._handle(*self.client.read_timed())
        pause["bytes_waiting"] = self.rec.bytes - before
        self.pauses.append(pause)
        self.on_notice(self, stall_words(pause))
        self._heard_at, self._pinged_at = self.elapsed(), None
        self.run_clock.waited()  # (the reading just now: work, not a stall)

    # -- metadata -------------------------------------------------------------------
    def meta(self):
        """This session's entry in meta.json (``tactile.recording.layout`` adds the totals)."""
        return session_entry(self)

    def _write_meta(self):
        self._meta_at = self.elapsed()
        self.rec.write_meta(self.meta())
