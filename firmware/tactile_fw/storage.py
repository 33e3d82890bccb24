"""Small files on the board's flash (settings, calibration), replaced so that a power cut
at any point leaves the old copy or the new one, never neither.

Every file the board keeps ends with the CRC-16 of the bytes before it, low byte first
(``settings.bin``, ``cal<N>.bin``), so the storage tells a whole copy from a torn one
(``intact``) without knowing the format.

``DirStorage.write(name, data)``, with ``name.tmp`` beside ``name``:

1. if ``name`` is missing and ``name.tmp`` is intact (an earlier write cut between steps
   4 and 5), that copy is renamed to ``name`` first, so step 2 never truncates the only one;
2. the data go to ``name.tmp``, are read back and compared (OSError if they differ);
3. ``os.rename(name.tmp, name)``: on littlefs (the rp2 port's filesystem) and POSIX this
   replaces ``name`` in one step, so a cut leaves the old or the new file;
4. where the rename refuses because ``name`` exists (FAT on some ports), ``name`` is
   removed, only now that the whole new copy is checked in ``name.tmp``,
5. and the rename is done again.

``read(name)`` gives ``name`` if intact, else ``name.tmp`` if intact (a cut between steps
4 and 5: the new copy), else whatever ``name`` holds, None if missing (the loaders then
use the defaults: nothing was ever written whole).  Only ``open``, ``os.rename``,
``os.remove`` and ``os.stat``, as on MicroPython.

``MemoryStorage`` keeps files in a dict (tests, emulator).  ``write`` raises OSError when
the flash refuses.
"""

import os

from tactile_protocol.crc16 import crc16

TMP = ".tmp"
_EIO = 5


def intact(data):
    """True if ``data`` ends with the CRC-16 of the bytes before it."""
    if data is None or len(data) < 2:
        return False
    n = len(data) - 2
    return crc16(data, 0, n) == data[n] | (data[n + 1] << 8)


def _exists(path):
    try:
        os.stat(path)
    except OSError:
        return False
    return True


class DirStorage:
    def __init__(self, root=""):
        self.root = root

    def _path(self, name):
        return self.root + "/" + name if self.root else name

    @staticmethod
    def _load(path):
        try:
            with open(path, "rb") as f:
                return f.read()
        except OSError:
            return None

    def read(self, name):
        path = self._path(name)
        data = self._load(path)
        if intact(data):
            return data
        spare = self._load(path + TMP)
        return spare if intact(spare) else data

    def write(self, name, data):
        path = self._path(name)
        tmp = path + TMP
        if not _exists(path) and intact(self._load(tmp)):
            os.rename(tmp, path)  # the only copy: keep it before tmp is written again
        with open(tmp, "wb") as f:
            f.write(data)
        if self._load(tmp) != bytes(data):
            raise OSError(_EIO, "flash read back differs")
        try:
            os.rename(tmp, path)
        except OSError:
            if not _exists(path):
                raise
            os.remove(path)  # this port's rename does not replace: tmp holds the new copy
            os.rename(tmp, path)


class MemoryStorage:
    def __init__(self):
        self.files = {}
        self.fail_writes = False  # fault injection: the flash refuses

    def read(self, name):
        return self.files.get(name)

    def write(self, name, data):
        if self.fail_writes:
            raise OSError(28, "no space left on device")
        self.files[name] = bytes(data)
