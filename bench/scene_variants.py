"""Malformed scene files, one per kind of mistake (issue 12), and the one line each must give.

The table is shared: ``tests/test_scene_schema.py`` runs every variant through the CLI and
asserts exit 2 and the message, and ``bench/reliability_scenes.py`` turns the same runs into
the Scenes table of docs/reliability.md.  A variant edits a shipped scene (parsed, changed,
written back as TOML by ``to_toml``) or gives the file's bytes outright; ``where`` is the
``[section] key`` its message must name (None for file-level errors) and ``says`` a piece
of what it must say.

Run: .venv/bin/python bench/scene_variants.py   (lists the variants and their messages)
"""

import contextlib
import datetime
import io
import math
import pathlib
import re
import tomllib
from dataclasses import dataclass

NAN, INF = math.nan, math.inf
SCENE_DIR = pathlib.Path(__file__).resolve().parents[1] / "sim" / "tactile_sim" / "scenes"


@dataclass(frozen=True)
class Variant:
    name: str  # what is wrong, for the table
    base: str = "press"  # the shipped scene edited
    edits: tuple = ()  # (("board.sensors", 0), ...): "section.key" or a top-level "name"
    where: str | None = None  # "[board] sensors"; None: a file-level error
    says: str = ""  # a piece of the message after "where: "
    raw: bytes | None = None  # the file's bytes instead of an edited scene
    line: int | None = None  # a file-level error's line, named as "scene.toml:3:"


def _v(name, base, edits, where, says):
    return Variant(name, base, tuple(edits.items()), where, says)


DROP = object()  # an edit's value: delete the key or section


P, RIG, SWEEP, ROLL = "press", "ch5_plane", "ep2_sweep_sphere", "ep1_roll"
ZERO = [0.0] * 6
FAULT = "sensor_fault"

