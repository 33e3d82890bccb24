"""The board's clock in a recording, segment by segment, and its mapping to host time.

A board stamps every frame with a 32-bit microsecond clock that wraps every 71.6 min and
restarts at a reboot (PROTOCOL.md §3).  ``BoardClock`` reads a message stream in order and
gives each message its **segment** (one per boot seen: a new ``boot_id`` in HELLO/INFO, or
a HELLO whose clock went back) and its **unwrapped** board time within that segment (the
raw stamp plus 2^32 per wrap, counted from the segment's first frame).  Given arrival
times (``tactile record``), each segment also gathers the points of its board -> host fit
(``tactile.recording.timefit``); given none (a replay), it only numbers and unwraps, by the same
rule,
so a replay of ``capture.bin`` finds the segments the recorder found.

``Segment.to_meta`` is the segment's entry in ``meta.json``'s ``time_base``;
``mapping_from_meta`` reads one back.  The mapping is

    host_monotonic_s = host_monotonic_ref_s + (board_us - board_ref_us) * 1e-6 * rate
    host_utc_s       = host_utc_ref_s       + (board_us - board_ref_us) * 1e-6 * rate

with ``rate = 1 + drift_ppm * 1e-6`` and ``board_us`` unwrapped within the segment.
"""

from dataclasses import dataclass, field

import numpy as np

from tactile.board.stream_decoder import decode_bytes
from tactile.errors import DataError
from tactile.recording.timefit import BIN_S, TAU, BinMinima, fit
from tactile_protocol import constants as C

WRAP = C.TIMESTAMP_MODULO  # 2^32 us
HALF = WRAP // 2
# A fit whose rate is further than this from 1 is not a clock's drift (crystals differ by
# tens of ppm): an emulator in fast mode, whose simulated time outruns the wall clock.
MAX_DRIFT_PPM = 1000.0
SIMULATED = "simulated time: board time only (the port runs the board as fast as it can)"
METHOD = (
    f"the {TAU:.0%} quantile line of each bin's least (arrival - board time), bins of"
    f" {BIN_S:g} s or wider (tactile.recording.timefit)"
)


@dataclass
class Segment:
    """One boot's clock in the stream: ``boot_id``, the unwrapped board time of its first and
    latest frame (us), its arrival points, and the frames.csv rows it covers."""

    boot_id: int | None
    first_us: int
    last_us: int
    bins: BinMinima = field(default_factory=BinMinima)
    first_row: int | None = None
    rows: int = 0
    row_wraps: list = field(default_factory=list)  # (row, wraps) where the wrap count changes
    fitted: object = None  # the latest ClockFit (board s -> host monotonic s)
    simulated: bool = False  # the port said its board runs on simulated time

    def fit(self):
        self.fitted = fit(self.bins)
        return self.fitted

    def usable(self):
        """Whether the fit is a clock's (|drift| <= MAX_DRIFT_PPM) and the board's time is
        not simulated (a loaded machine can pace a fast emulator near the wall clock)."""
        fitted = self.fitted
        return not self.simulated and fitted is not None and abs(fitted.drift_ppm) <= MAX_DRIFT_PPM


class BoardClock:
    """See the module docstring.  ``stamp(m)`` -> (segment index, unwrapped board us, wraps)."""

    def __init__(self):
        self.segments = []
        self.simulated = False  # set from the port (``simulated_time``): no segment is usable
        self._prev = None  # raw stamp of the previous frame (of the current segment)
        self._wraps = 0
        self._boot = None

    def _new_segment(self, boot_id, raw):
        self.segments.append(Segment(boot_id, raw, raw, simulated=self.simulated))
        self._prev, self._wraps, self._boot = raw, 0, boot_id

    def stamp(self, m):
        """Place message ``m`` (anything with ``timestamp_us``; HELLO/INFO may start a new
        segment) and return (segment, unwrapped board us, wraps), or None for a frame that
        carries no trustworthy time (an invalid one)."""
        if m.type_code == 0:  # Invalid: its values are not acted on, its time neither
            return None
        raw = m.timestamp_us
        boot = getattr(m, "boot_id", None) if m.type_code in (C.MSG_HELLO, C.MSG_INFO) else None
        step = 0 if self._prev is None else (raw - self._prev) % WRAP
        if (
            self._prev is None
            or (boot is not None and self._boot not in (None, boot))
            or (step >= HALF and m.type_code == C.MSG_HELLO)  # the clock went back: a reboot
        ):
            self._new_segment(boot, raw)
            step = 0
        elif boot is not None:
            self._boot = self.segments[-1].boot_id = boot
        seg = self.segments[-1]
        if step < HALF:  # forward (or the same instant)
            if raw < self._prev:
                self._wraps += 1
            self._prev = raw
            us = raw + self._wraps * WRAP
        else:  # a frame from before the previous one (a broken transport reorders)
            us = self._prev + self._wraps * WRAP - (WRAP - step)
        seg.last_us = max(seg.last_us, us)
        return len(self.segments) - 1, us, self._wraps

    def observe(self, msgs, arrivals):
        """Stamp ``msgs`` in order; ``arrivals`` (host monotonic s per message, or None) feed
        the fits.  Returns the stamps."""
        out = []
        for k, m in enumerate(msgs):
            s = self.stamp(m)
            out.append(s)
            if s is not None and arrivals is not None and arrivals[k] is not None:
                self.segments[s[0]].bins.add(s[1] * 1e-6, arrivals[k])
        return out


