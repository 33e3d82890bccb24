"""Files that lie: every file the host reads is bounded and regular, parsed without Python's
limits reaching the user, held to a strict CSV dialect, judged in the float32 it is sent
in, and its text escaped on the terminal and in plots; option values that look negative.

Probes that could hang (a FIFO, ``/dev/zero``) run ``tactile`` as a subprocess under a
timeout; the others run it in process (``reliability_numbers.run``), capturing every
warning.  ``bench/reliability.py`` prints the table; ``tests/test_reliability.py``
requires every probe to hold.
"""

import contextlib
import io
import json
import math
import os
import pathlib
import subprocess
import sys
import tempfile
import time

from reliability_numbers import run, verdict

AREA = "Files that lie"
TIMEOUT_S = 30  # a refusal takes about a second (Python's start); a hang never ends
RAW = ("\x1b", "\u202e")
EYE = [[float(i == j) for j in range(6)] for i in range(6)]


def _env():
    return dict(os.environ, PYTHONPATH=os.pathsep.join(sys.path))


def process(*args):
    """(exit code, stdout, stderr, []) of a ``tactile ARGS`` process, or a FAILED reason."""
    cmd = [sys.executable, "-m", "tactile.cli.main", *map(str, args)]
    t0 = time.monotonic()
    try:
        r = subprocess.run(cmd, capture_output=True, text=True, timeout=TIMEOUT_S, env=_env())
    except subprocess.TimeoutExpired:
        return f"hung for {TIMEOUT_S} s", "", "", []
    return r.returncode, r.stdout, r.stderr, [], time.monotonic() - t0


def in_time(result, code, says):
    """``verdict`` of a process's result, and it ended within 10 s."""
    if isinstance(result[0], str):
        return f"FAILED: {result[0]}"
    held = verdict(result[:4], code, says)
    return held if held != "held" or result[4] < 10 else f"FAILED: took {result[4]:.0f} s"


def escaped(result, code, says=None):
    """``verdict``, and no raw ESC or U+202E in stdout or stderr."""
    held = verdict(result, code, says)
    if held == "held" and any(ch in result[1] + result[2] for ch in RAW):
        return "FAILED: a raw control character reached the terminal"
    return held


def _recording(tmp):
    out = tmp / "run"
    run("record", "--port", "sim://press", "--duration", "0.2", "-o", out, "--quiet")
    return out


def _meta(tmp):
    out = _recording(tmp)
    meta = out / "meta.json"
    meta.unlink()
    os.symlink("/dev/zero", meta)
    says = "meta.json: not a regular file"
    yield (
        "meta.json a symlink to /dev/zero: `export`",
        "exit 2 within seconds, one line (was a read until the kernel killed it, 23 GB)",
        in_time(process("export", out, "-o", tmp / "x.mcap"), 2, says),
    )
    code = f"import tactile\ntry: tactile.load_recording({str(out)!r})\nexcept ValueError: pass"
    try:
        r = subprocess.run([sys.executable, "-c", code], timeout=TIMEOUT_S, env=_env())
        held = "held" if r.returncode == 0 else f"FAILED: exit {r.returncode}"
    except subprocess.TimeoutExpired:
        held = f"FAILED: hung for {TIMEOUT_S} s"
    yield ("the same: `load_recording`", "an InputError (a ValueError) at once", held)
    meta.unlink()
    os.mkfifo(meta)
    before = (out / "capture.bin").read_bytes()
    result = process("record", "--port", "sim://press", "--duration", "0.2", "-o", out,
                     "--quiet", "--append")  # fmt: skip
    held = in_time(result, 2, says)
    if held == "held" and (out / "capture.bin").read_bytes() != before:
        held = "FAILED: capture.bin changed"
    yield ("meta.json a FIFO: `record --append`", "exit 2 at once, capture kept (was a hang)", held)
    meta.unlink()
    meta.write_text("[" * 100_000 + "]" * 100_000)
    yield (
        "meta.json nested 100,000 deep: `export`",
        "exit 2, one line (was a RecursionError traceback)",
        verdict(run("export", out, "-o", tmp / "x.mcap"), 2, "nested more than 64 deep"),
    )


def _inputs(tmp):
    for what, args in (
        ("calibration", ("calibrate", "--dry-run")),
        ("scene", ("emulate",)),
        ("pose log", ("record", "--port", "/dev/null", "-o", tmp / "r", "--pose-log")),
    ):
        fifo = tmp / f"{what}.fifo"
        os.mkfifo(fifo)
        yield (
            f"a FIFO as a {what}: `{args[0]}`",
            "exit 2 at once: not a regular file",
            in_time(process(*args, fifo), 2, f"{fifo}: not a regular file"),
        )


def _json(tmp):
    big = tmp / "big.json"
    big.write_text(json.dumps({"id": 1, "matrix": EYE}).replace("1.0", "1" + "0" * 4999, 1))
    yield (
        "a JSON calibration with a 5,000-digit integer",
        "exit 2 naming the field: not a finite number (was a ValueError traceback)",
        verdict(run("calibrate", "--dry-run", big), 2, "field matrix[0][0] (fx, g0)"),
    )
    deep = tmp / "deep.toml"
    deep.write_text("a = " + "[" * 100_000 + "]" * 100_000 + "\n")
    yield (
        "a scene nested 100,000 deep",
        "exit 2, one line (was a RecursionError traceback)",
        verdict(run("emulate", deep), 2, "nested too deeply"),
    )


