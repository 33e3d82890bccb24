"""``tactile ep1 estimate FILE.csv``: curvature at a point from rolling probes (eqs. 29-33)."""

import math

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


def add_sensor_arguments(parser):
    parser.add_argument("--finger-radius", type=float, required=True, help="R1")
    parser.add_argument(
        "--resolution", type=float, default=0.0, help="contact sensor step (arc length), 0=exact"
    )
    parser.add_argument(
        "--noise-theta", type=float, default=0.0, help="rotation noise (rad, 1 sigma)"
    )


def check_sensor_arguments(args):
    if not 1e-300 <= args.finger_radius <= 1e300:
        raise InputError(
            f"--finger-radius: must be a number in [1e-300, 1e300], got {args.finger_radius}"
        )
    for name in ("resolution", "noise_theta"):
        value = getattr(args, name)
        if not (math.isfinite(value) and value >= 0):
            flag = "--" + name.replace("_", "-")
            raise InputError(f"{flag}: must be a non-negative number, got {value}")


def run(args):
    check_sensor_arguments(args)
    if not (math.isfinite(args.u0) and abs(args.u0) < math.pi / 2 and math.isfinite(args.v0)):
        raise InputError(f"--u0/--v0: ({args.u0}, {args.v0}) is outside the chart of eq. 20")
    from tactile.ep1.estimator import EXIT_OK, estimate
    from tactile.ep1.probes_csv import read_probes

    dtheta, dp = read_probes(args.file)
    result = estimate(dtheta, dp, args.finger_radius, args.u0, args.resolution, args.noise_theta)
    from tactile import units

    try:
        unit = units.parse_length(args.units)
    except ValueError as exc:
        raise InputError(f"--units: {exc}") from None
    print_result(result.as_dict(), args.json, unit)
    if result.status not in EXIT_OK:
        raise DataError(f"{args.file}: {result.status}: {result.message}")
    return 0


CURVATURES = ("kx", "ky", "k1", "k2")


def print_result(result, as_json, unit=None):
    """The estimate as JSON or ``key: value`` lines; curvatures in 1/``unit`` (the unit of
    --finger-radius) when it is given."""
    from tactile.output.jsonout import dumps
    from tactile.output.textout import printable

    if as_json:
        if unit is not None:
            named = {k: f"1/{unit}" for k in CURVATURES} | {"residual": unit}
            result = {**result, "units": named}
        print(dumps(result))
        return
    for key in ("status", "kx", "ky", "k1", "k2", "direction1", "residual", "n_probes", "message"):
        value = result.get(key)
        if isinstance(value, float):
            value = f"{value:.6g}"
        label = key
        if unit is not None and key in (*CURVATURES, "residual"):
            label = f"{key} ({unit})" if key == "residual" else f"{key} (1/{unit})"
        print(printable(f"{label:>14}: {value if value is not None else '-'}"))