# fmt: off
VARIANTS = (
    # [scene]
    _v('seed = "abc"', P, {"scene.seed": "abc"}, "[scene] seed", "must be an integer"),
    _v("seed = 1.5", P, {"scene.seed": 1.5}, "[scene] seed", "must be an integer"),
    _v("seed = -1", P, {"scene.seed": -1}, "[scene] seed", "must be from 0"),
    _v("seed = a date", P, {"scene.seed": datetime.date(2024, 5, 1)}, "[scene] seed", "a date"),
    _v("name = 5", P, {"scene.name": 5}, "[scene] name", "must be a string"),
    _v("name with escapes", P, {"scene.name": "\x1b[2J\n"}, "[scene] name", "printable ASCII"),
    _v("duration_s = -4", P, {"scene.duration_s": -4}, "[scene] duration_s", "finite, > 0"),
    _v("duration_s = nan", P, {"scene.duration_s": NAN}, "[scene] duration_s", "got nan"),
    # [board]
    _v('rate_hz = "fast"', P, {"board.rate_hz": "fast"}, "[board] rate_hz", "an integer"),
    _v("rate_hz = 1000.0", P, {"board.rate_hz": 1000.0}, "[board] rate_hz", "an integer"),
    _v("rate_hz = 0", P, {"board.rate_hz": 0}, "[board] rate_hz", "from 1 to 65535"),
    _v("rate_hz = 99999", P, {"board.rate_hz": 99999}, "[board] rate_hz", "from 1 to 65535"),
    _v("rate_hz over the ceiling", P, {"board.rate_hz": 5000}, "[board] rate_hz", "of 1 sensor"),
    _v("autostart = 1", P, {"board.autostart": 1}, "[board] autostart", "true or false"),
    _v('streams = "contacts"', P, {"board.streams": "contacts"}, "[board] streams", "a list"),
    _v('streams = ["video"]', P, {"board.streams": ["video"]}, "[board] streams[0]", "one of"),
    _v("streams repeated", P, {"board.streams": ["contacts"] * 2}, "[board] streams", "repeat"),
    _v('gate = "4d"', P, {"board.gate": "4d"}, "[board] gate", "must be one of xy, 3d"),
    _v("gate = 3", P, {"board.gate": 3}, "[board] gate", "must be one of xy, 3d, got 3"),
    _v("enter_threshold_N = -1", P, {"board.enter_threshold_N": -1},
       "[board] enter_threshold_N", ">= 0"),
    _v("enter_threshold_N = nan", P, {"board.enter_threshold_N": NAN},
       "[board] enter_threshold_N", "must be finite"),
    _v("enter_threshold_N = 1e9", P, {"board.enter_threshold_N": 1e9},
       "[board] enter_threshold_N", "<= 2147.48"),
    _v("exit above enter", P, {"board.exit_threshold_N": 2.0}, "[board] exit_threshold_N",
       "must be <= enter_threshold_N (1.39)"),
    _v("debounce = 0", P, {"board.debounce": 0}, "[board] debounce", "from 1 to 255"),
    _v("debounce = 256", P, {"board.debounce": 256}, "[board] debounce", "from 1 to 255"),
    _v("debounce = true", P, {"board.debounce": True}, "[board] debounce", "an integer, got true"),
    _v("sensors = 0", P, {"board.sensors": 0}, "[board] sensors", "from 1 to 4"),
    _v("sensors = 5", P, {"board.sensors": 5}, "[board] sensors", "from 1 to 4"),
    _v("sensors = 1000000", P, {"board.sensors": 1_000_000}, "[board] sensors", "from 1 to 4"),
    _v("sensors = a table", P, {"board.sensors": {"n": 2}}, "[board] sensors", "got a table"),
    _v("max_rate_hz = -5", P, {"board.max_rate_hz": -5}, "[board] max_rate_hz", "from 0"),
    _v("max_rate_hz = 70000", P, {"board.max_rate_hz": 70000}, "[board] max_rate_hz", "65535"),
    _v("max_rate_hz below rate_hz", P, {"board.max_rate_hz": 10}, "[board] rate_hz",
       "must be <= [board] max_rate_hz (10)"),
    _v("unknown key in [board]", P, {"board.rate": 500}, "[board] rate",
       "unknown key (did you mean rate_hz?)"),
    # [sensor]
    _v("force_range_N = -50", P, {"sensor.force_range_N": -50}, "[sensor] force_range_N",
       ">= 1e-06"),
    _v("force_range_N = 0", P, {"sensor.force_range_N": 0}, "[sensor] force_range_N", "got 0"),
    _v("force_range_N = inf", P, {"sensor.force_range_N": INF}, "[sensor] force_range_N", "inf"),
    _v("torque_range_Nm = a table", P, {"sensor.torque_range_Nm": {"a": 1}},
       "[sensor] torque_range_Nm", "must be a number, got a table"),
    _v("negative noise", P, {"sensor.noise_force_N": [-0.1, 0, 0]}, "[sensor] noise_force_N[0]",
       "must be finite, >= 0"),
    _v("NaN noise", P, {"sensor.noise_force_N": [0.05, NAN, 0.1]}, "[sensor] noise_force_N[1]",
       "must be finite, >= 0 and <= 2147.48, got nan"),
    _v("inf noise", P, {"sensor.noise_torque_Nm": [0, 0, INF]}, "[sensor] noise_torque_Nm[2]",
       "got inf"),
    _v("two noise values", P, {"sensor.noise_force_N": [0.1, 0.1]}, "[sensor] noise_force_N",
       "must be a list of 3"),
    _v("noise as one number", P, {"sensor.noise_force_N": 0.1}, "[sensor] noise_force_N",
       "must be a list of 3"),
    _v("noise as strings", P, {"sensor.noise_torque_Nm": ["a", "b", "c"]},
       "[sensor] noise_torque_Nm[0]", "must be a number"),
    _v("bias_counts = 1e300", P, {"sensor.bias_counts": 1e300}, "[sensor] bias_counts",
       "<= 8388608"),
    _v("three bias values", P, {"sensor.bias_counts": [1, 2, 3]}, "[sensor] bias_counts",
       "must be a list of 6"),
    _v("drift = nan", P, {"sensor.drift_counts_per_s": NAN}, "[sensor] drift_counts_per_s", "nan"),
    _v("cal_id = -1", P, {"sensor.cal_id": -1}, "[sensor] cal_id", "from 0 to 4294967295"),
    _v("cal_id = 2**32", P, {"sensor.cal_id": 2**32}, "[sensor] cal_id", "from 0 to 4294967295"),
    _v("model too long", P, {"sensor.model": "x" * 40}, "[sensor] model", "1 to 16"),
    # [motion]
    _v("no [motion]", P, {"motion": DROP}, "[motion]", "required, with kind"),
    _v("no kind", P, {"motion.kind": DROP}, "[motion] kind",
       "must be one of commanded, poses, press"),
    _v('kind = "teleport"', P, {"motion.kind": "teleport"}, "[motion] kind",
       "must be one of commanded, poses, press, rig, roll, sweep, got 'teleport'"),
    _v("[motion] = a number", P, {"motion": 3}, "[motion]", "must be a table"),
    _v("no keyframes", P, {"motion.keyframes": DROP}, "[motion] keyframes", "required"),
    _v("a short keyframe", P, {"motion.keyframes": [[0, 1]]}, "[motion] keyframes[0]",
       "must be a list of 7 numbers"),
    _v("keyframe times go back", P, {"motion.keyframes": [[0] + ZERO, [1] + ZERO, [0.5] + ZERO]},
       "[motion] keyframes[2]", "time must be after 1 s"),
    _v("a NaN in a keyframe", P, {"motion.keyframes": [[0, NAN] + ZERO[1:]]},
       "[motion] keyframes[0][1]", "got nan"),
    _v("a huge force in a keyframe", P, {"motion.keyframes": [[0, 1e300] + ZERO[1:]]},
       "[motion] keyframes[0][1]", "<= 2147.48"),
    _v('repeat = "yes"', P, {"motion.repeat": "yes"}, "[motion] repeat", "true or false"),
    _v("rig passes = 1000000", RIG, {"motion.passes": 1_000_000}, "[motion] passes", "1 to 10"),
    _v("rig points = 0", RIG, {"motion.points": 0}, "[motion] points", "from 1 to 50"),
    _v('rig object = "cube"', RIG, {"motion.object": "cube"}, "[motion] object",
       "must be one of plane, convex, concave"),
    _v("rig speed_mps = 0", RIG, {"motion.speed_mps": 0}, "[motion] speed_mps", ">= 0.001"),
    _v("rig probing too long", RIG,
       {"motion.passes": 2, "motion.points": 2, "motion.samples": 10, "motion.hold_s": 60},
       "[motion]", "the probing would take 2424040 samples"),
    _v("sweep fingers > sensors", SWEEP, {"motion.fingers": 4}, "[motion] fingers",
       "must be <= [board] sensors (3)"),
    _v("sweep samples = 1", SWEEP, {"motion.samples": 1}, "[motion] samples", "from 2 to 1000"),
    _v("sweep mu = -0.1", SWEEP, {"motion.mu": -0.1}, "[motion] mu", ">= 0"),
    _v("sweep settle_s too long", SWEEP, {"motion.settle_s": 0.5}, "[motion] settle_s",
       "shorter than the time per station (0.04 s)"),
    _v("sweep one roll angle", SWEEP, {"motion.roll_deg": [0]}, "[motion] roll_deg",
       "one angle per finger (3)"),
    _v("sweep unknown key", SWEEP, {"motion.speed": 1.0}, "[motion] speed",
       "unknown key for kind sweep (did you mean speed_mps?)"),
    _v("roll dtheta_rad = -0.5", ROLL, {"motion.dtheta_rad": -0.5}, "[motion] dtheta_rad", "> 0"),
    _v("roll off the fingertip", ROLL, {"motion.dtheta_rad": 2.0}, "[motion] dtheta_rad",
       "a roll stops early"),
    _v('roll surface = "blob"', ROLL, {"motion.surface": "blob"}, "[motion] surface", "one of"),
    _v("roll surface_params = 3", ROLL, {"motion.surface_params": 3}, "[motion] surface_params",
       "must be a table"),
    _v("roll surface_params nan", ROLL, {"motion.surface_params": {"a": NAN, "b": 1, "c": 1}},
       "[motion] surface_params.a", "got nan"),
    _v("roll on a 1e-247 m ellipsoid", ROLL,
       {"motion.surface_params": {"a": 0.02, "b": 0.03, "c": 1e-247}}, "[motion]",
       "the rolling simulation breaks down (divide by zero"),
    _v("roll surface_params d = 1", ROLL, {"motion.surface_params": {"a": 1, "d": 1}},
       "[motion] surface_params", "ellipsoid: ellipsoid() got an unexpected keyword"),
    _v("roll no directions", ROLL, {"motion.directions_deg": []}, "[motion] directions_deg",
       "must be a list of 1 to 16"),
    # unknown sections; tables and arrays in the wrong place
    _v("unknown section [boards]", P, {"boards.rate_hz": 500}, "[boards]",
       "unknown section (did you mean [board]?)"),
    _v("unknown section [extra]", P, {"extra.x": 1}, "[extra]", "unknown section (known: "),
    _v("a key outside any section", P, {"seed": 5}, "seed",
       "a key outside any section (put it under [scene])"),
    _v("[[board]]", P, {"board": [{"rate_hz": 500}]}, "[board]", "must be a table"),
    _v("[sensor_fault] not [[...]]", P, {FAULT: {"kind": "i2c_nack"}}, "[[sensor_fault]]",
       "must be tables"),
    _v('sensor_fault kind = "meltdown"', P, {FAULT: [{"kind": "meltdown"}]},
       "[[sensor_fault]] #1 kind", "must be one of i2c_timeout"),
    _v("sensor_fault with no kind", P, {FAULT: [{"at_s": 1.0}]}, "[[sensor_fault]] #1 kind",
       "required"),
    _v("sensor_fault at_s = -1", P,
       {FAULT: [{"kind": "i2c_nack"}, {"kind": "saturate", "at_s": -1}]},
       "[[sensor_fault]] #2 at_s", ">= 0"),
    _v("sensor_fault on sensor 2 of 1", P, {FAULT: [{"kind": "i2c_nack", "sensor": 2}]},
       "[[sensor_fault]] #1 sensor", "must be < [board] sensors (1)"),
    _v("corrupt_frames = [-1]", P, {"link.corrupt_frames": [-1]}, "[link] corrupt_frames[0]",
       "from 0"),
    _v('corrupt_frames = "all"', P, {"link.corrupt_frames": "all"}, "[link] corrupt_frames",
       "must be a list"),
    _v("a disconnect that ends first", P, {"link.disconnect": [[2.0, 1.0]]},
       "[link] disconnect[0]", "must end after it starts"),
    _v("a disconnect of one time", P, {"link.disconnect": [[1.0]]}, "[link] disconnect[0]",
       "must be a list of 2 numbers"),
    _v("unknown key in [link]", P, {"link.drop_frames": [3]}, "[link] drop_frames",
       "did you mean drop_byte_frames?"),
    # the file itself
    Variant("TOML syntax error", raw=b"[motion\n", says="(at line 1, column 8)"),
    Variant("duplicate key", raw=b"[board]\nrate_hz = 1\nrate_hz = 2\n", says="(at line 3"),
    Variant("not UTF-8", raw=b'[scene]\nname = "x"\n# \xff\n', line=3, says="not UTF-8 text"),
    Variant("an empty file", raw=b"", where="[motion]", says="required"),
    Variant("a 2 MB file", raw=b"#" * (2 << 20), says="larger than 1 MiB"),
)
# fmt: on


