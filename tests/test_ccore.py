"""The C core (firmware/c) against protocol/vectors.json, byte for byte, and its build rules.

The library is built by ``cc`` for this run (``ccore_lib`` in conftest); without a C
compiler these tests skip with the reason. The generated tables are checked without one.
"""

import ctypes
import importlib.util
import pathlib
import shutil
import struct
import subprocess

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from toolchain import arm_gcc, arm_tool, missing

from tactile_fw_tools import ccore
from tactile_protocol import constants as C
from tactile_protocol.cobs_codec import encode as cobs_encode
from tactile_protocol.crc16 import crc16
from tactile_protocol.framing import FRAME_OK, FrameAssembler
from tactile_protocol.messages import BY_NAME, BY_TYPE, SPECS, field_codes, unpack

GEN = pathlib.Path(ccore.__file__).with_name("c_tables.py")
_NATIVE = {0: "B", 1: "H", 2: "I", 3: "i", 4: "f"}  # tc_field_t.kind -> struct code
_SIZE = {"B": 1, "H": 2, "I": 4, "i": 4, "f": 4}


def generator():
    spec = importlib.util.spec_from_file_location("gen_tables", GEN)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def test_generated_tables_are_current():
    """Regenerating from tactile_protocol and tactile_fw gives the committed bytes."""
    gen = generator()
    for name, render in gen.OUTPUTS.items():
        committed = (ccore.SRC / name).read_text()
        assert render() == committed, f"firmware/c/{name} is stale: run python {GEN}"


def _fields(lib, mtype):
    d = lib.tc_msg_desc(mtype).contents
    return d, [d.fields[k] for k in range(d.n_fields)]


def test_descriptor_table_is_the_python_table(ccore_lib):
    """Each message's fields in order, at consecutive wire offsets, up to its body length."""
    for mtype, name, fmt, _ in SPECS:
        d, rows = _fields(ccore_lib, mtype)
        assert (d.type, d.name.decode(), d.body_len) == (mtype, name, BY_TYPE[mtype][3])
        codes = field_codes(fmt)
        wire = C.HEADER_SIZE
        k = 0
        for r in rows:
            if r.kind == 5:
                assert codes[k] == f"{r.count}s"
                size, k = r.count, k + 1
            else:
                assert codes[k : k + r.count] == [_NATIVE[r.kind]] * r.count
                size, k = _SIZE[_NATIVE[r.kind]] * r.count, k + r.count
            assert r.wire == wire, (name, r.wire)
            wire += size
        assert (k, wire) == (len(codes), d.body_len), name
    assert not ccore_lib.tc_msg_desc(0x08) and not ccore_lib.tc_msg_desc(0x47)


def to_struct(lib, mtype, values):
    """The message struct (tc_msg_t) holding ``values``, laid out by the C table itself."""
    buf = ctypes.create_string_buffer(lib.tc_msg_size())
    _, rows = _fields(lib, mtype)
    k = 0
    for r in rows:
        if r.kind == 5:  # bytes
            raw = bytes(values[k]).ljust(r.count, b"\0")
            ctypes.memmove(ctypes.addressof(buf) + r.mem, raw, r.count)
            k += 1
            continue
        code = _NATIVE[r.kind]
        for j in range(r.count):
            struct.pack_into("=" + code, buf, r.mem + j * _SIZE[code], values[k])
            k += 1
    return buf


def from_struct(lib, mtype, buf):
    _, rows = _fields(lib, mtype)
    out = []
    for r in rows:
        if r.kind == 5:
            out.append(bytes(buf.raw[r.mem : r.mem + r.count]))
            continue
        code = _NATIVE[r.kind]
        for j in range(r.count):
            out.append(struct.unpack_from("=" + code, buf, r.mem + j * _SIZE[code])[0])
    return tuple(out)


def _values(case):
    entry = BY_NAME[case["type"]]
    out = []
    for f, c in zip(entry[4], entry[5]):
        v = case["fields"][f]
        out.append(bytes.fromhex(v) if c.endswith("s") else v)
    return out


def test_crc_vectors(ccore_lib, vectors):
    for case in vectors["crc16"]:
        data = bytes.fromhex(case["data_hex"])
        assert ccore_lib.tc_crc16(data, len(data), 0xFFFF) == case["crc"]


