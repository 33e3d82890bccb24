"""One emulator server: a board's core behind a pseudo-terminal, which a host opens as a port.

``Server`` does, once for every core, all that lies between the core and its host:

- **the endpoint** (``pty_endpoint``) and the stable ``--link`` to it (``pty_link``);
- **host presence:** a host is announced once it has had the port open for
  ``OPEN_SETTLE_S`` (pyserial flushes its input at the end of ``open()``: a HELLO written
  the instant the port opens would be discarded); only then does it read and write; that
  flush, heard on the pty, also tells a host that closed and opened the port again before
  the server looked (``PtyEndpoint.opens``): a new host;
- **keep and drop:** what the board sends goes nowhere while no host is announced (as on
  USB), unless the core keeps it for one to come (``keeps_for_absent_host``); what waits
  for the host beyond ``KEEP_BYTES`` is dropped and counted (``dropped``);
- **hold:** as fast as possible, the board's time waits for a host that is absent or not
  reading (``wants_hold``), in a run with an end at most ``HOLD_LIMIT_S`` in a row, so a run
  always ends at its duration;
- **drain:** at the end of a fast run, the host reads what is in flight before the run ends;
  one that takes nothing for ``HOLD_LIMIT_S`` is given up on;
- **the scene's start:** the scene plays from the board's start (``when_opened``: from the
  first host's open); with ``replay``, each later host session (not the return of the
  server's own unplugged port) plays it again from its start, the board running on with
  its settings and clock.  ``on_scene(t_us)`` hears the board's clock (its frames' stamps)
  at each start, before the host's first byte of that session reaches the board: the
  emulator writes the robot's log for the new run there;
- **open, close** and the thread that serves.

A core supplies only ``step(held)`` (let the board run a little, not while ``held``; False
once it has ended), ``read()`` (the bytes it sent its host since the last call) and
``write(data)`` (bytes from the host): a template method, as python-can's ``BusABC.recv``
over each backend's ``_recv_internal``.  It may refine ``t_us``, ``idle_s``, ``wants_hold``
and the hooks ``prepare``, ``start``, ``opened``, ``finish``, ``check`` and ``halt``.

One way to start a server: ``with server:`` serves in a thread until the block ends, then
stops, joins and closes it and raises what the run raised (``servers.serve(scene, core=...)``
builds the board and its core's server; docs/emulator.md).
"""

import threading
import time

from tactile_sim.emulator import pty_link
from tactile_sim.emulator.pty_endpoint import PtyEndpoint

OPEN_SETTLE_S = 0.05  # wait this long after the host opens before announcing
DRAINED_S = 0.1  # ... the host has read all once the pty's input queue stays empty this long
HOLD_LIMIT_S = 3.0  # as fast as possible: hold for an absent or stalled host at most this long
HOLD_BYTES = 4096  # bytes waiting for the host beyond which a fast board's time holds
KEEP_BYTES = 1 << 20  # bytes kept for a host that does not read (then dropped, counted)
WAIT_FOR_HOST_S = 0.01  # ``when_opened``: look for a host this often
JOIN_S = 10.0  # leaving the block: the serving thread ends within this


class HoldLimit:
    """As fast as possible: ``limit(want)`` says whether time may hold for the host now, for
    at most ``HOLD_LIMIT_S`` in a row (``want`` false ends a hold).  Only a run with an end
    (``bounded``) needs the limit: without one, holding for a host costs nothing."""

    def __init__(self, clock=time.monotonic, limit_s=HOLD_LIMIT_S):
        self.clock, self.since, self.bounded, self.limit_s = clock, None, True, limit_s

    def __call__(self, want):
        if not want:
            self.since = None
            return False
        now = self.clock()
        if self.since is None:
            self.since = now
        return not self.bounded or now - self.since < self.limit_s


class Stalled:
    """A host that takes nothing: ``stalled(state)`` turns true once ``state`` (what waits
    for the host) has not changed for ``limit_s``."""

    def __init__(self, clock=time.monotonic, limit_s=HOLD_LIMIT_S):
        self.clock, self.last, self.moved, self.limit_s = clock, None, clock(), limit_s

    def __call__(self, state):
        if state != self.last:
            self.last, self.moved = state, self.clock()
        return self.clock() - self.moved >= self.limit_s


