"""The project's error tree and its exit codes, one layer below every program that raises them.

The host library, the emulator and the CLI raise these; the CLI turns any of them into one
line and ``exit_code``.  The firmware raises builtins only.

- ``TactileError``: base; ``exit_code`` is what the CLI returns.
- ``InputError`` (2): bad user input; the message names file, line, column/field.
- ``MissingExtra`` (2): the command needs an optional extra or tool that is not installed;
  the message says how to install it.
- ``DataError`` (3): the data are well formed but do not determine a result.
- ``BoardError`` (IOError, 4): talking to a board or emulator failed.
- ``HostFileError`` (5): writing the host's own files failed (a full disk, a file-size
  limit, an I/O error); the message names the file and what was kept.

CPython only: MicroPython cannot derive one class from two built-in exceptions, so
``tactile flash`` leaves this module behind (``tactile.board.flashing.HOST_SIDE``).
"""


class TactileError(Exception):
    exit_code = 1


class InputError(TactileError, ValueError):
    exit_code = 2


class MissingExtra(TactileError):
    exit_code = 2


class DataError(TactileError):
    exit_code = 3


class BoardError(TactileError, IOError):
    exit_code = 4


class HostFileError(TactileError):
    exit_code = 5
