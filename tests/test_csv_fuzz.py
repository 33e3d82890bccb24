"""Every CSV reader under hostile bytes (issue 12): the answer is a result, or an
``InputError``/``DataError`` of one line naming the file and a line number; never another
exception, and never a numpy warning (warnings are errors here).

The files are built from the formats' own headers and ``#`` lines, with cells drawn from
numbers (huge, tiny, NaN, inf), text with control characters and quotes, then BOMs, mixed
line endings, stray bytes and over-long lines spliced in.  Fixed seed in CI
(tests/conftest.py); ``TACTILE_FUZZ=long`` runs ``FUZZ_SCALE`` times more, randomised.
"""

import re

import numpy as np
import pytest
from conftest import FUZZ_SCALE
from hypothesis import HealthCheck, event, given, settings
from hypothesis import strategies as st

from tactile.commands.derive import check_log
from tactile.ep1.probes import read_probes
from tactile.ep2.contacts_csv import read_contacts
from tactile.errors import DataError, InputError
from tactile.files import tabular
from tactile.localize.posed import posed_world_contacts
from tactile.logs.read import read_pose_log, read_probe_log

pytestmark = pytest.mark.filterwarnings("error")

FORMATS = {  # header, '#' lines with their good values, a good row for window/row i
    "contacts": ("x,y,z,nx,ny,nz,finger,patch", {}),
    "pose": (
        "t_start_us,t_end_us,finger,px,py,pz,qw,qx,qy,qz",
        {"# probe: sphere radius_m={} centre_m={},{},{}": (0.01, 0.05, 0, 0),
         "# sensor: noise_force_N={},{},{} noise_torque_Nm={},{},{}": (0.1,) * 3 + (0.01,) * 3},
    ),
    "scara": ("t_start_us,t_end_us,finger,q1,q2,q3,z",
              {"# rig: scara L1={} L2={} L3={} L4={}": (0.35, 0.3, 0.12, 0.015)}),
    "probes": ("dtheta_x,dtheta_y,du,dv", {}),
    "probe_log": (
        "probe,t_start_us,t_end_us,dtheta_x,dtheta_y",
        {"# probe: sphere radius_m={} centre_m={},{},{}": (0.01, 0.05, 0, 0),
         "# hold: half_width_us={}": (80000,)},
    ),
}  # fmt: skip
READERS = {
    "contacts": read_contacts,
    "pose": read_pose_log,
    "scara": read_pose_log,
    "probes": read_probes,
    "probe_log": read_probe_log,
}
ODD = [
    "", " ", "nan", "NaN", "inf", "-inf", "1e308", "-1e308", "1e309", "5e-324", "1e-320",
    "1e19", "4294967296", "-0", "0x10", "1_0", "+-1", "\u0661", "\u00a0", "\x00", "\x1b[2J",
    '"', '""', "#", "1,5", "\ufeff1", "0.5", "-1",
]  # fmt: skip

extreme = st.sampled_from(["1e308", "-1e308", "1e300", "1e-300", "1e-320", "5e-324", "1e19"])
hostile = st.one_of(
    extreme,
    st.floats(allow_nan=True, allow_infinity=True).map(repr),
    st.integers(-(2**70), 2**70).map(str),
    st.sampled_from(ODD),
    st.text(max_size=6),
)
plain = st.floats(-1e3, 1e3).map(repr)
wild = st.one_of(plain, plain, extreme)  # a quarter of the numbers at the float's edges


def rarely(n):
    """True about once in ``n`` draws (hypothesis favours the ends of integer ranges)."""
    return st.sampled_from([False] * (n - 1) + [True])


def good_row(draw, fmt, i, scale, number):
    """A well-formed row (window i of a log, or a contact at ``scale``), its free numbers
    drawn from ``number``."""
    t = [str(1000 * i), str(1000 * i + 500)]
    if fmt == "contacts":
        xyz = [repr(draw(st.floats(-10, 10)) * scale) for _ in range(3)]
        n = [draw(number), draw(number), repr(draw(st.floats(0.1, 1e3)))]
        return xyz + n + [str(i % 3), draw(st.sampled_from(["1", "a", "007"]))]
    if fmt == "pose":
        return t + [str(i % 2)] + [draw(number) for _ in range(3)] + ["1", "0", "0", "0"]
    if fmt == "scara":
        return t + [str(i)] + [draw(number) for _ in range(4)]
    if fmt == "probes":
        return [draw(number) for _ in range(4)]
    return [str(i)] + t + [draw(number), draw(number)]


