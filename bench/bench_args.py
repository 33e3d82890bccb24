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
