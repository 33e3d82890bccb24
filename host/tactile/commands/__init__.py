"""What a ``tactile`` command is made of, for the CLI and for the packages that add commands
to it.

A command is a module with ``add_arguments(parser)`` and ``run(args) -> int``, or a ``Verb``
holding those two in a module that holds several commands; it parses, calls and prints, and
the work lives in a library.  ``tactile`` imports it only when it runs (or shows its help).
A ``Command`` names that module (``package.module``, or ``package.module:VERB``) and carries
the one line that ``tactile --help`` shows, so listing every command imports none of them.

``tactile.cli`` has a table of its own commands.  Other packages add theirs through entry
points (pyproject.toml), as python-can's interfaces do:

- group ``tactile.commands``: a command's name -> a ``Command`` (``emulate =
  "tactile_sim.commands:EMULATE"``);
- group ``tactile.commands.NAME``: a family of subcommands of the group command ``NAME``
  (``tactile sim ep1``) -> a module with ``SUBCOMMANDS`` (**group commands**, below);
- group ``tactile.ports``: a URL scheme -> a function that registers its pyserial handler
  (``sim = "tactile_sim.urlhandler:register"``), called when a port of that scheme is named.

A package whose commands are registered but not installed is left out; running one of its
commands says so in one line.  Also here, the words every command shares, and those
``tactile ep1`` and ``tactile sim ep1`` share (below); beside it, the post-run pipeline
that ``tactile record --pose-log`` and the chapter 5 replica share (``derive``: it draws on
the recording, the robot logs, localisation and EP1, so it sits above them all).  Nothing
here imports the CLI, the simulator or the studies, so each of them may import it.

**Group commands**: ``tactile sim ep2``, ``tactile study ep1-noise``.

A group command's subcommands come in families, each a module that packages register in
the entry-point group ``tactile.commands.NAME`` (``tactile.commands.sim``: ``ep1`` from the
studies, ``ep2`` from the simulator).  A family module exposes ``SUBCOMMANDS = {name: (help,
add_arguments, run)}``.  Building the group's parser imports every family, so a family
module imports nothing heavy (NumPy, SciPy, the simulator's models) at module level: only
the chosen subcommand's ``run`` does.

**The commands' one vocabulary**: ``-o/--out`` for every output path, ``-q/--quiet`` for "no
progress display", ``$TACTILE_PORT`` for the board's port, and old spellings kept working as
hidden aliases that say once, on stderr, what replaced them.

``add_out`` adds ``-o/--out`` (plus hidden old long options); ``add_quiet`` adds
``-q/--quiet``; ``renamed`` maps an old choice value (``concave-cylinder``) to its one
spelling (``concave_cylinder``); ``contacts_of`` is what a command taking contacts reads of
a run folder (its ``contacts.csv``) or a CSV.

**The EP1 estimate** as ``tactile ep1 estimate`` and ``tactile sim ep1`` take and show it: the
contact sensor's options, their checks, and the printed result.
"""

import argparse
import math
import pathlib
import sys
from collections.abc import Callable
from importlib.metadata import entry_points
from typing import NamedTuple

from tactile.errors import InputError
from tactile.output.text import dumps, printable

COMMANDS = "tactile.commands"
PORTS = "tactile.ports"


class Command(NamedTuple):
    """A command as ``tactile`` lists it: its module (imported when it runs), or the module
    and the name of its ``Verb`` there (``module:VERB``), and its help."""

    module: str
    help: str


class Verb(NamedTuple):
    """One of the commands a module holds: its ``add_arguments(parser)`` and ``run(args)``."""

    add_arguments: Callable
    run: Callable


def absent(error, module):
    """Whether ``error`` (a ModuleNotFoundError) says that ``module`` is not installed, itself
    or a package holding it, rather than that something it imports is missing."""
    missing = error.name or ""
    return bool(missing) and (module == missing or module.startswith(missing + "."))


def families(name):
    """The entry points of group command ``name``'s families, in registration order."""
    return entry_points(group=f"{COMMANDS}.{name}")


def add_group(parser, dest, found):
    """One subparser per subcommand of the families ``found`` (entry points); a family whose
    module is not installed is left out."""
    subs = parser.add_subparsers(dest=dest, metavar="NAME", required=True)
    for entry in found:
        try:
            module = entry.load()
        except ModuleNotFoundError as exc:
            if not absent(exc, entry.module):
                raise
            continue  # that family of subcommands is not in this build
        for name, (help_, add_arguments, run) in module.SUBCOMMANDS.items():
            sub = subs.add_parser(name, help=help_, description=help_)
            add_arguments(sub)
            sub.set_defaults(_run=run)


