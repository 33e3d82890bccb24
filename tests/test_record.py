"""``tactile record`` (issue 7): files written as data arrive, serial faults lose nothing."""

import errno
import json

import pytest
import serial

from tactile.board.serial_port import open_port
from tactile.board.stream_decoder import decode_bytes
from tactile.errors import PortError
from tactile.recording.session import Session


def _files(out):
    capture = (out / "capture.bin").read_bytes()
    rows = (out / "frames.csv").read_text().splitlines()
    assert rows[0] == "# units: N, N*m, us, s"
    rows = rows[1:]  # the header and the data rows
    meta = json.loads((out / "meta.json").read_text())
    return capture, rows, meta


def test_record_writes_capture_frames_and_meta_that_agree(cli, tmp_path):
    out = tmp_path / "run"
    code, stdout, err = cli("record", "--port", "sim://press", "--duration", "0.5", "-o", out,
                            "--quiet")  # fmt: skip
    assert code == 0 and "Traceback" not in err
    capture, rows, meta = _files(out)
    messages, counters = decode_bytes(capture)
    data = [m for m in messages if m.type_name in ("SAMPLE", "CONTACT")]
    # > 20: a real stream (500 at 1 kHz on a quiet machine; 64 seen at load 5)
    assert len(rows) - 1 == len(data) == meta["samples"] > 20
    first = data[0]
    row = dict(zip(rows[0].split(","), rows[1].split(",")))
    assert (row["seq"], row["timestamp_us"], row["type"]) == (
        str(first.seq),
        str(first.timestamp_us),
        first.type_name,
    )
    # sim:// runs simulated time as fast as it can: no host time is claimed for it
    assert row["host_monotonic_s"] == row["host_utc_s"] == ""
    assert not meta["time_base"]["segments"][0]["usable"]
    assert meta["ended"] == "duration" and meta["device"]["rate_hz"] == 1000
    assert meta["decoder"]["lost_frames"] == counters.lost_frames == 0
    assert meta["bytes"] == len(capture)
    assert f"recorded {meta['samples']:,} reading" in stdout


def test_record_stops_after_n_contacts_and_refuses_to_overwrite(cli, tmp_path):
    out = tmp_path / "run"
    code, _, _ = cli("record", "--port", "sim://press", "--contacts", "2", "-o", out, "--quiet")
    assert code == 0
    _, _, meta = _files(out)
    assert meta["ended"] == "contacts" and meta["contacts_ended"] == 2
    before = (out / "capture.bin").read_bytes()
    code, _, err = cli("record", "--port", "sim://press", "--contacts", "1", "-o", out)
    assert code == 2 and "already holds a recording" in err
    assert (out / "capture.bin").read_bytes() == before  # nothing recorded is lost
    code, _, _ = cli("record", "--port", "sim://press", "--contacts", "1", "-o", out, "--append",
                     "--quiet")  # fmt: skip
    assert code == 0 and (out / "capture.bin").read_bytes().startswith(before)


ONE_BOARD = "sim://press?board_id=0123456789abcdef"  # each open: this board, rebooted


class Delivered:
    """Wrap sim:// ports: remember every byte handed to the host; fail the Nth read.
    ``urls``: the port each open gives, in turn (the last one from then on)."""

    def __init__(self, mocker, fail_at, exc, gone, urls=(ONE_BOARD,)):
        self.mocker, self.fail_at, self.exc = mocker, fail_at, exc
        self.urls = list(urls)
        self.bytes = bytearray()
        self.by_open = []  # the bytes each opened port handed over
        self.reads = 0
        self.gone_after = gone  # opens refused (the device node vanished) after the failure
        self.gone = 0

    def open(self, name):
        if self.gone > 0:
            self.gone -= 1
            raise PortError(f"{name}: no such port")
        port = open_port(self.urls.pop(0) if len(self.urls) > 1 else self.urls[0])
        real_read = port.read
        mine = bytearray()
        self.by_open.append(mine)

        def read(size=1):
            self.reads += 1
            if self.reads == self.fail_at:
                self.gone = self.gone_after
                raise self.exc
            data = real_read(size)
            self.bytes += data
            mine.extend(data)
            return data

        self.mocker.patch.object(port, "read", side_effect=read)
        return port


@pytest.mark.parametrize(
    "exc",
    [
        serial.SerialException(
            "device reports readiness to read but returned no data "
            "(device disconnected or multiple access on port?)"
        ),
        OSError(errno.EIO, "Input/output error"),
    ],
)
def test_a_port_lost_mid_read_loses_nothing_and_the_gap_is_recorded(mocker, tmp_path, exc):
    ports = Delivered(mocker, fail_at=300, exc=exc, gone=3)  # missing for 3 tries, then back

    def back_and_reading(session):  # 100 reads after the port came back, however slow they are
        gaps = session.gaps
        return "recovered" if gaps and gaps[-1].get("back_at_s") and ports.reads > 400 else None

    session = Session("/dev/ttyACM0", tmp_path, duration_s=60, opener=ports.open,
                      sleep=lambda s: None, stop_when=back_and_reading)  # fmt: skip
    meta = session.run()
    capture, rows, meta_file = _files(tmp_path)
    assert capture == bytes(ports.bytes)  # every byte received is on disk, in order
    assert meta["ended"] == "recovered" and meta_file["gaps"] == meta["gaps"]
    (gap,) = meta["gaps"]
    assert gap["back_at_s"] is not None and gap["back_at_s"] >= gap["lost_at_s"]
    assert "disconnected" in gap["why"] or "Input/output" in gap["why"]
    assert meta["reboots"] == 1  # the new port is a fresh board (a new boot id): TAREd again
    messages, _ = decode_bytes(capture)
    assert len(rows) - 1 == sum(m.type_name in ("SAMPLE", "CONTACT") for m in messages)


