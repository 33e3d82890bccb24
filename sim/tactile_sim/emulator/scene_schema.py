"""The scene schema: ``KEYS``, a row per key of a scene TOML file (section ``motion.KIND``
for a motion kind's keys), with limits from ``tactile_protocol`` (its messages and settings), and the
rules across keys (``broken_rules``).  ``validate(data)`` checks a parsed scene whole and
fills in the defaults; ``markdown()`` is docs/scenes.md's tables.  An error is
``Bad`` with ``where`` = ``[section] key`` (``[[sensor_fault]] #2 kind``,
``[sensor] noise_force_N[1]``).
"""

import copy
import math
import struct
from collections import namedtuple
from functools import partial
from typing import NamedTuple

from tactile_protocol import constants as C
from tactile_protocol import settings
from tactile_protocol.messages import BY_NAME
from tactile_protocol.settings import DEFAULTS, GATES, STREAMS, to_newtons
from tactile_sim.adc_model import FULL_SCALE_CODES
from tactile_sim.emulator import sensor_faults
from tactile_sim.emulator.cores import CORES, DEFAULT_CORE
from tactile_sim.emulator.scene_words import (
    choices,
    describe,
    did_you_mean,
    number_text,
    show,
    size_text,
)


def wire_max(message, field):
    """The largest value the wire carries in ``message.field`` (from its struct code)."""
    _, _, _, _, fields, codes = BY_NAME[message]
    code = codes[fields.index(field)]
    bits = 8 * struct.calcsize("<" + code)
    return (1 << bits) - 1 if code.isupper() else (1 << (bits - 1)) - 1


class T(NamedTuple):
    """A value's type: ``of`` is a list's or table's item type, a row's item types, the
    options of ``either`` or a choice's names (``"module:NAME"``: imported when checked);
    ``lo``, ``hi`` bound a number, a text's length, a list's size, a table's entries."""

    kind: str
    of: object = ()
    lo: float = 0
    hi: float = 10_000
    open: bool = False  # a number: above ``lo``
    names: tuple = ()  # a row's items
    unique: bool = False  # a list's items


Int, Num, Text = partial(T, "int", ()), partial(T, "number", ()), partial(T, "text", (), 1)
OneOf, ListOf, Row, Either = (partial(T, kind) for kind in ("choice", "list", "row", "either"))
BOOL, Key = T("bool"), namedtuple("Key", "section name type default unit help")

REQUIRED = object()  # the default of a key that must be given
FORCE_MAX_N = to_newtons(wire_max("CONFIG", "enter_threshold"))  # 2147.48 N
TORQUE_MAX_NM = wire_max("SAMPLE", "tx") * C.TORQUE_LSB_NM
MAX_TIME_S = 1e6  # any time or duration in a scene (11.6 days)
U32, FORCE, TORQUE = 2**32 - 1, Num(0.0, FORCE_MAX_N), Num(0.0, TORQUE_MAX_NM)
TIME, CODES, CHART = Num(0.0, MAX_TIME_S), Num(-FULL_SCALE_CODES, FULL_SCALE_CODES), Num(-100, 100)
DEG, MU, LENGTH = Num(-360.0, 360.0), Num(0.0, 10.0), Num(0.0, 1.0, True)
SIGNED = (Num(-FORCE_MAX_N, FORCE_MAX_N),) * 3 + (Num(-TORQUE_MAX_NM, TORQUE_MAX_NM),) * 3
KEYFRAME = Row((TIME, *SIGNED), names=("t_s", "fx", "fy", "fz", "tx", "ty", "tz"))
WALK, CELSIUS, G = Num(0.0, FULL_SCALE_CODES), Num(-273.15, 1000.0), Num(-100.0, 100.0)
TEMPERATURE = Row((TIME, CELSIUS), names=("t_s", "C"))
XYZ = partial(Row, names=("x", "y", "z"))
RPY = Row((DEG, DEG, DEG), names=("roll", "pitch", "yaw"))
FRICTION = "Coulomb friction: tangential / normal load"


