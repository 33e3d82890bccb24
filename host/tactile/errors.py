"""The host's error tree.  The CLI turns any of these into one line and an exit code.

The tree and its exit codes are the protocol layer's (``tactile_protocol.errors``), shared
with the emulator; the host adds the refinements of ``BoardError`` and ``where``.

- ``TactileError``: base; ``exit_code`` is what the CLI returns.
- ``InputError`` (2): bad user input; the message names file, line, column/field.
- ``MissingExtra`` (2): the command needs an optional extra that is not installed; the
  message says how to install it (``tactile.extras``).
- ``DataError`` (3): the data are well formed but do not determine a result.
- ``BoardError`` (IOError, 4): talking to a board or emulator failed;
  ``BoardTimeout``, ``ProtocolVersionError`` and ``PortError`` refine it;
  ``PortLost`` (a ``PortError``) is a port that stopped working once open.
- ``HostFileError`` (5): writing the host's own files failed (a full disk, a file-size
  limit, an I/O error); the message names the file and what was kept.
"""

from tactile_protocol.errors import (
    BoardError,
    DataError,
    HostFileError,
    InputError,
    MissingExtra,
    TactileError,
)

__all__ = ["BoardError", "BoardTimeout", "DataError", "HostFileError", "InputError",
           "MissingExtra", "PortError", "PortLost", "ProtocolVersionError", "TactileError",
           "where"]  # fmt: skip


class BoardTimeout(BoardError):
    pass


class ProtocolVersionError(BoardError):
    pass


class PortError(BoardError):
    """The serial port is missing, busy or not permitted."""


class PortLost(PortError):
    """An open port stopped working: the board was unplugged or reset, the emulator died."""


def where(path, line=None, column=None):
    """Format a location prefix: ``file.csv:12: column 'nz'``."""
    out = str(path)
    if line is not None:
        out += f":{line}"
    if column is not None:
        out += f": column '{column}'"
    return out