def _matrices(tmp):
    for scale, word in ((1e-200, "underflows"), (1e200, "overflows")):
        path = tmp / f"m{scale:g}.json"
        path.write_text(json.dumps({"id": 1, "matrix": [[v * scale for v in r] for r in EYE]}))
        was = "'singular (rank 6 of 6)'" if scale < 1 else "overflow warnings, then 'rank 0'"
        yield (
            f"identity x {scale:g} as a calibration",
            f"exit 2: {word} float32, no numpy warning (was {was})",
            verdict(run("calibrate", "--dry-run", path), 2, f"{word} float32"),
        )
    near = [list(r) for r in EYE]
    near[4] = [v * (1 + 1e-9) + 1e-3 for v in near[1]]
    near[1] = [v + 1e-3 for v in near[1]]
    path = tmp / "near.json"
    path.write_text(json.dumps({"id": 1, "matrix": near}))
    yield (
        "two rows equal once rounded to float32",
        "exit 2: singular (rank 5 of 6), judged as sent",
        verdict(run("calibrate", "--dry-run", path), 2, "singular (rank 5 of 6)"),
    )


def contacts(tmp, name, patch="a", head="x,y,z,nx,ny,nz,patch", first="", extra=""):
    rows = [head]
    for i in range(30):
        c, s = math.cos(0.02 * i), math.sin(0.02 * i)  # a 33 deg arc: one patch
        rows.append(f"{6.6 * c!r},{i % 5},{6.6 * s!r},{c!r},0,{s!r},{patch}")
    path = tmp / name
    path.write_text(first + "\n".join(rows[:20]) + "\n" + extra + "\n".join(rows[20:]) + "\n")
    return path


def _text(tmp):
    evil = contacts(tmp, "evil.csv", patch="\x1b[31mred\u202e$x^{$")
    yield (
        "a patch id holding ESC[31m and U+202E: `ep2 analyze`",
        "exit 0, the id escaped (was raw on the terminal)",
        escaped(run("ep2", "analyze", evil), 0),
    )
    yield (
        "the same file: `plot`",
        "exit 0, three PNGs, no glyph or mathtext warning",
        escaped(run("plot", evil, "-o", tmp / "evil"), 0),
    )


def _dialect(tmp):
    cases = (
        ("an unterminated quote", {"extra": '0,0,0,0,0,1,"a\n'}, ":21: a quote opened",
         "exit 2 naming its line (was 'all contacts at one point', exit 3)"),
        ("a second '# units:' line", {"first": "# units: m\n# units: cm\n"}, ":2: a second",
         "exit 2 naming the line (was ignored)"),
        ("a '# units:' line mid-file", {"extra": "# units: cm\n"}, ":21: a '# units:' line after",
         "exit 2 naming the line (was ignored)"),
        ("a column named twice", {"head": "x,y,z,nx,ny,nz,x"}, ":1: column 'x': named twice",
         "exit 2 naming the line and column (was: the first used)"),
    )  # fmt: skip
    for i, (what, parts, says, promise) in enumerate(cases):
        path = contacts(tmp, f"d{i}.csv", **parts)
        yield f"contacts CSV with {what}", promise, verdict(run("ep2", "analyze", path), 2, says)
    from tactile.calib.ati import format_cal

    for odd in ("1_0", "\u0661\u0660", "\uff11\uff10"):
        path = tmp / f"odd{len(odd)}{ord(odd[0])}.cal"
        path.write_text(format_cal(EYE, "FT7").replace('"1.0 ', f'"{odd} ', 1))
        yield (
            f"an ATI .cal with {odd.encode('ascii', 'backslashreplace').decode()} for 1.0",
            "exit 2 naming file:line, the axis and the number (was read as 10)",
            verdict(run("calibrate", "--dry-run", path), 2, f"{path}:4: column"),
        )


def _options(tmp):
    path = tmp / "perv.json"
    path.write_text(json.dumps({"id": 1, "matrix": EYE, "units": "N, N-m per V"}))
    yield (
        "`calibrate --volts-per-count -3e-9`",
        "parsed; exit 2, one line: must be positive (was argparse's whole usage block)",
        verdict(run("calibrate", "--dry-run", path, "--volts-per-count", "-3e-9"), 2,
                "--volts-per-count: must be a positive"),
    )  # fmt: skip
    result = argparse_run("calibrate", "--dry-run", path, "--volts-per-count", "x")
    held = verdict(result, 2, "argument --volts-per-count: invalid float value: 'x'")
    yield (
        "`calibrate --volts-per-count x`",
        "exit 2, one line naming the option, no usage block",
        "FAILED: the usage block" if held == "held" and "usage:" in result[2] else held,
    )


def argparse_run(*args):
    """``run``, with argparse's SystemExit taken as the exit code it carries."""
    from tactile.cli.main import main

    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        try:
            code = main([str(a) for a in args])
        except SystemExit as exc:
            code = exc.code
    return code, out.getvalue(), err.getvalue(), []


def probes():
    with tempfile.TemporaryDirectory() as name:
        tmp = pathlib.Path(name)
        for group in (_meta, _inputs, _json, _matrices, _text, _dialect, _options):
            yield from group(tmp)


if __name__ == "__main__":
    for row in probes():
        print(" | ".join(row))
