"""A recording directory, written so that a crash loses nothing already received.

Files (``tactile record -o DIR``):

- ``capture.bin``: every byte read from the port, appended and flushed per read;
  the source of truth (``tactile decode DIR/capture.bin`` replays it).
- ``frames.csv``: ``# units: N, N*m, us, s``, then one row per SAMPLE or CONTACT frame, SI
  units, appended and flushed; each row has the board's stamp (``timestamp_us``) and the
  host's time of it, monotonic and UTC (``host_monotonic_s``, ``host_utc_s``, from
  ``tactile.recording.timebase``): written with the fit as it stands, and rewritten with the final
  fit
  when the recording ends (``rewrite_host``).
- ``device.jsonl``: the other frames (HELLO, INFO, STATUS, NAK) as JSON lines.
- ``meta.json``: device INFO, configuration, calibration ids, counters, gaps;
  replaced whole (``tactile.files.writing``) every second and at the end.

One writer per directory: a ``Recording`` takes the directory's lock
(``tactile.files.writing``) before it reads or writes anything in it, making the
directory first if need be, and gives it back at ``close``; another process's recording or
export there is refused (``Busy``, exit 5) having touched nothing.  A session that received
nothing (no port, no board) is undone by ``discard``: the files it made are removed, the
others cut back, meta.json left as it was, and the directory removed if it made it.

A write that fails (a full disk) raises ``WriteFailed`` naming the file; ``settle`` then
leaves every file readable: frames.csv and device.jsonl cut back to their last whole line
(a torn row's reading is in capture.bin), the counts taken from the files.  meta.json that
cannot be replaced is overwritten in place, without indentation, when that fits the
file's length (no new space needed); otherwise the old one stays.  No temporary is left behind.

A directory that already holds a capture is refused unless ``append`` is set; then the
new bytes follow the old ones and nothing recorded is ever lost: a run cut short has its
torn last row cut and frames.csv completed from capture.bin first
(``tactile.recording.recover``), and meta.json keeps one entry per session with totals
over them (``tactile.recording.layout``).

frames.csv's row, the file names, the whole-line helpers and the reader are
``tactile.recording.layout``, below this module and ``recover``.
"""

import contextlib
import itertools
import json
import os
import pathlib
import stat

import numpy as np

from tactile import units
from tactile.errors import InputError
from tactile.files import writing
from tactile.output.text import clean, dumps
from tactile.recording.layout import (
    CAPTURE,
    DEVICE,
    FRAME_COLUMNS,
    FRAMES,
    META,
    WRITE_ENDS,
    WriteFailed,
    count_rows,
    cut_torn,
    document,
    frame_row,
    previous_sessions,
    put,
)
from tactile.recording.recover import complete_frames
from tactile_protocol import constants as C

REWRITE_ROWS = 65536  # rows per chunk when the host times are rewritten


def _refuse_pipe(path):
    """A recording's file may be a regular file or a device (/dev/null, or /dev/full to try
    a full disk); a FIFO, socket or directory there would hang or fail: refused at once."""
    try:
        mode = os.stat(path).st_mode
    except OSError:
        return
    if stat.S_ISFIFO(mode) or stat.S_ISSOCK(mode) or stat.S_ISDIR(mode):
        raise InputError(f"{path}: not a regular file (a recording's files must be files)")


