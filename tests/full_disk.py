"""A disk that fills up, for tests and probes: ``builtins.open`` patched so that writes to
the chosen files of one directory share ``free`` bytes; the write that crosses it lands
the part that fits, as the kernel's short write does, and then raises
``OSError(ENOSPC)``.  ``names`` are shell patterns (``TEMP % "meta.json"`` is any
temporary ``tactile.files.writing`` writes meta.json through).  As on a real disk, writing
over a file's own bytes costs nothing (``in_place=False``: it does).  Reads, and files
elsewhere, are untouched."""

import builtins
import contextlib
import errno
import fnmatch
import io
import os
import pathlib

TEMP = ".%s.*.tmp"  # the temporaries of tactile.files.writing


class FullDisk:
    """``free`` bytes left (None: no limit, until a test sets one) for writes to ``names``
    (None: every file) under ``root``."""

    def __init__(self, root, free, names=None, in_place=True):
        self.root = pathlib.Path(root).resolve()
        self.free = free
        self.names = names
        self.in_place = in_place
        self.hits = []  # the files a write to failed, in order

    def covers(self, file):
        if not isinstance(file, str | os.PathLike):
            return False
        path = pathlib.Path(file).resolve()
        if path.parent != self.root:
            return False
        return self.names is None or any(fnmatch.fnmatchcase(path.name, n) for n in self.names)

    def take(self, name, n):
        """How many of ``n`` bytes fit; a write that does not fit is recorded."""
        if self.free is None:
            return n
        fits = max(0, min(n, self.free))
        self.free -= fits
        if fits < n:
            self.hits.append(pathlib.Path(name).name)
        return fits

    def open(self, real_open):
        def opener(file, mode="r", buffering=-1, encoding=None, errors=None, newline=None,
                   **kw):  # fmt: skip
            if not self.covers(file) or not set(mode) & set("wax+"):
                return real_open(file, mode, buffering, encoding, errors, newline, **kw)
            raw = _Limited(self, file, mode.replace("b", "").replace("t", ""))
            buffered = io.BufferedWriter(raw) if "+" not in mode else io.BufferedRandom(raw)
            if "b" in mode:
                return buffered
            return io.TextIOWrapper(buffered, encoding=encoding, errors=errors, newline=newline)

        return opener


class _Limited(io.FileIO):
    def __init__(self, disk, file, mode):
        super().__init__(file, mode)
        self.disk = disk

    def write(self, b):
        data = bytes(b)
        st = os.fstat(self.fileno())
        has = max(0, st.st_size - self.tell()) if self.disk.in_place else 0
        fits = min(len(data), has) + self.disk.take(self.name, max(0, len(data) - has))
        if fits < len(data):
            if fits:
                super().write(data[:fits])
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC), str(self.name))
        return super().write(data)


@contextlib.contextmanager
def full_disk(root, free, names=None, in_place=True):
    """Within the block, ``root``'s files (or ``names`` of them) have ``free`` bytes."""
    disk = FullDisk(root, free, names, in_place)
    real = builtins.open
    builtins.open = disk.open(real)
    try:
        yield disk
    finally:
        builtins.open = real
