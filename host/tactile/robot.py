"""A robot arm the host commands: the ``Robot`` interface, its poses, and the line-protocol client.

A ``Robot`` carries the F/T sensor.  It moves only when told: ``move(pose)`` goes to a pose
without touching anything, ``touch(start, direction, max_force_N, max_travel_m)`` goes to
``start``, approaches along ``direction`` until the fingertip presses with ``max_force_N`` or
has travelled ``max_travel_m``, and then holds still, pressed, until the next command (the
host averages the board's stream meanwhile); ``pose()`` says where the sensor is.

Frames and units: positions in metres, in the world frame, of the sensor's origin; the
orientation a unit quaternion (w, x, y, z) taking sensor-frame vectors to the world frame.
Forces in newtons.  ``Touch.t_us`` is the board-clock window (µs) of the hold when the robot
knows the board's clock (the emulator does), otherwise None.

The wire (``docs/robot.md``): one JSON object per line each way, over TCP.  Requests
``{"op": "move", "pose": {"position_m": [x, y, z], "quaternion": [w, x, y, z]}}``,
``{"op": "touch", "from": [x, y, z], "direction": [dx, dy, dz], "max_force_N": f,
"max_travel_m": d}`` and ``{"op": "pose"}``; answers ``{"ok": true, ...}`` or
``{"ok": false, "error": "one line"}``.  ``RobotClient`` speaks it; the emulated arm
(``tactile_sim.emulator.robot_server``) serves it and a real arm's adapter would too.
"""

import dataclasses
import json
import math
import socket
import typing

from tactile.errors import BoardError, BoardTimeout, InputError

__all__ = ["MAX_LINE_BYTES", "Pose", "Robot", "RobotClient", "RobotError", "Touch",
           "WireError", "parse_address", "pose_from_wire", "pose_to_wire", "read_line",
           "touch_from_wire", "touch_request", "touch_to_wire"]  # fmt: skip

MAX_LINE_BYTES = 64 * 1024  # one request or answer; a pose is ~100 bytes
UNIT_TOLERANCE = 1e-6  # |q| must be 1 within this; the quaternion is then renormalised


class RobotError(BoardError):
    """The robot refused a command, answered nonsense, or could not be reached (exit 4)."""


class WireError(InputError):
    """A value of the robot protocol that is not what it must be: a bad ``Pose`` or touch
    argument is bad input (exit 2); the client turns a bad answer into a RobotError."""


@dataclasses.dataclass(frozen=True)
class Pose:
    """The sensor's pose: ``position_m`` (x, y, z) of its origin in the world, and
    ``quaternion`` (w, x, y, z), world from sensor, of unit length."""

    position_m: tuple
    quaternion: tuple = (1.0, 0.0, 0.0, 0.0)

    def __post_init__(self):
        p = _vector(self.position_m, 3, "position_m")
        q = _vector(self.quaternion, 4, "quaternion")
        norm = math.sqrt(sum(v * v for v in q))
        if abs(norm - 1.0) > UNIT_TOLERANCE:
            raise WireError(f"quaternion: must have unit length, got |q| = {norm:.9g}")
        object.__setattr__(self, "position_m", p)
        object.__setattr__(self, "quaternion", tuple(v / norm for v in q))


@dataclasses.dataclass(frozen=True)
class Touch:
    """What a touch found: ``touched``, the ``pose`` it stopped at, the distance travelled
    along the direction (m), the force reached (N; the commanded one, or 0 without contact),
    and the board-clock window of the hold (µs, or None when the robot does not know it)."""

    touched: bool
    pose: Pose
    travel_m: float
    force_N: float
    t_us: tuple | None = None


class Robot(typing.Protocol):
    """What ``tactile explore`` needs of an arm; ``RobotClient`` and the emulated arm have it."""

    def move(self, pose: Pose) -> Pose: ...

    def touch(self, start, direction, max_force_N: float, max_travel_m: float) -> Touch: ...

    def pose(self) -> Pose: ...

    def close(self) -> None: ...


