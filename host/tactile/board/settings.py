"""The board-settings vocabulary, in one place: units, stream and gate names, limits.

The board stores forces as integers of ``FORCE_LSB_N`` (1 uN) and settings as CONFIG's
five fields (rate, enter, exit, debounce, flags).  What a user types is newtons, stream
names and gate modes; the limits and defaults are the firmware's own (``tactile_fw.settings``,
the board checks the same rule and NAKs the field).  No numpy: the CLI's parsing imports it.
"""

from tactile_fw import settings as fw
from tactile_protocol import constants as C

STREAMS = {"samples": C.CFG_STREAM_SAMPLES, "contacts": C.CFG_STREAM_CONTACTS}
GATES = {"xy": 0, "3d": C.CFG_GATE_3D}  # |F| in the sensor's x-y plane (§5.1), or 3-D
COUNTS_PER_N = round(1 / C.FORCE_LSB_N)  # 10^6: a force count is 1 uN
COUNTS_PER_NM = round(1 / C.TORQUE_LSB_NM)  # 10^6: a torque count is 1 uN*m
WRENCH_LSB = (C.FORCE_LSB_N,) * 3 + (C.TORQUE_LSB_NM,) * 3  # fx..tz counts -> N, N*m


def to_counts(newtons):
    """A force in N as the board's integer counts (1 uN)."""
    return round(newtons * COUNTS_PER_N)


def to_newtons(counts):
    """The board's force counts in N (1390000 -> 1.39 exactly as typed, not 1.3900...01)."""
    return counts / COUNTS_PER_N


def wrench_si(fx, fy, fz, tx, ty, tz):
    """A frame's six counts as (N, N, N, N*m, N*m, N*m)."""
    return (*(v / COUNTS_PER_N for v in (fx, fy, fz)), *(v / COUNTS_PER_NM for v in (tx, ty, tz)))


DEFAULTS = {
    "rate_hz": fw.DEFAULT_RATE_HZ,
    "enter_N": to_newtons(fw.DEFAULT_ENTER_UN),
    "exit_N": to_newtons(fw.DEFAULT_EXIT_UN),
    "debounce": fw.DEFAULT_DEBOUNCE,
}


def gate_name(flags):
    """The gate mode ('xy' or '3d') of CONFIG/INFO flags."""
    return "3d" if flags & GATES["3d"] else "xy"


def config_flags(gate, streams, autostart=False):
    """CONFIG flags of a gate mode, stream names and autostart."""
    return GATES[gate] | stream_flags(streams) | (C.CFG_AUTOSTART if autostart else 0)


def stream_flags(names):
    """CONFIG stream bits of a list of stream names (``ValueError`` naming an unknown one)."""
    flags = 0
    for name in names:
        if name not in STREAMS:
            raise ValueError(f"unknown stream {name!r} ({', '.join(STREAMS)})")
        flags |= STREAMS[name]
    return flags


def stream_names(flags):
    return [name for name, bit in STREAMS.items() if flags & bit]


def problem(rate_hz, enter_N, exit_N, debounce, max_rate_hz):
    """None, or one line naming the first value out of range and the range allowed
    (the firmware's ``settings.check``, in the units a user types)."""
    if not fw.MIN_RATE_HZ <= rate_hz <= max_rate_hz:
        allowed = f"{fw.MIN_RATE_HZ}..{max_rate_hz} Hz on this board"
        return f"--rate: {rate_hz} Hz is out of range: {allowed}"
    if not 0 <= to_counts(enter_N):
        return f"--enter: {enter_N:g} N is out of range: 0 N or more"
    if not 0 <= to_counts(exit_N) <= to_counts(enter_N):
        return f"--exit: {exit_N:g} N is out of range: 0..{enter_N:g} N (at most --enter)"
    if not 1 <= debounce <= fw.MAX_DEBOUNCE:
        return f"--debounce: {debounce} is out of range: 1..{fw.MAX_DEBOUNCE} readings"
    return None
