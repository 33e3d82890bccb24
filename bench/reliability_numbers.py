"""Numbers at the edge (issue 12): extreme coordinates, unbounded reads, bad log values and
Excel files, each tried through the real CLI on real files.

Every probe runs ``tactile.cli.main.main([...])`` in-process on files written to a fresh
temporary directory, capturing stdout, stderr and every warning, and checks the exit code,
a one-line stderr without 'Traceback' or 'Warning', no NaN/Infinity in the output, and what
the probe promises beyond that.  ``bench/reliability.py`` prints the table;
``tests/test_reliability.py`` requires every probe to hold.
"""

import contextlib
import io
import json
import math
import os
import pathlib
import tempfile
import tracemalloc
import warnings

import numpy as np

AREA = "Numbers at the edge"

POSE_HEAD = "t_start_us,t_end_us,finger,px,py,pz,qw,qx,qy,qz\n"
PROBE_HEAD = "# probe: sphere radius_m=0.01 centre_m=0.05,0,0\n" + POSE_HEAD
WILD_PROBE = PROBE_HEAD.replace("0.05,0,0", "1e308,0,0")
EP1_LOG = (
    "# probe: sphere radius_m=0.01 centre_m=0,0,0\nprobe,t_start_us,t_end_us,dtheta_x,dtheta_y\n"
)


def run(*args):
    """(exit code or 'raised X', stdout, stderr, [warning texts]) of ``tactile ARGS``."""
    from tactile.cli.main import main

    out, err = io.StringIO(), io.StringIO()
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
            try:
                code = main([str(a) for a in args])
            except BaseException as exc:  # a probe reports what escaped, whatever it is
                code = f"raised {type(exc).__name__}"
    return code, out.getvalue(), err.getvalue(), [str(w.message) for w in caught]


def verdict(result, code, says=None):
    """'held', or 'FAILED: why' for an outcome that broke the promise."""
    got, out, err, caught = result
    if got != code:
        return f"FAILED: exit {got}, not {code}: {err.strip()[:120]}"
    if caught:
        return f"FAILED: warning reached the user: {caught[0][:100]}"
    if "Traceback" in err or "Warning" in err:
        return "FAILED: traceback or warning text on stderr"
    if err.count("\n") != (1 if code else 0):
        return f"FAILED: stderr has {err.count(chr(10))} lines"
    for bad in ("NaN", "Infinity", " nan", " inf"):
        if bad in out:
            return f"FAILED: {bad.strip()} in the output"
    if says is not None and says not in err:
        return f"FAILED: message lacks {says!r}: {err.strip()[:120]}"
    return "held"


def contacts(tmp, name, scale=1.0, normal_scale=1.0, bom=False, crlf=False):
    """A noisy cylinder sweep (R 6.6) as a contacts CSV, coordinates times ``scale``."""
    from tactile_sim.ep2 import make, sweep

    d = sweep(make("cylinder", 6.6, 30.0, centre=(2.0, 2.0)), noise_pos=0.01, noise_normal=0.01)
    rows = np.column_stack([d["points"] * scale, d["normals"] * normal_scale])
    lines = ["x,y,z,nx,ny,nz,finger"]
    lines += [",".join(repr(float(v)) for v in r) + f",{f}" for r, f in zip(rows, d["finger"])]
    eol = "\r\n" if crlf else "\n"
    path = tmp / name
    path.write_bytes((b"\xef\xbb\xbf" if bom else b"") + (eol.join(lines) + eol).encode())
    return path


def same_answer(base, result, scale):
    """'held' when ``result`` (--json) is ``base`` for contacts times ``scale``."""
    held = verdict(result, 0)
    if held != "held":
        return held
    a, b = json.loads(base[1]), json.loads(result[1])
    if (a["shape"], a["S"] is None) != (b["shape"], b["S"] is None):
        return f"FAILED: {b['shape']} where the original is {a['shape']}"
    if a["S"] is not None and abs(a["S"] - b["S"]) > 1e-9:
        return f"FAILED: S {b['S']} where the original has {a['S']}"
    if not math.isclose(b["k1"] * scale, a["k1"], rel_tol=1e-9):
        return f"FAILED: k1 {b['k1']} is not the original's {a['k1']} / {scale:g}"
    return "held"


