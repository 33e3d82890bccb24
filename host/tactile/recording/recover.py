"""A recording cut short (killed, a full disk) read whole, from ``capture.bin`` where needed.

The recorder appends every byte it reads to capture.bin before it decodes them, so
capture.bin holds every reading that arrived.  A run cut short may have

- no meta.json (killed before its first write, during the handshake) or an unreadable one;
- a frames.csv that lacks the last readings (killed between the two writes), that ends in
  a torn row (a full disk), or none at all.

``tactile.load_recording`` reads such a run through ``meta_of`` and ``frames_of``:
meta.json or a stand-in, then frames.csv's whole rows followed by the readings capture.bin
holds beyond them (``lines`` -1: not in frames.csv), each repair with a note saying so.
``complete_frames`` makes the same repair on disk before ``tactile record --append`` adds
to a run, so its rows follow whole ones.

capture.bin is decoded only when the files say the run was cut short (meta.json missing or
unreadable, ``ended`` running, error or a failed write, counts that differ from the files,
a torn row), session by session as the recorder decoded it: a new decoder where each
``--append`` run began (``capture_offset``).
"""

import json
import math
import os
import pathlib
import stat
from array import array

from tactile import units
from tactile.board.stream_decoder import StreamDecoder
from tactile.errors import InputError
from tactile.files.tabular import Table
from tactile.recording.layout import (
    CAPTURE,
    DEVICE,
    FRAME_COLUMNS,
    FRAMES,
    MAX_META_BYTES,
    META,
    WRITE_ENDS,
    count_rows,
    cut_torn,
    frame_row,
    put,
    read_frames,
    read_meta,
    sessions_of,
    whole_end,
)
from tactile_protocol import constants as C
from tactile_protocol.settings import wrench_si

CUT_SHORT = {"running", "error", "write failed", *WRITE_ENDS.values()}
ROW_TYPES = (C.MSG_SAMPLE, C.MSG_CONTACT)
CHUNK = 1 << 16


def meta_of(path):
    """(meta.json as a dict, notes).  Missing or unreadable beside a capture.bin with bytes:
    a stand-in ``{"ended": None, "rebuilt": why}`` and a note; else ``InputError``."""
    meta_path = pathlib.Path(path) / META
    try:
        meta = read_meta(meta_path)
    except InputError:
        if not _capture_size(path) or _not_a_torn_file(meta_path):
            raise
        why = "unreadable" if meta_path.exists() else "missing"
        note = f"{meta_path}: {why} (the run was cut short): read from capture.bin alone"
        return {"ended": None, "rebuilt": f"meta.json {why}"}, [note]
    if meta.get("ended") == "running":
        return meta, [f"{meta_path}: says 'running': the run was cut short (or still records)"]
    return meta, []


def _not_a_torn_file(path):
    """A meta.json no cut-short run leaves, refused (exit 2) rather than read around: a
    device, FIFO or directory, beyond the bound, or JSON that parses past a break but is
    nested or numbered beyond what the reader takes (a torn file is a syntax error)."""
    try:
        info = os.stat(path)
        if not stat.S_ISREG(info.st_mode) or info.st_size > MAX_META_BYTES:
            return True
        text = pathlib.Path(path).read_bytes().decode("utf-8", "replace")
    except OSError:
        return False
    try:
        json.loads(text)
    except json.JSONDecodeError:
        return False
    except (RecursionError, ValueError):  # (a JSONDecodeError is a ValueError: caught first)
        return True
    return True  # it parses: what was wrong with it is not tearing


def frames_of(path, meta):
    """(frames.csv's whole rows and the readings capture.bin holds beyond them as a
    ``tabular.Table``, notes)."""
    path = pathlib.Path(path)
    frames, notes = path / FRAMES, []
    end, torn = whole_end(frames)
    table = None
    if end is None:
        notes.append(f"{frames}: missing: the rows are rebuilt from capture.bin")
    elif count_rows(frames):
        table = read_frames(frames, end=end if torn else None)
    if torn:
        line = count_rows(frames, header=False) + 1
        notes.append(
            f"{frames}:{line}: a torn last row ({torn} bytes, no line end) left out;"
            " capture.bin holds its reading"
        )
    n = 0 if table is None else len(table)
    if not (torn or table is None or cut_short(meta, _capture_size(path), n)):
        return table, notes
    extra, same = beyond(path, meta, table)
    if not same:
        notes.append(f"{path / CAPTURE}: its readings are not frames.csv's: frames.csv read as is")
    elif extra:
        notes.append(
            f"{frames}: {len(extra):,} reading{'s' * (len(extra) != 1)} after its last whole"
            f" row rebuilt from capture.bin (the run ended: {meta.get('ended') or 'unknown'})"
        )
        table = _extended(frames, table, extra)
    if table is None:
        raise InputError(f"{path}: no reading was recorded (frames.csv and capture.bin hold none)")
    return table, notes


