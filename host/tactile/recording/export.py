"""A recording exported: as Parquet tables, and where an export may write.

**Parquet**: a recording as tables, for pandas, polars, DuckDB and Arrow users.

``RUN.parquet`` holds the frames, one row per SAMPLE or CONTACT frame in file order, with
the columns of ``tactile.load_recording`` (``COLUMNS``): board time, host time, sensor,
contact fields, and the wrench in N and N*m.  ``RUN.contacts.parquet`` beside it holds
contacts.csv in m, when the run has one.  Every column's unit is in its Arrow field
metadata (``unit``), and the file's metadata holds ``tactile`` (version, source, units)
and the recording's ``meta.json``.  A host time the recording does not determine is a null,
never a NaN.

``pyarrow`` is the ``parquet`` extra, imported only here.

**Where ``tactile export`` may write**, checked before any work is done.

- Each output is a new file in an existing folder or a regular file
  (``tactile.files.writing.check_target``): never a directory, a device (``/dev/null``
  included), a FIFO or a socket (exit 2).
- Never a file of the run being exported.  Paths are compared once symlinks are resolved,
  so a link to capture.bin is capture.bin.  Inside the run folder an export may name a new
  file, or an earlier export of its own format (a name ending ``.mcap`` or ``.parquet``),
  but never the recording's own files (``RUN_FILES``, even before they exist) nor any other
  file already there (exit 2).
- An export into the run folder holds the run's lock (``tactile.files.writing``) while
  it reads and writes, so it is refused (exit 5) while a ``record`` writes there, and a
  ``record`` is refused while it writes.
"""

import json
import os
import pathlib

import numpy as np

from tactile import __version__
from tactile.errors import InputError, need
from tactile.files.writing import atomic_write, check_target
from tactile.recording.layout import CAPTURE, DEVICE, FRAMES, META

__all__ = ["RUN_FILES", "check_outputs"]

# column, RecordingData attribute (index into a 2-D one), unit
COLUMNS = (
    ("seq", "seq", None, "1"),
    ("board_us", "board_us", None, "us"),
    ("segment", "segment", None, "1"),
    ("board_time_s", "board_time_s", None, "s"),
    ("host_utc_s", "host_utc_s", None, "s"),
    ("host_monotonic_s", "host_monotonic_s", None, "s"),
    ("sensor", "sensor", None, "1"),
    ("is_contact", "is_contact", None, "1"),
    ("phase", "phase", None, "1"),
    ("contact_id", "contact_id", None, "1"),
    ("flags", "flags", None, "1"),
    ("fx_N", "force_N", 0, "N"),
    ("fy_N", "force_N", 1, "N"),
    ("fz_N", "force_N", 2, "N"),
    ("tx_Nm", "torque_Nm", 0, "N*m"),
    ("ty_Nm", "torque_Nm", 1, "N*m"),
    ("tz_Nm", "torque_Nm", 2, "N*m"),
)
CONTACT_COLUMNS = (("x_m", "m"), ("y_m", "m"), ("z_m", "m"), ("nx", "1"), ("ny", "1"), ("nz", "1"))


def require_pyarrow():
    """``(pyarrow, pyarrow.parquet)``, or ``MissingExtra`` (the ``parquet`` extra)."""
    return need("parquet", "Parquet export", "pyarrow", "pyarrow.parquet")


def _array(pa, values):
    """An Arrow array; NaN (a host time not determined) becomes null."""
    values = np.asarray(values)
    if values.dtype.kind == "f":
        return pa.array(values, mask=~np.isfinite(values))
    return pa.array(values)


def frames_table(rec):
    """The frames of ``rec`` (a ``RecordingData``) as an Arrow table with units."""
    pa, _ = require_pyarrow()
    fields, arrays = [], []
    for name, attr, col, unit in COLUMNS:
        values = getattr(rec, attr)
        if values is None:  # no host time at all: a column of nulls, still typed
            values = np.full(len(rec), np.nan)
        arr = _array(pa, values if col is None else values[:, col])
        fields.append(pa.field(name, arr.type, metadata={"unit": unit}))
        arrays.append(arr)
    why = rec.host_time_why or ""
    meta = {"tactile": _describe("frames", rec, why), "meta.json": json.dumps(rec.meta)}
    return pa.Table.from_arrays(arrays, schema=pa.schema(fields, metadata=meta))


def contacts_table(contacts):
    """contacts.csv (``rec.contacts``) in m as an Arrow table: points, normals, labels."""
    pa, _ = require_pyarrow()
    values = np.hstack([contacts.points_m, contacts.normals])
    fields = [pa.field(n, pa.float64(), metadata={"unit": u}) for n, u in CONTACT_COLUMNS]
    arrays = [pa.array(values[:, i]) for i in range(6)]
    for label in ("finger", "patch"):
        if getattr(contacts, label) is not None:
            fields.append(pa.field(label, pa.string(), metadata={"unit": "label"}))
            arrays.append(pa.array([str(v) for v in getattr(contacts, label)]))
    return pa.Table.from_arrays(arrays, schema=pa.schema(fields))


def _describe(what, rec, why):
    return json.dumps(
        {
            "version": __version__,
            "table": what,
            "source": str(rec.path),
            "host_time": rec.host_time_source,
            "host_time_why": why,
        }
    )


def write_parquet(rec, path):
    """Write ``rec`` to ``path`` (frames) and, with contacts, ``NAME.contacts.parquet``
    beside it, each replaced whole (``tactile.files.writing``).  Returns a summary."""
    _, pq = require_pyarrow()
    path = pathlib.Path(path)
    out = {"path": str(path), "frames": len(rec), "contacts": None, "contacts_path": None}
    tables = [(path, frames_table(rec))]
    if rec.contacts is not None:
        cpath = contacts_path(path)
        tables.append((cpath, contacts_table(rec.contacts)))
        out.update(contacts=len(rec.contacts.points_m), contacts_path=str(cpath))
    for target, table in tables:
        with atomic_write(target) as fh:  # a disk error: exit 5; not a file there: exit 2
            pq.write_table(table, fh)
    return out


def contacts_path(path):
    """Where ``write_parquet`` puts the contacts of a run written to ``path``."""
    path = pathlib.Path(path)
    return path.with_name(path.name.removesuffix(".parquet") + ".contacts.parquet")


RUN_FILES = (CAPTURE, FRAMES, DEVICE, META, "contacts.csv", "probes.csv")


def _inside(folder, real):
    return os.path.commonpath([folder, real]) == folder


def check_outputs(run_dir, outs, suffix):
    """Check the outputs ``outs`` of an export of ``run_dir`` whose files end in
    ``suffix`` (``.mcap``); True when one lies inside the run (the export then locks it);
    ``InputError`` (exit 2) naming the first output refused."""
    run = os.path.realpath(run_dir)
    own = {os.path.join(run, n) for n in RUN_FILES}
    own |= {os.path.realpath(p) for p in own}
    inside = False
    for out in outs:
        real = check_target(out)
        if not _inside(run, real):
            continue
        inside = True
        if real in own or (os.path.lexists(real) and not real.endswith(suffix)):
            raise InputError(
                f"{out}: a file of the run being exported ({run_dir}); export never writes"
                " over a recording's files (choose another -o)"
            )
    return inside