class Server:
    """Serve ``board`` (an ``EmulatedBoard``) on a pty; see the module docstring.

    ``realtime``: on the wall clock (may change while serving), else as fast as possible;
    ``faults``: the scene's ``LinkFaults`` on what the board sends; ``disconnects``: the
    scene's unplugged windows (s), for a core that serves them (``SERVES_DISCONNECTS``);
    ``duration_s``: the board's time served (None: until stopped), counted whether or not a
    host came; ``when_opened``: start the board once a host has the port open (in a run
    with a duration, at most ``HOLD_LIMIT_S`` after serving began: no host, the run starts
    without one); ``replay``: each new host session plays the scene from its start;
    ``on_scene(t_us)``: told the board's clock at each start of the scene; ``clock``: the
    wall clock (tests inject); ``hold_limit_s``: how long a hold or a drain waits for a host
    that takes nothing (``HOLD_LIMIT_S``; a test whose in-process host a loaded machine can
    stall for seconds gives it longer).
    """

    SERVES_DISCONNECTS = False

    def __init__(self, board, link_path=None, realtime=True, faults=None, disconnects=(),
                 duration_s=None, when_opened=False, replay=False, on_scene=None,
                 clock=None, hold_limit_s=HOLD_LIMIT_S):  # fmt: skip
        if disconnects and not self.SERVES_DISCONNECTS:
            raise ValueError(f"{type(self).__name__} serves no [link] disconnect windows")
        self.board, self.link_path, self.realtime, self.faults = board, link_path, realtime, faults
        self.disconnects = sorted((int(a * 1e6), int(b * 1e6)) for a, b in disconnects)
        self.duration_s, self.when_opened = duration_s, when_opened
        self.replay, self.on_scene = replay, on_scene
        self.replays = 0  # host sessions that played the scene again
        self._sessions = 0  # host sessions announced
        self._replugged = False  # the next announce is the server's own port coming back
        self._scene_at = 0  # the board's clock at the scene's start, as last told on_scene
        self.clock = clock or time.monotonic
        self.endpoint = None
        self.to_host = bytearray()  # what waits for the host
        self.dropped = 0  # bytes for a host that did not read, beyond KEEP_BYTES
        self.stop = False
        self.draining = False  # the run is over: the host reads what is in flight
        self.readable = False  # host input waited at the last look
        self.end_us = None
        self.error = None  # what the serving thread raised
        self._present_since = None
        self._opens = 0  # the endpoint's host opens (flushes) seen
        self.hold_limit_s = hold_limit_s
        self._limit = HoldLimit(self.clock, hold_limit_s)
        self._thread = None

    # --- what a core supplies ---------------------------------------------------------------
    def step(self, held):
        """Let the board run a little (its time not at all while ``held``); False once it
        has ended."""
        raise NotImplementedError

    def read(self):
        """The bytes the board sent its host since the last call."""
        raise NotImplementedError

    def write(self, data):
        """Bytes from the host, to the board."""
        raise NotImplementedError

    @property
    def t_us(self):
        """The board's time, which ``duration_s`` bounds."""
        return self.board.t_us

    @property
    def keeps_for_absent_host(self):
        """Whether what the board sends while no host is there waits for one."""
        return False

    def wants_hold(self):
        """Whether the board's time should wait for the host now (before ``HoldLimit``)."""
        return not self.realtime and len(self.to_host) > HOLD_BYTES

    def idle_s(self):
        """How long to wait for host input before the next step."""
        return 0.0

    def prepare(self):
        """Build or power what the core needs, or refuse, before the port is offered."""

    def start(self):
        """The run begins (after ``when_opened``'s wait)."""

    def opened(self):
        """A host has just been announced."""

    def finish(self):
        """The run reached its end with the board still running."""

    def check(self):
        """After the run: raise what ended the board, if it failed."""

    def halt(self):
        """Stop what the core started (idempotent)."""

    def scene_at_us(self):
        """The board's clock (its frames' stamps) at the scene's latest start."""
        return getattr(self.board, "scene_start_us", 0)  # (0: a stand-in without a scene)

    def models_us(self):
        """The simulated sensors' clock now (where a replayed scene starts)."""
        return self.board.t_us

    # --- the scene's start ------------------------------------------------------------------
    def _new_session(self):
        """A host has just been announced: with ``replay``, a new session (not the first,
        nor the server's own port coming back) plays the scene from its start."""
        self._sessions += 1
        replug, self._replugged = self._replugged, False
        if self.replay and self._sessions > 1 and not replug:
            self.board.restart_scene(self.models_us())
            self.replays += 1
        self._tell_scene()

    def _tell_scene(self):
        """``on_scene`` hears of a new start of the scene (by the board's clock)."""
        at = self.scene_at_us()
        if at != self._scene_at:
            self._scene_at = at
            if self.on_scene is not None:
                self.on_scene(at)

    # --- the endpoint -----------------------------------------------------------------------
    @property
    def path(self):
        return self.link_path or self.endpoint.path

    def open(self):
        """Make the pty (and point ``link_path`` at it); its path.  A link refused leaves
        no pty behind."""
        endpoint = PtyEndpoint()
        if self.link_path:
            try:
                pty_link.point(self.link_path, endpoint.path)  # only over an emulator's link
            except BaseException:
                endpoint.close()
                raise
        self.endpoint, self._opens = endpoint, 0
        return self.path

    def close(self):
        self.halt()
        if self.endpoint is not None:
            self.endpoint.close()
        if self.link_path:
            pty_link.remove(self.link_path)

    # --- the run ----------------------------------------------------------------------------
    def serve(self):
        """Serve until ``stop``, ``duration_s`` of the board's time, or the board's end."""
        if self.endpoint is None:
            self.open()
        if self.when_opened and not self._wait_for_host():
            return
        self.start()
        self.end_us = None if self.duration_s is None else int(self.duration_s * 1e6)
        self._limit.bounded = self.end_us is not None  # (a run without an end may hold)
        try:
            running = True
            while running and not self.stop and not self._over():
                running = self._turn()
            if running:
                self.finish()
            if not self.realtime:
                self._let_host_read()  # the end of the run reaches the host too
            self.check()
        finally:
            self.halt()

    def _over(self):
        t_us = self.t_us  # (read every turn: a core may keep count of its time there)
        return self.end_us is not None and t_us >= self.end_us

    def _turn(self, held=None):
        """One exchange: the host, the board's step, its output; False once it has ended."""
        self._host(self.idle_s())
        if self.stop:  # told to stop by what the host sent (a board that dies at a command)
            return True  # or from outside: nothing more reaches the host
        if held is None:
            held = self._limit(self.wants_hold())
        running = self.step(held)
        self._tell_scene()  # (a core whose scene restarts by itself: a Pico's reset)
        self._pump()
        return running

    def _wait_for_host(self):
        """Until a host is announced (True), ``stop`` (False) or, in a run with a duration,
        ``HOLD_LIMIT_S`` without one (True: the run starts, and its duration counts)."""
        self._limit.bounded = self.duration_s is not None
        while not self.stop:
            self._host(WAIT_FOR_HOST_S)
            if self.endpoint.host_present or not self._limit(True):
                return True
        return False

    def _host(self, wait_s):
        """Look at the host, waiting up to ``wait_s`` for its input: its presence (announced
        after ``OPEN_SETTLE_S``) and, once announced, its bytes to the board."""
        ep = self.endpoint
        readable, present = ep.wait(wait_s)
        now = time.monotonic()
        if readable:
            ep.pump()  # (its flushes too: a host that opened the port again)
        if not present:
            self._present_since = None
        elif self._present_since is None or ep.opens != self._opens:
            if ep.opens != self._opens and ep.host_present:
                ep.host_present = False  # gone and back before we looked: a new host
            self._present_since, self._opens = now, ep.opens
        announced = present and now - self._present_since >= OPEN_SETTLE_S
        if not announced and not self.keeps_for_absent_host:
            self.to_host.clear()  # nobody is listening: the first thing a host sees is new
        if announced and not ep.host_present:
            self._new_session()  # (before the host's first byte reaches the board)
            self.opened()
        ep.host_present, self.readable = announced, readable
        if announced and ep.waiting:
            self.write(ep.read())

    def _pump(self):
        """What the board sent, through the scene's link faults, to the host: kept while one
        is there (or for one to come), beyond ``KEEP_BYTES`` dropped and counted."""
        ep = self.endpoint
        data = self.read()
        if data and self.faults is not None:
            data = self.faults.apply(data)
        if data and (ep.host_present or self.keeps_for_absent_host):
            if len(self.to_host) < KEEP_BYTES:
                self.to_host += data
            else:
                self.dropped += len(data)
        if self.to_host and ep.host_present:
            del self.to_host[: ep.write(self.to_host)]

    def _let_host_read(self):
        """As fast as possible: wait, the board's time held, while the host (if any) reads
        what is queued or in flight; give up on one that takes nothing for ``HOLD_LIMIT_S``."""
        empty_since, stalled = None, Stalled(self.clock, self.hold_limit_s)
        self.draining = True
        try:
            while self.endpoint.host_present and not self.stop:
                if not self._turn(held=True):
                    return
                state = (len(self.to_host), self.endpoint.unread())
                if stalled(state):
                    return
                if any(state):
                    empty_since = None
                elif empty_since is None:
                    empty_since = time.monotonic()
                elif time.monotonic() - empty_since >= DRAINED_S:
                    # (the input queue can read empty while the pty's buffer still holds more,
                    # until the kernel moves it along: far less than DRAINED_S)
                    return
        finally:
            self.draining = False

    # --- one way to start -------------------------------------------------------------------
    def __enter__(self):
        try:
            self.prepare()
            if self.endpoint is None:
                self.open()
        except BaseException:
            self.close()
            raise
        self._thread = threading.Thread(target=self._run, name="emulator", daemon=True)
        self._thread.start()
        return self

    def _run(self):
        try:
            self.serve()
        except BaseException as exc:  # raised when the block ends
            self.error = exc

    def __exit__(self, kind, value, tb):
        self.stop = True
        if self._thread is not None:
            self._thread.join(JOIN_S)
        self.close()
        if self.error is not None and kind is None:
            raise self.error

    @property
    def serving(self):
        """Whether the run goes on (started and not yet at its end)."""
        return self._thread is not None and self._thread.is_alive()

    def wait(self, timeout_s=None):
        """Until the run ends (its duration, the board's end, ``stop``) or ``timeout_s``
        passes; True once it has ended."""
        self._thread.join(timeout_s)
        return not self._thread.is_alive()
