"""``tactile study ep2-*``: replicas of figs. 30-34 and tables 5-7 as CSV + PNG.

Each prints the path of every file it wrote (``tactile_studies.ep2.studies.run``).  A family
of ``tactile study`` (``tactile.commands``): the studies load when one runs.
"""

from tactile.commands import add_out
from tactile.errors import InputError
from tactile.output.text import printable, printable_lines


def _add(parser):
    add_out(parser, "output folder (CSV + PNG)", default="study_out")
    parser.add_argument("--no-png", action="store_true", help="write CSV only")


def _study(name, args, **options):
    """(rows, paths) of study ``name`` written into ``--out``."""
    from tactile_studies.ep2 import studies  # NumPy: a family module (above)

    return studies.run(name, args.out, png=not args.no_png, **options)


def _run_with(name):
    def run(args):
        _, paths = _study(name, args)
        print(printable_lines(paths))
        return 0

    return run


def _add_tables(parser):
    _add(parser)
    parser.add_argument("--trials", type=int, default=50, help="seeds per surface and fit")


def _run_tables(args):
    if args.trials < 1:
        raise InputError(f"--trials: must be at least 1, got {args.trials}")
    rows, paths = _study("tables", args, trials=args.trials)
    print(
        "| surface | weighting | S | S std | R (1/cm) | radius (cm) | thesis S | thesis S std"
        " | thesis R (1/cm) | thesis radius (cm) | label share |"
    )
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    for r in rows:
        cells = [r["surface"], r["weighting"]] + [
            "-" if r[k] is None else f"{r[k]:.4g}"
            for k in (
                "S_mean",
                "S_std",
                "R_mean",
                "radius",
                "thesis_S",
                "thesis_S_std",
                "thesis_R",
                "thesis_radius",
                "label_share",
            )
        ]
        print(printable("| " + " | ".join(cells) + " |"))
    print(printable_lines(paths))
    return 0


SUBCOMMANDS = {
    "ep2-cylinders": (
        "fig. 30/31: S of cylinders R 6/10/500 at 7 rotations",
        _add,
        _run_with("cylinders"),
    ),
    "ep2-rotation": ("fig. 32: RMS S error against rotation", _add, _run_with("rotation")),
    "ep2-cylinder-radius": (
        "fig. 33: S of 45-deg cylinders against radius and order",
        _add,
        _run_with("cylinder-radius"),
    ),
    "ep2-sphere-radius": (
        "fig. 34: S of spheres against radius and order",
        _add,
        _run_with("sphere-radius"),
    ),
    "ep2-tables": (
        "tables 5-7 in simulation, beside the thesis's values",
        _add_tables,
        _run_tables,
    ),
}
