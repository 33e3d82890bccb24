"""``tactile study NAME``: reproduce the thesis's simulation studies as CSV + PNG."""

from tactile.cli.dispatch import add_group, run_group

MODULES = ("tactile.cli.study_ep1", "tactile.cli.study_ep2")


def add_arguments(parser):
    add_group(parser, MODULES, "study")


def run(args):
    return run_group(args)
