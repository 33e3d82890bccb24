"""What a board says about itself before it has a ``Board``: its firmware version, its boot id
and its board id.

Apart from ``board.py`` so that an entry point can name both without importing the whole
Python firmware: ``port_mpy`` picks the C core (``tactile_native``) when its version matches
``FW_VERSION``, and importing ``board`` and its modules costs a Pico about 1.3 s and 42 KB of
heap at boot (MicroPython compiles them from source).

The board id (HELLO/INFO ``board_id``, 8 bytes) names the board for its whole life: on a
Pico the flash chip's unique id (``machine.unique_id()``), elsewhere what the entry point
injects (``board_id_from`` makes any id 8 bytes).  ``NO_BOARD_ID`` (8 zero bytes) is a board
that has none.
"""

from tactile_protocol.constants import BOARD_ID_SIZE

FW_VERSION = (0, 1, 0)
NO_BOARD_ID = bytes(BOARD_ID_SIZE)


def boot_id_from(entropy):
    """Fold bytes that differ per power-up into a 32-bit boot id (FNV-1a)."""
    h = 0x811C9DC5
    for b in entropy:
        h = ((h ^ b) * 0x01000193) & 0xFFFFFFFF
    return h


def board_id_from(raw):
    """A chip's unique id as HELLO's 8-byte ``board_id``: as it is when it has 8 bytes (the
    RP2040's), NUL-padded when shorter, folded (bytes xored in turn) when longer."""
    out = bytearray(BOARD_ID_SIZE)
    for i, b in enumerate(bytes(raw)):
        out[i % BOARD_ID_SIZE] ^= b
    return bytes(out)
