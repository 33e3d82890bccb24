"""Frames: COBS(header + payload + CRC16 little-endian) + 0x00 (PROTOCOL.md §3).

``FrameEncoder`` owns preallocated buffers and a per-direction sequence
counter, so encoding a frame allocates no buffers.  ``FrameAssembler`` is
the byte-at-a-time receiver used on the board for commands: its memory is
fixed whatever arrives.
"""

from tactile_protocol.cobs_codec import encode_into
from tactile_protocol.constants import CRC_SIZE, MAX_BODY, MAX_ENCODED, MAX_FRAME
from tactile_protocol.crc16 import crc16
from tactile_protocol.messages import pack_into, unpack


class FrameEncoder:
    """Encode messages into one reused output buffer.

    ``encode`` returns a memoryview that stays valid until the next call.
    """

    def __init__(self, seq=0):
        self.seq = seq & 0xFFFF
        self._body = bytearray(MAX_BODY)
        self._out = bytearray(MAX_FRAME)
        self._out_mv = memoryview(self._out)

    def encode(self, mtype, timestamp_us, values, check=True):
        body = self._body
        n = pack_into(body, mtype, self.seq, timestamp_us, values, check)
        crc = crc16(body, 0, n)
        body[n] = crc & 0xFF
        body[n + 1] = crc >> 8
        end = encode_into(body, n + CRC_SIZE, self._out, 0)
        self._out[end] = 0
        self.seq = (self.seq + 1) & 0xFFFF
        return self._out_mv[: end + 1]


def encode_frame(mtype, seq, timestamp_us, values):
    """One frame as bytes (convenience; not for hot paths)."""
    return bytes(FrameEncoder(seq).encode(mtype, timestamp_us, values))


def decode_cobs_in_place(buf, n):
    """Decode ``buf[:n]`` in place (decoded data is never longer); -1 if bad."""
    i = 0
    out = 0
    while i < n:
        code = buf[i]
        if code == 0 or i + code > n:
            return -1
        for j in range(i + 1, i + code):
            buf[out] = buf[j]
            out += 1
        i += code
        if code != 0xFF and i < n:
            buf[out] = 0
            out += 1
    return out


# FrameAssembler.feed results
FRAME_NONE = 0  # no complete frame yet
FRAME_OK = 1
FRAME_BAD = 2  # COBS, CRC, or layout error
FRAME_OVERSIZE = 3


class FrameAssembler:
    """Collect bytes up to the 0x00 delimiter into a fixed buffer.

    ``feed(byte)`` returns one of the FRAME_* codes.  After FRAME_OK,
    ``message()`` returns ``(mtype, seq, timestamp_us, values)``.
    """

    def __init__(self):
        self._buf = bytearray(MAX_ENCODED)
        self._n = 0
        self._overflow = False
        self._body_len = 0

    def feed(self, byte):
        if byte != 0:
            if self._n < MAX_ENCODED:
                self._buf[self._n] = byte
                self._n += 1
            else:
                self._overflow = True
            return FRAME_NONE
        n, overflow = self._n, self._overflow
        self._n = 0
        self._overflow = False
        if overflow:
            return FRAME_OVERSIZE
        if n == 0:
            return FRAME_NONE
        m = decode_cobs_in_place(self._buf, n)
        if m < CRC_SIZE + 1:
            return FRAME_BAD
        body_len = m - CRC_SIZE
        if crc16(self._buf, 0, body_len) != self._buf[body_len] | (self._buf[body_len + 1] << 8):
            return FRAME_BAD
        self._body_len = body_len
        return FRAME_OK

    def message(self):
        """Parse the frame just completed; ValueError if its layout is wrong."""
        return unpack(self._buf, self._body_len)
