"""The studies' and benches' figures as a paper's reviewer reads them (issue 15): each names
its thesis figure, has units on every axis and its legend off the data; fig. 18 runs along
its x variable; figs. 30, 33 and 34 draw the STD of S as bars; the commands print exactly
the files they wrote."""

import functools
import os

import numpy as np
import pytest
from conftest import load_bench
from figure_checks import caught, paper_problems, titles

from tactile_studies.ep1 import plots as ep1_plots
from tactile_studies.ep1 import studies as ep1
from tactile_studies.ep2 import plots as ep2_plots
from tactile_studies.ep2 import studies as ep2

pytestmark = pytest.mark.filterwarnings("error::RuntimeWarning")

SMALL_NOISE = {"radii": (1000, 1, 0.001), "dthetas": (0.01, 0.25), "noises": (0.0, 0.001)}
SMALL_PARABOLOID = {
    "Cs": (8, 1, 0.1, 0.01),  # radius along u 259, 5.61, 5.30, 50: not monotonic in C
    "dthetas": (0.05, 0.25),
    "noises": (0.0, 0.001),
    "at": (1.0, 0.1),
}
SMALL_RESOLUTION = {"radii": (5, 1, 0.2), "resolutions": (0, 0.05), "dthetas": (0.5, np.pi / 2)}


@pytest.fixture
def figures(mocker):
    return caught(mocker)


def only_files(directory):
    return sorted(os.path.join(directory, f) for f in os.listdir(directory))


@pytest.mark.parametrize(
    ("plot", "study", "number"),
    [
        (ep1_plots.plot_noise, lambda: ep1.study_noise(trials=2, grid=SMALL_NOISE), "16"),
        (
            ep1_plots.plot_paraboloid,
            lambda: ep1.study_paraboloid(trials=2, grid=SMALL_PARABOLOID),
            "18",
        ),
        (ep1_plots.plot_arclength, lambda: ep1.study_arclength(n=9), "21"),
    ],
)
def test_ep1_figures_are_paper_ready(tmp_path, figures, plot, study, number):
    paths = plot(study(), str(tmp_path / "f.png"))
    assert paths == only_files(tmp_path) == [str(tmp_path / "f.png")]
    (fig,) = figures()
    assert paper_problems(fig) == []
    assert f"Thesis fig. {number}:" in titles(fig)


def test_fig18_lines_run_along_c_with_the_radius_named_on_top(tmp_path, figures):
    rows = ep1.study_paraboloid(trials=2, grid=SMALL_PARABOLOID)
    ep1_plots.plot_paraboloid(rows, str(tmp_path / "f.png"))
    (fig,) = figures()
    cs = sorted(SMALL_PARABOLOID["Cs"])
    radius = {r["C"]: r["radius_u"] for r in rows}
    assert sorted(radius.values()) != [radius[c] for c in cs]  # the radius would zig-zag
    for ax, dth in zip(fig.axes, SMALL_PARABOLOID["dthetas"], strict=True):
        lines = ax.get_lines()
        assert len(lines) == len(SMALL_PARABOLOID["noises"])
        for line, noise in zip(lines, SMALL_PARABOLOID["noises"], strict=True):
            np.testing.assert_array_equal(line.get_xdata(), cs)  # sorted by the x variable
            want = [
                next(
                    r["mean_rel_error_u"]
                    for r in rows
                    if (r["C"], r["dtheta"], r["noise"]) == (c, dth, noise)
                )
                for c in cs
            ]
            np.testing.assert_allclose(line.get_ydata(), 100 * np.maximum(want, 1e-14))
        (top,) = [c for c in ax.child_axes if c.get_xlabel().startswith("radius along u")]
        np.testing.assert_array_equal(top.get_xticks(), cs)
        assert [t.get_text() for t in top.get_xticklabels()] == [f"{radius[c]:.3g}" for c in cs]


def test_fig20_and_dtheta_write_and_return_every_png(tmp_path, figures):
    rows = ep1.study_resolution(trials=2, grid=SMALL_RESOLUTION, sensors=("bias", "gauss"))
    paths = ep1_plots.plot_resolution(rows, str(tmp_path / "r.png"))
    assert paths == only_files(tmp_path)
    assert [os.path.basename(p) for p in paths] == ["r_bias.png", "r_gauss.png"]
    rows, _ = ep1.study_optimal_dtheta(
        radii=np.logspace(-1, 1, 5), dthetas=np.array([0.5, 1.5]), trials=3
    )
    assert ep1_plots.plot_optimal(rows, str(tmp_path / "d.png"), setup="x") == [
        str(tmp_path / "d.png")
    ]
    for fig in figures():
        assert paper_problems(fig) == []
    assert [titles(f).count("Thesis fig. 20:") for f in figures()] == [1, 1, 0]


def test_ep1_resolution_prints_exactly_the_files_it_wrote(tmp_path, cli, monkeypatch):
    small = functools.partial(ep1.study_resolution, grid=SMALL_RESOLUTION)
    monkeypatch.setattr(ep1, "study_resolution", small)
    code, stdout, stderr = cli(
        "study", "ep1-resolution", "--out", tmp_path, "--trials", "1", "--quiet"
    )
    assert (code, stderr) == (0, "")
    assert sorted(stdout.split()) == only_files(tmp_path)
    assert len(only_files(tmp_path)) == 4  # the CSV and one PNG per sensor model


