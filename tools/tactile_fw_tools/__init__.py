"""Tooling beside the firmware that runs under CPython only, never on a board.

- ``ccore``: the C core (``firmware/c``) built with ``cc`` and driven through ctypes;
- ``cross``: the C core cross-compiled for QEMU's micro:bit (``make firmware-c``);
- ``natmod``: the C core as the Pico's native module (``make natmod``);
- ``c_tables``: the C tables generated from ``tactile_protocol`` and ``tactile_fw``;
- ``port_linux``: the firmware on a Linux controller (the one place that imports ``smbus2``).

Its own import package, outside ``tactile_fw``: ``tactile flash`` copies the firmware
package whole, and none of this is in it.
"""
