"""A tool (what hangs between the sensor and the contact) as the payload model sees it, and
its file, ``tool.json``.

The model (``weight`` below): in the sensor frame, at orientation R of the sensor
in the world, the sensor reads the tool's weight and a bias,

    F = m R^T g + b_F                     (N)
    T = c x (m R^T g) + b_T               (N*m, about the sensor's origin)

``Tool`` holds m (``mass_kg``), c (``com_m``, the centre of mass in the sensor frame), b_F
and b_T (``bias_force_N``, ``bias_torque_Nm``: the biases while the tool was identified),
the gravity vector g of the robot's world frame (``gravity_m_s2``), each estimate's standard
error (``*_se``) and the fit's rms residual, and what the values belong to: the board's
sensor index (``sensor``) and the calibration id that sensor reported (``cal_id``, 0: none).

tool.json is one JSON object with exactly those keys (each key names its unit), plus
``"tactile_tool": 1`` (the format's version) and ``identified_from`` (free text: the run and
pose log).  ``read_tool`` refuses anything else: an unknown or missing key, a value that is
not a finite number in range, a vector of the wrong length; one line naming the file and
the field (``InputError``, exit 2).  ``write_tool`` replaces the file whole
(``tactile.files.writing``).  ``check_device`` refuses a tool for another sensor or another
calibration than the board's (``InputError``).

**The tool's weight** in the sensor frame, and a wrench with it removed.

``weight(R, tool)`` is the wrench the tool's weight puts on the sensor at orientation R (the
sensor frame's axes in the world's, (..., 3, 3)): F_w = m R^T g, T_w = c x F_w
(``Tool`` above).  ``compensate(wrench, R, tool, bias)`` is the wrench less that
weight and less the bias: what the contact alone applies.  ``tare_bias(reading, R, tool)``
is the bias a reading taken out of contact at orientation R gives: the reading less the
tool's weight there (not the whole reading, which is what a TARE on the board takes, and
which holds at that one orientation only).
"""

import json
from dataclasses import dataclass, field, fields

import numpy as np

from tactile.errors import InputError
from tactile.files import bounded
from tactile.files.writing import write_bytes
from tactile.output.text import printable

__all__ = [
    "FORMAT",
    "GRAVITY",
    "Tool",
    "check_device",
    "read_tool",
    "tool_doc",
    "write_tool",
    "compensate",
    "gravity_in_sensor",
    "tare_bias",
    "weight",
]

FORMAT = 1  # "tactile_tool": the version of tool.json's layout
GRAVITY = (0.0, 0.0, -9.81)  # m/s^2 in the robot's world frame, z up
MAX_TOOL_BYTES = 64 * 2**10  # tool.json: a few hundred bytes
MAX_MASS_KG = 5.0  # what a fingertip's F/T sensor carries
MAX_COM_M = 1.0  # |c| per axis
MAX_FORCE_N = 1e4  # |bias| per axis, and the residual
MAX_TORQUE_NM = 1e3
MAX_GRAVITY = 100.0  # m/s^2 per axis
MAX_SENSOR = 3  # the board's sensor index (PROTOCOL.md: up to 4 sensors)
MAX_CAL_ID = 0xFFFFFFFF  # a u32; 0: the sensor reported no calibration
MAX_POSES = 10**6


@dataclass(frozen=True)
class Tool:
    """A tool's mass, centre of mass and the biases it was identified with (module docstring);
    the standard errors and residuals are None for a tool given by hand."""

    mass_kg: float
    com_m: np.ndarray
    bias_force_N: np.ndarray = field(default_factory=lambda: np.zeros(3))
    bias_torque_Nm: np.ndarray = field(default_factory=lambda: np.zeros(3))
    sensor: int = 0
    cal_id: int = 0
    gravity_m_s2: np.ndarray = field(default_factory=lambda: np.array(GRAVITY))
    mass_kg_se: float | None = None
    com_m_se: np.ndarray | None = None
    bias_force_N_se: np.ndarray | None = None
    bias_torque_Nm_se: np.ndarray | None = None
    residual_force_N: float | None = None  # rms over the poses' axes
    residual_torque_Nm: float | None = None
    poses: int | None = None
    identified_from: str = ""

    def __post_init__(self):
        for name in VECTORS:
            value = getattr(self, name)
            if value is not None:
                object.__setattr__(self, name, np.asarray(value, dtype=float).reshape(3))

    @property
    def weight_N(self):
        """|m g|: the tool's weight in N."""
        return float(self.mass_kg * np.linalg.norm(self.gravity_m_s2))

    @property
    def bias(self):
        """(6,) b_F then b_T, N and N*m."""
        return np.concatenate([self.bias_force_N, self.bias_torque_Nm])


