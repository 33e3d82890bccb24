"""The board a test talks to, chosen by a parameter: either emulated core, or a real board.

Like pyserial's ``loop://`` suite, the board suite (``tests/test_board_suite.py``) is
written once against a port and run on every target of the ``board`` fixture (conftest):

- ``python``: the MicroPython firmware in the emulator;
- ``c``: the C core (``firmware/c``) in the emulator, behind the same ports;
- ``hardware``: the board on ``pytest --port /dev/ttyACM0`` (marked ``hardware``: skipped,
  with the reason, without ``--port``).

A test reaches the board through ``url`` (``sim://SCENE?core=..``, in process) or
``serve`` (a real pseudo-terminal, as ``tactile emulate`` serves it); on hardware both
give the real port and the scene is not used, so port-level tests stay agnostic.  What
only an emulator can do (a scripted load, injected faults, an unplug) is asked for with
``emulated_only``, which skips on hardware with the reason.
"""

import contextlib
import threading
import time

import pytest

from tactile.board_client import BoardClient
from tactile.serial_port import open_port
from tactile.stream_decoder import StreamDecoder

EMULATED = ("python", "c")
TARGETS = (*EMULATED, pytest.param("hardware", marks=pytest.mark.hardware))
NO_PORT = "needs a real board: run pytest --port /dev/ttyACM0 (or the board's port)"


class BoardTarget:
    """One target; ``core`` is the emulated core's name, None on hardware."""

    def __init__(self, kind, port=None):
        self.kind = kind
        self.port = port
        self.core = kind if kind in EMULATED else None

    @property
    def emulated(self):
        return self.core is not None

    def __repr__(self):
        return f"BoardTarget({self.kind!r})"

    def emulated_only(self, why):
        """Skip on hardware: ``why`` names what only the emulator can script."""
        if not self.emulated:
            pytest.skip(f"emulator only: {why}")

    def url(self, scene="press", **options):
        """The in-process emulator of ``scene`` on this core, or the real port."""
        if not self.emulated:
            return self.port
        query = "&".join(f"{k}={v}" for k, v in {"core": self.core, **options}.items())
        return f"sim://{scene}?{query}"

    def client(self, scene="press", timeout=2.0, **options):
        """A ``BoardClient`` on ``url(scene)`` after its handshake (HELLO or INFO)."""
        name = self.url(scene, **options)
        client = BoardClient(open_port(name), name)
        try:
            client.handshake(timeout)
        except BaseException:
            client.close()
            raise
        return client

    @contextlib.contextmanager
    def serve(self, scene="press", realtime=True, link_path=None, disconnects=(), duration_s=None):
        """A device path: the emulator serving ``scene`` on a pty (in a thread), or the port.

        ``scene``: a shipped name, a path or a loaded ``Scene``; ``duration_s``: simulated
        seconds served (``serving()`` turns false after them), else until the block ends.
        """
        if not self.emulated:
            yield self.port
            return
        from tactile_sim.emulator import load_scene
        from tactile_sim.emulator.device import EmulatedBoard
        from tactile_sim.emulator.pty_server import PtyServer

        loaded = load_scene(scene) if isinstance(scene, str) else scene
        server = PtyServer(
            EmulatedBoard(loaded, core=self.core),
            link_path=link_path,
            realtime=realtime,
            disconnects=disconnects,
        )
        path = server.open()
        thread = threading.Thread(target=server.serve, args=(duration_s,), daemon=True)
        thread.start()
        self.server, self._thread = server, thread
        try:
            yield path
        finally:
            server.stop = True
            thread.join(5)
            server.close()

    def serving(self):
        """Whether the emulator of ``serve`` still runs (a real board always does)."""
        return not self.emulated or self._thread.is_alive()


def read_for(client, seconds, until=None):
    """Messages read for ``seconds`` (or until ``until(messages)`` holds)."""
    out, end = [], time.monotonic() + seconds
    while time.monotonic() < end:
        out += client.read()
        if until is not None and until(out):
            break
    return out


def run_emulated(url, seconds):
    """Read the in-process emulator at ``url`` (``sim://...``) until its board clock passes
    ``seconds``: (port, decoded messages, decoder counters)."""
    import serial

    port = serial.serial_for_url(url, timeout=0.01)
    decoder = StreamDecoder()
    msgs = []
    while port.emulator.t_us < seconds * 1e6:
        msgs += decoder.feed(port.read(8192))
    return port, msgs, decoder.counters