def test_cobs_vectors(ccore_lib, vectors):
    for case in vectors["cobs"]:
        raw, enc = bytes.fromhex(case["decoded_hex"]), bytes.fromhex(case["encoded_hex"])
        out = (ctypes.c_uint8 * (len(raw) + len(raw) // 254 + 1))()
        n = ccore_lib.tc_cobs_encode(raw, len(raw), out)
        assert bytes(out[:n]) == enc, case["name"]
        buf = (ctypes.c_uint8 * max(1, len(enc)))(*enc)
        assert ccore_lib.tc_cobs_decode_in_place(buf, len(enc)) == len(raw), case["name"]
        assert bytes(buf[: len(raw)]) == raw, case["name"]


@settings(max_examples=200, deadline=None)
@given(st.binary(max_size=600), st.integers(0, 0xFFFF))
def test_crc_and_cobs_on_any_bytes(ccore_lib, data, seed):
    """The unrolled CRC (odd and even lengths, any start value) and COBS's frame-sized and
    long forms (runs of 254+ non-zero bytes) against the Python codecs."""
    assert ccore_lib.tc_crc16(data, len(data), seed) == crc16(data, 0, len(data), seed)
    out = (ctypes.c_uint8 * (len(data) + len(data) // 254 + 1))()
    n = ccore_lib.tc_cobs_encode(data, len(data), out)
    assert bytes(out[:n]) == cobs_encode(data)
    for size in (253, 254, 255, 400, 508, 509):  # no zeros: blocks fill up
        run = bytes((b or 1) for b in data[:size]).ljust(size, bytes([seed % 255 + 1]))
        out = (ctypes.c_uint8 * (size + size // 254 + 1))()
        n = ccore_lib.tc_cobs_encode(run, size, out)
        assert bytes(out[:n]) == cobs_encode(run)


def encode(lib, mtype, seq, ts, values):
    """pack + CRC + COBS through the C core: tc_pack, tc_crc16, tc_cobs_encode."""
    body = (ctypes.c_uint8 * C.MAX_BODY)()
    n = lib.tc_pack(body, mtype, seq, ts, to_struct(lib, mtype, values))
    raw = bytes(body[:n])
    crc = lib.tc_crc16(raw, n, 0xFFFF)
    raw += bytes((crc & 0xFF, crc >> 8))
    out = (ctypes.c_uint8 * C.MAX_FRAME)()
    m = lib.tc_cobs_encode(raw, len(raw), out)
    return bytes(out[:m]) + b"\0"


def test_every_frame_vector_packs_and_unpacks(ccore_lib, vectors):
    for case in vectors["frames"]:
        mtype, values = case["type_code"], _values(case)
        frame = encode(ccore_lib, mtype, case["seq"], case["timestamp_us"], values)
        assert frame.hex() == case["frame_hex"], (case["type"], case["group"])
        asm = ccore.Assembler()
        ccore_lib.tc_assembler_init(ctypes.byref(asm))
        results = [ccore_lib.tc_assembler_feed(ctypes.byref(asm), b) for b in frame]
        assert results[-1] == FRAME_OK and set(results[:-1]) == {0}
        header, msg = ccore.Header(), ctypes.create_string_buffer(ccore_lib.tc_msg_size())
        body = bytes(asm.buf)
        assert ccore_lib.tc_unpack(body, asm.body_len, ctypes.byref(header), msg) == 0
        assert (header.type, header.seq, header.timestamp_us) == (
            mtype,
            case["seq"],
            case["timestamp_us"],
        )
        assert from_struct(ccore_lib, mtype, msg) == unpack(_body(case))[3]


def _body(case):
    from tactile_protocol.cobs_codec import decode

    return decode(bytes.fromhex(case["frame_hex"])[:-1])[:-2]


def test_the_encoder_gives_the_vector_bytes_and_counts_seq(ccore_lib, vectors):
    """tc_encode (the board's path): the typical frames, with seq from the encoder."""
    for case in vectors["frames"]:
        if case["group"] != "typical":
            continue
        enc = ccore.Encoder(seq=case["seq"])
        values = to_struct(ccore_lib, case["type_code"], _values(case))
        n = ccore_lib.tc_encode(ctypes.byref(enc), case["type_code"], case["timestamp_us"], values)
        assert bytes(enc.out[:n]).hex() == case["frame_hex"], case["type"]
        assert enc.seq == (case["seq"] + 1) & 0xFFFF


def _c_feed(lib, data):
    asm = ccore.Assembler()
    lib.tc_assembler_init(ctypes.byref(asm))
    out = []
    for b in data:
        r = lib.tc_assembler_feed(ctypes.byref(asm), b)
        if r == FRAME_OK:
            h, msg = ccore.Header(), ctypes.create_string_buffer(lib.tc_msg_size())
            ok = lib.tc_unpack(bytes(asm.buf), asm.body_len, ctypes.byref(h), msg)
            out.append((r, ok, h.type, h.seq, from_struct(lib, h.type, msg) if not ok else ()))
        else:
            out.append((r,))
    return out


def _py_feed(data):
    asm = FrameAssembler()
    out = []
    for b in data:
        r = asm.feed(b)
        if r == FRAME_OK:
            body, n = asm._buf, asm._body_len
            try:
                mtype, seq, _, values = asm.message()
                out.append((r, 0, mtype, seq, tuple(values)))
            except ValueError:  # the reason, as tc_unpack numbers it
                if n < C.HEADER_SIZE:
                    out.append((r, 1, 0, 0, ()))
                    continue
                why = 2 if body[0] != C.PROTOCOL_VERSION else 3 if body[1] not in BY_TYPE else 4
                out.append((r, why, body[1], body[2] | body[3] << 8, ()))
        else:
            out.append((r,))
    return out


def test_stream_vectors_through_the_board_assembler(ccore_lib, vectors):
    """Every stream, byte by byte: the same result per byte as the Python assembler, and every
    frame the host delivers without salvage is one the board assembler delivers too."""
    for case in vectors["streams"]:
        data = bytes.fromhex(case["input_hex"])
        got = _c_feed(ccore_lib, data)
        assert got == _py_feed(data), case["name"]
        delivered = [g[3] for g in got if len(g) > 1 and g[1] == 0]
        if not case["counters"]["salvaged"]:
            assert delivered == case["delivered_seqs"], case["name"]
        assert set(delivered) <= set(case["delivered_seqs"]), case["name"]


def test_the_core_calls_no_allocator(tmp_path):
    """No malloc/calloc/realloc/free/printf in any object of the core (nm -u)."""
    nm = shutil.which("nm")
    try:
        cc = ccore.compiler()
    except ccore.NoCompiler as exc:
        missing(str(exc))
    if nm is None:
        missing("nm: apt-get install binutils")
    for src in ccore.sources():
        obj = tmp_path / (src.stem + ".o")
        subprocess.run([cc, *ccore.CFLAGS, "-c", str(src), "-o", str(obj)], check=True)
        undefined = subprocess.run([nm, "-u", str(obj)], capture_output=True, text=True).stdout
        names = {line.split()[-1] for line in undefined.splitlines() if line.strip()}
        banned = {"malloc", "calloc", "realloc", "free", "printf", "fprintf", "abort", "exit"}
        assert not names & banned, (src.name, names & banned)
        assert names <= {"memcpy", "memset", "memcmp", "memmove"} | {
            n for n in names if n.startswith(("tc_", "__stack_chk", "_GLOBAL_OFFSET"))
        }, (src.name, names)


def test_a_refused_configuration_is_an_error_not_a_crash(ccore_lib):
    from fw_rig import Rig

    rig = Rig(n=1)
    with pytest.raises(ValueError, match="sensor count"):
        ccore.CBoard(ccore_lib, rig.buses, [], rig.link, rig.clock, rig.storage)
    with pytest.raises(ValueError, match="address slot"):
        ccore.CBoard(ccore_lib, rig.buses, [(0, 5)], rig.link, rig.clock, rig.storage)
    with pytest.raises(ValueError, match="tx buffer"):
        ccore.CBoard(ccore_lib, rig.buses, [(0, 0)], rig.link, rig.clock, rig.storage, tx_size=9)


def test_the_core_compiles_for_a_cortex_m0plus(tmp_path):
    """arm-none-eabi-gcc -mcpu=cortex-m0plus -Os, warnings as errors (skipped without it)."""
    cc = arm_gcc()
    flags = ["-std=c99", "-mcpu=cortex-m0plus", "-mthumb", "-Os", "-Wall", "-Wextra"]
    flags += ["-Wpedantic", "-Wconversion", "-Werror", "-I", str(ccore.SRC)]
    for src in ccore.sources():
        subprocess.run([cc, *flags, "-c", str(src), "-o", str(tmp_path / "x.o")], check=True)


def test_the_core_compiles_as_a_micropython_native_module_would(tmp_path):
    """With MicroPython's natmod flags for ARCH=armv6m (py/dynruntime.mk: position-independent
    Thumb-1), the core needs from outside only libgcc's helpers and memcpy/memset/memcmp; it
    has no BSS, and its one initialised object in a writable section is the message table,
    whose pointers the loader relocates (docs/firmware.md, "Flashing a Pico")."""
    cc, ld, nm = arm_gcc(), arm_tool("ld"), arm_tool("nm")
    flags = ["-std=c99", "-mthumb", "-mcpu=cortex-m0", "-Os", "-fpic", "-fno-common"]
    flags += ["-Wall", "-Werror", "-I", str(ccore.SRC)]
    objs = []
    for src in ccore.sources():
        objs.append(tmp_path / (src.stem + ".o"))
        subprocess.run([cc, *flags, "-c", str(src), "-o", str(objs[-1])], check=True)
    subprocess.run([ld, "-r", "-o", str(tmp_path / "core.o"), *map(str, objs)], check=True)
    out = subprocess.run([nm, "-u", str(tmp_path / "core.o")], capture_output=True, text=True)
    undefined = {line.split()[-1] for line in out.stdout.splitlines() if line.strip()}
    libc = {"memcpy", "memset", "memcmp", "_GLOBAL_OFFSET_TABLE_"}
    assert undefined and all(s in libc or s.startswith("__") for s in undefined), undefined
    out = subprocess.run([nm, str(tmp_path / "core.o")], capture_output=True, text=True)
    syms = [line.split()[1:] for line in out.stdout.splitlines() if len(line.split()) == 3]
    assert not [n for k, n in syms if k in "BbC"], "no state outside the caller's structs"
    assert [n for k, n in syms if k in "Dd"] == ["tc_messages"]
