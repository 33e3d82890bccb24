"""``tactile completion bash|zsh|tcsh``: the shell completion script, made by ``shtab``.

Commands, subcommands, options and choices complete; file arguments complete as files.
Load it in bash with ``source <(tactile completion bash)`` (docs/cli.md).
"""

from tactile.cli.main import full_parser
from tactile.errors import InputError

SHELLS = ("bash", "zsh", "tcsh")
# Arguments that name a file or a directory: the shell completes paths for them.
PATHS = {"out", "file", "source", "capture", "run", "scene", "pose_log", "link"}


def add_arguments(parser):
    parser.add_argument("shell", choices=SHELLS, help="the shell to complete in")


def _mark_paths(parser, shtab):
    for action in parser._actions:
        if action.dest in PATHS:
            action.complete = shtab.FILE
        if isinstance(action.choices, dict):  # subcommands
            for sub in action.choices.values():
                _mark_paths(sub, shtab)


def run(args):
    try:
        import shtab
    except ImportError:  # a dependency since issue 15: an environment from before it
        raise InputError("shell completion needs shtab: pip install 'shtab>=1.7'") from None

    parser = full_parser()
    _mark_paths(parser, shtab)
    print(shtab.complete(parser, shell=args.shell), end="")  # escaped: our own parser's words
    return 0
