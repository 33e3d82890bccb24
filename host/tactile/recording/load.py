"""``tactile.load_recording(DIR)``: a ``tactile record`` directory as NumPy arrays in SI units.

It reads what the recorder wrote, through the modules that own each file:

- ``frames.csv`` (``tactile.recording.layout.read_frames``): one row per SAMPLE or CONTACT frame,
  forces in N, torques in N*m, the board's stamp in us and, from a recorder that maps the
  board's clock to the host's, the host time of each row (``host_monotonic_s``,
  ``host_utc_s``);
- ``meta.json`` (``tactile.recording.layout``): the sessions and, from such a recorder, the
  mapping itself (``time_base``: one line per run of the board's clock);
- ``contacts.csv`` when there is one (the EP2 contacts CSV, ``tactile.ep2.contacts_csv``):
  world points, converted to metres by its ``# units:`` line, and unit normals.

``capture.bin`` holds the same frames as frames.csv; it is read only for a run cut short
(``tactile.recording.recover``): meta.json missing or unreadable, frames.csv missing, torn
or short of what capture.bin holds.  The readings taken from it follow frames.csv's whole
rows, and ``notes`` says what was rebuilt, one sentence each.

**Board time.**  The board's 32-bit microsecond clock wraps every 71.6 min and restarts when
the board reboots (PROTOCOL.md §3).  Rows are cut into *segments*, one per run of that clock:
the ``time_base`` segments of meta.json when it has them, else one per session, split
where the stamp steps back by more than ``REBOOT_BACK_US``.  Within a segment the stamps are
unwrapped from its first row (a step back of under half the wrap is a frame out of order).

**Host time**, the first of these that the recording has:

1. the host-time columns of frames.csv (empty cells: NaN);
2. meta.json's mapping, ``host = host_ref_s + (board_us - board_ref_us) * 1e-6 * (1 +
   drift_ppm * 1e-6)`` per segment (NaN in a segment whose mapping is not usable);
3. none: ``host_utc_s`` and ``host_monotonic_s`` are None.

``host_time_source`` says which (``"frames.csv"``, ``"meta.json"`` or None) and
``host_time_why`` why some or all rows have no host time (None when every row has one).
"""

import pathlib
import shlex
from dataclasses import dataclass, field

import numpy as np

from tactile import units
from tactile.ep2.contacts_csv import REQUIRED
from tactile.errors import InputError
from tactile.files.tabular import read_csv
from tactile.logs.read import log_columns
from tactile.recording.layout import META, sessions_of
from tactile.recording.recover import frames_of, meta_of
from tactile_protocol import constants as C

__all__ = ["Contacts", "RecordingData", "load_recording"]

WRAP = C.TIMESTAMP_MODULO  # 2^32 us
HALF = WRAP // 2
REBOOT_BACK_US = 1_000_000  # a step back this large is a new boot, not a frame out of order
CONTACTS = "contacts.csv"


@dataclass
class Contacts:
    """contacts.csv: ``points_m`` (k, 3) in metres, ``normals`` (k, 3) of unit length, per
    row the ``finger`` and ``patch`` labels (lists, or None without the column), the unit the
    file was written in and the file's ``lines``."""

    points_m: np.ndarray
    normals: np.ndarray
    finger: list | None
    patch: list | None
    file_unit: str
    lines: np.ndarray


