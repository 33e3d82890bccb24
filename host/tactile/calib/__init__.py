"""Calibration matrices onto a board: ``tactile calibrate`` (issue 14, part 4).

- ``units``: force, torque and gauge units and their SI factors;
- ``files``: reading a file (bounded) into a ``MatrixFile``: CSV and JSON here, ATI's
  ``.cal`` XML in ``ati``;
- ``convert``: the matrix in the board's convention (N and N*m per ADC count, float32),
  refused when singular or ill-conditioned;
- ``install``: SET_CAL, then INFO read back to verify the id and the matrix's checksum.

The convention and the checks: docs/calibration.md.  ``MatrixFile``, what every reader
returns, is here, below the readers.
"""

from collections import namedtuple

MAX_ID = 0xFFFFFFFF  # cal_id is a u32; 0 means "no calibration"

MatrixFile = namedtuple(
    "MatrixFile",
    "path kind matrix units cal_id id_from label notes places",
    defaults=((),),
)
MatrixFile.__doc__ = """A matrix as a file states it.

``matrix``: 6 lists of 6 floats; ``units``: ``units.Units``; ``cal_id``: int or None;
``id_from``: where the id came from; ``label``: one line saying what the file is;
``notes``: lines worth telling the user; ``places``: per row, its location for messages.
"""
