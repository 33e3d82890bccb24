"""``tactile study ep1-noise|ep1-paraboloid|ep1-resolution|ep1-arclength|ep1-dtheta``.

Each writes NAME.csv and NAME.png (fig. 20: NAME_SENSOR.png, one per sensor model) into
--out, and prints the path of every file it wrote.  A family of ``tactile study``
(``tactile.commands``): the studies load when one runs.
"""

import os

from tactile.commands import add_out, add_quiet
from tactile.errors import InputError
from tactile.output.text import dumps, printable


def _common(parser):
    add_out(parser, "output directory (created if missing)", default=".")
    parser.add_argument("--finger-radius", type=float, default=1.0)
    parser.add_argument("--trials", type=int, default=100, help="Monte-Carlo trials per cell")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--no-plot", action="store_true", help="CSV only")
    add_quiet(parser)


def _setup(args):
    if not args.finger_radius > 0:
        raise InputError(f"--finger-radius: must be positive, got {args.finger_radius}")
    if args.trials < 1:
        raise InputError(f"--trials: must be at least 1, got {args.trials}")
    try:
        os.makedirs(args.out, exist_ok=True)
    except OSError as exc:
        raise InputError(f"--out: cannot create {args.out}: {exc.strerror}") from None
    if args.quiet:
        return lambda it, **_: it
    try:
        from tqdm import tqdm
    except ImportError:  # no bar without the 'progress' extra
        return lambda it, **_: it

    return lambda it, desc="": tqdm(list(it), desc=desc, unit="step")


def _ep1(run):
    """``run(args, progress, studies, plots)`` as a subcommand's run: the options checked,
    then EP1's studies and figures loaded (SciPy: a family module, above)."""

    def checked(args):
        progress = _setup(args)
        from tactile_studies.ep1 import plots, studies

        return run(args, progress, studies, plots)

    return checked


def _finish(args, name, rows, studies, plot, **plot_kw):
    csv_path = os.path.join(args.out, f"{name}.csv")
    studies.write_csv(csv_path, rows)
    print(printable(csv_path))
    if not args.no_plot:
        for png in plot(rows, os.path.join(args.out, f"{name}.png"), **plot_kw):
            print(printable(png))
    return 0


def _monte_carlo(kind):
    """The run of study ``ep1-KIND``: ``study_KIND`` over ``--trials``, then ``plot_KIND``."""

    @_ep1
    def run(args, progress, studies, plots):
        study = getattr(studies, f"study_{kind}")
        rows = study(args.finger_radius, args.trials, args.seed, progress=progress)
        return _finish(args, f"ep1-{kind}", rows, studies, getattr(plots, f"plot_{kind}"))

    return run


run_noise = _monte_carlo("noise")
run_paraboloid = _monte_carlo("paraboloid")
run_resolution = _monte_carlo("resolution")


@_ep1
def run_arclength(args, progress, studies, plots):
    rows = studies.study_arclength(args.finger_radius)
    return _finish(args, "ep1-arclength", rows, studies, plots.plot_arclength)


def add_dtheta(parser):
    _common(parser)
    parser.add_argument("--noise-theta", type=float, default=0.005, help="rad, 1 sigma")
    parser.add_argument("--resolution", type=float, default=0.05, help="sensor step")
    parser.add_argument("--sensor", choices=("array", "gauss", "bias"), default="array")


@_ep1
def run_dtheta(args, progress, studies, plots):
    rows, summary = studies.study_optimal_dtheta(
        args.finger_radius,
        args.noise_theta,
        args.resolution,
        args.sensor,
        trials=args.trials,
        seed=args.seed,
    )
    print(dumps({"widest_range_within_25pct": summary}))
    setup = (
        f"'{args.sensor}' sensor, resolution {args.resolution:g} (unit of R1),"
        f" noise in \u0394\u03b8 {args.noise_theta:g} rad, R1 = {args.finger_radius:g},"
        f" {args.trials} trials"
    )
    return _finish(args, "ep1-dtheta", rows, studies, plots.plot_optimal, setup=setup)


SUBCOMMANDS = {
    "ep1-noise": ("fig. 16: sphere error vs RCR, dtheta and angle noise", _common, run_noise),
    "ep1-paraboloid": ("fig. 18: paraboloid error vs C, dtheta and noise", _common, run_paraboloid),
    "ep1-resolution": (
        "fig. 20: sphere error vs contact-sensor resolution",
        _common,
        run_resolution,
    ),
    "ep1-arclength": ("fig. 21: arc length vs RCR for a 90 degree roll", _common, run_arclength),
    "ep1-dtheta": (
        "beyond the thesis: best dtheta per radius for one sensor",
        add_dtheta,
        run_dtheta,
    ),
}