def _e(scale):
    """1e+160 -> '1e160'."""
    return f"{scale:.0e}".replace("e+", "e").replace("e-0", "e-").replace("e0", "e")


def _edit(path, line, value):
    """Replace the first cell of ``line`` (1-based) with ``value``."""
    text = path.read_text().splitlines()
    text[line - 1] = value + text[line - 1][text[line - 1].index(",") :]
    path.write_text("\n".join(text) + "\n")
    return path


def _coordinates(tmp):
    base = run("ep2", "analyze", contacts(tmp, "c.csv"), "--json")
    wild = _edit(contacts(tmp, "wild.csv"), 4, "1e308")
    says = f"{wild}:4: column 'x': the contacts spread over"
    yield (
        "contacts CSV with x = 1e308 in one row: `ep2 analyze`",
        "exit 2, one line naming file:line and column (was a LinAlgError traceback)",
        verdict(run("ep2", "analyze", wild), 2, says),
    )
    yield (
        "the same file: `plot`",
        "exit 2, the same line; nothing drawn",
        verdict(run("plot", wild, "-o", tmp / "wild"), 2, says),
    )
    for scale in (1e160, 1e-160, 1e299, 1e-299):
        path = contacts(tmp, f"s{scale:g}.csv", scale)
        yield (
            f"coordinates times {_e(scale)}: `ep2 analyze --json`",
            f"exit 0, same label and S, curvature / {_e(scale)}, no warning",
            same_answer(base, run("ep2", "analyze", path, "--json"), scale),
        )
    for scale in (1e160, 1e-160):
        path = contacts(tmp, f"p{scale:g}.csv", scale)
        result = run("plot", path, "-o", tmp / f"p{scale:g}", "--what", "patch,maps")
        held = verdict(result, 0)
        if held == "held" and len(result[1].split()) != 2:
            held = f"FAILED: wrote {result[1].split()}"
        yield (
            f"coordinates times {_e(scale)}: `plot`",
            "exit 0, two PNGs, no warning (was 'Singular matrix' or RGBA tracebacks)",
            held,
        )
    path = contacts(tmp, "n.csv", normal_scale=1e300)
    yield (
        "normals of length 1e300: `ep2 analyze --json`",
        "the answer of unit normals",
        same_answer(base, run("ep2", "analyze", path, "--json"), 1.0),
    )
    yield (
        "coordinates times 1e-310 (subnormal spread): `ep2 analyze`",
        "exit 2, one line: spread under the 1e-300 EP2 represents",
        verdict(run("ep2", "analyze", contacts(tmp, "t.csv", 1e-310)), 2, "spread over only"),
    )
    path = tmp / "point.csv"
    path.write_text("x,y,z,nx,ny,nz\n" + "1e300,1e300,1e300,0,0,1\n" * 12)
    yield (
        "twelve contacts at one point, 1e300: `ep2 analyze`",
        "exit 3, one line: the data do not determine a curvature",
        verdict(run("ep2", "analyze", path), 3, "all contacts at one point"),
    )
    for option, value, was in (
        ("--noise-pos", "nan", "a LinAlgError traceback"),
        ("--noise-normal", "1e308", "RuntimeWarning lines"),
        ("--grid", "100000", "a MemoryError traceback"),
    ):
        yield (
            f"`ep2 analyze {option} {value}`",
            f"exit 2, one line naming the option (was {was})",
            verdict(run("ep2", "analyze", tmp / "c.csv", option, value), 2, f"({option})"),
        )


