"""The commands ``tactile`` has: its own (``OWN``), and those other installed packages register
in the entry-point group ``tactile.commands`` (the simulator's ``emulate`` and ``sim``, the
studies' ``demo`` and ``study``), found as python-can finds its interfaces.

Each is a ``Command``: its module, imported only when it runs, and the line ``tactile
--help`` shows.  The entry points are read only when a name is not one of ``OWN``, for
``--help``, and for a port URL whose scheme a package serves (group ``tactile.ports``), so
the CLI itself never imports the simulator or the studies (``tactile.commands``).
"""

import importlib
from importlib.metadata import entry_points

from tactile.commands import COMMANDS, PORTS, Command, absent
from tactile.errors import TactileError

# The CLI's own commands, in the order ``tactile --help`` lists them.
OWN = {
    "ports": Command("tactile.cli.cmd_ports", "list serial ports"),
    "info": Command("tactile.cli.cmd_info", "show a board's INFO"),
    "config": Command("tactile.cli.cmd_config", "set sample rate, contact gate and streams"),
    "tare": Command("tactile.cli.cmd_tare", "bias the F/T sensor"),
    "calibrate": Command(
        "tactile.cli.cmd_calibrate", "load a 6x6 calibration matrix onto a sensor"
    ),
    "record": Command(
        "tactile.cli.cmd_record", "record a stream: raw capture, contacts CSV, metadata"
    ),
    "live": Command("tactile.cli.cmd_live", "terminal view of force/torque and contact state"),
    "decode": Command(
        "tactile.cli.cmd_decode", "decode a raw byte capture: one message per line (text or --json)"
    ),
    "export": Command(
        "tactile.cli.cmd_export", "write a recording as MCAP (ROS 2) or Parquet for other tools"
    ),
    "flash": Command("tactile.cli.cmd_flash", "copy the firmware onto a MicroPython board"),
    "ep1": Command("tactile.cli.cmd_ep1", "EP1: curvature at a point from rolling probes (ch. 3)"),
    "ep2": Command("tactile.cli.cmd_ep2", "EP2: patch fit and shape classification (ch. 4)"),
    "payload": Command(
        "tactile.cli.cmd_payload", "identify the tool's weight (mass, centre of mass, biases)"
    ),
    "explore": Command(
        "tactile.cli.cmd_explore", "touch where the patch is least known until its label is sure"
    ),
    "plot": Command("tactile.cli.cmd_plot", "draw contacts, fitted patches and S/C maps as PNG"),
    "completion": Command("tactile.cli.cmd_completion", "print a bash/zsh/tcsh completion script"),
}


def _plugins():
    """name -> entry point of each command another package registers (not one of ``OWN``)."""
    return {e.name: e for e in entry_points(group=COMMANDS) if e.name not in OWN}


def names():
    """Every command's name: the CLI's own, then the registered ones."""
    return [*OWN, *_plugins()]


def commands():
    """name -> ``Command`` of every command that is installed, in ``names`` order."""
    found = dict(OWN)
    for name, entry in _plugins().items():
        try:
            found[name] = entry.load()
        except ModuleNotFoundError as exc:
            if not absent(exc, entry.module):
                raise
    return found


def find(name):
    """The ``Command`` called ``name``."""
    return OWN[name] if name in OWN else _plugins()[name].load()


def load(name):
    """The module of command ``name``, and its ``Command``; a TactileError (one line) when a
    module it needs is not installed (a package left out of this build)."""
    try:
        command = find(name)
        return importlib.import_module(command.module), command
    except ModuleNotFoundError as exc:
        raise TactileError(
            f"'{name}' is not available in this build: module {exc.name} is not installed"
        ) from None


def serve_ports(words):
    """Register the pyserial handler of each URL scheme a package serves (group
    ``tactile.ports``) that one of ``words`` (the arguments, ``$TACTILE_PORT``) names."""
    if not any("://" in word for word in words):
        return
    for entry in entry_points(group=PORTS):
        if any(f"{entry.name}://" in word for word in words):
            entry.load()()
