"""The board-settings vocabulary as the host uses it: the protocol's, plus ``problem``.

Units, stream and gate names, limits and defaults are ``tactile_protocol.settings`` (the
firmware checks the same rule and NAKs the field; the emulator reads the same names), named
here too so that the host's modules keep one import.  ``problem`` words the rule in the
units and options a user types.  No numpy: the CLI's parsing imports it.
"""

from tactile_protocol.settings import (
    COUNTS_PER_N,
    COUNTS_PER_NM,
    DEFAULTS,
    GATES,
    MAX_DEBOUNCE,
    MIN_RATE_HZ,
    STREAMS,
    WRENCH_LSB,
    config_flags,
    gate_name,
    stream_flags,
    stream_names,
    to_counts,
    to_newtons,
    wrench_si,
)

__all__ = ["COUNTS_PER_N", "COUNTS_PER_NM", "DEFAULTS", "GATES", "STREAMS", "WRENCH_LSB",
           "config_flags", "gate_name", "problem", "stream_flags", "stream_names", "to_counts",
           "to_newtons", "wrench_si"]  # fmt: skip


def problem(rate_hz, enter_N, exit_N, debounce, max_rate_hz):
    """None, or one line naming the first value out of range and the range allowed
    (the firmware's ``settings.check``, in the units a user types)."""
    if not MIN_RATE_HZ <= rate_hz <= max_rate_hz:
        allowed = f"{MIN_RATE_HZ}..{max_rate_hz} Hz on this board"
        return f"--rate: {rate_hz} Hz is out of range: {allowed}"
    if not 0 <= to_counts(enter_N):
        return f"--enter: {enter_N:g} N is out of range: 0 N or more"
    if not 0 <= to_counts(exit_N) <= to_counts(enter_N):
        return f"--exit: {exit_N:g} N is out of range: 0..{enter_N:g} N (at most --enter)"
    if not 1 <= debounce <= MAX_DEBOUNCE:
        return f"--debounce: {debounce} is out of range: 1..{MAX_DEBOUNCE} readings"
    return None
