"""The scene schema: every section and key of a scene TOML file, its type, range and default.

This module is the one place a scene's keys are declared.  ``validate(data)`` checks a whole
parsed scene against it before anything is built, and returns each section with its
defaults filled in; the emulator's modules read those values and check nothing again.  The
limits the wire or the firmware impose (sensor count, rates, thresholds, calibration id,
debounce) are read from ``tactile_protocol`` (its messages and settings), not restated.  A rule that
spans keys (``exit_threshold_N`` <= ``enter_threshold_N``) is one function in ``RULES``.
``markdown()`` renders the schema for docs/scenes.md, which a test keeps equal to it.

Errors are ``toml_keys.Bad`` with ``where`` = ``[section] key`` (``[[sensor_fault]] #2 kind``
for an array of tables, ``[sensor] noise_force_N[1]`` for a list item); the loader prefixes
the file.
"""

import math
import struct

from tactile_protocol import constants as C
from tactile_protocol import settings
from tactile_protocol.messages import BY_NAME
from tactile_protocol.settings import DEFAULTS, GATES, STREAMS, to_newtons
from tactile_sim.adc_model import FULL_SCALE_CODES
from tactile_sim.emulator import sensor_faults
from tactile_sim.emulator.cores import CORES, DEFAULT_CORE
from tactile_sim.emulator.toml_keys import (
    Bad,
    Bool,
    Choice,
    Either,
    Float,
    Int,
    List,
    Map,
    Row,
    Text,
    check_table,
    did_you_mean,
    markdown_table,
    show,
)


def wire_max(message, field):
    """The largest value the wire carries in ``message.field`` (from its struct code)."""
    _, _, _, _, fields, codes = BY_NAME[message]
    code = codes[fields.index(field)]
    bits = 8 * struct.calcsize("<" + code)
    return (1 << bits) - 1 if code.isupper() else (1 << (bits - 1)) - 1


FORCE_MAX_N = to_newtons(wire_max("CONFIG", "enter_threshold"))  # 2147.48 N
TORQUE_MAX_NM = wire_max("SAMPLE", "tx") * C.TORQUE_LSB_NM
MAX_TIME_S = 1e6  # any time or duration in a scene (11.6 days)


def _s(default, doc, hi=MAX_TIME_S, positive=False):
    return Float(0.0, hi, default, "s", doc, lo_open=positive)


def _m(default, doc, hi=1.0, positive=True):
    return Float(0.0, hi, default, "m", doc, lo_open=positive)


def _deg(default, doc):
    return Float(-360.0, 360.0, default, "deg", doc)


def _n(default, doc, positive=False):
    return Float(0.0, FORCE_MAX_N, default, "N", doc, lo_open=positive)


def _mu(default):
    return Float(0.0, 10.0, default, "", "Coulomb friction: tangential / normal load")


_CODES = Float(-FULL_SCALE_CODES, FULL_SCALE_CODES)
_TORQUE = Float(-TORQUE_MAX_NM, TORQUE_MAX_NM)
_FORCE = Float(-FORCE_MAX_N, FORCE_MAX_N)
_CHART = Float(-100.0, 100.0)
_FRAME = Int(0, 2**32 - 1)

