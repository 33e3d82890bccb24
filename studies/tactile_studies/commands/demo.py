"""``tactile demo``: the chapter 5 experiment replicated on the board emulator.

For each of the thesis's three surfaces: the emulated board (the real
firmware, simulated transducer) streams CONTACT frames over a serial port;
``tactile_studies.replica.replicate`` records them as ``tactile record`` does (TARE,
capture, frames, meta), localises each contact on the wheel probe with the
robot's pose log (eqs. 60-62), fits tangent- and position-weighted
biquadratic patches on an 8x8 grid, and this prints S, sd S, R, sd R and
radius beside the thesis's tables 5-7, and per surface its label, contacts, localised
readings and frames lost.
"""

import pathlib

from tactile.commands import renamed
from tactile.output.text import printable
from tactile_studies import replica

# The surfaces by the one name EP2 labels them with -> the ch. 5 scene's rig object.
KINDS = {"plane": "plane", "cylinder": "convex", "concave_cylinder": "concave"}
OLD_NAMES = {"convex": "cylinder", "concave": "concave_cylinder"}
W = 9  # width of a number column: the table fits 80 columns


def add_arguments(parser):
    parser.add_argument(
        "--object",
        choices=tuple(KINDS),
        type=renamed(OLD_NAMES, "tactile demo"),
        action="append",
        help="default: all three",
    )
    parser.add_argument("-o", "--out", default="demo-out", help="recordings go here (demo-out/)")
    parser.add_argument(
        "--via",
        choices=("pty", "sim"),
        default="pty",
        help="serial path: a pseudo-terminal (default) or the in-process sim:// port",
    )


def run(args):
    true = ", ".join(f"{r:g}" for r in replica.TRUE_RADIUS_CM.values() if r)
    print(printable(f"Chapter 5 replica on the emulator: biquadratic, 8x8 grid; true r {true} cm"))
    head = ("S", "sd S", "R 1/cm", "sd 1/cm", "r cm")
    print(printable(f"{'surface':<17}{'fit':<9}{'':>6}" + "".join(f"{h:>{W}}" for h in head)))
    for name in dict.fromkeys(args.object or KINDS):
        kind = KINDS[name]
        outdir = pathlib.Path(args.out) / name
        meta, _, results = replica.replicate(kind, outdir, args.via)
        for weighting, res in results.items():
            _row(name, weighting, "ours", _ours(res))
            _row("", "", "thesis", replica.THESIS[kind][weighting])
        print(
            printable(
                f"{'':<17}label {results['tangent'].shape}; {meta['contacts_ended']} contacts,"
                f" {results['tangent'].n_points} localised, {meta['decoder']['lost_frames']} lost"
            )
        )
    print(printable(f"recordings: {pathlib.Path(args.out) / '*'} (one per surface)"))
    return 0


def _ours(res):
    return (res.S_mean, res.S_std, res.R_mean, res.R_std, res.radius)


def _row(name, weighting, who, values):
    cells = "".join(f"{'-' if v is None else f'{v:.4f}':>{W}}" for v in values)
    print(printable(f"{name:<17}{weighting:<9}{who:>6}{cells}"))
