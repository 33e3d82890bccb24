"""``tactile ep2 analyze FILE.csv``: fit a patch to contacts and normals, label its shape."""

METHODS = ("jet", "spline")
WEIGHTINGS = ("auto", "tangent", "position")


def add_arguments(parser):
    from tactile.ep2.patch_frame import MAX_NORMAL_ANGLE_DEG

    subs = parser.add_subparsers(dest="action", metavar="ACTION", required=True)
    p = subs.add_parser("analyze", help="fit and classify every patch of a contacts CSV")
    p.add_argument("file", help="CSV with x,y,z,nx,ny,nz [,finger] [,patch]")
    p.add_argument(
        "--method",
        choices=METHODS,
        default="jet",
        help="jet: curvature at the patch centre, model chosen by the data (default);"
        " spline: the thesis's B-spline patch (§4.6)",
    )
    p.add_argument(
        "--order",
        type=int,
        choices=(2, 3, 4, 5),
        help="spline degree per direction: 2 biquadratic (default), 3 bicubic, 4 biquartic",
    )
    p.add_argument("--segments", type=int, default=1, help="spline segments per direction")
    p.add_argument(
        "--weighting",
        choices=WEIGHTINGS,
        default="auto",
        help="spline row weights: auto (noise), or the thesis's tangent/position 100:1 (§4.9)",
    )
    p.add_argument("--grid", type=int, default=8, help="analysis grid N x N (default 8)")
    p.add_argument("--noise-pos", type=float, help="position noise sigma (length unit)")
    p.add_argument("--noise-normal", type=float, help="normal direction noise sigma (rad)")
    p.add_argument("--align", action="store_true", help="refit in the principal frame (§4.10)")
    p.add_argument(
        "--max-normal-angle",
        type=float,
        default=MAX_NORMAL_ANGLE_DEG,
        help=f"limit from the mean normal (deg, default {MAX_NORMAL_ANGLE_DEG:g})",
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
    if args.method == "jet" and (args.order is not None or args.weighting != "auto"):
        raise InputError("--order and --weighting choose the thesis's spline: add --method spline")
    opts = dict(
        method=args.method,
        order=args.order,
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
        name = patch_id(g.patch)
        try:
            results = analyze_sweep(
                g.points, g.normals, finger=g.finger, split=args.split, lines=g.lines, **opts
            )
        except InputError as exc:  # a split part EP2 cannot represent (``ep2.extent``)
            raise InputError(f"{args.file}: patch {name}: {exc}") from None
        except DataError as exc:
            if len(groups) == 1:
                raise DataError(f"{args.file}: {exc}") from None
            failed.append((name, str(exc)))
            records.append(
                {"patch": name, "n_points": len(g.points), "shape": None, "error": str(exc)}
            )
            continue
        for i, res in enumerate(results):
            label = name if len(results) == 1 else f"{name}#{i + 1}"  # split parts: text
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


def patch_id(text):
    """The patch id as the CSV has it: a number stays a number (1, 2.5), text stays text;
    1 when the file has no patch column.  Only canonical spellings become numbers, so
    '007' or '1.50' stay text and round-trip unchanged."""
    if text is None:
        return 1
    for kind in (int, float):
        try:
            value = kind(text)
        except ValueError:
            continue
        if (str(value) if kind is int else repr(value)) == text:
            return value
    return text


def _fmt(v, spec=".4g"):
    return "-" if v is None else format(v, spec)


def _table(records):
    """One line per patch, everything at the patch centre; S_mean etc. only in --json."""
    head = (
        f"{'patch':<10} {'n':>4} {'shape':<16} {'conf':>5} {'S':>7} {'S 95%':>15} "
        f"{'k1 (1/u)':>10} {'k2 (1/u)':>10} {'radius (u)':>10} {'C':>7}  model"
    )
    lines = [head]
    for r in records:
        if r.get("shape") is None:
            lines.append(f"{r['patch']:<10} {r['n_points']:>4} refused: {r['error']}")
            continue
        si = r["S_interval"]
        s95 = "-" if si is None else f"[{si[0]:.3f},{si[1]:.3f}]"
        lines.append(
            f"{r['patch']:<10} {r['n_points']:>4} {r['shape']:<16} {r['confidence']:>5.2f} "
            f"{_fmt(r['S'], '.3f'):>7} {s95:>15} {_fmt(r['k1']):>10} {_fmt(r['k2']):>10} "
            f"{_fmt(r['radius']):>10} {_fmt(r['C'], '.3f'):>7}  {r['model'].split(':')[0]}"
        )
        lines.extend(f"  warning: {w}" for w in r.get("warnings", []))
    lines.append(
        "u = the CSV's length unit; S, k1, k2, radius, C at the patch centre (--json: more)"
    )
    return "\n".join(lines)
