"""The simulator's ``tactile`` commands: ``emulate`` and ``sim`` (pyproject.toml registers
them in the entry-point group ``tactile.commands``, and ``sim ep2`` in
``tactile.commands.sim``; ``tactile.commands`` says how).  They import the host library and
the simulator, never the CLI."""

from tactile.commands import Command

EMULATE = Command("tactile_sim.commands.emulate", "serve a simulated board on a pseudo-terminal")
SIM = Command("tactile_sim.commands.sim", "simulate EP1 probes or EP2 sweeps into files")
