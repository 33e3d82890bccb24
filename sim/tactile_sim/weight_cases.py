"""Cases for the benches of the tool's weight and the gauges' drift, drawn wider than the
shipped scenes, part of them held out (docs/scenes.md, "Cases for the weight and drift benches").

Case k (0 <= k < ``N_CASES``) is drawn from its own generator (``MASTER_SEED``, k), so it
never depends on how many cases are drawn, and belongs to one of four families in turn:

- ``identify``: a ``poses`` scene, an unloaded finger at an orientation set: ``spread9``
  (the nine of ``payload_poses``, the hand yawed at random), ``random`` (6-9 orientations
  drawn uniformly) or ``one_axis`` (the finger pointing down, spun about its own axis only:
  the weight's direction in the sensor frame stays on one cone, which determines nothing,
  and a bench must see it refused);
- ``ep1``: a ``roll`` on a sphere, a saddle or a cylinder at 1.5 or 5 N;
- ``ep2``: a three-finger ``sweep`` with ``wrist = "normal"`` over a sphere, a saddle or a
  cylinder, turned and tilted at random;
- ``turn``: a 50-100 g tool turned through 180 deg about a random horizontal axis, touching
  nothing (no contact may appear).

Each case draws a tool of 0-100 g (one in ten weightless; the ``turn`` family 50-100 g), its
centre of mass (up to 30 mm out along the finger's axis, a few mm off it), a drift kind
(``DRIFTS``: none, linear up to 0.04 N/min, a walk, a temperature change of 1-5 degC, or all
three) and a scene seed.

Split: case k is ``held_out`` when the first byte of SHA-256("tactile weight case k") is
below ``HELD_OUT_BELOW`` (about a quarter), else ``bench``; it depends on k alone.
``cases("held_out")`` refuses unless ``final=True``: only the final bench looks at them.

Run: ``python -m tactile_sim.weight_cases bench DIR`` writes each case's scene (``NAME.toml``)
and ``cases.json`` (the truth per case); ``held_out DIR --final`` the held-out ones.
"""

import argparse
import hashlib
import json
import math
import pathlib
import sys
import warnings
from dataclasses import asdict, dataclass

import numpy as np
from scipy.spatial.transform import Rotation

from tactile.errors import InputError
from tactile.files.writing import atomic_write
from tactile.output.text import printable
from tactile_sim.emulator.ft_model import sensitivity_matrix

__all__ = ["DRIFTS", "FAMILIES", "N_CASES", "OBJECTS", "Case", "Sealed", "cases", "scene_toml",
           "split_of", "write_cases"]  # fmt: skip

N_CASES = 160
MASTER_SEED = 38_0038
HELD_OUT_BELOW = 64  # of 256: a quarter held out
FAMILIES = ("identify", "ep1", "ep2", "turn")
OBJECTS = ("sphere", "saddle", "cylinder")
DRIFTS = ("none", "linear", "walk", "temperature", "all")
ORIENTATION_SETS = ("spread9", "random", "one_axis")
SPREAD9 = (
    (0, 0, 0),
    (90, 0, 0),
    (180, 0, 0),
    (-90, 0, 0),
    (0, 90, 0),
    (0, -90, 0),
    (45, 45, 30),
    (135, -45, -60),
    (-120, 30, 90),
)  # fmt: skip (payload_poses)
NOISE = {"noise_force_N": [0.0556, 0.0556, 0.1112], "noise_torque_Nm": [0.00282] * 3}
RANGES = (50.0, 2.0)  # the scenes' default force and torque ranges (N, N*m)


class Sealed(ValueError):
    """The held-out cases asked for outside the final bench."""


@dataclass(frozen=True)
class Case:
    """One drawn scene: ``scene`` its TOML tables, ``truth`` what a bench compares with."""

    id: int
    name: str
    split: str
    family: str
    seed: int
    truth: dict
    scene: dict


def split_of(k):
    """``held_out`` or ``bench`` for case ``k``, by the rule of the module docstring."""
    digest = hashlib.sha256(f"tactile weight case {k}".encode()).digest()
    return "held_out" if digest[0] < HELD_OUT_BELOW else "bench"


def cases(split="bench", *, final=False, n=N_CASES):
    """The cases of ``split`` among the first ``n``; the held-out ones only when ``final``."""
    if split not in ("bench", "held_out"):
        raise ValueError(f"split must be bench or held_out, got {split!r}")
    if split == "held_out" and not final:
        raise Sealed("the held-out cases are for the final bench only (final=True, --final)")
    return [draw(k) for k in range(n) if split_of(k) == split]


