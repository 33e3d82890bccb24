"""tool.json: written whole, read back equal, every bad file one line naming the field."""

import json

import numpy as np
import pytest

from tactile.errors import InputError
from tactile.payload import Tool, check_device, read_tool, write_tool
from tactile.payload.tool import tool_doc

TOOL = Tool(
    0.03, [0.02, 0.0, 0.001], [0.1, -0.2, 0.05], [0.001, 0.0, -0.002], sensor=1, cal_id=8578,
    mass_kg_se=1e-4, com_m_se=[1e-4] * 3, residual_force_N=0.004, poses=9,
)  # fmt: skip
DEVICE = {"n_sensors": 2, "cal_ids": [7, 8578]}


def test_round_trip(tmp_path):
    path = tmp_path / "tool.json"
    write_tool(path, TOOL)
    doc = json.loads(path.read_text())
    assert doc["tactile_tool"] == 1 and doc["mass_kg"] == 0.03 and doc["cal_id"] == 8578
    back = read_tool(path)
    assert tool_doc(back) == tool_doc(TOOL)
    assert np.array_equal(back.com_m, TOOL.com_m) and back.bias_force_N_se is None


GOOD = tool_doc(TOOL)
BAD = [  # (what, the document or its text, the words the one line must hold)
    ("not JSON", "{", "not valid JSON"),
    ("a list", [], "not a tool file"),
    ("no version", {k: v for k, v in GOOD.items() if k != "tactile_tool"}, "'tactile_tool'"),
    ("a newer version", {**GOOD, "tactile_tool": 2}, "field 'tactile_tool'"),
    ("an unknown key", {**GOOD, "mass_g": 30}, "unknown field 'mass_g'"),
    ("no mass", {k: v for k, v in GOOD.items() if k != "mass_kg"}, "field 'mass_kg' is missing"),
    ("a negative mass", {**GOOD, "mass_kg": -0.1}, "need a finite number in 0..5 kg"),
    ("a mass as text", {**GOOD, "mass_kg": "30 g"}, "field 'mass_kg'"),
    ("two numbers", {**GOOD, "com_m": [0.0, 0.1]}, "field 'com_m': need 3 finite numbers"),
    ("a far centre", {**GOOD, "com_m": [2.0, 0, 0]}, "-1..1 m"),
    ("NaN", '{"mass_kg": NaN}', "not a finite number"),
    ("a sensor past 3", {**GOOD, "sensor": 4}, "field 'sensor': need a whole number 0..3"),
    ("a true cal id", {**GOOD, "cal_id": True}, "field 'cal_id'"),
    ("no gravity", {**GOOD, "gravity_m_s2": [0, 0, 0]}, "must not be zero"),
    ("a negative error", {**GOOD, "mass_kg_se": -1e-3}, "field 'mass_kg_se'"),
]  # fmt: skip


@pytest.mark.parametrize("what, doc, words", BAD, ids=[b[0] for b in BAD])
def test_a_bad_tool_file_is_one_line_naming_the_field(tmp_path, what, doc, words):
    path = tmp_path / "tool.json"
    path.write_text(doc if isinstance(doc, str) else json.dumps(doc))
    with pytest.raises(InputError) as err:
        read_tool(path)
    line = str(err.value)
    assert "\n" not in line and str(path) in line and words in line, line


def test_a_directory_or_a_device_is_no_tool_file(tmp_path):
    with pytest.raises(InputError, match="directory"):
        read_tool(tmp_path)
    with pytest.raises(InputError, match="regular file"):
        write_tool("/dev/null", TOOL)


def test_the_tool_must_be_the_boards_sensor_and_calibration():
    check_device(TOOL, DEVICE, "tool.json")
    with pytest.raises(InputError, match="calibration id 8578 of sensor 1, but that sensor"):
        check_device(TOOL, {**DEVICE, "cal_ids": [7, 9999]}, "tool.json")
    with pytest.raises(InputError, match="the tool is for sensor 1, but the board has 1 sensor"):
        check_device(TOOL, {"n_sensors": 1, "cal_ids": [8578]}, "tool.json")
    with pytest.raises(InputError, match="INFO is not known"):
        check_device(TOOL, None, "tool.json")
