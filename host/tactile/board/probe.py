"""Before flashing: get a board to MicroPython's raw REPL, or say in one line what is there.

``break_in(port, name)`` does what mpremote does to reach the raw REPL (CR, Ctrl-C, then CR,
Ctrl-A) after one 0x00, which ends any partial frame the tactile firmware may hold: then
the firmware sees CR, Ctrl-C, CR as the first bytes of a frame, its ``BREAK_IN``
(``tactile_fw.port_mpy``), exits to the REPL, and the Ctrl-A that follows is the REPL's. A
board at its REPL, or running any program that Ctrl-C stops, answers with the raw REPL's
banner; ``break_in`` returns once it has come.  Everything else ends within
``window_s`` (``FIRMWARE_S`` once frames come) in a ``NoRepl`` naming what was found:

- the tactile firmware speaking its protocol, with no REPL behind it (the emulator's
  python core, a Linux controller, a MicroPython firmware without ``BREAK_IN``);
- nothing at all;
- bytes that are neither, shown escaped.

A port that fails while it is probed is ``PortLost``, as in ``tactile.board.client``; one
that cannot be opened is ``tactile.board.serial_port``'s business.
"""

import time

from tactile.board.client import BoardClient
from tactile.board.serial_port import describe_lost
from tactile.errors import BoardError, PortLost, TactileError

BREAK = b"\x00\r\x03"  # end a partial frame; CR, Ctrl-C (BREAK_IN's first two bytes)
RAW = b"\r\x01"  # CR (BREAK_IN's third); Ctrl-A: the raw REPL
BANNER = b"raw REPL; CTRL-B to exit\r\n>"
PAUSE_S = 0.1  # between BREAK and RAW: a Ctrl-C'd program's traceback, as mpremote waits
RESEND_S = 2.5  # a board still booting may have missed the first
WINDOW_S = 10.0  # no banner and no frames by then: not a MicroPython REPL
FIRMWARE_S = 3.0  # frames for this long after the first, no banner: no REPL behind them
FIRMWARE_FRAMES = 2  # a CRC-checked frame or two in noise is chance; a stream is not
INFO_S = 1.5  # asking the firmware its version
SHOWN_BYTES = 48
READ_TIMEOUT_S = 0.05  # the port's, while probing: a read waits at most this for bytes


class NoRepl(BoardError):
    """The port answers, or not, but not as MicroPython's REPL (one line, exit 4)."""


class _Heard:
    """What the port said: its first bytes (for the message) and a tail to find the banner
    in, bounded whatever streams in."""

    def __init__(self):
        self.first = b""
        self.tail = b""
        self.count = 0
        self.banner = False

    def __call__(self, data):
        self.count += len(data)
        if len(self.first) < SHOWN_BYTES:
            self.first += data[: SHOWN_BYTES - len(self.first)]
        seen = self.tail + data
        self.banner = self.banner or BANNER in seen
        self.tail = seen[-len(BANNER) :]


def _write(port, name, data):
    try:
        port.write(data)
    except TactileError:
        raise
    except OSError as exc:  # pyserial's SerialException is an OSError
        raise PortLost(describe_lost(name, exc, "writing")) from None


def break_in(port, name, window_s=WINDOW_S, clock=time.monotonic):
    """Bring the board on ``port`` (open, pyserial-like, with a short read timeout) to its
    raw REPL's prompt, or raise ``NoRepl``; see the module docstring."""
    heard = _Heard()
    client = BoardClient(port, name, capture=heard, clock=clock)
    start = clock()
    next_break, raw_at, frames_since = start, None, None
    while True:
        now = clock()
        if now >= next_break:
            _write(port, name, BREAK)
            next_break, raw_at = now + RESEND_S, now + PAUSE_S
        if raw_at is not None and now >= raw_at:
            _write(port, name, RAW)
            raw_at = None
        client.read()  # (waits up to the port's timeout for bytes)
        if heard.banner:
            return
        c = client.decoder.counters
        if frames_since is None and c.frames + c.version_mismatch >= FIRMWARE_FRAMES:
            frames_since = now
        if frames_since is not None and now - frames_since >= FIRMWARE_S:
            raise NoRepl(_firmware(client, name))
        if now - start >= window_s:
            break
    if heard.count == 0:
        raise NoRepl(f"{name} said nothing in {window_s:g} s: is it a MicroPython board?")
    shown = heard.first.decode("latin-1").encode("unicode_escape").decode("ascii")
    more = "..." if heard.count > len(heard.first) else ""
    raise NoRepl(f"{name} answered, but not as MicroPython's REPL: {shown}{more}")


def _firmware(client, name):
    """The line for a port where the tactile firmware answers and no REPL does."""
    c = client.decoder.counters
    if c.frames == 0:
        what = f"protocol version {c.last_version}"
    else:
        info = client.info
        if info is None:
            try:
                info = client.get_info(timeout=INFO_S)
            except BoardError:
                info = None
        if info is None:
            what = "firmware version unknown"
        else:
            what = f"firmware {info.fw_major}.{info.fw_minor}.{info.fw_patch}"
    return (
        f"found the tactile firmware speaking its protocol on {name} ({what}, no MicroPython "
        "REPL behind it)"
    )
