"""A board that dies on cue: the emulator on a pty whose pty closes for good once the host's
``at_command``-th command frame has reached the board, ``after_s`` seconds of the board's
time later (its own clock: on a loaded machine the wall clock would cut its stream short).

For the tests and reliability probes of what a host does when a board is unplugged in the
middle of a command or a stream (issue 12): the host's open port then fails exactly as a
real one does (``in_waiting`` with EIO, ``read`` finding no data after select() said
readable, ``write`` with EIO).
"""

import threading

from tactile_sim.emulator import load_scene
from tactile_sim.emulator.device import EmulatedBoard
from tactile_sim.emulator.pty_server import PtyServer


class DyingBoard:
    """Serve ``scene`` in real time on a pty (``path``) until it dies; ``join()`` ends it."""

    def __init__(self, scene="press", at_command=1, after_s=0.0, serve_s=30.0):
        self.server = PtyServer(EmulatedBoard(load_scene(scene)), realtime=True)
        self.path = self.server.open()
        self.commands, self.at_command, self.after_s = 0, at_command, after_s
        self.dies_at_us = None  # the board's time it dies at, once the command came
        board = self.server.board
        deliver = board.write_host

        def write_host(data):
            deliver(data)
            self.commands += data.count(0)  # one delimiter per frame
            if self.commands >= self.at_command and self.dies_at_us is None:
                self.dies_at_us = board.t_us + int(self.after_s * 1e6)
                if not self.after_s:
                    self.server.stop = True

        board.write_host = write_host
        self.thread = threading.Thread(target=self._serve, args=(serve_s,), daemon=True)
        self.thread.start()

    def _tick(self, board):
        if self.dies_at_us is not None and board.t_us >= self.dies_at_us:
            self.server.stop = True

    def _serve(self, serve_s):
        try:
            self.server.serve(serve_s, on_tick=self._tick)
        finally:
            self.server.close()  # the master closes: the host's port is dead

    def join(self, timeout_s=5.0):
        self.server.stop = True
        self.thread.join(timeout_s)
