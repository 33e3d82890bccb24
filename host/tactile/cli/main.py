"""``tactile`` entry point: parse, run the chosen command, turn its errors into one line.

The commands ``tactile`` has: its own (``OWN``), and those other installed packages register
in the entry-point group ``tactile.commands`` (the simulator's ``emulate`` and ``sim``, the
studies' ``demo`` and ``study``), found as python-can finds its interfaces.  Each is a
``Command``: its module (and its ``Verb`` there, for a module that holds several commands),
imported only when it runs, and the line ``tactile --help`` shows.  The entry points are
read only when a name is not one of ``OWN``, for ``--help``, and for a port URL whose scheme
a package serves (group ``tactile.ports``), so the CLI itself never imports the simulator or
the studies (``tactile.commands``).

A command module defines ``add_arguments(parser)`` and ``run(args) -> int`` (a ``Verb``
holds the two); it only parses, calls and prints, and the work lives in the library.

``tactile completion bash|zsh|tcsh`` is here too: the shell completion script, made by
``shtab`` from the whole tree of parsers.  Commands, subcommands, options and choices
complete; file arguments complete as files.  Load it in bash with ``source <(tactile
completion bash)`` (docs/cli.md).
"""

import argparse
import difflib
import importlib
import logging
import os
import re
import sys
from importlib.metadata import entry_points

from tactile import __version__
from tactile.commands import COMMANDS, ENV_PORT, PORTS, Command, Verb, absent
from tactile.errors import InputError, TactileError
from tactile.output.text import Escaped, printable


class Parser(argparse.ArgumentParser):
    """argparse as the CLI's errors want it: a bad option value is one line (no usage
    block), exit 2; a value that looks like a negative number, exponent and all
    (``--volts-per-count -3e-9``), is a value, not an option.  Subparsers are of this
    class too (argparse makes them of their parent's)."""

    def __init__(self, *args, **kwargs):
        super().__init__(*args, **kwargs)
        self._negative_number_matcher = NEGATIVE_NUMBER

    def error(self, message):  # (the message may quote what was typed)
        said = f"{message}{did_you_mean(self, message)}"
        self.exit(2, printable(f"{self.prog}: error: {said} (see '{self.prog} --help')") + "\n")


# argparse's own pattern takes -3 and -.5 but not -3e-9, which it then reads as an option
NEGATIVE_NUMBER = re.compile(r"^-(?:[0-9]+\.?[0-9]*|\.[0-9]+)(?:[eE][+-]?[0-9]+)?$")
CHOICE = re.compile(r"argument ([^:]+): invalid choice: '([^']*)'")
UNKNOWN = re.compile(r"unrecognized arguments: (.*)$")


def did_you_mean(parser, message):
    """``; did you mean 'record'?`` for a mistyped command, subcommand or choice (argparse's
    ``invalid choice``) or option (``unrecognized arguments``), when one is close
    (difflib, as Python 3.12's ``suggest_on_error``); else ''."""
    actions = [a for p in (parser, *_subparsers(parser)) for a in p._actions]
    if found := CHOICE.search(message):  # (argparse names an argument as below)
        named = [a for a in actions if found[1] in ("/".join(a.option_strings), a.metavar)]
        typed, known = found[2], [str(c) for a in named if a.choices for c in a.choices]
    elif found := UNKNOWN.search(message):
        words = [w for w in found[1].split() if w.startswith("-")]
        typed = words[0].split("=")[0] if words else ""
        known = [o for a in actions for o in a.option_strings if o.startswith("--")]
    else:
        return ""
    close = difflib.get_close_matches(typed, known, n=1, cutoff=0.6) if typed else []
    return f"; did you mean '{close[0]}'?" if close else ""


