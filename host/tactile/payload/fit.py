"""Identifying a tool from the mean readings at a few poses: one linear least squares.

With u_i = R_i^T g, gravity in the sensor frame at pose i, the model of ``tactile.payload.tool``
is linear in (m, b_F) and in (m c, b_T), as in FTCalib (ROS force_torque_tools):

    F_i = m u_i + b_F                           3 rows per pose, unknowns (m, b_F)
    T_i = (m c) x u_i + b_T = -[u_i]x (m c) + b_T   3 rows per pose, unknowns (m c, b_T)

The ten unknowns split into two blocks that share no unknown, so each is solved alone by QR
(``numpy.linalg.qr``, never the normal equations): forces and torques have their own units
and noise, and each block's residual gives its own variance.  Standard errors are
sqrt(sigma^2 diag((A^T A)^-1)) with (A^T A)^-1 = R^-1 R^-T from the QR factor, sigma^2 the
block's residual sum of squares over its degrees of freedom (3n - 4, 3n - 6); c = (m c) / m,
its error to first order from both blocks.

**What the poses must do.**  Only the spread of the u_i / |g| (unit gravity directions in the
sensor frame) about their mean informs the fit: a reading that repeats at every pose is
indistinguishable from a bias.  With s1 >= s2 the singular values of that spread
(rms, ``spread``):

- s1 = 0, one direction (poses turned only about the gravity axis, such as a fingertip
  pointing down turned about its own axis): F_i = m u + b_F for every i, three equations for
  four unknowns, and T_i = (m c) x u + b_T likewise: nothing is identified;
- s2 = 0, two directions (unit vectors on one line are at most two): the differences
  T_i - T_j = (m c) x (u_i - u_j) are blind to m c along u_i - u_j: the centre of mass along
  that line is not identified (the mass and b_F are);
- otherwise everything is, with errors that grow as 1/s.  Turning about any one axis that
  is not vertical is enough in principle (u_i then run round a cone), but a small tilt gives
  a small s: tilt the sensor well away from gravity about two axes.

``identify`` raises ``DataError`` (exit 3), one line saying what is missing, when s1 or s2 is
below ``MIN_SPREAD``, or when the mass found is not above its own noise.
"""

import numpy as np

from tactile.errors import DataError
from tactile.payload.tool import GRAVITY, MAX_MASS_KG, Tool
from tactile.payload.tool_weight import gravity_in_sensor

__all__ = ["MIN_POSES", "MIN_SPREAD", "identify", "spread"]

MIN_POSES = 3  # the torque block has 6 unknowns: 3 poses leave 3 degrees of freedom
# rms spread of the unit gravity directions below which they are taken as one (s1) or as on
# one line (s2): 0.02 is about 1 deg of rms tilt, where an error of 1 mN in a hold's mean
# makes about 5 mg of error in a 10 g tool's mass.
MIN_SPREAD = 0.02
SIGNIFICANT = 3.0  # the mass must exceed this many of its standard errors


def spread(u):
    """(s1, s2, s3) and the principal directions (3, 3) (rows) of the unit vectors ``u``
    (n, 3) about their mean: rms lengths, largest first."""
    d = u / np.linalg.norm(u, axis=1, keepdims=True)
    centred = d - d.mean(axis=0)
    _, s, vt = np.linalg.svd(centred / np.sqrt(len(d)), full_matrices=True)
    return np.concatenate([s, np.zeros(3 - len(s))]), vt


def _skew(v):
    """[v]x (n, 3, 3): [v]x w = v x w."""
    z = np.zeros(len(v))
    x, y, w = v.T
    return np.stack(
        [np.stack([z, -w, y], -1), np.stack([w, z, -x], -1), np.stack([-y, x, z], -1)], -2
    )


def _solve(A, y):
    """(x, standard errors, rms residual) of min |A x - y| by QR."""
    Q, R = np.linalg.qr(A)
    x = np.linalg.solve(R, Q.T @ y)  # R is upper triangular and of full rank (checked before)
    r = y - A @ x
    dof = len(y) - len(x)
    sigma2 = float(r @ r) / dof
    Rinv = np.linalg.solve(R, np.eye(len(x)))
    se = np.sqrt(sigma2 * np.einsum("ij,ij->i", Rinv, Rinv))
    return x, se, float(np.sqrt(np.mean(r * r)))


