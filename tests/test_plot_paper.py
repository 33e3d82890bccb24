"""``tactile plot`` figures as a paper's reviewer reads them (issue 15): units on every axis,
legends outside the data, tick labels that do not overprint on rig data (a sweep seen
edge-on), passes named as passes, equal scales, and the thesis's figure numbers."""

import json

import numpy as np
import pytest
from figure_checks import caught, overprinted, paper_problems, titles, unit_problems

from tactile.ep2 import analyze_patch
from tactile.output import plots

pytestmark = pytest.mark.filterwarnings("error::RuntimeWarning")


def rig_cylinder(radius=6.6, axis_x=62.4):
    """The ch. 5 rig's view of a convex cylinder (axis vertical at x = 62.4 cm): 3 passes
    at heights 10, 12, 14 cm, 6 stops across y, 2 readings per stop; normals toward the
    probe (-x).  World x spans only ~0.7 cm: the 3-D box is seen nearly edge-on."""
    rng = np.random.default_rng(3)
    y = np.repeat(np.linspace(-3.0, 3.0, 6), 2) + rng.normal(0, 0.01, 12)
    rows, normals, passes = [], [], []
    for k, z in enumerate((10.0, 12.0, 14.0)):
        x = axis_x - np.sqrt(radius**2 - y**2)
        rows.append(np.column_stack([x, y, np.full_like(y, z)]))
        normals.append(np.column_stack([x - axis_x, y, np.zeros_like(y)]) / radius)
        passes += [str(k)] * len(y)
    return np.vstack(rows), np.vstack(normals), passes


@pytest.fixture
def figures(mocker):
    return caught(mocker)


def test_rig_contacts_have_units_legend_outside_and_no_overprinted_ticks(tmp_path, figures):
    pts, nrm, passes = rig_cylinder()
    plots.plot_contacts(pts, nrm, tmp_path / "c.png", finger=passes, unit="cm", group="pass")
    (fig,) = figures()
    assert paper_problems(fig) == []
    ax = fig.axes[0]
    assert [ax.get_xlabel(), ax.get_ylabel(), ax.get_zlabel()] == ["x (cm)", "y (cm)", "z (cm)"]
    assert [t.get_text() for t in ax.get_legend().get_texts()] == ["pass 0", "pass 1", "pass 2"]
    assert "thesis figs. 39 ii, 42 ii, 46 ii" in titles(fig)
    # equal scales: the box's sides are in proportion to the ranges drawn
    ranges = np.array([np.ptp(lim) for lim in (ax.get_xlim(), ax.get_ylim(), ax.get_zlim())])
    box = np.asarray(ax.get_box_aspect())
    np.testing.assert_allclose(box / box.max(), ranges / ranges.max(), rtol=1e-9)


def test_the_overprint_check_catches_matplotlibs_default_ticks_on_rig_data(tmp_path, figures):
    """The check above can fail: with matplotlib's own locators (as before issue 15) the
    edge-on x axis of the rig's contacts prints its labels over one another."""
    import matplotlib.pyplot as plt

    pts, nrm, _ = rig_cylinder()
    fig = plt.figure(figsize=(5.5, 5.0))
    ax = fig.add_subplot(projection="3d")
    ax.scatter(*pts.T)
    lo, hi = pts.min(axis=0), pts.max(axis=0)
    ax.set(xlim=(lo[0], hi[0]), ylim=(lo[1], hi[1]), zlim=(lo[2], hi[2]))
    ax.set_box_aspect(tuple(hi - lo))
    assert any(axis == "x" for axis, _, _ in overprinted(fig))
    plt.close(fig)


def test_patch_and_maps_name_their_unit_and_thesis_figure(tmp_path, figures):
    pts, nrm, passes = rig_cylinder()
    res = analyze_patch(pts, nrm, method="spline", maps=True)
    assert res.shape == "cylinder"
    plots.plot_patch(res, pts, nrm, tmp_path / "p.png", finger=passes, unit="cm", group="pass")
    plots.plot_maps(res, tmp_path / "m.png", points=pts, unit="cm")
    patch, maps = figures()
    for fig in (patch, maps):
        assert paper_problems(fig) == []
    assert "fig. 43" in titles(patch) and f"radius {res.radius:.3g} cm" in titles(patch)
    ax = patch.axes[0]  # one length unit on all three axes: the box is in their proportion
    ranges = np.array([np.ptp(lim) for lim in (ax.get_xlim(), ax.get_ylim(), ax.get_zlim())])
    box = np.asarray(ax.get_box_aspect())
    np.testing.assert_allclose(box / box.max(), ranges / ranges.max(), rtol=1e-9)
    assert len({ax.get_xlabel()[-4:], ax.get_ylabel()[-4:], ax.get_zlabel()[-4:]}) == 1  # (cm)
    labels = [t.get_text() for t in patch.axes[0].get_legend().get_texts()]
    assert labels == ["control mesh", "pass 0", "pass 1", "pass 2"]
    assert "fig. 50" in titles(maps)
    for fig in (patch, maps):  # plain titles: the label and the fit, not the model's notes
        assert "cylinder, S " in titles(fig) and "(biquadratic B-spline)" in titles(fig)
        assert "segment(s)" not in titles(fig) and "weights" not in titles(fig)
    jet = analyze_patch(pts, nrm, maps=True)
    plots.plot_patch(jet, pts, nrm, tmp_path / "j.png", unit="cm")
    assert "(local jet)" in titles(figures()[-1]) and "2-jet" not in titles(figures()[-1])
    data = [ax for ax in maps.axes if ax.get_label() != "<colorbar>"]
    assert [ax.get_aspect() for ax in data] == [1.0, 1.0]  # geometry to equal scale
    bars = [ax.get_ylabel() for ax in maps.axes if ax.get_label() == "<colorbar>"]
    assert bars == ["shape index S (dimensionless)", "curvedness C = (2/\u03c0) ln R (R in 1/cm)"]


