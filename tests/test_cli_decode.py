"""``tactile decode``: captures in, JSON lines and a counter summary out, never a traceback."""

import json

import pytest

from tactile_protocol.constants import MSG_HELLO, MSG_SAMPLE, PROTOCOL_VERSION
from tactile_protocol.framing import FrameEncoder


def _capture(tmp_path, junk=b""):
    enc = FrameEncoder()
    data = bytes(
        enc.encode(
            MSG_HELLO,
            0,
            (1, 2, 3, PROTOCOL_VERSION, b"SIM", 1, 1000, 5, 0, 0, 0, 500, 5, 4, 2, 3, 9)
            + (7, 0, 0, 0, b"\x01\x02\x03\x04\x05\x06\x07\x08"),
        )
    )
    for i in range(5):
        data += bytes(enc.encode(MSG_SAMPLE, 1000 * i, (0, 0x40, i, -i, 0, 0, 0, 7)))
        data += junk if i == 2 else b""
    path = tmp_path / "cap.bin"
    path.write_bytes(data)
    return path


def test_json_lines_and_summary(tmp_path, cli):
    code, out, err = cli("decode", _capture(tmp_path), "--json")
    assert code == 0 and err == ""
    lines = [json.loads(line) for line in out.splitlines()]
    assert lines[0]["type"] == "HELLO" and lines[0]["sensor_model"] == "SIM"
    samples = [m for m in lines if m.get("type") == "SAMPLE"]
    assert [m["fx"] for m in samples] == [0, 1, 2, 3, 4]
    assert lines[-1]["summary"]["frames"] == 6
    assert lines[-1]["summary"]["lost_frames"] == 0


def test_damaged_capture_is_counted_not_fatal(tmp_path, cli):
    code, out, _ = cli("decode", _capture(tmp_path, junk=b"\x55" * 700 + b"\x00\x03"), "--json")
    assert code == 0
    summary = json.loads(out.splitlines()[-1])["summary"]
    assert summary["frames"] == 6 and summary["oversize"] == 1


def test_text_output_is_readable(tmp_path, cli):
    code, out, _ = cli("decode", _capture(tmp_path))
    assert code == 0
    assert out.splitlines()[1].startswith("SAMPLE   seq=1")
    assert out.splitlines()[-1].startswith("summary  bytes=")


def test_missing_file_is_one_line_exit_2(tmp_path, cli):
    code, out, err = cli("decode", tmp_path / "nope.bin")
    assert code == 2 and out == ""
    assert err.count("\n") == 1 and "nope.bin" in err and "Traceback" not in err


def test_unknown_command_and_help(capsys):
    from tactile.cli.main import main, names

    with pytest.raises(SystemExit) as exc:
        main(["frobnicate"])
    assert exc.value.code == 2
    with pytest.raises(SystemExit) as exc:
        main(["--help"])
    out = capsys.readouterr().out
    assert exc.value.code == 0
    assert all(name in out for name in names())


def test_decode_help_names_the_argument(capsys):
    from tactile.cli.main import main

    with pytest.raises(SystemExit) as exc:
        main(["decode", "--help"])
    assert exc.value.code == 0 and "capture" in capsys.readouterr().out


def test_decode_imports_nothing_heavy():
    """'Leave out what a run does not need': decoding never imports NumPy or SciPy."""
    import subprocess
    import sys

    code = (
        "import sys; from tactile.cli.main import main; "
        "import tactile.cli.cmd_board, "
        "tactile.board.stream_decoder; print(sorted(m for m in ('numpy', 'scipy', 'matplotlib') "
        "if m in sys.modules))"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[]"


def test_group_dispatch_skips_a_missing_module():
    import argparse
    from importlib.metadata import EntryPoint

    from tactile.commands import add_group

    group = "tactile.commands.sim"
    found = [EntryPoint(n, m, group) for n, m in (("ep0", "tactile_sim.commands.no_such_module"),
             ("ep1", "tactile_studies.commands.sim_ep1"))]  # fmt: skip
    parser = argparse.ArgumentParser()
    add_group(parser, "what", found)
    argv = ["ep1", "--object", "sphere", "--finger-radius", "1", "--dtheta", "0.1"]
    assert callable(parser.parse_args(argv)._run)


ISSUE_7_COMMANDS = (
    "ports info config tare record live decode emulate flash ep1 ep2 study plot".split()
)


@pytest.mark.parametrize("name", ISSUE_7_COMMANDS + ["demo", "sim"])
def test_every_subcommand_exists_and_has_help(capsys, name):
    from tactile.cli.main import commands, main

    assert name in commands()
    with pytest.raises(SystemExit) as exc:
        main([name, "--help"])
    out = capsys.readouterr().out
    assert exc.value.code == 0 and out.startswith(f"usage: tactile {name}")
