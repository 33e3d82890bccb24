"""``tactile plot`` and ``tactile.output.plots``: valid PNGs, the plotted data are the fit's,
errors.

The drawn data are checked by independent routes: the control net against the
closed-form Bezier control points of a paraboloid and against a scipy B-spline
built from the net; the S and C maps against curvatures from finite differences
of the fitted surface on a grid rebuilt from the contacts.
"""

import struct
import subprocess
import sys

import numpy as np
import pytest
from scipy.interpolate import BSpline

from tactile.ep2 import analyze_patch

# issue 12: no numpy warning may reach a user of the CLI
pytestmark = pytest.mark.filterwarnings("error::RuntimeWarning")

PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"
XS = (-2.0, 0.0, 2.0)  # three fingers
YS = np.linspace(0.0, 4.0, 6)  # six stops each


def cylinder(radius=6.6):
    """Convex cylinder z = sqrt(R^2 - x^2) - R along y; normals toward +z (the finger)."""
    x, y = (v.ravel() for v in np.meshgrid(XS, YS, indexing="ij"))
    z = np.sqrt(radius**2 - x**2) - radius
    normals = np.column_stack([x, np.zeros_like(x), z + radius]) / radius
    return np.column_stack([x, y, z]), normals


def sphere(radius=5.0):
    x, y = (v.ravel() for v in np.meshgrid(XS, YS - 2.0, indexing="ij"))
    z = np.sqrt(radius**2 - x**2 - y**2) - radius
    normals = np.column_stack([x, y, z + radius]) / radius
    return np.column_stack([x, y, z]), normals


def write_csv(path, patches):
    """patches: {name: (points, normals)}; fingers by x column (0, 1, 2)."""
    lines = ["# test contacts", "x,y,z,nx,ny,nz,finger,patch"]
    for name, (pts, nrm) in patches.items():
        for p, n in zip(pts, nrm, strict=True):
            finger = XS.index(round(p[0], 9)) if round(p[0], 9) in XS else 0
            lines.append(",".join(f"{v:.12g}" for v in (*p, *n)) + f",{finger},{name}")
    path.write_text("\n".join(lines) + "\n")
    return path


def png_size(path):
    """(width, height) from a PNG's IHDR, after checking the signature."""
    data = path.read_bytes()
    assert data[:8] == PNG_SIGNATURE
    assert data[12:16] == b"IHDR"
    return struct.unpack(">II", data[16:24])


def assert_real_png(path):
    width, height = png_size(path)
    assert 300 <= width <= 2000 and 300 <= height <= 2000
    import matplotlib.image

    pixels = matplotlib.image.imread(path)  # decodes the whole file: not truncated
    assert pixels.shape[:2] == (height, width)
    assert pixels[..., :3].std() > 0.05  # something was drawn


@pytest.fixture
def two_patches(tmp_path):
    return write_csv(tmp_path / "scan.csv", {"cyl": cylinder(), "sph": sphere()})


@pytest.mark.slow
def test_cli_writes_one_valid_png_per_figure_and_patch(two_patches, tmp_path, cli):
    out = tmp_path / "figs"
    code, stdout, stderr = cli("plot", two_patches, "-o", out)
    assert (code, stderr) == (0, "")
    written = stdout.split()
    names = [f"scan_{p}_{w}.png" for p in ("cyl", "sph") for w in ("contacts", "patch", "maps")]
    assert [p.rsplit("/", 1)[-1] for p in written] == names
    for name in names:
        assert_real_png(out / name)


def test_record_directory_and_figure_subset(tmp_path, cli):
    run = tmp_path / "run1"
    run.mkdir()
    pts, nrm = cylinder()
    (run / "contacts.csv").write_text(
        "x,y,z,nx,ny,nz\n" + "\n".join(",".join(map(str, (*p, *n))) for p, n in zip(pts, nrm))
    )
    code, stdout, _ = cli(
        "plot", run, "--what", "maps", "--method", "spline", "--order", "3", "--grid", "5"
    )
    assert code == 0
    assert stdout.split() == [str(run / "run1_maps.png")]
    assert_real_png(run / "run1_maps.png")


