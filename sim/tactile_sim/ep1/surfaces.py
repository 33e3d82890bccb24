"""Parametric surface maps f(u, v) for EP1 (§2.1, eq. 20, eq. 36) and their local geometry.

A ``Surface`` holds a name, its parameters, its chart (open box in (u, v)) and a function
returning f and its first and second partial derivatives.  ``local`` turns those into the
quantities Montana's equations need (eqs. 2-4, 13, 16), for ANY parameterisation:

- orthonormal Gauss frame: ``x = f_u/|f_u|``, ``z = f_u x f_v / |f_u x f_v|`` (outward),
  ``y = z x x`` (Gram-Schmidt; equals ``f_v/|f_v|`` only where ``f_u`` is perpendicular
  to ``f_v``, which eq. 2 silently assumes);
- metric ``M = [x y]^T [f_u f_v]`` (upper triangular; eq. 4 is its diagonal special case);
- curvature form ``K = [x y]^T [z_u z_v] M^-1`` (eq. 13; symmetric; convex positive);
- torsion form ``T = y^T [x_u x_v] M^-1`` (eq. 16).

Sign convention: the normal points out of the object's material, so convex surfaces
(sphere, convex cylinder, paraboloid of eq. 36 with C > 0) have positive curvature and
concave ones negative.
"""

from typing import NamedTuple

import numpy as np

__all__ = [
    "Surface",
    "Local",
    "local",
    "fingertip",
    "plane",
    "sphere",
    "cylinder",
    "paraboloid",
    "ellipsoid",
    "saddle",
    "torus",
    "make",
    "KINDS",
]

HALF_PI = 0.5 * np.pi


class Surface(NamedTuple):
    """A parametric map: ``derivs(u, v) -> (f, fu, fv, fuu, fuv, fvv)``, each shape (3, ...)."""

    name: str
    params: dict
    chart: tuple  # ((u_min, u_max), (v_min, v_max)), open
    derivs: object


class Local(NamedTuple):
    """Local geometry at one (u, v): frame columns x, y, z; metric M; curvature K; torsion T."""

    point: np.ndarray
    x: np.ndarray
    y: np.ndarray
    z: np.ndarray
    M: np.ndarray
    K: np.ndarray
    T: np.ndarray


def _cross(a, b):
    return np.array(
        [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]
    )


def local(surface, u, v):
    """Gauss frame, metric, curvature form and torsion form at scalar (u, v) (eqs. 2-4, 13, 16)."""
    f, fu, fv, fuu, fuv, fvv = surface.derivs(u, v)
    nu = np.sqrt(fu @ fu)
    x = fu / nu
    N = _cross(fu, fv)
    nN = np.sqrt(N @ N)
    z = N / nN
    y = _cross(z, x)
    M = np.array([[nu, x @ fv], [0.0, y @ fv]])
    # z_u, z_v: derivative of N/|N| = tangential part of N_u over |N|.
    Nu = _cross(fuu, fv) + _cross(fu, fuv)
    Nv = _cross(fuv, fv) + _cross(fu, fvv)
    zu = (Nu - z * (z @ Nu)) / nN
    zv = (Nv - z * (z @ Nv)) / nN
    Minv = _inv_upper(M)
    K = np.array([[x @ zu, x @ zv], [y @ zu, y @ zv]]) @ Minv
    K = 0.5 * (K + K.T)  # symmetric in exact arithmetic (Weingarten map, orthonormal frame)
    # x_u = tangential part of f_uu over |f_u| (minus its x component), y . x_u = y . f_uu / |f_u|.
    T = np.array([y @ fuu, y @ fuv]) / nu @ Minv
    return Local(f, x, y, z, M, K, T)


def _inv_upper(M):
    a, b, d = M[0, 0], M[0, 1], M[1, 1]
    return np.array([[1.0 / a, -b / (a * d)], [0.0, 1.0 / d]])


def fingertip(radius=1.0):
    """Semi-sphere of eq. 20: f = R (cos u cos v, -cos u sin v, sin u), |u|, |v| < pi/2."""
    return _sphere_map(
        "fingertip", radius, 1.0, 1.0, 1.0, ((-HALF_PI, HALF_PI), (-HALF_PI, HALF_PI))
    )


def sphere(radius=1.0):
    """Sphere with the map of eq. 20 (Montana's); u in (-pi/2, pi/2), v in (-pi, pi)."""
    return _sphere_map("sphere", radius, 1.0, 1.0, 1.0, ((-HALF_PI, HALF_PI), (-np.pi, np.pi)))


def ellipsoid(a=1.0, b=1.0, c=1.0):
    """Ellipsoid f = (a cos u cos v, -b cos u sin v, c sin u): not orthogonal unless a == b."""
    s = _sphere_map("ellipsoid", 1.0, a, b, c, ((-HALF_PI, HALF_PI), (-np.pi, np.pi)))
    return s._replace(params={"a": a, "b": b, "c": c})