class RecordingClock:
    """``tactile record``'s time base: stamps what arrives (``take``), refits, gives the host
    times of frames.csv rows (``host_of``) and the ``time_base`` entry of meta.json.

    ``rows_offset``: the file's rows before this session; ``utc_minus_mono``: UTC minus the
    monotonic clock when the session began (UTC = monotonic + it; a step of the wall clock
    during the run shows as ``utc_minus_monotonic_end_s``)."""

    def __init__(self, rows_offset=0, utc_minus_mono=0.0):
        from scipy.optimize import linprog  # noqa: F401  (~1 s to import: not mid-stream)

        self.board = BoardClock()
        self.rows_offset = rows_offset
        self.rows = 0
        self.utc_minus_mono = utc_minus_mono
        self.utc_minus_mono_end = None
        self.final = False  # frames.csv rewritten with the final fit
        self.fit_s = 0.0  # wall time of the latest fit (spaces the refits)

    def take(self, msgs, arrivals):
        """Stamp ``msgs``; return one (monotonic s, UTC s) or None per message: the host
        time of each SAMPLE/CONTACT (a frames.csv row) by the fit as it stands."""
        stamps = self.board.observe(msgs, arrivals)
        out = []
        for m, st in zip(msgs, stamps):
            if st is None or m.type_code not in (C.MSG_SAMPLE, C.MSG_CONTACT):
                out.append(None)
                continue
            seg = self.board.segments[st[0]]
            if seg.first_row is None:
                seg.first_row = self.rows_offset + self.rows
            wraps = (st[1] - m.timestamp_us) // WRAP
            if not seg.row_wraps or seg.row_wraps[-1][1] != wraps:
                seg.row_wraps.append((self.rows, wraps))
            seg.rows += 1
            self.rows += 1
            f = seg.fitted or seg.fit()
            mono = f.host0_s + f.rate * (st[1] * 1e-6 - f.board0_s)
            out.append((mono, mono + self.utc_minus_mono))
        return out

    def refit(self):
        """Refit every segment from its points so far."""
        import time

        t = time.perf_counter()
        for seg in self.board.segments:
            seg.fit()
        self.fit_s = time.perf_counter() - t

    def board_us(self):
        """The latest board time heard (us, unwrapped in the current segment), or None."""
        return self.board.segments[-1].last_us if self.board.segments else None

    def host_of(self, rows, stamps):
        """(monotonic s, UTC s) arrays for this session's rows ``rows`` (from 0) with raw
        board stamps ``stamps``, by each segment's current fit; NaN where it is unusable."""
        mono = np.full(len(rows), np.nan)
        for seg in self.board.segments:
            if seg.first_row is None or not seg.usable():
                continue
            lo = seg.first_row - self.rows_offset
            mine = (rows >= lo) & (rows < lo + seg.rows)
            if not np.any(mine):
                continue
            at, k = np.array(seg.row_wraps, dtype=np.int64).T
            wraps = k[np.clip(np.searchsorted(at, rows[mine], side="right") - 1, 0, None)]
            us = stamps[mine] + wraps * WRAP
            mono[mine] = seg.fitted.to_host(us * 1e-6)
        return mono, mono + self.utc_minus_mono

    def meta(self):
        return {
            "host_clocks": "monotonic: the host's CLOCK_MONOTONIC (s); utc: Unix time (s) ="
            " monotonic + utc_minus_monotonic_s",
            "method": METHOD,
            "utc_minus_monotonic_s": round(self.utc_minus_mono, 6),
            "utc_minus_monotonic_end_s": None
            if self.utc_minus_mono_end is None
            else round(self.utc_minus_mono_end, 6),
            "frames_csv": "final fit" if self.final else "the fit as each row was written",
            "segments": [segment_meta(s, self.utc_minus_mono) for s in self.board.segments],
        }


