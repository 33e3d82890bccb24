"""A device that lies, in-process: well-framed frames with whatever content a test gives.

``LyingPort`` behaves like a pyserial port on a board: HELLO on open, INFO + ACK
to GET_INFO, ACK to every other command and, once started, the frames of
``stream``.  ``lying_ports(port)`` makes every ``--port`` the CLI opens (``info``,
``config``, ``tare``, ``live``, ``record``) that port.  Values are packed without
the encoder's checks: anything a field's type holds goes on the wire.
"""

import contextlib
import time
from unittest import mock

import tactile.recording.session  # noqa: F401 - imported before patching (see lying_ports)
from tactile.board.stream_decoder import StreamDecoder
from tactile_protocol import constants as C
from tactile_protocol.framing import FrameEncoder
from tactile_protocol.messages import BY_NAME

FIELDS, CODES = BY_NAME["HELLO"][4], BY_NAME["HELLO"][5]  # HELLO and INFO share the layout
GOOD = dict(fw_major=1, fw_minor=2, fw_patch=3, protocol_version=C.PROTOCOL_VERSION,
            sensor_model=b"FT6", n_sensors=1, max_rate_hz=1730, cal_id_0=7, rate_hz=1000,
            enter_threshold=1390000, exit_threshold=1112000, debounce=3,
            flags=C.CFG_STREAM_CONTACTS)  # fmt: skip


def info_values(**changes):
    """A valid HELLO/INFO payload with ``changes``; a field not named above is 0."""
    values = {**GOOD, **changes}
    return tuple(values.get(f, b"" if c.endswith("s") else 0) for f, c in zip(FIELDS, CODES))


GOOD_INFO = info_values()


def frame(mtype, values, seq=0, ts=0):
    return bytes(FrameEncoder(seq).encode(mtype, ts, values, False))


class LyingPort:
    """See the module docstring; ``stream``: (type, values) sent after START, in order."""

    def __init__(self, hello=GOOD_INFO, info=None, stream=()):
        self.enc = FrameEncoder()
        self.info = hello if info is None else info
        self.stream = list(stream)
        self.out = bytearray(self._frame(C.MSG_HELLO, hello))
        self.commands = StreamDecoder(check_limits=False)
        self.streaming = False
        self.closed = False

    def _frame(self, mtype, values):
        return bytes(self.enc.encode(mtype, 1000 * self.enc.seq, values, False))

    @property
    def in_waiting(self):
        return len(self.out)

    def read(self, size=1):
        if not self.out and self.streaming and self.stream:
            for mtype, values in self.stream[:8]:
                self.out += self._frame(mtype, values)
            del self.stream[:8]
        if not self.out:
            time.sleep(0.001)  # a real port waits out its timeout
            return b""
        data = bytes(self.out[:size])
        del self.out[:size]
        return data

    def write(self, data):
        for m in self.commands.feed(bytes(data)):
            if m.type_code == C.CMD_GET_INFO:
                self.out += self._frame(C.MSG_INFO, self.info)
            elif m.type_code == C.CMD_START:
                self.streaming = True
            elif m.type_code == C.CMD_STOP:
                self.streaming = False
            self.out += self._frame(C.MSG_ACK, (m.type_code, m.seq))
        return len(data)

    def close(self):
        self.closed = True


@contextlib.contextmanager
def lying_ports(make_port):
    """While active, opening any port gives ``make_port()`` (a fresh LyingPort each time).

    ``tactile.recording.session`` binds ``open_port`` at import: imported first (above), so
    it does not bind the patched opener for good."""
    opener = lambda name, *a, **k: make_port()  # noqa: E731
    with (
        mock.patch("tactile.board.serial_port.open_port", opener),
        mock.patch("tactile.recording.session.open_port", opener),
    ):
        yield
