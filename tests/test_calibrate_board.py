"""``tactile calibrate`` end to end on the emulator: the board takes the matrix, INFO shows its
id and checksum, and the readings follow the matrix (issue 14, part 4).

The emulator runs the real firmware behind a real pseudo-terminal, as ``tactile emulate``
serves it, so the board keeps what it was sent from one connection to the next, as a board
does.  Its scene holds one constant wrench without noise or offset, so every SAMPLE should
read that wrench (to the converters' quantisation) through whatever matrix the board holds.
"""

import json
import re
import time

import numpy as np
import pytest
from lying_device import LyingPort, lying_ports

from tactile.board.client import BoardClient, CommandRefused
from tactile.board.serial_port import open_port
from tactile.calib import board_matrix, files
from tactile_fw import calibration
from tactile_sim.emulator import load_scene
from tactile_sim.emulator.device import EmulatedBoard
from tactile_sim.emulator.pty_server import PtyServer

pytestmark = pytest.mark.realtime  # on the wall clock: bench/realtime_soak.py

WRENCH = np.array([3.2, 2.4, -1.0, 0.01, -0.02, 0.005])  # N, N*m
SCENE = """
[scene]
name = "calibrate"
seed = 3

[board]
rate_hz = 500
streams = ["samples"]
sensors = {sensors}

[sensor]
bias_counts = 0.0
cal_id = 1

[motion]
kind = "press"
keyframes = [[0.0, {w}], [1.0, {w}]]
"""
LBF = 0.45359237 * 9.80665  # N per lbf, by definition
LBF_IN = LBF * 0.0254  # N*m per lbf-in
# One count of the converters' quantisation is at most about 1e-5 N and 4e-7 N*m here.
TOL = np.array([1e-4] * 3 + [4e-6] * 3)


def _scene(tmp_path, sensors=1):
    path = tmp_path / "calibrate.toml"
    path.write_text(SCENE.format(sensors=sensors, w=", ".join(repr(float(v)) for v in WRENCH)))
    return path


@pytest.fixture
def board(tmp_path):
    """(pty path, EmulatedBoard) served as fast as possible while a host reads."""
    emu = EmulatedBoard(load_scene(str(_scene(tmp_path))))
    with PtyServer(emu, realtime=False) as server:
        yield server.path, emu


def _readings(path, n=40):
    """``n`` SAMPLE readings in N and N*m, read as any host reads a board."""
    client = BoardClient(open_port(path), path)
    got, deadline = [], time.monotonic() + 20
    try:
        client.handshake(2.0)
        while len(got) < n and time.monotonic() < deadline:
            got += [m for m in client.read() if m.type_name == "SAMPLE"]
    finally:
        client.close()
    assert len(got) >= n
    return np.array([[m.fx, m.fy, m.fz, m.tx, m.ty, m.tz] for m in got[:n]]) * 1e-6


def _ati_cal(path, c_per_volt):
    """An ATI .cal (lbf, lbf-in per V) holding ``c_per_volt`` (N and N*m per V)."""
    rows = c_per_volt / np.array([LBF] * 3 + [LBF_IN] * 3)[:, None]
    axes = "\n".join(
        f'    <UserAxis Name="{a}" values="{" ".join(repr(float(v)) for v in r)}" max="10"/>'
        for a, r in zip(("Fx", "Fy", "Fz", "Tx", "Ty", "Tz"), rows)
    )
    path.write_text(
        '<?xml version="1.0" encoding="utf-8"?>\n'
        '<FTSensor Serial="FT31337" BodyStyle="Sim" Family="DAQ" NumGages="6"'
        ' CalFileVersion="1.1">\n'
        '  <Calibration PartNumber="SIM-50-2" CalDate="1/1/2026" ForceUnits="lbf"'
        ' TorqueUnits="lbf-in" DistUnits="in" GainMultiplier="1">\n'
        f"{axes}\n  </Calibration>\n</FTSensor>\n"
    )
    return path


def _checksum(stdout):
    return int(re.search(r"checksum 0x([0-9a-f]{4})\)", stdout).group(1), 16)


