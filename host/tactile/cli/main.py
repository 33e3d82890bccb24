"""``tactile`` entry point: parse, run the chosen command, turn its errors into one line.

The commands are those ``tactile.cli.registry`` finds (the CLI's own and those other packages
register); only the chosen command's module is imported.  A command module defines
``add_arguments(parser)`` and ``run(args) -> int``; it only parses, calls and prints, and the
work lives in the library.
"""

import argparse
import difflib
import logging
import os
import re
import sys

from tactile import __version__
from tactile.cli import registry
from tactile.commands import ENV_PORT
from tactile.errors import TactileError
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
    listed = registry.commands() if listed is None else listed
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
    listed = registry.commands()
    top = _top_parser(None, listed)
    subs = top.add_subparsers(dest="command", metavar="COMMAND")
    for name in listed:
        try:
            module, command = registry.load(name)
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
        _top_parser(registry.names()).parse_args(argv or ["--help"])
        return None
    name = argv[0]
    if name not in registry.OWN:
        _top_parser(registry.names(), {}).parse_args(argv[:1])  # refuses an unknown name
    return name


def main(argv=None):
    argv = sys.argv[1:] if argv is None else list(argv)
    registry.serve_ports([*argv, os.environ.get(ENV_PORT, "")])
    name = _command_named(argv)
    if name is None:
        return 0
    try:
        module, command = registry.load(name)
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


if __name__ == "__main__":
    sys.exit(main())
