"""Hostile-world probes, "A device that lies" (issue 12): the real CLI against lying devices.

Each probe runs ``tactile`` in-process (``tactile.cli.main.main``, output captured)
against a crafted capture, a real pseudo-terminal served by a scripted device whose
frames are well framed but lie, or a path given to ``emulate --link``; it checks the
exit code, a one-line stderr, no traceback, no raw control character, and that nothing
received is lost.  Run through ``bench/reliability.py --area device``.
"""

import contextlib
import io
import json
import math
import os
import select
import tempfile
import threading
import time
import traceback
import tty
from pathlib import Path

from tactile.board.stream_decoder import StreamDecoder
from tactile.cli.main import main
from tactile_protocol import constants as C
from tactile_protocol.framing import FrameEncoder
from tactile_protocol.messages import BY_NAME

AREA = "A device that lies"

VALID = dict(fw_major=1, fw_minor=2, fw_patch=3, protocol_version=C.PROTOCOL_VERSION,
             sensor_model=b"FT6", n_sensors=1, max_rate_hz=1730, cal_id_0=7, rate_hz=1000,
             enter_threshold=1390000, exit_threshold=1112000, debounce=3,
             flags=C.CFG_STREAM_CONTACTS)  # fmt: skip
ESC_MODEL = b"\x1b[31m\x1b[2J\nOK"


def info(**changes):
    """A valid HELLO/INFO payload with ``changes`` (fields not named in VALID: 0)."""
    values = {**VALID, **changes}
    _, _, _, _, fields, codes = BY_NAME["HELLO"]
    return tuple(values.get(f, b"" if c.endswith("s") else 0) for f, c in zip(fields, codes))


GOOD = info()


def frame(mtype, values, seq=0):
    return bytes(FrameEncoder(seq).encode(mtype, 1000 * seq, values, False))


class PtyLiar:
    """A scripted device behind a real pty: HELLO until spoken to, INFO + ACK to GET_INFO,
    ``reply(command)`` (default ACK) to the rest and, once started, the ``stream`` frames."""

    def __init__(self, hello=GOOD, info=None, stream=(), reply=None):
        self.master, self.slave = os.openpty()  # the slave stays open: writes never fail
        tty.setraw(self.slave)
        self.path = os.ttyname(self.slave)
        os.set_blocking(self.master, False)
        self.enc = FrameEncoder()
        self.hello, self.info, self.stream = hello, info or hello, list(stream)
        self.reply = reply or (lambda m: [(C.MSG_ACK, (m.type_code, m.seq))])
        self.stop = threading.Event()
        self.thread = threading.Thread(target=self._run, daemon=True)

    def __enter__(self):
        self.thread.start()
        return self

    def __exit__(self, *exc):
        self.stop.set()
        self.thread.join(2)
        os.close(self.master)
        os.close(self.slave)

    def _send(self, mtype, values):
        try:
            os.write(self.master, self.enc.encode(mtype, 1000 * self.enc.seq, values, False))
        except BlockingIOError:
            pass  # nobody reads: dropped, as a board drops

    def _run(self):
        commands, spoken_to, streaming, hello_at = StreamDecoder(), False, False, 0
        while not self.stop.is_set():
            if select.select([self.master], [], [], 0.01)[0]:
                for m in commands.feed(os.read(self.master, 4096)):
                    spoken_to = True
                    if m.type_code == C.CMD_GET_INFO:
                        self._send(C.MSG_INFO, self.info)
                    streaming = streaming or m.type_code == C.CMD_START
                    for mtype, values in self.reply(m):
                        self._send(mtype, values)
            if not spoken_to and time.monotonic() - hello_at > 0.05:
                hello_at = time.monotonic()  # (pyserial discards what came before the open)
                self._send(C.MSG_HELLO, self.hello)
            if streaming and self.stream:
                self._send(*self.stream.pop(0))


def cli(*args):
    """``tactile ARGS`` in-process: (exit code or None, stdout, stderr + any traceback)."""
    out, err = io.StringIO(), io.StringIO()
    try:
        with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
            code = main([str(a) for a in args])
    except BaseException:  # the probe records what escaped
        return None, out.getvalue(), err.getvalue() + traceback.format_exc()
    return code, out.getvalue(), err.getvalue()


def verdict(result, code, has=(), one_line_error=None):
    """'held' or 'FAILED: why' for a CLI result against the promise."""
    got, out, err = result
    raw = sorted({repr(ch) for ch in out + err if not (ch.isprintable() or ch == "\n")})
    if "Traceback" in err:
        return "FAILED: traceback: " + err.strip().splitlines()[-1]
    if got != code:
        return f"FAILED: exit {got}, expected {code}: {err.strip()[:200]}"
    if raw:
        return "FAILED: raw control characters " + " ".join(raw)
    if one_line_error is not None and (err.count("\n") != 1 or one_line_error not in err):
        return f"FAILED: stderr is not one line with {one_line_error!r}: {err!r}"
    missing = [h for h in has if h not in out + err]
    return f"FAILED: output lacks {missing[0]!r}" if missing else "held"