@dataclass
class RecordingData:
    """One recording, a row per SAMPLE/CONTACT frame in file order (``n`` rows).

    Per row: ``seq`` (the frame's 16-bit sequence number), ``board_us`` (its raw 32-bit
    stamp), ``segment`` and ``board_time_s`` (the board's clock unwrapped within that
    segment, s), ``sensor``, ``is_contact`` (CONTACT, else SAMPLE), ``phase`` and
    ``contact_id`` (-1 on a SAMPLE), ``flags``, ``force_N`` and ``torque_Nm`` (n, 3),
    ``host_utc_s`` and ``host_monotonic_s`` (or None; see the module docstring) and
    ``lines`` (its line in frames.csv; -1: rebuilt from capture.bin).  ``contacts`` is
    contacts.csv (or None, and ``contacts_why`` says why); ``meta`` is meta.json as a dict
    (a stand-in with ``rebuilt`` when it is missing); ``notes`` what was rebuilt, and why.
    """

    path: pathlib.Path
    seq: np.ndarray
    board_us: np.ndarray
    segment: np.ndarray
    board_time_s: np.ndarray
    sensor: np.ndarray
    is_contact: np.ndarray
    phase: np.ndarray
    contact_id: np.ndarray
    flags: np.ndarray
    force_N: np.ndarray
    torque_Nm: np.ndarray
    host_utc_s: np.ndarray | None
    host_monotonic_s: np.ndarray | None
    host_time_source: str | None
    host_time_why: str | None
    contacts: Contacts | None
    contacts_why: str | None
    meta: dict
    lines: np.ndarray
    notes: list = field(default_factory=list)
    raw_force_N: np.ndarray | None = None
    raw_torque_Nm: np.ndarray | None = None
    host_phase: np.ndarray | None = None
    host_contact_id: np.ndarray | None = None
    payload: dict | None = None

    def times_in(self, clock):
        """Each row's time (int64 us) in a robot log's ``clock`` ("board": the raw stamps,
        "utc", "monotonic": the host times), and a mask of the rows that have one."""
        if clock == "board":
            return self.board_us.astype(np.int64), np.ones(len(self), dtype=bool)
        host = self.host_utc_s if clock == "utc" else self.host_monotonic_s
        if host is None:
            raise InputError(
                f"{self.path}: the robot log is in the {clock} clock, but the recording has no"
                f" host time ({self.host_time_why})"
            )
        known = np.isfinite(host)
        return np.where(known, np.round(np.nan_to_num(host) * 1e6), -1).astype(np.int64), known

    def __len__(self):
        return len(self.seq)

    @property
    def sensors(self):
        """The sensor indices that have rows, ascending."""
        return [int(s) for s in np.unique(self.sensor)]

    @property
    def wrench(self):
        """(n, 6): fx, fy, fz in N, then tx, ty, tz in N*m."""
        return np.hstack([self.force_N, self.torque_Nm])


def load_recording(path):
    """Read the ``tactile record`` directory ``path`` into a ``RecordingData``
    (``tactile.load_recording`` adds ``payload=``: ``tactile.payload.apply``).

    Raises ``tactile.errors.InputError`` (a ``ValueError``) naming the file, line and column
    of anything malformed."""
    return _load(pathlib.Path(path))


def robot_log_of(rec):
    """The robot log the recording's command names, if it still exists, else None."""
    return _pose_log(rec.path, rec.meta)


def _load(path):
    if not path.is_dir():
        raise InputError(f"{path}: not a directory (expected 'tactile record -o {path}')")
    meta, notes = meta_of(path)
    _check_segments(path / META, meta)
    table, more = frames_of(path, meta)
    col = table.columns
    n = len(table)
    raw = table.whole("timestamp_us", 0, WRAP - 1)
    segment, board_us = _board_time(raw, meta)
    phase = _blank_int(col.get("phase"), n)
    mono, utc, source, why = _host_time(col, segment, board_us, meta)
    contacts, contacts_why = _contacts(path, meta)
    return RecordingData(
        path=path,
        seq=table.whole("seq"),
        board_us=raw,
        segment=segment,
        board_time_s=board_us * 1e-6,
        sensor=table.whole("sensor", 0, C.MAX_SENSORS - 1),
        is_contact=phase >= 0,
        phase=phase,
        contact_id=_blank_int(col.get("contact_id"), n),
        flags=table.whole("flags"),
        force_N=table.array("fx_N", "fy_N", "fz_N"),
        torque_Nm=table.array("tx_Nm", "ty_Nm", "tz_Nm"),
        host_utc_s=utc,
        host_monotonic_s=mono,
        host_time_source=source,
        host_time_why=why,
        contacts=contacts,
        contacts_why=contacts_why,
        meta=meta,
        lines=np.frombuffer(table.lines, dtype=np.int64).copy(),
        notes=notes + more,
    )