def test_a_port_that_never_comes_back_ends_with_one_line_and_keeps_the_data(mocker, cli, tmp_path):
    ports = Delivered(mocker, 300, serial.SerialException("device disconnected"), gone=10**6)
    mocker.patch("tactile.recording.session.open_port", side_effect=ports.open)
    code, _, err = cli("record", "--port", "/dev/ttyACM0", "--duration", "5", "-o", tmp_path,
                       "--reconnect", "0.3", "--quiet")  # fmt: skip
    assert code == 4 and err.count("\n") == 1 and "Traceback" not in err
    assert "port lost and not back within 0.3 s" in err
    capture, _, meta = _files(tmp_path)
    assert capture == bytes(ports.bytes) and len(capture) > 0
    assert meta["ended"] == "port lost" and meta["gaps"][0]["back_at_s"] is None


def test_permission_denied_at_start_is_one_line(mocker, cli, tmp_path):
    mocker.patch.object(
        serial, "Serial", side_effect=serial.SerialException(errno.EACCES, "Permission denied")
    )
    code, out, err = cli("record", "--port", "/dev/ttyACM0", "--duration", "1", "-o", tmp_path)
    assert code == 4 and "permission denied" in err and "dialout" in err
    assert err.count("\n") == 1 and "Traceback" not in err


def test_a_bad_pose_log_is_refused_before_recording(cli, tmp_path):
    log = tmp_path / "poses.csv"
    log.write_text("t_start_us,t_end_us,finger,q1,q2,q3,z\n0,10,0,0,zero,0,0\n")
    out = tmp_path / "run"
    code, _, err = cli("record", "--port", "sim://press", "--duration", "5", "-o", out,
                       "--pose-log", log)  # fmt: skip
    assert code == 2 and err.count("\n") == 1 and "poses.csv:2" in err
    assert not out.exists()  # nothing was recorded against a log that cannot be used


def _rows(out):
    return len((out / "frames.csv").read_text().splitlines()) - 2  # units line, header


def test_two_appended_sessions_keep_one_entry_each_and_totals_that_match_the_files(cli, tmp_path):
    out = tmp_path / "run"
    for extra in ([], ["--append"]):
        code, _, err = cli("record", "--port", "sim://press", "--duration", "0.4", "-o", out,
                           "--quiet", *extra)  # fmt: skip
        assert code == 0, err
    capture, rows, meta = _files(out)
    first, second = meta["sessions"]
    assert meta["bytes"] == len(capture) == first["bytes"] + second["bytes"]
    assert meta["samples"] == _rows(out) == first["samples"] + second["samples"]
    assert second["capture_offset"] == first["bytes"] and second["rows_offset"] == first["samples"]
    assert first["capture_offset"] == first["rows_offset"] == 0
    assert meta["reboots"] == 0 and meta["decoder"]["frames"] == first["decoder"]["frames"] + \
        second["decoder"]["frames"]  # fmt: skip
    assert first["started_at"] <= second["started_at"]  # ISO 8601, UTC
    # each session's bytes are its own: decoding its span gives its own rows
    messages, _ = decode_bytes(capture[second["capture_offset"] :])
    assert sum(m.type_name in ("SAMPLE", "CONTACT") for m in messages) == second["samples"]
    assert rows[second["rows_offset"] + 1].split(",")[0] == str(
        next(m.seq for m in messages if m.type_name in ("SAMPLE", "CONTACT"))
    )


@pytest.mark.parametrize("damage", ["an older --append", "a crash before the last rewrite"])
def test_appending_to_a_meta_that_misses_data_accounts_for_it(cli, tmp_path, damage):
    out = tmp_path / "run"
    code, _, _ = cli("record", "--port", "sim://press", "--duration", "0.4", "-o", out, "--quiet")
    assert code == 0
    single = json.loads((out / "meta.json").read_text())["sessions"][0]
    if damage == "an older --append":  # one session's meta, files of two (the case)
        with open(out / "capture.bin", "ab") as fh:
            fh.write((out / "capture.bin").read_bytes())
        extra = (out / "frames.csv").read_text().splitlines(keepends=True)[1:]
        with open(out / "frames.csv", "a") as fh:
            fh.writelines(extra)
    else:  # meta.json is up to a second behind the files
        single["bytes"] -= 1000
        single["samples"] -= 20
    (out / "meta.json").write_text(json.dumps(single))  # the single-session layout
    code, _, err = cli("record", "--port", "sim://press", "--duration", "0.4", "-o", out,
                       "--quiet", "--append")  # fmt: skip
    assert code == 0, err
    capture, _, meta = _files(out)
    old, unrecorded, new = meta["sessions"]
    assert old["bytes"] == single["bytes"] and unrecorded["unrecorded"] is True
    assert meta["bytes"] == len(capture) and meta["samples"] == _rows(out)
    assert new["capture_offset"] == len(capture) - new["bytes"]


def test_appending_refuses_an_unreadable_meta_rather_than_overwrite_it(cli, tmp_path):
    out = tmp_path / "run"
    cli("record", "--port", "sim://press", "--duration", "0.2", "-o", out, "--quiet")
    (out / "meta.json").write_text("{not json")
    before = (out / "capture.bin").read_bytes()
    code, _, err = cli("record", "--port", "sim://press", "--duration", "0.2", "-o", out,
                       "--quiet", "--append")  # fmt: skip
    assert code == 2 and err.count("\n") == 1 and "meta.json: cannot append" in err
    assert (out / "capture.bin").read_bytes() == before
    assert (out / "meta.json").read_text() == "{not json"
