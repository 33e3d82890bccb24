"""``tactile ep2 map`` and ``tactile.ep2.region_map.map_contacts``: regions, edges, adjacency."""

import json
from types import SimpleNamespace as Fit

import numpy as np

from tactile.ep2 import region_map
from tactile.ep2.region_map import map_contacts
from tactile_sim.commands.sim_ep2 import MAP_OBJECTS
from tactile_sim.ep2 import map_objects


def _box_corner(seed=0, n=8):
    """Three faces of the unit cube about its corner (1, 1, 1), an n x n grid on each."""
    rng = np.random.default_rng(seed)
    g = np.linspace(0.05, 1.0, n)
    u, v = (a.ravel() for a in np.meshgrid(g, g))
    pts, nrm = [], []
    for axis in range(3):
        p = np.ones((len(u), 3))
        a, b = [i for i in range(3) if i != axis]
        p[:, a], p[:, b] = u, v
        m = np.zeros_like(p)
        m[:, axis] = 1.0
        pts.append(p)
        nrm.append(m)
    pts, nrm = np.vstack(pts), np.vstack(nrm)
    return pts + 0.002 * rng.standard_normal(pts.shape), nrm + 0.005 * rng.standard_normal(
        pts.shape
    )


def test_a_box_corner_maps_to_three_planes_and_three_right_angle_ridges():
    pts, nrm = _box_corner()
    found = map_contacts(pts, nrm)
    assert [r.shape for r in found.regions] == ["plane"] * 3
    faces = [set(np.argmax(np.abs(nrm[r.contacts]), axis=1)) for r in found.regions]
    assert all(len(f) == 1 for f in faces)  # each region one face
    assert len(found.edges) == 3
    for e in found.edges:
        lo, hi = e.dihedral_interval
        assert e.kind == "ridge" and lo <= 90.0 <= hi
        axis = int(np.argmax(np.abs(e.direction)))
        others = [i for i in range(3) if i != axis]
        assert np.allclose(np.array(e.point)[others], 1.0, atol=0.02)  # on the cube's edge
        off = np.degrees(np.arccos(min(1.0, float(np.max(np.abs(e.direction))))))
        assert off <= e.direction_err_deg < 1.0  # the crease's direction within its 95 %
    assert found.adjacency == {0: [1, 2], 1: [0, 2], 2: [0, 1]}


def test_a_plane_beside_a_cylinder_is_two_regions_with_a_curvature_jump():
    x, y = np.meshgrid(np.linspace(-1.5, 0, 10), np.linspace(0, 1.5, 10))
    flat = np.column_stack([x.ravel(), y.ravel(), np.zeros(x.size)])
    phi, y2 = np.meshgrid(np.linspace(0.15, 1.2, 10), np.linspace(0, 1.5, 10))
    R = 1.0
    curved = np.column_stack([R * np.sin(phi.ravel()), y2.ravel(), R * (np.cos(phi.ravel()) - 1)])
    pts = np.vstack([flat, curved])
    nrm = np.vstack([np.tile([0.0, 0.0, 1.0], (100, 1)), (curved - [0, 0, -R]) * [1, 0, 1] / R])
    found = map_contacts(pts, nrm)
    shapes = sorted(r.shape for r in found.regions)
    assert shapes == ["cylinder", "plane"]
    cyl = next(r for r in found.regions if r.shape == "cylinder")
    assert cyl.k1_interval[0] <= 1.0 / R <= cyl.k1_interval[1]
    assert [e.kind for e in found.edges] == ["curvature jump"]


def test_cli_map_json_and_csv_name_their_units(tmp_path, cli):
    pts, nrm = _box_corner()
    path = tmp_path / "corner.csv"
    rows = "\n".join(",".join(f"{v:.6f}" for v in (*p, *n)) for p, n in zip(pts, nrm))
    path.write_text("# units: cm\nx,y,z,nx,ny,nz\n" + rows + "\n", encoding="utf-8")
    code, out, err = cli("ep2", "map", path, "--json", "--units", "mm")
    assert code == 0, err
    rec = json.loads(out)
    assert rec["units"] == {"length": "mm", "curvature": "1/mm", "angle": "deg"}
    assert len(rec["regions"]) == 3 and len(rec["edges"]) == 3
    assert {"shape", "S", "k1", "k2", "S_interval", "k1_interval", "contacts"} <= set(
        rec["regions"][0]
    )
    e = rec["edges"][0]
    assert max(e["point"]) > 9.0  # cm shown in mm
    assert e["dihedral_interval"][0] <= 90 <= e["dihedral_interval"][1]
    assert 0.0 < e["direction_err_deg"] < 1.0  # a crease's direction's half-angle (deg)
    code, out, err = cli("ep2", "map", path, "--csv")
    head, *_ = out.splitlines()
    assert code == 0 and head.startswith("region,n_points,shape,S") and "k1 (1/cm)" in head
    assert "# edges" in out and "dihedral (deg)" in out


def test_cli_map_refuses_bad_options_in_one_line(tmp_path, cli):
    pts, nrm = _box_corner()
    path = tmp_path / "c.csv"
    rows = "\n".join(",".join(f"{v:.6f}" for v in (*p, *n)) for p, n in zip(pts, nrm))
    path.write_text("x,y,z,nx,ny,nz\n" + rows + "\n", encoding="utf-8")
    code, out, err = cli("ep2", "map", path, "--neighbours", "2")
    assert code == 2 and "--neighbours" in err and len(err.strip().splitlines()) == 1