def per_gauge(t):
    """One value of type ``t`` for all six gauges, or a list of one per gauge."""
    return Either((t, ListOf(t, 6, 6)))


# fmt: off
KEYS = tuple(Key(*row) for row in (
    # section, key, type, default, unit, help
    ("scene", "name", Text(64), None, "", "shown by `tactile emulate`; default: the file's name"),
    ("scene", "seed", Int(0, U32), 0, "", "seeds the sensor noise"),
    ("scene", "duration_s", Num(0.0, MAX_TIME_S, True), 10.0, "s", "nominal length (informational)"),
    ("board", "rate_hz", Int(settings.MIN_RATE_HZ, wire_max("CONFIG", "rate_hz")), DEFAULTS["rate_hz"], "Hz", "sample rate; at most the ceiling of the board's sensors"),
    ("board", "autostart", BOOL, True, "", "stream from boot"),
    ("board", "streams", ListOf(OneOf(STREAMS), 0, len(STREAMS), unique=True), ["contacts"], "", "frames streamed: SAMPLE and/or CONTACT"),
    ("board", "gate", OneOf(GATES), "xy", "", "contact gate on the force in the x-y plane or in 3-D"),
    ("board", "enter_threshold_N", FORCE, DEFAULTS["enter_N"], "N", "a contact begins above this (5 ozf)"),
    ("board", "exit_threshold_N", FORCE, DEFAULTS["exit_N"], "N", "... and ends below it (4 ozf); <= enter_threshold_N"),
    ("board", "debounce", Int(1, settings.MAX_DEBOUNCE), DEFAULTS["debounce"], "samples", "past a threshold to change state"),
    ("board", "sensors", Int(1, C.MAX_SENSORS), 1, "", "F/T sensors on the board, two per I2C bus"),
    ("board", "max_rate_hz", Int(0, wire_max("INFO", "max_rate_hz")), 0, "Hz", "0: the hardware's ceiling; else override it (benches only)"),
    ("board", "core", OneOf(CORES), DEFAULT_CORE, "", "firmware run: the MicroPython one, or the C core (firmware/c, built with cc)"),
    ("sensor", "model", Text(16), "SIM-FT6", "", "informational (HELLO names the firmware's own)"),
    ("sensor", "force_range_N", Num(C.FORCE_LSB_N, FORCE_MAX_N), 50.0, "N", "full-scale force, at 60% of the converters' range"),
    ("sensor", "torque_range_Nm", Num(C.TORQUE_LSB_NM, TORQUE_MAX_NM), 2.0, "N*m", "full-scale torque"),
    ("sensor", "noise_force_N", ListOf(FORCE, 3, 3), [0.0] * 3, "N", "sd of fx, fy, fz noise; all zero: no random numbers"),
    ("sensor", "noise_torque_Nm", ListOf(TORQUE, 3, 3), [0.0] * 3, "N*m", "sd of tx, ty, tz noise"),
    ("sensor", "bias_counts", Either((CODES, ListOf(CODES, 6, 6))), 20000.0, "counts", "gauge offset, one for all or one per gauge (TARE removes it)"),
    ("sensor", "drift_counts_per_s", per_gauge(CODES), 0.0, "counts/s", "linear gauge drift, one for all or one per gauge"),
    ("sensor", "bias_walk_counts_per_sqrt_s", per_gauge(WALK), 0.0, "counts/s^0.5", "random walk of each gauge's offset (sd after t s: this x sqrt(t)), seeded by [scene] seed"),
    ("sensor", "temperature_C", ListOf(TEMPERATURE, 0, 1000), [], "s, degC", "the sensor's temperature at increasing times, linear in between, held outside; none: constant"),
    ("sensor", "bias_counts_per_C", per_gauge(CODES), 0.0, "counts/degC", "gauge offset per degree away from the first temperature_C"),
    ("sensor", "cal_id", Int(0, wire_max("INFO", "cal_id_0")), 1, "", "calibration id in HELLO"),
    ("tool", "mass_kg", Num(0.0, 5.0), 0.0, "kg", "what the sensor carries (fingertip, adapter): its weight loads every sensor"),
    ("tool", "com_m", XYZ((Num(-1.0, 1.0),) * 3), [0.0, 0.0, 0.0], "m", "the tool's centre of mass, sensor frame"),
    ("world", "gravity_m_s2", XYZ((G,) * 3), [0.0, 0.0, -9.81], "m/s^2", "gravity in the robot's world frame (the pose log's)"),
    ("motion", "kind", OneOf(f"{__name__}:MOTION_KINDS"), REQUIRED, "", "which motion; each kind has its own keys below"),
    ("motion.press", "keyframes", ListOf(KEYFRAME, 1), REQUIRED, "s, N, N*m", "the wrench at increasing times, linear in between"),
    ("motion.press", "repeat", BOOL, False, "", "loop the keyframes over their span"),
    ("motion.rig", "object", OneOf("tactile_sim.rig.objects:CH5_OBJECTS"), "plane", "", "ch. 5 surface (§5.2)"),
    ("motion.rig", "passes", Int(1, 10), 3, "", "passes (the thesis's 'fingers')"),
    ("motion.rig", "points", Int(1, 50), 6, "", "points per pass"),
    ("motion.rig", "samples", Int(1, 10), 2, "", "touches per point"),
    ("motion.rig", "mu", MU, 0.0, "", FRICTION),
    ("motion.rig", "hold_s", Num(0.0, 60.0, True), 0.05, "s", "hold per touch"),
    ("motion.rig", "speed_mps", Num(1e-3, 1.0), 0.01, "m/s", "approach speed"),
    ("motion.rig", "lead_in_s", Num(0.0, 3600.0), 1.0, "s", "rest before the first approach (time for a TARE)"),
    ("motion.roll", "surface", OneOf("tactile_sim.ep1.surfaces:KINDS"), "ellipsoid", "", "EP1 object surface"),
    ("motion.roll", "surface_params", T("table", CHART, 0, 16), {"a": 0.02, "b": 0.03, "c": 0.02}, "m", "the surface's parameters, by name"),
    ("motion.roll", "object_uv", Row((CHART, CHART)), [0.0, 0.0], "", "start contact, object chart"),
    ("motion.roll", "finger_uv", Row((CHART, CHART)), [0.0, 0.0], "", "start contact, finger chart"),
    ("motion.roll", "psi", Num(-2 * math.pi, 2 * math.pi), 0.0, "rad", "start angle between contact frames"),
    ("motion.roll", "finger_radius_m", LENGTH, 0.01, "m", "fingertip radius R1"),
    ("motion.roll", "sensor_offset_m", Num(0.0, 1.0), 0.05, "m", "sensor origin behind the fingertip centre"),
    ("motion.roll", "normal_force_N", Num(0.0, FORCE_MAX_N, True), 5.0, "N", "normal load"),
    ("motion.roll", "mu", MU, 0.0, "", FRICTION),
    ("motion.roll", "friction_dir_deg", DEG, 0.0, "deg", "friction load's direction, fingertip tangent basis"),
    ("motion.roll", "dtheta_rad", Num(0.0, math.pi, True), 0.5, "rad", "rotation per probe"),
    ("motion.roll", "directions_deg", ListOf(DEG, 1, 16), [0.0, 180.0, 90.0, 270.0], "deg", "roll directions, each out and back"),
    ("motion.roll", "rest_s", Num(0.0, 3600.0), 0.5, "s", "unloaded before and after"),
    ("motion.roll", "press_s", Num(0.0, 3600.0, True), 0.2, "s", "load ramp"),
    ("motion.roll", "hold_s", Num(0.0, 3600.0, True), 0.2, "s", "hold at each end of a roll"),
    ("motion.roll", "roll_s", Num(0.0, 3600.0, True), 0.3, "s", "one roll"),
    ("motion.roll", "release_s", Num(0.0, 3600.0, True), 0.2, "s", "unload ramp"),
    ("motion.sweep", "object", OneOf("tactile_sim.ep2.objects:KINDS"), "sphere", "", "EP2 object"),
    ("motion.sweep", "radius_m", Num(0.0, 10.0, True), 0.05, "m", "the object's radius"),
    ("motion.sweep", "rotation_deg", DEG, 0.0, "deg", "the object turned about its normal"),
    ("motion.sweep", "tilt_deg", DEG, 0.0, "deg", "object and hand turned about world x"),
    ("motion.sweep", "fingers", Int(1, C.MAX_SENSORS), 3, "", "one per board sensor; <= [board] sensors"),
    ("motion.sweep", "spacing_m", LENGTH, 0.02, "m", "between fingers, along x"),
    ("motion.sweep", "length_m", LENGTH, 0.04, "m", "swept along y"),
    ("motion.sweep", "samples", Int(2, 1000), 21, "", "stations per finger"),
    ("motion.sweep", "speed_mps", Num(1e-4, 10.0), 0.05, "m/s", "sweep speed"),
    ("motion.sweep", "settle_s", Num(0.0, 60.0), 0.002, "s", "move between stations; < the time per station"),
    ("motion.sweep", "fingertip_radius_m", LENGTH, 0.012, "m", "spherical fingertip"),
    ("motion.sweep", "sensor_offset_m", Num(0.0, 1.0), 0.03, "m", "sensor origin behind the fingertip centre"),
    ("motion.sweep", "normal_force_N", FORCE, 5.0, "N", "normal load"),
    ("motion.sweep", "mu", MU, 0.3, "", FRICTION),
    ("motion.sweep", "ramp_s", Num(0.0, 60.0), 0.02, "s", "load ramp at the first and last station"),
    ("motion.sweep", "rest_s", Num(0.0, 3600.0), 1.0, "s", "unloaded before and after (the host TAREs in it)"),
    ("motion.sweep", "roll_deg", ListOf(DEG, 1, C.MAX_SENSORS), [0.0, 30.0, -30.0], "deg", "finger k turned about its pole; one per finger"),
    ("motion.sweep", "wrist", OneOf(("fixed", "normal")), "fixed", "", "fixed: the hand keeps its orientation; normal: it turns each finger's pole along the surface normal, as a 6-axis arm"),
    ("motion.commanded", "object", OneOf("tactile_sim.ep2.objects:KINDS"), "sphere", "", "EP2 object, its apex at the origin"),
    ("motion.commanded", "radius_m", Num(0.0, 10.0, True), 0.05, "m", "the object's radius"),
    ("motion.commanded", "rotation_deg", DEG, 0.0, "deg", "the object turned about its normal"),
    ("motion.commanded", "tilt_deg", DEG, 0.0, "deg", "the object turned about world x"),
    ("motion.commanded", "finger_radius_m", LENGTH, 0.012, "m", "spherical fingertip"),
    ("motion.commanded", "sensor_offset_m", Num(0.0, 1.0), 0.03, "m", "fingertip centre along the sensor's +x, from its origin"),
    ("motion.commanded", "stiffness_N_m", Num(1.0, 1e9), 20000.0, "N/m", "penalty spring of the contact: a press of f N goes f / stiffness into the object"),
    ("motion.commanded", "speed_mps", Num(1e-4, 10.0), 0.05, "m/s", "moves and approaches"),
    ("motion.commanded", "hold_s", Num(0.0, 60.0, True), 0.2, "s", "the hold a touch answers after (the press stays until the next command)"),
    ("motion.commanded", "home_m", XYZ((Num(-1.0, 1.0),) * 3), [0.0, 0.0, 0.03], "m", "fingertip centre at the start, world frame, pole down"),
    ("motion.commanded", "workspace_min_m", XYZ((Num(-1.0, 1.0),) * 3), [-0.03, -0.03, -0.03], "m", "the fingertip centre's reach, lower corner, world frame"),
    ("motion.commanded", "workspace_max_m", XYZ((Num(-1.0, 1.0),) * 3), [0.03, 0.03, 0.06], "m", "... upper corner; each > workspace_min_m's"),
    ("motion.poses", "orientations_deg", ListOf(RPY, 1, 1000), REQUIRED, "deg", "the hand's orientations, each the turn roll about world x, then pitch about y, then yaw about z"),
    ("motion.poses", "hold_s", Num(0.0, 3600.0, True), 1.0, "s", "each orientation held, the fingers unloaded"),
    ("motion.poses", "move_s", Num(0.0, 3600.0), 0.5, "s", "turning from one orientation to the next (shortest arc)"),
    ("link", "corrupt_frames", ListOf(Int(0, U32)), [], "", "frames (from 0) with one byte XOR-ed"),
    ("link", "drop_byte_frames", ListOf(Int(0, U32)), [], "", "frames (from 0) with one byte removed"),
    ("link", "disconnect", ListOf(Row((TIME, TIME), names=("from_s", "to_s"))), [], "s", "pty removed, a new one later (behind --link)"),
    ("sensor_fault", "at_s", TIME, 0.0, "s", "when"),
    ("sensor_fault", "kind", OneOf(sensor_faults.KINDS), REQUIRED, "", "what fails"),
    ("sensor_fault", "sensor", Int(0, C.MAX_SENSORS - 1), 0, "", "which sensor; < [board] sensors"),
    ("sensor_fault", "count", Int(1, 1_000_000), 3, "", "failed transactions (i2c_timeout)"),
    ("sensor_fault", "for_s", Num(0.0, MAX_TIME_S, True), 0.05, "s", "how long (the other kinds)"),
))
# fmt: on
SECTIONS = {}  # section -> {key: Key}, in the order of KEYS
for _key in KEYS:
    SECTIONS.setdefault(_key.section, {})[_key.name] = _key