def _toml_key(key):
    return key if re.fullmatch(r"[A-Za-z0-9_-]+", key) else _toml_value(key)


def _toml_value(v):
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, float):
        if math.isnan(v):
            return "nan"
        return ("inf" if v > 0 else "-inf") if math.isinf(v) else repr(v)
    if isinstance(v, int):
        return str(v)
    if isinstance(v, str):
        esc = {'"': '\\"', "\\": "\\\\"}
        out = "".join(esc.get(c, c) if 0x20 <= ord(c) != 0x7F else f"\\u{ord(c):04x}" for c in v)
        return f'"{out}"'
    if isinstance(v, (datetime.date, datetime.time)):
        return v.isoformat()
    if isinstance(v, list):
        return "[" + ", ".join(_toml_value(x) for x in v) + "]"
    if isinstance(v, dict):
        return "{" + ", ".join(f"{_toml_key(k)} = {_toml_value(x)}" for k, x in v.items()) + "}"
    raise TypeError(f"no TOML for {type(v).__name__}")


def to_toml(data):
    """TOML text for ``data`` (a parsed scene, possibly broken): top-level values first,
    then ``[tables]``, then ``[[arrays of tables]]``; anything else inline."""
    lines, tables, arrays = [], [], []
    for key, value in data.items():
        if isinstance(value, dict):
            tables.append((key, value))
        elif isinstance(value, list) and value and all(isinstance(x, dict) for x in value):
            arrays.append((key, value))
        else:
            lines.append(f"{_toml_key(key)} = {_toml_value(value)}")
    for key, table in tables:
        lines += ["", f"[{_toml_key(key)}]"]
        lines += [f"{_toml_key(k)} = {_toml_value(v)}" for k, v in table.items()]
    for key, items in arrays:
        for table in items:
            lines += ["", f"[[{_toml_key(key)}]]"]
            lines += [f"{_toml_key(k)} = {_toml_value(v)}" for k, v in table.items()]
    return "\n".join(lines) + "\n"


