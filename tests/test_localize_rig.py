"""The ch. 5 rig forward model against the localiser: schedule -> wrench -> contacts, and the
EP1 fingertip through the F/T path."""

import numpy as np
import pytest

from tactile.files.tabular import read_csv
from tactile.localize import STATUS, format_contacts, scara_contacts, sphere_contact
from tactile_sim.ep1.probes import measure, sphere_plus_probes
from tactile_sim.rig.contact import contact_wrench, wheel_touch
from tactile_sim.rig.fingertip import fingertip_point, fingertip_uv, fingertip_wrench
from tactile_sim.rig.geometry import FREDDY, fk, ik
from tactile_sim.rig.objects import CH5_OBJECTS, Sphere, VerticalCylinder, ch5_object
from tactile_sim.rig.schedule import probe_schedule
from tactile_sim.rig.sensor import GATE_N, OZF, SIGMA_F
from tactile_studies.ep1.ft_measure import measure_ft

LENGTHS = (FREDDY.L1, FREDDY.L2, FREDDY.L3, FREDDY.L4)


def _localise(r, method):
    return scara_contacts(
        r["force"],
        r["moment"],
        r["q"],
        LENGTHS,
        GATE_N,
        method,
        FREDDY.half_thickness,
        FREDDY.arc_limit,
    )


def test_units_of_the_thesis_sensor():
    assert np.isclose(OZF, 0.45359237 * 9.80665 / 16)
    np.testing.assert_allclose(SIGMA_F, [0.0556, 0.0556, 0.1112], atol=1e-4)
    assert np.isclose(GATE_N, 1.390, atol=1e-3)


@pytest.mark.parametrize("kind", CH5_OBJECTS)
@pytest.mark.parametrize("method", ["force", "moment"])
def test_noiseless_schedule_round_trip(kind, method):
    r = probe_schedule(ch5_object(kind), sigma_f=0, sigma_m=0)
    assert len(r["q"]) == 36 and r["recorded"].all()  # 3 passes x 6 points x 2 samples
    c, theta = _localise(r, method)
    assert np.all(c.status == 0)
    assert np.abs(c.point - r["point"]).max() < 1e-12
    assert np.abs(c.normal - r["normal"]).max() < 1e-12
    np.testing.assert_allclose(theta, r["theta"], atol=1e-10)
    # passes at three heights, normals horizontal (vertical axes, §5.1.1)
    np.testing.assert_allclose(np.unique(c.point[:, 2].round(9)), [0.10, 0.12, 0.14])
    assert np.abs(c.normal[:, 2]).max() == 0.0


def test_normals_point_toward_the_probe_and_curvature_has_the_right_sign():
    for kind, sign in (("convex", 1), ("concave", -1)):
        r = probe_schedule(ch5_object(kind), sigma_f=0, sigma_m=0)
        c, _ = _localise(r, "force")
        # the wheel centre is on the +normal side of every contact
        R_, t_ = fk(FREDDY, r["q"][0])
        row = c.point[:6:2]
        nrm = c.normal[:6:2]
        # normals of a convex surface diverge along the sweep, a concave one's converge
        dy = np.diff(row[:, 1])
        dny = np.diff(nrm[:, 1])
        assert np.all(np.sign(dny / dy) == sign)
        centre_w = R_ @ FREDDY.centre + t_
        assert (centre_w - c.point[0]) @ c.normal[0] > 0


def test_friction_biases_the_thesis_method_and_not_the_moment_method():
    r = probe_schedule(ch5_object("convex"), sigma_f=0, sigma_m=0, mu=0.3)
    f, _ = _localise(r, "force")
    m, _ = _localise(r, "moment")
    assert np.abs(m.point - r["point"]).max() < 1e-12
    err = np.linalg.norm(f.point - r["point"], axis=1)
    assert err.max() > 1e-3  # up to L4 * atan(0.3) = 4.4 mm on the outer points
    assert err.max() <= FREDDY.L4 * np.arctan(0.3) + 1e-12
    np.testing.assert_allclose(np.tan(m.friction).max(), 0.3, rtol=1e-9)