VECTORS = ("com_m", "bias_force_N", "bias_torque_Nm", "gravity_m_s2")
VECTORS += ("com_m_se", "bias_force_N_se", "bias_torque_Nm_se")
# key -> (kind, bound, required): "real" a number in [-bound, bound], "positive" in [0, bound],
# "vector"/"vector+" three such numbers, "whole" an integer in [0, bound], "text" a string
SCHEMA = {
    "tactile_tool": ("whole", FORMAT, True),
    "sensor": ("whole", MAX_SENSOR, True),
    "cal_id": ("whole", MAX_CAL_ID, True),
    "mass_kg": ("positive", MAX_MASS_KG, True),
    "com_m": ("vector", MAX_COM_M, True),
    "bias_force_N": ("vector", MAX_FORCE_N, True),
    "bias_torque_Nm": ("vector", MAX_TORQUE_NM, True),
    "gravity_m_s2": ("vector", MAX_GRAVITY, True),
    "mass_kg_se": ("positive", MAX_MASS_KG, False),
    "com_m_se": ("vector+", MAX_COM_M, False),
    "bias_force_N_se": ("vector+", MAX_FORCE_N, False),
    "bias_torque_Nm_se": ("vector+", MAX_TORQUE_NM, False),
    "residual_force_N": ("positive", MAX_FORCE_N, False),
    "residual_torque_Nm": ("positive", MAX_TORQUE_NM, False),
    "poses": ("whole", MAX_POSES, False),
    "identified_from": ("text", 4096, False),
}
UNITS = {"kg": "kg", "_m": "m", "_N": "N", "Nm": "N*m", "s2": "m/s^2"}


def _number(v):
    return isinstance(v, int | float) and not isinstance(v, bool) and np.isfinite(v)


def _check(path, key, value):
    """``value`` of ``key`` as its Python value, or InputError naming the field."""
    kind, bound, _ = SCHEMA[key]
    at = f"{path}: field '{key}'"
    shown = printable(json.dumps(value)[:60])
    if kind == "text":
        if not isinstance(value, str) or len(value) > bound:
            raise InputError(f"{at}: need a string of at most {bound} characters, got {shown}")
        return value
    if kind == "whole":
        if not (isinstance(value, int) and not isinstance(value, bool) and 0 <= value <= bound):
            raise InputError(f"{at}: need a whole number 0..{bound}, got {shown}")
        return value
    least = -bound if kind in ("real", "vector") else 0.0
    unit = next((u for end, u in UNITS.items() if key.removesuffix("_se").endswith(end)), "")
    if kind.startswith("vector"):
        ok = isinstance(value, list) and len(value) == 3 and all(_number(v) for v in value)
        if not ok or not all(least <= v <= bound for v in value):
            raise InputError(
                f"{at}: need 3 finite numbers in {least:g}..{bound:g} {unit}, got {shown}"
            )
        return np.array(value, dtype=float)
    if not (_number(value) and least <= value <= bound):
        raise InputError(f"{at}: need a finite number in {least:g}..{bound:g} {unit}, got {shown}")
    return float(value)


def tool_from_doc(path, doc):
    """The ``Tool`` a parsed tool.json document holds, or InputError naming the field."""
    if not isinstance(doc, dict):
        raise InputError(f"{path}: not a tool file (expected a JSON object with 'tactile_tool')")
    if "tactile_tool" not in doc:
        raise InputError(f"{path}: not a tool file: no field 'tactile_tool' (the format version)")
    unknown = [k for k in doc if k not in SCHEMA]
    if unknown:
        known = ", ".join(SCHEMA)
        raise InputError(f"{path}: unknown field '{printable(unknown[0][:40])}' (known: {known})")
    missing = [k for k, (_, _, required) in SCHEMA.items() if required and k not in doc]
    if missing:
        raise InputError(f"{path}: field '{missing[0]}' is missing")
    values = {k: _check(path, k, v) for k, v in doc.items()}
    if not np.linalg.norm(values["gravity_m_s2"]) > 0:
        raise InputError(f"{path}: field 'gravity_m_s2': must not be zero")
    del values["tactile_tool"]
    return Tool(**values)


