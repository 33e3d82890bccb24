"""Every file the host reads is a regular file, read within a bound, parsed without Python's
limits reaching the user: a FIFO, ``/dev/zero``, deep nesting or a 5,000-digit integer is
one line and exit 2, at once.

The FIFO and ``/dev/zero`` cases run ``tactile`` as a subprocess under a timeout, so a hang
or an unbounded read fails the test instead of blocking it."""

import json
import os
import subprocess
import sys

import pytest

from tactile.errors import InputError
from tactile.files import bounded

TIMEOUT_S = 60  # generous: a refusal takes well under a second; a hang never ends


def tactile(*args, cwd=None):
    """(exit code, stderr) of a ``tactile ARGS`` process."""
    cmd = [sys.executable, "-m", "tactile.cli.main", *map(str, args)]
    r = subprocess.run(cmd, capture_output=True, text=True, timeout=TIMEOUT_S, cwd=cwd)
    return r.returncode, r.stderr


def one_line(code, err, says):
    assert code == 2, err
    assert err.count("\n") == 1 and "Traceback" not in err, err
    assert says in err, err


def hostile(path, kind):
    """Make ``path`` a FIFO, a symlink to /dev/zero or a directory."""
    if kind == "fifo":
        os.mkfifo(path)
    elif kind == "zero":
        os.symlink("/dev/zero", path)
    else:
        path.mkdir()


KINDS = {"fifo": "not a regular file", "zero": "not a regular file", "dir": "a directory"}


def recording(tmp_path, cli):
    out = tmp_path / "run"
    cli("record", "--port", "sim://press", "--duration", "0.2", "-o", out, "--quiet")
    return out


@pytest.mark.parametrize("kind", list(KINDS))
def test_a_meta_json_that_is_no_file_is_refused_by_export_load_and_append(tmp_path, cli, kind):
    out = recording(tmp_path, cli)
    (out / "meta.json").unlink()
    hostile(out / "meta.json", kind)
    says = f"meta.json: {KINDS[kind]}"
    one_line(*tactile("export", out, "-o", tmp_path / "x.mcap"), says)
    one_line(*tactile("plot", out, "-o", tmp_path / "p"), "contacts.csv")  # no contacts here
    code, err = tactile("record", "--port", "sim://press", "--duration", "0.2", "-o", out,
                        "--quiet", "--append")  # fmt: skip
    one_line(code, err, says)
    code = subprocess.run(
        [sys.executable, "-c", f"import tactile; tactile.load_recording({str(out)!r})"],
        capture_output=True, text=True, timeout=TIMEOUT_S,
    ).stderr  # fmt: skip
    assert f"InputError: {out}/meta.json: {KINDS[kind]}" in code


def test_a_frames_csv_fifo_is_refused_by_append(tmp_path, cli):
    out = recording(tmp_path, cli)
    (out / "frames.csv").unlink()
    os.mkfifo(out / "frames.csv")
    code, err = tactile("record", "--port", "sim://press", "--duration", "0.2", "-o", out,
                        "--quiet", "--append")  # fmt: skip
    one_line(code, err, "frames.csv: not a regular file")


@pytest.mark.parametrize("kind", ["fifo", "zero"])
@pytest.mark.parametrize(
    "args",
    [
        ("calibrate", "--dry-run", "{f}"),
        ("emulate", "{f}"),
        ("ep2", "analyze", "{f}"),
        ("ep1", "estimate", "{f}", "--finger-radius", "1"),
        ("record", "--port", "/dev/null", "-o", "{d}", "--pose-log", "{f}"),
    ],
    ids=["calibration", "scene", "contacts", "probes", "pose log"],
)
def test_every_input_file_that_is_no_file_is_refused_at_once(tmp_path, kind, args):
    f = tmp_path / "input"
    hostile(f, kind)
    args = [a.format(f=f, d=tmp_path / "rec") for a in args]
    one_line(*tactile(*args), f"{f}: not a regular file")


def test_meta_json_nested_deeply_is_one_line(tmp_path, cli):
    out = recording(tmp_path, cli)
    (out / "meta.json").write_text("[" * 100_000 + "]" * 100_000)
    code, _, err = cli("export", out, "-o", tmp_path / "x.mcap")
    one_line(code, err, "meta.json: JSON nested more than 64 deep")
    (out / "meta.json").write_text('{"a": ' + "[" * 70 + "]" * 70 + "}")  # within recursion
    code, _, err = cli("export", out, "-o", tmp_path / "x.mcap")
    one_line(code, err, "nested more than 64 deep")


def test_meta_json_with_a_huge_integer_names_its_line(tmp_path, cli):
    out = recording(tmp_path, cli)
    (out / "meta.json").write_text('{\n  "frames": ' + "9" * 5000 + "\n}\n")
    code, _, err = cli("export", out, "-o", tmp_path / "x.mcap")
    one_line(code, err, "meta.json:2: column 13: an integer of 5,000 digits")


def test_a_calibration_with_a_5000_digit_integer_names_the_field(tmp_path, cli):
    m = [[float(i == j) for j in range(6)] for i in range(6)]
    text = json.dumps({"id": 1, "matrix": m}).replace("1.0", "1" + "0" * 4999, 1)
    (tmp_path / "m.json").write_text(text)
    code, _, err = cli("calibrate", "--dry-run", tmp_path / "m.json")
    one_line(code, err, "field matrix[0][0] (fx, g0): not a finite number")


def test_a_deeply_nested_scene_is_one_line(tmp_path, cli):
    path = tmp_path / "deep.toml"
    path.write_text("a = " + "[" * 100_000 + "]" * 100_000 + "\n")
    code, _, err = cli("emulate", path)
    one_line(code, err, "nested too deeply to be a scene")


def test_read_bytes_never_reads_past_its_bound(tmp_path):
    path = tmp_path / "f"
    path.write_bytes(b"x" * 100)
    assert bounded.read_bytes(path, 100) == b"x" * 100
    with pytest.raises(InputError, match=r"larger than 99 bytes"):
        bounded.read_bytes(path, 99)
    with pytest.raises(bounded.Missing, match="No such file"):
        bounded.read_bytes(tmp_path / "none", 10)


def test_parse_json_limits(tmp_path):
    assert bounded.parse_json("f", b"\xef\xbb\xbf" + b"[" * 64 + b"]" * 64) is not None
    for data, says in (
        (b"[" * 65 + b"]" * 65, "nested more than 64 deep"),
        (b"[NaN]", "NaN is not a finite number"),
        (b'{"a":\n 1,}', "f:2: column 4: not valid JSON"),
        (b'"\xff"', "f:1: not UTF-8 text"),
        (b"-" + b"1" * 401, "an integer of 401 digits"),
    ):
        with pytest.raises(InputError, match=None) as exc:
            bounded.parse_json("f", data)
        assert says in str(exc.value)
    assert bounded.parse_json("f", b"-" + b"1" * 400) == -int("1" * 400)


@pytest.mark.parametrize("value", ["x", [], -5, 1.5, 1e300, True])
def test_a_damaged_time_base_field_is_one_line(tmp_path, cli, value):
    out = recording(tmp_path, cli)
    meta = json.loads((out / "meta.json").read_text())
    meta["time_base"]["segments"][0]["first_row"] = value
    meta["sessions"] = [dict(meta, sessions=None)]
    (out / "meta.json").write_text(json.dumps(meta))
    code, _, err = cli("export", out, "-o", tmp_path / "x.mcap")
    one_line(code, err, "meta.json: time_base segment 0 field 'first_row': not a whole number")