def draw(k):
    """Case ``k``, from its own generator."""
    rng = np.random.default_rng([MASTER_SEED, k])
    family = FAMILIES[k % len(FAMILIES)]
    seed = int(rng.integers(0, 2**32))
    if family == "turn":
        mass = float(rng.uniform(0.05, 0.1))
    else:
        mass = 0.0 if rng.random() < 0.1 else float(rng.uniform(0.005, 0.1))
    com = [float(rng.uniform(0.0, 0.03)), *map(float, rng.normal(0.0, 0.003, 2))]
    scene, truth = BUILD[family](rng)
    drift = str(rng.choice(DRIFTS)) if family != "turn" else "none"
    sensor = {"bias_counts": 0.0, **NOISE, **_drift(rng, drift, truth.pop("duration_s"))}
    name = f"case{k:03d}_{family}"
    tables = {"scene": {"name": name, "seed": seed}, **scene.pop("_board"), "sensor": sensor,
              "tool": {"mass_kg": mass, "com_m": com}, "motion": scene}  # fmt: skip
    truth.update(mass_kg=mass, com_m=com, drift=drift)
    return Case(k, name, split_of(k), family, seed, truth, tables)


def _identify(rng):
    kind = str(rng.choice(ORIENTATION_SETS, p=(0.4, 0.45, 0.15)))
    if kind == "spread9":
        yaw = float(rng.uniform(-180.0, 180.0))
        rpy = [_rpy(Rotation.from_euler("z", yaw, degrees=True) * _rot(p)) for p in SPREAD9]
    elif kind == "random":
        turns = Rotation.random(int(rng.integers(6, 10)), random_state=rng)
        rpy = [_rpy(r) for r in turns]
    else:  # pointing down (pitch 90), spun about the finger's own axis
        spins = rng.uniform(-180.0, 180.0) + np.arange(int(rng.integers(6, 10))) * 40.0
        rpy = [_rpy(_rot((0, 90, 0)) * Rotation.from_euler("x", a, degrees=True)) for a in spins]
    board = {"board": {"rate_hz": 500, "streams": ["contacts", "samples"]}}
    motion = {"kind": "poses", "orientations_deg": rpy, "hold_s": 1.0, "move_s": 0.5}
    truth = {"orientations": kind, "orientations_deg": rpy, "object": None,
             "duration_s": 1.5 * len(rpy)}  # fmt: skip
    return {**motion, "_board": board}, truth


def _ep1(rng):
    obj = str(rng.choice(OBJECTS))
    radius = float(rng.uniform(0.015, 0.05))
    params = {"radius": radius} if obj != "saddle" else {"a": 0.5 / radius, "b": 0.5 / radius}
    force = float(rng.choice([1.5, 5.0]))
    enter = min(1.0, 0.4 * force)
    board = {"board": {"rate_hz": 1000, "streams": ["contacts"], "gate": "3d", "debounce": 3,
                       "enter_threshold_N": enter, "exit_threshold_N": 0.8 * enter}}  # fmt: skip
    motion = {"kind": "roll", "surface": obj, "surface_params": params, "finger_radius_m": 0.01,
              "sensor_offset_m": 0.05, "normal_force_N": force, "mu": float(rng.uniform(0, 0.3)),
              "dtheta_rad": float(rng.uniform(0.3, 0.5))}  # fmt: skip
    truth = {"object": obj, "radius_m": radius, "normal_force_N": force, "duration_s": 5.6}
    return {**motion, "_board": board}, truth


def _ep2(rng):
    obj = str(rng.choice(OBJECTS))
    radius = float(rng.uniform(0.04, 0.08))
    board = {
        "board": {
            "rate_hz": 500,
            "sensors": 3,
            "streams": ["contacts"],
            "gate": "xy",
            "enter_threshold_N": 1.39,
            "exit_threshold_N": 1.112,
            "debounce": 1,
        }
    }
    motion = {"kind": "sweep", "object": obj, "radius_m": radius, "wrist": "normal",
              "rotation_deg": float(rng.uniform(0.0, 180.0)),
              "tilt_deg": float(rng.uniform(-30.0, 30.0))}  # fmt: skip
    truth = {"object": obj, "radius_m": radius, "duration_s": 2.9}
    return {**motion, "_board": board}, truth


