"""Board settings (rate, contact gate, streams, autostart): limits and persistence.

Defaults follow the thesis (§5.1, §5.1.3): a contact is |F| in the x-y plane
above "5 units"; the sensor's stated accuracy is 0.20 oz in x and y, so the
units are read as ounces-force (1 ozf = 0.278 N).  Enter at 5 ozf
(1.390 N), exit at 4 ozf (1.112 N): the 1 ozf hysteresis band is five times
the stated accuracy, and a 3-sample debounce rejects single-sample spikes.
"""

import struct

from tactile_protocol.constants import CFG_PERSIST, CFG_STREAM_CONTACTS, CFG_WRITABLE
from tactile_protocol.crc16 import crc16

FILE_NAME = "settings.bin"
DEFAULT_RATE_HZ = 1000
DEFAULT_ENTER_UN = 1390000  # 5 ozf in uN
DEFAULT_EXIT_UN = 1112000  # 4 ozf in uN
DEFAULT_DEBOUNCE = 3
DEFAULT_FLAGS = CFG_STREAM_CONTACTS
MIN_RATE_HZ = 1
MAX_DEBOUNCE = 255
_MAGIC = b"TSET"
_FMT = "<4sBHiiBB"
_SIZE = struct.calcsize(_FMT)

# CONFIG field indices, reported in NAK.detail
F_RATE = 0
F_ENTER = 1
F_EXIT = 2
F_DEBOUNCE = 3
F_FLAGS = 4


class Settings:
    def __init__(
        self,
        rate_hz=DEFAULT_RATE_HZ,
        enter=DEFAULT_ENTER_UN,
        exit_=DEFAULT_EXIT_UN,
        debounce=DEFAULT_DEBOUNCE,
        flags=DEFAULT_FLAGS,
    ):
        self.rate_hz = rate_hz
        self.enter = enter
        self.exit = exit_
        self.debounce = debounce
        self.flags = flags & CFG_WRITABLE & ~CFG_PERSIST

    def fields(self):
        return (self.rate_hz, self.enter, self.exit, self.debounce, self.flags)

    def to_bytes(self):
        body = struct.pack(_FMT, _MAGIC, 1, *self.fields())
        crc = crc16(body)
        return body + bytes((crc & 0xFF, crc >> 8))

    def save(self, storage):
        storage.write(FILE_NAME, self.to_bytes())


def check(rate_hz, enter, exit_, debounce, flags, max_rate_hz):
    """Index of the first CONFIG field out of range, or -1 if all are valid."""
    if not MIN_RATE_HZ <= rate_hz <= max_rate_hz:
        return F_RATE
    if enter < 0:
        return F_ENTER
    if not 0 <= exit_ <= enter:
        return F_EXIT
    if not 1 <= debounce <= MAX_DEBOUNCE:
        return F_DEBOUNCE
    if flags & ~CFG_WRITABLE:
        return F_FLAGS
    return -1


def load(storage, max_rate_hz):
    """Stored settings if present, intact and within today's limits; else defaults."""
    data = storage.read(FILE_NAME)
    default = Settings(rate_hz=min(DEFAULT_RATE_HZ, max_rate_hz))
    if data is None or len(data) != _SIZE + 2:
        return default
    if crc16(data, 0, _SIZE) != data[_SIZE] | (data[_SIZE + 1] << 8):
        return default
    f = struct.unpack(_FMT, data[:_SIZE])
    if f[0] != _MAGIC or f[1] != 1 or check(f[2], f[3], f[4], f[5], f[6], max_rate_hz) >= 0:
        return default
    return Settings(f[2], f[3], f[4], f[5], f[6])
