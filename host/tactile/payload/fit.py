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

**A sensor's readings averaged within each hold** of a pose log, for ``identify``.

Each window of the log is a hold: the robot keeps the unloaded finger still at one pose.
Its edges are trimmed (``trim``, a fraction of the window at each end: the arm settling,
a log's stamps a little off), and the readings left are averaged.  A hold with fewer than
``min_readings`` readings left is dropped, and said so.

A board streaming both SAMPLE and CONTACT frames sends each reading in contact twice; the
readings of a sensor are its SAMPLE frames when it has any, else its CONTACT frames
(``reading_rows``).

**``identify_run(RUN, LOG)``**: a tool identified from a recording of the unloaded finger held
at the poses of a robot's pose log (``tactile payload identify``).

The recording is read with ``tactile.load_recording``; each reading's time is taken in the
log's clock (the board's stamps, or the host times of the recording's time base); the
sensor's readings are averaged within each hold (``tactile.payload.fit``) and the tool is
fitted to the means (``tactile.payload.fit.identify``).  The tool belongs to the sensor the
log's windows name and to the calibration id that sensor reported in the recording's INFO.

A log without orientations (no ``qw,qx,qy,qz``: a probe log, or any other CSV) is bad input
(``InputError``, exit 2); poses that do not determine the fit are ``DataError`` (exit 3).
"""

from dataclasses import dataclass, field

import numpy as np

from tactile.errors import DataError, InputError
from tactile.logs.read import GENERIC, SCARA, log_columns, read_pose_log
from tactile.payload.apply import ANY, Orientations
from tactile.payload.tool import GRAVITY, MAX_MASS_KG, Tool, gravity_in_sensor
from tactile.recording.load import load_recording

__all__ = [
    "MIN_POSES",
    "MIN_SPREAD",
    "identify",
    "spread",
    "MIN_READINGS",
    "TRIM",
    "Holds",
    "hold_means",
    "reading_rows",
    "identify_run",
    "pose_log_with_orientations",
]

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


TRIM = 0.2  # of each window, at each end
MIN_READINGS = 5


@dataclass
class Holds:
    """Per kept hold: ``R`` (k, 3, 3), mean force ``F`` (k, 3) N and torque ``T`` (k, 3) N*m,
    ``count`` (k,) readings averaged, ``sd`` (k, 6) their standard deviations, ``lines`` the
    log's line of each; ``dropped`` [(line, why)] of the holds left out."""

    R: np.ndarray
    F: np.ndarray
    T: np.ndarray
    count: np.ndarray
    sd: np.ndarray
    lines: list
    dropped: list = field(default_factory=list)

    def __len__(self):
        return len(self.count)


def reading_rows(sensor, is_sample, s):
    """Indices of sensor ``s``'s readings among frames of ``sensor`` (n,) and ``is_sample``
    (n,) bool (SAMPLE, else CONTACT): its SAMPLE frames if it has any, else its CONTACT ones."""
    mine = np.asarray(sensor) == s
    samples = mine & np.asarray(is_sample, dtype=bool)
    return np.flatnonzero(samples if samples.any() else mine)


def hold_means(t_us, wrench, t_start, t_end, R, lines, trim=TRIM, min_readings=MIN_READINGS):
    """``Holds`` of readings at ``t_us`` (n,) with ``wrench`` (n, 6) (one sensor's, in the
    log's clock) over windows ``t_start``, ``t_end`` (k,) held at ``R`` (k, 3, 3)."""
    if not 0 <= trim < 0.5:
        raise ValueError(f"trim: {trim!r} is not a fraction of a window in [0, 0.5)")
    t = np.asarray(t_us, dtype=np.int64)
    W = np.asarray(wrench, dtype=float).reshape(-1, 6)
    order = np.argsort(t, kind="stable")
    ts = t[order]
    keep, means, sds, counts, dropped = [], [], [], [], []
    for i, (a, b) in enumerate(zip(np.asarray(t_start), np.asarray(t_end))):
        cut = trim * (b - a)
        lo = np.searchsorted(ts, a + cut, side="left")
        hi = np.searchsorted(ts, b - cut, side="right")
        rows = order[lo:hi]
        if len(rows) < min_readings:
            dropped.append(
                (lines[i], f"{len(rows)} readings in the hold (fewer than {min_readings})")
            )
            continue
        keep.append(i)
        means.append(W[rows].mean(axis=0))
        sds.append(W[rows].std(axis=0))
        counts.append(len(rows))
    mean = np.array(means).reshape(-1, 6)
    return Holds(
        R=np.asarray(R, dtype=float)[keep].reshape(-1, 3, 3),
        F=mean[:, :3],
        T=mean[:, 3:],
        count=np.array(counts, dtype=int),
        sd=np.array(sds).reshape(-1, 6),
        lines=[lines[i] for i in keep],
        dropped=dropped,
    )


def pose_log_with_orientations(path):
    """The ``PoseLog`` at ``path`` if it gives the sensor's orientation (a generic pose log's
    quaternions, or a SCARA log's joints), else InputError saying so."""
    names = set(log_columns(path))
    if not ({"qw", "qx", "qy", "qz"} <= names or set(SCARA[3:]) <= names):
        raise InputError(
            f"{path}: the log has no orientations: the sensor's pose at each hold is needed,"
            f" columns {','.join(GENERIC)}"
        )
    return read_pose_log(path)


def _sensor_of(orient, sensor, log_path):
    """The sensor to identify: ``sensor`` if given (and in the log), else the log's only one."""
    found = orient.sensors()
    if sensor is not None:
        if not orient.covers(sensor):
            raise InputError(f"{log_path}: no window of sensor {sensor} (the log has {found})")
        return int(sensor)
    if found == [ANY]:
        return 0
    if len(found) != 1:
        raise InputError(f"{log_path}: windows of sensors {found}: choose one (--sensor)")
    return found[0]


def _cal_id(rec, sensor):
    device = rec.meta.get("device")
    ids = device.get("cal_ids") if isinstance(device, dict) else None
    if not isinstance(ids, list) or sensor >= len(ids) or not isinstance(ids[sensor], int):
        raise InputError(
            f"{rec.path}: meta.json has no calibration id of sensor {sensor} (no device INFO),"
            " so the tool cannot say which calibration it was measured with"
        )
    return ids[sensor]


def identify_run(run, pose_log, sensor=None, g=GRAVITY, trim=TRIM):
    """(``Tool``, ``Holds``): the tool identified from recording ``run`` (a ``tactile
    record`` folder) held at the poses of ``pose_log`` (module docstring)."""
    log = pose_log_with_orientations(pose_log)
    orient = Orientations.from_pose_log(log)
    s = _sensor_of(orient, sensor, pose_log)
    rec = load_recording(run)
    t_us, known = rec.times_in(log.clock)
    rows = reading_rows(rec.sensor, ~rec.is_contact, s)
    rows = rows[known[rows]]
    t0, t1, R = orient.held_windows(s)
    lines = [log.lines[i] for i in _window_rows(log, s)]
    holds = hold_means(t_us[rows], rec.wrench[rows], t0, t1, R, lines, trim)
    if len(holds) == 0:
        raise DataError(
            f"{run}: no readings of sensor {s} inside the pose log's holds (a log of another"
            " run? a board streaming only contacts: tactile config --streams samples,contacts)"
        )
    source = f"{run} at the poses of {pose_log}"
    tool = identify(holds.R, holds.F, holds.T, g, s, _cal_id(rec, s), source)
    return tool, holds


def _window_rows(log, sensor):
    """The log's rows of ``sensor``'s windows in time order (``Orientations`` order)."""
    rows = np.arange(len(log)) if log.kind == "scara" else np.flatnonzero(log.finger == sensor)
    return rows[np.argsort(log.t_start[rows], kind="stable")]