SCENE = {
    "name": Text(64, None, "shown by `tactile emulate`; default: the file's name"),
    "seed": Int(0, 2**32 - 1, 0, "", "seeds the sensor noise"),
    "duration_s": _s(10.0, "nominal length (informational)", positive=True),
}
BOARD = {
    "rate_hz": Int(
        settings.MIN_RATE_HZ,
        wire_max("CONFIG", "rate_hz"),
        DEFAULTS["rate_hz"],
        "Hz",
        "sample rate; at most the ceiling of the board's sensors",
    ),
    "autostart": Bool(True, doc="stream from boot"),
    "streams": List(
        Choice(STREAMS),
        ["contacts"],
        "",
        "frames streamed: SAMPLE and/or CONTACT",
        max_len=len(STREAMS),
        unique=True,
    ),
    "gate": Choice(GATES, "xy", "contact gate on the force in the x-y plane or in 3-D"),
    "enter_threshold_N": _n(DEFAULTS["enter_N"], "a contact begins above this (5 ozf)"),
    "exit_threshold_N": _n(
        DEFAULTS["exit_N"], "... and ends below it (4 ozf); <= enter_threshold_N"
    ),
    "debounce": Int(
        1,
        settings.MAX_DEBOUNCE,
        DEFAULTS["debounce"],
        "samples",
        "past a threshold to change state",
    ),
    "sensors": Int(1, C.MAX_SENSORS, 1, "", "F/T sensors on the board, two per I2C bus"),
    "max_rate_hz": Int(
        0,
        wire_max("INFO", "max_rate_hz"),
        0,
        "Hz",
        "0: the hardware's ceiling; else override it (benches only)",
    ),
    "core": Choice(
        CORES,
        DEFAULT_CORE,
        "firmware run: the MicroPython one, or the C core (firmware/c, built with cc)",
    ),
}
SENSOR = {
    "model": Text(16, "SIM-FT6", "informational (HELLO names the firmware's own)"),
    "force_range_N": Float(
        C.FORCE_LSB_N, FORCE_MAX_N, 50.0, "N", "full-scale force, at 60% of the converters' range"
    ),
    "torque_range_Nm": Float(C.TORQUE_LSB_NM, TORQUE_MAX_NM, 2.0, "N*m", "full-scale torque"),
    "noise_force_N": List(
        _n(0.0, ""),
        [0.0, 0.0, 0.0],
        "N",
        "sd of fx, fy, fz noise; all zero: no random numbers",
        length=3,
    ),
    "noise_torque_Nm": List(
        Float(0.0, TORQUE_MAX_NM), [0.0, 0.0, 0.0], "N*m", "sd of tx, ty, tz noise", length=3
    ),
    "bias_counts": Either(
        _CODES,
        List(_CODES, length=6),
        default=20000.0,
        unit="counts",
        doc="gauge offset, one for all or one per gauge (TARE removes it)",
    ),
    "drift_counts_per_s": Float(
        -FULL_SCALE_CODES, FULL_SCALE_CODES, 0.0, "counts/s", "gauge drift"
    ),
    "cal_id": Int(0, wire_max("INFO", "cal_id_0"), 1, "", "calibration id in HELLO"),
}
_KEYFRAME = Row(
    _s(None, ""),
    _FORCE,
    _FORCE,
    _FORCE,
    _TORQUE,
    _TORQUE,
    _TORQUE,
    names=("t_s", "fx", "fy", "fz", "tx", "ty", "tz"),
)
MOTION = {
    "press": {
        "keyframes": List(
            _KEYFRAME,
            unit="s, N, N*m",
            min_len=1,
            doc="the wrench at increasing times, linear in between",
        ),
        "repeat": Bool(False, doc="loop the keyframes over their span"),
    },
    "rig": {
        "object": Choice("tactile_sim.rig.objects:CH5_OBJECTS", "plane", "ch. 5 surface (§5.2)"),
        "passes": Int(1, 10, 3, "", "passes (the thesis's 'fingers')"),
        "points": Int(1, 50, 6, "", "points per pass"),
        "samples": Int(1, 10, 2, "", "touches per point"),
        "mu": _mu(0.0),
        "hold_s": _s(0.05, "hold per touch", hi=60.0, positive=True),
        "speed_mps": Float(1e-3, 1.0, 0.01, "m/s", "approach speed"),
        "lead_in_s": _s(1.0, "rest before the first approach (time for a TARE)", hi=3600.0),
    },
    "sweep": {
        "object": Choice("tactile_sim.ep2.objects:KINDS", "sphere", "EP2 object"),
        "radius_m": _m(0.05, "the object's radius", hi=10.0),
        "rotation_deg": _deg(0.0, "the object turned about its normal"),
        "tilt_deg": _deg(0.0, "object and hand turned about world x"),
        "fingers": Int(1, C.MAX_SENSORS, 3, "", "one per board sensor; <= [board] sensors"),
        "spacing_m": _m(0.02, "between fingers, along x"),
        "length_m": _m(0.04, "swept along y"),
        "samples": Int(2, 1000, 21, "", "stations per finger"),
        "speed_mps": Float(1e-4, 10.0, 0.05, "m/s", "sweep speed"),
        "settle_s": _s(0.002, "move between stations; < the time per station", hi=60.0),
        "fingertip_radius_m": _m(0.012, "spherical fingertip"),
        "sensor_offset_m": _m(0.03, "sensor origin behind the fingertip centre", positive=False),
        "normal_force_N": _n(5.0, "normal load"),
        "mu": _mu(0.3),
        "ramp_s": _s(0.02, "load ramp at the first and last station", hi=60.0),
        "rest_s": _s(1.0, "unloaded before and after (the host TAREs in it)", hi=3600.0),
        "roll_deg": List(
            Float(-360.0, 360.0),
            [0.0, 30.0, -30.0],
            "deg",
            "finger k turned about its pole; one per finger",
            min_len=1,
            max_len=C.MAX_SENSORS,
        ),
    },
    "roll": {
        "surface": Choice("tactile_sim.ep1.surfaces:KINDS", "ellipsoid", "EP1 object surface"),
        "surface_params": Map(
            _CHART, {"a": 0.02, "b": 0.03, "c": 0.02}, "m", "the surface's parameters, by name"
        ),
        "object_uv": Row(_CHART, _CHART, default=[0.0, 0.0], doc="start contact, object chart"),
        "finger_uv": Row(_CHART, _CHART, default=[0.0, 0.0], doc="start contact, finger chart"),
        "psi": Float(-2 * math.pi, 2 * math.pi, 0.0, "rad", "start angle between contact frames"),
        "finger_radius_m": _m(0.01, "fingertip radius R1"),
        "sensor_offset_m": _m(0.05, "sensor origin behind the fingertip centre", positive=False),
        "normal_force_N": _n(5.0, "normal load", positive=True),
        "mu": _mu(0.0),
        "friction_dir_deg": _deg(0.0, "friction load's direction, fingertip tangent basis"),
        "dtheta_rad": Float(0.0, math.pi, 0.5, "rad", "rotation per probe", lo_open=True),
        "directions_deg": List(
            Float(-360.0, 360.0),
            [0.0, 180.0, 90.0, 270.0],
            "deg",
            "roll directions, each out and back",
            min_len=1,
            max_len=16,
        ),
        "rest_s": _s(0.5, "unloaded before and after", hi=3600.0),
        "press_s": _s(0.2, "load ramp", hi=3600.0, positive=True),
        "hold_s": _s(0.2, "hold at each end of a roll", hi=3600.0, positive=True),
        "roll_s": _s(0.3, "one roll", hi=3600.0, positive=True),
        "release_s": _s(0.2, "unload ramp", hi=3600.0, positive=True),
    },
}
MOTION_KINDS = tuple(sorted(MOTION))
LINK = {
    "corrupt_frames": List(_FRAME, [], "", "frames (from 0) with one byte XOR-ed"),
    "drop_byte_frames": List(_FRAME, [], "", "frames (from 0) with one byte removed"),
    "disconnect": List(
        Row(_s(None, ""), _s(None, ""), names=("from_s", "to_s")),
        [],
        "s",
        "pty removed, a new one later (behind --link)",
    ),
}
SENSOR_FAULT = {
    "at_s": _s(0.0, "when"),
    "kind": Choice(sensor_faults.KINDS, doc="what fails"),
    "sensor": Int(0, C.MAX_SENSORS - 1, 0, "", "which sensor; < [board] sensors"),
    "count": Int(1, 1_000_000, 3, "", "failed transactions (i2c_timeout)"),
    "for_s": _s(0.05, "how long (the other kinds)", positive=True),
}
SECTIONS = {"scene": SCENE, "board": BOARD, "sensor": SENSOR, "motion": MOTION, "link": LINK}
ARRAYS = {"sensor_fault": SENSOR_FAULT}  # [[name]]: any number of tables