def _vector(values, n, field):
    """A tuple of ``n`` finite floats, or a WireError naming ``field``."""
    if isinstance(values, (str, bytes, dict)) or not hasattr(values, "__len__"):
        raise WireError(f"{field}: must be a list of {n} numbers")
    if len(values) != n:
        raise WireError(f"{field}: must be a list of {n} numbers, got {len(values)}")
    out = []
    for i, v in enumerate(values):
        out.append(_number(v, f"{field}[{i}]"))
    return tuple(out)


def _number(v, field):
    if isinstance(v, bool) or not isinstance(v, (int, float)) and not hasattr(v, "__float__"):
        raise WireError(f"{field}: must be a number, got {type(v).__name__}")
    v = float(v)
    if not math.isfinite(v):
        raise WireError(f"{field}: must be finite, got {v}")
    return v


def _positive(v, field):
    v = _number(v, field)
    if v <= 0:
        raise WireError(f"{field}: must be > 0, got {v:g}")
    return v


def pose_to_wire(pose):
    return {"position_m": list(pose.position_m), "quaternion": list(pose.quaternion)}


def pose_from_wire(obj, field="pose"):
    """A Pose from its JSON object, or a WireError naming the field."""
    if not isinstance(obj, dict):
        raise WireError(f"{field}: must be an object with position_m and quaternion")
    for key in ("position_m", "quaternion"):
        if key not in obj:
            raise WireError(f"{field}: missing {key}")
    try:
        return Pose(obj["position_m"], obj["quaternion"])
    except WireError as exc:
        raise WireError(f"{field}.{exc}") from None


def touch_request(start, direction, max_force_N, max_travel_m):
    """The touch request's fields, validated: (start (3,), unit direction (3,), force, travel)."""
    p = _vector(start, 3, "from")
    d = _vector(direction, 3, "direction")
    norm = math.sqrt(sum(v * v for v in d))
    if norm < 1e-9:
        raise WireError("direction: must not be zero")
    d = tuple(v / norm for v in d)
    return p, d, _positive(max_force_N, "max_force_N"), _positive(max_travel_m, "max_travel_m")


def touch_to_wire(touch):
    t = None if touch.t_us is None else [int(touch.t_us[0]), int(touch.t_us[1])]
    return {
        "touched": bool(touch.touched),
        "pose": pose_to_wire(touch.pose),
        "travel_m": float(touch.travel_m),
        "force_N": float(touch.force_N),
        "t_us": t,
    }


def touch_from_wire(obj):
    """A Touch from a touch answer, or a WireError naming the field."""
    touched = obj.get("touched")
    if not isinstance(touched, bool):
        raise WireError("touched: must be true or false")
    pose = pose_from_wire(obj.get("pose"))
    travel = _number(obj.get("travel_m"), "travel_m")
    force = _number(obj.get("force_N"), "force_N")
    if travel < 0 or force < 0:
        raise WireError(f"travel_m and force_N: must be >= 0, got {travel:g} m, {force:g} N")
    t = obj.get("t_us")
    if t is not None:
        ok = isinstance(t, list) and len(t) == 2
        ok = ok and all(isinstance(v, int) and not isinstance(v, bool) for v in t)
        if not ok or t[0] > t[1]:
            raise WireError("t_us: must be null or [t0, t1], whole microseconds, t0 <= t1")
        t = (t[0], t[1])
    return Touch(touched, pose, travel, force, t)


def read_line(stream, limit=MAX_LINE_BYTES):
    """One line from a binary ``stream`` (without its newline); b"" at the end of the stream.

    A line longer than ``limit`` raises WireError after its rest is skipped, so the next
    line is read from its start.
    """
    line = stream.readline(limit + 1)
    if len(line) > limit and not line.endswith(b"\n"):
        while True:  # skip to the end of the oversize line
            rest = stream.readline(limit + 1)
            if not rest or rest.endswith(b"\n"):
                break
        raise WireError(f"line longer than {limit} bytes")
    return line.rstrip(b"\r\n") if line else b""


