"""Power cuts at every flash call of the board's storage, then a boot: what does it load?

``Flash`` stands between ``tactile_fw.storage`` and the real filesystem (``install``
swaps it in for the module's ``open`` and ``os``): every call (open, write, close, stat,
rename, remove) is counted, and at call number ``cut_at`` the power goes: that call does
nothing (a write lands half its bytes, a torn page) and raises ``PowerCut``, as does
every call after it.  What reached the directory before the cut is what the next boot
finds.  ``refuse_replace`` makes ``rename`` refuse an existing target (FAT on some
MicroPython ports) instead of replacing it (littlefs, POSIX).

``sweep`` persists settings and calibration ``OLD``, then ``NEW`` with a cut at call k,
for every k until the writes complete, and boots after each: the loaders (``settings.load``,
``calibration.load``) name what they found, ``old``, ``new`` or ``defaults``.

Runs unchanged on CPython (tests/test_fw_storage.py) and MicroPython
(tests/fw_mpy_power_cut.py, on the WebAssembly port's filesystem).
"""

import os

from tactile_fw import calibration, settings, storage

MAX_RATE_HZ = 1000
FILES = ("settings.bin", "cal0.bin")


class PowerCut(Exception):
    """The board lost power during this call."""


class _File:
    def __init__(self, flash, f):
        self.flash, self.f = flash, f

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()

    def read(self, *n):
        self.flash.call("read")
        return self.f.read(*n)

    def write(self, data):
        if self.flash.cut is None and self.flash.calls == self.flash.cut_at:
            self.f.write(data[: len(data) // 2])  # the page torn halfway
        self.flash.call("write")
        return self.f.write(data)

    def close(self):
        if self.f is None:
            return
        f, self.f = self.f, None
        f.close()  # (the host's handle; what was written is on the flash already)
        self.flash.call("close")


class Flash:
    """The filesystem as ``tactile_fw.storage`` sees it, with a power cut (module doc)."""

    def __init__(self, cut_at=-1, refuse_replace=False):
        self.cut_at, self.refuse_replace = cut_at, refuse_replace
        self.calls = 0
        self.cut = None  # the call the power went in

    def call(self, what):
        if self.cut is not None or self.calls == self.cut_at:
            self.cut = self.cut or what
            raise PowerCut(what)
        self.calls += 1

    def open(self, path, mode="r"):
        self.call("open")
        return _File(self, open(path, mode))

    def stat(self, path):
        self.call("stat")
        return os.stat(path)

    def remove(self, path):
        self.call("remove")
        os.remove(path)

    def rename(self, src, dst):
        self.call("rename")
        if self.refuse_replace and _exists(dst):
            raise OSError(17, "file exists")  # EEXIST
        os.rename(src, dst)


def _exists(path):
    try:
        os.stat(path)
    except OSError:
        return False
    return True


def install(flash):
    """Make ``tactile_fw.storage`` use ``flash``; returns what to give ``uninstall``."""
    saved = (storage.os, getattr(storage, "open", None))
    storage.os = flash
    storage.open = flash.open
    return saved


def uninstall(saved):
    storage.os = saved[0]
    if saved[1] is None:
        del storage.open  # back to the builtin
    else:
        storage.open = saved[1]


def _coeffs(scale):
    return [scale * (1 + r) * 1e-6 if r == c else 1e-9 * c for r in range(6) for c in range(6)]


def _pair(rate, cal_id):
    return settings.Settings(rate, 2000 * rate, 1000 * rate, 4, 0x0B), calibration.Calibration(
        _coeffs(cal_id), cal_id
    )


OLD, NEW, NEWER = _pair(500, 11), _pair(250, 22), _pair(125, 33)
NAMES = (("old", OLD), ("new", NEW), ("newer", NEWER))


def persist(root, pair, flash):
    """What CONFIG with CFG_PERSIST and SET_CAL write, through ``flash``."""
    saved = install(flash)
    try:
        store = storage.DirStorage(root)
        pair[0].save(store)
        pair[1].save(store, 0)
    finally:
        uninstall(saved)


def boot(root):
    """What the board loads at boot, named: (settings, calibration), each ``old``, ``new``,
    ``newer``, ``defaults`` (identity for the calibration) or ``other``."""
    store = storage.DirStorage(root)
    s = settings.load(store, MAX_RATE_HZ).fields()
    c = calibration.load(store, 0)
    seen_s = seen_c = "other"
    if s == settings.Settings(rate_hz=MAX_RATE_HZ).fields():
        seen_s = "defaults"
    if not c.present:
        seen_c = "defaults"
    for name, pair in NAMES:
        if pair[0].fields() == s:
            seen_s = name
        if (pair[1].cal_id, pair[1].raw) == (c.cal_id, c.raw):
            seen_c = name
    return seen_s, seen_c


def clear(root):
    for name in FILES:
        for path in (root + "/" + name, root + "/" + name + ".tmp"):
            if _exists(path):
                os.remove(path)


def cut_once(root, k, refuse_replace, first=OLD, then=NEW):
    """Persist ``first``, then ``then`` with a cut at call ``k``; the call cut (None if the
    writes completed) and what the board boots with."""
    clear(root)
    persist(root, first, Flash(refuse_replace=refuse_replace))
    flash = Flash(k, refuse_replace)
    try:
        persist(root, then, flash)
    except PowerCut:
        pass
    return flash.cut, boot(root)


def sweep(root, refuse_replace):
    """[(k, call cut, settings at boot, calibration at boot)] for every k, the last uncut."""
    rows = []
    k = 0
    while True:
        cut, seen = cut_once(root, k, refuse_replace)
        rows.append((k, cut, seen[0], seen[1]))
        if cut is None:
            return rows
        k += 1


def cut_twice(root, k1, k2, refuse_replace):
    """Persist ``OLD``, ``NEW`` cut at call ``k1``, boot, ``NEWER`` cut at call ``k2``, boot:
    (what the first boot loaded, what the second did)."""
    cut_once(root, k1, refuse_replace)
    first = boot(root)
    try:
        persist(root, NEWER, Flash(k2, refuse_replace))
    except PowerCut:
        pass
    return first, boot(root)