# --- rules across keys: each returns (where, why) when broken, else None --------------------


def _exit_not_above_enter(d):
    b = d["board"]
    if b["exit_threshold_N"] > b["enter_threshold_N"]:
        return (
            "[board] exit_threshold_N",
            f"must be <= enter_threshold_N ({b['enter_threshold_N']:g})",
        )


def _keyframe_times_increase(d):
    m = d["motion"]
    if m["kind"] == "press":
        times = [row[0] for row in m["keyframes"]]
        for i in range(1, len(times)):
            if times[i] <= times[i - 1]:
                return f"[motion] keyframes[{i}]", f"time must be after {times[i - 1]:g} s"


def _fingers_fit_the_board(d):
    m, sensors = d["motion"], d["board"]["sensors"]
    if m["kind"] != "sweep":
        return None
    if m["fingers"] > sensors:
        return "[motion] fingers", f"must be <= [board] sensors ({sensors}): one sensor each"
    if len(m["roll_deg"]) < m["fingers"]:
        return "[motion] roll_deg", f"must give one angle per finger ({m['fingers']})"
    period = m["length_m"] / (m["samples"] - 1) / m["speed_mps"]
    if not m["settle_s"] < period:
        return "[motion] settle_s", f"must be shorter than the time per station ({period:g} s)"


