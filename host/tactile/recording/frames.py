"""frames.csv and the run's file names: the row as it is written, whole lines, and the file
read back.  Below ``files`` (the writer) and ``recover`` (runs cut short), which both use it.

A row (``frame_row``): ``FRAME_COLUMNS``, forces in N and torques in N*m to six decimals
(1 uN and 1 uN*m counts: exact), the host's time of the stamp to the microsecond, or empty
cells.  A write that fails raises ``WriteFailed`` naming the file and meta.json's word for
it (``WRITE_ENDS``); ``cut_torn`` and ``whole_end`` find the last whole line of a file a
crash or a full disk tore.  ``read_frames`` reads frames.csv back (``tactile.recording.load``).
"""

import errno
import os
import pathlib
import stat

from tactile import units
from tactile.errors import HostFileError
from tactile.files import bounded
from tactile.files.tabular import read_csv
from tactile_protocol import constants as C
from tactile_protocol.settings import wrench_si

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
