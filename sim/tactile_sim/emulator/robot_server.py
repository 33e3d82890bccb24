"""The emulated arm: a ``tactile.robot.Robot`` in-process (``EmulatedArm``) or on TCP.

``EmulatedArm(scene, clock)`` drives a ``commanded`` scene's motion
(``motion_commanded.CommandedMotion``), the one the emulated board's sensor models read, so
what the arm does reaches the board's stream.  ``clock()`` is the board's clock (µs) when a
command arrives; ``wait(t_us)``, when given, returns once the board's clock has passed
``t_us``: a command's answer then comes after its motion has ended, so the stream already
holds its load (tests drive the clock themselves and pass no ``wait``).  ``pose_log``: the
robot's pose log, written again after each touch with a row for its hold.

``RobotServer(arm, host, port)`` serves the line protocol of ``tactile.robot``
(``docs/robot.md``) for ``tactile emulate SCENE --robot HOST:PORT``: one JSON object per
line each way, any number of clients, one command at a time.  Whatever a client sends, it
gets one line back and the server serves on: an unknown op, a bad or unreachable pose,
malformed JSON, non-finite numbers and a line over ``MAX_LINE_BYTES`` each get
``{"ok": false, "error": "..."}``; a client that vanishes, even mid-line, is let go and
the next one served.
"""

import json
import socket
import socketserver
import threading
import time

from tactile.robot import (
    MAX_LINE_BYTES,
    Pose,
    RobotError,
    Touch,
    WireError,
    pose_from_wire,
    pose_to_wire,
    touch_request,
    touch_to_wire,
)
from tactile_protocol.errors import InputError, TactileError
from tactile_sim.emulator.device import build_motion
from tactile_sim.emulator.scene import Scene

__all__ = ["EmulatedArm", "RobotServer", "board_waiter"]

STALL_S = 10.0  # the board's clock standing still this long: the answer is an error
POLL_S = 0.002  # how often a waiting command looks at the board's clock
OPS = ("move", "touch", "pose")


def board_waiter(board_us, stall_s=STALL_S, sleep=time.sleep, clock=time.monotonic):
    """``wait(t_us)`` for an arm beside a served board whose clock ``board_us()`` gives: poll
    until it passes t_us; a RobotError once it has not moved for ``stall_s`` (no host reads
    a fast emulator's port, or the run has ended)."""

    def wait(t_us):
        last, since = board_us(), clock()
        while last < t_us:
            sleep(POLL_S)
            now = board_us()
            if now != last:
                last, since = now, clock()
            elif clock() - since >= stall_s:
                why = f"the board's clock stopped at {last} us, before the motion ends at {t_us} us"
                raise RobotError(f"{why} (is a host reading the board's port?)")

    return wait


class EmulatedArm:
    """A ``Robot`` over a ``commanded`` scene (a ``Scene``, or the motion an
    ``EmulatedBoard`` built of one).  A pose it cannot take is a ``RobotError``."""

    def __init__(self, scene, clock=lambda: 0, wait=None, pose_log=None, at_us=0):
        if not isinstance(scene, Scene):
            self.motion = scene
        elif scene.motion["kind"] != "commanded":
            raise InputError(f"{scene.path}: [motion] kind: the arm needs kind = "
                             f"\"commanded\", got {scene.motion['kind']!r}")  # fmt: skip
        else:
            self.motion = build_motion(scene)
        self.clock, self.wait, self.pose_log, self.at_us = clock, wait, pose_log, at_us
        self.lock = threading.Lock()  # one command at a time, whoever asks

    def _now_s(self):
        return (self.clock() - self.at_us) * 1e-6

    def _done(self, end_s):
        """Return once the board's clock has passed the motion's end (with ``wait``)."""
        if self.wait is not None:
            self.wait(self.at_us + round(end_s * 1e6))

    def pose(self):
        p, q = self.motion.pose()
        return Pose(tuple(p.tolist()), tuple(q.tolist()))

    def move(self, pose):
        with self.lock:
            end = self.motion.move(pose.quaternion, pose.position_m, self._now_s())
            self._done(end)
            return self.pose()

    def touch(self, start, direction, max_force_N, max_travel_m):
        try:
            p, d, force, travel = touch_request(start, direction, max_force_N, max_travel_m)
        except WireError as exc:
            raise InputError(f"touch: {exc}") from None
        with self.lock:
            touched, moved, f, hold = self.motion.touch(p, d, force, travel, self._now_s())
            t_us = None
            if hold is not None:
                t_us = tuple(self.at_us + round(t * 1e6) for t in hold)
                if self.pose_log is not None:
                    self.motion.write_pose_log(self.pose_log, self.at_us)
            self._done(self.motion.end_s)
            return Touch(touched, self.pose(), moved, f, t_us)

    def close(self):
        """Nothing to let go: the arm lives as long as its scene."""


