"""One CLI vocabulary, command by command: -v/--verbose anywhere after the command (after
positionals, after a subcommand's name), -p/--port or TACTILE_PORT for every board command,
each default shown once in help, one spelling per option, -q/--quiet for "no progress"."""

import argparse
import json

import pytest
from cli_tree import command_parser, tree

from tactile.cli import main as cli_main

# Every command that opens a board's port.
BOARD = {"info", "config", "tare", "calibrate", "record", "live", "flash", "explore"}


def _leaves():
    """(path, argv) per leaf command: its required options and positionals with
    placeholder values, enough to parse."""
    for path, parser in tree():
        if any(isinstance(a, argparse._SubParsersAction) for a in parser._actions):
            continue
        opts, positionals = [], []
        for action in parser._actions:
            n = action.nargs if isinstance(action.nargs, int) else 1
            values = [str(next(iter(action.choices))) if action.choices else "1"] * n
            if not action.option_strings and action.nargs not in ("?", "*"):
                positionals += values
            elif action.required:
                opts += [action.option_strings[-1], *values]
        for group in parser._mutually_exclusive_groups:
            if group.required:
                opts += [group._group_actions[0].option_strings[-1], "1"]
        yield path, [*path[1:], *opts, *positionals]


LEAVES = list(_leaves())


def _ids(cases):
    return [" ".join(path) for path, _ in cases]


@pytest.mark.parametrize("path, argv", LEAVES, ids=_ids(LEAVES))
def test_verbose_parses_after_positionals_and_subcommands(path, argv):
    parser = command_parser(path[0])
    assert parser.parse_args(argv).verbose == 0
    assert parser.parse_args([*argv, "-v"]).verbose == 1
    assert parser.parse_args([*argv, "-vv"]).verbose == 2
    if len(path) > 1:  # before the subcommand's name too, and kept by it
        assert parser.parse_args(["-v", *argv]).verbose == 1


def test_every_board_command_takes_p_and_tactile_port(monkeypatch):
    monkeypatch.delenv("TACTILE_PORT", raising=False)
    has_port = {path[0] for path, p in tree() if "--port" in p._option_string_actions}
    assert has_port == BOARD
    for path, argv in LEAVES:
        if path[0] not in BOARD:
            continue
        assert command_parser(path[0]).parse_args([*argv, "-p", "/dev/ttyX"]).port == "/dev/ttyX"
        assert command_parser(path[0]).parse_args(argv).port is None
        monkeypatch.setenv("TACTILE_PORT", "sim://press")
        assert command_parser(path[0]).parse_args(argv).port == "sim://press"
        monkeypatch.delenv("TACTILE_PORT")


@pytest.mark.parametrize("name", sorted(BOARD))
def test_a_missing_port_is_one_line_naming_both(name, tmp_path, monkeypatch, capsys):
    monkeypatch.delenv("TACTILE_PORT", raising=False)
    monkeypatch.chdir(tmp_path)
    (tmp_path / "m.json").write_text(
        json.dumps({"id": 1, "matrix": [[float(i == j) for j in range(6)] for i in range(6)]})
    )
    argv = {"calibrate": ["m.json"], "record": ["-o", "run"],
            "explore": ["--robot", "127.0.0.1:9", "-o", "run"]}.get(name, [])  # fmt: skip
    assert cli_main.main([name, *argv]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "Traceback" not in err, err
    assert "--port" in err and "TACTILE_PORT" in err, err


@pytest.mark.parametrize("name", sorted(BOARD))
def test_a_port_that_is_not_there_is_one_wording_across_commands(name, tmp_path, capsys):
    (tmp_path / "m.json").write_text(
        json.dumps({"id": 1, "matrix": [[float(i == j) for j in range(6)] for i in range(6)]})
    )
    run = ["-o", tmp_path / "run"]
    argv = {"calibrate": [tmp_path / "m.json"], "record": run,
            "explore": ["--robot", "127.0.0.1:9", *run]}.get(name, [])  # fmt: skip
    assert cli_main.main([name, "--port", "/dev/ttyNOPE0", *map(str, argv)]) == 4
    assert capsys.readouterr().err == (
        f"tactile {name}: error: /dev/ttyNOPE0: no such port (is the board plugged in?"
        " 'tactile ports' lists them)\n"
    )


def test_every_default_is_shown_once():
    for path, parser in tree():
        assert parser.formatter_class is cli_main._Help, path
        formatter = parser._get_formatter()
        for action in parser._actions:
            if not action.help or action.help == argparse.SUPPRESS:
                continue
            text = formatter._get_help_string(action)
            assert text.lower().count("default") <= 1, (path, action.option_strings, text)
            d = action.default
            shown = d is not None and d is not argparse.SUPPRESS and not isinstance(d, bool)
            if shown and action.option_strings and not isinstance(action, argparse._CountAction):
                said = {str(d)} | ({f"{d:g}"} if isinstance(d, float) else set())
                assert "default" in text or any(f"({v}" in text for v in said), (path, text)


def test_no_two_options_differ_only_by_case():
    for path, parser in tree():
        words = list(parser._option_string_actions)
        assert len({w.lower() for w in words}) == len(words), (path, sorted(words))


def test_quiet_is_one_spelling():
    quiet = {path for path, p in tree() if "--quiet" in p._option_string_actions}
    assert {("record",), ("flash",), ("ep2", "analyze"), ("study", "ep1-noise")} <= quiet
    for path, parser in tree():
        assert "--no-progress" not in parser._option_string_actions, path
        if "--quiet" in parser._option_string_actions:
            assert parser._option_string_actions["-q"].dest == "quiet", path


def test_sim_ep1_paraboloid_coefficient_is_coef(capsys):
    argv = ["sim", "ep1", "--object", "paraboloid", "--coef", "2", "--finger-radius", "0.1"]
    assert cli_main.main([*argv, "--dtheta", "0.1", "--json"]) == 0
    truth = json.loads(capsys.readouterr().out)["truth"]
    assert truth["kx"] == pytest.approx(4.0), truth  # 2C at the apex


def test_decode_says_what_it_prints(tmp_path, capsys):
    assert "text or --json" in cli_main.OWN["decode"].help
    capture = tmp_path / "c.bin"
    capture.write_bytes(b"\x00garbage\x00")
    assert cli_main.main(["decode", str(capture)]) == 0
    assert capsys.readouterr().out.startswith("summary ")
    assert cli_main.main(["decode", str(capture), "--json"]) == 0
    assert "summary" in json.loads(capsys.readouterr().out.splitlines()[-1])
