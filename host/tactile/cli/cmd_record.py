"""``tactile record --port P [--duration S | --contacts N] -o DIR``: record a board's stream.

Writes DIR/capture.bin, frames.csv, device.jsonl and meta.json as data arrive
(see ``tactile.recording.files``); with ``--pose-log`` it then derives the contact
points for EP2 (DIR/contacts.csv) or the rolling probes for EP1
(DIR/probes.csv), ready for ``tactile ep2 analyze`` / ``tactile ep1 estimate``.
With a pose log it stops on its own once the log's end has passed (its ``# end:`` line,
or half a second after its last entry), and says so while it waits.  The summary names the
board -> host time base (``tactile.recording.timebase``); ``warning:`` lines go to stderr.
``--foxglove`` serves the frames to Foxglove while recording (``tactile.cli.options``).
The run folder's lock (``tactile.files.writing``) is held from before anything is
written until the command ends: a second ``record`` or an ``export`` into it is refused
(exit 5).  A run that fails before the board sent a byte leaves nothing behind: a folder it
made is removed, one that was there is left as it was.
"""

import functools
import sys
import time

from tactile.board.client import info_dict
from tactile.cli.options import (
    add_foxglove_arguments,
    add_port_argument,
    check_foxglove,
    connect,
    new_pose_log,
    start_foxglove,
    stop_foxglove,
)
from tactile.commands import add_quiet
from tactile.commands.derive import check_log, derive
from tactile.errors import BoardError, DataError, InputError
from tactile.files.writing import hold
from tactile.logs.tags import log_end, show_time
from tactile.output.text import count, fields, printable
from tactile.payload.apply import Following, OnBoard, Orientations
from tactile.payload.tool import read_tool
from tactile.recording.session import Session


def add_arguments(parser):
    add_port_argument(parser)
    stop = parser.add_mutually_exclusive_group()
    stop.add_argument("--duration", type=float, help="stop after S seconds")
    stop.add_argument("--contacts", type=int, help="stop after N completed contacts")
    parser.add_argument("-o", "--out", required=True, help="output directory")
    parser.add_argument("--append", action="store_true", help="add to a recording in --out")
    parser.add_argument("--no-tare", action="store_true", help="do not bias the sensor first")
    parser.add_argument(
        "--pose-log",
        help="robot pose log (CSV) to derive contacts.csv or probes.csv; the run stops once"
        " the log's end has passed",
    )
    parser.add_argument(
        "--per-contact",
        type=int,
        help="readings kept per contact (default: 2 for a SCARA log as §5.1, else all)",
    )
    parser.add_argument(
        "--reconnect", type=float, default=30.0, help="seconds to wait for a lost port (30)"
    )
    parser.add_argument(
        "--payload",
        action="append",
        metavar="TOOL",
        help="a sensor's tool file (tactile payload identify): its weight and the drifting bias"
        " are removed and contacts gated on the host; needs --pose-log; once per sensor",
    )
    add_quiet(parser)
    add_foxglove_arguments(parser)


def payload_of(args, log):
    """[(path, Tool)] of ``--payload``, checked before anything is recorded: each file, and
    a pose log with the sensor's orientation for every reading; and the ``Orientations``."""
    if not args.payload:
        return [], None
    if log is None:
        raise InputError("--payload: needs --pose-log (the sensor's orientation at each reading)")
    tools = [(path, read_tool(path)) for path in args.payload]
    orient = Orientations.of_log(log)
    for path, tool in tools:
        if not orient.covers(tool.sensor):
            raise InputError(f"{path}: the tool is for sensor {tool.sensor}: {log.path} has none")
    return tools, orient


def run(args):
    with hold(args.out, create=True):  # one writer in the run, derive included
        return _run(args)