def run_group(args):
    return args._run(args)


OUT = ("-o", "--out")
ENV_PORT = "TACTILE_PORT"  # the port of every command that opens one, when --port is not given


def _note(prog, old, new):
    print(printable(f"{prog}: note: '{old}' is deprecated, use '{new}'"), file=sys.stderr)


class _OldSpelling(argparse.Action):
    """A hidden option: stores into the new option's dest and notes the rename."""

    def __init__(self, option_strings, dest, new="", **kwargs):
        super().__init__(option_strings, dest, **kwargs)
        self.new = new

    def __call__(self, parser, namespace, values, option_string=None):
        _note(parser.prog, option_string, self.new)
        setattr(namespace, self.dest, values)


def add_out(parser, help, old=(), required=False, **kwargs):
    """``-o/--out`` (dest ``out``) with ``help``; each of ``old`` still works, unlisted."""
    if not old:
        return parser.add_argument(*OUT, required=required, help=help, **kwargs)
    target = parser.add_mutually_exclusive_group(required=required) if required else parser
    action = target.add_argument(*OUT, help=help, **kwargs)
    for spelling in old:
        target.add_argument(
            spelling,
            dest="out",
            action=_OldSpelling,
            new="--out",
            help=argparse.SUPPRESS,
            metavar=action.metavar,
        )
    return action


def add_quiet(parser):
    """``-q/--quiet`` (dest ``quiet``): no progress display on stderr."""
    return parser.add_argument("-q", "--quiet", action="store_true", help="no progress display")


def renamed(old_to_new, prog=""):
    """An argparse ``type`` that turns an old value into its one spelling, with a note."""

    def convert(value):
        new = old_to_new.get(value)
        if new is None:
            return value
        _note(prog or "tactile", value, new)
        return new

    return convert


def contacts_of(path):
    """The contacts CSV that ``path`` names: the file itself, or a ``tactile record -o DIR``
    folder's ``contacts.csv`` (InputError, exit 2, for a folder without one)."""
    path = pathlib.Path(path)
    if not path.is_dir():
        return path
    csv_path = path / "contacts.csv"
    if not csv_path.is_file():
        raise InputError(
            f"{path}: no contacts.csv in this directory (expected 'tactile record -o {path}"
            " --pose-log LOG')"
        )
    return csv_path


CURVATURES = ("kx", "ky", "k1", "k2")
SHOWN = ("status", "kx", "ky", "k1", "k2", "direction1", "residual", "n_probes", "message")


def add_sensor_arguments(parser):
    parser.add_argument("--finger-radius", type=float, required=True, help="R1")
    parser.add_argument(
        "--resolution", type=float, default=0.0, help="contact sensor step (arc length), 0=exact"
    )
    parser.add_argument(
        "--noise-theta", type=float, default=0.0, help="rotation noise (rad, 1 sigma)"
    )


def check_sensor_arguments(args):
    if not 1e-300 <= args.finger_radius <= 1e300:
        raise InputError(
            f"--finger-radius: must be a number in [1e-300, 1e300], got {args.finger_radius}"
        )
    for name in ("resolution", "noise_theta"):
        value = getattr(args, name)
        if not (math.isfinite(value) and value >= 0):
            flag = "--" + name.replace("_", "-")
            raise InputError(f"{flag}: must be a non-negative number, got {value}")


def print_result(result, as_json, unit=None):
    """The estimate as JSON or ``key: value`` lines; curvatures in 1/``unit`` (the unit of
    --finger-radius) when it is given."""
    if as_json:
        if unit is not None:
            named = {k: f"1/{unit}" for k in CURVATURES} | {"residual": unit}
            result = {**result, "units": named}
        print(dumps(result))
        return
    for key in SHOWN:
        value = result.get(key)
        if isinstance(value, float):
            value = f"{value:.6g}"
        label = key
        if unit is not None and key in (*CURVATURES, "residual"):
            label = f"{key} ({unit})" if key == "residual" else f"{key} (1/{unit})"
        print(printable(f"{label:>14}: {value if value is not None else '-'}"))