def _reads(tmp):
    yield (
        "`/dev/zero` as a contacts CSV",
        "exit 2 at once: not a regular file (was an unbounded read, MemoryError)",
        verdict(run("ep2", "analyze", "/dev/zero"), 2, "not a regular file"),
    )
    fifo = tmp / "fifo.csv"
    os.mkfifo(fifo)
    yield (
        "a FIFO with no writer as a contacts CSV",
        "exit 2 at once, without waiting for a writer",
        verdict(run("ep2", "analyze", fifo), 2, "not a regular file"),
    )
    path = tmp / "long.csv"
    path.write_bytes(b"x,y,z,nx,ny,nz\n0,0,0,0,0,1\n" + b"9" * 4_000_000 + b",0,0,0,0,1\n")
    tracemalloc.start()
    result = run("ep2", "analyze", path)
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    held = verdict(result, 2, f"{path}:3: line longer than 65536 bytes")
    if held == "held" and peak > 2_000_000:
        held = f"FAILED: {peak / 1e6:.1f} MB held for a 4 MB line"
    yield ("a 4 MB line in a contacts CSV", "exit 2 naming line 3; under 2 MB held", held)
    big = tmp / "big.csv"
    with open(big, "wb") as fh:
        fh.write(b"x,y,z,nx,ny,nz\n")
        fh.truncate(16 * 2**30 + 1)  # sparse: 16 GiB without writing them
    yield (
        "a contacts CSV over 16 GiB",
        "exit 2 before reading: over the 16 GiB limit of a streamed file",
        verdict(run("ep2", "analyze", big), 2, "larger than 16 GiB"),
    )
    yield (
        "the same file to `plot`, which reads a file whole",
        "exit 2 before reading: over the 64 MiB limit",
        verdict(run("plot", big, "-o", tmp / "plots"), 2, "larger than 64 MiB"),
    )


def _sphere_rows(n, seed, patch):
    """CSV rows of ``n`` noisy contacts on a sphere cap of radius 8 over 4 x 4."""
    rng = np.random.default_rng(seed)
    xy = rng.uniform(-2.0, 2.0, (n, 2))
    z = np.sqrt(64.0 - np.sum(xy * xy, axis=1))
    pts = np.column_stack([xy, z]) + 1e-3 * rng.standard_normal((n, 3))
    table = np.column_stack([pts, np.column_stack([xy, z]) / 8.0])
    return [",".join(f"{v:.9g}" for v in row) + f",{patch}" for row in table]


def _peak(*args):
    """``run(*args)`` and the most memory (bytes, tracemalloc) it held at once."""
    tracemalloc.start()
    result = run(*args)
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    return result, peak


def _big_patches(tmp):
    path = tmp / "million.csv"
    block = "\n".join(_sphere_rows(1000, 0, "p")) + "\n"
    with open(path, "w") as fh:
        fh.write("x,y,z,nx,ny,nz,patch\n" + block * 1000)
    result, peak = _peak("ep2", "analyze", path)
    held = verdict(result, 2, f"{path}:2: column 'patch': patch 'p': 1,000,000 contacts")
    if held == "held" and peak > 200e6:
        held = f"FAILED: {peak / 1e6:.0f} MB held before refusing"
    yield (
        "one patch of 1,000,000 rows (the most a patch's rows may wait): `ep2 analyze`",
        "exit 2 before its rows are gathered, one line, under 200 MB held (was a MemoryError"
        " traceback: an n x n matrix of 7.28 TiB)",
        held,
    )
    rows = [r for k in range(40) for r in _sphere_rows(30, k, f"s{k}")]
    path = tmp / "unlike.csv"
    path.write_text(
        "x,y,z,nx,ny,nz,patch\n" + "\n".join(rows[:600] + _sphere_rows(100_000, 99, "big")
        + rows[600:]) + "\n"
    )  # fmt: skip
    result, peak = _peak("ep2", "analyze", path, "--json")
    held = verdict(result, 0)
    if held == "held" and peak > 1e9:
        held = f"FAILED: {peak / 1e9:.1f} GB held"
    yield (
        "one patch of 100,000 rows between 40 of 30: `ep2 analyze --json`",
        "exit 0, every patch answered, under 1 GB held (was 80 GB: an n x n matrix; the small"
        " patches padded to the large one's rows)",
        held,
    )


