"""tactile wire protocol: constants, CRC-16, COBS and message packing.

Runs unchanged on MicroPython and CPython: only ``struct`` is used, no
dataclasses, enum or typing.  The spec is ``protocol/PROTOCOL.md``.  Each part is
imported from its own module (``tactile_protocol.constants``, ``.framing`` ...): the
package itself names nothing, so importing one part on the board loads no other.
"""
