"""Second-level subcommands (``tactile sim ep2``, ``tactile study ep1-noise``).

A group lists modules; each module exposes ``SUBCOMMANDS = {name: (help,
add_arguments, run)}``.  Group modules must not import NumPy or SciPy at
module level: only the chosen subcommand's ``run`` does heavy imports.
"""

import importlib


def add_group(parser, modules, dest):
    subs = parser.add_subparsers(dest=dest, metavar="NAME", required=True)
    for module_name in modules:
        try:
            module = importlib.import_module(module_name)
        except ModuleNotFoundError as exc:
            if exc.name != module_name:
                raise
            continue  # that family of subcommands is not in this build
        for name, (help_, add_arguments, run) in module.SUBCOMMANDS.items():
            sub = subs.add_parser(name, help=help_, description=help_)
            add_arguments(sub)
            sub.set_defaults(_run=run)


def run_group(args):
    return args._run(args)