def _top_parser(names, listed=None):
    """``tactile``'s own parser: ``--version``, and ``COMMAND`` one of ``names`` (None: no
    positional); ``listed`` (name -> Command) are the commands its help lists."""
    listed = commands() if listed is None else listed
    width = max(map(len, listed), default=0)
    lines = [f"  {name:<{width}}  {command.help}" for name, command in listed.items()]
    parser = Parser(
        prog="tactile",
        description="Tactile shape exploration: board, emulator, EP1 and EP2.",
        epilog="commands:\n" + "\n".join(lines) + "\n\n'tactile COMMAND --help' for details.",
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument("--version", action="version", version=f"tactile {__version__}")
    if names is not None:
        parser.add_argument("command", choices=names, metavar="COMMAND")
    return parser


class _Help(argparse.HelpFormatter):
    """Help that shows each option's default once, where it has one worth showing: not
    when the help already speaks of its default."""

    def _get_help_string(self, action):
        text = action.help or ""
        default = action.default
        if default is None or default is argparse.SUPPRESS or isinstance(default, bool | list):
            return text  # (`is`: a default of 0 is shown, though 0 == False)
        if isinstance(action, argparse._CountAction) or not action.option_strings:
            return text
        if "default" in text:
            return text
        said = {str(default)} | ({f"{default:g}"} if isinstance(default, float) else set())
        if any(f"({v}" in text for v in said):
            return text  # "readings averaged (64)"
        shown = " ".join(map(str, default)) if isinstance(default, tuple) else str(default)
        return f"{text} (default: {shown.replace('%', '%%')})"


VERBOSE_HELP = "log progress (-vv: each frame)"


def _command_parser(name, module, help_, parser=None):
    """``tactile NAME``'s parser: the module's options, and -v/--verbose on it and on each
    of its subcommands, so that -v goes anywhere after the command."""
    if parser is None:
        parser = Parser(prog=f"tactile {name}", description=help_, formatter_class=_Help)
    module.add_arguments(parser)
    parser.add_argument("-v", "--verbose", action="count", default=0, help=VERBOSE_HELP)
    for sub in _subparsers(parser):
        sub.formatter_class = _Help
        # SUPPRESS: a subcommand without -v keeps what was given before its name
        sub.add_argument(
            "-v", "--verbose", action="count", default=argparse.SUPPRESS, help=VERBOSE_HELP
        )
    return parser


def _subparsers(parser):
    """Every subcommand's parser below ``parser``, subcommands of subcommands included."""
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for sub in action.choices.values():
                yield sub
                yield from _subparsers(sub)


def full_parser():
    """The whole tree in one parser (every command a subparser), for shell completion:
    ``main`` itself builds only the parser of the command it runs."""
    listed = commands()
    top = _top_parser(None, listed)
    subs = top.add_subparsers(dest="command", metavar="COMMAND")
    for name in listed:
        try:
            module, command = load(name)
        except TactileError:
            continue  # not in this build
        help_ = command.help
        sub = subs.add_parser(name, help=help_, description=help_, formatter_class=_Help)
        _command_parser(name, module, help_, sub)
    return top


def _logging(verbose):
    """-v: what the tool does (INFO), -vv: every frame and command (DEBUG), on stderr, for
    this call only: returns the undo (``main`` may run many times in one process).  Each
    line escaped; the libraries the project adopts log here too (``tactile.output.text``)."""
    logger = logging.getLogger("tactile")
    handler = logging.StreamHandler(sys.stderr)
    handler.setFormatter(Escaped("tactile %(name)s: %(message)s"))
    level = logger.level
    logger.addHandler(handler)
    logger.setLevel(logging.INFO if verbose == 1 else logging.DEBUG)

    def undo():
        logger.removeHandler(handler)
        logger.setLevel(level)

    return undo


def _command_named(argv):
    """The command ``argv`` names (its parser refuses another), or None when ``argv`` asks
    for ``tactile``'s own help or version (printed here)."""
    if not argv or argv[0].startswith("-"):
        _top_parser(names()).parse_args(argv or ["--help"])
        return None
    name = argv[0]
    if name not in OWN:
        _top_parser(names(), {}).parse_args(argv[:1])  # refuses an unknown name
    return name


def main(argv=None):
    argv = sys.argv[1:] if argv is None else list(argv)
    serve_ports([*argv, os.environ.get(ENV_PORT, "")])
    name = _command_named(argv)
    if name is None:
        return 0
    try:
        module, command = load(name)
        args = _command_parser(name, module, command.help).parse_args(argv[1:])
        undo = _logging(args.verbose) if args.verbose else None
        try:
            return int(module.run(args) or 0)
        finally:
            if undo is not None:
                undo()
    except TactileError as exc:  # a message may quote a file's text, a path, a device
        print(printable(f"tactile {name}: error: {exc}"), file=sys.stderr)
        return exc.exit_code
    except KeyboardInterrupt:
        print(printable(f"tactile {name}: interrupted"), file=sys.stderr)
        return 130
    except BrokenPipeError:
        return 0


# The CLI's own commands, in the order ``tactile --help`` lists them.
OWN = {
    "ports": Command("tactile.cli.cmd_board:PORTS", "list serial ports"),
    "info": Command("tactile.cli.cmd_board:INFO", "show a board's INFO"),
    "config": Command("tactile.cli.cmd_board:CONFIG", "set sample rate, contact gate and streams"),
    "tare": Command("tactile.cli.cmd_board:TARE", "bias the F/T sensor"),
    "calibrate": Command(
        "tactile.cli.cmd_calibrate:CALIBRATE", "load a 6x6 calibration matrix onto a sensor"
    ),
    "record": Command(
        "tactile.cli.cmd_record", "record a stream: raw capture, contacts CSV, metadata"
    ),
    "live": Command("tactile.cli.cmd_live", "terminal view of force/torque and contact state"),
    "decode": Command(
        "tactile.cli.cmd_board:DECODE",
        "decode a raw byte capture: one message per line (text or --json)",
    ),
    "export": Command(
        "tactile.cli.cmd_export", "write a recording as MCAP (ROS 2) or Parquet for other tools"
    ),
    "flash": Command("tactile.cli.cmd_board:FLASH", "copy the firmware onto a MicroPython board"),
    "ep1": Command("tactile.cli.cmd_ep1", "EP1: curvature at a point from rolling probes (ch. 3)"),
    "ep2": Command("tactile.cli.cmd_ep2", "EP2: patch fit and shape classification (ch. 4)"),
    "payload": Command(
        "tactile.cli.cmd_calibrate:PAYLOAD",
        "identify the tool's weight (mass, centre of mass, biases)",
    ),
    "explore": Command(
        "tactile.cli.cmd_explore", "touch where the patch is least known until its label is sure"
    ),
    "plot": Command("tactile.cli.cmd_plot", "draw contacts, fitted patches and S/C maps as PNG"),
    "completion": Command("tactile.cli.main:COMPLETION", "print a bash/zsh/tcsh completion script"),
}


def _plugins():
    """name -> entry point of each command another package registers (not one of ``OWN``)."""
    return {e.name: e for e in entry_points(group=COMMANDS) if e.name not in OWN}


def names():
    """Every command's name: the CLI's own, then the registered ones."""
    return [*OWN, *_plugins()]


def commands():
    """name -> ``Command`` of every command that is installed, in ``names`` order."""
    found = dict(OWN)
    for name, entry in _plugins().items():
        try:
            found[name] = entry.load()
        except ModuleNotFoundError as exc:
            if not absent(exc, entry.module):
                raise
    return found


def find(name):
    """The ``Command`` called ``name``."""
    return OWN[name] if name in OWN else _plugins()[name].load()


def load(name):
    """The module (or ``Verb``) of command ``name``, and its ``Command``; a TactileError (one
    line) when a module it needs is not installed (a package left out of this build)."""
    try:
        command = find(name)
        path, _, verb = command.module.partition(":")
        module = importlib.import_module(path)
        return (getattr(module, verb) if verb else module), command
    except ModuleNotFoundError as exc:
        raise TactileError(
            f"'{name}' is not available in this build: module {exc.name} is not installed"
        ) from None


def serve_ports(words):
    """Register the pyserial handler of each URL scheme a package serves (group
    ``tactile.ports``) that one of ``words`` (the arguments, ``$TACTILE_PORT``) names."""
    if not any("://" in word for word in words):
        return
    for entry in entry_points(group=PORTS):
        if any(f"{entry.name}://" in word for word in words):
            entry.load()()


SHELLS = ("bash", "zsh", "tcsh")
# Arguments that name a file or a directory: the shell completes paths for them.
PATHS = {"out", "file", "source", "capture", "run", "scene", "pose_log", "link"}


def add_completion_arguments(parser):
    parser.add_argument("shell", choices=SHELLS, help="the shell to complete in")


def _mark_paths(parser, shtab):
    for action in parser._actions:
        if action.dest in PATHS:
            action.complete = shtab.FILE
        if isinstance(action.choices, dict):  # subcommands
            for sub in action.choices.values():
                _mark_paths(sub, shtab)


def run_completion(args):
    try:
        import shtab
    except ImportError:  # a dependency since issue 15: an environment from before it
        raise InputError("shell completion needs shtab: pip install 'shtab>=1.7'") from None

    parser = full_parser()
    _mark_paths(parser, shtab)
    print(shtab.complete(parser, shell=args.shell), end="")  # escaped: our own parser's words
    return 0


COMPLETION = Verb(add_completion_arguments, run_completion)


if __name__ == "__main__":
    sys.exit(main())
