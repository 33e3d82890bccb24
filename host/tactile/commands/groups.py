"""Group commands: ``tactile sim ep2``, ``tactile study ep1-noise``.

A group command's subcommands come in families, each a module that packages register in
the entry-point group ``tactile.commands.NAME`` (``tactile.commands.sim``: ``ep1`` from the
studies, ``ep2`` from the simulator).  A family module exposes ``SUBCOMMANDS = {name: (help,
add_arguments, run)}``.  Building the group's parser imports every family, so a family
module imports nothing heavy (NumPy, SciPy, the simulator's models) at module level: only
the chosen subcommand's ``run`` does.
"""

from importlib.metadata import entry_points

from tactile.commands import COMMANDS, absent


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
