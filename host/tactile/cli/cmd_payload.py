"""``tactile payload identify RUN --pose-log LOG -o tool.json``: the tool's mass, centre of mass
and the sensor's biases, from a recording of the unloaded finger held at the log's poses.

The work is ``tactile.payload.fit.identify_run``; this prints each parameter with its
standard error and unit, and the fit's residual, and writes tool.json
(``tactile.payload.tool``).  A log without orientations is bad input (exit 2); poses that do
not determine the fit exit 3 with one line saying what is missing.  Nothing is written on
an error: the output is checked before the work and written whole after it.
"""

import sys

from tactile.commands import add_out
from tactile.errors import InputError
from tactile.files.writing import check_target
from tactile.output.text import dumps, printable_lines
from tactile.payload.fit import TRIM, identify_run
from tactile.payload.tool import GRAVITY, MAX_GRAVITY, MAX_SENSOR, tool_doc, write_tool


def add_arguments(parser):
    subs = parser.add_subparsers(dest="action", metavar="ACTION", required=True)
    p = subs.add_parser("identify", help="fit the tool's mass, centre of mass and the biases")
    p.add_argument("run", help="a recording of the unloaded finger held at the log's poses")
    p.add_argument(
        "--pose-log",
        required=True,
        help="the robot's pose log (sensor poses: qw,qx,qy,qz), one window per hold",
    )
    add_out(p, "tool file to write (JSON)", required=True)
    p.add_argument("--sensor", type=int, help="the sensor (default: the log's only one)")
    p.add_argument(
        "--gravity",
        default=",".join(f"{v:g}" for v in GRAVITY),
        metavar="GX,GY,GZ",
        help="gravity in the robot's world frame, m/s^2",
    )
    p.add_argument(
        "--trim",
        type=float,
        default=TRIM,
        help="fraction of each hold left out at each end (the arm settling)",
    )
    p.add_argument("--json", action="store_true", help="print tool.json's object")


def _gravity(text):
    try:
        g = [float(v) for v in text.split(",")]
    except ValueError:
        g = []
    if len(g) != 3 or not all(abs(v) <= MAX_GRAVITY for v in g) or not any(g):
        raise InputError(
            f"--gravity: need GX,GY,GZ in m/s^2 (each within +-{MAX_GRAVITY:g}), got {text!r}"
        )
    return g


def run(args):
    if args.sensor is not None and not 0 <= args.sensor <= MAX_SENSOR:
        raise InputError(f"--sensor: {args.sensor} is not 0..{MAX_SENSOR}")
    if not 0 <= args.trim < 0.5:
        raise InputError(f"--trim: {args.trim} is not a fraction in [0, 0.5)")
    g = _gravity(args.gravity)
    check_target(args.out)  # a bad output is refused before the work
    tool, holds = identify_run(args.run, args.pose_log, args.sensor, g, args.trim)
    write_tool(args.out, tool)
    if args.json:
        print(dumps(tool_doc(tool)))
    else:
        print(printable_lines(lines(tool, holds, args.out)))
    for line, why in holds.dropped:
        print(
            printable_lines([f"note: hold on line {line} of the pose log left out: {why}"]),
            file=sys.stderr,
        )
    return 0


def _vector(v, se, scale, digits):
    value = ", ".join(f"{x * scale:.{digits}f}" for x in v)
    error = ", ".join(f"{x * scale:.{digits}f}" for x in se)
    return f"({value}) +- ({error})"


def lines(tool, holds, out):
    """What ``identify`` prints: each parameter with its standard error and unit."""
    return [
        f"tool of sensor {tool.sensor} (calibration id {tool.cal_id}) from {len(holds)} poses,"
        f" {int(holds.count.sum()):,} readings",
        f"mass            {tool.mass_kg * 1e3:.3f} +- {tool.mass_kg_se * 1e3:.3f} g"
        f" (weight {tool.weight_N * 1e3:.1f} mN)",
        f"centre of mass  {_vector(tool.com_m, tool.com_m_se, 1e3, 2)} mm",
        f"force bias      {_vector(tool.bias_force_N, tool.bias_force_N_se, 1e3, 1)} mN",
        f"torque bias     {_vector(tool.bias_torque_Nm, tool.bias_torque_Nm_se, 1e3, 3)} mN*m",
        f"residual        {tool.residual_force_N * 1e3:.2f} mN rms (force),"
        f" {tool.residual_torque_Nm * 1e3:.4f} mN*m rms (torque)",
        f"-> {out}",
    ]