def base_data(name):
    """A shipped scene, parsed."""
    return tomllib.loads((SCENE_DIR / f"{name}.toml").read_text(encoding="utf-8"))


def scene_bytes(variant):
    if variant.raw is not None:
        return variant.raw
    data = base_data(variant.base)
    for path, value in variant.edits:
        section, _, key = path.rpartition(".")
        table = data.setdefault(section, {}) if section else data
        if value is DROP:
            del table[key]
        else:
            table[key] = value
    return to_toml(data).encode("utf-8")


def write(variant, directory):
    path = pathlib.Path(directory) / "scene.toml"
    path.write_bytes(scene_bytes(variant))
    return path


def expected(variant, path, command):
    """The regular expression the one line on stderr must match."""
    where = "" if variant.where is None else f": {variant.where}"
    line = "" if variant.line is None else f":{variant.line}"
    prefix = re.escape(f"tactile {command}: error: {path}{line}{where}: ")
    return prefix + f".*{re.escape(variant.says)}.*"


ROUTES = {  # how a scene reaches the CLI: the command, and its arguments for a path
    "emulate": ("emulate", lambda p: ["emulate", str(p), "--now", "--duration", "0"]),
    "sim://": ("info", lambda p: ["info", "--port", f"sim://{p}"]),
}


def run(variant, directory, route="emulate"):
    """Write ``variant``, run the CLI on it in-process; (code, stdout, stderr, path, command)."""
    from tactile.cli.main import main

    path = write(variant, directory)
    command, argv = ROUTES[route]
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = main(argv(path))
    return code, out.getvalue(), err.getvalue(), path, command


def verdict(variant, code, err, path, command):
    """``held``, or ``FAILED: why`` (exit code or message not as promised)."""
    if code != 2:
        return f"FAILED: exit {code}, stderr {err[-200:]!r}"
    if err.count("\n") != 1 or not err.endswith("\n"):
        return f"FAILED: not one line: {err[-200:]!r}"
    if not re.fullmatch(expected(variant, path, command), err[:-1]):
        return f"FAILED: message {err[:-1]!r}"
    return "held"


if __name__ == "__main__":
    import tempfile

    with tempfile.TemporaryDirectory() as tmp:
        for v in VARIANTS:
            code, _, err, path, command = run(v, tmp)
            print(f"{v.name:40} exit {code}  {err.strip().replace(str(path), 'scene.toml')}")
