"""``tactile ep2 analyze FILE.csv``: fit a patch to contacts and normals, label its shape;
``tactile ep2 map FILE.csv``: smooth regions, the edges between them, and what touches what.

``map`` takes every patch of the file as part of one object (a long sweep, or many patches
over it); ``tactile.ep2.region_map.map_contacts`` segments and describes it.  Output: a table
(default), one JSON object (``--json``: ``units``, ``regions``, ``edges``, ``adjacency``) or
CSV (``--csv``: the regions, then after a ``# edges`` line the edges), every length in the
shown unit and every curvature in 1/unit.
"""

import os
import sys

import numpy as np

from tactile import units
from tactile.commands import add_quiet, contacts_of
from tactile.ep2 import JetOptions, SplineOptions, contacts_csv
from tactile.ep2.batch import keep_heap
from tactile.ep2.geometry import MAX_NORMAL_ANGLE_DEG
from tactile.ep2.patch_input import METHODS, WEIGHTINGS, Request
from tactile.ep2.region_map import EDGE_ANGLE_DEG, NEIGHBOURS, map_contacts
from tactile.ep2.stream import MAX_JOBS, in_unit, outcomes
from tactile.errors import DataError, InputError
from tactile.output.text import dumps, printable, printable_lines


def add_fit_arguments(parser, method_help, weighting_help, segments=False):
    """The fit's options, as ``tactile ep2 analyze`` and ``tactile plot`` share them:
    ``--method``, ``--order``, (``--segments``,) ``--weighting`` and ``--grid``."""
    parser.add_argument("--method", choices=METHODS, default="jet", help=method_help)
    parser.add_argument(
        "--order",
        type=int,
        choices=(2, 3, 4, 5),
        help="spline degree per direction: 2 biquadratic (default), 3 bicubic, 4 biquartic",
    )
    if segments:
        parser.add_argument("--segments", type=int, default=1, help="spline segments per direction")
    parser.add_argument("--weighting", choices=WEIGHTINGS, default="auto", help=weighting_help)
    parser.add_argument("--grid", type=int, default=8, help="analysis grid N x N (default 8)")


def check_fit_arguments(args):
    """``add_fit_arguments``'s options refused in one line (exit 2) before any file is read."""
    if args.grid < 2:
        raise InputError(f"--grid must be at least 2 (got {args.grid})")
    if args.method == "jet" and (args.order is not None or args.weighting != "auto"):
        raise InputError("--order and --weighting choose the thesis's spline: add --method spline")


def add_arguments(parser):
    subs = parser.add_subparsers(dest="action", metavar="ACTION", required=True)
    p = subs.add_parser("analyze", help="fit and classify every patch of a contacts CSV")
    p.add_argument(
        "file",
        help="CSV with x,y,z,nx,ny,nz [,finger] [,patch], or a 'tactile record -o DIR' folder"
        " (DIR/contacts.csv)",
    )
    add_fit_arguments(
        p,
        "jet: curvature at the patch centre, model chosen by the data (default);"
        " spline: the thesis's B-spline patch (§4.6)",
        "spline row weights: auto (noise), or the thesis's tangent/position 100:1 (§4.9)",
        segments=True,
    )
    p.add_argument(
        "--units",
        metavar="U",
        help="length unit shown (m, cm, mm, um, ...; default: the file's '# units:' line);"
        " k in 1/U, C from R in 1/U",
    )
    p.add_argument(
        "--file-units",
        metavar="U",
        help="the file's length unit, for a file without a '# units:' line; one that has"
        " the line must agree (else exit 2)",
    )
    p.add_argument("--noise-pos", type=float, help="position noise sigma (in --units' unit)")
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
    p.add_argument(
        "--jobs",
        type=int,
        default=1,
        metavar="N",
        help="analyse patches in N processes (default 1); the output is the same, in file order",
    )
    add_quiet(p)
    _add_map_arguments(subs)


def run(args):
    if args.action == "map":
        return _run_map(args)
    args.file = str(contacts_of(args.file))  # a run folder: its contacts.csv
    check_fit_arguments(args)
    if args.segments < 1:
        raise InputError(f"--segments must be at least 1 (got {args.segments})")
    if not 1 <= args.jobs <= MAX_JOBS:
        raise InputError(f"--jobs must be a whole number in 1..{MAX_JOBS} (got {args.jobs})")

    if args.file_units is not None:
        units.length_option(args.file_units, "--file-units")
    file_unit = units.stated_length(args.file, args.file_units)
    shown, scale = units.display(file_unit, args.units)
    groups = _checked(args.file, args.quiet)  # read again, patch by patch, as they are analysed
    req = Request(
        args.method,
        jet=JetOptions(
            noise_pos=None if args.noise_pos is None else args.noise_pos / scale,
            noise_normal=args.noise_normal,
            max_normal_angle=args.max_normal_angle,
            break_angle=args.break_angle,
            grid=args.grid,
        ),
        spline=SplineOptions(args.order, args.segments, args.weighting, args.align),
    )
    named = ((g, patch_id(g.patch)) for g in groups)
    out = _Printer(args.json, shown, scale, file_unit is not None)
    failed = []
    bar = None if args.quiet else _progress(len(groups))
    keep_heap()  # (this process fits stack after stack: the allocator keeps their pages)
    try:
        for done in outcomes(named, req, split=args.split, jobs=args.jobs):
            if done.input_error is not None:
                raise InputError(f"{args.file}: patch {done.name}: {done.input_error}")
            if done.data_error is not None:
                if len(groups) == 1:
                    raise DataError(f"{args.file}: {done.data_error}")
                failed.append((done.name, done.data_error))
                rec = {"patch": done.name, "n_points": done.n_points, "shape": None}
                done.records.append({**rec, "error": done.data_error})
            out.records(done.records)
            if bar is not None:
                bar.update()
    finally:
        if bar is not None:
            bar.close()
    out.close()
    if failed:
        name, why = failed[0]
        raise DataError(
            f"{args.file}: {len(failed)} of {len(groups)} patch(es) not determined;"
            f" first: patch {name}: {why}"
        )
    return 0