def _spoil(draw, cells, odds):
    """Replace one cell by a hostile one, once in ``odds`` rows (never for 0)."""
    if odds and draw(rarely(odds)):
        cells[draw(st.integers(0, len(cells) - 1))] = draw(hostile)
    return cells


@st.composite
def files(draw, fmt):
    header, tags = FORMATS[fmt]
    scale = 10.0 ** draw(st.integers(-300, 300))
    odds = draw(st.sampled_from([0, 0, 2, 12]))
    number = draw(st.sampled_from([plain, wild]))
    lines = []
    for tag, values in tags.items():
        if not draw(rarely(4)):
            cells = [draw(number) if draw(rarely(3)) else repr(float(v)) for v in values]
            lines.append(tag.format(*_spoil(draw, cells, odds)))
    if not draw(rarely(16)):  # sometimes no header at all
        lines.append(draw(hostile) + "," + header if draw(rarely(8)) else header)
    for i in range(draw(st.sampled_from([3, 5, 8, 2, 1, 0]))):
        lines.append(",".join(_spoil(draw, good_row(draw, fmt, i, scale, number), odds)))
        if draw(rarely(8)):
            lines.append(draw(st.sampled_from(["", "# note", "  ", "#", ",,,"])))
    eol = draw(st.sampled_from(["\n", "\r\n", "\r"]))
    data = eol.join(lines).encode("utf-8") + (eol.encode() if draw(st.booleans()) else b"")
    if draw(st.booleans()):
        data = b"\xef\xbb\xbf" + data  # Excel's CSV UTF-8
    if draw(rarely(4)):
        for _ in range(draw(st.integers(1, 3))):
            at = draw(st.integers(0, len(data)))
            data = data[:at] + draw(st.binary(min_size=1, max_size=4)) + data[at:]
    if draw(rarely(16)):
        at = draw(st.integers(0, len(data)))
        data = data[:at] + b"7" * (tabular.MAX_LINE_BYTES + 1) + data[at:]
    return data


def _outcome(path, read):
    """The reader's result, or None after checking its refusal is one line at file:line."""
    try:
        return read(path)
    except (InputError, DataError) as exc:
        msg = str(exc)
        assert "\n" not in msg and "\r" not in msg, msg
        assert re.match(rf"{re.escape(str(path))}:\d+: ", msg), msg
        event(f"{read.__name__}: refused")
        return None


def _use_pose_log(log):
    """Place a press on every window's fingertip, as ``tactile record --pose-log`` does."""
    if log.kind == "pose" and log.probe is None:
        return
    wrench = np.tile([-3.0, 0.2, 0.1, 0.0, 0.01, -0.02], (len(log), 1))
    lengths = None if log.kind == "pose" or log.lengths else (0.35, 0.3, 0.12, 0.015)
    posed_world_contacts(log, log.t_start, log.finger, wrench, 1.0, lengths=lengths)


FUZZ = settings(
    max_examples=200 * FUZZ_SCALE,
    suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow],
)


@FUZZ
@given(data=st.data(), fmt=st.sampled_from(sorted(FORMATS)))
def test_every_reader_answers_or_refuses_in_one_line(tmp_path, data, fmt):
    path = tmp_path / f"{fmt}.csv"
    path.write_bytes(data.draw(files(fmt)))
    result = _outcome(path, READERS[fmt])
    if result is not None:
        event(f"{fmt}: read")
    if fmt in ("pose", "scara", "probe_log"):
        _outcome(path, check_log)  # what 'tactile record --pose-log' reads first
    if fmt in ("pose", "scara") and result is not None:
        try:
            _use_pose_log(result)
        except (InputError, DataError) as exc:
            assert "\n" not in str(exc)
    if fmt == "contacts" and result is not None:
        for group in result:
            assert np.all(np.isfinite(group.points)) and np.all(np.isfinite(group.normals))
