"""``tactile ep1 estimate FILE.csv``: curvature at a point from rolling probes (eqs. 29-33)."""

import math

from tactile import units
from tactile.commands import add_sensor_arguments, check_sensor_arguments, print_result
from tactile.ep1.estimator import EXIT_OK, estimate
from tactile.ep1.probes import read_probes
from tactile.errors import DataError, InputError


def add_arguments(parser):
    subs = parser.add_subparsers(dest="action", metavar="ACTION", required=True)
    est = subs.add_parser("estimate", help="estimate K2~, kx, ky and principal curvatures")
    est.add_argument("file", help="probes CSV: dtheta_x,dtheta_y,du,dv")
    add_sensor_arguments(est)
    est.add_argument("--u0", type=float, default=0.0, help="fingertip u at the start (eq. 20)")
    est.add_argument("--v0", type=float, default=0.0, help="fingertip v at the start (eq. 20)")
    est.add_argument(
        "--units",
        default="m",
        metavar="U",
        help="length unit of --finger-radius and --resolution (default m); curvatures in 1/U",
    )
    est.add_argument("--json", action="store_true", help="print one JSON object")


def run(args):
    check_sensor_arguments(args)
    if not (math.isfinite(args.u0) and abs(args.u0) < math.pi / 2 and math.isfinite(args.v0)):
        raise InputError(f"--u0/--v0: ({args.u0}, {args.v0}) is outside the chart of eq. 20")
    dtheta, dp = read_probes(args.file)
    result = estimate(dtheta, dp, args.finger_radius, args.u0, args.resolution, args.noise_theta)
    unit = units.length_option(args.units)
    print_result(result.as_dict(), args.json, unit)
    if result.status not in EXIT_OK:
        raise DataError(f"{args.file}: {result.status}: {result.message}")
    return 0
