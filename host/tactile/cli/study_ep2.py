"""``tactile study ep2-*``: replicas of figs. 30-34 and tables 5-7 as CSV + PNG."""


def _add(parser):
    parser.add_argument("--out", default="study_out", help="output folder (CSV + PNG)")
    parser.add_argument("--no-png", action="store_true", help="write CSV only")


def _run_with(fn_name, **extra):
    def run(args):
        from tactile_sim.ep2 import studies

        fn = getattr(studies, fn_name)
        rows = fn(args.out, png=not args.no_png, **extra)
        print(f"{fn_name}: {len(rows)} rows written to {args.out}/")
        return 0

    return run


def _add_tables(parser):
    _add(parser)
    parser.add_argument("--trials", type=int, default=50)


def _run_tables(args):
    from tactile_sim.ep2 import studies

    rows = studies.tables(args.out, trials=args.trials)
    print(
        "| surface | weighting | S | S std | R | radius | thesis S | thesis S std | thesis R"
        " | thesis radius | label share |"
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
        print("| " + " | ".join(cells) + " |")
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
        _run_with("radius_sweep", kind="cylinder"),
    ),
    "ep2-sphere-radius": (
        "fig. 34: S of spheres against radius and order",
        _add,
        _run_with("radius_sweep", kind="sphere"),
    ),
    "ep2-tables": (
        "tables 5-7 in simulation, beside the thesis's values",
        _add_tables,
        _run_tables,
    ),
}