@pytest.mark.parametrize(
    ("content", "expect"),
    [
        ("x,y,z,nx,ny\n0,0,0,0,0\n", "column(s) nz"),
        ("x,y,z,nx,ny,nz\n0,0,0,0,0,1\n1,0,abc,0,0,1\n", ":3"),
        ("x,y,z,nx,ny,nz\n0,0,0,0,0,0\n", "zero-length normal"),
    ],
)
def test_bad_csv_is_one_line_naming_the_file(tmp_path, cli, content, expect):
    bad = tmp_path / "bad.csv"
    bad.write_text(content)
    code, stdout, stderr = cli("plot", bad, "-o", tmp_path / "out")
    assert code == 2
    assert stdout == ""
    assert stderr.count("\n") == 1 and "Traceback" not in stderr
    assert "bad.csv" in stderr and expect in stderr
    assert not list((tmp_path).glob("**/*.png"))


@pytest.mark.parametrize(
    ("args", "expect"),
    [
        (["--what", "contacts,surface"], "--what"),
        (["--grid", "1"], "--grid"),
    ],
)
def test_bad_options(two_patches, cli, args, expect):
    code, _, stderr = cli("plot", two_patches, *args)
    assert code == 2 and expect in stderr and stderr.count("\n") == 1


def test_missing_source_and_directory_without_contacts(tmp_path, cli):
    code, _, stderr = cli("plot", tmp_path / "nope.csv")
    assert code == 2 and "nope.csv" in stderr
    code, _, stderr = cli("plot", tmp_path)
    assert code == 2 and "contacts.csv" in stderr and stderr.count("\n") == 1


def test_unwritable_output_is_one_line(two_patches, tmp_path, cli):
    (tmp_path / "scan_cyl_patch.png").mkdir()  # a directory where the PNG should go
    code, stdout, stderr = cli("plot", two_patches, "-o", tmp_path)
    assert code == 2 and stdout.split() == [str(tmp_path / "scan_cyl_contacts.png")]
    assert stderr.count("\n") == 1 and "scan_cyl_patch.png: a directory" in stderr


def test_patch_that_cannot_be_fitted_still_gets_its_contacts_drawn(tmp_path, cli):
    pts, nrm = cylinder()
    one_line = pts[:6], nrm[:6]  # a single finger: rank deficient
    path = write_csv(tmp_path / "mixed.csv", {"good": cylinder(), "bad": one_line})
    code, stdout, stderr = cli("plot", path, "-o", tmp_path)
    assert code == 3
    assert stderr.count("\n") == 1 and "patch bad" in stderr and "one line" in stderr
    names = [p.rsplit("/", 1)[-1] for p in stdout.split()]
    assert names == [f"mixed_good_{w}.png" for w in ("contacts", "patch", "maps")] + [
        "mixed_bad_contacts.png"
    ]
    assert not (tmp_path / "mixed_bad_patch.png").exists()


def test_missing_matplotlib_gives_the_install_hint(two_patches, tmp_path, cli, monkeypatch):
    monkeypatch.setitem(sys.modules, "matplotlib", None)  # import matplotlib -> ImportError
    code, stdout, stderr = cli("plot", two_patches, "-o", tmp_path / "out")
    assert code != 0 and stdout == ""
    assert stderr.count("\n") == 1
    assert "pip install 'tactile-shape[plot]'" in stderr
    assert not (tmp_path / "out").exists()


def test_other_commands_do_not_import_matplotlib(two_patches):
    code = (
        "import sys\n"
        "from tactile.cli.main import main\n"
        "import tactile.output.plots, tactile.cli.cmd_plot\n"
        f"assert main(['ep2', 'analyze', {str(two_patches)!r}]) == 0\n"
        "print('matplotlib' in sys.modules)\n"
    )
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert done.stdout.strip().splitlines()[-1] == "False"


def bezier_quadratic(f, df, a, b):
    """Control values of the quadratic Bezier equal to f on [a, b] (end tangents meet)."""
    return np.array([f(a), f(a) + df(a) * (b - a) / 2, f(b)])


