"""The board handed over around a flash: to MicroPython's raw REPL before, back to the
firmware after.

**Before flashing**: get a board to MicroPython's raw REPL, or say in one line what is there.

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

**After a flash resets the board**: the port again, and the firmware's HELLO, in bounded time.

A Pico's USB port goes away at ``machine.reset()`` and comes back once MicroPython runs
again; an emulator's pty stays.  ``answer`` opens the port as often as it goes away, within
``wait_s`` in all, and waits for the firmware's HELLO (sent at boot) or asks with GET_INFO.
It asks soon (``ASK_GONE_S``) only on a port that went and came back: there the firmware
has started (USB enumerates after MicroPython does, and ``main.py`` turns Ctrl-C off on its
first line).  On a port that stayed (an emulator's pty, which hears the HELLO) it asks only
``ASK_STAYED_S`` after the reset, since a GET_INFO's 0x03 reaching MicroPython before
``main.py`` has run that line would stop ``main.py``.
Nothing in time is one ``BoardTimeout`` line with the last thing the port said (a
traceback's last line, when the firmware failed to start).
"""

import time

from tactile.board.client import BoardClient
from tactile.board.serial_port import describe_lost, open_port
from tactile.errors import BoardError, BoardTimeout, PortError, PortLost, TactileError
from tactile.output.text import printable

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


SETTLE_S = 0.3  # after the reset, before looking for the port
ASK_GONE_S = 1.0  # the port went and came back: ask after this long
ASK_STAYED_S = 8.0  # the port stayed: let HELLO come this long after the reset first
REOPEN_S = 0.2  # between tries to open a port that is not back
REPL_LINES = (b">>>", b"MicroPython v", b'Type "help()"', b"raw REPL")


class _Said:
    """The last bytes the port said, for the line when no firmware answers."""

    def __init__(self):
        self.tail = b""

    def __call__(self, data):
        self.tail = (self.tail + data)[-600:]

    def last_line(self):
        """Its last line that is not the REPL's banner or prompt, escaped ("" for none)."""
        lines = [ln.strip() for ln in self.tail.replace(b"\r", b"\n").split(b"\n")]
        lines = [ln for ln in lines if ln and not ln.startswith(REPL_LINES)]
        return printable(lines[-1][:80].decode("latin-1")) if lines else ""


def answer(
    port, wait_s, what="the copy finished", opener=open_port, clock=time.monotonic, sleep=time.sleep
):
    """The firmware's HELLO or INFO on ``port`` within ``wait_s`` of the reset (module
    docstring); ``what`` starts the line when it does not come."""
    start = clock()
    said, client, gone, ask = _Said(), None, False, ASK_STAYED_S
    sleep(SETTLE_S)
    try:
        while (left := wait_s - (clock() - start)) > 0:
            if client is None:
                try:
                    client = BoardClient(opener(port), port, capture=said, clock=clock)
                except PortError:
                    gone = True
                    sleep(min(REOPEN_S, left))
                    continue
                ask = ASK_GONE_S if gone else max(0.0, ASK_STAYED_S - (clock() - start))
            try:
                return client.handshake(timeout=min(left, max(2 * ask, 2.0)), ask_after=ask)
            except BoardTimeout:
                ask = ASK_GONE_S  # asked once: ask again at this pace
            except PortLost:
                client.close()
                client, gone = None, True
                sleep(min(REOPEN_S, left))
    finally:
        if client is not None:
            client.close()
    last = said.last_line()
    heard = f"; the last it said: {last}" if last else "; it said nothing"
    raise BoardTimeout(
        f"{port}: {what} and the board was reset, but the firmware did not answer within "
        f"{wait_s:g} s{heard}"
    )


def describe(info):
    """One line on what answered: firmware, sensors, rate."""
    model = printable(bytes(info.sensor_model).rstrip(b"\0").decode("latin-1"))
    n = info.n_sensors
    return (
        f"tactile firmware {info.fw_major}.{info.fw_minor}.{info.fw_patch} (protocol "
        f"{info.protocol_version}), {n} sensor{'s' if n != 1 else ''} {model}, "
        f"{info.rate_hz} Hz (ceiling {info.max_rate_hz} Hz)"
    )
