"""The commands' one vocabulary: ``-o/--out`` for every output path, ``-q/--quiet`` for "no
progress display", ``$TACTILE_PORT`` for the board's port, and old spellings kept working as
hidden aliases that say once, on stderr, what replaced them.

``add_out`` adds ``-o/--out`` (plus hidden old long options); ``add_quiet`` adds
``-q/--quiet``; ``renamed`` maps an old choice value (``concave-cylinder``) to its one
spelling (``concave_cylinder``); ``contacts_of`` is what a command taking contacts reads of
a run folder (its ``contacts.csv``) or a CSV.
"""

import argparse
import pathlib
import sys

from tactile.errors import InputError
from tactile.output.text import printable

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
