"""``tactile plot CONTACTS.csv|DIR``: PNGs of the contacts, the fitted patch and the S/C maps,
and (``--what map``) the region map of all the file's contacts as one object.

Axis labels carry a length unit: ``--units U`` converts to U from the CSV's ``# units:``
line; a CSV without the line is drawn as it is, labelled U (or "input unit").  The
``finger`` column of a recording from a one-sensor board counts passes (the ch. 5 rig moves
one finger in passes), so its legend says "pass".
"""

import pathlib
import re

import numpy as np

from tactile import units
from tactile.cli.cmd_ep2 import add_fit_arguments, check_fit_arguments
from tactile.commands import add_out, contacts_of
from tactile.ep2 import analyze_patch
from tactile.ep2.contacts_csv import read_contacts
from tactile.ep2.region_map import map_contacts
from tactile.errors import DataError, InputError
from tactile.output import plots, region_plot
from tactile.output.text import printable
from tactile.recording.layout import read_meta

WHAT = ("contacts", "patch", "maps", "map")
DEFAULT_WHAT = WHAT[:3]  # the region map takes the whole file as one object: asked for


def add_arguments(parser):
    parser.add_argument(
        "source", help="EP2 contacts CSV, or a 'tactile record -o DIR' directory (DIR/contacts.csv)"
    )
    add_out(parser, "where the PNGs go (default: next to the CSV, or DIR)", old=("--outdir",))
    add_fit_arguments(
        parser,
        "jet: the default fit (no control mesh); spline: the thesis's B-spline and its mesh",
        "spline row weights (§4.9)",
    )
    parser.add_argument(
        "--units",
        help="length unit drawn (m, cm, mm, ...; default: the CSV's '# units: U' line); a CSV"
        " without the line is drawn as it is, labelled U",
    )
    parser.add_argument(
        "--what",
        default=",".join(DEFAULT_WHAT),
        help=f"comma-separated figures to draw, of {','.join(WHAT)} (default"
        f" {','.join(DEFAULT_WHAT)}; map: all the file's contacts as one object, 'ep2 map')",
    )


def run(args):
    what = [w.strip() for w in args.what.split(",") if w.strip()]
    unknown = [w for w in what if w not in WHAT]
    if unknown or not what:
        raise InputError(
            f"--what: unknown figure {unknown[0] if unknown else '(none)'!r}"
            f" (choose from {','.join(WHAT)})"
        )
    check_fit_arguments(args)
    csv_path, stem, default_out = _source(pathlib.Path(args.source))
    outdir = pathlib.Path(args.out) if args.out else default_out
    plots.require_matplotlib()  # the install hint before any work
    groups = read_contacts(csv_path)
    unit, scale = _display(csv_path, args.units)
    word = _group_word(pathlib.Path(args.source))
    try:
        outdir.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise InputError(f"{outdir}: cannot create the output directory ({exc.strerror})") from None

    if scale != 1.0:
        for g in groups:
            g.points = g.points * scale
    labels = _labels(groups)
    failed = []
    for g, label in zip(groups, labels, strict=True):
        prefix = stem if label is None else f"{stem}_{label}"
        name = g.patch if g.patch is not None else "1"
        out = {w: outdir / f"{prefix}_{w}.png" for w in what if w != "map"}
        drawn = {"finger": g.finger, "unit": unit, "group": word}  # as every figure names them
        if "contacts" in out:
            title = f"patch {name}: {len(g.points)} contacts and normals"
            _draw(plots.plot_contacts, g.points, g.normals, out["contacts"], title=title, **drawn)
        if "patch" not in out and "maps" not in out:
            continue
        try:
            res = analyze_patch(
                g.points,
                g.normals,
                method=args.method,
                order=args.order,
                weighting=args.weighting,
                grid=args.grid,
                finger=g.finger,
                lines=g.lines,
                maps="maps" in out,
            )
        except DataError as exc:
            failed.append((name, str(exc)))
            continue
        if "patch" in out:
            _draw(plots.plot_patch, res, g.points, g.normals, out["patch"], **drawn)
        if "maps" in out:
            _draw(plots.plot_maps, res, out["maps"], points=g.points, unit=unit)
    if "map" in what:  # after the patches' figures: a map that cannot be made loses none
        _draw_map(groups, outdir / f"{stem}_map.png", unit)
    if failed:
        name, why = failed[0]
        raise DataError(
            f"{csv_path}: {len(failed)} of {len(groups)} patch(es) not fitted, so not drawn;"
            f" first: patch {name}: {why}"
        )
    return 0


def _draw_map(groups, path, unit):
    """The region map of every contact of the file (``map_contacts``, noise estimated)."""
    pts = np.vstack([g.points for g in groups])
    found = map_contacts(pts, np.vstack([g.normals for g in groups]))
    _draw(region_plot.plot_region_map, pts, found, path, unit=unit)


def _draw(plot, *args, **kw):
    """Call a ``tactile.output.plots`` function and print the path it wrote (its file is
    replaced whole: not a file there, exit 2; a disk error, exit 5)."""
    print(printable(plot(*args, **kw)), flush=True)


def _source(path):
    """(csv path, file-name stem, default output directory) for a CSV or a record directory."""
    if path.is_dir():
        return contacts_of(path), path.resolve().name or "contacts", path
    if not path.exists():
        raise InputError(f"{path}: no such file or directory")
    return path, path.stem, path.parent


def _display(csv_path, shown):
    """(the unit drawn or None, the scale from the file's unit to it): ``units.display``,
    except that a CSV stating no unit is drawn as it is, labelled ``shown``."""
    file_unit = units.stated_length(csv_path)
    if file_unit is None:
        return shown, 1.0
    return units.display(file_unit, shown) if shown else (file_unit, 1.0)


def _group_word(source):
    """'pass' for a recording from a one-sensor board (its finger column counts passes),
    else 'finger'."""
    try:
        sensors = read_meta(source / "meta.json")["device"]["n_sensors"]
    except (InputError, KeyError, TypeError):
        return "finger"
    return "pass" if sensors == 1 else "finger"


def _labels(groups):
    """File-name part per patch: None for a file without a patch column, else a safe unique name."""
    if len(groups) == 1 and groups[0].patch is None:
        return [None]
    out, seen = [], set()
    for i, g in enumerate(groups, 1):
        label = re.sub(r"[^A-Za-z0-9.-]+", "-", g.patch).strip(".-") or str(i)
        if label in seen:
            label = f"{label}-{i}"
        seen.add(label)
        out.append(label)
    return out
