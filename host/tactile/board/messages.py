"""Host-side message objects, generated from the protocol's one table (``SPECS``).

Each message type is a named tuple ``(seq, timestamp_us, *fields)`` with
class attributes ``type_code`` and ``type_name``.  ``to_dict`` gives the
JSON form used by ``tactile decode``: text fields (``sensor_model``) as text, the binary
``board_id`` as hex digits (None in a HELLO/INFO of a version without it).  Units:
PROTOCOL.md §4.

``Invalid`` stands in for a frame whose framing and layout are good but whose
content breaks the protocol's limits (``tactile_protocol.limits``): it names the
message type it claimed to be and the field that is wrong, and carries none of
the values, so nothing downstream can act on a lie.
"""

from collections import namedtuple

from tactile_protocol.messages import SPECS

BINARY = ("board_id",)  # bytes fields that are not text


def board_id_text(board_id):
    """A HELLO/INFO ``board_id`` in words: 16 hex digits, or "none" (a version without it)."""
    return "none" if board_id is None else bytes(board_id).hex()


def _to_dict(self):
    out = {"type": self.type_name}
    for name, value in zip(self._fields, self):
        if isinstance(value, bytes):
            binary = name in BINARY
            value = value.hex() if binary else value.rstrip(b"\0").decode("ascii", "replace")
        out[name] = value
    return out


def _make(mtype, name, fields):
    cls = namedtuple(name.title().replace("_", ""), ("seq", "timestamp_us") + tuple(fields))
    cls.type_code = mtype
    cls.type_name = name
    cls.to_dict = _to_dict
    return cls


CLASSES = {mtype: _make(mtype, name, fields) for mtype, name, _, fields in SPECS}
BY_NAME = {cls.type_name: cls for cls in CLASSES.values()}

Hello = BY_NAME["HELLO"]
Info = BY_NAME["INFO"]
Sample = BY_NAME["SAMPLE"]
Contact = BY_NAME["CONTACT"]
Status = BY_NAME["STATUS"]
Ack = BY_NAME["ACK"]
Nak = BY_NAME["NAK"]

INVALID = 0  # not a wire type: the type code of ``Invalid``
Invalid = _make(INVALID, "INVALID", ("message", "error"))
