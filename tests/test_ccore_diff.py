"""The C core against the Python firmware: the same inputs give the same output bytes.

Hypothesis draws a session: stored settings and calibration at boot, a start time (the
30-bit tick counter wraps in some), then a sequence of host commands (sensible ones,
any values of a command's types, crafted and damaged frames), gauge code patterns on
each sensor (ramps through the contact gate, full-scale codes), bus faults (timeouts,
NACKs, stuck DRDY), a host that stops reading or reopens the port, and a flash that
refuses writes. Both boards run on twin simulated hardware (``ccore_twin``), and after
every step the bytes each one wrote must be identical; at the end so must the counters.
"""

import struct

import numpy as np
from conftest import FUZZ_SCALE
from fw_rig import decode_frames
from fw_rig import name as frame_name
from hypothesis import given, settings
from hypothesis import strategies as st

from tactile_fw import calibration
from tactile_fw import settings as fw_settings
from tactile_protocol import constants as C
from tactile_protocol.cobs_codec import encode as cobs_encode
from tactile_protocol.crc16 import crc16
from tactile_protocol.messages import BY_TYPE

COMMANDS = [t for t in BY_TYPE if t >= 0x40]
_CODES = {
    "B": st.integers(0, 0xFF),
    "H": st.integers(0, 0xFFFF),
    "I": st.integers(0, 0xFFFFFFFF),
    "i": st.integers(-(2**31), 2**31 - 1),
    "f": st.floats(width=32),  # NaN and infinities included
}
COEFF = st.one_of(
    st.floats(-(2**-18), 2**-18, width=32),  # a realistic matrix: up to 3 uN per count
    st.floats(width=32),  # anything, NaN and huge included
    st.sampled_from([0.0, -0.0, 1e-6, 1.0, 1e-45, 3.4e38]),
)


def framed(mtype, seq, fmt, values, version=C.PROTOCOL_VERSION):
    body = struct.pack(fmt, version, mtype, seq, 0, *values)
    crc = crc16(body)
    return cobs_encode(body + bytes((crc & 0xFF, crc >> 8))) + b"\0"


def _fmt(mtype):
    return BY_TYPE[mtype][2]


@st.composite
def sensible(draw, n):
    """Commands a host sends, with values around the limits."""
    seq = draw(st.integers(0, 0xFFFF))
    kind = draw(st.sampled_from(["config", "config", "tare", "start", "stop", "cal", "ping"]))
    if kind == "config":
        rate = draw(st.sampled_from([1, 100, 500, 1000, 1730, 1740, 5000, 0]))
        enter = draw(st.sampled_from([0, 300_000, 1_000_000, 1_390_000, -5]))
        exit_ = draw(st.sampled_from([0, 200_000, 500_000, enter, enter + 1]))
        flags = draw(st.integers(0, 0x3F))
        values = (rate, enter, exit_, draw(st.sampled_from([1, 2, 3, 0, 255])), flags)
        return framed(C.CMD_CONFIG, seq, _fmt(C.CMD_CONFIG), values)
    if kind == "tare":
        sensor = draw(st.sampled_from([0, n - 1, n, 0xFF]))
        count = draw(st.sampled_from([0, 1, 3, 10, 10_001]))
        return framed(C.CMD_TARE, seq, _fmt(C.CMD_TARE), (sensor, count))
    if kind == "cal":
        sensor = draw(st.sampled_from([0, n - 1, n]))
        coeffs = draw(st.lists(COEFF, min_size=36, max_size=36))
        values = (sensor, draw(st.integers(0, 0xFFFFFFFF)), *coeffs)
        return framed(C.CMD_SET_CAL, seq, _fmt(C.CMD_SET_CAL), values)
    mtype = {"start": C.CMD_START, "stop": C.CMD_STOP, "ping": C.CMD_PING}[kind]
    return framed(mtype, seq, _fmt(mtype), ())


