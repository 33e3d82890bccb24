"""The C core under AddressSanitizer and UBSan, fed random command bytes by hypothesis.

``firmware/c/host/fuzz_harness.c`` runs a fresh board per script on a fake HAL in C
(always-ready converters, a byte queue, a clock that wraps, two flash slots); it is
built with ``-fsanitize=address,undefined -fno-sanitize-recover=all``, so any
out-of-bounds access, overflow or undefined shift aborts it with a report, which fails
the test. Each script mixes sensible and hostile command frames, raw bytes, runs,
gauge codes, bus failures, a host that stops reading or reopens, and a flash that
refuses writes. Everything the board writes must decode as valid frames within the
protocol's limits, and after the barrage it must still answer PING.
"""

import struct
import subprocess

import pytest
from conftest import FUZZ_SCALE
from hypothesis import given, settings
from hypothesis import strategies as st
from test_ccore_diff import framed, hostile, sensible
from toolchain import missing

from tactile.board.stream_decoder import StreamDecoder
from tactile_fw_tools import ccore
from tactile_protocol import constants as C


@pytest.fixture(scope="module")
def harness(tmp_path_factory):
    try:
        cc = ccore.compiler()
    except ccore.NoCompiler as exc:
        missing(str(exc))
    exe = tmp_path_factory.mktemp("fuzz") / "fuzz_harness"
    cmd = [cc, "-std=c99", "-Wall", "-Wextra", "-Werror", *ccore.SANITIZE, "-I", str(ccore.SRC)]
    cmd += [str(ccore.SRC / "host" / "fuzz_harness.c"), *map(str, ccore.sources()), "-o", str(exe)]
    r = subprocess.run(cmd, capture_output=True, text=True)
    if r.returncode != 0 and "asan" in r.stderr.lower():
        last = r.stderr.splitlines()[-1]
        missing(f"{cc} has no AddressSanitizer runtime (apt-get install gcc): {last}")
    assert r.returncode == 0, r.stderr
    proc = subprocess.Popen(
        [str(exe)], stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.PIPE
    )
    yield proc
    for pipe in (proc.stdin, proc.stdout, proc.stderr):
        try:
            pipe.close()
        except BrokenPipeError:  # the harness died: its report is already in a failure
            pass
    proc.wait(timeout=30)


def died(proc):
    proc.wait(timeout=30)
    return AssertionError("the harness died:\n" + proc.stderr.read().decode(errors="replace"))


def run(proc, script):
    if proc.poll() is not None:
        raise died(proc)
    try:
        proc.stdin.write(struct.pack("<I", len(script)) + script)
        proc.stdin.flush()
    except BrokenPipeError:
        raise died(proc) from None
    head = proc.stdout.read(4)
    if len(head) < 4:
        raise died(proc)
    (n,) = struct.unpack("<I", head)
    return proc.stdout.read(n)


def host_bytes(data):
    """Opcode 0 in chunks of at most 255 bytes."""
    out = b""
    for k in range(0, len(data), 255):
        chunk = data[k : k + 255]
        out += bytes((0, len(chunk))) + chunk
    return out


@st.composite
def op(draw):
    kind = draw(st.integers(0, 10))
    if kind <= 2:
        return host_bytes(draw(st.one_of(sensible(4), hostile(), st.binary(max_size=300))))
    if kind == 10:  # a run without delimiter around the assembler's limit
        return host_bytes(b"\x55" * draw(st.integers(C.MAX_ENCODED - 2, 700)) + b"\0")
    if kind <= 4:
        return bytes((1,)) + struct.pack("<H", draw(st.integers(0, 30_000)))
    if kind == 5:
        return bytes((2, draw(st.integers(0, 7)), draw(st.integers(0, 255))))
    if kind == 6:
        return bytes((3,)) + draw(st.binary(min_size=19, max_size=19))
    if kind == 7:
        return bytes((6, draw(st.integers(0, 255))))  # a sensor's DRDY stuck or freed
    return bytes((draw(st.sampled_from([4, 5, 7])),))  # reading, reopen, flash


START = host_bytes(framed(C.CMD_CONFIG, 1, "<BBHIHiiBB", (1000, 300_000, 200_000, 1, 3)))
START += host_bytes(framed(C.CMD_START, 2, "<BBHI", ()))
PING = host_bytes(b"\0" + framed(C.CMD_PING, 0xBEEF, "<BBHI", ()))


@settings(max_examples=150 * FUZZ_SCALE)
@given(st.integers(0, 3), st.booleans(), st.lists(op(), max_size=30))
def test_random_commands_under_sanitizers(harness, n, stream, ops):
    script = bytes((n,)) + (START if stream else b"") + b"".join(ops) + PING
    out = run(harness, script)
    decoder = StreamDecoder()
    msgs = decoder.feed(out)
    c = decoder.counters
    assert c.damaged == 0 and c.invalid == 0, c.as_dict()
    assert msgs and msgs[0].type_name == "HELLO" and msgs[0].n_sensors == n + 1
    acks = [(m.cmd_type, m.cmd_seq) for m in msgs if m.type_name == "ACK"]
    assert (C.CMD_PING, 0xBEEF) in acks