def _blank_int(values, n):
    """A column that is empty on some rows as int64, -1 where empty."""
    if values is None:
        return np.full(n, -1, dtype=np.int64)
    v = np.asarray(values, dtype=float)
    return np.where(np.isnan(v), -1, v).astype(np.int64)


# --- time ------------------------------------------------------------------------------------


def _time_segments(meta):
    """meta.json's ``time_base`` segments over all sessions, in row order (may be empty)."""
    out = []
    for ses in sessions_of(meta):
        base = ses.get("time_base") if isinstance(ses, dict) else None
        segs = base.get("segments") if isinstance(base, dict) else None
        out += [s for s in segs or () if isinstance(s, dict) and s.get("first_row") is not None]
    return out


SEGMENT_WHOLE = ("first_row", "board_ref_us")  # whole numbers >= 0
SEGMENT_REAL = ("drift_ppm", "host_monotonic_ref_s", "host_utc_ref_s")  # finite numbers


def _check_segments(path, meta):
    """``InputError`` naming the first ``time_base`` segment field that is not the number it
    must be (meta.json is a file like any other: it may have been edited or damaged)."""
    for k, e in enumerate(_time_segments(meta)):
        names = SEGMENT_WHOLE + (SEGMENT_REAL if e.get("usable") and "board_ref_us" in e else ())
        for name in names:
            v = e.get(name, 0)
            real = isinstance(v, int | float) and not isinstance(v, bool) and np.isfinite(v)
            whole = real and v == int(v) and 0 <= v < 2**63
            if not (whole if name in SEGMENT_WHOLE else real and abs(v) < 1e300):
                raise InputError(
                    f"{path}: time_base segment {k} field {name!r}: not a"
                    f" {'whole number >= 0' if name in SEGMENT_WHOLE else 'finite number'}:"
                    f" {str(v)[:40]!r}"
                )


def _unwrap(raw):
    """Stamps of one segment unwrapped from its first (int64 us): each step is taken modulo
    the wrap, and one of half the wrap or more is a step back."""
    if len(raw) == 0:
        return raw.astype(np.int64)
    step = np.diff(raw) % WRAP
    step = np.where(step >= HALF, step - WRAP, step)
    return raw[0] + np.concatenate([[0], np.cumsum(step)])


def _starts(raw, meta):
    """Row indices where a segment begins (0 first)."""
    entries = _time_segments(meta)
    if entries:
        starts = {0} | {int(e["first_row"]) for e in entries}
        return sorted(s for s in starts if s < len(raw))
    starts = {0}
    for ses in sessions_of(meta):
        off = ses.get("rows_offset")
        if isinstance(off, int) and 0 < off < len(raw):
            starts.add(off)
    step = np.diff(raw) % WRAP
    back = np.flatnonzero((step >= HALF) & (WRAP - step > REBOOT_BACK_US)) + 1
    return sorted(starts | set(back.tolist()))


def _board_time(raw, meta):
    """(segment index per row, board time unwrapped within its segment in us)."""
    starts = _starts(raw, meta)
    segment = np.zeros(len(raw), dtype=np.int64)
    us = np.empty(len(raw), dtype=np.int64)
    for k, (a, b) in enumerate(zip(starts, [*starts[1:], len(raw)])):
        segment[a:b] = k
        us[a:b] = _unwrap(raw[a:b])
    return segment, us


def _host_time(col, segment, board_us, meta):
    """(monotonic s, UTC s, source, why) per the module docstring."""
    if "host_utc_s" in col and "host_monotonic_s" in col:
        mono = np.asarray(col["host_monotonic_s"], dtype=float)
        utc = np.asarray(col["host_utc_s"], dtype=float)
        known = np.isfinite(mono) & np.isfinite(utc)
        if known.any():
            return mono, utc, "frames.csv", _missing(known, "frames.csv has no host time", meta)
    entries = _time_segments(meta)
    if not entries:
        why = "the recording has no host time (frames.csv has no host-time columns and meta.json"
        return None, None, None, why + " no time_base: its recorder did not map the board's clock)"
    mono = np.full(len(board_us), np.nan)
    utc = np.full(len(board_us), np.nan)
    for e in entries:
        if not e.get("usable") or "board_ref_us" not in e or int(e["first_row"]) >= len(segment):
            continue
        rows = segment == segment[int(e["first_row"])]
        d = (board_us[rows] - int(e["board_ref_us"])) * 1e-6 * (1 + float(e["drift_ppm"]) * 1e-6)
        mono[rows] = float(e["host_monotonic_ref_s"]) + d
        utc[rows] = float(e["host_utc_ref_s"]) + d
    known = np.isfinite(utc)
    if not known.any():
        return None, None, None, _reasons(meta)
    return mono, utc, "meta.json", _missing(known, "its segment has no usable mapping", meta)


