"""A board that dies on cue: the emulator on a pty whose pty closes for good once the host's
``at_command``-th command frame has reached the board: at once, or ``after_s`` seconds of the
board's time later (its own clock: on a loaded machine the wall clock would cut its stream
short), once the host has read what the board sent until then (on a loaded machine the pty's
buffer would otherwise lose a varying tail, and a test could not say what the host kept).

For the tests and reliability probes of what a host does when a board is unplugged in the
middle of a command or a stream: the host's open port then fails exactly as a real one does
(``in_waiting`` with EIO, ``read`` finding no data after select() said readable, ``write``
with EIO).  Started as every server is: ``with DyingBoard(...) as board: ... board.path``.

Its path is a link of its own in a private folder, not the pty's ``/dev/pts/N``: a dead
board's pty number is soon another emulator's, and a host waiting for the port to come back
must not find that one (tests run side by side).
"""

import shutil
import tempfile
from pathlib import Path

from tactile_sim.emulator import load_scene
from tactile_sim.emulator.device import EmulatedBoard
from tactile_sim.emulator.pty_server import PtyServer


class DyingBoard(PtyServer):
    """Serve ``scene`` in real time on a pty (``path``) until it dies, at most ``serve_s``."""

    def __init__(self, scene="press", at_command=1, after_s=0.0, serve_s=30.0):
        self._folder = Path(tempfile.mkdtemp(prefix="tactile-dying-"))
        super().__init__(EmulatedBoard(load_scene(scene)), self._folder / "board",
                         realtime=True, duration_s=serve_s)  # fmt: skip
        self.commands, self.at_command, self.after_s = 0, at_command, after_s
        self.dies_at_us = None  # the board's time it dies at, once the command came

    def write(self, data):
        super().write(data)
        self.commands += data.count(0)  # one delimiter per frame
        if self.commands >= self.at_command and self.dies_at_us is None:
            self.dies_at_us = self.board.t_us + int(self.after_s * 1e6)
            if not self.after_s:
                self.stop = True

    def tick(self):
        if self.dies_at_us is not None and self.board.t_us >= self.dies_at_us:
            self.end_us = self.dies_at_us  # the board sends nothing after this

    def serve(self):
        try:
            super().serve()
            if not self.stop:  # died on its clock: what it sent reaches the host first
                self._let_host_read()  # (bounded: a host that takes nothing is given up on)
        finally:
            self.close()  # the master closes: the host's port is dead

    def close(self):
        super().close()
        shutil.rmtree(self._folder, ignore_errors=True)
