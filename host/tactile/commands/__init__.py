"""What a ``tactile`` command is made of, for the CLI and for the packages that add commands
to it.

A command is a module with ``add_arguments(parser)`` and ``run(args) -> int``; it parses,
calls and prints, and the work lives in a library.  ``tactile`` imports it only when it runs
(or shows its help).  A ``Command`` names that module and carries the one line that
``tactile --help`` shows, so listing every command imports none of them.

``tactile.cli`` has a table of its own commands.  Other packages add theirs through entry
points (pyproject.toml), as python-can's interfaces do:

- group ``tactile.commands``: a command's name -> a ``Command`` (``emulate =
  "tactile_sim.commands:EMULATE"``);
- group ``tactile.commands.NAME``: a family of subcommands of the group command ``NAME``
  (``tactile sim ep1``) -> a module with ``SUBCOMMANDS`` (``groups``);
- group ``tactile.ports``: a URL scheme -> a function that registers its pyserial handler
  (``sim = "tactile_sim.urlhandler:register"``), called when a port of that scheme is named.

A package whose commands are registered but not installed is left out; running one of its
commands says so in one line.  Also here, the words every command shares (``words``), those
``tactile ep1`` and ``tactile sim ep1`` share (``ep1_estimate``), and the post-run pipeline
that ``tactile record --pose-log`` and the chapter 5 replica share (``derive``: it draws on
the recording, the robot logs, localisation and EP1, so it sits above them all).  Nothing
here imports the CLI, the simulator or the studies, so each of them may import it.
"""

from typing import NamedTuple

COMMANDS = "tactile.commands"
PORTS = "tactile.ports"

__all__ = ["COMMANDS", "PORTS", "Command", "absent"]


class Command(NamedTuple):
    """A command as ``tactile`` lists it: its module (imported when it runs) and its help."""

    module: str
    help: str


def absent(error, module):
    """Whether ``error`` (a ModuleNotFoundError) says that ``module`` is not installed, itself
    or a package holding it, rather than that something it imports is missing."""
    missing = error.name or ""
    return bool(missing) and (module == missing or module.startswith(missing + "."))