def _run(args):
    if args.duration is not None and not args.duration > 0:
        raise InputError(f"--duration: {args.duration} is not a positive number of seconds")
    if args.contacts is not None and args.contacts <= 0:
        raise InputError(f"--contacts: {args.contacts} is not a positive count")
    check_foxglove(args)
    if not args.port:
        connect(args)  # raises the 'no port given' message
    until = posed = log = following = None
    if args.pose_log:  # a bad log is refused before recording, not after
        log, posed, _ = _read_log(args.pose_log)
    tools, orient = payload_of(args, log)
    # a port in use is refused before anything is written
    live = start_foxglove(args, pose_log=posed)
    follow = None if live is None else live.follow
    if live is not None and tools:
        following = Following(tools, orient, log.clock)
        follow = _compensating(live, following)
    if args.pose_log:  # read again once the board answers: a robot (an emulator) that
        until = functools.partial(_log_again, args, live, following)  # starts anew writes it anew
    try:
        session = Session(
            args.port,
            args.out,
            duration_s=args.duration,
            contacts=args.contacts,
            tare=not args.no_tare,
            reconnect_s=args.reconnect,
            handshake_s=args.wait,
            append=args.append,
            argv=sys.argv,
            until=until,
            on_frames=follow,
            payload=OnBoard(tools) if tools else None,
        )
    except BaseException:
        stop_foxglove(live, quiet=True)
        raise
    progress = None if args.quiet else Progress(args.duration, args.contacts)
    if progress:
        session.on_progress = progress.update
        session.on_notice = progress.say  # a port lost and waited for, a stall of the host
    try:
        meta = session.run()
    except BoardError as exc:
        raise _says_kept(exc, session.rec) from None
    finally:
        if progress:
            progress.close(session)
        stop_foxglove(live)
    print(printable(summary(meta, args.out)))  # the folder is the user's
    print(printable(time_summary(meta.get("time_base"))))
    _log_not_over(meta, args.pose_log, args.out)
    if args.pose_log:
        for line in derive(args.out, args.pose_log, per_contact=args.per_contact, payload=tools):
            out = sys.stderr if line.startswith("warning:") else sys.stdout
            print(printable(line), file=out)  # a line may quote the pose log
    return 0


def _read_log(path):
    """(the log, its ``PoseLog`` if an EP2 log or None, until = (clock, end us, how))."""
    log = check_log(path)
    end, how = log_end(log.t_end if hasattr(log, "t_end") else log.t_end_us, log.end_us)
    posed = log if getattr(log, "kind", None) in ("pose", "scara") else None  # not EP1's
    return log, posed, (log.clock, end, how)


def _log_again(args, live, following=None):
    """The pose log as it is now the board has answered (and the Foxglove scene and the
    payload's orientations with it); says where the run stops."""
    log, posed, until = _read_log(args.pose_log)
    new_pose_log(live, posed)
    if following is not None:
        following.orient = Orientations.of_log(log)
    if not args.quiet:
        clock, end, how = until
        print(printable(f"record: stops when the pose log is done ({show_time(clock, end)}:"
                        f" {how}), or on Ctrl-C"), file=sys.stderr)  # fmt: skip
    return until


def _log_not_over(meta, pose_log, out):
    """A robot log in the board's clock that had ended before the recording began: one line
    saying so (exit 3), the recording kept."""
    stop, segments = meta.get("stops_at"), (meta.get("time_base") or {}).get("segments")
    if not stop or stop["clock"] != "board" or not segments:
        return
    first_us, end_us = segments[0]["board_first_us"], stop["time_us"]
    if first_us < end_us:
        return
    raise DataError(
        f"{pose_log}: the robot's log ended at board {end_us / 1e6:.3f} s, before this"
        f" recording began (the board's clock read {first_us / 1e6:.3f} s): its run is over"
        " and none of it was recorded; start the robot again (an emulator: 'tactile emulate'"
        f" again, or without --once) and record again (what the board sent is kept in {out})"
    )


def _compensating(live, following):
    """The session's ``on_frames``: the Foxglove server fed the compensated frames."""

    def follow(session, msgs, host_times):
        info = session.client.info if session.client is not None else None
        device = info_dict(info) if info is not None else None
        out, host, _ = following.feed(msgs, device, host_times)
        live.follow(session, out, host)

    return follow


def _says_kept(exc, rec):
    """A failed run's line says what it left: what the port sent is kept (a run that
    received nothing left nothing: ``Session``)."""
    if not rec.bytes or str(rec.dir) in str(exc):
        return exc
    return BoardError(f"{exc}; the {count(rec.bytes, 'byte')} received are kept in {rec.dir}")


def time_summary(time_base):
    """One line: the board -> host mapping of the latest segment and its quality."""
    segs = (time_base or {}).get("segments") or []
    if not segs:
        return "time base: none (no frame arrived)"
    s = segs[-1]
    more = f" (segment {len(segs)} of {len(segs)}, one per boot)" if len(segs) > 1 else ""
    why = s.get("why", "no fit")
    if not s.get("usable"):
        return f"time base{more}: {why}" if why.startswith(("fast mode", "simulated")) else (
            f"time base: not usable{more}: {why}")  # fmt: skip
    if s["bins"] < 2:  # (one bin: an offset, no drift to speak of)
        return (
            f"time base{more}: an offset only ({count(s['frames'], 'frame')}, too few to"
            " measure the board clock's drift)"
        )
    return (
        f"time base{more}: board clock drift {s['drift_ppm']:+.1f} ppm, {s['bins']} bins;"
        f" arrival delay mean {s['arrival_delay_mean_ms']:.2f} ms, max"
        f" {s['arrival_delay_max_ms']:.2f} ms; fit floor {s['fit_floor_ms']:.3f} ms"
    )


