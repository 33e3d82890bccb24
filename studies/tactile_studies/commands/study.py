"""``tactile study NAME``: reproduce the thesis's simulation studies as CSV + PNG.

Its families register in the entry-point group ``tactile.commands.study``: ``ep1`` (ch. 3)
and ``ep2`` (§4.9, tables 5-7)."""

from tactile.commands import add_group, families, run_group


def add_arguments(parser):
    add_group(parser, "study", families("study"))


run = run_group
