"""``tactile sim ep1``: simulate EP1's rolling probes on an object, estimate, compare.

A family of ``tactile sim`` (``tactile.commands``), from the studies: it runs the
host's estimator on the simulator's probes (``tactile_studies.ep1.experiment``), which load
NumPy and SciPy when it runs, not when ``tactile sim``'s parser is built."""

import math

from tactile.commands import (
    add_out,
    add_sensor_arguments,
    check_sensor_arguments,
    print_result,
    renamed,
)
from tactile.errors import DataError, InputError
from tactile.files.writing import write_bytes
from tactile.output.text import printable

OBJECTS = (
    "plane",
    "sphere",
    "cylinder",
    "concave_cylinder",
    "paraboloid",
    "ellipsoid",
    "saddle",
    "torus",
)
# --flag -> (dest, surface parameter per object kind)
PARAMS = {
    "sphere": {"radius": "radius"},
    "cylinder": {"radius": "radius"},
    "concave_cylinder": {"radius": "radius"},
    "paraboloid": {"coef": "C"},
    "ellipsoid": {"a": "a", "b": "b", "c": "c"},
    "saddle": {"a": "a", "b": "b"},
    "torus": {"major": "R", "minor": "r"},
    "plane": {},
}


def add_arguments(parser):
    parser.add_argument(
        "--object",
        required=True,
        choices=OBJECTS,
        type=renamed({"concave-cylinder": "concave_cylinder"}, "tactile sim ep1"),
    )
    parser.add_argument("--radius", type=float, default=1.0, help="sphere/cylinder radius")
    parser.add_argument(
        "--coef", type=float, default=1.0, metavar="C", help="paraboloid z = -C (u^2 + v^2)"
    )
    parser.add_argument("--a", type=float, default=1.0, help="ellipsoid/saddle parameter a")
    parser.add_argument("--b", type=float, default=1.0, help="ellipsoid/saddle parameter b")
    parser.add_argument("--c", type=float, default=1.0, help="ellipsoid parameter c")
    parser.add_argument("--major", type=float, default=2.0, help="torus major radius")
    parser.add_argument("--minor", type=float, default=0.5, help="torus minor radius")
    parser.add_argument(
        "--at",
        type=float,
        nargs=2,
        default=(0.0, 0.0),
        metavar=("U", "V"),
        help="object parameters (u, v) of the probed point",
    )
    add_sensor_arguments(parser)
    parser.add_argument("--dtheta", type=float, required=True, help="rotation per probe (rad)")
    parser.add_argument(
        "--sensor",
        choices=("array", "gauss", "bias"),
        default="array",
        help="contact sensor model for --resolution (§3.3.3)",
    )
    parser.add_argument("--seed", type=int, default=None)
    add_out(parser, "also write the measured probes CSV here", old=("--probes-out",))
    parser.add_argument("--json", action="store_true")


def run(args):
    check_sensor_arguments(args)
    if not (math.isfinite(args.dtheta) and 0 < args.dtheta < math.pi):
        raise InputError(f"--dtheta: must be in (0, pi) rad, got {args.dtheta}")
    params = {p: getattr(args, flag) for flag, p in PARAMS[args.object].items()}
    for name, value in params.items():
        if not (math.isfinite(value) and value != 0):
            raise InputError(f"object parameter {name}: must be a non-zero number, got {value}")
    import numpy as np

    from tactile.ep1 import estimator, probes  # NumPy and SciPy: a family module (above)
    from tactile_sim.ep1.surfaces import make
    from tactile_studies.ep1.experiment import run_ep1

    try:
        obj = make(args.object, **params)
    except ValueError as exc:
        raise InputError(str(exc)) from None
    (lo_u, hi_u), (lo_v, hi_v) = obj.chart
    if not (lo_u < args.at[0] < hi_u and lo_v < args.at[1] < hi_v):
        raise InputError(f"--at: {tuple(args.at)} is outside the object's chart {obj.chart}")
    rows, est, truth, rolled = run_ep1(
        obj,
        args.finger_radius,
        args.dtheta,
        p2=tuple(args.at),
        sigma_theta=args.noise_theta,
        resolution=args.resolution,
        sensor=args.sensor,
        seed=args.seed,
    )
    if args.out:
        write_bytes(args.out, probes.format_probes(rows))  # a disk error: exit 5
    out = est.as_dict()
    out["truth"] = {k: np.asarray(v).tolist() for k, v in truth.items()}
    out["relative_error"] = {k: _rel(out[k], truth[k]) for k in ("kx", "ky", "k1", "k2")}
    stopped = sorted({s for s in rolled.status if s != "done"})
    out["roll_status"] = stopped or ["done"]
    print_result(out, args.json)
    if not args.json:
        print(
            printable(
                f"{'truth':>10}: kx={truth['kx']:.6g} ky={truth['ky']:.6g} "
                f"k1={truth['k1']:.6g} k2={truth['k2']:.6g}"
            )
        )
    if stopped:
        raise DataError(f"a probe roll stopped early ({', '.join(stopped)}): reduce --dtheta")
    if est.status not in estimator.EXIT_OK:
        raise DataError(f"{est.status}: {est.message}")
    return 0


def _rel(est, true):
    if est is None:
        return None
    scale = max(abs(true), 1e-12)
    return abs(est - true) / scale


SUBCOMMANDS = {
    "ep1": ("simulate EP1 probes on an object, estimate and compare (ch. 3)", add_arguments, run)
}
