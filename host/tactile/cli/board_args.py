"""What the board commands (info, config, tare, calibrate, record, live, flash) share:
``--port`` and connecting."""

import os

from tactile.board import serial_port
from tactile.board.client import BoardClient
from tactile.commands import ENV_PORT
from tactile.errors import InputError

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