def _sphere_map(name, r, a, b, c, chart):
    sa, sb, sc = r * a, r * b, r * c

    def derivs(u, v):
        cu, su, cv, sv = np.cos(u), np.sin(u), np.cos(v), np.sin(v)
        f = np.array([sa * cu * cv, -sb * cu * sv, sc * su])
        fu = np.array([-sa * su * cv, sb * su * sv, sc * cu])
        fv = np.array([-sa * cu * sv, -sb * cu * cv, 0.0 * u])
        fuu = -np.array([sa * cu * cv, -sb * cu * sv, sc * su])
        fuv = np.array([sa * su * sv, sb * su * cv, 0.0 * u])
        fvv = np.array([-sa * cu * cv, sb * cu * sv, 0.0 * u])
        return f, fu, fv, fuu, fuv, fvv

    return Surface(name, {"radius": r}, chart, derivs)


def _graph(name, params, chart, hu, hv, huu, huv, hvv, h):
    """Graph f = (u, v, h(u, v)) with upward normal."""

    def derivs(u, v):
        zero, one = 0.0 * u, 1.0 + 0.0 * u
        return (
            np.array([u + zero, v + zero, h(u, v) + zero]),
            np.array([one, zero, hu(u, v) + zero]),
            np.array([zero, one, hv(u, v) + zero]),
            np.array([zero, zero, huu(u, v) + zero]),
            np.array([zero, zero, huv(u, v) + zero]),
            np.array([zero, zero, hvv(u, v) + zero]),
        )

    return Surface(name, params, chart, derivs)


def plane(half_width=1e6):
    """Plane z = 0 with normal +z."""
    z = lambda u, v: 0.0  # noqa: E731
    w = half_width
    return _graph("plane", {}, ((-w, w), (-w, w)), z, z, z, z, z, z)


def paraboloid(C=1.0, half_width=2.0):
    """Paraboloid of revolution of eq. 36: f = (u, v, -C (u^2 + v^2)), |u|, |v| < 2.

    Convex (positive curvature) for C > 0.
    """
    w = half_width
    return _graph(
        "paraboloid",
        {"C": C},
        ((-w, w), (-w, w)),
        lambda u, v: -2.0 * C * u,
        lambda u, v: -2.0 * C * v,
        lambda u, v: -2.0 * C,
        lambda u, v: 0.0,
        lambda u, v: -2.0 * C,
        lambda u, v: -C * (u * u + v * v),
    )


def saddle(a=0.5, b=0.5, half_width=10.0):
    """Saddle f = (u, v, -(a u^2 - b v^2)): curvature 2a along u and -2b along v at the origin."""
    w = half_width
    return _graph(
        "saddle",
        {"a": a, "b": b},
        ((-w, w), (-w, w)),
        lambda u, v: -2.0 * a * u,
        lambda u, v: 2.0 * b * v,
        lambda u, v: -2.0 * a,
        lambda u, v: 0.0,
        lambda u, v: 2.0 * b,
        lambda u, v: -(a * u * u - b * v * v),
    )


def cylinder(radius=1.0, concave=False, half_length=1e6):
    """Cylinder along x.  Convex: f = (u, R sin v, R cos v); concave (inside of a pipe):
    f = (u, R sin v, -R cos v) with the normal towards the axis (curvature -1/R)."""
    r, s = radius, (-1.0 if concave else 1.0)
    vmax = HALF_PI if concave else np.pi

    def derivs(u, v):
        zero, one = 0.0 * u, 1.0 + 0.0 * u
        cv, sv = np.cos(v) + zero, np.sin(v) + zero
        return (
            np.array([u + zero, r * sv, s * r * cv]),
            np.array([one, zero, zero]),
            np.array([zero, r * cv, -s * r * sv]),
            np.array([zero, zero, zero]),
            np.array([zero, zero, zero]),
            np.array([zero, -r * sv, -s * r * cv]),
        )

    name = "concave_cylinder" if concave else "cylinder"
    return Surface(name, {"radius": radius}, ((-half_length, half_length), (-vmax, vmax)), derivs)


def torus(R=2.0, r=0.5):
    """Torus f = ((R + r cos u) cos v, -(R + r cos u) sin v, r sin u), outward normal."""

    def derivs(u, v):
        cu, su, cv, sv = np.cos(u), np.sin(u), np.cos(v), np.sin(v)
        w = R + r * cu
        return (
            np.array([w * cv, -w * sv, r * su]),
            np.array([-r * su * cv, r * su * sv, r * cu]),
            np.array([-w * sv, -w * cv, 0.0 * u]),
            np.array([-r * cu * cv, r * cu * sv, -r * su]),
            np.array([r * su * sv, r * su * cv, 0.0 * u]),
            np.array([-w * cv, w * sv, 0.0 * u]),
        )

    return Surface("torus", {"R": R, "r": r}, ((-np.pi, np.pi), (-np.pi, np.pi)), derivs)


KINDS = {
    "plane": plane,
    "sphere": sphere,
    "cylinder": cylinder,
    "concave_cylinder": lambda radius=1.0: cylinder(radius, concave=True),
    "paraboloid": paraboloid,
    "ellipsoid": ellipsoid,
    "saddle": saddle,
    "torus": torus,
}


def make(kind, **params):
    """Build an object surface by name (see ``KINDS``)."""
    try:
        factory = KINDS[kind]
    except KeyError:
        raise ValueError(f"unknown surface {kind!r}; choose from {', '.join(KINDS)}") from None
    return factory(**params)