def _all(*checks):
    """The first failure among ``checks`` (strings or callables), else 'held'."""
    for c in checks:
        c = c() if callable(c) else c
        if c != "held":
            return c
    return "held"


def _expect(cond, why):
    return "held" if cond else f"FAILED: {why}"


# -- the probes: (probe, promise, function returning the outcome) ---------------------------


def info_escapes():
    with PtyLiar(info(sensor_model=ESC_MODEL)) as dev:
        return verdict(cli("info", "--port", dev.path), 0, has=[r"\x1b[31m\x1b[2J\nOK x 1"])


def decode_escapes(tmp, as_json):
    path = tmp / "esc.bin"
    path.write_bytes(frame(C.MSG_HELLO, info(sensor_model=ESC_MODEL)))
    if as_json:
        return verdict(cli("decode", path, "--json"), 0, has=[r"\u001b[31m\u001b[2J\nOK"])
    return verdict(cli("decode", path), 0, has=[r"sensor_model=\x1b[31m\x1b[2J\nOK "])


def decode_non_finite(tmp):
    path = tmp / "cal.bin"
    coeffs = [1.0] * 36
    coeffs[0], coeffs[1] = math.nan, math.inf
    path.write_bytes(frame(C.CMD_SET_CAL, (0, 1, *coeffs)))
    text, js = cli("decode", path), cli("decode", path, "--json")
    words = set((text[1] + js[1]).replace(":", " ").replace(",", " ").split())
    return _all(
        verdict(text, 0, has=["INVALID  SET_CAL seq=0 timestamp_us=0: c00 is not finite"]),
        verdict(js, 0, has=['"error":"c00 is not finite']),
        _expect(not {"nan", "inf", "NaN", "Infinity"} & words, "NaN or inf in the output"),
    )


def info_refuses(hello, info_=None, line=""):
    with PtyLiar(hello, info_) as dev:
        return verdict(cli("info", "--port", dev.path), 4, one_line_error=line)


def record_refuses(tmp):
    out = tmp / "rec255"
    with PtyLiar(info(n_sensors=255)) as dev:
        result = cli("record", "--port", dev.path, "--duration", "5", "-o", out, "--quiet")
    line = "invalid HELLO: n_sensors = 255 (protocol allows 1..4)"

    def files():
        meta = json.loads((out / "meta.json").read_text())
        kept = meta["bytes"] == (out / "capture.bin").stat().st_size > 0
        return _expect(
            meta["ended"] == "error" and meta["decoder"]["invalid"] >= 1 and kept,
            f"meta.json: ended {meta['ended']}, decoder {meta['decoder']}, bytes {meta['bytes']}",
        )

    return _all(verdict(result, 4, one_line_error=line), files)


def record_through_lies(tmp):
    out = tmp / "reclies"
    sample = lambda sensor, fx: (C.MSG_SAMPLE, (sensor, 0, fx, 0, 0, 0, 0, 0))  # noqa: E731
    stream = [sample(0, 1), sample(2, 9), (C.MSG_CONTACT, (0, 7, 1, 0, 0, 0, 0, 0, 0, 0))]
    stream += [(C.MSG_STATUS, (0x40, 0xFF, 0, 0, 0, 0, 0, 0, 0)), sample(0, 2), sample(0, 3)]
    with PtyLiar(stream=stream) as dev:
        result = cli("record", "--port", dev.path, "--duration", "0.6", "-o", out, "--quiet")

    def files():
        meta = json.loads((out / "meta.json").read_text())
        rows = (out / "frames.csv").read_text().splitlines()[2:]  # below units, header
        return _expect(
            meta["decoder"]["invalid"] == 3 and meta["decoder"]["lost_frames"] == 0
            and len(rows) == 3 and meta["bytes"] == (out / "capture.bin").stat().st_size,
            f"{len(rows)} rows, decoder {meta['decoder']}",
        )  # fmt: skip

    return _all(verdict(result, 0, has=["recorded 3 readings"]), files)


def decode_counts(tmp):
    path = tmp / "hello5.bin"
    data = frame(C.MSG_HELLO, info(n_sensors=5), 0)
    data += b"".join(frame(C.MSG_SAMPLE, (0, 0, i, 0, 0, 0, 0, 0), 1 + i) for i in range(3))
    path.write_bytes(data)
    line = "INVALID  HELLO seq=0 timestamp_us=0: n_sensors = 5 (protocol allows 1..4)"
    return verdict(cli("decode", path), 0, has=[line, " invalid=1 ", " lost_frames=0 "])


def command_reply_lies(command, reply, line):
    def answer(m):
        if m.type_code == command:
            return [reply(m)]
        return [(C.MSG_ACK, (m.type_code, m.seq))]

    args = {C.CMD_CONFIG: ("config", "--rate", "500"), C.CMD_TARE: ("tare",)}[command]
    with PtyLiar(reply=answer) as dev:
        return verdict(cli(*args, "--port", dev.path), 4, one_line_error=line)