def _deg(s):
    d = float(np.degrees(s))
    return f"{d:.2g} deg" if d >= 1e-6 else "0 deg"


def _check_poses(u):
    n = len(u)
    if n < MIN_POSES:
        raise DataError(
            f"the poses do not determine the tool: {n} pose{'s' * (n != 1)}, at least"
            f" {MIN_POSES} needed (orientations tilted about two axes across gravity)"
        )
    s, vt = spread(u)
    if s[0] < MIN_SPREAD:
        raise DataError(
            "the poses do not determine the tool: gravity points the same way in the sensor"
            f" frame at every pose (rms spread {_deg(s[0])}), so the mass cannot"
            " be told from the force bias nor the centre of mass from the torque bias (turning"
            " about the gravity axis, or a vertical fingertip about its own axis, changes"
            " nothing): tilt the sensor about two axes across gravity"
        )
    if s[1] < MIN_SPREAD:
        line = ", ".join(f"{v:+.2f}" for v in vt[0])
        raise DataError(
            "the poses do not determine the tool: gravity takes only two directions in the"
            f" sensor frame (rms spread {_deg(s[1])} across their line), so the"
            f" centre of mass along ({line}) (sensor frame) is not determined: add a pose"
            " tilted about another axis"
        )


def identify(R_list, F_mean, T_mean, g=GRAVITY, sensor=0, cal_id=0, identified_from=""):
    """The ``Tool`` (mass, centre of mass, force and torque biases, each with its standard
    error, and the rms residuals) that best explains mean readings at ``n`` poses.

    ``R_list`` (n, 3, 3): the sensor's orientation in the world at each pose; ``F_mean``
    (n, 3) N and ``T_mean`` (n, 3) N*m: the mean reading held there (sensor frame, torque
    about the sensor origin); ``g`` (3,) m/s^2: gravity in the world frame.  ``sensor`` and
    ``cal_id`` are what the tool belongs to (``Tool``).  ``DataError`` when the poses do not
    determine the fit (module docstring) or the mass is not significant.
    """
    R = np.asarray(R_list, dtype=float).reshape(-1, 3, 3)
    F = np.asarray(F_mean, dtype=float).reshape(-1, 3)
    T = np.asarray(T_mean, dtype=float).reshape(-1, 3)
    if not len(R) == len(F) == len(T):
        raise ValueError(f"R_list ({len(R)}), F_mean ({len(F)}), T_mean ({len(T)}) differ")
    if not (np.all(np.isfinite(R)) and np.all(np.isfinite(F)) and np.all(np.isfinite(T))):
        raise ValueError("R_list, F_mean and T_mean must be finite")
    g = np.asarray(g, dtype=float).reshape(3)
    u = gravity_in_sensor(R, g)
    _check_poses(u)
    n, eye = len(u), np.tile(np.eye(3), (len(u), 1))
    xf, sef, rf = _solve(np.hstack([u.reshape(-1, 1), eye]), F.ravel())
    xt, set_, rt = _solve(np.hstack([-_skew(u).reshape(-1, 3), eye]), T.ravel())
    m, mc = xf[0], xt[:3]
    if not (m > SIGNIFICANT * sef[0] and m > 0):
        raise DataError(
            f"the poses do not determine the tool: its mass comes out {m * 1e3:.4g} +-"
            f" {sef[0] * 1e3:.2g} g, not above its noise (no tool, a pose log of another run,"
            " or gravity the other way: the world's z must point up)"
        )
    if m > MAX_MASS_KG:
        raise DataError(f"the mass comes out {m:.4g} kg, above {MAX_MASS_KG:g} kg: not a tool")
    com = mc / m
    com_se = np.sqrt((set_[:3] / m) ** 2 + (com * sef[0] / m) ** 2)
    return Tool(
        mass_kg=float(m),
        com_m=com,
        bias_force_N=xf[1:],
        bias_torque_Nm=xt[3:],
        sensor=int(sensor),
        cal_id=int(cal_id),
        gravity_m_s2=g,
        mass_kg_se=float(sef[0]),
        com_m_se=com_se,
        bias_force_N_se=sef[1:],
        bias_torque_Nm_se=set_[3:],
        residual_force_N=rf,
        residual_torque_Nm=rt,
        poses=n,
        identified_from=identified_from,
    )
