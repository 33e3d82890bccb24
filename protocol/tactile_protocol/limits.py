"""Field limits (PROTOCOL.md §4, "Field limits"): what a field may hold beyond its type.

A frame with a good CRC and layout can still lie: a HELLO claiming 5 sensors,
a CONTACT in phase 7, a calibration coefficient that is NaN.  ``LIMITS`` names,
per message, the fields that are restricted and how; a field not listed may
take any value of its type.  ``violation(name, values)`` checks one message's
payload values and returns ``None`` or one line naming the first field out of
its limits, e.g. ``n_sensors = 5 (protocol allows 1..4)``.

Rules (``(field, kind, a, b)``):

- ``RANGE, lo, hi``: an integer in ``lo..hi``; ``hi`` may name an earlier field
  of the same message (``rate_hz`` at most ``max_rate_hz``);
- ``BITS, mask, _``: only the bits of ``mask`` may be set;
- ``SENSOR, allow_all, _``: a sensor index below the number of sensors the
  device announced (``MAX_SENSORS`` before any HELLO), or ``SENSOR_ALL`` when
  ``allow_all``;
- ``FINITE, _, _``: a finite float32.

Pure and allocation-light, so it runs unchanged on MicroPython and CPython.
"""

from tactile_protocol.constants import (
    CFG_AUTOSTART,
    CFG_GATE_3D,
    CFG_STREAM_CONTACTS,
    CFG_STREAM_SAMPLES,
    CFG_STREAMING,
    CFG_WRITABLE,
    FAULT_DRDY_STUCK,
    FAULT_I2C,
    FAULT_NO_CALIBRATION,
    FAULT_OVERRUN,
    FAULT_RECOVERED,
    FAULT_SATURATION,
    FAULT_TX_DROPPED,
    MAX_SENSORS,
    MAX_TARE_SAMPLES,
    NAK_LOADED,
    NAK_UNKNOWN_COMMAND,
    PHASE_BEGIN,
    PHASE_END,
    PROTOCOL_VERSION,
    SENSOR_ALL,
)
from tactile_protocol.messages import BY_NAME

RANGE = 0
BITS = 1
SENSOR = 2
FINITE = 3

INT32_MAX = 0x7FFFFFFF
FLOAT32_MAX = 3.4028234663852886e38
# HELLO / INFO flags: CONFIG's, less CFG_PERSIST (a request, never a state), plus CFG_STREAMING.
INFO_FLAGS = CFG_STREAM_SAMPLES | CFG_STREAM_CONTACTS | CFG_GATE_3D | CFG_AUTOSTART | CFG_STREAMING
FAULT_BITS = (
    FAULT_I2C
    | FAULT_DRDY_STUCK
    | FAULT_SATURATION
    | FAULT_OVERRUN
    | FAULT_TX_DROPPED
    | FAULT_NO_CALIBRATION
    | FAULT_RECOVERED
)
HOST_TYPES = (0x40, 0x7F)  # message types of host-to-device frames (PROTOCOL.md §3)

_CONFIG = (
    ("rate_hz", RANGE, 1, 0xFFFF),
    ("enter_threshold", RANGE, 0, INT32_MAX),
    ("exit_threshold", RANGE, 0, "enter_threshold"),
    ("debounce", RANGE, 1, 0xFF),
)
_INFO = (
    (
        ("protocol_version", RANGE, PROTOCOL_VERSION, PROTOCOL_VERSION),
        ("n_sensors", RANGE, 1, MAX_SENSORS),
        ("max_rate_hz", RANGE, 1, 0xFFFF),
        ("rate_hz", RANGE, 1, "max_rate_hz"),
    )
    + _CONFIG[1:]
    + (("flags", BITS, INFO_FLAGS, 0),)
)

LIMITS = {
    "HELLO": _INFO,
    "INFO": _INFO,
    "SAMPLE": (("sensor", SENSOR, False, 0),),
    "CONTACT": (("sensor", SENSOR, False, 0), ("phase", RANGE, PHASE_BEGIN, PHASE_END)),
    "STATUS": (("faults", BITS, FAULT_BITS, 0), ("sensor", SENSOR, True, 0)),
    "ACK": (("cmd_type", RANGE, HOST_TYPES[0], HOST_TYPES[1]),),
    "NAK": (("reason", RANGE, NAK_UNKNOWN_COMMAND, NAK_LOADED),),
    "CONFIG": _CONFIG + (("flags", BITS, CFG_WRITABLE, 0),),
    "TARE": (("sensor", SENSOR, True, 0), ("n_samples", RANGE, 0, MAX_TARE_SAMPLES)),
    "SET_CAL": (("sensor", SENSOR, False, 0),)
    + tuple(("c%d%d" % (r, c), FINITE, 0, 0) for r in range(6) for c in range(6)),
}


def _compile():
    """name -> [(index, field, kind, a, b, b_index)]: field positions resolved once."""
    out = {}
    for name, rules in LIMITS.items():
        fields = BY_NAME[name][4]
        compiled = []
        for field, kind, a, b in rules:
            b_index = fields.index(b) if isinstance(b, str) else -1
            compiled.append((fields.index(field), field, kind, a, b, b_index))
        out[name] = compiled
    return out


RULES = _compile()


def _sensors(n):
    return "%d sensor%s" % (n, "" if n == 1 else "s")


def violation(name, values, n_sensors=None, offset=0):
    """None if the payload ``values`` of message ``name`` keep the limits, else one line.

    ``n_sensors``: the count the device announced in its HELLO/INFO (None: not known
    yet, ``MAX_SENSORS`` applies).  ``offset``: index of the first payload field in
    ``values`` (2 for a host message tuple that starts with seq and timestamp).
    """
    rules = RULES.get(name)
    if rules is None:
        return None
    for index, field, kind, a, b, b_index in rules:
        v = values[offset + index]
        if kind == RANGE:
            hi = values[offset + b_index] if b_index >= 0 else b
            if a <= v <= hi:
                continue
            if b_index >= 0:
                allowed = "%d..%s = %d" % (a, b, hi)
            else:
                allowed = "%d" % a if a == hi else "%d..%d" % (a, hi)
            return "%s = %d (protocol allows %s)" % (field, v, allowed)
        if kind == BITS:
            if not v & ~a:
                continue
            return "%s = 0x%02x (protocol allows bits 0x%02x)" % (field, v, a)
        if kind == SENSOR:
            n = MAX_SENSORS if n_sensors is None else n_sensors
            if v < n or (a and v == SENSOR_ALL):
                continue
            also = " or %d for all" % SENSOR_ALL if a else ""
            if n_sensors is None:
                return "%s = %d (protocol allows 0..%d%s)" % (field, v, n - 1, also)
            return "%s = %d (the device announced %s: 0..%d%s)" % (
                field,
                v,
                _sensors(n),
                n - 1,
                also,
            )
        if kind == FINITE:
            if v == v and -FLOAT32_MAX <= v <= FLOAT32_MAX:
                continue
            return "%s is not finite (protocol allows finite float32 values)" % field
    return None
