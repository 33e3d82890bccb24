"""``tactile sim ep1|ep2``: simulate probes or sweeps into files.

Its families register in the entry-point group ``tactile.commands.sim``: ``ep2`` here,
``ep1`` from the studies (it runs the host's EP1 estimator on what it simulates)."""

from tactile.commands import add_group, families, run_group


def add_arguments(parser):
    add_group(parser, "what", families("sim"))


run = run_group
