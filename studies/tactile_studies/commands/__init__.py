"""The studies' ``tactile`` commands: ``demo`` and ``study``, and ``sim ep1`` (pyproject.toml
registers them in the entry-point groups ``tactile.commands``, ``tactile.commands.study``
and ``tactile.commands.sim``; ``tactile.commands`` says how).  They import the host library,
the simulator and the studies, never the CLI."""

from tactile.commands import Command

DEMO = Command(
    "tactile_studies.commands.demo", "run the main job on the board emulator and print the result"
)
STUDY = Command("tactile_studies.commands.study", "reproduce the thesis's simulation studies")