def test_control_net_matches_closed_form_bezier_of_a_paraboloid():
    # z = A x^2 + B y^2 is a biquadratic: the fit is exact and its control
    # points are f(x0) + ..., the sums of the 1-D Bezier control values.
    A, B = -0.05, -0.02
    x, y = (v.ravel() for v in np.meshgrid(XS, YS - 2.0, indexing="ij"))
    pts = np.column_stack([x, y, A * x**2 + B * y**2])
    nrm = np.column_stack([-2 * A * x, -2 * B * y, np.ones_like(x)])
    res = analyze_patch(pts, nrm, method="spline", weighting="tangent")
    # symmetric sampling: the patch frame is the world frame shifted to the centroid
    np.testing.assert_allclose(res.frame.rot, np.eye(3), atol=1e-12)
    zc = pts[:, 2].mean()
    net = res.control_net()
    assert net.shape == (3, 3, 3)
    cx = bezier_quadratic(lambda t: A * t * t, lambda t: 2 * A * t, -2.0, 2.0)
    cy = bezier_quadratic(lambda t: B * t * t, lambda t: 2 * B * t, -2.0, 2.0)
    np.testing.assert_allclose(net[..., 0], np.tile([[-2.0], [0.0], [2.0]], (1, 3)), atol=1e-12)
    np.testing.assert_allclose(net[..., 1], np.tile([-2.0, 0.0, 2.0], (3, 1)), atol=1e-12)
    np.testing.assert_allclose(net[..., 2], cx[:, None] + cy[None, :] - zc, atol=1e-9)


@pytest.mark.parametrize(("degree", "segments", "shape"), [(3, 1, (4, 4)), (2, (1, 2), (3, 4))])
def test_control_net_spans_the_fitted_surface(degree, segments, shape):
    """The net as a parametric B-spline (scipy design matrices) is the fitted surface."""
    pts, nrm = cylinder()
    res = analyze_patch(pts, nrm, method="spline", order=degree, segments=segments)
    net = res.control_net()
    assert net.shape == (*shape, 3)
    fit = res.fit
    u = np.linspace(0.0, 1.0, 7)
    bu = BSpline.design_matrix(u, np.array(fit.tx), degree).toarray()
    bv = BSpline.design_matrix(u, np.array(fit.ty), degree).toarray()
    surf = np.einsum("ai,bj,ijc->abc", bu, bv, net)
    x0, x1, y0, y1 = res.domain_box()
    np.testing.assert_allclose(surf[..., 0], (x0 + (x1 - x0) * u)[:, None] + 0 * u, atol=1e-9)
    np.testing.assert_allclose(
        surf[..., 1], (y0 + (y1 - y0) * u)[None, :] + 0 * u[:, None], atol=1e-9
    )
    z = res.surface(surf[..., :2].reshape(-1, 2)).reshape(7, 7)
    np.testing.assert_allclose(surf[..., 2], z, atol=1e-9)


def curvature_by_finite_differences(res, x, y, h=1e-3):
    """(k1, k2) of the fitted height field at (x, y): central differences and the textbook
    H, K of z = f(x, y), signed convex-toward-the-finger positive (normal along -z here)."""

    def f(dx, dy):
        return res.surface(np.column_stack([x + dx, y + dy]))

    z0 = f(0, 0)
    zx = (f(h, 0) - f(-h, 0)) / (2 * h)
    zy = (f(0, h) - f(0, -h)) / (2 * h)
    zxx = (f(h, 0) - 2 * z0 + f(-h, 0)) / h**2
    zyy = (f(0, h) - 2 * z0 + f(0, -h)) / h**2
    zxy = (f(h, h) - f(h, -h) - f(-h, h) + f(-h, -h)) / (4 * h * h)
    w2 = 1 + zx**2 + zy**2
    K = (zxx * zyy - zxy**2) / w2**2
    H = -((1 + zy**2) * zxx - 2 * zx * zy * zxy + (1 + zx**2) * zyy) / (2 * w2**1.5)
    root = np.sqrt(np.maximum(H * H - K, 0.0))
    return H + root, H - root


