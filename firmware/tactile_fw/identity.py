"""What a board says about itself before it has a ``Board``: its firmware version and boot id.

Apart from ``board.py`` so that an entry point can name both without importing the whole
Python firmware: ``port_mpy`` picks the C core (``tactile_native``) when its version matches
``FW_VERSION``, and importing ``board`` and its modules costs a Pico about 1.3 s and 42 KB of
heap at boot (MicroPython compiles them from source).
"""

FW_VERSION = (0, 1, 0)


def boot_id_from(entropy):
    """Fold bytes that differ per power-up into a 32-bit boot id (FNV-1a)."""
    h = 0x811C9DC5
    for b in entropy:
        h = ((h ^ b) * 0x01000193) & 0xFFFFFFFF
    return h
