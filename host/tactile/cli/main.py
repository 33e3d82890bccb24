"""``tactile`` entry point: a registry of subcommands, each imported only when used.

A subcommand module defines ``add_arguments(parser)`` and ``run(args) -> int``.
Modules only parse, call and print; the work lives in the library.
"""

import argparse
import importlib
import re
import sys

from tactile import __version__
from tactile.errors import TactileError
from tactile.output.textout import printable

# name -> (module, one-line help).  Keep alphabetical within groups.
COMMANDS = {
    "demo": ("tactile.cli.cmd_demo", "run the main job on the board emulator and print the result"),
    "ports": ("tactile.cli.cmd_ports", "list serial ports"),
    "info": ("tactile.cli.cmd_info", "show a board's INFO"),
    "config": ("tactile.cli.cmd_config", "set sample rate, contact gate and streams"),
    "tare": ("tactile.cli.cmd_tare", "bias the F/T sensor"),
    "calibrate": ("tactile.cli.cmd_calibrate", "load a 6x6 calibration matrix onto a sensor"),
    "record": ("tactile.cli.cmd_record", "record a stream: raw capture, contacts CSV, metadata"),
    "live": ("tactile.cli.cmd_live", "terminal view of force/torque and contact state"),
    "decode": (
        "tactile.cli.cmd_decode",
        "decode a raw byte capture: one message per line (text or --json)",
    ),
    "export": (
        "tactile.cli.cmd_export",
        "write a recording as MCAP (ROS 2) or Parquet for other tools",
    ),
    "emulate": ("tactile.cli.cmd_emulate", "serve a simulated board on a pseudo-terminal"),
    "flash": ("tactile.cli.cmd_flash", "copy the firmware onto a MicroPython board"),
    "ep1": ("tactile.cli.cmd_ep1", "EP1: curvature at a point from rolling probes (ch. 3)"),
    "ep2": ("tactile.cli.cmd_ep2", "EP2: patch fit and shape classification (ch. 4)"),
    "sim": ("tactile.cli.cmd_sim", "simulate EP1 probes or EP2 sweeps into files"),
    "study": ("tactile.cli.cmd_study", "reproduce the thesis's simulation studies"),
    "plot": ("tactile.cli.cmd_plot", "draw contacts, fitted patches and S/C maps as PNG"),
    "completion": ("tactile.cli.cmd_completion", "print a bash/zsh/tcsh completion script"),
}


class Parser(argparse.ArgumentParser):
    """argparse as the CLI's errors want it: a bad option value is one line (no usage
    block), exit 2; a value that looks like a negative number, exponent and all
    (``--volts-per-count -3e-9``), is a value, not an option.  Subparsers are of this
    class too (argparse makes them of their parent's)."""

    def __init__(self, *args, **kwargs):
        super().__init__(*args, **kwargs)
        self._negative_number_matcher = NEGATIVE_NUMBER

    def error(self, message):  # (the message may quote what was typed)
        self.exit(2, printable(f"{self.prog}: error: {message} (see '{self.prog} --help')") + "\n")


# argparse's own pattern takes -3 and -.5 but not -3e-9, which it then reads as an option
NEGATIVE_NUMBER = re.compile(r"^-(?:[0-9]+\.?[0-9]*|\.[0-9]+)(?:[eE][+-]?[0-9]+)?$")


def _top_parser(positional=True):
    width = max(map(len, COMMANDS))
    lines = [f"  {name:<{width}}  {help_}" for name, (_, help_) in COMMANDS.items()]
    parser = Parser(
        prog="tactile",
        description="Tactile shape exploration: board, emulator, EP1 and EP2.",
        epilog="commands:\n" + "\n".join(lines) + "\n\n'tactile COMMAND --help' for details.",
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument("--version", action="version", version=f"tactile {__version__}")
    if positional:
        parser.add_argument("command", choices=list(COMMANDS), metavar="COMMAND")
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
    top = _top_parser(positional=False)
    subs = top.add_subparsers(dest="command", metavar="COMMAND")
    for name in COMMANDS:
        try:
            module, help_ = _load(name)
        except TactileError:
            continue  # not in this build
        sub = subs.add_parser(name, help=help_, description=help_, formatter_class=_Help)
        _command_parser(name, module, help_, sub)
    return top


def _logging(verbose):
    """-v: what the tool does (INFO), -vv: every frame and command (DEBUG), on stderr, for
    this call only: returns the undo (``main`` may run many times in one process).  Each
    line escaped; the libraries the project adopts log here too (``tactile.output.logs``)."""
    import logging

    from tactile.output.logs import Escaped

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


def _load(name):
    module_name, help_ = COMMANDS[name]
    try:
        return importlib.import_module(module_name), help_
    except ModuleNotFoundError as exc:
        if exc.name == module_name:
            raise TactileError(f"'{name}' is not available in this build") from None
        raise


def _simulator_ports(argv):
    """The application layer serves sim:// ports: the library below never imports the
    simulator (``tests/test_layers.py``)."""
    import os

    if any("sim://" in a for a in argv) or "sim://" in os.environ.get("TACTILE_PORT", ""):
        from tactile_sim.urlhandler import register

        register()


def main(argv=None):
    argv = sys.argv[1:] if argv is None else list(argv)
    _simulator_ports(argv)
    top = _top_parser()
    if not argv or argv[0].startswith("-"):
        top.parse_args(argv or ["--help"])
        return 0
    top.parse_args(argv[:1])  # validates the command name
    name = argv[0]
    try:
        module, help_ = _load(name)
        args = _command_parser(name, module, help_).parse_args(argv[1:])
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
