"""``meta.json`` across ``tactile record --append`` runs: one entry per session, totals that
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
"""

import json
import math

from tactile.board.client import info_dict
from tactile.errors import InputError
from tactile.files import bounded
from tactile.files.writing import write_bytes
from tactile.output.text import clean
from tactile.recording.run_state import span_s
from tactile_protocol import constants as C

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
