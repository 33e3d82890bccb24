"""The CLI's parsers as the CLI builds them, command by command, for the vocabulary tests."""

import argparse

from tactile.cli import main as cli_main


def command_parser(name):
    """``tactile NAME``'s parser, built as ``tactile`` builds it."""
    module, command = cli_main.load(name)
    return cli_main._command_parser(name, module, command.help)


def walk(parser, path=()):
    """Every (command path, parser) below ``parser``, subcommands of subcommands included."""
    yield path, parser
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for name, sub in action.choices.items():
                yield from walk(sub, (*path, name))


def tree():
    """Every (command path, parser) of the whole CLI."""
    for name in sorted(cli_main.commands()):
        yield from walk(command_parser(name), (name,))
