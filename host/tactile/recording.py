"""A recording directory, written so that a crash loses nothing already received.

Files (``tactile record -o DIR``):

- ``capture.bin``: every byte read from the port, appended and flushed per read;
  the source of truth (``tactile decode DIR/capture.bin`` replays it).
- ``frames.csv``: one row per SAMPLE or CONTACT frame, SI units, appended and flushed.
- ``device.jsonl``: the other frames (HELLO, INFO, STATUS, NAK) as JSON lines.
- ``meta.json``: device INFO, configuration, calibration ids, counters, gaps;
  replaced atomically (write, fsync, rename) every second and at the end.

A directory that already holds a capture is refused unless ``append`` is set;
then the new bytes follow the old ones and nothing is ever truncated, and
meta.json keeps one entry per session with totals over them
(``tactile.recording_meta``).
"""

import json
import os
import pathlib

from tactile.errors import InputError
from tactile.jsonout import clean, dumps
from tactile.recording_meta import count_rows, document, previous_sessions
from tactile_protocol import constants as C

FRAME_COLUMNS = (
    "seq,timestamp_us,type,sensor,phase,contact_id,flags,fx_N,fy_N,fz_N,tx_Nm,ty_Nm,tz_Nm"
)
CAPTURE, FRAMES, DEVICE, META = "capture.bin", "frames.csv", "device.jsonl", "meta.json"


def _frame_row(m):
    """Forces in N, torques in N*m: 1 uN / 1 uN*m counts, so six decimals are exact."""
    phase, cid = ("", "") if m.type_code == C.MSG_SAMPLE else (m.phase, m.contact_id)
    w = ",".join(f"{v / 1e6:.6f}" for v in (m.fx, m.fy, m.fz, m.tx, m.ty, m.tz))
    return f"{m.seq},{m.timestamp_us},{m.type_name},{m.sensor},{phase},{cid},{m.flags},{w}\n"


class Recording:
    """The open files of one recording directory; see the module docstring."""

    def __init__(self, outdir, append=False):
        self.dir = pathlib.Path(outdir)
        capture = self.dir / CAPTURE
        if not append and capture.exists() and capture.stat().st_size > 0:
            raise InputError(
                f"{outdir}: already holds a recording (choose another -o, or --append to add to it)"
            )
        self.capture_offset = capture.stat().st_size if capture.exists() else 0
        self.rows_offset = count_rows(self.dir / FRAMES)
        self.previous = []  # the sessions already in the directory (--append)
        if self.capture_offset or self.rows_offset:
            self.previous = previous_sessions(
                self.dir / META, self.capture_offset, self.rows_offset
            )
        try:
            self.dir.mkdir(parents=True, exist_ok=True)
            self._capture = open(self.dir / CAPTURE, "ab")
            new = not (self.dir / FRAMES).exists() or (self.dir / FRAMES).stat().st_size == 0
            self._frames = open(self.dir / FRAMES, "a", encoding="utf-8")
            self._device = open(self.dir / DEVICE, "a", encoding="utf-8")
        except OSError as exc:
            raise InputError(f"{outdir}: cannot write the recording: {exc.strerror}") from None
        if new:
            self._frames.write(FRAME_COLUMNS + "\n")
        self.bytes = 0

    def raw(self, data):
        """Append raw bytes (before anything else looks at them) and flush."""
        self._capture.write(data)
        self._capture.flush()
        self.bytes += len(data)

    def messages(self, msgs):
        """Append decoded frames to frames.csv / device.jsonl and flush."""
        rows, other = [], []
        for m in msgs:
            if m.type_code in (C.MSG_SAMPLE, C.MSG_CONTACT):
                rows.append(_frame_row(m))
            elif m.type_code != C.MSG_ACK:
                other.append(dumps(m.to_dict()) + "\n")
        if rows:
            self._frames.write("".join(rows))
            self._frames.flush()
        if other:
            self._device.write("".join(other))
            self._device.flush()

    def write_meta(self, session):
        """Replace meta.json (the sessions before this one, then ``session``) atomically:
        a reader never sees half a file."""
        path = self.dir / META
        tmp = path.with_suffix(".json.tmp")
        doc = document(self.previous + [session])
        with open(tmp, "w", encoding="utf-8") as fh:
            fh.write(json.dumps(clean(doc), indent=2, allow_nan=False) + "\n")
            fh.flush()
            os.fsync(fh.fileno())
        os.replace(tmp, path)

    def close(self):
        for fh in (self._capture, self._frames, self._device):
            fh.close()


def remove_recording(outdir):
    """Delete the files a recording writes in ``outdir`` (for scratch output like the demo's)."""
    for name in (CAPTURE, FRAMES, DEVICE, META, "contacts.csv", "probes.csv"):
        (pathlib.Path(outdir) / name).unlink(missing_ok=True)


# --- reading frames.csv back (``tactile.recording_load``) ------------------------------------

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
# The units a '# units:' line of frames.csv may name: its columns are N, N*m, us and s.
FRAME_UNITS = frozenset({"si", "n", "n*m", "nm", "n.m", "n·m", "m", "s", "us", "µs"})
# A recording is the project's own file and may be long: 1 kHz x 3 sensors for 55 min.
MAX_FRAMES_BYTES = 2 * 2**30
MAX_FRAME_ROWS = 10_000_000


def read_frames(path):
    """frames.csv as a ``tabular.Table`` (``FRAME_NUMBERS``, ``FRAME_BLANKS`` as NaN where
    empty, ``type`` as text), after checking that a ``# units:`` line names SI units."""
    import re

    from tactile.tabular import read_csv, show, units_line

    stated = units_line(path)
    if stated is not None:
        line_no, text = stated
        wrong = [u for u in re.split(r"[\s,;()]+", text.lower()) if u and u not in FRAME_UNITS]
        if wrong or not text:
            raise InputError(
                f"{path}:{line_no}: units {show(text)}: frames.csv holds N, N*m and s (SI);"
                " this file says otherwise"
            )
    return read_csv(
        path,
        FRAME_NUMBERS,
        optional_text=("type",),
        blank_float=FRAME_BLANKS,
        max_bytes=MAX_FRAMES_BYTES,
        max_rows=MAX_FRAME_ROWS,
    )