def test_the_four_map_objects_get_their_regions_and_labels():
    """A box corner, a capped cylinder, a rounded cube edge and a saddle (bench/ep2_map.py
    runs the noisy trials and the edges' placement)."""
    for name in map_objects.NAMES:
        d = map_objects.make(name)
        found = map_contacts(d["points"], d["normals"])
        assert sorted(r.shape for r in found.regions) == sorted(r["shape"] for r in d["regions"])
        assert sorted(e.kind for e in found.edges) == sorted(e["kind"] for e in d["edges"])


def test_sim_writes_a_map_object_that_ep2_map_reads(tmp_path, cli):
    assert [n.replace("saddle_map", "saddle") for n in MAP_OBJECTS] == list(map_objects.NAMES)
    path = tmp_path / "corner.csv"
    code, out, err = cli("sim", "ep2", "--object", "box_corner", "--noise-pos", "0.005", "-o", path)
    assert code == 0, err
    code, out, err = cli("ep2", "map", path, "--json")
    rec = json.loads(out)
    assert code == 0 and [r["shape"] for r in rec["regions"]] == ["plane"] * 3
    assert rec["units"]["length"] == "cm" and len(rec["edges"]) == 3


def test_a_curvature_jump_is_placed_within_the_contacts_spacing():
    """The capped cylinder's contacts are 4 mm apart across the jump: the crossing links'
    midpoints alone put it 2 mm off; the hinge in the normals' turn puts it on the line."""
    for name, seed in (("capped_cylinder", 11), ("rounded_edge", 12)):
        d = map_objects.make(name, 0.005, 0.005, seed=seed)
        found = map_contacts(d["points"], d["normals"], noise_pos=0.005, noise_normal=0.005)
        jumps = [e for e in found.edges if e.kind == "curvature jump"]
        for truth in d["edges"]:
            off = [np.asarray(e.point) - truth["point"] for e in jumps]
            dist = [np.linalg.norm(o - (o @ truth["direction"]) * truth["direction"]) for o in off]
            assert min(dist) < 0.12  # cm


def test_a_cap_half_of_whose_local_fits_are_uncertain_is_still_a_sphere():
    """Seed 4: 37 of the cap's 71 neighbourhoods are `uncertain`, nearly all with `sphere`
    their top vote, and no confident fit says otherwise: the cap is a sphere."""
    d = map_objects.make("capped_cylinder", 0.005, 0.005, seed=4)
    found = map_contacts(d["points"], d["normals"], noise_pos=0.005, noise_normal=0.005)
    assert sorted(r.shape for r in found.regions) == ["cylinder", "sphere"]
    cap = next(r for r in found.regions if r.shape == "sphere")
    assert cap.S > 0.9 and cap.S_interval[0] > 0.75  # the sphere band


def test_a_region_whose_confident_local_labels_disagree_stays_uncertain():
    fits = [Fit(shape="cylinder", votes={})] * 6 + [Fit(shape="sphere", votes={})] * 4
    assert region_map._label(fits, 0.7) == "uncertain"
    unsure = Fit(shape="uncertain", votes={"sphere": 0.9, "cylinder": 0.1})
    assert region_map._label([Fit(shape="sphere", votes={})] * 3 + [unsure] * 5, 0.95) == "sphere"
    assert region_map._label([Fit(shape="sphere", votes={})] * 3 + [unsure] * 5, 0.6) == "uncertain"


def test_a_jump_direction_is_the_line_through_its_sections_hinges_and_holds_its_interval():
    """Seed 17: the crossing links' midpoints run 6.2 deg off the cap's rim; the line through
    the hinge points of sections across it runs along it, within its stated half-angle."""
    d = map_objects.make("capped_cylinder", 0.005, 0.005, seed=17)
    found = map_contacts(d["points"], d["normals"], noise_pos=0.005, noise_normal=0.005)
    (jump,) = [e for e in found.edges if e.kind == "curvature jump"]
    truth = d["edges"][0]["direction"]
    angle = np.degrees(np.arccos(min(1.0, abs(float(np.dot(jump.direction, truth))))))
    assert angle < 5.0 and angle <= jump.direction_err_deg < 5.0


def test_a_strip_along_a_join_held_by_stray_local_labels_joins_a_neighbour():
    """Seed 18 at noise 0.01: two neighbourhoods at the cap's rim come out `plane` and their
    eight `uncertain` neighbours settle to it: a 10-contact strip, not a third region."""
    d = map_objects.make("capped_cylinder", 0.01, 0.01, seed=18)
    found = map_contacts(d["points"], d["normals"], noise_pos=0.01, noise_normal=0.01)
    assert sorted(r.shape for r in found.regions) == ["cylinder", "sphere"]
    assert [e.kind for e in found.edges] == ["curvature jump"]


def test_each_regions_s_interval_holds_its_truth():
    """A region's interval is its local values' spread widened to a typical part's own 95 %
    interval: on a sphere every local S sits just under 1 (noise lowers |S|), so the
    spread alone held the cap's S = 1 in 60 of 90 regions over 30 seeds."""
    truth = {"cylinder": 0.5, "sphere": 1.0}
    for seed in range(3):
        d = map_objects.make("capped_cylinder", 0.005, 0.005, seed=seed)
        found = map_contacts(d["points"], d["normals"], noise_pos=0.005, noise_normal=0.005)
        for r in found.regions:
            lo, hi = r.S_interval
            assert lo <= truth[r.shape] <= hi and hi - lo < 0.3, (seed, r.shape, r.S_interval)
