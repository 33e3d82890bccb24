"""The run's files as laid out: meta.json, frames.csv and the file names.

**``meta.json``** across ``tactile record --append`` runs: one entry per session, totals that
match the files.

The document keeps the keys one session always had, so a reader needs no second path:

- counts (``frames``, ``samples``, ``contacts_*``, ``bytes``, ``reboots``, ``elapsed_s``,
  ``device_time_s``, ``tx_dropped``, every ``decoder`` counter) are totals over the
  sessions, and ``gaps`` and ``pauses`` list every session's in order: ``bytes`` is the size
  of ``capture.bin`` and ``samples`` the number of rows in ``frames.csv``;
- the rest (``command``, ``port``, ``device``, ``ended``, ``time_base``, ...) is the latest
  session's;
- ``time_base`` (``tactile.recording.timebase``): the board -> host clock mapping, one entry per
  segment of the board's clock (a boot), each with the frames.csv rows it covers
  (``first_row``, ``rows``), the mapping ``host_*_ref_s + (board_us - board_ref_us) * 1e-6 *
  (1 + drift_ppm * 1e-6)`` and its quality (``fit_floor_ms``, ``arrival_delay_*_ms``);
  ``usable`` false when it is not a clock's (an emulator in fast mode);
- ``sessions`` holds each run's own entry, with ``capture_offset`` and ``rows_offset``:
  where its bytes in ``capture.bin`` and its rows in ``frames.csv`` begin.

A meta.json without ``sessions`` (one run, before this layout) reads as one session.  When
the sessions do not account for everything already in the files (a crash less than a
second after the last rewrite, or an older ``--append`` that overwrote the first run's
entry), an entry ``{"unrecorded": true, ...}`` holds the difference, so the totals still
match the files.

**frames.csv and the run's file names**: the row as it is written, whole lines, and the file
read back.  Below ``files`` (the writer) and ``recover`` (runs cut short), which both use it.

A row (``frame_row``): ``FRAME_COLUMNS``, forces in N and torques in N*m to six decimals
(1 uN and 1 uN*m counts: exact), the host's time of the stamp to the microsecond, or empty
cells.  A write that fails raises ``WriteFailed`` naming the file and meta.json's word for
it (``WRITE_ENDS``); ``cut_torn`` and ``whole_end`` find the last whole line of a file a
crash or a full disk tore.  ``read_frames`` reads frames.csv back (``tactile.recording.load``).
"""

import errno
import json
import math
import os
import pathlib
import stat

from tactile import units
from tactile.board.client import info_dict
from tactile.errors import HostFileError, InputError
from tactile.files import bounded
from tactile.files.tabular import read_csv
from tactile.files.writing import write_bytes
from tactile.output.text import clean
from tactile.recording.run_state import span_s
from tactile_protocol import constants as C
from tactile_protocol.settings import wrench_si

MAX_META_BYTES = 64 * 2**20  # meta.json: a few kB, more with many gaps

SUMMED = (
    "frames",
    "samples",
    "late_samples",
    "contacts_begun",
    "contacts_ended",
    "bytes",
    "reboots",
    "elapsed_s",
    "device_time_s",
    "tx_dropped",
)
LATEST = (
    "tactile_version",
    "protocol_version",
    "port",
    "command",
    "ended",
    "board",
    "tared",
    "stops_at",
    "time_base",
)


def count_rows(path, header=True, strict=True):
    """Lines in ``path`` (less its header and the ``#`` lines before it: the units line),
    read in bounded chunks; 0 if it does not exist (or, ``strict`` false, is not a regular
    file: a recording file on a device such as /dev/full); else ``InputError`` if it is not a
    regular file."""
    try:
        fh = bounded.open_regular(path, None, "a recording's frames.csv")
    except bounded.Missing:
        return 0
    except InputError:
        if strict:
            raise
        return 0
    with fh:
        comments = 0
        while header and fh.read(1) == b"#":
            comments += 1
            _skip_line(fh)
        fh.seek(0)
        lines = sum(chunk.count(b"\n") for chunk in iter(lambda: fh.read(1 << 20), b""))
    return max(0, lines - 1 - comments) if header else lines


def _skip_line(fh):
    """Read past the next line break, a chunk at a time (a line may be any length)."""
    while chunk := fh.read(1 << 16):
        end = chunk.find(b"\n")
        if end >= 0:
            fh.seek(end + 1 - len(chunk), 1)
            return


def previous_sessions(path, capture_bytes, rows):
    """The session entries of the meta.json at ``path`` for a recording being appended to,
    plus an ``unrecorded`` entry for bytes and rows of the files that they miss."""
    try:
        old = bounded.read_json(path, MAX_META_BYTES, "a recording's meta.json")
    except bounded.Missing:
        old = {"sessions": []}
    except InputError as exc:
        raise InputError(f"{path}: cannot append: {exc}; move it away") from None
    if not isinstance(old, dict):
        raise InputError(f"{path}: cannot append: not a recording's meta.json; move it away")
    sessions = old.get("sessions", [old])
    if not isinstance(sessions, list) or not all(isinstance(s, dict) for s in sessions):
        raise InputError(f"{path}: cannot append: 'sessions' is not a list of objects")
    sessions = list(sessions)
    missing_bytes = capture_bytes - sum(_count(s, "bytes") for s in sessions)
    missing_rows = rows - sum(_count(s, "samples") for s in sessions)
    if missing_bytes or missing_rows:
        sessions.append(
            {
                "unrecorded": True,
                "why": "in the files but not in meta.json (a crash, or an older --append)",
                "bytes": missing_bytes,
                "samples": missing_rows,
            }
        )
    return sessions


