"""The options several commands share: ``--port`` and ``--foxglove``.

``--foxglove`` and its options, shared by ``tactile live`` and ``tactile record``: a
Foxglove WebSocket server of the board's frames (``tactile.foxglove.live``, the
``foxglove`` extra) beside what the command does.  Its lines go to stderr.

What the board commands (info, config, tare, calibrate, record, live, flash) share:
``--port`` and connecting.
"""

import os
import sys

from tactile.board import serial_port
from tactile.board.client import BoardClient
from tactile.commands import ENV_PORT
from tactile.errors import InputError
from tactile.foxglove.live import LiveServer, require_foxglove
from tactile.output.text import count, printable

DEFAULT_HOST = "127.0.0.1"
DEFAULT_PORT = 8765
DEFAULT_RATE_HZ = 100.0  # tactile.foxglove.live.DEFAULT_RATE_HZ
LOOPBACK = ("127.0.0.1", "localhost", "::1")


def add_foxglove_arguments(parser):
    group = parser.add_argument_group("Foxglove (needs the 'foxglove' extra)")
    group.add_argument(
        "--foxglove",
        action="store_true",
        help="serve the wrench and contact state to Foxglove over its WebSocket protocol"
        " (record --pose-log: the contacts, sensor poses and EP2 patch too)",
    )
    group.add_argument(
        "--foxglove-host",
        default=DEFAULT_HOST,
        metavar="HOST",
        help="address to bind (127.0.0.1: this machine only)",
    )
    group.add_argument(
        "--foxglove-port",
        type=int,
        default=DEFAULT_PORT,
        metavar="PORT",
        help="TCP port; 0: any free one",
    )
    group.add_argument(
        "--foxglove-rate",
        type=float,
        default=DEFAULT_RATE_HZ,
        metavar="HZ",
        help="messages per sensor per second, by the board's clock; 0: every frame;"
        " contact begin/end frames always (100 Hz)",
    )


def check_foxglove(args):
    """Refuse bad ``--foxglove*`` values and a missing extra, before any board work."""
    if not args.foxglove:
        return

    if not 0 <= args.foxglove_port <= 65535:
        raise InputError(f"--foxglove-port: {args.foxglove_port} is not a TCP port (0-65535)")
    if not 0 <= args.foxglove_rate < float("inf"):
        raise InputError(f"--foxglove-rate: {args.foxglove_rate} is not a rate in Hz (>= 0)")
    require_foxglove()


def start_foxglove(args, device=None, pose_log=None, topics=(), port=None):
    """The ``LiveServer`` that ``args`` ask for (None without ``--foxglove``); says where.
    ``pose_log``: a robot's ``PoseLog``, to serve the contacts, transforms and patch too;
    ``topics``: the caller's own, made before the server listens; ``port``: the board's
    (its ``simulated_time``: no clock fit of its arrivals)."""
    if not args.foxglove:
        return None
    check_foxglove(args)

    per_contact = getattr(args, "per_contact", None)
    simulated = bool(getattr(port, "simulated_time", False))
    server = LiveServer(
        args.foxglove_host, args.foxglove_port, args.foxglove_rate, device, pose_log, per_contact,
        topics, simulated,
    )  # fmt: skip
    print(printable(f"foxglove: serving {server.url} ({_rate(args.foxglove_rate)})"),
          file=sys.stderr, flush=True)  # fmt: skip
    if args.foxglove_host not in LOOPBACK:
        print(
            printable(
                f"foxglove: note: {args.foxglove_host} is not loopback; anyone who reaches it"
                " sees the stream (the protocol has no authentication)"
            ),
            file=sys.stderr,
        )
    return server


def new_pose_log(server, pose_log):
    """The robot wrote its log anew as its run started (an emulator replaying its scene):
    ``server``'s scene localises by ``pose_log`` from the first frame on."""
    if server is not None and server.scene is not None and pose_log is not None:
        server.scene.live.log = pose_log


def _rate(rate_hz):
    """The rate in words: by the board's clock, which an emulator in fast mode runs faster
    than the host's (a client then gets more messages per second of its own)."""
    return f"{rate_hz:g} Hz per sensor by the board's clock" if rate_hz else "every frame"


def stop_foxglove(server, quiet=False):
    """Stop ``server`` (if any); print one line of what it published and dropped."""
    if server is None:
        return
    s = server.close()
    if quiet:
        return
    line = f"foxglove: published {s['published']:,} of {count(s['offered'], 'frame')}"
    out = [f"{s['decimated']:,} left out by the rate, {_rate(s['rate_hz'])}"] * bool(s["decimated"])
    out += [count(s["other"], "status or reply frame")] * bool(s["other"])
    if out:
        line += f" ({'; '.join(out)})"
    line += f"; {s['dropped']:,} dropped (the publisher fell behind)"
    if s["failed"]:
        line += f"; {s['failed']:,} failed ({s['error']})"
    print(printable(line), file=sys.stderr, flush=True)  # the error may quote a client
    c = s.get("scene")
    if c is not None:
        line = (
            f"foxglove: scene: {c['contacts']:,} contact readings localised,"
            f" {count(c['patches'], 'EP2 patch', 'es')} published"
            f" ({count(c['stale_fits'], 'fit')} skipped for newer contacts)"
        )
        if c["dropped_batches"]:
            line += f"; {c['dropped_batches']:,} frame batches dropped (the scene fell behind)"
        if c["localise_error"]:
            line += f"; localising stopped: {c['localise_error']}"
        if c["failed"]:
            line += f"; {c['failed']:,} failed ({c['error']})"
        print(printable(line), file=sys.stderr, flush=True)


PORT_HELP = "serial device or URL (sim://SCENE for the in-process emulator)"


def add_port_argument(
    parser, wait=2.0, wait_help="seconds to wait for the board's HELLO", port_help=PORT_HELP
):
    parser.add_argument(
        "-p",
        "--port",
        default=os.environ.get(ENV_PORT) or None,
        help=f"{port_help}; env {ENV_PORT}",
    )
    parser.add_argument("--wait", type=float, default=wait, help=wait_help)


def port_of(args):
    """``args.port``, or an InputError saying none was given."""
    if not args.port:
        raise InputError(
            f"--port: no port given (and {ENV_PORT} unset); 'tactile ports' lists them"
        )
    return args.port


def connect(args):
    """Open ``args.port`` and wait for HELLO; returns a BoardClient (the caller closes it)."""
    port = serial_port.open_port(port_of(args))  # (looked up here: tests fake ports)
    client = BoardClient(port, args.port)
    try:
        client.handshake(args.wait)
    except BaseException:
        client.close()
        raise
    return client
