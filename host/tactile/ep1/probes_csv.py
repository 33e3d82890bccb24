"""The EP1 probes CSV contract.

A ``# units: rad`` line (a file without it is read as before), a header row; required
columns ``dtheta_x,dtheta_y,du,dv``: the net rotation of the finger about the x and y axes
of the contact frame (rad) and the change of the contact point in the fingertip parameters
of eq. 20 (rad), with the signs of eq. 29: M1 dp = (K1 + K2~)^-1 [-dtheta_y,
dtheta_x]^T.  Other columns are ignored; ``#`` lines are comments.
"""

from tactile import units
from tactile.files.tabular import read_csv

COLUMNS = ("dtheta_x", "dtheta_y", "du", "dv")

__all__ = ["COLUMNS", "read_probes", "format_probes"]


def read_probes(path):
    """Return (dtheta (m, 2), dp (m, 2)) arrays; errors are InputError naming file:line:column."""
    units.check_stated(path, {units.PROBES}, "a probes CSV holds angles in rad")
    table = read_csv(path, COLUMNS)
    data = table.array(*COLUMNS)
    return data[:, :2], data[:, 2:]


def format_probes(rows):
    """CSV text for an (m, 4) array of (dtheta_x, dtheta_y, du, dv) rows (repr precision)."""
    lines = [units.line(units.PROBES).rstrip("\n"), ",".join(COLUMNS)]
    lines += [",".join(repr(float(x)) for x in row) for row in rows]
    return "\n".join(lines) + "\n"