def link_refused(tmp, kind):
    path = tmp / f"link-{kind.replace(' ', '-')}"
    if kind == "file":
        path.write_text("precious\n")
    elif kind == "directory":
        path.mkdir()
    else:
        path.symlink_to("/etc/hostname")
    before = sorted(os.listdir(tmp))
    result = cli("emulate", "press", "--link", path, "--now", "--duration", "0.05")
    return _all(
        verdict(result, 2, one_line_error="only replaces its own link to a pty"),
        _expect(sorted(os.listdir(tmp)) == before, "files changed or a temporary was left"),
        _expect(
            kind != "file" or (path.is_file() and path.read_text() == "precious\n"),
            "the file was replaced",
        ),  # fmt: skip
    )


def link_stale(tmp):
    path = tmp / "link-stale"
    path.symlink_to("/dev/pts/9999")
    result = cli("emulate", "press", "--link", path, "--now", "--duration", "0.05")
    return _all(
        verdict(result, 0, has=[str(path)]),
        _expect(not os.path.lexists(path) and not list(tmp.glob("link-stale.tmp*")),
                "the link or a temporary was left behind"),
    )  # fmt: skip


def table(tmp):
    invalid = "exit 4, one line naming the field"
    return [
        ("`info`: HELLO/INFO `sensor_model` holds ESC[31m, ESC[2J and a newline",
         "exit 0, the model shown escaped, no raw control character", info_escapes),
        ("`decode`: a capture whose HELLO `sensor_model` holds escape codes",
         "exit 0, escaped in text", lambda: decode_escapes(tmp, False)),
        ("`decode --json`: the same capture", "exit 0, escaped by JSON",
         lambda: decode_escapes(tmp, True)),
        ("`decode`, text and `--json`: a SET_CAL with NaN and inf coefficients",
         "one rule for both: INVALID naming c00, no NaN or inf", lambda: decode_non_finite(tmp)),
        ("`info`: HELLO claims 5 sensors", invalid,
         lambda: info_refuses(info(n_sensors=5), line="n_sensors = 5 (protocol allows 1..4)")),
        ("`info`: HELLO claims 255 sensors", invalid,
         lambda: info_refuses(info(n_sensors=255), line="n_sensors = 255")),
        ("`info`: valid HELLO, then INFO with a rate above its own ceiling", invalid,
         lambda: info_refuses(GOOD, info(rate_hz=2000), "invalid INFO: rate_hz = 2000")),
        ("`info`: HELLO with unknown flag bits (0x80)", invalid,
         lambda: info_refuses(info(flags=0x80), line="flags = 0x80")),
        ("`record`: HELLO claims 255 sensors",
         "exit 4, one line; meta.json written (ended error, invalid counted), capture kept",
         lambda: record_refuses(tmp)),
        ("`record`: SAMPLE of an unannounced sensor, CONTACT phase 7, unknown STATUS bits",
         "exit 0; the 3 valid readings in frames.csv, 3 invalid counted, none lost",
         lambda: record_through_lies(tmp)),
        ("`decode`: HELLO claiming 5 sensors, then samples",
         "exit 0; INVALID line naming the field, counted, no frame lost",
         lambda: decode_counts(tmp)),
        ("`config`: the board answers NAK with reason 99", invalid,
         lambda: command_reply_lies(C.CMD_CONFIG, lambda m: (C.MSG_NAK, (m.type_code, m.seq, 99,
                                    0xFF)), "invalid NAK: reason = 99 (protocol allows 1..8)")),
        ("`tare`: the board's ACK names a device-to-host type (0x06)", invalid,
         lambda: command_reply_lies(C.CMD_TARE, lambda m: (C.MSG_ACK, (0x06, m.seq)),
                                    "invalid ACK: cmd_type = 6 (protocol allows 64..127)")),
        ("`emulate --link FILE`: a regular file",
         "exit 2, one line; content kept, no temporary left", lambda: link_refused(tmp, "file")),
        ("`emulate --link DIR`: a directory", "exit 2, one line; no temporary left",
         lambda: link_refused(tmp, "directory")),
        ("`emulate --link`: a symlink to another file", "exit 2, one line; the symlink kept",
         lambda: link_refused(tmp, "symlink")),
        ("`emulate --link`: a stale emulator link (to /dev/pts/9999)",
         "replaced while serving, removed at exit", lambda: link_stale(tmp)),
    ]  # fmt: skip


def probes():
    with tempfile.TemporaryDirectory() as name:
        for probe, promise, run in table(Path(name)):
            try:
                outcome = run()
            except Exception as exc:  # a broken probe: a FAILED row
                outcome = f"FAILED: the probe itself raised {type(exc).__name__}: {exc}"
            yield probe, promise, " ".join(outcome.replace("|", "\\|").split())  # one table cell
