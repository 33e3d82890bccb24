"""tactile wire protocol: constants, CRC-16, COBS and message packing.

Runs unchanged on MicroPython and CPython: only ``struct`` is used, no
dataclasses, enum or typing.  The spec is ``protocol/PROTOCOL.md``.
"""

from tactile_protocol.constants import *  # noqa: F401,F403
