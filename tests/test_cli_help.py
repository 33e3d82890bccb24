"""One CLI vocabulary (issue 15): every command's --help runs, shows each option's default,
and takes -v/--verbose; logging goes to stderr only when asked."""

import argparse

import pytest
from cli_tree import command_parser, tree

from tactile.cli import main as cli_main


@pytest.mark.parametrize("name", sorted(cli_main.commands()))
def test_help_shows_every_default(name, capsys):
    with pytest.raises(SystemExit) as exit_:
        cli_main.main([name, "--help"])
    assert exit_.value.code == 0
    text = " ".join(capsys.readouterr().out.split())
    assert "-v, --verbose" in text
    for action in command_parser(name)._actions:
        d = action.default
        if action.option_strings and action.help and d not in (None, False, argparse.SUPPRESS):
            if not isinstance(d, bool | list):
                shown = {str(d)} | ({f"{d:g}"} if isinstance(d, float) else set())
                assert any(v in text for v in shown), (name, action.option_strings, d)


def test_verbose_logs_commands_on_stderr(tmp_path, capsys):
    assert cli_main.main(["info", "--port", "sim://press", "-v"]) == 0
    err = capsys.readouterr().err
    assert "tactile tactile.board.client: sim://press: GET_INFO" in err


# Every leaf command that writes files: its output path is -o/--out.
WRITES_FILES = {
    ("demo",),
    ("record",),
    ("export",),
    ("plot",),
    ("sim", "ep1"),
    ("sim", "ep2"),
    *(("study", name) for name in ("ep1-noise", "ep1-paraboloid", "ep1-resolution")),
    *(("study", name) for name in ("ep1-arclength", "ep1-dtheta", "ep2-cylinders")),
    *(("study", name) for name in ("ep2-rotation", "ep2-cylinder-radius", "ep2-sphere-radius")),
    ("study", "ep2-tables"),
}
OLD_WORDS = ("--degree", "--output", "--outdir", "--probes-out")


def test_one_spelling_for_outputs_and_order():
    """Issue 15: -o/--out for every output path, --order for the spline order, and no old
    spelling shown; an option's dest that names an output is never spelled otherwise."""
    seen = set()
    for path, parser in tree():
        seen.add(path)
        shown = [a for a in parser._actions if a.option_strings and a.help != argparse.SUPPRESS]
        for action in shown:
            words = set(action.option_strings)
            assert not words & set(OLD_WORDS), (path, words)
            if action.dest in ("out", "output", "outdir") or action.dest.endswith("_out"):
                assert action.option_strings == ["-o", "--out"], (path, action.option_strings)
            if "-o" in words:
                assert action.dest == "out", (path, action.option_strings)
            assert "degree" not in action.dest, (path, action.option_strings)
        if path in WRITES_FILES:
            assert any(a.option_strings == ["-o", "--out"] for a in shown), path
        help_text = parser.format_help()
        for old in OLD_WORDS:
            assert old not in help_text, (path, old)
    assert WRITES_FILES <= seen, WRITES_FILES - seen


@pytest.mark.parametrize(
    "argv, old",
    [
        (["plot", "x.csv", "--outdir", "D"], "--outdir"),
        (["sim", "ep2", "--object", "plane", "--output", "D"], "--output"),
        (["sim", "ep1", "--object", "plane", "--finger-radius", "1", "--dtheta", ".1",
          "--probes-out", "D"], "--probes-out"),
    ],
)  # fmt: skip
def test_old_spellings_still_work_with_a_one_line_note(argv, old, capsys):
    parser = command_parser(argv[0])
    args = parser.parse_args(argv[1:])
    assert args.out == "D"
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and f"'{old}' is deprecated, use '--out'" in err


def test_sim_ep2_still_requires_its_output(capsys):
    with pytest.raises(SystemExit) as exit_:
        command_parser("sim").parse_args(["ep2", "--object", "plane"])
    assert exit_.value.code == 2
    assert "-o/--out is required" in capsys.readouterr().err


def test_object_names_are_spelled_one_way():
    """concave_cylinder, as EP2 labels it, wherever a command takes an object name."""
    from tactile.ep2.geometry import S_NAMES

    names = set()
    for _, parser in tree():
        for action in parser._actions:
            if action.dest == "object":
                names |= set(action.choices)
    assert "concave_cylinder" in names
    assert not {n for n in names if "concave" in n or "convex" in n} - {"concave_cylinder"}
    map_objects = {"box_corner", "capped_cylinder", "rounded_edge", "saddle_map"}  # ep2 map's
    assert names - {"plane", "quadric"} - map_objects <= {
        *S_NAMES,
        "pit",
        "paraboloid",
        "ellipsoid",
        "torus",
    }
