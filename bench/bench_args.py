"""Argument types the benches share (not a bench itself)."""

import argparse


def positive_int(text):
    """An ``argparse`` type: a whole number of at least 1 (a count of patches or trials);
    anything else is argparse's one-line usage error, exit 2."""
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not a whole number: {text!r}") from None
    if value < 1:
        raise argparse.ArgumentTypeError(f"must be at least 1, got {value}")
    return value


def add_split(parser, splits, default="tune"):
    """``--split`` (one of ``splits``) and ``--final``: a held-out split (its name holds
    "holdout") is for the final evaluation only, so it is refused without ``--final``."""
    parser.add_argument("--split", default=default, choices=sorted(splits))
    parser.add_argument("--final", action="store_true", help="allow a held-out split")


def check_split(parser, args):
    """Refuse a held-out ``--split`` without ``--final`` (argparse's one line, exit 2)."""
    if "holdout" in args.split and not args.final:
        parser.error(f"--split {args.split} is for the final evaluation only: add --final")
