"""Small files on the board's flash (settings, calibration), written atomically.

``DirStorage`` uses ``open``/``os.rename`` (both on MicroPython and CPython);
``MemoryStorage`` keeps files in a dict (tests, emulator).  ``read`` returns
None for a missing file; ``write`` raises OSError when the flash refuses.
"""

import os


class DirStorage:
    def __init__(self, root=""):
        self.root = root

    def _path(self, name):
        return self.root + "/" + name if self.root else name

    def read(self, name):
        try:
            with open(self._path(name), "rb") as f:
                return f.read()
        except OSError:
            return None

    def write(self, name, data):
        path = self._path(name)
        tmp = path + ".tmp"
        with open(tmp, "wb") as f:
            f.write(data)
        try:
            os.remove(path)  # MicroPython's rename does not replace on every port
        except OSError:
            pass
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