def _count(session, key):
    """A session's count ``key``, 0 when absent or not a finite number (a hostile file)."""
    v = session.get(key)
    ok = isinstance(v, int | float) and not isinstance(v, bool) and math.isfinite(v)
    return v if ok else 0


def _decoder_totals(sessions):
    counters = [s["decoder"] for s in sessions if isinstance(s.get("decoder"), dict)]
    if not counters:
        return None
    out = {}
    for k in counters[-1]:
        values = [c.get(k) for c in counters]
        if not k.startswith("last_") and all(isinstance(v, int | float | None) for v in values):
            out[k] = sum(v or 0 for v in values)  # a count: the total over the sessions
        else:  # a description (last_version, last_invalid): the latest one given
            given = [v for v in values if v is not None]
            out[k] = given[-1] if given else None
    return out


def document(sessions):
    """The meta.json document for ``sessions`` (oldest first, the running one last)."""
    latest = sessions[-1]
    doc = {k: latest.get(k) for k in LATEST}
    devices = [s["device"] for s in sessions if s.get("device")]
    doc["device"] = devices[-1] if devices else None
    doc["device_status"] = latest.get("device_status", [])
    for k in SUMMED:
        total = sum(_count(s, k) for s in sessions)
        doc[k] = round(total, 3) if isinstance(total, float) else total
    for k in ("gaps", "pauses"):
        doc[k] = [g for s in sessions if isinstance(s.get(k), list) for g in s[k]]
    doc["decoder"] = _decoder_totals(sessions)
    if latest.get("payload") is not None:  # record --payload (tactile.payload)
        doc["payload"] = latest["payload"]
    doc["sessions"] = sessions
    return doc


def read_meta(path):
    """The meta.json document at ``path`` (a dict), or ``InputError`` naming what is wrong."""
    try:
        doc = bounded.read_json(path, MAX_META_BYTES, "a recording's meta.json")
    except bounded.Missing:
        raise InputError(f"{path}: no such file (not a 'tactile record' directory?)") from None
    if not isinstance(doc, dict):
        raise InputError(f"{path}: not a recording's meta.json (not a JSON object)")
    return doc


def sessions_of(doc):
    """The session entries of a meta.json document, oldest first (an older single-run
    document is its own one session)."""
    sessions = doc.get("sessions")
    if not isinstance(sessions, list) or not sessions:
        return [doc]
    return [s for s in sessions if isinstance(s, dict)]


def session_entry(session):
    """A recording session's own entry (``tactile.recording.session.Session.meta``)."""
    client, s, rec = session.client, session.stats, session.rec
    info = client.info if client is not None else None
    return {
        "tactile_version": session.version,
        "protocol_version": C.PROTOCOL_VERSION,
        "port": session.port_name,
        "command": session.argv,
        "started_at": session.started_at,
        "ended": session.ended,
        "elapsed_s": round(session.elapsed(), 3),
        "device": info_dict(info) if info is not None else None,
        "board": session.identity.meta(),
        "tared": session.tared,  # a TARE the board acknowledged
        "frames": s.frames,
        "samples": rec.rows,  # = s.samples, or what frames.csv kept of a failed write
        "late_samples": s.late_samples,
        "contacts_begun": s.contacts_begun,
        "contacts_ended": s.contacts_ended,
        "device_time_s": span_s(s.first_ts, s.last_ts),
        "device_status": list(s.status.values()),
        "reboots": client.decoder.counters.reboots if client is not None else 0,
        "gaps": session.gaps,
        "pauses": session.pauses,
        "tx_dropped": s.tx_dropped,
        "bytes": rec.bytes,
        "capture_offset": rec.capture_offset,
        "rows_offset": rec.rows_offset,
        "decoder": client.decoder.counters.as_dict() if client is not None else None,
        "stops_at": None if session.log_end is None else session.log_end.meta(),
        "time_base": session.timing.meta(),
    } | _payload(session)


def _payload(session):
    """meta.json's "payload" of a run with tools (``record --payload``)."""
    payload = getattr(session, "payload", None)
    return {"payload": payload.meta()} if payload else {}


def amend(path, key, value):
    """Set ``key`` of the meta.json at ``path`` to ``value`` (at the top and in the latest
    session's entry, so an ``--append`` keeps it) and replace the file whole."""
    doc = read_meta(path)
    doc[key] = value
    sessions = doc.get("sessions")
    if isinstance(sessions, list) and sessions and isinstance(sessions[-1], dict):
        sessions[-1][key] = value
    write_bytes(path, json.dumps(clean(doc), indent=2, allow_nan=False) + "\n")


