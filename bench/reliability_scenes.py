"""Hostile-world probes, Scenes (issue 12): malformed scene files and an idle emulator.

Every malformed kind of ``scene_variants.VARIANTS`` goes through ``tactile emulate`` (in
process, as the tests do), a few also through ``--port sim://`` and one through a real
``tactile`` process; then the shipped scenes, the old hang and the idle emulator's CPU.
``bench/reliability.py`` collects the rows; ``tests/test_reliability.py`` requires each
to hold.
"""

import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
import scene_variants  # noqa: E402

AREA = "Scenes"
SIM_ROUTE = ("sensors = 1000000", "NaN noise", "unknown section [boards]", "TOML syntax error")
IDLE_S = 1.5


def _promise(v):
    where = f"`{v.where}: ...{v.says}...`" if v.where else f"`...{v.says}...`"
    return f"exit 2, one line: {where}"


def _variant_rows():
    by_name = {v.name: v for v in scene_variants.VARIANTS}
    runs = [(v, "emulate") for v in scene_variants.VARIANTS]
    runs += [(by_name[name], "sim://") for name in SIM_ROUTE]
    for v, route in runs:
        with tempfile.TemporaryDirectory() as tmp:
            try:
                code, _, err, path, command = scene_variants.run(v, tmp, route)
                outcome = scene_variants.verdict(v, code, err, path, command)
            except Exception as exc:  # a probe reports what escaped, it does not stop the table
                outcome = f"FAILED: {type(exc).__name__}: {exc}"
        via = "`tactile emulate`" if route == "emulate" else "`tactile info --port sim://`"
        yield f"{v.name} ({v.base if v.raw is None else 'file'}), {via}", _promise(v), outcome


def _env():
    return dict(os.environ, PYTHONPATH=os.pathsep.join(sys.path))


def _real_process():
    v = next(v for v in scene_variants.VARIANTS if v.name == "NaN noise")
    with tempfile.TemporaryDirectory() as tmp:
        path = scene_variants.write(v, tmp)
        cmd = [sys.executable, "-m", "tactile.cli.main", "emulate", str(path)]
        out = subprocess.run(cmd, capture_output=True, text=True, timeout=60, env=_env())
        outcome = scene_variants.verdict(v, out.returncode, out.stderr, path, "emulate")
        if outcome == "held" and "Traceback" in out.stdout + out.stderr:
            outcome = "FAILED: a traceback"
    return "NaN noise, a real `tactile emulate` process", "exit 2, one line, no traceback", outcome


def _shipped():
    from tactile_sim.emulator import load_scene
    from tactile_sim.emulator.device import EmulatedBoard
    from tactile_sim.emulator.scene import SCENE_DIR

    bad = []
    names = sorted(p.stem for p in SCENE_DIR.glob("*.toml"))
    for name in names:
        try:
            board = EmulatedBoard(load_scene(name))
            board.host_opened()
            board.run_until(60_000)
            if not board.read_host():
                bad.append(f"{name}: no bytes")
        except Exception as exc:
            bad.append(f"{name}: {type(exc).__name__}: {exc}")
    outcome = "held" if not bad else "FAILED: " + "; ".join(bad)
    return f"the {len(names)} shipped scenes", "each validates, builds and streams", outcome


def _no_hang():
    v = next(v for v in scene_variants.VARIANTS if v.name == "sensors = 1000000")
    with tempfile.TemporaryDirectory() as tmp:
        t0 = time.monotonic()
        code, _, err, path, command = scene_variants.run(v, tmp)
        took = time.monotonic() - t0
    outcome = scene_variants.verdict(v, code, err, path, command)
    if outcome == "held" and took > 1.0:
        outcome = f"FAILED: took {took:.1f} s"
    return "sensors = 1000000 (it hung)", "refused within 1 s", outcome


def _cpu_s(pid):
    with open(f"/proc/{pid}/stat") as fh:
        fields = fh.read().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def _idle():
    promise = "under 10% of a core while no host has the port; a host then gets HELLO"
    probe = f"`tactile emulate press` waiting for a host, {IDLE_S} s"
    if not os.path.exists("/proc/self/stat"):
        return probe, promise, "FAILED: needs Linux /proc"
    import serial

    from tactile.board.stream_decoder import StreamDecoder

    cmd = [sys.executable, "-m", "tactile.cli.main", "emulate", "press"]
    quiet = {"stderr": subprocess.DEVNULL, "text": True, "env": _env()}
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, **quiet)
    try:
        path = proc.stdout.readline().strip()
        time.sleep(0.3)
        cpu0, t0 = _cpu_s(proc.pid), time.monotonic()
        time.sleep(IDLE_S)
        fraction = (_cpu_s(proc.pid) - cpu0) / (time.monotonic() - t0)
        decoder, hello, end = StreamDecoder(), False, time.monotonic() + 10.0
        with serial.Serial(path, timeout=0.1) as port:
            while not hello and time.monotonic() < end:
                hello = any(m.type_name == "HELLO" for m in decoder.feed(port.read(256)))
    finally:
        proc.terminate()
        proc.wait(5)
    if fraction >= 0.10:
        return probe, promise, f"FAILED: {fraction:.0%} of a core"
    return probe, promise, "held" if hello else "FAILED: no HELLO after the idle wait"


def probes():
    yield from _variant_rows()
    yield _real_process()
    yield _shipped()
    yield _no_hang()
    yield _idle()


if __name__ == "__main__":
    for row in probes():
        print(" | ".join(row))