# --- the line protocol ------------------------------------------------------------------------


def _not_finite(name):
    raise WireError(f"non-finite number {name}: JSON numbers must be finite")


def answer(arm, line):
    """The answer (a dict) to one request line (bytes, its newline removed)."""
    try:
        request = json.loads(line, parse_constant=_not_finite)
    except WireError as exc:
        return _error(str(exc))
    except (ValueError, UnicodeDecodeError) as exc:
        return _error(f"malformed JSON: {' '.join(str(exc).split())}")
    if not isinstance(request, dict):
        return _error("malformed request: must be a JSON object with an op")
    op = request.get("op")
    if op not in OPS:
        return _error(f"unknown op {json.dumps(op)[:40]} (ops: {', '.join(OPS)})")
    try:
        if op == "pose":
            return {"ok": True, "pose": pose_to_wire(arm.pose())}
        if op == "move":
            return {"ok": True, "pose": pose_to_wire(arm.move(pose_from_wire(request.get("pose"))))}
        args = [request.get(k) for k in ("from", "direction", "max_force_N", "max_travel_m")]
        return {"ok": True, **touch_to_wire(arm.touch(*args))}
    except WireError as exc:
        return _error(f"{op}: {exc}")
    except TactileError as exc:
        return _error(str(exc))


def _error(why):
    return {"ok": False, "error": " ".join(why.split())[:300]}


class _Client(socketserver.StreamRequestHandler):
    """One client: a line in, a line out, until it goes."""

    def setup(self):
        super().setup()
        self.server.clients.add(self.connection)

    def finish(self):
        self.server.clients.discard(self.connection)
        super().finish()

    def handle(self):
        while True:
            try:
                raw = self.rfile.readline(MAX_LINE_BYTES + 1)
            except OSError:
                return  # (reset by the client)
            if not raw:
                return
            if raw.endswith(b"\n"):
                reply = self._answer(raw.rstrip(b"\r\n"))
            elif len(raw) > MAX_LINE_BYTES:
                if not self._skip_line():
                    return
                reply = _error(f"line longer than {MAX_LINE_BYTES} bytes")
            else:
                return  # it went mid-line: nothing to do, nobody to tell
            try:
                self.wfile.write(json.dumps(reply, allow_nan=False).encode() + b"\n")
            except OSError:
                return

    def _answer(self, line):
        if not line.strip():
            return _error("malformed JSON: an empty line")
        try:
            return answer(self.server.arm, line)
        except Exception as exc:  # a fault of the emulator's own: say so, serve on
            return _error(f"emulator fault: {type(exc).__name__}: {exc}")

    def _skip_line(self):
        """Read past the rest of an oversize line; False if the client went meanwhile."""
        while True:
            try:
                rest = self.rfile.readline(MAX_LINE_BYTES + 1)
            except OSError:
                return False
            if not rest:
                return False
            if rest.endswith(b"\n"):
                return True


class _TCP(socketserver.ThreadingTCPServer):
    daemon_threads = True
    allow_reuse_address = True

    def __init__(self, address, handler, arm):
        self.arm, self.clients = arm, set()
        super().__init__(address, handler)

    def hang_up(self):
        """End every client's connection (the server is closing)."""
        for sock in list(self.clients):
            try:
                sock.shutdown(socket.SHUT_RDWR)
            except OSError:
                pass


class RobotServer:
    """The line protocol for ``arm`` on ``host:port`` (port 0: a free one, ``address``
    says which); a context manager that serves in a thread until the block ends."""

    def __init__(self, arm, host="127.0.0.1", port=0):
        try:
            self._tcp = _TCP((host, port), _Client, arm)
        except OSError as exc:
            raise InputError(f"--robot {host}:{port}: cannot listen there "
                             f"({exc.strerror or exc})") from None  # fmt: skip
        self._thread = None

    @property
    def address(self):
        host, port = self._tcp.server_address[:2]
        return f"{host}:{port}"

    def __enter__(self):
        self._thread = threading.Thread(target=self._tcp.serve_forever, name="robot",
                                        kwargs={"poll_interval": 0.05}, daemon=True)  # fmt: skip
        self._thread.start()
        return self

    def __exit__(self, *exc):
        self.close()

    def close(self):
        if self._thread is not None:
            self._tcp.shutdown()
            self._thread.join()
            self._thread = None
        self._tcp.hang_up()
        self._tcp.server_close()
