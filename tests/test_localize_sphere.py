"""Spherical fingertip: line of action of force and moment meets the sphere (§5.1.1, §3.3.3)."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from tactile.localize import STATUS, sphere_contact, sphere_contact_frictionless
from tactile.localize.contact import (
    MISS,
    NEAR_MISS,
    NO_CONTACT,
    OFF_PROBE,
    OK,
    entry_root,
    line_of_action,
)


def _unit(v):
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def _random_contacts(rng, n, centre, r, mu, scale=0.1):
    """Contacts on the sphere with a force inside the Coulomb cone of half-angle atan(mu)."""
    m = _unit(rng.standard_normal((n, 3)))  # probe's outward normal at the contact
    p = centre + r * m
    normal = -m  # object's outward normal: toward the probe centre
    t = _unit(np.cross(normal, rng.standard_normal((n, 3))))
    ratio = mu * rng.uniform(0.0, 1.0, n)
    fn = rng.uniform(0.5, 20.0, n)
    F = fn[:, None] * (normal + ratio[:, None] * t)
    origin = rng.standard_normal(3) * scale
    M = np.cross(p - origin, F)  # forward model: moment of a point force
    return p, normal, F, M, origin, ratio


@pytest.mark.parametrize("mu", [0.0, 0.3, 1.0])
def test_round_trip_random_poses_with_friction(mu):
    rng = np.random.default_rng(7)
    centre, r = np.array([0.12, -0.03, 0.05]), 0.02
    p, n, F, M, origin, ratio = _random_contacts(rng, 5000, centre, r, mu)
    c = sphere_contact(F, M, centre, r, origin=origin)
    assert np.all(c.status == OK)
    assert np.abs(c.point - p).max() < 1e-12
    assert np.abs(c.normal - n).max() < 1e-10
    np.testing.assert_allclose(c.friction, np.arctan(ratio), atol=1e-9)
    np.testing.assert_allclose(c.force, np.einsum("ij,ij->i", F, n), rtol=1e-12)


def test_frictionless_force_only_is_exact_without_friction_and_biased_with_it():
    rng = np.random.default_rng(3)
    centre, r = np.zeros(3), 1.5
    p, n, F, M, origin, _ = _random_contacts(rng, 2000, centre, r, 0.0)
    c = sphere_contact_frictionless(F, centre, r)
    assert np.abs(c.point - p).max() < 1e-13 and np.all(c.status == OK)
    mu = 0.4
    p, n, F, M, origin, ratio = _random_contacts(rng, 2000, centre, r, mu)
    c = sphere_contact_frictionless(F, centre, r)
    # the point slides along the surface by r * atan(ratio): the bias the moment removes
    arc = r * np.arccos(np.clip(np.einsum("ij,ij->i", c.normal, n), -1, 1))
    np.testing.assert_allclose(arc, r * np.arctan(ratio), atol=1e-9)


def test_below_threshold_and_zero_force_are_not_contacts_and_never_nan():
    F = np.array([[0.0, 0.0, 0.0], [0.0, 0.1, 0.0], [np.nan, 1.0, 0.0], [0.0, 0.0, -5.0]])
    M = np.zeros((4, 3))
    c = sphere_contact(F, M, (0.0, 0.0, 1.0), 0.5, threshold=0.5)
    assert list(c.status[:3]) == [NO_CONTACT] * 3 and c.status[3] == OK
    for arr in c:
        assert np.all(np.isfinite(arr))
    assert np.all(c.point[:3] == 0.0) and not c.usable[:3].any()
    # F = -5 z through the origin enters the sphere centred at (0, 0, 1) at its top, z = 1.5
    np.testing.assert_allclose(c.point[3], [0.0, 0.0, 1.5])
    np.testing.assert_allclose(c.normal[3], [0.0, 0.0, -1.0])


def test_force_parallel_to_the_moment_arm():
    # M = 0: the line passes through the sensor origin; the contact is where it enters.
    centre, r = np.array([0.1, 0.0, 0.0]), 0.02
    F = np.array([[-3.0, 0.0, 0.0], [-1.0, -0.1, 0.0]])
    c = sphere_contact(F, np.zeros((2, 3)), centre, r)
    np.testing.assert_allclose(c.point[0], [0.12, 0.0, 0.0], atol=1e-15)
    assert c.status[0] == OK
    # forward check for the second: the point lies on the line through O along F
    assert np.linalg.norm(np.cross(c.point[1], F[1])) < 1e-15
    assert abs(np.linalg.norm(c.point[1] - centre) - r) < 1e-15


def test_line_missing_the_sphere_gives_closest_point_and_flags():
    centre, r = np.zeros(3), 1.0
    # line x = 1 + d (offset along +x), running along -z
    d = np.array([0.0, 0.05, 0.5])
    p_line = np.stack([1.0 + d, 0 * d, 0 * d], axis=-1)
    F = np.tile([0.0, 0.0, -2.0], (3, 1))
    c = sphere_contact(F, np.cross(p_line, F), centre, r, tol=0.1)
    assert [STATUS[s] for s in c.status] == ["ok", "near_miss", "miss"]
    np.testing.assert_allclose(c.residual, [0.0, 0.05, 0.5], atol=1e-12)
    np.testing.assert_allclose(c.point[1:], [[1, 0, 0], [1, 0, 0]], atol=1e-12)
    assert c.usable.tolist() == [True, True, False]
    assert c.status[1] == NEAR_MISS and c.status[2] == MISS


def test_hemisphere_pole_flags_points_behind_the_fingertip():
    centre, r = np.zeros(3), 1.0
    F = np.array([[-1.0, 0.0, 0.0], [1.0, 0.0, 0.0]])  # hits at +x, and at -x
    c = sphere_contact(F, np.zeros((2, 3)), centre, r, axis=(1.0, 0.0, 0.0))
    assert c.status[0] == OK and c.status[1] == OFF_PROBE


def test_twist_about_the_force_does_not_move_the_point():
    rng = np.random.default_rng(11)
    p, n, F, M, origin, _ = _random_contacts(rng, 200, np.zeros(3), 1.0, 0.5)
    twist = rng.normal(size=200)[:, None] * _unit(F)
    a = sphere_contact(F, M, np.zeros(3), 1.0, origin=origin)
    b = sphere_contact(F, M + twist, np.zeros(3), 1.0, origin=origin)
    assert np.abs(a.point - b.point).max() < 1e-12
    _, _, _, tw = line_of_action(F, M + twist, origin)
    np.testing.assert_allclose(tw, np.einsum("ij,ij->i", twist, _unit(F)), atol=1e-12)


def _normal(x):
    return x == 0.0 or abs(x) > 1e-100  # no subnormal underflow in b*b, a*c


@settings(max_examples=300, deadline=None)
@given(
    b=st.floats(-1e6, 1e6).filter(_normal),
    c=st.floats(-1e6, 1e6).filter(_normal),
    a=st.floats(1e-3, 1e3),
)
def test_entry_root_is_the_smaller_root_without_cancellation(a, b, c):
    t, disc = entry_root(np.float64(a), np.float64(b), np.float64(c))
    if disc >= 0:
        roots = np.roots([a, 2 * b, c]) if c != 0 or b != 0 else np.array([0.0])
        assert np.isclose(t, np.min(roots.real), rtol=1e-7, atol=1e-9 * (1 + abs(b) / a))
        assert (
            abs(a * t * t + 2 * b * t + c) <= 1e-9 * (a * t * t + 2 * abs(b * t) + abs(c)) + 1e-300
        )
    else:
        assert t == -b / a


def test_tiny_and_huge_spheres_are_located_to_relative_precision():
    rng = np.random.default_rng(5)
    for r in (1e-3, 1.0, 1e3):
        centre = np.array([3.0, -2.0, 1.0]) * r
        p, n, F, M, origin, _ = _random_contacts(rng, 500, centre, r, 0.5, scale=r)
        c = sphere_contact(F, M, centre, r, origin=origin)
        assert np.all(c.status == OK)
        assert np.abs(c.point - p).max() < 1e-9 * r
        assert np.abs(c.normal - n).max() < 1e-8