MOTION = {s.removeprefix("motion."): keys for s, keys in SECTIONS.items() if "." in s}
MOTION_KINDS = tuple(sorted(MOTION))
TOP = [s for s in SECTIONS if "." not in s]  # the sections a file may hold
ARRAYS = ("sensor_fault",)  # [[name]]: any number of tables
OPTIONAL = ("link",)  # None when the scene has none
BOARD, SENSOR = SECTIONS["board"], SECTIONS["sensor"]


def broken_rules(d):
    """Yield (where, why) for each rule across keys that ``d`` (the checked sections) breaks."""
    b, m, sensors = d["board"], d["motion"], d["board"]["sensors"]
    if b["exit_threshold_N"] > b["enter_threshold_N"]:
        why = f"must be <= enter_threshold_N ({b['enter_threshold_N']:g})"
        yield "[board] exit_threshold_N", why
    if m["kind"] == "press":
        yield from _increasing("[motion] keyframes", m["keyframes"])
    yield from _increasing("[sensor] temperature_C", d["sensor"]["temperature_C"])
    if m["kind"] == "sweep":
        if m["fingers"] > sensors:
            yield "[motion] fingers", f"must be <= [board] sensors ({sensors}): one sensor each"
        if len(m["roll_deg"]) < m["fingers"]:
            yield "[motion] roll_deg", f"must give one angle per finger ({m['fingers']})"
        period = m["length_m"] / (m["samples"] - 1) / m["speed_mps"]
        if not m["settle_s"] < period:
            yield "[motion] settle_s", f"must be shorter than the time per station ({period:g} s)"
    if m["kind"] == "commanded":
        for axis, lo, hi in zip("xyz", m["workspace_min_m"], m["workspace_max_m"]):
            if not lo < hi:
                yield "[motion] workspace_max_m", f"{axis} must be > workspace_min_m's ({lo:g})"
                break
    for k, fault in enumerate(d["sensor_fault"]):
        if fault["sensor"] >= sensors:
            yield f"[[sensor_fault]] #{k + 1} sensor", f"must be < [board] sensors ({sensors})"
    for k, (start, end) in enumerate((d["link"] or {}).get("disconnect", [])):
        if not start < end:
            yield f"[link] disconnect[{k}]", f"must end after it starts, got [{start:g}, {end:g}]"