def _logs(tmp):
    cases = (
        ("finger=1e19", POSE_HEAD + "0,10,1e19,0,0,0,1,0,0,0\n", ":2: column 'finger'"),
        ("t_start_us=1e308", POSE_HEAD + "1e308,1e308,0,0,0,0,1,0,0,0\n", ":2: column 't_start"),
        ("px=1e300", POSE_HEAD + "0,10,0,1e300,0,0,1,0,0,0\n", ":2: column 'px'"),
        ("probe centre 1e308", WILD_PROBE + "0,10,0,0,0,0,1,0,0,0\n", ":1: probe: centre_m"),
        ("EP1 probe=1e19", EP1_LOG + "1e19,0,10,0.5,0\n", ":3: column 'probe'"),
    )  # fmt: skip
    for i, (what, text, says) in enumerate(cases):
        log = tmp / f"log{i}.csv"
        log.write_text(text)
        yield (
            f"robot log with {what}: `record --pose-log`",
            "exit 2 before recording, one line naming file:line (was garbage ids after a cast"
            " warning, or NaN contacts)",
            verdict(run("record", "--port", "/dev/null", "-o", tmp / "rec", "--pose-log", log),
                    2, f"{log}{says}"),
        )  # fmt: skip


def _encodings(tmp):
    base = run("ep2", "analyze", contacts(tmp, "plain.csv"), "--json")
    path = contacts(tmp, "excel.csv", bom=True, crlf=True)
    yield (
        "Excel 'CSV UTF-8' (byte-order mark, CR LF)",
        "read as the plain file (was 'missing column x')",
        same_answer(base, run("ep2", "analyze", path, "--json"), 1.0),
    )
    bad = contacts(tmp, "bad.csv")
    data = bad.read_bytes().splitlines(keepends=True)
    data[4] = data[4].replace(b",", b"\xff,", 1)
    bad.write_bytes(b"".join(data))
    yield (
        "a byte that is not UTF-8 on line 5",
        "exit 2 naming line 5 (was line 0)",
        verdict(run("ep2", "analyze", bad), 2, f"{bad}:5: not UTF-8 text"),
    )
    u16 = tmp / "u16.csv"
    u16.write_bytes("x,y,z,nx,ny,nz\n0,0,0,0,0,1\n".encode("utf-16"))
    yield (
        "a UTF-16 file (Excel 'Unicode Text')",
        "exit 2: says it is UTF-16",
        verdict(run("ep2", "analyze", u16), 2, "UTF-16 text"),
    )
    probes = tmp / "ep1.csv"
    rows = ["dtheta_x,dtheta_y,du,dv"]
    rows += [f"{0.05 * math.cos(a)!r},{0.05 * math.sin(a)!r},{1e-320 * math.sin(a)!r},1e-320"
             for a in np.linspace(0, 2 * math.pi, 8, endpoint=False)]  # fmt: skip
    probes.write_text("\n".join(rows) + "\n")
    result = run("ep1", "estimate", probes, "--finger-radius", "1")
    yield (
        "EP1 probes with du, dv of 1e-320: `ep1 estimate`",
        "an answer or exit 3, never 'nan' (was kx: nan)",
        verdict(result, result[0] if result[0] in (0, 3) else 0),
    )


def probes():
    with tempfile.TemporaryDirectory() as name:
        tmp = pathlib.Path(name)
        for group in (_coordinates, _reads, _big_patches, _logs, _encodings):
            yield from group(tmp)


if __name__ == "__main__":
    for row in probes():
        print(" | ".join(row))