FRAME_COLUMNS = (
    "seq,timestamp_us,host_monotonic_s,host_utc_s,type,sensor,phase,contact_id,flags,"
    "fx_N,fy_N,fz_N,tx_Nm,ty_Nm,tz_Nm"
)
CAPTURE, FRAMES, DEVICE, META = "capture.bin", "frames.csv", "device.jsonl", "meta.json"
# meta.json's ``ended`` for a write that failed, by errno (anything else: "write failed")
WRITE_ENDS = {errno.ENOSPC: "disk full", errno.EDQUOT: "disk full", errno.EFBIG: "file too large"}


class WriteFailed(HostFileError):
    """Writing ``path`` failed: ``ended`` is meta.json's word for it ("disk full", ...)."""

    def __init__(self, path, exc):
        self.path = pathlib.Path(path)
        self.ended = WRITE_ENDS.get(exc.errno, "write failed")
        why = exc.strerror or str(exc)
        same = why.lower() == self.ended
        super().__init__(f"{path}: {self.ended}" + ("" if same else f" ({why})"))


def put(fh, text, path):
    """Write and flush, or ``WriteFailed`` naming ``path``."""
    try:
        fh.write(text)
        fh.flush()
    except OSError as exc:
        raise WriteFailed(path, exc) from None


def _host_cells(host):
    """``host_monotonic_s,host_utc_s`` to the microsecond, or empty cells when unknown."""
    return ",".join("" if v is None else f"{v:.6f}" for v in host) if host else ","


def frame_row(m, host=None):
    """Forces in N, torques in N*m: 1 uN / 1 uN*m counts, so six decimals are exact;
    ``host`` = (monotonic s, UTC s) of the frame's stamp, or None."""
    phase, cid = ("", "") if m.type_code == C.MSG_SAMPLE else (m.phase, m.contact_id)
    w = ",".join(f"{v:.6f}" for v in wrench_si(m.fx, m.fy, m.fz, m.tx, m.ty, m.tz))
    return (
        f"{m.seq},{m.timestamp_us},{_host_cells(host)},{m.type_name},{m.sensor},{phase},{cid},"
        f"{m.flags},{w}\n"
    )


def cut_torn(path):
    """Cut ``path`` back to the end of its last whole line (a write torn by a full disk
    or a kill); return the bytes cut.  Truncating needs no free space."""
    try:
        with open(path, "r+b") as fh:
            if not stat.S_ISREG(os.fstat(fh.fileno()).st_mode):
                return 0
            end = fh.seek(0, os.SEEK_END)
            pos = _whole_lines_end(fh)
            if pos < end:
                fh.truncate(pos)
            return end - pos
    except FileNotFoundError:
        return 0


def whole_end(path):
    """(bytes up to the end of the last whole line, bytes after it) of ``path``; (None, 0)
    when it does not exist; ``InputError`` when it is not a regular file."""
    try:
        with bounded.open_regular(path, None, "a recording's file") as fh:
            size = fh.seek(0, os.SEEK_END)
            end = _whole_lines_end(fh)
            return end, size - end
    except bounded.Missing:
        return None, 0


def _whole_lines_end(fh):
    """The offset just past the last line break of the open binary file ``fh`` (0: none),
    read backwards a block at a time."""
    pos = fh.seek(0, os.SEEK_END)
    while pos > 0:
        start = max(0, pos - 4096)
        fh.seek(start)
        k = fh.read(pos - start).rfind(b"\n")
        if k >= 0:
            return start + k + 1
        pos = start
    return 0


FRAME_NUMBERS = (
    "seq",
    "timestamp_us",
    "sensor",
    "flags",
    *("fx_N", "fy_N", "fz_N", "tx_Nm", "ty_Nm", "tz_Nm"),
)
# Empty where not given: phase and contact id of a SAMPLE; the host time of a row whose
# board -> host mapping is unusable (the columns themselves are a newer recorder's).
FRAME_BLANKS = ("phase", "contact_id", "host_monotonic_s", "host_utc_s")
# A recording is the project's own file and may be long: 1 kHz x 3 sensors for 55 min.
MAX_FRAMES_BYTES = 2 * 2**30
MAX_FRAME_ROWS = 10_000_000


def read_frames(path, end=None):
    """frames.csv as a ``tabular.Table`` (``FRAME_NUMBERS``, ``FRAME_BLANKS`` as NaN where
    empty, ``type`` as text), after checking that a ``# units:`` line names SI units;
    ``end``: only its first ``end`` bytes."""
    units.check_stated(path, units.FRAME_WORDS, "frames.csv holds N, N*m, us and s (SI)")
    return read_csv(
        path,
        FRAME_NUMBERS,
        optional_text=("type",),
        blank_float=FRAME_BLANKS,
        max_bytes=MAX_FRAMES_BYTES,
        max_rows=MAX_FRAME_ROWS,
        end=end,
    )