def _increasing(where, rows):
    """(where, why) for the first row whose time (item 0) is not after the one before."""
    for i in range(1, len(rows)):
        if rows[i][0] <= rows[i - 1][0]:
            yield f"{where}[{i}]", f"time must be after {rows[i - 1][0]:g} s"
            return


# --- checking -----------------------------------------------------------------------------


class Bad(ValueError):
    """A value that breaks its key's rule (``why``); ``where`` is the path to it."""

    def __init__(self, why, where=""):
        super().__init__(why)
        self.why, self.where = why, where


def validate(data):
    """The parsed scene ``data`` checked whole: {section: values, defaults filled in}, None
    for an ``OPTIONAL`` section the scene has not, a list for an array; or ``Bad``."""
    for name, value in data.items():
        if name in TOP:
            continue
        if not isinstance(value, (dict, list)):
            owner = [s for s in TOP if s not in ("motion", *ARRAYS) and name in SECTIONS[s]]
            hint = f" (put it under [{owner[0]}])" if owner else ""
            raise Bad("a key outside any section" + hint, where=str(name))
        hint = did_you_mean(f"[{name}]", [f"[{s}]" for s in TOP])
        raise Bad("unknown section" + hint, where=f"[{name}]")
    out = {name: _top(name, data.get(name)) for name in TOP}
    for where, why in broken_rules(out):
        raise Bad(why, where)
    return out


