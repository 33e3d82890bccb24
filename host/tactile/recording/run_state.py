"""What a recording run keeps as it reads: its board, its own clock, its counts, its end.

**Which board** a recording is of, and holding a reconnection's bytes until the board is known.

A port that comes back after it was lost may not lead to the same board: on a shared machine
another board can take the path (``/dev/ttyACM0``) while this one is unplugged.  HELLO and
INFO carry the board's unique id (``board_id``, PROTOCOL.md section 4: on a Pico its flash
chip's id) and its ``boot_id``.  ``BoardIdentity`` remembers the id from the run's first
HELLO and every boot id since; after a reconnection it accepts the same board, rebooted or
not, and refuses another (``OtherBoard``, exit 4: ``tactile.recording.session`` ends the run
there, everything of its own board kept).

``Held`` keeps a reconnection's bytes out of the capture until the board answering has said
who it is: the same board's bytes then go to the capture, in order, as if never held; another
board's are dropped and the decoder is put back as it was before them, so its frames, counts
and reboot are not this recording's.  An attempt that fails before any HELLO keeps its bytes
(``release``): nothing says they are another board's.

**A recording's own time**: seconds since it started that never go back, and the host's stalls.

``record`` reads its board in a loop whose turns take a read timeout and a few writes: tens
of milliseconds.  A turn much longer than that is not the board's doing: the host stood
still (Ctrl-Z then ``fg``, a paused VM, a disk that took seconds to write).  The board went
on meanwhile, and what it sent waits on the port (or was dropped by the board, which its
sequence numbers and STATUS ``tx_dropped`` say).  ``RunClock`` tells the loop so, and the
loop reads what waits before it judges anything by the clock (``tactile.recording.session``).

The host's monotonic clock may also step back (a VM restored or migrated): ``elapsed()``
adds only the forward steps, so it never goes back and never goes below 0, and a step back
is reported as a stall too.

**What a recording run counts** as it reads: frames, readings, contacts, the board's own
STATUS counters, and the device time its frames cover (meta.json's counts).

**When a recording with a pose log stops**: once the log's end has passed on the log's clock.

``until`` is (clock, end in us, how it was found): the clock is the board's (its latest stamp
heard, or between frames the board -> host fit at the host's time) or one of the host's
(monotonic, UTC), as ``tactile.logs.tags`` names them.
"""

import copy
import time

from tactile.board.stream_decoder import board_id_text
from tactile.errors import BoardError
from tactile.logs.tags import show_time
from tactile_protocol import constants as C


class OtherBoard(BoardError):
    """Another board answered on the port after it was lost (one line, exit 4)."""


class BoardIdentity:
    """The board of a run: its ``board_id`` (bytes) and the ``boot_ids`` seen, in order."""

    def __init__(self):
        self.board_id = None
        self.boot_ids = []

    def seen(self, info):
        """The board's HELLO/INFO: the first names the run's board; later ones may add a boot."""
        if not self.boot_ids:
            self.board_id = info.board_id
        if not self.boot_ids or self.boot_ids[-1] != info.boot_id:
            self.boot_ids.append(info.boot_id)

    def same(self, info):
        """Whether ``info`` (a HELLO/INFO after a reconnection) is this run's board."""
        return not self.boot_ids or info.board_id == self.board_id

    def rebooted(self, info):
        """Whether this run's board, back after a reconnection, booted since it was last seen."""
        return bool(self.boot_ids) and info.boot_id != self.boot_ids[-1]

    def refusal(self, port, info, where):
        """The one line that ends a run on which ``info``'s board answered, not its own."""
        return OtherBoard(
            f"{port}: another board answered after the port was lost (board id"
            f" {board_id_text(info.board_id)}, not this run's {board_id_text(self.board_id)});"
            f" recording stopped, everything from this run's board is in {where}"
        )

    def meta(self):
        if not self.boot_ids:
            return None
        return {"board_id": board_id_text(self.board_id), "boot_ids": list(self.boot_ids)}


class Held:
    """A reconnection attempt's bytes, held from ``client``'s capture until ``accept``ed
    (written with ``write``, in order) or ``refuse``d (dropped, the client put back)."""

    def __init__(self, client, write):
        self.client, self.write = client, write
        self.chunks = []
        self.saved = (copy.deepcopy(client.decoder), client.info, client.capture)
        client.capture = self.chunks.append

    @property
    def bytes(self):
        return sum(len(c) for c in self.chunks)

    def accept(self):
        """The board is this run's: the bytes go to the capture as they came."""
        self.client.capture = self.saved[2]
        for chunk in self.chunks:
            self.write(chunk)
        self.chunks = []

    release = accept  # an attempt that failed before the board said who it is

    def refuse(self):
        """Another board's: none of its bytes, frames or counts are this recording's.
        Returns how many bytes were dropped."""
        decoder, info, capture = self.saved
        self.client.decoder, self.client.info, self.client.capture = decoder, info, capture
        self.client.backlog, self.client.backlog_times = [], []
        dropped, self.chunks = self.bytes, []
        return dropped


