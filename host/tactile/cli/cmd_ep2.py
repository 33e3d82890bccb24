"""``tactile ep2 analyze FILE.csv``: fit a patch to contacts and normals, label its shape."""

WEIGHTINGS = ("auto", "tangent", "position")


def add_arguments(parser):
    subs = parser.add_subparsers(dest="action", metavar="ACTION", required=True)
    p = subs.add_parser("analyze", help="fit and classify every patch of a contacts CSV")
    p.add_argument("file", help="CSV with x,y,z,nx,ny,nz [,finger] [,patch]")
    p.add_argument(
        "--order",
        type=int,
        default=2,
        choices=(2, 3, 4, 5),
        help="polynomial degree per direction: 2 biquadratic (default), 3 bicubic, 4 biquartic",
    )
    p.add_argument("--segments", type=int, default=1, help="spline segments per direction")
    p.add_argument("--weighting", choices=WEIGHTINGS, default="auto", help="row weights (§4.9)")
    p.add_argument("--grid", type=int, default=8, help="analysis grid N x N (default 8)")
    p.add_argument("--noise-pos", type=float, help="position noise sigma (length unit)")
    p.add_argument("--noise-normal", type=float, help="normal direction noise sigma (rad)")
    p.add_argument("--align", action="store_true", help="refit in the principal frame (§4.10)")
    p.add_argument(
        "--max-normal-angle", type=float, default=70.0, help="limit from the mean normal (deg)"
    )
    p.add_argument("--break-angle", type=float, default=30.0, help="discontinuity angle (deg)")
    p.add_argument("--split", action="store_true", help="split a patch at discontinuities")
    p.add_argument("--json", action="store_true", help="one JSON object per patch per line")


def run(args):
    from tactile.ep2 import analyze_sweep
    from tactile.ep2.contacts_csv import read_contacts
    from tactile.errors import DataError, InputError
    from tactile.jsonout import dumps

    if args.grid < 2:
        raise InputError(f"--grid must be at least 2 (got {args.grid})")
    if args.segments < 1:
        raise InputError(f"--segments must be at least 1 (got {args.segments})")
    groups = read_contacts(args.file)
    opts = dict(
        degree=args.order,
        segments=args.segments,
        weighting=args.weighting,
        grid=args.grid,
        noise_pos=args.noise_pos,
        noise_normal=args.noise_normal,
        align=args.align,
        max_normal_angle=args.max_normal_angle,
        break_angle=args.break_angle,
    )
    failed = []
    records = []
    for g in groups:
        name = g.patch if g.patch is not None else "1"
        try:
            results = analyze_sweep(
                g.points, g.normals, finger=g.finger, split=args.split, lines=g.lines, **opts
            )
        except DataError as exc:
            if len(groups) == 1:
                raise DataError(f"{args.file}: {exc}") from None
            failed.append((name, str(exc)))
            records.append(
                {"patch": name, "n_points": len(g.points), "shape": None, "error": str(exc)}
            )
            continue
        for i, res in enumerate(results):
            label = name if len(results) == 1 else f"{name}#{i + 1}"
            records.append(res.to_dict(label))
    if args.json:
        for rec in records:
            print(dumps(rec))
    else:
        print(_table(records))
    if failed:
        name, why = failed[0]
        raise DataError(
            f"{args.file}: {len(failed)} of {len(groups)} patch(es) not determined;"
            f" first: patch {name}: {why}"
        )
    return 0


def _fmt(v, spec=".4g"):
    return "-" if v is None else format(v, spec)


def _table(records):
    head = (
        f"{'patch':<10} {'n':>4} {'shape':<16} {'conf':>5} {'S':>7} {'S_std':>6} "
        f"{'S 95%':>15} {'R':>9} {'C':>7} {'k1':>9} {'k2':>9} {'radius':>9}"
    )
    lines = [head]
    for r in records:
        if r.get("shape") is None:
            lines.append(f"{r['patch']:<10} {r['n_points']:>4} error: {r['error']}")
            continue
        si = r["S_interval"]
        s95 = "-" if si is None else f"[{si[0]:.3f},{si[1]:.3f}]"
        lines.append(
            f"{r['patch']:<10} {r['n_points']:>4} {r['shape']:<16} {r['confidence']:>5.2f} "
            f"{_fmt(r['S_mean'], '.3f'):>7} {_fmt(r['S_std'], '.3f'):>6} {s95:>15} "
            f"{_fmt(r['R_mean']):>9} {_fmt(r['C_mean'], '.3f'):>7} {_fmt(r['k1_mean']):>9} "
            f"{_fmt(r['k2_mean']):>9} {_fmt(r['radius']):>9}"
        )
        for row, finger, angle in (
            (d["row"], d["finger"], d["angle_deg"]) for d in r.get("discontinuities", [])
        ):
            lines.append(f"  warning: normals turn {angle:.0f} deg at row {row} (finger {finger})")
    return "\n".join(lines)
