"""Two firmwares on twin hardware: the Python ``Board`` and the C core, fed the same inputs.

Each twin owns its own simulated converters, buses, clock, link and storage (a ``Rig``
of ``fw_rig``), so neither can see the other's state; every operation is applied to
both, and the bytes each board wrote are compared after every step.
"""

import pathlib

from fw_rig import Rig
from toolchain import missing

from tactile_fw_tools import ccore

ROOT = pathlib.Path(__file__).resolve().parents[1]


def build_or_skip(out_dir, **kw):
    """The core built by ``cc`` into ``out_dir``; a skip with the reason when there is no cc."""
    try:
        return ccore.build(out_dir, **kw)
    except ccore.NoCompiler as exc:
        missing(str(exc))


def c_rig(lib, n=1, storage=None, **board_kw):
    """A ``Rig`` whose board is the C core on the rig's own buses, link, clock and storage."""
    rig = Rig(n=n, storage=storage)
    layout = [(i % 2, i // 2) for i in range(n)]
    rig.board = ccore.CBoard(lib, rig.buses, layout, rig.link, rig.clock, rig.storage, **board_kw)
    return rig


class Twin:
    """``py`` and ``c``: the same sensors, the same start time, the same stored files."""

    def __init__(self, lib, n=1, t0=0, files=None, **board_kw):
        self.py = Rig(n=n, **board_kw)
        self.c = c_rig(lib, n=n, **board_kw)
        self.rigs = (self.py, self.c)
        for rig in self.rigs:
            rig.clock.t_us = t0
            rig.storage.files.update(files or {})
        # the boards read the clock when built: rebuild them at t0
        self.py.board = type(self.py.board)(
            self.py.sensors, self.py.link, self.py.clock, self.py.storage, **board_kw
        )
        layout = [(i % 2, i // 2) for i in range(n)]
        self.c.board = ccore.CBoard(
            lib, self.c.buses, layout, self.c.link, self.c.clock, self.c.storage, **board_kw
        )
        self.out = [bytearray(), bytearray()]

    def each(self, fn):
        for rig in self.rigs:
            fn(rig)

    def step(self, what):
        """Take both outputs; they must be the same bytes (``what`` names the step)."""
        a, b = self.py.link.take(), self.c.link.take()
        self.out[0] += a
        self.out[1] += b
        if a != b:
            raise AssertionError(
                f"after {what}: Python wrote {len(a)} bytes, C {len(b)}\n"
                f"  py {a.hex()}\n  c  {b.hex()}"
            )
        return a

    def boot(self):
        self.each(lambda r: r.board.boot())
        return self.step("boot")

    def run(self, us, step=50):
        self.each(lambda r: r.run(us, step))
        return self.step(f"run {us} us")

    def put(self, data):
        self.each(lambda r: r.link.put(data))
