"""The host's error tree.  The CLI turns any of these into one line and an exit code.

The tree and its exit codes are the protocol layer's (``tactile_protocol.errors``), shared
with the emulator; the host adds the refinements of ``BoardError`` and ``where``.

- ``TactileError``: base; ``exit_code`` is what the CLI returns.
- ``InputError`` (2): bad user input; the message names file, line, column/field.
- ``MissingExtra`` (2): the command needs an optional extra that is not installed; the
  message says how to install it (``tactile.errors``).
- ``DataError`` (3): the data are well formed but do not determine a result.
- ``BoardError`` (IOError, 4): talking to a board or emulator failed;
  ``BoardTimeout``, ``ProtocolVersionError`` and ``PortError`` refine it;
  ``PortLost`` (a ``PortError``) is a port that stopped working once open.
- ``HostFileError`` (5): writing the host's own files failed (a full disk, a file-size
  limit, an I/O error); the message names the file and what was kept.

**The optional extras** (``[project.optional-dependencies]`` of pyproject.toml), in one place.

``need`` imports what one extra provides, or raises ``MissingExtra`` whose one line says
which extra and how to install it.  Modules call it inside the function that uses the
extra, so a run that does not need it never imports it (tests check the CLI's imports).
"""

import importlib

from tactile_protocol.errors import (
    BoardError,
    DataError,
    HostFileError,
    InputError,
    MissingExtra,
    TactileError,
)

__all__ = [
    "BoardError",
    "BoardTimeout",
    "DataError",
    "HostFileError",
    "InputError",
    "MissingExtra",
    "PortError",
    "PortLost",
    "ProtocolVersionError",
    "TactileError",
    "where",
]


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


DISTRIBUTION = "tactile-shape"


def hint(extra, purpose):
    """The one line a user sees: '<purpose> needs the '<extra>' extra: pip install ...'."""
    return f"{purpose} needs the '{extra}' extra: pip install '{DISTRIBUTION}[{extra}]'"


def need(extra, purpose, *modules):
    """The ``modules`` imported (a tuple, in order), or ``MissingExtra`` (``hint``)."""
    try:
        return tuple(importlib.import_module(name) for name in modules)
    except ImportError:
        raise MissingExtra(hint(extra, purpose)) from None


def pyplot():
    """``matplotlib.pyplot`` on the Agg backend (files only, no display), or ``MissingExtra``."""
    (matplotlib,) = need("plot", "Plotting", "matplotlib")
    matplotlib.use("Agg")
    return need("plot", "Plotting", "matplotlib.pyplot")[0]