@pytest.mark.slow
def test_calibrate_then_info_shows_it_then_readings_follow_the_matrix(cli, tmp_path, board):
    path, emu = board
    model, adc = emu.models[0], emu.adcs[0]
    before = _readings(path)
    assert np.all(np.abs(before - WRENCH) <= TOL)  # the emulator's own calibration

    # 1. ATI's form: per volt, in lbf and lbf-in; the board's front end gives V per count
    volts_per_count = adc.vref_v / adc.pga_gain / 2**23
    cal = _ati_cal(tmp_path / "FT31337.cal", model.C / volts_per_count)
    code, out, err = cli("calibrate", "--port", path, cal, "--volts-per-count", volts_per_count)
    assert code == 0, err
    assert "sensor 0: calibration 31337 loaded and verified" in out
    crc = _checksum(out)
    code, out, err = cli("info", "--port", path, "--json")
    info = json.loads(out)
    assert (info["cal_ids"], info["cal_crcs"]) == ([31337], [crc])
    assert calibration.load(emu.board.storage, 0).crc == crc  # what it boots with next time
    after = _readings(path)
    assert np.all(np.abs(after - WRENCH) <= TOL)  # unit conversion right: the same newtons
    assert np.abs(after - before).max() < 2e-5  # float32 rounding apart, at most 20 uN

    # 2. a matrix that swaps and scales axes, torques in N*mm: the readings follow it
    c = model.C
    swapped = [c[1], c[0], -2 * c[2], 1e3 * c[5], 1e3 * c[4], 1e3 * c[3]]
    doc = {"matrix": [r.tolist() for r in swapped], "units": "N, N-mm per count"}
    (tmp_path / "swap.json").write_text(json.dumps(doc))
    code, out, err = cli("calibrate", "--port", path, tmp_path / "swap.json", "--id", 77)
    assert code == 0, err
    code, out, _ = cli("info", "--port", path)
    assert f"calibration ids [77] (checksums 0x{_checksum_of(tmp_path / 'swap.json'):04x})" in out
    w = WRENCH
    expect = np.array([w[1], w[0], -2 * w[2], w[5], w[4], w[3]])
    assert np.all(np.abs(_readings(path) - expect) <= 2 * TOL)


def _checksum_of(path):
    return board_matrix.to_board(files.read(str(path)), cal_id=77).crc


def _one_micronewton_csv(tmp_path):
    """A CSV matrix with id 5: 1 uN and 1 uN*m per count, on the diagonal."""
    path = tmp_path / "m.csv"
    path.write_text("# id: 5\n" + "\n".join(",".join(r) for r in np.where(np.eye(6), "1e-6", "0")))
    return path


def test_a_board_with_two_sensors_needs_sensor_and_loads_only_that_one(cli, tmp_path):
    url = f"sim://{_scene(tmp_path, sensors=2)}"
    good = _one_micronewton_csv(tmp_path)
    code, _, err = cli("calibrate", "--port", url, good)
    assert code == 2 and "--sensor: needed: the board has 2 sensors (0..1)" in err
    assert err.count("\n") == 1
    code, _, err = cli("calibrate", "--port", url, good, "--sensor", 2)
    assert code == 2 and "--sensor: 2, but the board has 2 sensors (0..1)" in err
    bm = board_matrix.to_board(files.read(str(good)))
    client = BoardClient(open_port(url), url)
    try:
        client.handshake(2.0)
        sensor, info = board_matrix.install(client, bm, sensor=1)
    finally:
        client.close()
    assert sensor == 1
    assert (info.cal_id_0, info.cal_id_1) == (1, 5)  # sensor 0 keeps the scene's calibration
    assert info.cal_crc_1 == bm.crc and info.cal_crc_0 != bm.crc


def test_a_board_that_refuses_or_ignores_set_cal_exits_4(cli, tmp_path):
    good = _one_micronewton_csv(tmp_path)
    # a board that ACKs SET_CAL and keeps its old matrix: INFO gives it away
    with lying_ports(LyingPort):
        code, out, err = cli("calibrate", "--port", "/dev/ttyACM0", good)
    assert code == 4 and err.count("\n") == 1
    assert (
        "sensor 0 reports calibration id 7 (checksum 0x0000) after SET_CAL was acknowledged" in err
    )
    # a board whose flash refuses the write: NAK, named
    url = f"sim://{_scene(tmp_path)}"
    port = open_port(url)
    port.emulator.board.storage.fail_writes = True
    client = BoardClient(port, url)
    try:
        client.handshake(2.0)
        with pytest.raises(CommandRefused, match="board refused SET_CAL: storage error") as exc:
            board_matrix.install(client, board_matrix.to_board(files.read(str(good))))
    finally:
        client.close()
    assert exc.value.exit_code == 4
    # a bad file is found before any port is opened: exit 2, not 4
    code, _, err = cli("calibrate", "--port", "/dev/ttyNOPE", tmp_path / "none.csv")
    assert code == 2 and "none.csv: cannot read" in err
    code, _, err = cli("calibrate", "--port", "/dev/ttyNOPE", good)
    assert code == 4 and "/dev/ttyNOPE: no such port" in err