def segment_meta(seg, utc_minus_mono):
    """A segment's ``time_base`` entry for meta.json (its fit as of now)."""
    f = seg.fitted
    out = {
        "boot_id": seg.boot_id,
        "first_row": seg.first_row,
        "rows": seg.rows,
        "board_first_us": seg.first_us,
        "board_last_us": seg.last_us,
    }
    if f is None:
        return out | {"usable": False, "why": "no frame arrived with a time"}
    ref_us = int(round(f.board0_s * 1e6))
    host_ref = float(f.to_host(ref_us * 1e-6))
    out |= {
        "board_ref_us": ref_us,
        "host_monotonic_ref_s": round(host_ref, 9),
        "host_utc_ref_s": round(host_ref + utc_minus_mono, 6),
        "drift_ppm": round(f.drift_ppm, 4),
        "bins": f.bins,
        "frames": f.frames,
        "fit_floor_ms": round(f.floor_s * 1e3, 4),
        "arrival_delay_mean_ms": round(f.delay_mean_s * 1e3, 4),
        "arrival_delay_max_ms": round(f.delay_max_s * 1e3, 4),
        "usable": seg.usable(),
    }
    if not seg.usable():
        out["why"] = SIMULATED if seg.simulated else _why_unusable(f.rate)
    return out


def _why_unusable(rate):
    """Why a fit of ``rate`` (host s per board s) is no clock's: a board clock that outran the
    host's is an emulator in fast mode, whose frames have board time only."""
    if rate > 0 and 1 / rate > 1 + MAX_DRIFT_PPM * 1e-6:
        return (
            f"fast mode: board time only (the board's clock ran {1 / rate:.3g} x as fast as the"
            " host's, as an emulator's --fast does)"
        )
    pace = f"ran {1 / rate:.3g} x as fast as" if rate > 0 else "did not follow"
    limit = f"|drift| > {MAX_DRIFT_PPM:g} ppm"
    return f"the board clock {pace} the host's ({limit}): no crystal's drift"


@dataclass(frozen=True)
class Mapping:
    """One segment's board -> host mapping as meta.json stores it (see the module docstring)."""

    board_ref_us: int
    host_monotonic_ref_s: float
    host_utc_ref_s: float
    rate: float

    def host(self, board_us, clock="monotonic"):
        ref = self.host_monotonic_ref_s if clock == "monotonic" else self.host_utc_ref_s
        d = (np.asarray(board_us, dtype=np.int64) - self.board_ref_us) * 1e-6
        return ref + d * self.rate


def mapping_from_meta(entry):
    """The ``Mapping`` of a meta.json ``time_base`` segment, or None if it has none usable."""
    if not entry.get("usable") or "board_ref_us" not in entry:
        return None
    return Mapping(
        int(entry["board_ref_us"]),
        float(entry["host_monotonic_ref_s"]),
        float(entry["host_utc_ref_s"]),
        1.0 + float(entry["drift_ppm"]) * 1e-6,
    )


def recorded_times(data, meta, clock, where="recording"):
    """(messages, times) of a capture for a log stamped in a host ``clock`` ("utc" or
    "monotonic"): the messages decoded session by session, as the recorder decoded them, and
    each one's time in that clock (int64 us; -1 where its segment has no usable mapping).

    Raises ``DataError`` when no message has a time (a recording without a time base, or an
    emulator in fast mode, whose clock is not the host's)."""
    sessions = meta.get("sessions", [meta]) if isinstance(meta, dict) else []
    messages, times, why, offset = [], [], [], 0
    for ses in sessions:
        n = int(ses.get("bytes") or 0)
        msgs, _ = decode_bytes(data[offset : offset + n])
        offset += n
        entries = (ses.get("time_base") or {}).get("segments")
        if entries is None:
            why.append("meta.json has no time base (recorded by an older tactile)")
        maps = [mapping_from_meta(e) for e in entries or ()]
        why += [e["why"] for e in entries or () if e.get("why")]
        stamps = BoardClock().observe(msgs, None)
        seg = np.array([-1 if st is None else st[0] for st in stamps], dtype=np.int64)
        us = np.array([0 if st is None else st[1] for st in stamps], dtype=np.int64)
        t = np.full(len(msgs), -1, dtype=np.int64)
        for j, mapping in enumerate(maps):
            rows = np.flatnonzero(seg == j)
            if mapping is not None and rows.size:
                t[rows] = np.round(mapping.host(us[rows], clock) * 1e6).astype(np.int64)
        messages += msgs
        times.append(t)
    t = np.concatenate(times) if times else np.zeros(0, dtype=np.int64)
    if not np.any(t >= 0):
        reason = why[0] if why else "no frame was received"
        raise DataError(
            f"{where}: the log is stamped in {clock} time, but the recording cannot say when"
            f" its frames were taken in that clock: {reason}"
        )
    return messages, t
