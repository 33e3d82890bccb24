"""Scenes: TOML files naming the board, the sensor, the motion and the link faults.

Only the sections a scene names are built: the motion's module is imported
by kind (``MOTIONS``), a noiseless sensor gets no random generator, a scene
without ``[link]`` faults gets no fault injector.  Every error is a
``SceneError`` naming the file and the key.
"""

import pathlib
import tomllib

from tactile.errors import InputError

SCENE_DIR = pathlib.Path(__file__).resolve().parents[1] / "scenes"

# motion kind -> module exposing ``build(scene) -> Motion``: every ``motion_KIND.py`` here.
# Only the module a scene names is imported (device.build_motion).
MOTIONS = {
    p.stem.removeprefix("motion_"): f"tactile_sim.emulator.{p.stem}"
    for p in sorted(pathlib.Path(__file__).parent.glob("motion_*.py"))
}

BOARD_DEFAULTS = {
    "rate_hz": 1000,
    "autostart": True,
    "streams": ["contacts"],
    "gate": "xy",
    "enter_threshold_N": 1.39,
    "exit_threshold_N": 1.112,
    "debounce": 3,
    "sensors": 1,
    "max_rate_hz": 0,
}
SENSOR_DEFAULTS = {
    "model": "SIM-FT6",
    "force_range_N": 50.0,
    "torque_range_Nm": 2.0,
    "noise_force_N": [0.0, 0.0, 0.0],
    "noise_torque_Nm": [0.0, 0.0, 0.0],
    "bias_counts": 20000.0,
    "drift_counts_per_s": 0.0,
    "cal_id": 1,
}
LINK_DEFAULTS = {
    "corrupt_frames": [],
    "drop_byte_frames": [],
    "disconnect": [],
}


class SceneError(InputError):
    """A scene file that cannot be used; the message names file and key."""


class Scene:
    """A validated scene: plain dictionaries per section plus its path and seed."""

    def __init__(self, path, data):
        self.path = pathlib.Path(path)
        self.name = data.get("scene", {}).get("name", self.path.stem)
        self.seed = int(data.get("scene", {}).get("seed", 0))
        self.duration_s = float(data.get("scene", {}).get("duration_s", 10.0))
        self.board = _section(path, data, "board", BOARD_DEFAULTS)
        self.sensor = _section(path, data, "sensor", SENSOR_DEFAULTS)
        self.link = _section(path, data, "link", LINK_DEFAULTS) if "link" in data else None
        self.motion = data.get("motion")
        self.raw = data
        if not isinstance(self.motion, dict) or self.motion.get("kind") not in MOTIONS:
            kinds = ", ".join(MOTIONS)
            raise SceneError(f"{path}: [motion] kind must be one of {kinds}")

    def error(self, key, why):
        return SceneError(f"{self.path}: {key}: {why}")


def _section(path, data, name, defaults):
    given = data.get(name, {})
    unknown = sorted(set(given) - set(defaults))
    if unknown:
        raise SceneError(f"{path}: [{name}] unknown key(s): {', '.join(unknown)}")
    out = dict(defaults)
    for key, value in given.items():
        if type(value) is not type(defaults[key]) and not (
            isinstance(defaults[key], float) and isinstance(value, int)
        ):
            expect = type(defaults[key]).__name__
            raise SceneError(f"{path}: [{name}] {key}: expected {expect}, got {value!r}")
        out[key] = value
    return out


def resolve(name):
    """A scene path, or the name of a shipped scene (``press``, ``ch5_convex``)."""
    path = pathlib.Path(name)
    if path.exists():
        return path
    shipped = SCENE_DIR / f"{name}.toml"
    if shipped.exists():
        return shipped
    names = ", ".join(sorted(p.stem for p in SCENE_DIR.glob("*.toml")))
    raise SceneError(f"{name}: no such scene file (shipped scenes: {names})")


def load_scene(name):
    path = resolve(name)
    try:
        data = tomllib.loads(path.read_text(encoding="utf-8"))
    except tomllib.TOMLDecodeError as exc:
        raise SceneError(f"{path}: {exc}") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise SceneError(f"{path}: cannot read: {exc}") from None
    return Scene(path, data)