# Why a run ended (meta.json's "ended") in the summary's words; the first three are a
# run that finished as asked, and its bar shows 100 %.
ENDED = {
    "duration": "its --duration",
    "contacts": "its --contacts",
    "pose log end": "the pose log's end",
    "scene end": "the scene's end",
    "interrupted": "Ctrl-C",
    "port lost": "the port lost",
    "error": "an error",
}
FINISHED = ("duration", "contacts", "pose log end", "scene end")


def summary(meta, out):
    """One line in words: what was recorded, why it stopped, what was lost, where it is."""
    d = meta["decoder"] or {}
    invalid = d.get("invalid", 0)  # frames outside the protocol's limits (device.jsonl names them)
    ended = ENDED.get(meta["ended"], str(meta["ended"]))
    lost = [
        count(d.get("lost_frames", 0), "frame"),
        count(d.get("crc_errors", 0), "CRC error"),
        count(len(meta["gaps"]), "gap"),
    ]
    refused = f", {count(invalid, 'invalid frame')} refused" if invalid else ""
    dropped = meta.get("tx_dropped", 0)  # the board's own count, from its STATUS
    if dropped:
        lost[0] += f" ({count(dropped, 'frame')} dropped by the board: the host did not read)"
    late = meta.get("late_samples", 0)
    late = f"; {count(late, 'reading')} late (the board missed its rate)" if late else ""
    got = f"{count(meta['samples'], 'reading')}, {count(meta['contacts_ended'], 'contact')}"
    return (
        f"recorded {got} in {meta['elapsed_s']:.1f} s (stopped by {ended});"
        f" lost {', '.join(lost)}{refused}{late} -> {out}"
    )


class Progress:
    """A tqdm bar (time, contacts, or time to the pose log's end) with rate, contacts and
    loss; plain lines without tqdm.  A run that finishes as asked ends its bar at 100 %."""

    def __init__(self, duration, contacts):
        self.by_contacts = contacts is not None
        self.total = contacts if self.by_contacts else duration
        self.last = 0.0
        self.bar = None
        self.plain = False

    def _open(self):
        """The bar appears once the board answered (an error before it prints alone)."""
        try:
            from tqdm import tqdm
        except ImportError:
            self.plain = True
            return
        unit = "contact" if self.by_contacts else "s"
        self.bar = tqdm(total=self.total, unit=unit, desc="record")
        self._format()

    def _format(self):
        if self.bar.total is None:
            self.bar.bar_format = "{desc}: {n:.0f} {unit} [{elapsed}{postfix}]"
        else:
            d = 0 if self.by_contacts else 1
            self.bar.bar_format = (
                f"{{l_bar}}{{bar}}| {{n:.{d}f}}/{{total:.{d}f}} {{unit}} [{{elapsed}}{{postfix}}]"
            )

    def update(self, session):
        now = time.monotonic()
        if now - self.last < (1.0 if self.plain else 0.1):
            return
        self.last = now
        if self.bar is None and not self.plain:
            self._open()
        s, c = session.stats, session.client.decoder.counters
        elapsed = session.elapsed()
        rate = s.samples / max(1e-9, elapsed)
        info = {
            "rate": f"{rate:.0f}/s",
            "contacts": s.contacts_ended,
            "lost": c.lost_frames,
            "bad": c.damaged,
            "gaps": len(session.gaps),
        }
        waiting = session.waiting_for()
        if waiting:
            info["until"] = waiting
        if self.plain:
            print(fields(info, skip=()), file=sys.stderr)
            return
        left = session.until_left_s() if self.total is None else None
        if left is not None:  # no --duration or --contacts: the pose log's end is the total
            self.bar.total = elapsed + left
            self._format()
        n = s.contacts_ended if self.by_contacts else elapsed
        self.bar.n = n if self.bar.total is None else min(n, self.bar.total)
        self.bar.set_postfix(info, refresh=False)
        self.bar.refresh()

    def say(self, session, line):
        """A line for the user while the bar runs (above it, not through it)."""
        if self.bar is not None:
            self.bar.write(printable(f"record: {line}"), file=sys.stderr)
        else:
            print(printable(f"record: {line}"), file=sys.stderr)

    def close(self, session):
        """The last counts; a run that finished as asked fills the bar."""
        if self.bar is None:
            return
        if session.ended in FINISHED:
            self.last = 0.0
            self.update(session)
            if self.bar.total:
                self.bar.n = self.bar.total
                self.bar.refresh()
        self.bar.close()