def radius_rows(kind_s):
    """Synthetic fig. 33/34 rows: S mean and STD distinct per radius, order and weighting."""
    rng = np.random.default_rng(0)
    return [
        {"radius": r, "spline_degree": d, "weighting": w, "S_mean": kind_s + rng.normal(0, 0.02),
         "S_std": rng.uniform(0.001, 0.05)}
        for r in ep2.RADII for d in (2, 3, 4) for w in ("tangent", "position", "auto")
    ]  # fmt: skip


@pytest.mark.parametrize(
    ("plot", "true_s", "number"),
    [(ep2_plots.plot_cylinder_radius, 0.5, "33"), (ep2_plots.plot_sphere_radius, 1.0, "34")],
)
def test_figs_33_and_34_draw_mean_s_with_its_std_as_bars(tmp_path, figures, plot, true_s, number):
    rows = radius_rows(true_s)
    rows[5]["S_mean"] = rows[5]["S_std"] = None  # a failed fit is left out, not drawn as 0
    assert plot(rows, str(tmp_path / "f.png")) == str(tmp_path / "f.png")
    (fig,) = figures()
    assert paper_problems(fig) == []
    assert f"Thesis fig. {number}:" in titles(fig) and "STD" in titles(fig)
    for ax, degree in zip(fig.axes, (2, 3, 4), strict=True):
        bars = ax.containers
        assert len(bars) == 3  # one errorbar series per weighting
        for bar, w in zip(bars, ("tangent", "position", "auto"), strict=True):
            sel = [
                r
                for r in rows
                if (r["spline_degree"], r["weighting"]) == (degree, w) and r["S_mean"] is not None
            ]
            mean, std = (np.array([r[k] for r in sel]) for k in ("S_mean", "S_std"))
            np.testing.assert_allclose(bar.lines[0].get_ydata(), mean)
            (segments,) = bar.lines[2]
            ends = np.array([s[:, 1] for s in segments.get_segments()])
            np.testing.assert_allclose(ends, np.column_stack([mean - std, mean + std]))
    ticks = fig.axes[-1].get_xticklabels()  # the radii as categories, shared by the panels
    assert [t.get_text() for t in ticks] == [f"{r:g}" for r in ep2.RADII]


@pytest.mark.slow
def test_ep2_study_runs_print_exactly_what_they_wrote(tmp_path, cli, figures):
    code, stdout, stderr = cli("study", "ep2-rotation", "--out", tmp_path / "rot")
    assert (code, stderr) == (0, "")
    assert stdout.split() == only_files(tmp_path / "rot")
    assert [os.path.basename(p) for p in stdout.split()] == [
        "ep2_fig32_rotation.csv",
        "ep2_fig32_rotation.png",
    ]
    code, stdout, stderr = cli("study", "ep2-tables", "--out", tmp_path / "tab", "--trials", "1")
    assert (code, stderr) == (0, "")
    printed = [line for line in stdout.splitlines() if not line.startswith("|")]
    assert printed == only_files(tmp_path / "tab")  # the PNG its help promises
    assert printed[-1].endswith("ep2_tables5_7.png")
    rotation, tables = figures()
    for fig in (rotation, tables):
        assert paper_problems(fig) == []
    assert "Thesis fig. 32:" in titles(rotation) and "Thesis tables 5-7:" in titles(tables)
    code, stdout, _ = cli("study", "ep2-tables", "--out", tmp_path / "csv", "--no-png")
    assert code == 0 and only_files(tmp_path / "csv")[0].endswith(".csv")


def test_fig30_draws_the_std_and_names_its_units(tmp_path, figures):
    rows = [
        {"radius": r, "rotation": a, "weighting": w, "spline_degree": 2 if w == "auto" else 3,
         "S_mean": 0.5 - a / 1000, "S_std": a / 2000}
        for r in (6, 10, 500) for a in ep2.ROTATIONS for w in ("tangent", "position", "auto")
    ]  # fmt: skip
    ep2_plots.plot_cylinders(rows, str(tmp_path / "f.png"))
    (fig,) = figures()
    assert paper_problems(fig) == []
    assert "Thesis fig. 30:" in titles(fig)
    bar = fig.axes[0].containers[0]
    (segments,) = bar.lines[2]
    half = np.array([np.ptp(s[:, 1]) / 2 for s in segments.get_segments()])
    np.testing.assert_allclose(half, [a / 2000 for a in ep2.ROTATIONS])


def test_bench_figures_are_paper_ready(tmp_path, figures):
    wp = load_bench("ep1_work_precision")
    results = [
        (name, m, rtol, rtol * (i + 1), 1e-3 * (i + 1) / rtol**0.1)
        for name in wp.CASES
        for i, m in enumerate(wp.METHODS)
        for rtol in wp.RTOLS
    ]
    wp.plot(results, tmp_path / "wp.png")
    (fig,) = figures()
    assert paper_problems(fig) == []
