"""``tactile export RUN --format mcap [-o FILE]``: a recording as a file other tools open.

``mcap``: ROS 2 messages (``tactile.export_mcap``) for Foxglove and ROS 2 tools; it needs
the ``export`` extra, and without it the command prints the install line and exits 2.
The one-line summary names the file, the messages per topic and the clock of the stamps.
"""

FORMATS = ("mcap",)


def add_arguments(parser):
    parser.add_argument("run", help="a 'tactile record -o DIR' directory")
    parser.add_argument(
        "--format",
        choices=FORMATS,
        default="mcap",
        help="mcap: ROS 2 WrenchStamped per sensor and a PoseArray of contacts (default mcap)",
    )
    parser.add_argument(
        "-o", "--out", help="output file (default: RUN/NAME.mcap, NAME the directory's name)"
    )


def run(args):
    import pathlib

    from tactile.errors import InputError
    from tactile.export_mcap import require_mcap, write_mcap
    from tactile.recording_load import load_recording

    require_mcap()  # the install hint before any work
    run_dir = pathlib.Path(args.run)
    if not run_dir.is_dir():
        raise InputError(f"{run_dir}: not a directory (expected 'tactile record -o {run_dir}')")
    name = f"{run_dir.resolve().name}.{args.format}"
    out = pathlib.Path(args.out) if args.out else run_dir / name
    summary = write_mcap(load_recording(run_dir), out)
    print(line(summary), flush=True)
    return 0


def line(summary):
    """``wrote FILE: N WrenchStamped on K topics, M contacts (PoseArray); stamps: ...``."""
    topics = dict(summary["topics"])
    contacts = topics.pop("/tactile/contacts", None)
    wrenches = sum(topics.values())
    out = f"wrote {summary['path']}: {wrenches} WrenchStamped (N, N*m) on {len(topics)} topic"
    out += "s" * (len(topics) != 1)
    if contacts is not None:
        out += f", {contacts} contacts (m) as one PoseArray on /tactile/contacts"
    return out + f"; stamps: {summary['why']}"