PROGRESS_FROM = 2000  # patches: a bar on stderr (a terminal only) for files larger than this
CHECK_BAR_FROM = 64 * 2**20  # bytes: a bar for the checking pass of a file larger than this


def _checked(path, quiet=False):
    """``ContactsFile(path)``: the whole file checked, with a bar for a large one."""
    try:
        size = os.path.getsize(path)
    except OSError:
        size = 0  # ContactsFile says why
    bar = None if quiet else _bar(size, CHECK_BAR_FROM, unit="B", unit_scale=True, desc="ep2 check")
    if bar is None:
        return contacts_csv.ContactsFile(path)
    try:
        return contacts_csv.ContactsFile(path, progress=lambda done: bar.update(done - bar.n))
    finally:
        bar.close()


def _progress(n_patches):
    """A tqdm bar on stderr for a long file when stderr is a terminal; None otherwise (no
    tqdm installed, output piped or captured, few patches)."""
    return _bar(n_patches, PROGRESS_FROM, unit="patch", desc="ep2 analyze")


def _bar(total, start_above, **kw):
    if total <= start_above or not sys.stderr.isatty():
        return None
    try:
        from tqdm import tqdm
    except ImportError:
        return None
    return tqdm(total=total, file=sys.stderr, **kw)


class _Printer:
    """Each patch's lines as soon as they are known, flushed: JSON lines, or the table
    (its header before the first row, its footnote at the end)."""

    def __init__(self, as_json, unit="u", scale=1.0, stated=True):
        self.as_json, self.unit, self.scale, self.stated = as_json, unit, scale, stated
        self.started = False

    def records(self, records):
        records = [in_unit(r, self.unit, self.scale) for r in records]
        if self.as_json:
            lines = [dumps(r) for r in records]
        else:
            lines = [] if self.started else [_head(self.unit)]
            self.started = True
            for r in records:
                lines.extend(_rows(r))  # patch ids are the file's: escaped below
        print(printable_lines(lines), flush=True)

    def close(self):
        if not self.as_json:
            lines = [] if self.started else [_head(self.unit)]
            print(printable_lines([*lines, _foot(self.unit, self.stated)]), flush=True)


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


def _head(unit):
    k1, k2, radius, c = f"k1 (1/{unit})", f"k2 (1/{unit})", f"radius ({unit})", f"C (R in 1/{unit})"
    return (
        f"{'patch':<10} {'n':>4} {'shape':<16} {'conf':>5} {'S':>7} {'S 95%':>15} "
        f"{k1:>11} {k2:>11} {radius:>11} {c:>14}  model"
    )


def _foot(unit, stated):
    what = (
        f"lengths in {unit}"
        if stated
        else "u = the CSV's length unit (the file states none: add '# units: m' or --file-units)"
    )
    return (
        f"{what}; C = (2/pi) ln R with R = sqrt((k1^2 + k2^2)/2) in 1/{unit}: another unit"
        " shifts C; S, k1, k2, radius, C at the patch centre (--json: more)"
    )


def _rows(r):
    """One record's table lines: the patch centre's values (S_mean etc. only in --json),
    then its warnings."""
    if r.get("shape") is None:
        return [f"{r['patch']:<10} {r['n_points']:>4} refused: {r['error']}"]
    si = r["S_interval"]
    s95 = "-" if si is None else f"[{si[0]:.3f},{si[1]:.3f}]"
    line = (
        f"{r['patch']:<10} {r['n_points']:>4} {r['shape']:<16} {r['confidence']:>5.2f} "
        f"{_fmt(r['S'], '.3f'):>7} {s95:>15} {_fmt(r['k1']):>11} {_fmt(r['k2']):>11} "
        f"{_fmt(r['radius']):>11} {_fmt(r['C'], '.3f'):>14}  {r['model'].split(':')[0]}"
    )
    return [line, *(f"  warning: {w}" for w in r.get("warnings", []))]


# --- tactile ep2 map ---------------------------------------------------------------------


