"""What the sensor carries, measured: its calibration matrix, and the tool's weight.

``tactile calibrate --port P FILE``: load a 6x6 calibration matrix and its id onto a board
sensor, then verify them through INFO (id and checksum).  FILE is ATI's ``.cal`` XML, a CSV
or a JSON matrix (docs/calibration.md); ``--dry-run`` shows what would be sent.

``tactile payload identify RUN --pose-log LOG -o tool.json``: the tool's mass, centre of mass
and the sensor's biases, from a recording of the unloaded finger held at the log's poses.

The work is ``tactile.payload.fit.identify_run``; this prints each parameter with its
standard error and unit, and the fit's residual, and writes tool.json
(``tactile.payload.tool``).  A log without orientations is bad input (exit 2); poses that do
not determine the fit exit 3 with one line saying what is missing.  Nothing is written on
an error: the output is checked before the work and written whole after it.
"""

import sys

from tactile.calib import board_matrix, describe, files
from tactile.cli.options import add_port_argument, connect
from tactile.commands import Verb, add_out
from tactile.errors import InputError
from tactile.files.writing import check_target
from tactile.output.text import (
    dumps,
    printable,  # the label and notes quote the file
    printable_lines,  # the file's words
)
from tactile.payload.fit import TRIM, identify_run
from tactile.payload.tool import GRAVITY, MAX_GRAVITY, MAX_SENSOR, tool_doc, write_tool


def add_calibrate_arguments(parser):
    add_port_argument(parser)
    parser.add_argument("file", metavar="FILE", help="ATI .cal, CSV or JSON calibration matrix")
    parser.add_argument("--sensor", type=int, help="sensor index (needed on a multi-sensor board)")
    parser.add_argument("--id", type=int, help="calibration id 1..4294967295 (default: the file's)")
    parser.add_argument(
        "--volts-per-count",
        type=float,
        metavar="V",
        help="gauge volts per ADC count, for a matrix per volt such as ATI's",
    )
    parser.add_argument("--index", type=int, help="which calibration of a multi-range ATI .cal")
    parser.add_argument(
        "--dry-run", action="store_true", help="check FILE and print the matrix; no board"
    )


def run_calibrate(args):
    mf = files.read(args.file, args.index)
    bm = board_matrix.to_board(mf, args.volts_per_count, args.id)
    scale = f"; {args.volts_per_count:.6g} V per count" if args.volts_per_count else ""
    print(printable(f"{args.file}: {mf.label}{scale}"))
    for note in mf.notes:
        print(printable(f"note: {note}"))
    print(
        printable(
            f"id {bm.cal_id} ({'--id' if args.id is not None else mf.id_from});"
            f" condition number {bm.condition:.3g} (rows scaled to unit length; refused above"
            f" {board_matrix.MAX_CONDITION:g}); checksum 0x{bm.crc:04x}"
        )
    )
    if args.dry_run:
        print(printable(f"would send (from {describe(mf.units)}):"))
        print(printable_lines(board_matrix.table(bm.coeffs)))
        return 0
    client = connect(args)
    try:
        sensor, _ = board_matrix.install(client, bm, args.sensor)
    finally:
        client.close()
    print(
        printable(
            f"sensor {sensor}: calibration {bm.cal_id} loaded and verified"
            f" (INFO reports id {bm.cal_id}, checksum 0x{bm.crc:04x})"
        )
    )
    return 0


CALIBRATE = Verb(add_calibrate_arguments, run_calibrate)


def add_payload_arguments(parser):
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


def run_payload(args):
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


PAYLOAD = Verb(add_payload_arguments, run_payload)
