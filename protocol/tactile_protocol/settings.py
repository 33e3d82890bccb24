"""The board-settings vocabulary: CONFIG's limits and defaults, units, stream and gate names.

One place for what the firmware checks and stores, what the host types and shows and what a
scene sets.  The board keeps CONFIG's five fields (rate, enter, exit, debounce, flags), forces
as integers of ``FORCE_LSB_N`` (1 uN); a user types newtons, stream names and gate modes.

Defaults follow the thesis (§5.1, §5.1.3): a contact is |F| in the x-y plane above "5
units"; the sensor's stated accuracy is 0.20 oz in x and y, so the units are read as
ounces-force (1 ozf = 0.278 N).  Enter at 5 ozf (1.390 N), exit at 4 ozf (1.112 N): the
1 ozf hysteresis band is five times the stated accuracy, and a 3-sample debounce rejects
single-sample spikes.

Runs unchanged on MicroPython (the firmware's ``check``) and CPython.
"""

from tactile_protocol.constants import (
    CFG_AUTOSTART,
    CFG_GATE_3D,
    CFG_STREAM_CONTACTS,
    CFG_STREAM_SAMPLES,
    CFG_WRITABLE,
    FORCE_LSB_N,
    TORQUE_LSB_NM,
)

DEFAULT_RATE_HZ = 1000
DEFAULT_ENTER_UN = 1390000  # 5 ozf in uN
DEFAULT_EXIT_UN = 1112000  # 4 ozf in uN
DEFAULT_DEBOUNCE = 3
DEFAULT_FLAGS = CFG_STREAM_CONTACTS
MIN_RATE_HZ = 1
MAX_DEBOUNCE = 255

# CONFIG field indices, reported in NAK.detail
F_RATE = 0
F_ENTER = 1
F_EXIT = 2
F_DEBOUNCE = 3
F_FLAGS = 4


def check(rate_hz, enter, exit_, debounce, flags, max_rate_hz):
    """Index of the first CONFIG field out of range, or -1 if all are valid."""
    if not MIN_RATE_HZ <= rate_hz <= max_rate_hz:
        return F_RATE
    if enter < 0:
        return F_ENTER
    if not 0 <= exit_ <= enter:
        return F_EXIT
    if not 1 <= debounce <= MAX_DEBOUNCE:
        return F_DEBOUNCE
    if flags & ~CFG_WRITABLE:
        return F_FLAGS
    return -1


# --- in the units and names a user types -------------------------------------------------------
STREAMS = {"samples": CFG_STREAM_SAMPLES, "contacts": CFG_STREAM_CONTACTS}
GATES = {"xy": 0, "3d": CFG_GATE_3D}  # |F| in the sensor's x-y plane (§5.1), or 3-D
COUNTS_PER_N = round(1 / FORCE_LSB_N)  # 10^6: a force count is 1 uN
COUNTS_PER_NM = round(1 / TORQUE_LSB_NM)  # 10^6: a torque count is 1 uN*m
WRENCH_LSB = (FORCE_LSB_N,) * 3 + (TORQUE_LSB_NM,) * 3  # fx..tz counts -> N, N*m


def to_counts(newtons):
    """A force in N as the board's integer counts (1 uN)."""
    return round(newtons * COUNTS_PER_N)


def to_newtons(counts):
    """The board's force counts in N (1390000 -> 1.39 exactly as typed, not 1.3900...01)."""
    return counts / COUNTS_PER_N


def wrench_si(fx, fy, fz, tx, ty, tz):
    """A frame's six counts as (N, N, N, N*m, N*m, N*m)."""
    n, nm = COUNTS_PER_N, COUNTS_PER_NM
    return (fx / n, fy / n, fz / n, tx / nm, ty / nm, tz / nm)


DEFAULTS = {
    "rate_hz": DEFAULT_RATE_HZ,
    "enter_N": to_newtons(DEFAULT_ENTER_UN),
    "exit_N": to_newtons(DEFAULT_EXIT_UN),
    "debounce": DEFAULT_DEBOUNCE,
}


def gate_name(flags):
    """The gate mode ('xy' or '3d') of CONFIG/INFO flags."""
    return "3d" if flags & GATES["3d"] else "xy"


def config_flags(gate, streams, autostart=False):
    """CONFIG flags of a gate mode, stream names and autostart."""
    return GATES[gate] | stream_flags(streams) | (CFG_AUTOSTART if autostart else 0)


def stream_flags(names):
    """CONFIG stream bits of a list of stream names (``ValueError`` naming an unknown one)."""
    flags = 0
    for name in names:
        if name not in STREAMS:
            raise ValueError("unknown stream %r (%s)" % (name, ", ".join(STREAMS)))
        flags |= STREAMS[name]
    return flags


def stream_names(flags):
    return [name for name, bit in STREAMS.items() if flags & bit]
