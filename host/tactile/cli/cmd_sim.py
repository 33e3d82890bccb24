"""``tactile sim ep1|ep2``: simulate probes or sweeps into files."""

from tactile.cli.dispatch import add_group, run_group

MODULES = ("tactile.cli.sim_ep1", "tactile.cli.sim_ep2")


def add_arguments(parser):
    add_group(parser, MODULES, "what")


def run(args):
    return run_group(args)