def parse_address(text, field="--robot"):
    """``HOST:PORT`` -> (host, port); an InputError (exit 2) naming ``field`` otherwise."""
    host, sep, port = str(text).rpartition(":")
    host = host.strip("[]")
    if not sep or not host or not port.isdigit() or not 0 <= int(port) <= 65535:
        raise InputError(f"{field}: expected HOST:PORT (e.g. 127.0.0.1:5001), got {text!r}")
    return host, int(port)


class RobotClient:
    """A ``Robot`` over the JSON-lines protocol (``docs/robot.md``): one connection, one
    request at a time, each answer bounded (``MAX_LINE_BYTES``) and validated."""

    def __init__(self, address, timeout_s=30.0):
        self.host, self.port = parse_address(address) if isinstance(address, str) else address
        self.name = f"robot {self.host}:{self.port}"
        self.timeout_s = timeout_s
        try:
            self._sock = socket.create_connection((self.host, self.port), timeout=timeout_s)
        except TimeoutError:
            raise BoardTimeout(f"{self.name}: no connection within {timeout_s:g} s") from None
        except OSError as exc:
            why = f"cannot connect ({exc.strerror or exc})"
            hint = "is `tactile emulate SCENE --robot ADDRESS` running?"
            raise RobotError(f"{self.name}: {why}; {hint}") from None
        self._reader = self._sock.makefile("rb")

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()

    def close(self):
        if self._sock is not None:
            self._reader.close()
            self._sock.close()
            self._sock = None

    def move(self, pose):
        if not isinstance(pose, Pose):
            raise InputError(f"{self.name}: move needs a Pose, got {type(pose).__name__}")
        return self._pose_of(self._ask({"op": "move", "pose": pose_to_wire(pose)}))

    def pose(self):
        return self._pose_of(self._ask({"op": "pose"}))

    def touch(self, start, direction, max_force_N, max_travel_m):
        try:
            p, d, f, travel = touch_request(start, direction, max_force_N, max_travel_m)
        except WireError as exc:
            raise InputError(f"{self.name}: touch: {exc}") from None
        answer = self._ask({"op": "touch", "from": list(p), "direction": list(d),
                            "max_force_N": f, "max_travel_m": travel})  # fmt: skip
        try:
            return touch_from_wire(answer)
        except WireError as exc:
            raise RobotError(f"{self.name}: bad touch answer: {exc}") from None

    def _pose_of(self, answer):
        try:
            return pose_from_wire(answer.get("pose"))
        except WireError as exc:
            raise RobotError(f"{self.name}: bad answer: {exc}") from None

    def _ask(self, request):
        """Send one request and return its answer object (``ok`` true), or raise RobotError."""
        if self._sock is None:
            raise RobotError(f"{self.name}: the connection is closed")
        try:
            self._sock.sendall(json.dumps(request, allow_nan=False).encode() + b"\n")
            line = read_line(self._reader)
        except TimeoutError:  # (a late answer would be taken for the next one's: let go)
            self.close()
            raise BoardTimeout(f"{self.name}: no answer within {self.timeout_s:g} s") from None
        except WireError as exc:
            raise RobotError(f"{self.name}: {exc}") from None
        except OSError as exc:
            self.close()
            raise RobotError(f"{self.name}: connection lost ({exc.strerror or exc})") from None
        if not line:
            raise RobotError(f"{self.name}: the robot closed the connection")
        try:
            answer = json.loads(line, parse_constant=_no_constant)
        except (ValueError, UnicodeDecodeError):
            raise RobotError(f"{self.name}: answer is not JSON: {line[:60]!r}") from None
        if not isinstance(answer, dict) or not isinstance(answer.get("ok"), bool):
            raise RobotError(f'{self.name}: answer is not an object with "ok"')
        if not answer["ok"]:
            why = " ".join(str(answer.get("error", "refused")).split())[:200]
            raise RobotError(f"{self.name}: {why}")
        return answer


def _no_constant(name):
    raise ValueError(f"{name} is not a number JSON allows")