def read_tool(path):
    """Read tool.json (module docstring) into a ``Tool``; InputError (exit 2) on anything
    else, one line naming the file and the field."""
    return tool_from_doc(path, bounded.read_json(path, MAX_TOOL_BYTES, "a tool file"))


def tool_doc(tool):
    """tool.json's document (a dict, JSON-ready) of ``tool``: None values are left out."""
    doc = {"tactile_tool": FORMAT}
    for f in fields(tool):
        value = getattr(tool, f.name)
        if value is None or (f.name == "identified_from" and not value):
            continue
        if isinstance(value, np.ndarray):
            value = [float(v) for v in value]
        elif isinstance(value, float | np.floating):
            value = float(value)
        doc[f.name] = value
    return doc


def write_tool(path, tool):
    """Write ``tool`` to ``path`` whole (``atomic_write``); the file reads back equal."""
    tool_from_doc(path, json.loads(json.dumps(tool_doc(tool))))  # refuse what read refuses
    write_bytes(path, json.dumps(tool_doc(tool), indent=2) + "\n")


def check_device(tool, device, where_from):
    """InputError unless ``device`` (meta.json's "device", a board's INFO as
    ``tactile.board.client.info_dict`` gives it) has the tool's sensor with the calibration
    id the tool was measured with; ``where_from`` names the tool file."""
    if not isinstance(device, dict):
        raise InputError(
            f"{where_from}: the board's INFO is not known (no 'device' in meta.json), so the"
            " tool's sensor and calibration cannot be checked"
        )
    n = device.get("n_sensors")
    ids = device.get("cal_ids")
    if not isinstance(n, int) or not isinstance(ids, list) or len(ids) < min(n, MAX_SENSOR + 1):
        raise InputError(f"{where_from}: the board's INFO has no sensors or calibration ids")
    if not tool.sensor < n:
        raise InputError(
            f"{where_from}: the tool is for sensor {tool.sensor}, but the board has"
            f" {n} sensor{'s' * (n != 1)} (0..{n - 1}): identify the tool on this board"
        )
    got = ids[tool.sensor]
    if got != tool.cal_id:
        raise InputError(
            f"{where_from}: the tool was identified with calibration id {tool.cal_id} of sensor"
            f" {tool.sensor}, but that sensor reports id {got}: identify the tool again"
            " (tactile payload identify) with this calibration"
        )


def gravity_in_sensor(R, g):
    """R^T g (..., 3): the world's gravity ``g`` (3,) in the sensor frame, m/s^2."""
    R = np.asarray(R, dtype=float)
    return np.einsum("...ji,j->...i", R, np.asarray(g, dtype=float))


def weight(R, tool):
    """(..., 6): the force (N) and torque (N*m, about the sensor's origin) the tool's weight
    applies at orientations ``R`` (..., 3, 3)."""
    F = tool.mass_kg * gravity_in_sensor(R, tool.gravity_m_s2)
    T = np.cross(np.broadcast_to(tool.com_m, F.shape), F)
    return np.concatenate([F, T], axis=-1)


def compensate(wrench, R, tool, bias=None):
    """``wrench`` (..., 6) in N and N*m less the tool's weight at ``R`` (..., 3, 3) and less
    ``bias`` (6,) or (..., 6) (default: the tool's identified biases)."""
    b = tool.bias if bias is None else np.asarray(bias, dtype=float)
    return np.asarray(wrench, dtype=float) - weight(R, tool) - b


def tare_bias(reading, R, tool):
    """The bias (6,) of ``reading`` (6,) (N, N*m; a mean taken out of contact, or (n, 6)
    readings, averaged) at orientation ``R`` (3, 3): the reading less the tool's weight."""
    r = np.asarray(reading, dtype=float).reshape(-1, 6).mean(axis=0)
    return r - weight(np.asarray(R, dtype=float).reshape(3, 3), tool)
