"""Objects to map with ``tactile ep2 map`` (thesis §6.2.5, fig. 50), as EP2 case objects.

The emulator's scene motions sweep one smooth patch; these objects have edges and joins,
so they are made here, in the simulator's geometry: each ``make(name)`` returns the dense
finger sweeps over it (``points``, ``normals`` pointing out of the object, ``finger``) and
its truth: ``regions`` (label and count) and ``edges`` (``kind``, a ``point`` on the edge
nearest the sweeps' middle, its ``direction``, ``dihedral_deg``).  Lengths in cm (the
sweeps' ``UNIT``).

- ``box_corner``: three faces of a 4 cm cube about a corner; three 90 deg ridges.
- ``capped_cylinder``: a cylinder of radius 2 (axis z) under a hemispherical cap (§6.2.5):
  a cylinder and a sphere, one curvature jump on the circle z = 0.
- ``rounded_edge``: two faces of a cube meeting at a fillet of radius 1: plane, cylinder,
  plane, two curvature jumps where the fillet meets the faces.
- ``saddle``: z = (x^2 - y^2) / (2 R), R 5 (fig. 50): one region, no edge.
"""

import numpy as np

from tactile_sim.ep2.sweep import _tilt_normals

NAMES = ("box_corner", "capped_cylinder", "rounded_edge", "saddle")


def _lines(n_lines, stops, u_range, v_range):
    u = np.linspace(*u_range, n_lines)
    v = np.linspace(*v_range, stops)
    uu, vv = np.meshgrid(u, v, indexing="ij")
    return uu.ravel(), vv.ravel(), np.repeat(np.arange(n_lines), stops)


def box_corner():
    u, v, finger = _lines(8, 8, (0.2, 4.0), (0.2, 4.0))
    pts, nrm, fing = [], [], []
    for axis in range(3):
        a, b = [i for i in range(3) if i != axis]
        p = np.full((len(u), 3), 4.0)
        p[:, a], p[:, b] = u, v
        n = np.zeros_like(p)
        n[:, axis] = 1.0
        pts.append(p)
        nrm.append(n)
        fing.append(finger + 8 * axis)
    edges = []
    for axis in range(3):
        d = np.zeros(3)
        d[axis] = 1.0
        point = np.full(3, 4.0)
        point[axis] = 2.1
        edges.append({"kind": "ridge", "point": point, "direction": d, "dihedral_deg": 90.0})
    regions = [{"shape": "plane"}] * 3
    return np.vstack(pts), np.vstack(nrm), np.concatenate(fing), regions, edges


def capped_cylinder(R=2.0):
    """Lines over the cylinder's side facing +x (azimuth -50..50 deg), z -4..0, on over
    the cap to 60 deg of latitude."""
    az = np.radians(np.linspace(-50, 50, 9))
    pts, nrm, fing = [], [], []
    for i, a in enumerate(az):
        z = np.linspace(-4.0, 0.0, 10, endpoint=False)
        side = np.column_stack(
            [R * np.cos(a) * np.ones_like(z), R * np.sin(a) * np.ones_like(z), z]
        )
        n_side = np.column_stack([np.cos(a) * np.ones_like(z), np.sin(a) * np.ones_like(z), 0 * z])
        lat = np.radians(np.linspace(0, 60, 8))
        d = np.column_stack([np.cos(lat) * np.cos(a), np.cos(lat) * np.sin(a), np.sin(lat)])
        pts += [side, R * d]
        nrm += [n_side, d]
        fing.append(np.full(len(z) + len(lat), i))
    edges = [{"kind": "curvature jump", "point": np.array([R, 0.0, 0.0]),
              "direction": np.array([0.0, 1.0, 0.0]), "dihedral_deg": 180.0}]  # fmt: skip
    regions = [{"shape": "cylinder"}, {"shape": "sphere"}]
    return np.vstack(pts), np.vstack(nrm), np.concatenate(fing), regions, edges


def rounded_edge(r=1.0):
    """Face z = 0 (x <= 0), fillet of radius r about the axis (0, y, -r), face x = r
    (z <= -r); lines across the edge, arc-length parametrised."""
    s = np.linspace(-3.0, 3.0 + np.pi * r / 2, 30)
    y = np.linspace(0.0, 4.0, 8)
    pts, nrm, fing = [], [], []
    for i, yy in enumerate(y):
        for t in s:
            if t <= 0:
                p, n = [t, yy, 0.0], [0.0, 0.0, 1.0]
            elif t <= np.pi * r / 2:
                a = t / r
                p, n = [r * np.sin(a), yy, -r + r * np.cos(a)], [np.sin(a), 0.0, np.cos(a)]
            else:
                p, n = [r, yy, -r - (t - np.pi * r / 2)], [1.0, 0.0, 0.0]
            pts.append(p)
            nrm.append(n)
            fing.append(i)
    d = np.array([0.0, 1.0, 0.0])
    edges = [{"kind": "curvature jump", "point": np.array([0.0, 2.0, 0.0]), "direction": d,
              "dihedral_deg": 180.0},
             {"kind": "curvature jump", "point": np.array([r, 2.0, -r]), "direction": d,
              "dihedral_deg": 180.0}]  # fmt: skip
    regions = [{"shape": "plane"}, {"shape": "cylinder"}, {"shape": "plane"}]
    return np.array(pts), np.array(nrm), np.array(fing), regions, edges


def saddle(R=5.0):
    u, v, finger = _lines(10, 10, (-2.0, 2.0), (-2.0, 2.0))
    z = (u**2 - v**2) / (2 * R)
    n = np.column_stack([-u / R, v / R, np.ones_like(u)])
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    return np.column_stack([u, v, z]), n, finger, [{"shape": "saddle"}], []


MAKERS = {"box_corner": box_corner, "capped_cylinder": capped_cylinder,
          "rounded_edge": rounded_edge, "saddle": saddle}  # fmt: skip


def make(name, noise_pos=0.0, noise_normal=0.0, seed=0):
    """dict of ``points``, ``normals``, ``finger``, ``regions``, ``edges`` (module
    docstring), with Gaussian position noise (cm) and normal noise (rad per axis)."""
    pts, nrm, finger, regions, edges = MAKERS[name]()
    rng = np.random.default_rng(seed)
    if noise_pos:
        pts = pts + noise_pos * rng.standard_normal(pts.shape)
    if noise_normal:
        nrm = _tilt_normals(nrm, noise_normal, rng)
    return {"points": pts, "normals": nrm, "finger": finger, "regions": regions, "edges": edges}