def _top(name, given):
    """A section the file may hold: a table, an array of tables, or [motion] by its kind."""
    if name == "motion":
        return _motion(given)
    if given is None and name in OPTIONAL:
        return None
    if name not in ARRAYS:
        return _section(f"[{name}]", SECTIONS[name], {} if given is None else given)
    given = [] if given is None else given
    if not isinstance(given, list) or not all(isinstance(t, dict) for t in given):
        raise Bad(f"must be tables, each under a [[{name}]] line", where=f"[[{name}]]")
    return [_section(f"[[{name}]] #{k + 1}", SECTIONS[name], t) for k, t in enumerate(given)]


def _section(label, keys, given, unknown="unknown key"):
    """``given`` (a TOML table) checked against ``keys``, defaults filled in."""
    if not isinstance(given, dict):
        raise Bad(f"must be a table ({label} followed by its keys)", where=label)
    for name in given:
        if name not in keys:
            raise Bad(unknown + did_you_mean(name, list(keys)), f"{label} {name}")
    out = {}
    for name, key in keys.items():
        if name in given:
            out[name] = _under(f"{label} {name}", key.type, given[name])
        elif key.default is REQUIRED:
            raise Bad(f"required ({describe(key.type)})", f"{label} {name}")
        else:
            out[name] = copy.deepcopy(key.default)
    return out


