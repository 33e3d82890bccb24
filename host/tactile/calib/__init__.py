"""Calibration matrices onto a board: ``tactile calibrate`` (issue 14, part 4).

- ``units``: force, torque and gauge units and their SI factors;
- ``files``: reading a file (bounded) into a ``MatrixFile``: CSV and JSON here, ATI's
  ``.cal`` XML in ``ati``;
- ``convert``: the matrix in the board's convention (N and N*m per ADC count, float32),
  refused when singular or ill-conditioned;
- ``install``: SET_CAL, then INFO read back to verify the id and the matrix's checksum.

The convention and the checks: docs/calibration.md.
"""
