"""``tactile sim ep2``: simulate a three-finger EP2 sweep into a contacts CSV.

A family of ``tactile sim`` (``tactile.commands``): the simulator's NumPy models load
when it runs, not when ``tactile sim``'s parser is built."""

import io

from tactile import units
from tactile.commands import add_out
from tactile.errors import InputError
from tactile.files.writing import write_bytes
from tactile.output.text import printable

KINDS = ("plane", "cylinder", "concave_cylinder", "sphere", "pit", "saddle", "quadric")
MAP_OBJECTS = ("box_corner", "capped_cylinder", "rounded_edge", "saddle_map")  # ep2 map's


def add_arguments(parser):
    parser.add_argument(
        "--object",
        required=True,
        choices=KINDS + MAP_OBJECTS,
        help="object kind; box_corner, capped_cylinder, rounded_edge and saddle_map are whole"
        " objects swept by finger lines, for 'tactile ep2 map' (their own size, in --units)",
    )
    parser.add_argument("--radius", type=float, default=10.0, help="radius (in --units)")
    parser.add_argument("--rotation", type=float, default=0.0, help="rotation about z (deg)")
    parser.add_argument("--k1", type=float, help="quadric: first principal curvature (1/--units)")
    parser.add_argument("--k2", type=float, help="quadric: second principal curvature (1/--units)")
    parser.add_argument(
        "--slope",
        type=float,
        nargs=2,
        default=(0.0, 0.0),
        metavar=("SX", "SY"),
        help="add a plane slope (z += SX x + SY y), e.g. 3 2",
    )
    parser.add_argument(
        "--noise-pos", type=float, default=0.0, help="position noise sigma (in --units)"
    )
    parser.add_argument("--noise-normal", type=float, default=0.0, help="normal noise sigma (rad)")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--spacing", type=float, default=2.0, help="finger spacing (in --units)")
    parser.add_argument("--length", type=float, default=4.0, help="sweep length (in --units)")
    parser.add_argument("--samples", type=int, default=6, help="stops per finger")
    parser.add_argument("--repeats", type=int, default=2, help="readings per stop")
    parser.add_argument("--tilt", type=float, default=0.0, help="tilt of the scene about x (deg)")
    parser.add_argument(
        "--thesis-layout",
        action="store_true",
        help="object apex at the sweep's corner (0, 0) as in §4.9, not its centre",
    )
    parser.add_argument(
        "--units",
        default="cm",
        metavar="U",
        help="the length unit of every length option and of the file's '# units:' line"
        " (default cm: the thesis's ch. 4 numbers carry none)",
    )
    parser.add_argument("--patches", type=int, default=1, help="write N patches (seeds seed..)")
    add_out(parser, "the contacts CSV to write", old=("--output",), required=True)


def run(args):
    from tactile_sim.ep2 import make, sweep, write_rows  # NumPy: a family module (above)

    unit = units.length_option(args.units)
    if args.radius <= 0:
        raise InputError(f"--radius must be positive (got {args.radius})")
    if args.samples < 1 or args.repeats < 1 or args.patches < 1:
        raise InputError("--samples, --repeats and --patches must be at least 1")
    k = None
    if args.object == "quadric":
        k = (
            args.k1 if args.k1 is not None else 1 / args.radius,
            args.k2 if args.k2 is not None else 0.5 / args.radius,
        )
    if args.object in MAP_OBJECTS:
        return _map_object(args, unit)
    centre = (0.0, 0.0) if args.thesis_layout else (args.spacing, args.length / 2)
    obj = make(args.object, args.radius, args.rotation, centre=centre, k=k, slope=args.slope)
    try:
        fh = io.StringIO()  # the whole file, written once: a refused run leaves no file
        for i in range(args.patches):
            data = sweep(
                obj,
                spacing=args.spacing,
                length=args.length,
                samples=args.samples,
                repeats=args.repeats,
                noise_pos=args.noise_pos,
                noise_normal=args.noise_normal,
                tilt_deg=args.tilt,
                seed=args.seed + i,
            )
            write_rows(
                fh,
                data,
                patch=str(i + 1) if args.patches > 1 else None,
                header=i == 0,
                unit=unit,
            )
    except ValueError as exc:
        raise InputError(str(exc)) from None
    write_bytes(args.out, fh.getvalue())  # replaced whole; a disk error: exit 5
    n = len(data["points"])
    print(printable(f"wrote {args.out}: {args.patches} patch(es) of {n} contacts"))
    return 0


def _map_object(args, unit):
    from tactile_sim.ep2 import map_objects, write_rows  # NumPy: a family module (above)

    name = "saddle" if args.object == "saddle_map" else args.object
    data = map_objects.make(name, args.noise_pos, args.noise_normal, seed=args.seed)
    fh = io.StringIO()
    write_rows(fh, data, unit=unit)
    write_bytes(args.out, fh.getvalue())
    print(printable(f"wrote {args.out}: {args.object}, {len(data['points'])} contacts"))
    return 0


SUBCOMMANDS = {"ep2": ("simulate a three-finger EP2 sweep into a contacts CSV", add_arguments, run)}
