"""An emulator with nobody on its port sleeps (issue 12): it took ~64% of a core busy-polling.

A behavioural check, not a benchmark: ``tactile emulate`` runs as its own process, and its
CPU time (``/proc/PID/stat``, user + system) over an idle wall-clock interval must be a small
fraction of that interval.  It must still notice a host: opening the port afterwards gets
HELLO, so the fix is a blocking wait, not a deaf one.
"""

import os
import subprocess
import sys
import time

import pytest
import serial

from tactile.board.stream_decoder import StreamDecoder

pytestmark = pytest.mark.realtime  # on the wall clock: bench/realtime_soak.py

IDLE_S = 1.5
MAX_FRACTION = 0.10


def _cpu_s(pid):
    """User + system CPU seconds of process ``pid`` so far."""
    with open(f"/proc/{pid}/stat") as fh:
        fields = fh.read().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def _busy(pid, seconds):
    """The fraction of a core process ``pid`` used over the next ``seconds``."""
    cpu0, wall0 = _cpu_s(pid), time.monotonic()
    time.sleep(seconds)
    return (_cpu_s(pid) - cpu0) / (time.monotonic() - wall0)


@pytest.mark.skipif(not os.path.exists("/proc/self/stat"), reason="needs Linux /proc")
@pytest.mark.parametrize("options", [(), ("--now", "--fast")], ids=["waiting", "fast-now"])
def test_an_idle_emulator_sleeps_and_still_answers_a_host(options):
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(sys.path))  # this checkout's sources
    cmd = [sys.executable, "-m", "tactile.cli.main", "emulate", "press", *options]
    quiet = {"stderr": subprocess.DEVNULL, "text": True, "env": env}
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, **quiet)
    try:
        path = proc.stdout.readline().strip()
        assert path.startswith("/dev/"), path
        # The quietest of three windows: the first may still hold its start-up on a loaded
        # machine (a busy-polling emulator is busy in all three).
        fraction = min(_busy(proc.pid, IDLE_S / 3) for _ in range(3))
        assert fraction < MAX_FRACTION, f"idle emulator used {fraction:.0%} of a core"
        port = serial.Serial(path, timeout=0.1)
        decoder = StreamDecoder()
        msgs, end = [], time.monotonic() + 10.0  # (a shared machine can be slow)
        try:
            while time.monotonic() < end and not any(m.type_name == "HELLO" for m in msgs):
                msgs += decoder.feed(port.read(256))
        finally:
            port.close()
        assert any(m.type_name == "HELLO" for m in msgs), "the host got no HELLO"
    finally:
        proc.terminate()
        proc.wait(5)
