"""``tactile export RUN --format mcap|parquet [-o FILE]``: a recording other tools open.

``mcap``: ROS 2 messages (``tactile.foxglove.export_mcap``) for Foxglove and ROS 2 tools; it needs
the ``export`` extra.  ``parquet``: the frames (and contacts) as tables with units
(``tactile.recording.export``) for pandas and Arrow; it needs the ``parquet`` extra.
Without
its extra the command prints the install line and exits 2.  The one-line summary names the
file(s), what they hold and the clock of the stamps.  A run cut short (killed, a full disk)
is read with what capture.bin holds (``tactile.recording.recover``); one ``note:`` line on
stderr says what was rebuilt.

``-o`` is checked before any work (``tactile.recording.export``): a new file or a
regular file, never a directory, a device or a FIFO, never a file of the run; the file is
replaced whole (``tactile.files.writing``), a full disk is exit 5, and an export into the
run folder holds the run's lock while it works.
"""

import contextlib
import pathlib
import sys

from tactile.errors import InputError
from tactile.files.writing import hold
from tactile.foxglove import export_mcap
from tactile.logs.read import read_pose_log
from tactile.output.text import printable
from tactile.recording import export
from tactile.recording.load import load_recording

FORMATS = ("mcap", "parquet")


def add_arguments(parser):
    parser.add_argument("run", help="a 'tactile record -o DIR' directory")
    parser.add_argument(
        "--format",
        choices=FORMATS,
        default="mcap",
        help="mcap: ROS 2 WrenchStamped and contact state per sensor, the contacts and EP2"
        " patch as a Foxglove scene; parquet: the frames and contacts as tables with units"
        " (default mcap)",
    )
    parser.add_argument(
        "--pose-log",
        metavar="LOG",
        help="mcap: the robot's pose log of the run, for each sensor's pose (/tactile/tf)",
    )
    parser.add_argument(
        "-o",
        "--out",
        help="output file (default: RUN/NAME.mcap or RUN/NAME.parquet, NAME the directory's"
        " name; parquet puts the contacts beside it, in NAME.contacts.parquet)",
    )


def run(args):
    if args.format == "parquet":
        require, write = export.require_pyarrow, export.write_parquet
    else:
        require, write = export_mcap.require_mcap, export_mcap.write_mcap
    require()  # the install hint before any work
    run_dir = pathlib.Path(args.run)
    if not run_dir.is_dir():
        raise InputError(f"{run_dir}: not a directory (expected 'tactile record -o {run_dir}')")
    name = f"{run_dir.resolve().name}.{args.format}"
    out = pathlib.Path(args.out) if args.out else run_dir / name
    pose_log = None
    if args.pose_log:
        if args.format != "mcap":
            raise InputError("--pose-log is for --format mcap (the sensors' transforms)")
        pose_log = read_pose_log(args.pose_log)
    outs = [out] if args.format == "mcap" else [out, export.contacts_path(out)]
    inside = export.check_outputs(run_dir, outs, f".{args.format}")
    with hold(run_dir) if inside else contextlib.nullcontext():  # one writer in a run
        summary = _export(run_dir, out, pose_log, write)
    said = line(summary) if args.format == "mcap" else parquet_line(summary)
    print(printable(said), flush=True)  # the file is the user's
    return 0


def _export(run_dir, out, pose_log, write):
    """Read the run, write ``out``: the summary."""
    rec = load_recording(run_dir)
    if rec.notes:
        note = f"tactile export: note: {'; '.join(rec.notes)}"
        print(printable(note), file=sys.stderr, flush=True)
    return write(rec, out, pose_log) if pose_log is not None else write(rec, out)


def parquet_line(summary):
    """``wrote FILE: N frames (N, N*m, s)[; FILE2: M contacts (m)]``."""
    out = f"wrote {summary['path']}: {summary['frames']:,} frames (N, N*m, s; units in the schema)"
    if summary["contacts_path"]:
        out += f"; {summary['contacts_path']}: {summary['contacts']:,} contacts (m)"
    return out


def line(summary):
    """``wrote FILE: N WrenchStamped on K topics (+ contact state), M contacts and the EP2
    patch (its label), T transforms; stamps: ...``."""
    topics = dict(summary["topics"])
    contacts = topics.pop("/tactile/contacts", None)
    topics.pop("/tactile/patch", None)
    transforms = topics.pop("/tactile/tf", None)
    wrench = {t: n for t, n in topics.items() if t.endswith("/wrench")}
    out = f"wrote {summary['path']}: {sum(wrench.values())} WrenchStamped (N, N*m) on"
    out += f" {len(wrench)} topic" + "s" * (len(wrench) != 1)
    if len(topics) > len(wrench):
        out += " with their contact state (N)"
    if contacts is not None:
        shape = (summary.get("patch") or {}).get("shape") or "refused"
        out += f", {contacts} contacts (m) on /tactile/contacts, their EP2 patch ({shape})"
        out += " on /tactile/patch"
    if transforms is not None:
        out += f", {transforms} sensor poses (m) on /tactile/tf"
    return out + f"; stamps: {summary['why']}"
