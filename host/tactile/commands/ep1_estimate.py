"""The EP1 estimate as ``tactile ep1 estimate`` and ``tactile sim ep1`` take and show it: the
contact sensor's options, their checks, and the printed result."""

import math

from tactile.errors import InputError
from tactile.output.text import dumps, printable

CURVATURES = ("kx", "ky", "k1", "k2")
SHOWN = ("status", "kx", "ky", "k1", "k2", "direction1", "residual", "n_probes", "message")


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


def print_result(result, as_json, unit=None):
    """The estimate as JSON or ``key: value`` lines; curvatures in 1/``unit`` (the unit of
    --finger-radius) when it is given."""
    if as_json:
        if unit is not None:
            named = {k: f"1/{unit}" for k in CURVATURES} | {"residual": unit}
            result = {**result, "units": named}
        print(dumps(result))
        return
    for key in SHOWN:
        value = result.get(key)
        if isinstance(value, float):
            value = f"{value:.6g}"
        label = key
        if unit is not None and key in (*CURVATURES, "residual"):
            label = f"{key} ({unit})" if key == "residual" else f"{key} (1/{unit})"
        print(printable(f"{label:>14}: {value if value is not None else '-'}"))
