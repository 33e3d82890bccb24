"""After a flash resets the board: the port again, and the firmware's HELLO, in bounded time.

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
from tactile.board.serial_port import open_port
from tactile.errors import BoardTimeout, PortError, PortLost
from tactile.output.text import printable

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
