"""``record`` after a lost port carries on only with its own board (HELLO ``board_id``), and
says that it waits while it waits."""

import json

import serial
from test_record import ONE_BOARD, Delivered

from tactile.board.stream_decoder import decode_bytes

OTHER_BOARD = "sim://press?board_id=fedcba9876543210"
LOST = serial.SerialException("device reports readiness to read but returned no data")


def _record(cli, mocker, tmp_path, ports, *extra):
    mocker.patch("tactile.recording.session.open_port", side_effect=ports.open)
    return cli("record", "--port", "/dev/ttyACM0", "--duration", "30", "-o", tmp_path,
               "--reconnect", "5", *extra)  # fmt: skip


def _kept(tmp_path):
    capture = (tmp_path / "capture.bin").read_bytes()
    rows = (tmp_path / "frames.csv").read_text().splitlines()[2:]  # below units, header
    messages, counters = decode_bytes(capture)
    assert len(rows) == sum(m.type_name in ("SAMPLE", "CONTACT") for m in messages)
    return capture, counters, json.loads((tmp_path / "meta.json").read_text())


def test_another_board_on_the_port_ends_the_run_in_one_line_with_everything_kept(
    cli, mocker, tmp_path
):
    ports = Delivered(mocker, 300, LOST, gone=2, urls=[ONE_BOARD, OTHER_BOARD])
    code, _, err = _record(cli, mocker, tmp_path, ports, "--quiet")
    assert code == 4 and err.count("\n") == 1 and "Traceback" not in err, err
    assert "another board answered after the port was lost (board id fedcba9876543210" in err
    assert "not this run's 0123456789abcdef" in err and str(tmp_path) in err
    capture, counters, meta = _kept(tmp_path)
    first, other = ports.by_open
    assert capture == bytes(first) and len(other) > 0  # all of its own, none of the other's
    assert meta["ended"] == "other board" and meta["bytes"] == len(capture)
    (gap,) = meta["gaps"]
    assert gap["back_at_s"] is None and gap["other_board"]["board_id"] == "fedcba9876543210"
    assert gap["other_board"]["bytes_refused"] == len(other)
    assert meta["board"]["board_id"] == "0123456789abcdef" and len(meta["board"]["boot_ids"]) == 1
    assert meta["reboots"] == counters.reboots == 0  # the other board is not a reboot of this


def test_the_same_board_back_after_a_reboot_is_recorded_on(cli, mocker, tmp_path):
    ports = Delivered(mocker, 300, LOST, gone=2)

    def stop_after_it_came_back(session):
        return "back" if session.gaps and ports.reads > 500 else None

    mocker.patch("tactile.recording.session.Session._done", stop_after_it_came_back)
    code, _, err = _record(cli, mocker, tmp_path, ports, "--quiet")
    assert code == 0, err
    capture, counters, meta = _kept(tmp_path)
    assert capture == bytes(ports.bytes) and len(ports.by_open) == 2
    (gap,) = meta["gaps"]
    assert gap["back_at_s"] is not None and gap["rebooted"] is True and "other_board" not in gap
    assert meta["reboots"] == counters.reboots == 1  # the same board id, a new boot id
    assert meta["board"]["board_id"] == "0123456789abcdef"
    assert len(set(meta["board"]["boot_ids"])) == 2


def test_while_the_port_is_lost_record_says_that_it_waits_and_for_how_long(cli, mocker, tmp_path):
    ports = Delivered(mocker, 300, LOST, gone=10**6, urls=["sim://press"])
    code, _, err = _record(cli, mocker, tmp_path, ports, "--reconnect", "0.6")
    assert code == 4 and "Traceback" not in err
    lines = [ln for ln in err.splitlines() if "port lost at" in ln]
    assert len(lines) == 1 and lines[0].startswith("record: port lost at ")
    assert lines[0].endswith(" s; waiting up to 0.6 s for it to come back")
    at = float(lines[0].split("port lost at ")[1].split(" s;")[0])
    meta = json.loads((tmp_path / "meta.json").read_text())
    assert at == round(meta["gaps"][0]["lost_at_s"], 1)
    assert err.rstrip().splitlines()[-1].startswith("tactile record: error:")