def test_without_a_unit_the_labels_say_input_unit(tmp_path, figures):
    pts, nrm, _ = rig_cylinder()
    plots.plot_contacts(pts * 1e-6, nrm, tmp_path / "c.png")
    (fig,) = figures()
    assert unit_problems(fig) == []
    assert fig.axes[0].get_xlabel() == "x (1e-6 input unit)"  # drawn in a power-of-ten unit


def write_run(run, pts, nrm, passes, sensors, header=""):
    run.mkdir()
    lines = [f"{header}x,y,z,nx,ny,nz,finger"]
    lines += [
        ",".join(f"{v!r}" for v in (*p.tolist(), *n.tolist())) + f",{f}"
        for p, n, f in zip(pts, nrm, passes)
    ]
    (run / "contacts.csv").write_text("\n".join(lines) + "\n")
    (run / "meta.json").write_text(json.dumps({"device": {"n_sensors": sensors}}))


@pytest.mark.parametrize(
    ("sensors", "header", "option", "word", "unit"),
    [
        (1, "# units: cm\n", [], "pass", "cm"),  # the rig: one sensor, passes
        (1, "# units: cm\n", ["--units", "mm"], "pass", "mm"),  # the option wins
        (3, "", [], "finger", "input unit"),  # three sensors: fingers; no unit said
    ],
)
def test_cli_names_passes_and_units_from_the_recording(
    tmp_path, cli, figures, sensors, header, option, word, unit
):
    pts, nrm, passes = rig_cylinder()
    write_run(tmp_path / "run", pts, nrm, passes, sensors, header)
    code, stdout, stderr = cli("plot", tmp_path / "run", "--what", "contacts", *option)
    assert (code, stderr) == (0, "")
    assert stdout.split() == [str(tmp_path / "run" / "run_contacts.png")]
    (fig,) = figures()
    ax = fig.axes[0]
    assert [t.get_text() for t in ax.get_legend().get_texts()] == [f"{word} {k}" for k in "012"]
    assert ax.get_xlabel() == f"x ({unit})"
    assert paper_problems(fig) == []


def _mesh_limits(fig):
    """(vmin, vmax) of each map panel's colour scale, S then C."""
    data = [ax for ax in fig.axes if ax.get_label() != "<colorbar>"]
    return [ax.collections[0].get_clim() for ax in data]


def test_a_constant_field_is_drawn_constant_and_a_varying_one_over_its_range(tmp_path, figures):
    """Round-off in C (1.5184..1.5197: 0.09 % of the value) must not fill the colour bar;
    a field that varies (the noisy rig cylinder's C) keeps its own range."""
    import dataclasses

    pts, nrm, _ = rig_cylinder()
    res = analyze_patch(pts, nrm, maps=True)
    n = res.maps["C"].size
    flat = dict(res.maps, C=np.linspace(1.5184, 1.5197, n), S=np.full(n, 0.5))
    plots.plot_maps(dataclasses.replace(res, maps=flat), tmp_path / "flat.png", unit="cm")
    plots.plot_maps(res, tmp_path / "rig.png", unit="cm")
    flat_fig, rig_fig = figures()
    assert paper_problems(flat_fig) == []
    (s_lo, s_hi), (c_lo, c_hi) = _mesh_limits(flat_fig)
    assert (s_lo, s_hi) == (-1.0, 1.0)  # S always on [-1, 1]
    assert c_hi - c_lo >= plots.MIN_SPAN * 1.519 * (1 - 1e-12)  # at least the minimum span
    assert (c_lo + c_hi) / 2 == pytest.approx((1.5184 + 1.5197) / 2)  # about the values
    # the values fill under 90 % of the bar: a reader sees a near-constant field
    assert (1.5197 - 1.5184) / (c_hi - c_lo) < 0.9
    c = res.maps["C"]
    assert np.ptp(c) > plots.MIN_SPAN * abs(c.mean())  # this one varies ...
    assert _mesh_limits(rig_fig)[1] == pytest.approx((c.min(), c.max()))  # ... over its range


@pytest.mark.parametrize("value", [0.0, -1.5, 1e-9, 42.0])
def test_colour_limits_of_an_exactly_constant_field_have_a_span(value):
    lo, hi = plots.colour_limits(np.full(16, value))
    assert lo < value < hi and hi - lo == pytest.approx(plots.MIN_SPAN * max(abs(value), 1.0))
    assert plots.colour_limits(np.array([np.nan, value, np.nan])) == (lo, hi)  # NaN ignored