def _motion(given):
    """[motion]: its ``kind`` first, then the keys of that kind."""
    kinds = ", ".join(MOTION_KINDS)
    if given is None:
        raise Bad(f"required, with kind = one of {kinds}", where="[motion]")
    if not isinstance(given, dict):
        raise Bad("must be a table ([motion] followed by its keys)", where="[motion]")
    kind = given.get("kind")
    if kind not in MOTION_KINDS:
        got = "" if kind is None else f", got {show(kind)}"
        raise Bad(f"must be one of {kinds}{got}", where="[motion] kind")
    rest = {k: v for k, v in given.items() if k != "kind"}
    unknown = f"unknown key for kind {kind}"
    return {"kind": kind, **_section("[motion]", MOTION[kind], rest, unknown)}


def _under(part, t, value):
    """``check`` of ``value``, the path to it prefixed with ``part`` in an error."""
    try:
        return check(t, value)
    except Bad as bad:
        raise Bad(bad.why, part + bad.where) from None


def check(t, value):
    """``value`` as type ``t`` holds it (a number as a float, a list's items checked), or
    ``Bad`` saying what it must be."""
    if t.kind == "either":
        option = [o for o in t.of if isinstance(value, list) == (o.kind in ("list", "row"))]
        return check(option[0], value) if option else _bad(f"a {describe(t)}", value)
    if t.kind == "table":
        if not isinstance(value, dict) or len(value) > t.hi:
            _bad(f"a table of at most {t.hi} entries", value)
        return {name: _under(f".{name}", t.of, v) for name, v in value.items()}
    if t.kind in ("list", "row"):
        n = len(t.of) if t.kind == "row" else None
        size = n if n else f"{size_text(t)} ({describe(t.of)})"
        if not isinstance(value, list) or not (
            len(value) == n if n else t.lo <= len(value) <= t.hi
        ):
            _bad(f"a list of {size}{' numbers' if n else ''}", value)
        items = t.of if n else [t.of] * len(value)
        out = [_under(f"[{i}]", item, v) for i, (item, v) in enumerate(zip(items, value))]
        if t.unique and len(set(map(repr, out))) != len(out):
            raise Bad(f"must not repeat an item, got {show(value)}")
        return out
    number = isinstance(value, (int, float)) and not isinstance(value, bool)
    if t.kind == "int":
        if not number or isinstance(value, float):
            _bad("an integer", value)
        return value if t.lo <= value <= t.hi else _bad(f"from {t.lo} to {t.hi}", value)
    if t.kind == "number":
        if not number:
            _bad("a number", value)
        x = float(value) if abs(value) < 2**1000 else math.inf  # (an int beyond any float)
        if math.isfinite(x) and (x > t.lo if t.open else x >= t.lo) and x <= t.hi:
            return x
        _bad(
            f"finite, {'>' if t.open else '>='} {number_text(t.lo)} and <= {number_text(t.hi)}",
            value,
        )
    if t.kind == "bool":
        return value if isinstance(value, bool) else _bad("true or false", value)
    if t.kind == "text":
        if not isinstance(value, str):
            _bad("a string", value)
        ok = value.isascii() and value.isprintable() and 0 < len(value) <= t.hi
        return value if ok else _bad(f"1 to {t.hi} printable ASCII characters", value)
    ok = isinstance(value, str) and value in choices(t)
    return value if ok else _bad("one of " + ", ".join(choices(t)), value)