@pytest.mark.parametrize("grid", [8, 5])
def test_maps_draw_the_shape_index_and_curvedness_of_the_fit(tmp_path, mocker, grid):
    import matplotlib.axes

    from tactile.output import plots

    rng = np.random.default_rng(1)
    pts, nrm = sphere()
    pts = pts + rng.normal(0, 0.01, pts.shape)  # noise: S and C vary over the grid
    nrm = nrm + rng.normal(0, 0.01, nrm.shape)
    res = analyze_patch(pts, nrm, grid=grid, maps=True)
    assert res.shape == "sphere"
    spy = mocker.spy(matplotlib.axes.Axes, "pcolormesh")
    path = plots.plot_maps(res, tmp_path / "maps.png", points=pts)
    assert_real_png(path)
    # the maps' meshes (colour bars draw their own)
    drawn = [
        (c, m)
        for c, m in zip(spy.call_args_list, spy.spy_return_list, strict=True)
        if c.args[0].get_label() != "<colorbar>"
    ]
    assert len(drawn) == 2
    # the grid, rebuilt from the contacts' bounding box in the patch frame
    p = res.frame.to_patch(pts)
    gx, gy = np.meshgrid(
        np.linspace(p[:, 0].min(), p[:, 0].max(), grid),
        np.linspace(p[:, 1].min(), p[:, 1].max(), grid),
        indexing="ij",
    )
    k1, k2 = curvature_by_finite_differences(res, gx.ravel(), gy.ravel())
    s_true = (2 / np.pi) * np.arctan((k1 + k2) / (k1 - k2))  # k1 > k2 on a noisy sphere
    c_true = (2 / np.pi) * np.log(np.sqrt((k1**2 + k2**2) / 2))
    (s_call, s_mesh), (c_call, c_mesh) = drawn
    for call, true in ((s_call, s_true), (c_call, c_true)):
        _, x, y, values = call.args
        np.testing.assert_allclose(x, gx, atol=1e-12)
        np.testing.assert_allclose(y, gy, atol=1e-12)
        np.testing.assert_allclose(np.ma.getdata(values).ravel(), true, atol=2e-5)
    assert np.ptp(s_true) > 0.01  # a map, not a constant
    assert s_call.args[3].mean() == pytest.approx(res.S_mean, abs=1e-12)
    assert (s_mesh.norm.vmin, s_mesh.norm.vmax) == (-1.0, 1.0)
    assert s_mesh.cmap.name == plots.S_CMAP
    assert s_mesh.colorbar is not None and c_mesh.colorbar is not None


def test_plane_maps_say_not_computed(tmp_path, mocker):
    import matplotlib.axes

    from tactile.output import plots

    x, y = (v.ravel() for v in np.meshgrid(XS, YS, indexing="ij"))
    pts = np.column_stack([x, y, 0.3 * x + 0.2 * y])
    nrm = np.tile([-0.3, -0.2, 1.0], (len(x), 1))
    res = analyze_patch(pts, nrm, maps=True)
    assert res.shape == "plane"
    spy = mocker.spy(matplotlib.axes.Axes, "pcolormesh")
    title = mocker.spy(matplotlib.axes.Axes, "set_title")
    assert_real_png(plots.plot_maps(res, tmp_path / "plane.png"))
    assert spy.call_count == 0
    said = [c.args[1] for c in title.call_args_list]
    assert [t.split("\n")[0] for t in said] == ["plane: S not computed", "plane: C not computed"]


def test_contacts_and_patch_draw_the_given_normals_and_the_net(tmp_path, mocker):
    from mpl_toolkits.mplot3d import Axes3D

    from tactile.output import plots

    pts, nrm = cylinder()
    finger = [str(XS.index(p)) for p in pts[:, 0]]
    quiver = mocker.spy(Axes3D, "quiver")
    assert_real_png(plots.plot_contacts(pts, 3 * nrm, tmp_path / "c.png", finger=finger))
    assert quiver.call_count == 3  # one per finger
    tails = np.vstack([np.column_stack(c.args[1:4]) for c in quiver.call_args_list])
    arrows = np.vstack([np.column_stack(c.args[4:7]) for c in quiver.call_args_list])
    np.testing.assert_allclose(tails, pts)  # fingers are contiguous in these rows
    length = plots.NORMAL_LENGTH * 4.0  # largest extent of the contacts (y: 0..4)
    np.testing.assert_allclose(arrows, nrm * length)  # unit normals, whatever the input length

    jet = analyze_patch(pts, nrm)
    wire = mocker.spy(Axes3D, "plot_wireframe")
    assert_real_png(plots.plot_patch(jet, pts, nrm, tmp_path / "j.png"))
    assert jet.control_net() is None and wire.call_count == 0  # the jet has no control mesh
    res = analyze_patch(pts, nrm, method="spline")
    quiver.reset_mock()
    assert_real_png(plots.plot_patch(res, pts, nrm, tmp_path / "p.png"))
    net = res.control_net()
    np.testing.assert_allclose(np.stack(wire.call_args.args[1:4], axis=-1), net)
    (call,) = quiver.call_args_list
    np.testing.assert_allclose(np.column_stack(call.args[1:4]), res.frame.to_patch(pts))
    np.testing.assert_allclose(
        np.column_stack(call.args[4:7]),
        res.frame.to_patch_dirs(nrm) * plots.NORMAL_LENGTH * np.ptp(call.args[1:4], axis=1).max(),
        atol=1e-12,
    )