def _reasons(meta):
    """The time_base's own words for segments without a usable mapping."""
    entries = _time_segments(meta)
    if not entries:
        return "meta.json has no time_base"
    why = [e.get("why") for e in entries if not e.get("usable") and e.get("why")]
    return "; ".join(dict.fromkeys(why)) or "meta.json's time_base has no usable mapping"


def _missing(known, what, meta):
    """None when every row has a host time, else a sentence on the rows that do not."""
    if known.all():
        return None
    first = int(np.flatnonzero(~known)[0])
    return (
        f"{int((~known).sum())} of {len(known)} rows have no host time (NaN), the first at"
        f" row {first}: {what} ({_reasons(meta)})"
    )


# --- contacts.csv ----------------------------------------------------------------------------


def _contacts(path, meta):
    """(``Contacts`` or None, why None)."""
    csv_path = path / CONTACTS
    if not csv_path.exists():
        return None, f"{csv_path.name}: none (recorded without a pose log)"
    scale, unit, why = _contacts_unit(csv_path, meta)
    if scale is None:
        return None, why
    table = read_csv(csv_path, REQUIRED, optional_text=("finger", "patch"))
    normals = table.array("nx", "ny", "nz")
    length = np.linalg.norm(normals, axis=1)
    if not np.all(length > 0):
        i = int(np.flatnonzero(~(length > 0))[0])
        raise InputError(f"{csv_path}:{table.lines[i]}: column 'nx': zero-length normal")
    contacts = Contacts(
        points_m=table.array("x", "y", "z") * scale,
        normals=normals / length[:, None],
        finger=table.columns.get("finger"),
        patch=table.columns.get("patch"),
        file_unit=unit,
        lines=np.frombuffer(table.lines, dtype=np.int64).copy(),
    )
    return contacts, None


def _contacts_unit(csv_path, meta):
    """(metres per file unit, the unit, None) or (None, None, why it cannot be told).

    The ``# units:`` line says it.  A file without one (written before that line existed)
    is in cm when it came from a SCARA joint log (ch. 5, as tables 5-7), else in m: the
    recording's command names the log, whose header says which, if it is still readable."""
    unit = units.stated_length(csv_path)
    if unit is not None:
        return units.LENGTH_M[unit], unit, None
    log = _pose_log(csv_path.parent, meta)
    if log is None:
        why = (
            f"{csv_path.name} states no unit (no '# units:' line) and its pose log is not"
            " readable, so cm (SCARA) and m cannot be told apart; add '# units: cm' or"
            " '# units: m' before its header"
        )
        return None, None, why
    unit = "cm" if "q1" in log_columns(log) else "m"
    return units.LENGTH_M[unit], unit, None


def _pose_log(rec_dir, meta):
    """The pose log the recording's command names, if it still exists (as given, or beside
    the recording)."""
    argv = meta.get("command")
    if isinstance(argv, str):
        argv = shlex.split(argv)
    if not isinstance(argv, list):
        return None
    argv = [str(a) for a in argv]
    name = None
    for i, arg in enumerate(argv):
        if arg == "--pose-log" and i + 1 < len(argv):
            name = argv[i + 1]
        elif arg.startswith("--pose-log="):
            name = arg.split("=", 1)[1]
    if name is None:
        return None
    for candidate in (pathlib.Path(name), rec_dir.parent / name, rec_dir / name):
        if candidate.is_file():
            return candidate
    return None