def _faults_name_a_sensor(d):
    for k, fault in enumerate(d["sensor_fault"]):
        if fault["sensor"] >= d["board"]["sensors"]:
            where = f"[[sensor_fault]] #{k + 1} sensor"
            return where, f"must be < [board] sensors ({d['board']['sensors']})"


def _disconnects_end_after_they_start(d):
    for k, (a, b) in enumerate((d["link"] or {}).get("disconnect", [])):
        if not a < b:
            return f"[link] disconnect[{k}]", f"must end after it starts, got [{a:g}, {b:g}]"


RULES = (
    _exit_not_above_enter,
    _keyframe_times_increase,
    _fingers_fit_the_board,
    _faults_name_a_sensor,
    _disconnects_end_after_they_start,
)


# --- validation ---------------------------------------------------------------------------


def validate(data):
    """The parsed scene ``data`` checked whole; returns {section: values, defaults filled}.

    ``link`` is None when the scene has no ``[link]``; ``sensor_fault`` a list.  Raises
    ``Bad`` with ``where`` naming section and key.
    """
    _known_sections(data)
    out = {}
    for name in ("scene", "board", "sensor"):
        out[name] = _section(f"[{name}]", SECTIONS[name], data.get(name, {}))
    out["motion"] = _motion(data.get("motion"))
    out["link"] = _section("[link]", LINK, data["link"]) if "link" in data else None
    faults = data.get("sensor_fault", [])
    if not isinstance(faults, list) or not all(isinstance(f, dict) for f in faults):
        raise Bad("must be tables, each under a [[sensor_fault]] line", where="[[sensor_fault]]")
    out["sensor_fault"] = [
        _section(f"[[sensor_fault]] #{k + 1}", SENSOR_FAULT, f) for k, f in enumerate(faults)
    ]
    for rule in RULES:
        broken = rule(out)
        if broken:
            raise Bad(broken[1], where=broken[0])
    return out


def _known_sections(data):
    known = list(SECTIONS) + list(ARRAYS)
    for name, value in data.items():
        if name in known:
            continue
        if not isinstance(value, (dict, list)):
            owner = [s for s, keys in SECTIONS.items() if s != "motion" and name in keys]
            hint = f" (put it under [{owner[0]}])" if owner else ""
            raise Bad("a key outside any section" + hint, where=str(name))
        hint = did_you_mean(f"[{name}]", [f"[{s}]" for s in known])
        raise Bad("unknown section" + hint, where=f"[{name}]")


def _section(label, keys, given):
    if not isinstance(given, dict):
        raise Bad(f"must be a table ({label} followed by its keys)", where=label)
    try:
        return check_table(keys, given)
    except Bad as bad:
        raise bad.under(label + " ") from None


def _motion(given):
    """[motion]: its ``kind`` first, then the keys of that kind."""
    kinds = MOTION_KINDS
    if given is None:
        raise Bad(f"required, with kind = one of {', '.join(kinds)}", where="[motion]")
    if not isinstance(given, dict):
        raise Bad("must be a table ([motion] followed by its keys)", where="[motion]")
    kind = given.get("kind")
    if kind not in kinds:
        got = "" if kind is None else f", got {show(kind)}"
        raise Bad(f"must be one of {', '.join(kinds)}{got}", where="[motion] kind")
    rest = {k: v for k, v in given.items() if k != "kind"}
    try:
        return {"kind": kind, **check_table(MOTION[kind], rest)}
    except Bad as bad:
        if bad.why.startswith("unknown key"):
            bad = Bad(f"unknown key for kind {kind}" + bad.why[len("unknown key") :], bad.where)
        raise bad.under("[motion] ") from None


# --- documentation ------------------------------------------------------------------------


def markdown():
    """The schema as Markdown tables, one per section and motion kind (docs/scenes.md)."""
    out = []
    for name, keys in SECTIONS.items():
        if name == "motion":
            kind = Choice(MOTION_KINDS, doc="which motion; each kind has its own keys below")
            out += markdown_table("[motion]", {"kind": kind}) + [""]
            for k in MOTION_KINDS:
                out += markdown_table(f'[motion] kind = "{k}"', MOTION[k]) + [""]
        else:
            out += markdown_table(f"[{name}]", keys) + [""]
    for name, keys in ARRAYS.items():
        out += markdown_table(f"[[{name}]]", keys) + [""]
    return "\n".join(out).rstrip() + "\n"