@st.composite
def hostile(draw):
    """Any values of a command's types, other versions and types, bad lengths, damage."""
    mtype = draw(st.one_of(st.sampled_from(COMMANDS), st.integers(0, 255)))
    seq = draw(st.integers(0, 0xFFFF))
    how = draw(st.sampled_from(["values", "values", "version", "length", "bytes", "flip"]))
    if how in ("values", "flip") and mtype in BY_TYPE:
        values = [draw(_CODES[c]) for c in BY_TYPE[mtype][5] if not c.endswith("s")]
        if BY_TYPE[mtype][5] and BY_TYPE[mtype][5][4:5] == ["16s"]:
            values.insert(4, b"x")
        frame = bytearray(framed(mtype, seq, _fmt(mtype), values))
        if how == "flip":
            frame[draw(st.integers(0, len(frame) - 2))] ^= 1 << draw(st.integers(0, 7))
        return bytes(frame)
    if how == "version":
        return framed(mtype, seq, "<BBHI", (), version=draw(st.integers(0, 255)))
    if how == "length":
        body = struct.pack("<BBHI", C.PROTOCOL_VERSION, mtype, seq, 0)
        body += draw(st.binary(max_size=C.MAX_PAYLOAD))[: draw(st.integers(0, C.MAX_PAYLOAD))]
        crc = crc16(body)
        return cobs_encode(body + bytes((crc & 0xFF, crc >> 8))) + b"\0"
    return draw(st.binary(max_size=300))


def noisy(base, amplitude):
    """Codes that change every instant, pseudo-randomly (so calibration rounds every way)."""

    def codes(t):
        out = []
        for j, b in enumerate(base):
            h = (int(t) * 2654435761 + j * 40503) & 0xFFFFFFFF
            out.append(max(-0x800000, min(0x7FFFFF, b + h % (2 * amplitude) - amplitude)))
        return tuple(out)

    return codes