def test_region_map_draws_each_region_in_its_s_colour_and_each_edge(tmp_path, mocker):
    from matplotlib.colors import to_rgba
    from mpl_toolkits.mplot3d import Axes3D

    from tactile.ep2.region_map import map_contacts
    from tactile.output import plots, region_plot
    from tactile_sim.ep2 import map_objects

    d = map_objects.make("capped_cylinder", 0.002, 0.002, seed=1)
    found = map_contacts(d["points"], d["normals"], noise_pos=0.002, noise_normal=0.002)
    assert sorted(r.shape for r in found.regions) == ["cylinder", "sphere"]
    scatter = mocker.spy(Axes3D, "scatter")
    line = mocker.spy(Axes3D, "plot")
    labels = mocker.spy(Axes3D, "set")
    path = region_plot.plot_region_map(d["points"], found, tmp_path / "map.png", unit="cm")
    assert_real_png(path)
    cmap = __import__("matplotlib").colormaps[plots.S_CMAP]
    drawn = {c.kwargs["label"].split(":")[0]: c for c in scatter.call_args_list}
    for r in found.regions:
        call = drawn[f"region {r.id}"]
        np.testing.assert_allclose(np.column_stack(call.args[1:4]), d["points"][r.contacts])
        assert to_rgba(call.kwargs["color"]) == pytest.approx(cmap((r.S + 1) / 2))
    (edge,) = found.edges
    (call,) = line.call_args_list
    ends = np.column_stack(call.args[1:4])
    off = ends - edge.point
    along = off @ np.asarray(edge.direction)
    np.testing.assert_allclose(off, np.outer(along, edge.direction), atol=1e-9)  # on its line
    assert np.ptp(along) > 1.0 and call.kwargs["linestyle"] == "--"  # a curvature jump
    assert call.kwargs["label"] == "edge 0-1: curvature jump"
    (axes,) = [c.kwargs for c in labels.call_args_list if "xlabel" in c.kwargs]
    assert [axes[k] for k in ("xlabel", "ylabel", "zlabel")] == ["x (cm)", "y (cm)", "z (cm)"]


def test_region_map_draws_a_plane_grey_and_a_crease_with_its_dihedral(tmp_path, mocker):
    from matplotlib.colors import to_rgba
    from mpl_toolkits.mplot3d import Axes3D

    from tactile.ep2.region_map import map_contacts
    from tactile.output import region_plot
    from tactile_sim.ep2 import map_objects

    d = map_objects.make("box_corner", 0.002, 0.002, seed=1)
    found = map_contacts(d["points"], d["normals"])
    scatter = mocker.spy(Axes3D, "scatter")
    line = mocker.spy(Axes3D, "plot")
    region_plot.plot_region_map(d["points"], found, tmp_path / "box.png")
    colours = [to_rgba(c.kwargs["color"]) for c in scatter.call_args_list]
    assert colours == [to_rgba(region_plot.PLANE_GREY)] * 3
    names = sorted(c.kwargs["label"] for c in line.call_args_list)
    assert len(names) == 3 and all("ridge" in n and n.endswith(" deg") for n in names)
    assert all(c.kwargs["linestyle"] == "-" for c in line.call_args_list)


def test_cli_plots_the_region_map_of_the_whole_file(tmp_path, cli):
    from tactile_sim.ep2 import map_objects

    d = map_objects.make("box_corner", 0.002, 0.002, seed=2)
    csv = tmp_path / "box.csv"
    csv.write_text(
        "# units: cm\nx,y,z,nx,ny,nz\n"
        + "\n".join(
            ",".join(f"{v:.9g}" for v in (*p, *n)) for p, n in zip(d["points"], d["normals"])
        )
    )
    code, stdout, stderr = cli("plot", csv, "--what", "map", "--units", "mm")
    assert (code, stderr) == (0, "")
    assert stdout.split() == [str(tmp_path / "box_map.png")]
    assert_real_png(tmp_path / "box_map.png")