def _add_map_arguments(subs):
    p = subs.add_parser("map", help="segment one object's contacts into regions and edges")
    p.add_argument("file", help="CSV with x,y,z,nx,ny,nz [,finger] [,patch]: one object")
    p.add_argument("--units", metavar="U", help="length unit shown (default: the file's)")
    p.add_argument("--noise-pos", type=float, help="position noise sigma (in --units' unit)")
    p.add_argument("--noise-normal", type=float, help="normal direction noise sigma (rad)")
    p.add_argument("--neighbours", type=int, default=NEIGHBOURS, help="contacts a neighbourhood")
    p.add_argument("--edge-angle", type=float, default=EDGE_ANGLE_DEG,
                   help=f"normals this far apart across a link are an edge (deg, default"
                   f" {EDGE_ANGLE_DEG:g})")  # fmt: skip
    out = p.add_mutually_exclusive_group()
    out.add_argument("--json", action="store_true", help="one JSON object")
    out.add_argument("--csv", action="store_true", help="regions, then edges, as CSV")


def _run_map(args):
    if args.neighbours < 5:
        raise InputError(f"--neighbours must be at least 5 (got {args.neighbours})")
    if not 0 < args.edge_angle < 180:
        raise InputError(f"--edge-angle must be in (0, 180) deg (got {args.edge_angle})")
    shown, scale = units.display(units.stated_length(args.file, None), args.units)
    groups = contacts_csv.read_contacts(args.file)
    pts = np.vstack([g.points for g in groups])
    nrm = np.vstack([g.normals for g in groups])
    kw = {"noise_normal": args.noise_normal}
    if args.noise_pos is not None:
        kw["noise_pos"] = args.noise_pos / scale
    found = map_contacts(pts, nrm, neighbours_k=args.neighbours, edge_angle=args.edge_angle, **kw)
    rec = _map_in_unit(found.to_dict(), scale)
    rec["units"] = {"length": shown, "curvature": f"1/{shown}", "angle": "deg"}
    if args.json:
        print(dumps(rec))
    elif args.csv:
        _map_csv(rec, shown)
    else:
        _map_table(rec, shown)
    return 0


def _map_in_unit(rec, scale):
    for r in rec["regions"]:
        for k in ("k1", "k2"):
            r[k] /= scale
            r[k + "_interval"] = [v / scale for v in r[k + "_interval"]]
    for e in rec["edges"]:
        e["point"] = [v * scale for v in e["point"]]
    return rec


def _cell(v, spec=".4g"):
    return "" if v is None else format(v, spec)


def _iv(iv, spec=".4g"):
    return ("", "") if iv is None else (_cell(iv[0], spec), _cell(iv[1], spec))


def _region_rows(rec):
    for r in rec["regions"]:
        s = [_cell(r["S"], ".3f"), *_iv(r["S_interval"], ".3f")]
        yield [r["id"], r["n_points"], r["shape"], *s, _cell(r["k1"]), *_iv(r["k1_interval"]),
               _cell(r["k2"]), *_iv(r["k2_interval"])]  # fmt: skip


def _edge_rows(rec):
    for e in rec["edges"]:
        p = e["point"]
        d = e["direction"] or ["", "", ""]
        yield [*e["regions"], e["kind"], *(_cell(v) for v in p), *(_cell(v, ".3f") for v in d),
               _cell(e["dihedral_deg"], ".1f"), *_iv(e["dihedral_interval"], ".1f"),
               _cell(e["direction_err_deg"], ".2f")]  # fmt: skip


def _map_heads(unit):
    k = f"(1/{unit})"
    regions = ["region", "n_points", "shape", "S", "S_lo", "S_hi", f"k1 {k}", f"k1_lo {k}",
               f"k1_hi {k}", f"k2 {k}", f"k2_lo {k}", f"k2_hi {k}"]  # fmt: skip
    edges = ["region_a", "region_b", "kind", f"x ({unit})", f"y ({unit})", f"z ({unit})", "dx",
             "dy", "dz", "dihedral (deg)", "dihedral_lo (deg)", "dihedral_hi (deg)",
             "direction_err (deg)"]  # fmt: skip
    return regions, edges


def _map_csv(rec, unit):
    regions, edges = _map_heads(unit)
    print(printable(",".join(regions)))
    for row in _region_rows(rec):
        print(printable(",".join(str(v) for v in row)))
    print("# edges")
    print(printable(",".join(edges)))
    for row in _edge_rows(rec):
        print(printable(",".join(str(v) for v in row)))


def _map_table(rec, unit):
    regions, edges = _map_heads(unit)
    for head, rows in ((regions, list(_region_rows(rec))), (edges, list(_edge_rows(rec)))):
        cells = [head] + [[str(v) for v in r] for r in rows]
        width = [max(len(c[i]) for c in cells) for i in range(len(head))]
        for c in cells:
            print(printable("  ".join(v.rjust(w) for v, w in zip(c, width)).rstrip()))
        print()
    adj = "; ".join(f"{k}: {', '.join(map(str, v)) or '-'}" for k, v in rec["adjacency"].items())
    print(printable(f"adjacent regions: {adj}"))
