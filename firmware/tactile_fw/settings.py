"""Board settings (rate, contact gate, streams, autostart): persistence, within the limits.

The limits, defaults and the rule (``check``) are the protocol's settings vocabulary
(``tactile_protocol.settings``), which the host and the emulator read too; this module
stores and loads the settings a board keeps (``settings.bin``).
"""

import struct

from tactile_protocol.constants import CFG_PERSIST, CFG_WRITABLE
from tactile_protocol.crc16 import crc16
from tactile_protocol.settings import (
    DEFAULT_DEBOUNCE,
    DEFAULT_ENTER_UN,
    DEFAULT_EXIT_UN,
    DEFAULT_FLAGS,
    DEFAULT_RATE_HZ,
    check,
)

FILE_NAME = "settings.bin"
_MAGIC = b"TSET"
_FMT = "<4sBHiiBB"
_SIZE = struct.calcsize(_FMT)


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
