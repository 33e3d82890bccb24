"""One CLI vocabulary (issue 15): every command's --help runs, shows each option's default,
and takes -v/--verbose; logging goes to stderr only when asked."""

import argparse
import importlib

import pytest

from tactile.cli import main as cli_main


def _parser(name):
    module = importlib.import_module(cli_main.COMMANDS[name][0])
    parser = argparse.ArgumentParser(prog=f"tactile {name}", formatter_class=cli_main._Help)
    module.add_arguments(parser)
    return parser


@pytest.mark.parametrize("name", sorted(cli_main.COMMANDS))
def test_help_shows_every_default(name, capsys):
    with pytest.raises(SystemExit) as exit_:
        cli_main.main([name, "--help"])
    assert exit_.value.code == 0
    text = " ".join(capsys.readouterr().out.split())
    assert "-v, --verbose" in text
    for action in _parser(name)._actions:
        d = action.default
        if action.option_strings and action.help and d not in (None, False, argparse.SUPPRESS):
            if not isinstance(d, bool | list):
                shown = {str(d)} | ({f"{d:g}"} if isinstance(d, float) else set())
                assert any(v in text for v in shown), (name, action.option_strings, d)


def test_verbose_logs_commands_on_stderr(tmp_path, capsys):
    assert cli_main.main(["info", "--port", "sim://press", "-v"]) == 0
    err = capsys.readouterr().err
    assert "tactile tactile.board_client: sim://press: GET_INFO" in err