def _turn(rng):
    heading = float(rng.uniform(-180.0, 180.0))  # the horizontal axis turned about
    down = Rotation.from_euler("z", heading, degrees=True) * _rot((0, 90, 0))
    axis = Rotation.from_euler("z", heading, degrees=True).apply([0.0, 1.0, 0.0])
    rpy = [_rpy(Rotation.from_rotvec(-math.radians(a) * axis) * down) for a in range(0, 181, 30)]
    board = {
        "board": {
            "rate_hz": 500,
            "streams": ["contacts", "samples"],
            "gate": "3d",
            "enter_threshold_N": 1.0,
            "exit_threshold_N": 0.8,
            "debounce": 3,
        }
    }
    motion = {"kind": "poses", "orientations_deg": rpy, "hold_s": 0.5, "move_s": 1.0}
    truth = {"object": None, "orientations_deg": rpy, "duration_s": 9.5}
    return {**motion, "_board": board}, truth


BUILD = {"identify": _identify, "ep1": _ep1, "ep2": _ep2, "turn": _turn}


def _rot(rpy):
    return Rotation.from_euler("xyz", rpy, degrees=True)


def _rpy(r):
    """[roll, pitch, yaw] (deg) of a rotation, the convention of ``[motion] orientations_deg``
    (at pitch +-90 deg, roll and yaw share one turn: scipy puts it in roll, and says so)."""
    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", "Gimbal lock", UserWarning)
        return [float(a) for a in r.as_euler("xyz", degrees=True)]


def _drift(rng, kind, duration_s):
    """The ``[sensor]`` drift keys of a drift kind (counts, per gauge)."""
    out = {}
    if kind in ("linear", "all"):
        u = rng.normal(size=3)
        rate = rng.uniform(0.005, 0.04) / 60.0 * u / np.linalg.norm(u)  # N/s
        counts = sensitivity_matrix(*RANGES) @ np.concatenate([rate, np.zeros(3)])
        out["drift_counts_per_s"] = [round(float(c), 4) for c in counts]
    if kind in ("walk", "all"):
        out["bias_walk_counts_per_sqrt_s"] = float(rng.uniform(5.0, 40.0))
    if kind in ("temperature", "all"):
        rise = float(rng.uniform(1.0, 5.0))
        out["temperature_C"] = [[0.0, 25.0], [float(duration_s), 25.0 + rise]]
        out["bias_counts_per_C"] = [round(float(c), 3) for c in rng.normal(0.0, 30.0, 6)]
    return out


def scene_toml(case):
    """The case's scene as TOML text (tables of numbers, strings, lists and inline tables)."""
    lines = [f"# {case.name}: weight-and-drift case {case.id} ({case.split}, {case.family})"]
    for table, keys in case.scene.items():
        lines += ["", f"[{table}]"]
        lines += [f"{key} = {_toml(value)}" for key, value in keys.items()]
    return "\n".join(lines) + "\n"


def _toml(v):
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, str):
        return json.dumps(v)
    if isinstance(v, dict):
        return "{ " + ", ".join(f"{k} = {_toml(x)}" for k, x in v.items()) + " }"
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(_toml(x) for x in v) + "]"
    return repr(float(v)) if isinstance(v, float) else str(int(v))


def write_cases(directory, split="bench", *, final=False, n=N_CASES):
    """Each case's scene as ``directory/NAME.toml`` and their truth as ``cases.json``."""
    chosen = cases(split, final=final, n=n)
    directory = pathlib.Path(directory)
    directory.mkdir(parents=True, exist_ok=True)
    for case in chosen:
        with atomic_write(directory / f"{case.name}.toml", text=True) as fh:
            fh.write(scene_toml(case))
    manifest = [{k: v for k, v in asdict(c).items() if k != "scene"} for c in chosen]
    with atomic_write(directory / "cases.json", text=True) as fh:
        json.dump({"split": split, "cases": manifest}, fh, indent=1)
        fh.write("\n")
    return [directory / f"{c.name}.toml" for c in chosen]


def main(argv=None):
    ap = argparse.ArgumentParser(prog="python -m tactile_sim.weight_cases", description=__doc__
                                 .split("\n\n")[0])  # fmt: skip
    ap.add_argument("split", choices=("bench", "held_out"))
    ap.add_argument("directory")
    ap.add_argument("--final", action="store_true", help="the final bench: held-out cases too")
    args = ap.parse_args(argv)
    try:
        paths = write_cases(args.directory, args.split, final=args.final)
    except Sealed as exc:
        raise InputError(f"held_out: {exc}") from None
    print(printable(f"{len(paths)} {args.split} cases in {args.directory}"))
    return 0


if __name__ == "__main__":
    try:
        sys.exit(main())
    except InputError as exc:
        print(printable(f"weight_cases: error: {exc}"), file=sys.stderr)
        sys.exit(2)
