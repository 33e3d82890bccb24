"""EP1 studies on reduced grids: shapes, trends the thesis reports, and the dtheta choice."""

import numpy as np
import pytest

from tactile_studies.ep1 import studies as st


def test_noise_study_trends():
    rows = st.study_noise(
        trials=40, grid={"radii": (100, 1, 0.01), "dthetas": (0.01, 0.25), "noises": (0.0, 0.001)}
    )
    err = {(r["radius"], r["dtheta"], r["noise"]): r["mean_rel_error"] for r in rows}
    assert len(rows) == 3 * 2 * 2
    assert all(err[(R, d, 0.0)] < 1e-9 for R in (100, 1, 0.01) for d in (0.01, 0.25))
    assert err[(100, 0.25, 0.001)] > err[(1, 0.25, 0.001)] > err[(0.01, 0.25, 0.001)] * 0.5
    assert err[(1, 0.01, 0.001)] > err[(1, 0.25, 0.001)]  # larger dtheta, less sensitive


def test_paraboloid_study_uses_derived_truth_and_reports_table4():
    grid = {"Cs": (1.0,), "dthetas": (0.01, 0.25), "noises": (0.0,), "at": (1.0, 0.1)}
    rows = st.study_paraboloid(trials=2, grid=grid)
    assert rows[0]["radius_u"] == pytest.approx(5.6125, abs=1e-4)
    assert rows[0]["radius_u_thesis_table4"] == pytest.approx(5.7009, abs=1e-4)
    errs = [r["mean_rel_error_u"] for r in rows]
    assert errs[0] < errs[1] < 0.02  # model error grows with the arc length, but stays small


def test_resolution_study_reproduces_section_333_claim():
    grid = {"radii": (50, 5, 1, 0.2, 0.05), "resolutions": (0.05,), "dthetas": (np.pi / 2,)}
    rows = st.study_resolution(trials=50, grid=grid, sensors=("bias",))
    radii = np.array([r["radius"] for r in rows])
    err = np.array([r["mean_rel_error"] for r in rows])
    assert st.widest_range(radii[::-1], err[::-1]) == (0.2, 5.0)


def test_arclength_closed_form_and_ode_agree():
    rows = st.study_arclength(n=5)
    ode = [r for r in rows if r.get("source") == "ode"]
    for r in ode:
        assert r["ds"] == pytest.approx(np.pi / 2 * r["rcr"] / (1 + r["rcr"]), rel=1e-9)


def test_widest_range():
    radii = np.array([0.1, 1, 10, 100, 1000])
    assert st.widest_range(radii, [0.3, 0.1, 0.2, 0.5, 0.1]) == (1.0, 10.0)
    assert st.widest_range(radii, [0.3, 0.3, 0.3, 0.3, 0.3]) is None


def test_dtheta_choice_is_at_least_as_wide_as_fixed_half_radian():
    rows, summary = st.study_optimal_dtheta(
        sensor="gauss",
        radii=np.logspace(-2, 2, 9),
        dthetas=np.array([0.25, 0.5, 1.0, 1.5]),
        trials=60,
    )
    assert len(rows) == 9
    ad, fixed = summary["adaptive"], summary["0.5"]
    assert ad is not None and fixed is not None
    assert ad[1] / ad[0] >= fixed[1] / fixed[0]


def test_write_csv_never_writes_nan(tmp_path):
    path = tmp_path / "x.csv"
    st.write_csv(path, [{"a": 1.0, "b": float("nan")}, {"a": float("inf"), "c": "s"}])
    text = path.read_text()
    assert "nan" not in text and "inf" not in text
    assert text.splitlines()[:2] == ["# units: " + st.UNITS, "a,b,c"]
