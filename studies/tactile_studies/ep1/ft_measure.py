"""EP1 through the F/T path, measured: the simulator's probes felt by a wrist F/T sensor and
localised by the host (§3.2, §3.3.3).

``measure_ft`` turns the EP1 simulator's true probes (``tactile_sim.ep1.probes.Probes``) into
measured rows (dtheta_x, dtheta_y, du, dv), the same layout as ``probes.measure``: each end's
load comes from ``tactile_sim.rig.fingertip.fingertip_wrench`` and the sensor model, and du,
dv from that wrench localised by the host's ``tactile.localize.sphere_contact``.
"""

import numpy as np

from tactile.localize.probes import sphere_contact, sphere_contact_frictionless
from tactile_sim.rig.fingertip import fingertip_uv, fingertip_wrench
from tactile_sim.rig.sensor import SIGMA_F, SIGMA_M, add_noise

__all__ = ["measure_ft"]


def measure_ft(
    probes,
    R1,
    normal_force=1.5,
    offset=0.05,
    mu=0.0,
    sigma_f=SIGMA_F,
    sigma_m=SIGMA_M,
    sigma_theta=0.0,
    threshold=0.0,
    rng=None,
    method="moment",
):
    """Measured (dtheta_x, dtheta_y, du, dv) rows (..., n, 4) and a usable mask (..., n).

    Each probe's start and end contacts are felt through ``fingertip_wrench`` (friction of
    ratio ``mu`` in a random tangent direction when rng is given), noised per axis and
    localised on the hemisphere; a probe is usable when both ends localise ('ok' or
    'near_miss').  Angle noise as in ``probes.measure``.  ``method``: "moment" (line of
    action, valid with friction) or "force" (frictionless: the direction of F only).
    """
    if method not in ("moment", "force"):
        raise ValueError(f"unknown method {method!r}; choose 'moment' or 'force'")
    centre, pole = (offset, 0.0, 0.0), (1.0, 0.0, 0.0)

    noisy = rng is not None
    ends = []
    for p in (probes.p_start, probes.p_end):
        phi = rng.uniform(0.0, 2 * np.pi, p.shape[:-1]) if noisy and mu else 0.0
        F, M = fingertip_wrench(p[..., 0], p[..., 1], R1, normal_force, offset, mu, phi)
        F, M = add_noise(F, M, rng, sigma_f, sigma_m)
        if method == "moment":
            c = sphere_contact(F, M, centre, R1, threshold, axis=pole)
        else:
            c = sphere_contact_frictionless(F, centre, R1, threshold, axis=pole)
        ends.append((fingertip_uv(c.point - np.array([offset, 0.0, 0.0]), R1), c.usable))
    (uv0, ok0), (uv1, ok1) = ends
    dth = probes.dtheta
    if sigma_theta > 0.0 and noisy:
        dth = dth + rng.normal(0.0, sigma_theta, dth.shape[:-1])[..., None] * probes.axis
    rows = np.concatenate([dth, uv1 - uv0], axis=-1)
    usable = ok0 & ok1
    return np.where(usable[..., None], rows, 0.0), usable