def test_noise_at_the_thesis_accuracy_gives_sub_millimetre_points():
    errs = {"force": [], "moment": []}
    nerr = {"force": [], "moment": []}
    for seed in range(20):
        r = probe_schedule(ch5_object("convex"), seed=seed)
        for method in errs:
            c, _ = _localise(r, method)
            ok = c.usable & r["recorded"]
            errs[method].append(np.linalg.norm(c.point - r["point"], axis=1)[ok])
            cosang = np.clip(np.einsum("ij,ij->i", c.normal, r["normal"])[ok], -1, 1)
            nerr[method].append(np.degrees(np.arccos(cosang)))
    f, m = np.concatenate(errs["force"]), np.concatenate(errs["moment"])
    nf = np.concatenate(nerr["force"])
    # force only: normal error ~ sigma_f / |F| = 0.0556 / 1.81 rad (1.8 deg) -> L4 * that
    assert 1.0 < np.sqrt(np.mean(nf**2)) < 2.6
    assert np.sqrt(np.mean(f**2)) < 0.0007
    # the moment route works but is several times noisier at 1/40 lbf.in torque resolution
    assert np.median(m) > 2 * np.median(f)
    assert len(f) > 0.9 * 20 * 36


def test_unreachable_points_are_not_recorded():
    far = VerticalCylinder((1.4, 0.0), 0.066)  # the face is out of the arm's reach
    r = probe_schedule(far, sigma_f=0, sigma_m=0, wrist="normal")
    assert not r["recorded"].any()
    c, _ = _localise(r, "force")
    assert np.all(c.status == 1) and STATUS[1] == "no_contact"


def test_wheel_touch_matches_the_closed_form_for_a_cylinder():
    obj = VerticalCylinder((0.616, 0.01), 0.066)
    q = ik(FREDDY, np.array([0.54, 0.03, 0.1]), 0.2)
    R, t = fk(FREDDY, q)
    p, n, depth, th = wheel_touch(obj, R, t, FREDDY.centre, FREDDY.L4, FREDDY.arc_limit)
    centre = (R @ FREDDY.centre + t)[:2]
    gap = np.hypot(*(centre - obj.axis_xy)) - obj.radius - FREDDY.L4
    assert np.isclose(depth, -gap, atol=1e-15)
    u = (np.asarray(obj.axis_xy) - centre) / np.hypot(*(np.asarray(obj.axis_xy) - centre))
    np.testing.assert_allclose(p[:2], centre + FREDDY.L4 * u, atol=1e-15)
    np.testing.assert_allclose(n[:2], -u, atol=1e-15)


def test_other_shapes_plug_in_through_signed_distance():
    ball = Sphere((0.62, 0.0, 0.12), 0.05)
    r = probe_schedule(ball, sigma_f=0, sigma_m=0, wrist="normal", length=0.04)
    assert r["recorded"].all()
    F = r["force"]
    assert np.abs(F[:, 2]).max() > 0.1  # off-equator passes push up/down: normals tilt
    c, _ = _localise(r, "moment")
    # the thin rim touches at its mid-plane: the moment recovers the point in 3-D, ...
    assert np.all(c.usable) and np.abs(c.point - r["point"]).max() < 1e-9
    # ... but the wheel's normal is horizontal, only the x-y part of the true one (§5.1.1)
    nxy = r["normal"][:, :2] / np.linalg.norm(r["normal"][:, :2], axis=1, keepdims=True)
    np.testing.assert_allclose(c.normal[:, :2], nxy, atol=1e-9)


def test_contacts_csv_feeds_the_ep2_contract(tmp_path):
    r = probe_schedule(ch5_object("concave"), seed=3)
    c, _ = _localise(r, "force")
    path = tmp_path / "contacts.csv"
    path.write_text(
        format_contacts(c.point, c.normal, finger=r["finger"], unit="cm", mask=c.usable)
    )
    assert path.read_text().startswith("# units: cm\n")
    table = read_csv(path, ("x", "y", "z", "nx", "ny", "nz"), optional_float=("finger",))
    assert len(table) == int(c.usable.sum())
    xyz = table.array("x", "y", "z")
    np.testing.assert_allclose(xyz, 100.0 * c.point[c.usable], rtol=1e-15)
    assert set(table.columns["finger"]) == {0.0, 1.0, 2.0}