def codes_pattern(draw):
    """Gauge codes against time: constant, a ramp through the gate, or full scale."""
    kind = draw(st.sampled_from(["const", "ramp", "ramp", "noise", "rail"]))
    base = draw(st.lists(st.integers(-200_000, 200_000), min_size=6, max_size=6))
    if kind == "const":
        c = tuple(base)
        return lambda t: c
    if kind == "rail":
        c = tuple(draw(st.sampled_from([0x7FFFFF, -0x800000, 0])) for _ in range(6))
        return lambda t: c
    if kind == "noise":
        return noisy(base, draw(st.integers(1, 2_000_000)))
    slope = draw(st.integers(-4000, 4000))  # counts per 100 us: crosses 1 N in ~25 ms
    span = draw(st.integers(1, 3_000_000))

    def ramp(t):
        k = (t // 100 * slope) % (2 * span)
        v = k if k < span else 2 * span - k
        return tuple(
            max(-0x800000, min(0x7FFFFF, b + v * (j + 1) // 2)) for j, b in enumerate(base)
        )

    return ramp


@st.composite
def operation(draw, n):
    kind = draw(
        st.sampled_from(["cmd", "cmd", "cmd", "hostile", "run", "run", "run", "codes", "fault"])
        | st.sampled_from(["pause", "open", "flash"])
    )
    if kind == "cmd":
        return ("put", draw(sensible(n)))
    if kind == "hostile":
        return ("put", draw(hostile()))
    if kind == "run":
        return ("run", draw(st.integers(1, 40_000)), draw(st.sampled_from([37, 50, 100, 700])))
    if kind == "codes":
        return ("codes", draw(st.integers(0, n - 1)), codes_pattern(draw))
    if kind == "fault":
        what = draw(st.sampled_from(["timeout", "nack", "unnack", "stuck", "unstuck"]))
        return ("fault", what, draw(st.integers(0, n - 1)), draw(st.integers(0, 5)))
    if kind == "pause":
        return ("pause", draw(st.booleans()))
    if kind == "flash":
        return ("flash", draw(st.booleans()))
    return ("open",)


def apply(twin, op):
    kind = op[0]
    if kind == "put":
        twin.put(op[1])
    elif kind == "run":
        return twin.run(op[1], op[2])
    elif kind == "codes":
        twin.each(lambda r: r.set_codes(op[1], op[2]))
    elif kind == "fault":
        _, what, sensor, j = op
        for r in twin.rigs:
            bus = r.buses[sensor % 2]
            model = r.models[sensor][j]
            addr = [a for a, d in bus.devices.items() if d is model][0]
            if what == "timeout":
                bus.fail_next(j + 1, 110)
            elif what == "nack":
                bus.nack.add(addr)
            elif what == "unnack":
                bus.nack.discard(addr)
            else:
                model.stuck_drdy = what == "stuck"
    elif kind == "pause":
        twin.each(lambda r: setattr(r.link, "paused", op[1]))
    elif kind == "flash":
        twin.each(lambda r: setattr(r.storage, "fail_writes", op[1]))
    else:
        twin.each(lambda r: r.link.host_open())
    return twin.step(repr(op[:2]))


@st.composite
def stored_files(draw, n):
    """What the flash holds at power-up: nothing, settings (maybe autostart), calibrations."""
    files = {}
    if draw(st.booleans()):
        flags = draw(st.integers(0, 0x1F) | st.just(C.CFG_AUTOSTART | C.CFG_STREAM_SAMPLES | 2))
        s = fw_settings.Settings(
            draw(st.sampled_from([100, 1000, 1730])), 900_000, 600_000, 2, flags
        )
        files[fw_settings.FILE_NAME] = s.to_bytes()
    for i in range(n):
        if draw(st.booleans()):
            coeffs = [draw(st.floats(-(2**-18), 2**-18, width=32)) for _ in range(36)]
            files[calibration.file_name(i)] = calibration.Calibration(coeffs, i + 7).to_bytes(i)
    return files


START_TIMES = st.sampled_from([0, 12_345, (1 << 30) - 20_000, (1 << 32) - 30_000, 7 << 30])


@settings(max_examples=60 * FUZZ_SCALE)
@given(
    st.integers(1, 4).flatmap(
        lambda n: st.tuples(
            st.just(n),
            stored_files(n),
            START_TIMES,
            st.integers(0, 0xFFFFFFFF),
            st.lists(operation(n), min_size=3, max_size=25),
        )
    )
)
def test_same_session_same_bytes(ccore_lib, session):
    from ccore_twin import Twin

    n, files, t0, boot_id, ops = session
    twin = Twin(ccore_lib, n=n, t0=t0, files=files, boot_id=boot_id)
    twin.boot()
    for op in ops:
        apply(twin, op)
    twin.run(30_000)
    for name in ("samples", "i2c_errors", "drdy_timeouts", "saturations", "rx_errors"):
        assert getattr(twin.c.board, name) == getattr(twin.py.board, name) & 0xFFFFFFFF, name
    assert twin.c.board.overruns == twin.py.board.sched.overruns
    assert twin.c.board.tx_dropped == twin.py.board.tx.dropped
    assert twin.c.storage.files == twin.py.storage.files  # the same blobs on flash


def test_a_streaming_session_is_long_and_identical(ccore_lib):
    """A fixed, busy session: contacts opening and closing on two sensors, a fault, TARE."""
    from ccore_twin import Twin

    twin = Twin(ccore_lib, n=2, t0=(1 << 30) - 50_000, boot_id=0xC0FFEE)
    twin.boot()
    rng = np.random.default_rng(5)
    matrix = np.eye(6) * 1.5e-6 + rng.normal(0, 3e-8, (6, 6))
    cal = (0, 77, *[float(np.float32(v)) for v in matrix.ravel()])
    twin.put(framed(C.CMD_CONFIG, 1, _fmt(C.CMD_CONFIG), (1000, 1_000_000, 500_000, 2, 3)))
    twin.put(framed(C.CMD_SET_CAL, 2, _fmt(C.CMD_SET_CAL), cal))
    twin.put(framed(C.CMD_START, 3, "<BBHI", ()))
    ramp = noisy((0, 20_000, -30_000, 400, 500, -600), 40_000)
    twin.each(lambda r: r.set_codes(0, lambda t: ((t // 1000) % 40 * 60_000,) + ramp(t)[1:]))
    twin.each(lambda r: r.set_codes(1, lambda t: (0, (t // 700) % 30 * 90_000) + ramp(t)[2:]))
    out = twin.run(200_000)
    twin.each(lambda r: r.buses[0].fail_next(3, 110))
    out += twin.run(50_000)
    twin.each(lambda r: setattr(r.models[1][2], "stuck_drdy", True))
    out += twin.run(30_000)
    twin.each(lambda r: setattr(r.models[1][2], "stuck_drdy", False))
    out += twin.run(30_000)
    twin.put(framed(C.CMD_TARE, 4, _fmt(C.CMD_TARE), (0xFF, 20)))
    out += twin.run(60_000)
    frames = out.count(b"\0")
    assert frames > 500 and twin.c.board.samples > 500
    assert twin.c.board.i2c_errors == twin.py.board.i2c_errors >= 1
    assert twin.c.board.drdy_timeouts == twin.py.board.drdy_timeouts >= 1


@settings(max_examples=200 * FUZZ_SCALE)
@given(
    st.lists(COEFF, min_size=36, max_size=36),
    st.lists(st.integers(-(2**23), 2**23 - 1), min_size=6, max_size=6),  # a TARE's mean
    st.integers(1, 100),
    st.lists(st.integers(-(2**23), 2**23 - 1), min_size=6, max_size=6),
)
def test_calibration_is_the_same_integers(ccore_lib, coeffs, mean, n, counts):
    """tc_cal_apply against Calibration.apply: any float32 matrix, any bias, any codes."""
    import ctypes

    sums = [m * n + (k * 7919 % n) * (1 if m < 2**23 - 1 else 0) for k, m in enumerate(mean)]
    if calibration.bad_coefficient(coeffs) >= 0:
        return
    py = calibration.Calibration(coeffs)
    py.set_bias_sums(sums, n)
    cal = ctypes.create_string_buffer(ccore_lib.tc_cal_size())
    bits = (ctypes.c_uint32 * 36)(*struct.unpack("<36I", struct.pack("<36f", *coeffs)))
    ccore_lib.tc_cal_set(cal, bits, 0)
    ccore_lib.tc_cal_set_bias_sums(cal, (ctypes.c_int64 * 6)(*sums), n)
    out = (ctypes.c_int32 * 6)()
    want = [0] * 6
    for g in (counts, [0] * 6, [2**23 - 1] * 6, [-(2**23)] * 6, [v // 3 for v in counts]):
        ccore_lib.tc_cal_apply(cal, (ctypes.c_int32 * 6)(*g), out)
        py.apply(g, want)
        assert list(out) == want, (g, py.shift)


_TRIPLES = [(3, 4, 0, 5), (5, 12, 0, 13), (2, 3, 6, 7), (1, 4, 8, 9), (20, 21, 0, 29)]


@st.composite
def gate_case(draw):
    """Levels and forces with exact ties of |F| (Pythagorean triples) and near misses."""
    x, y, z, m = draw(st.sampled_from(_TRIPLES))
    k = draw(st.integers(1, 46_000_000 // 29))
    enter = m * k
    exit_ = draw(st.integers(0, enter))
    forces = []
    for _ in range(draw(st.integers(1, 40))):
        d = draw(st.sampled_from([-1, 0, 0, 0, 1]))
        sx, sy, sz = (draw(st.sampled_from([-1, 1])) for _ in range(3))
        lvl = draw(st.sampled_from([k, (exit_ // m) or k]))
        f = (sx * (x * lvl + d), sy * y * lvl, sz * z * lvl)
        forces.append(draw(st.sampled_from([f, f, (0, 0, 0), tuple(3 * v for v in f)])))
    return enter, exit_, draw(st.integers(1, 4)), draw(st.booleans()), forces


@settings(max_examples=300 * FUZZ_SCALE)
@given(gate_case())
def test_gate_is_the_same_on_ties(ccore_lib, case):
    """tc_gate_update against ContactGate.update, where |F| equals a level exactly."""
    import ctypes

    from tactile_fw.gate import ContactGate

    enter, exit_, debounce, three_d, forces = case
    py = ContactGate(enter, exit_, debounce, three_d)
    g = ctypes.create_string_buffer(ccore_lib.tc_gate_size())
    ccore_lib.tc_gate_configure(g, enter, exit_, debounce, three_d)
    for f in forces:
        assert ccore_lib.tc_gate_update(g, *f) == py.update(*f), (f, py.in_contact)


# --- TARE refused under load (PROTOCOL.md §4): the same NAK, the same biases after --------
LOADED = (2_000_000, 0, 0, 0, 0, 0)  # fx = 2 N through the identity: above the 1.39 N gate
OFFSET = (300_000, -200_000, 100_000, 50, 60, 70)  # an unloaded sensor's own offset


def _calibrated(lib, n, which=None):
    """Twins with the identity (1 uN per count) stored for the sensors in ``which``."""
    from ccore_twin import Twin

    files = {
        calibration.file_name(i): calibration.Calibration(calibration.identity(), 7).to_bytes(i)
        for i in (range(n) if which is None else which)
    }
    twin = Twin(lib, n=n, files=files, boot_id=0xBEEF)
    twin.boot()
    return twin


def _tare_replies(data, seq):
    return [
        (frame_name(f), f[3])
        for f in decode_frames(data)
        if frame_name(f) in ("ACK", "NAK") and f[3][0] == C.CMD_TARE and f[3][1] == seq
    ]


def _tare(twin, seq, sensor, n=20, us=100_000):
    twin.put(framed(C.CMD_TARE, seq, _fmt(C.CMD_TARE), (sensor, n)))
    return _tare_replies(twin.run(us), seq)


def _stream_samples(twin, seq):
    """Both boards stream SAMPLE frames for 20 ms: their values show the biases in force."""
    twin.put(framed(C.CMD_CONFIG, seq, _fmt(C.CMD_CONFIG), (500, 1_390_000, 1_112_000, 3, 1)))
    twin.put(framed(C.CMD_START, seq + 1, "<BBHI", ()))
    return twin.run(20_000)


def test_tare_of_a_loaded_idle_board_is_refused_the_same_and_keeps_every_bias(ccore_lib):
    twin = _calibrated(ccore_lib, 3)
    twin.each(lambda r: r.set_codes(0, OFFSET))
    assert [k for k, _ in _tare(twin, 1, 0xFF)] == ["ACK"]  # sensor 0 tared to its offset
    twin.each(lambda r: r.set_codes(0, [c + 1000 for c in OFFSET]))  # its offset drifts
    twin.each(lambda r: r.set_codes(1, LOADED))  # and sensor 1 is pressed
    assert _tare(twin, 2, 0xFF) == [("NAK", (C.CMD_TARE, 2, C.NAK_LOADED, 1))]
    samples = [f[3] for f in decode_frames(_stream_samples(twin, 3)) if frame_name(f) == "SAMPLE"]
    assert len(samples) > 20
    assert {s[2:5] for s in samples if s[0] == 0} == {(1000, 1000, 1000)}  # the old bias


def test_tare_while_a_contact_is_open_is_refused_at_once_the_same(ccore_lib):
    twin = _calibrated(ccore_lib, 2)
    _stream_samples(twin, 1)
    twin.each(lambda r: r.set_codes(1, LOADED))
    twin.run(10_000)
    assert twin.py.board.gates[1].in_contact
    twin.put(framed(C.CMD_TARE, 5, _fmt(C.CMD_TARE), (0xFF, 50)))
    assert _tare_replies(twin.run(100), 5) == [("NAK", (C.CMD_TARE, 5, C.NAK_LOADED, 1))]
    assert _tare(twin, 6, 0) == [("ACK", (C.CMD_TARE, 6))]  # sensor 0 alone is not loaded


def test_an_uncalibrated_sensor_is_tared_under_load_the_same(ccore_lib):
    twin = _calibrated(ccore_lib, 2, which=[1])
    twin.each(lambda r: r.set_codes(0, LOADED))
    assert [k for k, _ in _tare(twin, 1, 0xFF)] == ["ACK"]
    _stream_samples(twin, 2)


GATE_FX = st.sampled_from([0, 1_389_999, 1_390_000, 1_390_001, 2_000_000, -2_000_000, 900_000])


@st.composite
def gate_codes(draw):
    """Codes of a force near the gate (1 uN per count), steady or noisy."""
    fx, amp = draw(GATE_FX), draw(st.sampled_from([0, 1, 3_000, 800_000]))
    base = (fx, draw(st.sampled_from([0, 600_000])), 0, 0, 0, 0)
    return noisy(base, amp) if amp else lambda t: base


@st.composite
def tare_operation(draw, n):
    kind = draw(st.sampled_from(["tare", "tare", "run", "run", "codes", "config", "start", "stop"]))
    seq = draw(st.integers(0, 0xFFFF))
    if kind == "tare":  # and time for it to finish (or not)
        sensor = draw(st.sampled_from([0xFF, *range(n)]))
        values = (sensor, draw(st.integers(0, 40)))
        run = ("run", draw(st.integers(1, 60_000)), 100)
        return [("put", framed(C.CMD_TARE, seq, _fmt(C.CMD_TARE), values)), run]
    if kind == "run":
        return ("run", draw(st.integers(1, 60_000)), draw(st.sampled_from([50, 100, 700])))
    if kind == "codes":
        return ("codes", draw(st.integers(0, n - 1)), draw(gate_codes()))
    if kind == "config":
        enter = draw(st.sampled_from([0, 1_390_000, 2_000_000]))
        values = (1000, enter, enter // 2, draw(st.sampled_from([1, 2, 3, 5])), draw(GATE_FLAGS))
        return ("put", framed(C.CMD_CONFIG, seq, _fmt(C.CMD_CONFIG), values))
    mtype = C.CMD_START if kind == "start" else C.CMD_STOP
    return ("put", framed(mtype, seq, "<BBHI", ()))


GATE_FLAGS = st.sampled_from([0, 1, 2, 3, C.CFG_GATE_3D | 3])


@settings(max_examples=50 * FUZZ_SCALE)
@given(
    st.integers(1, 3).flatmap(
        lambda n: st.tuples(
            st.just(n),
            st.lists(st.sampled_from([True, True, False]), min_size=n, max_size=n),
            st.lists(gate_codes(), min_size=n, max_size=n),
            st.lists(tare_operation(n), min_size=4, max_size=20),
        )
    )
)
def test_tare_near_the_gate_is_the_same(ccore_lib, session):
    """TAREs among loads around the gate level, noisy or steady, streaming or idle."""
    n, calibrated, codes, ops = session
    twin = _calibrated(ccore_lib, n, which=[i for i in range(n) if calibrated[i]])
    for i, fn in enumerate(codes):
        twin.each(lambda r, i=i, fn=fn: r.set_codes(i, fn))
    for op in ops:
        for step in op if isinstance(op, list) else [op]:
            apply(twin, step)
    twin.run(60_000)
    _stream_samples(twin, 0xFFF0)  # the biases each board ended with, in its samples
