"""``tactile record --port P [--duration S | --contacts N] -o DIR``: record a board's stream.

Writes DIR/capture.bin, frames.csv, device.jsonl and meta.json as data arrive
(see ``tactile.recording``); with ``--pose-log`` it then derives the contact
points for EP2 (DIR/contacts.csv) or the rolling probes for EP1
(DIR/probes.csv), ready for ``tactile ep2 analyze`` / ``tactile ep1 estimate``.
With a pose log it stops on its own once the log's end has passed (its ``# end:`` line,
or half a second after its last entry), and says so while it waits.  The summary names the
board -> host time base (``tactile.timebase``); ``warning:`` lines go to stderr.
"""

import sys

from tactile.cli.board_args import add_port_argument


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
    parser.add_argument("--quiet", action="store_true", help="no progress display")


def run(args):
    from tactile.errors import InputError
    from tactile.record_session import Session

    if args.duration is not None and not args.duration > 0:
        raise InputError(f"--duration: {args.duration} is not a positive number of seconds")
    if args.contacts is not None and args.contacts <= 0:
        raise InputError(f"--contacts: {args.contacts} is not a positive count")
    if not args.port:
        from tactile.cli.board_args import connect

        connect(args)  # raises the 'no port given' message
    until = None
    if args.pose_log:
        from tactile.derive import check_log
        from tactile.log_clock import log_end

        log = check_log(args.pose_log)  # a bad log is refused before recording, not after
        end, how = log_end(log.t_end if hasattr(log, "t_end") else log.t_end_us, log.end_us)
        until = (log.clock, end, how)
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
    )
    if until is not None and not args.quiet:
        from tactile.log_clock import show_time

        print(
            f"record: stops when the pose log is done ({show_time(until[0], until[1])}:"
            f" {until[2]}), or on Ctrl-C",
            file=sys.stderr,
        )
    progress = None if args.quiet else Progress(args.duration, args.contacts)
    if progress:
        session.on_progress = progress.update
    try:
        meta = session.run()
    finally:
        if progress:
            progress.close()
    print(summary(meta, args.out))
    print(time_summary(meta.get("time_base")))
    if args.pose_log:
        from tactile.derive import derive

        for line in derive(args.out, args.pose_log, per_contact=args.per_contact):
            print(line, file=sys.stderr if line.startswith("warning:") else sys.stdout)
    return 0


def time_summary(time_base):
    """One line: the board -> host mapping of the latest segment and its quality."""
    segs = (time_base or {}).get("segments") or []
    if not segs:
        return "time base: none (no frame arrived)"
    s = segs[-1]
    more = f" (segment {len(segs)} of {len(segs)}, one per boot)" if len(segs) > 1 else ""
    if not s.get("usable"):
        return f"time base: not usable{more}: {s.get('why', 'no fit')}"
    return (
        f"time base{more}: board clock drift {s['drift_ppm']:+.1f} ppm, {s['bins']} bins;"
        f" arrival delay mean {s['arrival_delay_mean_ms']:.2f} ms, max"
        f" {s['arrival_delay_max_ms']:.2f} ms; fit floor {s['fit_floor_ms']:.3f} ms"
    )


def summary(meta, out):
    d = meta["decoder"] or {}
    gaps = len(meta["gaps"])
    invalid = d.get("invalid", 0)  # frames outside the protocol's limits (device.jsonl names them)
    return (
        f"recorded {meta['samples']} readings, {meta['contacts_ended']} contacts in "
        f"{meta['elapsed_s']:.1f} s ({meta['ended']}); lost {d.get('lost_frames', 0)} frames, "
        f"{d.get('crc_errors', 0)} CRC errors, {gaps} gap{'s' * (gaps != 1)}"
        f"{f', {invalid} invalid frames refused' if invalid else ''} -> {out}"
    )


class Progress:
    """A tqdm bar (time or contacts) with rate, contacts and loss; plain lines without tqdm."""

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
        fmt = "{l_bar}{bar}| {n:.0f}/{total_fmt} {unit} [{elapsed}{postfix}]"
        if self.total is None:
            fmt = "{desc}: {n:.0f} {unit} [{elapsed}{postfix}]"
        self.bar = tqdm(total=self.total, unit=unit, bar_format=fmt, desc="record")

    def update(self, session):
        import time

        now = time.monotonic()
        if now - self.last < (1.0 if self.plain else 0.1):
            return
        self.last = now
        if self.bar is None and not self.plain:
            self._open()
        s, c = session.stats, session.client.decoder.counters
        rate = s.samples / max(1e-9, now - session.started)
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
            print(" ".join(f"{k}={v}" for k, v in info.items()), file=sys.stderr)
            return
        self.bar.n = s.contacts_ended if self.by_contacts else now - session.started
        self.bar.set_postfix(info, refresh=False)
        self.bar.refresh()

    def close(self):
        if self.bar is not None:
            self.bar.close()