def test_contact_wrench_moment_is_about_the_given_origin():
    p = np.array([0.1, 0.02, 0.0])
    F, M = contact_wrench(p, [-1.0, 0.0, 0.0], 2.0, origin=(0.05, 0.0, 0.0))
    np.testing.assert_allclose(F, [-2.0, 0.0, 0.0])
    np.testing.assert_allclose(M, np.cross(p - [0.05, 0, 0], F))


def test_fingertip_map_and_its_inverse():
    rng = np.random.default_rng(0)
    uv = rng.uniform(-1.5, 1.5, (1000, 2))
    np.testing.assert_allclose(fingertip_uv(fingertip_point(uv[:, 0], uv[:, 1], 0.02), 0.02), uv)


def test_fingertip_wrench_localises_back_to_the_contact_with_friction():
    rng = np.random.default_rng(1)
    u, v = rng.uniform(-1.2, 1.2, (2, 500))
    F, M = fingertip_wrench(u, v, 0.01, 1.5, 0.05, mu=0.4, phi=rng.uniform(0, 6.3, 500))
    c = sphere_contact(F, M, (0.05, 0, 0), 0.01, axis=(1, 0, 0))
    assert np.all(c.status == 0)
    np.testing.assert_allclose(fingertip_uv(c.point - [0.05, 0, 0], 0.01), np.c_[u, v], atol=1e-10)


def test_measure_ft_without_noise_equals_the_ep1_measurement_model():
    R1 = 0.01
    probes = sphere_plus_probes(R1, 0.02, np.pi / 4)
    exact = measure(probes, R1)
    for method in ("moment", "force"):
        rows, ok = measure_ft(probes, R1, sigma_f=0, sigma_m=0, method=method)
        assert ok.all()
        np.testing.assert_allclose(rows, exact, atol=1e-12)


def test_measure_ft_with_noise_reports_usable_rows_only():
    R1 = 0.02
    probes = sphere_plus_probes(R1, 0.04, np.pi / 3)
    rows, ok = measure_ft(probes, R1, normal_force=5.0, rng=np.random.default_rng(2), mu=0.2)
    assert rows.shape == (8, 4) and np.all(np.isfinite(rows))
    assert np.all(rows[~ok] == 0.0)
    assert np.abs(rows[ok, 2:] - measure(probes, R1)[ok, 2:]).max() < 1.0


def test_timeline_onsets_and_loads_follow_the_geometry():
    from tactile_sim.rig.timeline import timeline

    r = probe_schedule(ch5_object("convex"), sigma_f=0, sigma_m=0)
    tl = timeline(r, rate=1000.0, gap=0.002, speed=0.01)
    f = np.linalg.norm(tl["force"], axis=1)
    touching = f > 0.0
    starts = tl["t"][np.flatnonzero(np.diff(touching.astype(int)) == 1) + 1]
    ends = tl["t"][np.flatnonzero(np.diff(touching.astype(int)) == -1) + 1]
    assert len(starts) == len(tl["onset"]) == 36
    # first loaded sample within one sample period after the geometric onset/release
    assert np.all((starts - tl["onset"] > 0) & (starts - tl["onset"] <= 1e-3 + 1e-12))
    assert np.all((ends - tl["release"] > 0) & (ends - tl["release"] <= 1e-3 + 1e-12))
    # the peak load of each touch is the scheduled wrench
    for i in (0, 17, 35):
        sel = tl["touch"] == i
        k = np.argmax(f[sel])
        np.testing.assert_allclose(tl["force"][sel][k], r["force"][i], rtol=1e-12)
        np.testing.assert_allclose(tl["moment"][sel][k], r["moment"][i], rtol=1e-12)