STALL_S = 1.0  # a loop turn this long (host seconds) means the host stood still


class RunClock:
    """Elapsed seconds on ``clock`` (any monotonic-ish callable), and the stalls seen.

    ``elapsed()`` reads the clock; ``stall()`` returns (and forgets) the largest step seen
    between two readings beyond ``stall_s`` (or below 0), or None; ``waited()`` forgets it
    too, after a wait the caller made on purpose (a handshake, a TARE, a reconnection).
    """

    def __init__(self, clock=time.monotonic, stall_s=STALL_S):
        self.clock = clock
        self.stall_s = stall_s
        self._at = None  # the clock's latest reading
        self._elapsed = 0.0
        self._stall = None  # the step of an unreported stall

    def start(self):
        self._at, self._elapsed, self._stall = self.clock(), 0.0, None

    def elapsed(self):
        """Seconds since ``start()``: the sum of the clock's forward steps."""
        if self._at is None:
            return 0.0
        now = self.clock()
        step = now - self._at
        self._at = now
        if not 0.0 <= step <= self.stall_s and (
            self._stall is None or abs(step) > abs(self._stall)
        ):
            self._stall = step
        self._elapsed += max(0.0, step)
        return self._elapsed

    def stall(self):
        """The clock's step over the latest stall (s; negative: it went back), or None."""
        self.elapsed()
        step, self._stall = self._stall, None
        return step

    def waited(self):
        """The time since the last reading was a wait the caller made: not a stall."""
        self.elapsed()
        self._stall = None


def stall_words(pause):
    """One line for the user about a stall (an entry of meta.json's ``pauses``)."""
    at, step, read = pause["at_s"], pause["clock_step_s"], pause["bytes_waiting"]
    if step < 0:
        what = f"the host's clock stepped back {-step:.1f} s at {at:.1f} s (elapsed time goes on)"
    else:
        what = f"the host stood still for {step:.1f} s at {at:.1f} s (suspended? a slow disk?)"
    return f"{what}; read the {read:,} bytes that waited on the port; recording goes on"


def span_s(first_us, last_us):
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
        self.tx_dropped = 0  # frames the board says it dropped (STATUS), over its boots
        self._dropped_seen = 0  # ... the count of this boot's latest board STATUS

    def new_boot(self):
        """The board rebooted: its STATUS counters start again from 0."""
        self._dropped_seen = 0

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
                if m.sensor == C.SENSOR_ALL:  # (u32 counters: wrap)
                    self.tx_dropped += (m.tx_dropped - self._dropped_seen) % (1 << 32)
                    self._dropped_seen = m.tx_dropped
            if m.type_code == C.MSG_CONTACT:
                self.contacts_begun += m.phase == C.PHASE_BEGIN
                self.contacts_ended += m.phase == C.PHASE_END


class LogEnd:
    """The pose log's end for a session: ``passed()``, ``left_s()``, in words, in meta.json."""

    def __init__(self, until, timing, clock, utc):
        self.clock_name, self.end_us, self.how = until
        self.timing, self.clock, self.utc = timing, clock, utc

    def now_us(self):
        """Now on the log's clock (us): the board's latest stamp heard (-1: none yet), or a
        host clock's reading."""
        if self.clock_name == "board":
            now = self.timing.board_us()
            return -1 if now is None else now
        return round((self.clock() if self.clock_name == "monotonic" else self.utc()) * 1e6)

    def passed(self):
        return self.now_us() >= self.end_us

    def left_s(self):
        """Seconds until the log's end; None before any board time (a board-clock log)."""
        now = self.now_us()
        segments = self.timing.board.segments
        seg = segments[-1] if segments else None
        if self.clock_name == "board" and seg is not None and seg.usable():  # between frames
            now = max(now, round(float(seg.fitted.to_board(self.clock())) * 1e6))
        return None if now < 0 else max(0.0, (self.end_us - now) / 1e6)

    def words(self):
        when = show_time(self.clock_name, self.end_us)
        left = self.left_s()
        if left is None:
            return f"pose log end ({when}); no board time heard yet"
        return f"pose log end in {left:.1f} s ({when})"

    def meta(self):
        how = f"the pose log: {self.how}"
        return {"clock": self.clock_name, "time_us": self.end_us, "from": how}
