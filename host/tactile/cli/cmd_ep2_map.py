"""``tactile ep2 map FILE.csv``: smooth regions, the edges between them, and what touches what.

Every patch of the file is taken as part of one object (a long sweep, or many patches over
it); ``tactile.ep2.region_map.map_contacts`` segments and describes it.  Output: a table
(default), one JSON object (``--json``: ``units``, ``regions``, ``edges``, ``adjacency``) or
CSV (``--csv``: the regions, then after a ``# edges`` line the edges), every length in the
shown unit and every curvature in 1/unit.
"""

import numpy as np

from tactile import units
from tactile.ep2.contacts_csv import read_contacts
from tactile.ep2.region_map import EDGE_ANGLE_DEG, NEIGHBOURS, map_contacts
from tactile.errors import InputError
from tactile.output.text import dumps, printable


def add_arguments(subs):
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


def run(args):
    if args.neighbours < 5:
        raise InputError(f"--neighbours must be at least 5 (got {args.neighbours})")
    if not 0 < args.edge_angle < 180:
        raise InputError(f"--edge-angle must be in (0, 180) deg (got {args.edge_angle})")
    shown, scale = units.display(units.stated_length(args.file, None), args.units)
    groups = read_contacts(args.file)
    pts = np.vstack([g.points for g in groups])
    nrm = np.vstack([g.normals for g in groups])
    kw = {"noise_normal": args.noise_normal}
    if args.noise_pos is not None:
        kw["noise_pos"] = args.noise_pos / scale
    found = map_contacts(pts, nrm, neighbours_k=args.neighbours, edge_angle=args.edge_angle, **kw)
    rec = _in_unit(found.to_dict(), scale)
    rec["units"] = {"length": shown, "curvature": f"1/{shown}", "angle": "deg"}
    if args.json:
        print(dumps(rec))
    elif args.csv:
        _csv(rec, shown)
    else:
        _table(rec, shown)
    return 0


def _in_unit(rec, scale):
    for r in rec["regions"]:
        for k in ("k1", "k2"):
            r[k] /= scale
            r[k + "_interval"] = [v / scale for v in r[k + "_interval"]]
    for e in rec["edges"]:
        e["point"] = [v * scale for v in e["point"]]
    return rec


def _f(v, spec=".4g"):
    return "" if v is None else format(v, spec)


def _iv(iv, spec=".4g"):
    return ("", "") if iv is None else (_f(iv[0], spec), _f(iv[1], spec))


def _region_rows(rec):
    for r in rec["regions"]:
        s = [_f(r["S"], ".3f"), *_iv(r["S_interval"], ".3f")]
        yield [r["id"], r["n_points"], r["shape"], *s, _f(r["k1"]), *_iv(r["k1_interval"]),
               _f(r["k2"]), *_iv(r["k2_interval"])]  # fmt: skip


def _edge_rows(rec):
    for e in rec["edges"]:
        p = e["point"]
        d = e["direction"] or ["", "", ""]
        yield [*e["regions"], e["kind"], *(_f(v) for v in p), *(_f(v, ".3f") for v in d),
               _f(e["dihedral_deg"], ".1f"), *_iv(e["dihedral_interval"], ".1f"),
               _f(e["direction_err_deg"], ".2f")]  # fmt: skip


def _heads(unit):
    k = f"(1/{unit})"
    regions = ["region", "n_points", "shape", "S", "S_lo", "S_hi", f"k1 {k}", f"k1_lo {k}",
               f"k1_hi {k}", f"k2 {k}", f"k2_lo {k}", f"k2_hi {k}"]  # fmt: skip
    edges = ["region_a", "region_b", "kind", f"x ({unit})", f"y ({unit})", f"z ({unit})", "dx",
             "dy", "dz", "dihedral (deg)", "dihedral_lo (deg)", "dihedral_hi (deg)",
             "direction_err (deg)"]  # fmt: skip
    return regions, edges


def _csv(rec, unit):
    regions, edges = _heads(unit)
    print(printable(",".join(regions)))
    for row in _region_rows(rec):
        print(printable(",".join(str(v) for v in row)))
    print("# edges")
    print(printable(",".join(edges)))
    for row in _edge_rows(rec):
        print(printable(",".join(str(v) for v in row)))


def _table(rec, unit):
    regions, edges = _heads(unit)
    for head, rows in ((regions, list(_region_rows(rec))), (edges, list(_edge_rows(rec)))):
        cells = [head] + [[str(v) for v in r] for r in rows]
        width = [max(len(c[i]) for c in cells) for i in range(len(head))]
        for c in cells:
            print(printable("  ".join(v.rjust(w) for v, w in zip(c, width)).rstrip()))
        print()
    adj = "; ".join(f"{k}: {', '.join(map(str, v)) or '-'}" for k, v in rec["adjacency"].items())
    print(printable(f"adjacent regions: {adj}"))