def complete_frames(run):
    """Before ``--append``: frames.csv and device.jsonl cut back to their last whole line,
    frames.csv completed from capture.bin (host-time cells empty); returns the rows added.
    Files it cannot read are left as they are (the append's own checks name them)."""
    run = pathlib.Path(run)
    frames = run / FRAMES
    torn = cut_torn(frames)
    cut_torn(run / DEVICE)
    rows = count_rows(frames)
    try:
        meta = read_meta(run / META) if (run / META).exists() else {"rebuilt": "missing"}
        if not (torn or rows == 0 or cut_short(meta, _capture_size(run), rows)):
            return 0
        extra, same = beyond(run, meta, read_frames(frames) if rows else None)
    except InputError:
        return 0
    if not (same and extra):
        return 0
    text = "".join(frame_row(m) for m in extra)
    if not frames.exists() or frames.stat().st_size == 0:
        text = units.line(units.FRAMES) + FRAME_COLUMNS + "\n" + text
    with open(frames, "a", encoding="utf-8") as fh:
        put(fh, text, frames)
    return len(extra)


def cut_short(meta, capture_bytes, rows):
    """True when meta.json says, or the files show, that the run did not end cleanly."""
    return (
        bool(meta.get("rebuilt"))
        or meta.get("ended") in CUT_SHORT
        or meta.get("bytes") != capture_bytes
        or meta.get("samples") != rows
    )


def beyond(path, meta, table):
    """(the readings of capture.bin after the ``table``'s rows, whether the first ones are
    the table's, by seq, stamp and sensor)."""
    n = 0 if table is None else len(table)
    cols = () if table is None else [table.columns[k] for k in ("seq", "timestamp_us", "sensor")]
    extra, i = [], 0
    for m in readings(path, meta):
        if i < n:
            if (m.seq, m.timestamp_us, m.sensor) != tuple(int(c[i]) for c in cols):
                return [], False
        else:
            extra.append(m)
        i += 1
    return extra, i >= n


def readings(path, meta):
    """Yield the SAMPLE and CONTACT messages of capture.bin, decoded session by session."""
    size = _capture_size(path)
    if not size:
        return
    starts = sorted(
        {0}
        | {
            s["capture_offset"]
            for s in sessions_of(meta)
            if isinstance(s.get("capture_offset"), int) and 0 < s["capture_offset"] < size
        }
    )
    with open(pathlib.Path(path) / CAPTURE, "rb") as fh:
        for a, b in zip(starts, [*starts[1:], size]):
            decoder = StreamDecoder(older=True)  # (a run recorded before a version change)
            fh.seek(a)
            left = b - a
            while left > 0 and (chunk := fh.read(min(CHUNK, left))):
                left -= len(chunk)
                yield from (m for m in decoder.feed(chunk) if m.type_code in ROW_TYPES)


def _capture_size(path):
    """Bytes in capture.bin; 0 when it is missing or not a regular file (a device)."""
    try:
        st = os.stat(pathlib.Path(path) / CAPTURE)
    except OSError:
        return 0
    return st.st_size if stat.S_ISREG(st.st_mode) else 0


def _cells(m):
    """A reading as frames.csv's cells: numbers, blanks (NaN) and its type."""
    contact = m.type_code == C.MSG_CONTACT
    nan = math.nan
    return {
        "seq": m.seq,
        "timestamp_us": m.timestamp_us,
        "sensor": m.sensor,
        "flags": m.flags,
        **dict(
            zip(
                ("fx_N", "fy_N", "fz_N", "tx_Nm", "ty_Nm", "tz_Nm"),
                wrench_si(m.fx, m.fy, m.fz, m.tx, m.ty, m.tz),
            )
        ),
        "phase": m.phase if contact else nan,
        "contact_id": m.contact_id if contact else nan,
        "host_monotonic_s": nan,
        "host_utc_s": nan,
        "type": m.type_name,
    }


def _extended(frames, table, extra):
    """``table`` (or nothing) followed by the rows of ``extra``, at line -1."""
    cells = [_cells(m) for m in extra]
    if table is None:
        names = [k for k in cells[0] if not k.startswith("host_")]
        columns = {k: array("d") if k != "type" else [] for k in names}
        lines = array("q")
    else:
        columns = {k: (array("d", v) if isinstance(v, array) else list(v))
                   for k, v in table.columns.items()}  # fmt: skip
        lines = array("q", table.lines)
    for c in cells:
        for k, col in columns.items():
            col.append(c[k])
    lines.extend([-1] * len(cells))
    return Table(frames, columns, lines)
