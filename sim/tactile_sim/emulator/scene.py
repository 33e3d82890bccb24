"""Scenes: TOML files naming the board, the sensor, the motion and the link faults.

``load_scene`` reads a file (bounded), parses it and validates the whole of it against
``scene_schema`` before anything is built.  Only the sections a scene names are built:
the motion's module is imported by kind (``MOTIONS``), a noiseless sensor gets no random
generator, a scene without ``[link]`` faults gets no fault injector.  Every error is a
one-line ``SceneError`` (exit 2) naming the file, section and key:
``scene.toml: [sensor] noise_force_N[2]: must be finite and >= 0, got nan``.
"""

import pathlib
import tomllib

from tactile.files import bounded
from tactile_protocol.errors import InputError
from tactile_sim.emulator import scene_schema
from tactile_sim.emulator.scene_schema import Bad

SCENE_DIR = pathlib.Path(__file__).resolve().parents[1] / "scenes"

# motion kind -> module exposing ``build(scene) -> Motion``: every ``motion_KIND.py`` here.
# Only the module a scene names is imported (device.build_motion).
MOTIONS = {
    p.stem.removeprefix("motion_"): f"tactile_sim.emulator.{p.stem}"
    for p in sorted(pathlib.Path(__file__).parent.glob("motion_*.py"))
}

MAX_SCENE_BYTES = 1 << 20  # a scene is a page of TOML; /dev/zero is not one


class SceneError(InputError):
    """A scene file that cannot be used; the message names file and key."""


class Scene:
    """A validated scene: each section's values (defaults filled), its path, name and seed.

    ``board``, ``sensor``, ``tool``, ``world``, ``motion`` (with ``kind``) and ``link`` (None
    without ``[link]``) are dictionaries, ``sensor_faults`` a list of them: ``scene_schema``
    has checked every key, so the modules that build the emulator read them as they are.
    """

    def __init__(self, path, data):
        self.path = pathlib.Path(path)
        try:
            values = scene_schema.validate(data)
        except Bad as bad:
            raise SceneError(f"{path}: {bad.where}: {bad.why}") from None
        self.name = values["scene"]["name"] or self.path.stem
        self.seed = values["scene"]["seed"]
        self.duration_s = values["scene"]["duration_s"]
        self.board = values["board"]
        self.sensor = values["sensor"]
        self.tool = values["tool"]
        self.world = values["world"]
        self.motion = values["motion"]
        self.link = values["link"]
        self.sensor_faults = values["sensor_fault"]
        self.raw = data

    def error(self, key, why):
        """A SceneError for what only building can find (``key``: ``[motion] surface``)."""
        return SceneError(f"{self.path}: {key}: {why}")


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
    """The scene ``name`` (a path or a shipped name), read and validated; or a SceneError."""
    path = resolve(name)
    try:  # a directory, /dev/zero or a FIFO (which would block the read) is refused
        raw = bounded.read_bytes(path, MAX_SCENE_BYTES, "a scene", "a scene is a page of TOML")
    except InputError as exc:
        raise SceneError(str(exc)) from None
    try:
        data = tomllib.loads(raw.decode("utf-8"))
    except UnicodeDecodeError as exc:
        line = raw[: exc.start].count(b"\n") + 1
        raise SceneError(f"{path}:{line}: not UTF-8 text ({exc.reason})") from None
    except tomllib.TOMLDecodeError as exc:
        raise SceneError(f"{path}: {exc}") from None
    except RecursionError:  # arrays or tables nested deeper than Python recurses
        raise SceneError(f"{path}: nested too deeply to be a scene") from None
    return Scene(path, data)
