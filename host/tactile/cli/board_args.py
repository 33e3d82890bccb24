"""What the board commands (info, config, tare, calibrate, record, live) share: ``--port``
and connecting."""

import os

ENV_PORT = "TACTILE_PORT"


def add_port_argument(parser):
    parser.add_argument(
        "--port",
        "-p",
        default=os.environ.get(ENV_PORT),
        help=f"serial device or URL (sim://SCENE for the in-process emulator); env {ENV_PORT}",
    )
    parser.add_argument(
        "--wait", type=float, default=2.0, help="seconds to wait for the board's HELLO"
    )


def connect(args):
    """Open ``args.port`` and wait for HELLO; returns a BoardClient (the caller closes it)."""
    from tactile.board_client import BoardClient
    from tactile.errors import InputError
    from tactile.serial_port import open_port

    if not args.port:
        raise InputError(
            f"--port: no port given (and {ENV_PORT} unset); 'tactile ports' lists them"
        )
    port = open_port(args.port)
    client = BoardClient(port, args.port)
    try:
        client.handshake(args.wait)
    except BaseException:
        client.close()
        raise
    return client
