"""The board a test talks to, chosen by a parameter: either emulated core, or a real board.

Like pyserial's ``loop://`` suite, the board suite (``tests/test_board_suite.py``) is
written once against a port and run on every target of the ``board`` fixture (conftest):

- ``python``: the MicroPython firmware in the emulator;
- ``c``: the C core (``firmware/c``) in the emulator, behind the same ports;
- ``qemu``: the C core cross-compiled for a Cortex-M0, in QEMU, served on a pty;
- ``rp2040``: the firmware flashed onto an emulated Raspberry Pi Pico, served on a pty;
- ``hardware``: the board on ``pytest --port /dev/ttyACM0`` (marked ``hardware``: skipped,
  with the reason, without ``--port``).

``qemu`` and ``rp2040`` run their own clocks, so the suite meets them as it meets a real
board: one board per session behind a port (``Served``), at rest on the bench.

A test reaches the board through ``url`` (``sim://SCENE?core=..``, in process) or
``serve`` (a real pseudo-terminal, as ``tactile emulate`` serves it); on hardware both
give the real port and the scene is not used, so port-level tests stay agnostic.  What
only an emulator can do (a scripted load, injected faults, an unplug) is asked for with
``emulated_only``, which skips on hardware with the reason.
"""

import contextlib
import time

import pytest
from toolchain import missing

from tactile.board.client import BoardClient
from tactile.board.serial_port import open_port
from tactile.board.stream_decoder import StreamDecoder

EMULATED = ("python", "c")
SERVED = ("qemu", "rp2040")
TARGETS = (*EMULATED, *SERVED, pytest.param("hardware", marks=pytest.mark.hardware))
NO_PORT = "needs a real board: run pytest --port /dev/ttyACM0 (or the board's port)"


class BoardTarget:
    """One target; ``core`` is the emulated core's name, None on hardware."""

    def __init__(self, kind, port=None):
        self.kind = kind
        self.port = port
        self.core = kind if kind in EMULATED else None
        self.served = kind in SERVED

    @property
    def emulated(self):
        return self.core is not None

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
        from tactile_sim.emulator.servers import serve

        with serve(scene, core=self.core, link_path=link_path, realtime=realtime,
                   disconnects=disconnects, duration_s=duration_s) as server:  # fmt: skip
            self.server = server
            yield server.path

    def serving(self):
        """Whether the emulator of ``serve`` still runs (a real board always does)."""
        return not self.emulated or self.server.serving


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


class Served:
    """The session's boards that run their own clocks, each on a pty: started on first use,
    at rest, with the press scene's streams on (``configure``), stopped at the session's end."""

    def __init__(self, session_dir, flash_dir):
        self.session_dir, self.flash_dir = session_dir, flash_dir
        self.servers, self.stacks = {}, []

    def port(self, kind):
        if kind not in self.servers:
            stack = contextlib.ExitStack()
            self.stacks.append(stack)
            server = stack.enter_context(getattr(self, "_" + kind)())
            self.servers[kind] = server
            configure(server.path)
        return self.servers[kind].path

    @contextlib.contextmanager
    def _qemu(self):
        from tactile_sim.emulator.qemu_core import QemuUnavailable, image
        from tactile_sim.emulator.servers import serve

        try:
            image()
        except QemuUnavailable as exc:
            missing(str(exc))
        # -icount, QEMU started at once: the board at rest, as on the bench
        with serve(rest_scene(self.session_dir), core="qemu", realtime=False,
                   when_opened=False) as server:  # fmt: skip
            yield server

    @contextlib.contextmanager
    def _rp2040(self):
        import shutil

        from pico_target import flash_master, serve, wait_booted

        flash = self.session_dir / "suite.flash"
        shutil.copyfile(flash_master(self.flash_dir), flash)
        with serve(rest_scene(self.session_dir), flash=flash) as server:
            wait_booted(server)
            yield server

    def close(self):
        for stack in self.stacks:
            stack.close()


def rest_scene(folder):
    """The press scene with nothing pressing: a board at rest, as a real one on the bench (its
    sensor noise kept), so that every port-level test may TARE it."""
    import re

    from tactile_sim.emulator import load_scene

    text = load_scene("press").path.read_text()
    text = re.sub(r"keyframes = \[.*?\n\]", "keyframes = [[0.0, 0, 0, 0, 0, 0, 0], "
                  "[1.0, 0, 0, 0, 0, 0, 0]]", text, flags=re.S)  # fmt: skip
    path = folder / "rest.toml"
    path.write_text(text.replace('name = "press"', 'name = "rest"'))
    return path


def configure(path, timeout=30.0):
    """The press scene's settings on a served board (its own flash may say otherwise): 1 kHz
    or its ceiling, samples and contacts, streaming; nothing persisted."""
    from tactile_protocol import constants as C

    client = BoardClient(open_port(path), path)
    try:
        client.handshake(timeout)
        info = client.get_info(timeout)
        flags = C.CFG_STREAM_SAMPLES | C.CFG_STREAM_CONTACTS
        client.configure(min(1000, info.max_rate_hz), 1.39, 1.112, 3, flags)
        client.start()
    finally:
        client.close()