def _bad(what, value):
    raise Bad(f"must be {what}, got {show(value)}")


def _default(key):
    d = key.default
    if d is REQUIRED or d is None:
        return "required" if d is REQUIRED else "see meaning"
    if isinstance(d, (bool, str)):
        return f'`"{d}"`' if isinstance(d, str) else f"`{str(d).lower()}`"
    if isinstance(d, dict):
        return "`{ " + ", ".join(f"{k} = {v!r}" for k, v in d.items()) + " }`"
    return f"`{d!r}`".replace("'", '"')


def markdown():
    """The schema as Markdown tables, one per section and motion kind (docs/scenes.md)."""
    out, kinds = [], [(f'[motion] kind = "{k}"', MOTION[k]) for k in MOTION_KINDS]
    for top in TOP:
        tables = [(f"[[{top}]]" if top in ARRAYS else f"[{top}]", SECTIONS[top])]
        for title, keys in tables + (kinds if top == "motion" else []):
            out += [f"### `{title}`", "", "| key | type and range | unit | default | meaning |"]
            out.append("|---|---|---|---|---|")
            for name, key in keys.items():
                cells = (f"`{name}`", describe(key.type), key.unit or "-", _default(key), key.help)
                out.append("| " + " | ".join(c.replace("|", "\\|") for c in cells) + " |")
            out.append("")
    return "\n".join(out).rstrip() + "\n"
