"""The circular probe of §5.1.1: eqs. 60-61 (force only) and the rim from force and moment."""

import numpy as np
import pytest

from tactile.localize import rim_contact, wheel_contact, wheel_theta
from tactile.localize.contact import DEGENERATE, NO_CONTACT, OFF_PROBE, OK

CENTRE = np.array([0.12, 0.0, 0.0])
L4 = 0.015
W = 0.004


def _rim_load(theta, z, fn, mu_xy=0.0, mu_z=0.0):
    """Forward model: contact on the rim at angle theta, height z; the load on the probe is
    normal (toward the centre) plus friction along the rim (xy) and along the axis (z)."""
    radial = np.stack([np.cos(theta), np.sin(theta), 0 * theta], -1)
    along = np.stack([-np.sin(theta), np.cos(theta), 0 * theta], -1)
    p = CENTRE + L4 * radial + np.stack([0 * z, 0 * z, z], -1)
    mu_xy = np.broadcast_to(mu_xy, theta.shape)
    mu_z = np.broadcast_to(mu_z, theta.shape)
    F = fn[:, None] * (-radial + mu_xy[:, None] * along + mu_z[:, None] * [0.0, 0.0, 1.0])
    return p, -radial, F, np.cross(p, F)


def test_eq61_conventions_are_opposite_and_eq60_normal_matches_eq62_point():
    theta = np.linspace(-3.0, 3.0, 13)
    on_probe = -np.stack([np.cos(theta), np.sin(theta), 0 * theta], -1)  # toward the centre
    np.testing.assert_allclose(wheel_theta(on_probe), theta, atol=1e-14)
    # the thesis's literal atan2(fy, fx) reads the force the probe applies to the object
    np.testing.assert_allclose(wheel_theta(-on_probe, convention="object"), theta, atol=1e-14)
    c, th = wheel_contact(on_probe, CENTRE, L4)
    np.testing.assert_allclose(c.point, CENTRE + L4 * -on_probe, atol=1e-15)
    # eq. 60: n(theta) = (-cos theta, -sin theta), from the contact toward the centre
    np.testing.assert_allclose(c.normal[:, :2], -np.stack([np.cos(th), np.sin(th)], -1))
    with pytest.raises(ValueError, match="convention"):
        wheel_theta(on_probe, convention="sensor")


def test_frictionless_round_trip_over_the_arc_and_the_edge_of_the_arc():
    rng = np.random.default_rng(2)
    limit = np.pi - np.arcsin(0.004 / L4)
    theta = rng.uniform(-np.pi, np.pi, 4000)
    p, n, F, _ = _rim_load(theta, np.zeros(4000), rng.uniform(1.0, 5.0, 4000), np.zeros(4000))
    c, th = wheel_contact(F, CENTRE, L4, threshold=0.5, arc_limit=limit)
    inside = np.abs(theta) <= limit
    assert np.all(c.status[inside] == OK) and np.all(c.status[~inside] == OFF_PROBE)
    assert np.abs(c.point - p).max() < 1e-15 and np.abs(c.normal - n).max() < 1e-15
    # just either side of the edge
    edge = np.array([limit - 1e-9, limit + 1e-9])
    _, _, F, _ = _rim_load(edge, np.zeros(2), np.ones(2), np.zeros(2))
    c, _ = wheel_contact(F, CENTRE, L4, arc_limit=limit)
    assert c.status.tolist() == [OK, OFF_PROBE]


def test_gate_is_on_the_xy_force_as_in_section_5_1():
    F = np.array([[-1.0, 0.0, 9.0], [-2.0, 0.0, 0.0], [0.0, 0.0, 0.0]])
    c, th = wheel_contact(F, CENTRE, L4, threshold=1.39)
    assert c.status.tolist() == [NO_CONTACT, OK, NO_CONTACT]
    assert np.all(np.isfinite(c.point)) and th[0] == 0.0


@pytest.mark.parametrize("mu", [0.0, 0.2, 0.6])
def test_rim_from_moment_recovers_point_height_and_normal_with_friction(mu):
    rng = np.random.default_rng(4)
    n_ = 3000
    theta = rng.uniform(-2.5, 2.5, n_)
    z = rng.uniform(-W, W, n_)
    phi = rng.uniform(0, 2 * np.pi, n_)
    ratio = mu * rng.uniform(0, 1, n_)
    p, n, F, M = _rim_load(
        theta, z, rng.uniform(1, 5, n_), ratio * np.cos(phi), ratio * np.sin(phi)
    )
    c, th = rim_contact(F, M, CENTRE, L4, half_thickness=W)
    assert np.all(c.status == OK)
    assert np.abs(c.point - p).max() < 1e-13
    assert np.abs(c.normal - n).max() < 1e-11
    np.testing.assert_allclose(th, theta, atol=1e-11)
    np.testing.assert_allclose(np.tan(c.friction), ratio, atol=1e-9)
    if mu:  # the force-only method of eqs. 60-61 is biased by friction; the moment is not
        f, _ = wheel_contact(F, CENTRE, L4)
        assert np.abs(f.point[:, :2] - p[:, :2]).max() > 0.5 * L4 * np.arctan(0.5 * mu)


def test_rim_flags_off_the_rim_and_degenerate_forces():
    theta, z = np.array([0.3, 0.3]), np.array([0.9 * W, 1.5 * W])
    _, _, F, M = _rim_load(theta, z, np.ones(2), np.zeros(2))
    c, _ = rim_contact(F, M, CENTRE, L4, half_thickness=W)
    assert c.status.tolist() == [OK, OFF_PROBE]
    # a purely vertical force cannot be located on the rim: degenerate, not NaN
    Fv = np.array([[0.0, 0.0, -3.0], [1e-9, 0.0, -3.0]])
    c, _ = rim_contact(Fv, np.zeros((2, 3)), CENTRE, L4, threshold=0.0)
    assert c.status.tolist() == [NO_CONTACT, DEGENERATE]
    assert all(np.all(np.isfinite(a)) for a in c)
