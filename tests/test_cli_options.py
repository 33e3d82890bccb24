"""Option values: a value that looks like a negative number, exponent and all, is a value
(``--volts-per-count -3e-9``), and any bad option value is one line (no usage block),
exit 2, naming the option."""

import json

import pytest

from tactile.cli.main import commands, main


def run(capsys, *args):
    """(exit code, stderr) of ``tactile ARGS`` in process, argparse's SystemExit included."""
    try:
        code = main([str(a) for a in args])
    except SystemExit as exc:
        code = exc.code
    return code, capsys.readouterr().err


def one_line(code, err, says):
    assert code == 2 and err.count("\n") == 1, err
    assert "usage:" not in err and "Traceback" not in err
    assert says in err, err


def test_a_negative_volts_per_count_reaches_the_check_of_its_value(tmp_path, capsys):
    path = tmp_path / "m.json"
    m = [[float(i == j) for j in range(6)] for i in range(6)]
    path.write_text(json.dumps({"id": 1, "matrix": m, "units": "N, N-m per V"}))
    for value in ("-3e-9", "-3E+2", "-.5e-1", "-3"):
        code, err = run(capsys, "calibrate", "--dry-run", path, "--volts-per-count", value)
        one_line(code, err, "--volts-per-count: must be a positive, finite number of volts")
    code, err = run(capsys, "calibrate", "--dry-run", path, "--volts-per-count", "3e-9")
    assert code == 0, err


@pytest.mark.parametrize(
    "args, says",
    [
        (("calibrate", "m.json", "--volts-per-count", "x"), "invalid float value: 'x'"),
        (("calibrate", "m.json", "--volts-per-count"), "--volts-per-count: expected one"),
        (("calibrate", "m.json", "--sensor", "1.5"), "--sensor: invalid int value"),
        (("ep2", "analyze", "c.csv", "--grid", "many"), "--grid: invalid int value"),
        (("ep2", "analyse", "c.csv"), "invalid choice: 'analyse'"),
        (("sim", "ep2", "--bogus"), "tactile sim ep2: error: "),
        (("record", "--port", "sim://press", "--duration", "-"), "--duration"),
    ],
)
def test_a_bad_option_value_is_one_line(capsys, args, says):
    one_line(*run(capsys, *args), says)


def test_a_negative_number_reaches_each_commands_own_check(tmp_path, capsys):
    path = tmp_path / "c.csv"
    path.write_text("x,y,z,nx,ny,nz\n" + "".join(f"{i},{i % 3},0,0,0,1\n" for i in range(9)))
    one_line(*run(capsys, "ep2", "analyze", path, "--noise-pos", "-1e-3"), "(--noise-pos)")
    one_line(*run(capsys, "ep2", "analyze", path, "--grid", "-5"), "--grid must be at least 2")


@pytest.mark.parametrize("name", sorted(commands()))
def test_every_command_says_an_unknown_option_in_one_line(capsys, name):
    one_line(*run(capsys, name, "--no-such-option"), f"tactile {name}")


@pytest.mark.parametrize(
    "args, meant",
    [
        (("recrod", "-o", "run"), "'record'"),
        (("ep2", "analyse", "c.csv"), "'analyze'"),
        (("ep2", "analyze", "c.csv", "--metod", "spline"), "'--method'"),
        (("ep2", "analyze", "c.csv", "--weighting", "tangnt"), "'tangent'"),
        (("record", "--prot", "/dev/ttyACM0", "-o", "run"), "'--port'"),
        (("emulate", "ch5_convex", "--fats"), "'--fast'"),
        (("demo", "--object", "cilinder"), "'cylinder'"),
    ],
)
def test_a_mistyped_command_or_option_gets_a_did_you_mean(capsys, args, meant):
    code, err = run(capsys, *args)
    one_line(code, err, f"; did you mean {meant}? (see 'tactile")


@pytest.mark.parametrize("args", [("zzzzzz",), ("info", "--zzzzzz"), ("ep2", "qqq")])
def test_nothing_close_is_not_guessed(capsys, args):
    code, err = run(capsys, *args)
    assert code == 2 and "did you mean" not in err, err