class Recording:
    """The open files of one recording directory; see the module docstring."""

    def __init__(self, outdir, append=False):
        self.dir = pathlib.Path(outdir)
        self._lock = writing.hold(self.dir, create=True)  # before anything is read
        try:
            self._start(outdir, append)
        except BaseException:
            self._lock.release()  # (a folder it made, left empty, is removed)
            raise

    def _start(self, outdir, append):
        for name in (CAPTURE, FRAMES, DEVICE):
            _refuse_pipe(self.dir / name)
        capture = self.dir / CAPTURE
        if not append and capture.exists() and capture.stat().st_size > 0:
            raise InputError(
                f"{outdir}: already holds a recording (choose another -o, or --append to add to it)"
            )
        self.capture_offset = capture.stat().st_size if capture.exists() else 0
        if self.capture_offset:
            _check_columns(self.dir / FRAMES)
            complete_frames(self.dir)  # a torn or short frames.csv made whole first
        self.rows_offset = count_rows(self.dir / FRAMES, strict=False)
        self.previous = []  # the sessions already in the directory (--append)
        if self.capture_offset or self.rows_offset:
            _check_columns(self.dir / FRAMES)
            self.previous = previous_sessions(
                self.dir / META, self.capture_offset, self.rows_offset
            )
        writing.check_target(self.dir / META)  # replaced whole: a regular file or none
        self._before = {n: _before(self.dir / n) for n in (CAPTURE, FRAMES, DEVICE)}
        self._open_files(outdir)
        self.frames_offset = (self.dir / FRAMES).stat().st_size  # where this session's rows go
        self.rows = 0  # rows written by this session
        self.bytes = 0

    def _open_files(self, outdir):
        try:
            self._capture = open(self.dir / CAPTURE, "ab")
            new = not (self.dir / FRAMES).exists() or (self.dir / FRAMES).stat().st_size == 0
            self._frames = open(self.dir / FRAMES, "a", encoding="utf-8")
            self._device = open(self.dir / DEVICE, "a", encoding="utf-8")
        except OSError as exc:
            raise InputError(f"{outdir}: cannot write the recording: {exc.strerror}") from None
        if new:
            try:
                head = units.line(units.FRAMES) + FRAME_COLUMNS + "\n"
                put(self._frames, head, self.dir / FRAMES)
            except WriteFailed:
                self.discard()  # nothing recorded: nothing left of this session
                raise

    def raw(self, data):
        """Append raw bytes (before anything else looks at them) and flush."""
        put(self._capture, data, self.dir / CAPTURE)
        self.bytes += len(data)

    def messages(self, msgs, host=None):
        """Append decoded frames to frames.csv / device.jsonl and flush; ``host`` (one per
        message: (monotonic s, UTC s) or None) fills the host-time columns."""
        rows, other = [], []
        for k, m in enumerate(msgs):
            if m.type_code in (C.MSG_SAMPLE, C.MSG_CONTACT):
                rows.append(frame_row(m, None if host is None else host[k]))
            elif m.type_code != C.MSG_ACK:
                other.append(dumps(m.to_dict()) + "\n")
        if rows:
            put(self._frames, "".join(rows), self.dir / FRAMES)
            self.rows += len(rows)
        if other:
            put(self._device, "".join(other), self.dir / DEVICE)

    def rewrite_host(self, host_of):
        """Rewrite the host-time cells of this session's rows with ``host_of(rows,
        timestamps_us)`` -> (monotonic s, UTC s) arrays (row numbers count from this
        session's first; a NaN leaves its cell empty).  The copy replaces frames.csv
        atomically, so a crash leaves the rows as they were."""
        path = self.dir / FRAMES
        self._frames.close()
        try:
            with open(path, "rb") as src, writing.atomic_write(path) as dst:
                _copy_bytes(src, dst, self.frames_offset)
                row = 0
                while lines := list(itertools.islice(src, REWRITE_ROWS)):
                    parts = [ln.split(b",", 4) for ln in lines]
                    stamps = np.array([int(p[1]) for p in parts], dtype=np.int64)
                    mono, utc = host_of(np.arange(row, row + len(parts)), stamps)
                    dst.write(b"".join(_with_host(p, a, b) for p, a, b in zip(parts, mono, utc)))
                    row += len(parts)
        finally:
            self._frames = open(path, "a", encoding="utf-8")

    def write_meta(self, session):
        """Replace meta.json (the sessions before this one, then ``session``) atomically:
        a reader never sees half a file."""
        path = self.dir / META
        doc = clean(document(self.previous + [session]))
        try:
            writing.write_bytes(path, (json.dumps(doc, indent=2, allow_nan=False) + "\n").encode())
        except OSError as exc:  # (atomic's WriteError and PathRefused are OSErrors)
            compact = (json.dumps(doc, separators=(",", ":"), allow_nan=False) + "\n").encode()
            if exc.errno not in WRITE_ENDS or not _overwrite(path, compact):
                raise WriteFailed(path, exc) from None

    def settle(self):
        """After a failed write: close the files (a flush that fails again is let go), cut
        frames.csv and device.jsonl back to their last whole line, and count this session's
        bytes and rows from the files."""
        self._close_files()
        for name in (FRAMES, DEVICE):
            cut_torn(self.dir / name)
        self.bytes = _size(self.dir / CAPTURE) - self.capture_offset
        self.rows = count_rows(self.dir / FRAMES, strict=False) - self.rows_offset

    def discard(self):
        """Undo a session that received nothing: its files closed, the ones it made
        removed, the others cut back to their length before it (meta.json is not
        touched); ``close`` then removes the folder if it made it."""
        self._close_files()
        for name, size in self._before.items():
            path = self.dir / name
            with contextlib.suppress(OSError):
                if size is None:
                    path.unlink()
                elif _size(path) > size and path.is_file():
                    os.truncate(path, size)

    def _close_files(self):
        for fh in (getattr(self, n, None) for n in ("_capture", "_frames", "_device")):
            with contextlib.suppress(OSError, AttributeError):
                fh.close()

    def close(self):
        """Close every file (a flush that fails is let go: ``settle`` counts what landed)
        and give the folder's lock back."""
        self._close_files()
        self._lock.release()


def _size(path):
    try:
        return path.stat().st_size
    except OSError:
        return 0


def _before(path):
    """``path``'s size before a session (None: no such name), for ``discard``."""
    return _size(path) if os.path.lexists(path) else None


def _overwrite(path, data):
    """A full disk's last resort: ``data`` (meta.json without indentation, shorter than
    the indented one) written over ``path`` in place, padded with spaces to its length, so
    no new space is needed; True when it was written."""
    try:
        with open(path, "r+b") as fh:
            size = os.fstat(fh.fileno()).st_size
            if len(data) > size:
                return False
            fh.write(data[:-1] + b" " * (size - len(data)) + b"\n")
            fh.flush()
            os.fsync(fh.fileno())
    except OSError:
        return False
    return True


def _copy_bytes(src, dst, n):
    while n > 0:
        chunk = src.read(min(n, 1 << 20))
        if not chunk:
            return
        dst.write(chunk)
        n -= len(chunk)


def _cell(v):
    return b"" if v != v else b"%.6f" % v


def _with_host(parts, mono, utc):
    return b"%s,%s,%s,%s,%s" % (parts[0], parts[1], _cell(mono), _cell(utc), parts[4])


def _check_columns(path):
    """Rows are appended only under the header they match."""
    try:
        with open(path, encoding="utf-8") as fh:
            header = fh.readline().strip()
            while header.startswith("#"):  # the units line (none in an older recorder's)
                header = fh.readline().strip()
    except FileNotFoundError:
        return
    if header and header != FRAME_COLUMNS:
        raise InputError(
            f"{path}: cannot append: its columns are an older tactile's ({header[:40]}...);"
            " record into a new directory"
        )


def remove_recording(outdir):
    """Delete the files a recording writes in ``outdir`` (for scratch output like the demo's)."""
    for name in (CAPTURE, FRAMES, DEVICE, META, "contacts.csv", "probes.csv"):
        (pathlib.Path(outdir) / name).unlink(missing_ok=True)
