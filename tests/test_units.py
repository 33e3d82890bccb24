"""Units stated everywhere (issue 14 part 3): the ``# units:`` line of every CSV the project
writes, its check on input, record's contacts in metres whatever the pose log, and display
units (``--units``) that scale lengths and curvatures and shift C by -(2/pi) ln(scale)."""

import json
import math
import shutil

import numpy as np
import pytest

from tactile import units
from tactile.cli.main import main
from tactile.errors import InputError
from tactile_studies.ep1.studies import UNITS as EP1_STUDY_UNITS
from tactile_studies.ep2.studies import UNITS as EP2_STUDY_UNITS

pytestmark = pytest.mark.filterwarnings("ignore::DeprecationWarning")


def _cli(capsys, *argv):
    code = main(list(argv))
    out, err = capsys.readouterr()
    return code, out, err


def _first_line(path):
    with open(path, encoding="utf-8") as fh:
        return fh.readline().rstrip("\n")


# --- every writer states its units on line 1 -----------------------------------------------


def _scene_logs(tmp_path):
    from tactile_sim.emulator.device import build_motion
    from tactile_sim.emulator.scene import load_scene

    out = {}
    for scene, method in (
        ("ch5_convex", "write_pose_log"),
        ("ep2_sweep_sphere", "write_pose_log"),
        ("ep1_roll", "write_probe_log"),
    ):
        path = tmp_path / f"{scene}.csv"
        getattr(build_motion(load_scene(scene)), method)(path)
        out[scene] = path
    return out


def test_every_csv_writer_starts_with_its_units_line(tmp_path):
    from tactile.ep1.probes import format_probes
    from tactile.localize import format_contacts
    from tactile.recording.files import Recording
    from tactile_sim.ep2 import make, sweep, write_csv
    from tactile_studies.ep1.studies import write_csv as ep1_study_csv
    from tactile_studies.ep2.studies import _write as ep2_study_csv

    rec = Recording(tmp_path / "rec")
    rec.close()
    (tmp_path / "contacts.csv").write_text(format_contacts(np.ones((2, 3)), np.ones((2, 3))))
    (tmp_path / "probes.csv").write_text(format_probes(np.ones((2, 4))))
    write_csv(tmp_path / "sim.csv", sweep(make("sphere", 8.0)))
    ep1_study_csv(tmp_path / "ep1_study.csv", [{"radius": 1.0}])
    ep2_study = ep2_study_csv(str(tmp_path), "ep2_study", [{"radius": 6.6}])
    written = {
        tmp_path / "rec" / "frames.csv": "# units: N, N*m, us, s",
        tmp_path / "contacts.csv": "# units: m",
        tmp_path / "probes.csv": "# units: rad",
        tmp_path / "sim.csv": "# units: cm",
        tmp_path / "ep1_study.csv": "# units: " + EP1_STUDY_UNITS,
        ep2_study: "# units: " + EP2_STUDY_UNITS,
    }  # fmt: skip
    logs = _scene_logs(tmp_path)
    written[logs["ch5_convex"]] = "# units: us, rad, m"
    written[logs["ep2_sweep_sphere"]] = "# units: us, m"
    written[logs["ep1_roll"]] = "# units: us, rad, m"
    for path, line in written.items():
        assert _first_line(path) == line, path


def test_written_files_read_back_through_their_readers(tmp_path):
    """The units line is part of each contract: the project's readers accept their own files."""
    from tactile.ep1.probes import format_probes, read_probes
    from tactile.ep2.contacts_csv import read_contacts
    from tactile.localize import format_contacts
    from tactile.logs.read import read_pose_log, read_probe_log

    pts = np.array([[0.0, 0.0, 0.0], [0.01, 0.02, 0.03]])
    (tmp_path / "c.csv").write_text(format_contacts(pts, [[0, 0, 1]] * 2))
    (patch,) = read_contacts(tmp_path / "c.csv")
    assert np.array_equal(patch.points, pts)
    (tmp_path / "p.csv").write_text(format_probes(np.arange(8.0).reshape(2, 4)))
    dtheta, dp = read_probes(tmp_path / "p.csv")
    assert dtheta.tolist() == [[0, 1], [4, 5]] and dp.tolist() == [[2, 3], [6, 7]]
    logs = _scene_logs(tmp_path)
    assert read_pose_log(logs["ch5_convex"]).kind == "scara"
    assert read_pose_log(logs["ep2_sweep_sphere"]).kind == "pose"
    assert len(read_probe_log(logs["ep1_roll"]).probe) > 0


def test_format_contacts_writes_another_unit_on_request():
    from tactile.localize import format_contacts

    text = format_contacts([[0.5, 0.25, 1.0]], [[0, 0, 1]], unit="mm")
    assert text.splitlines()[:3] == [
        "# units: mm",
        "x,y,z,nx,ny,nz",
        "500.0,250.0,1000.0,0.0,0.0,1.0",
    ]


# --- the input contract: the line accepted, a mismatch or unknown unit refused -----------------


def _sphere_csv(path, unit="cm", line=True):
    from tactile_sim.ep2 import make, sweep
    from tactile_sim.ep2.sweep import write_csv

    write_csv(path, sweep(make("sphere", 8.0), noise_pos=0.01), unit=unit)
    if not line:
        path.write_text(path.read_text().split("\n", 1)[1])
    return path


@pytest.mark.parametrize(
    "line, argv, message",
    [
        ("# units: m", ["--file-units", "mm"], r"f\.csv:1: units: the file is in m, not mm"),
        ("# units: parsec", [], r"f\.csv:1: units 'parsec': not a length unit \(one of m, cm"),
        ("# units: m, cm", [], r"f\.csv:1: units 'm, cm': not a length unit"),
        ("# units: m", ["--units", "furlong"], r"--units: unknown length unit 'furlong'"),
        ("# units: m", ["--file-units", "yd"], r"--file-units: unknown length unit 'yd'"),
    ],
)
def test_ep2_analyze_refuses_a_units_mismatch_in_one_line(tmp_path, capsys, line, argv, message):
    path = _sphere_csv(tmp_path / "f.csv", line=False)
    path.write_text(f"{line}\n" + path.read_text())
    code, out, err = _cli(capsys, "ep2", "analyze", str(path), *argv)
    assert code == 2 and out == ""
    assert len(err.strip().splitlines()) == 1 and "Traceback" not in err
    assert __import__("re").search(message, err), err


def test_a_file_without_the_line_is_read_as_before_and_cannot_be_converted(tmp_path, capsys):
    path = _sphere_csv(tmp_path / "old.csv", line=False)
    code, out, _ = _cli(capsys, "ep2", "analyze", str(path), "--json")
    assert code == 0 and json.loads(out)["units"]["radius"] == "u"
    code, _, err = _cli(capsys, "ep2", "analyze", str(path), "--units", "m")
    assert code == 2 and "states no length unit" in err
    code, out, _ = _cli(capsys, "ep2", "analyze", str(path), "--file-units", "cm", "--units", "m")
    assert code == 0 and "radius (m)" in out.splitlines()[0]


def test_probes_and_frames_refuse_a_unit_they_do_not_hold(tmp_path):
    from tactile.ep1.probes import read_probes
    from tactile.recording.layout import read_frames

    probes = tmp_path / "probes.csv"
    probes.write_text("# units: deg\ndtheta_x,dtheta_y,du,dv\n1,2,3,4\n")
    with pytest.raises(InputError, match=r"probes\.csv:1: units 'deg': a probes CSV holds"):
        read_probes(probes)
    frames = tmp_path / "frames.csv"
    frames.write_text("# units: kN, N*m\nseq,timestamp_us\n")
    with pytest.raises(InputError, match=r"frames\.csv:1: units 'kN, N\*m': frames\.csv holds"):
        read_frames(frames)


def test_a_pose_log_in_other_units_is_refused(tmp_path):
    from tactile.logs.read import read_pose_log

    log = _scene_logs(tmp_path)["ch5_convex"]
    log.write_text(log.read_text().replace("# units: us, rad, m", "# units: us, deg, cm"))
    with pytest.raises(InputError, match=r"ch5_convex\.csv:1: units 'us, deg, cm': a pose log"):
        read_pose_log(log)


# --- record: SCARA contacts in metres, the cm file of older recorders read the same ---------


@pytest.fixture(scope="module")
def scara_run(tmp_path_factory):
    from tactile_studies import replica

    out = tmp_path_factory.mktemp("scara") / "run"
    meta, lines, results = replica.replicate("convex", out, via="sim")
    return out, lines, results


def _analyze(capsys, path, *argv):
    code, out, err = _cli(capsys, "ep2", "analyze", str(path), "--json", *argv)
    assert code == 0, err
    return json.loads(out)


@pytest.mark.slow  # (the scara run: the ch5 convex scene through the emulator)
def test_scara_contacts_are_metres_and_the_cm_file_gives_the_same_shape(
    scara_run, tmp_path, capsys
):
    from tactile.ep2.contacts_csv import read_contacts
    from tactile.recording.load import load_recording

    run, lines, _ = scara_run
    assert "(m)" in lines[0] and _first_line(run / "contacts.csv") == "# units: m"
    m_points = read_contacts(run / "contacts.csv")[0].points
    assert 0.01 < np.ptp(m_points, axis=0).max() < 1.0  # a hand-sized sweep, in metres
    # the same contacts as a recorder before this change wrote them: cm, no units line
    old = tmp_path / "old"
    shutil.copytree(run, old)
    body = (run / "contacts.csv").read_text().split("\n", 2)[1:]
    rows = [r.split(",") for r in body[1].splitlines()]
    cm = [",".join([*(repr(float(v) * 100) for v in r[:3]), *r[3:]]) for r in rows]
    (old / "contacts.csv").write_text("\n".join([body[0], *cm]) + "\n")
    meta = json.loads((old / "meta.json").read_text())  # as `tactile record` names its log:
    meta["command"] = "tactile record --port sim://ch5_convex --pose-log poses.csv -o old"
    (old / "meta.json").write_text(json.dumps(meta))  # the loader tells cm from it
    np.testing.assert_allclose(
        load_recording(old).contacts.points_m, load_recording(run).contacts.points_m, rtol=1e-12
    )
    assert load_recording(old).contacts.file_unit == "cm"
    in_m = _analyze(capsys, run / "contacts.csv")
    in_cm = _analyze(capsys, old / "contacts.csv", "--file-units", "cm")
    cm_as_m = _analyze(capsys, old / "contacts.csv", "--file-units", "cm", "--units", "m")
    assert in_m["shape"] == in_cm["shape"] and in_m["votes"] == pytest.approx(in_cm["votes"])
    assert max(in_m["votes"], key=in_m["votes"].get) == "cylinder"  # (or its label: uncertain)
    assert in_m["units"]["radius"] == "m" and in_cm["units"]["radius"] == "cm"
    assert cm_as_m["radius"] == pytest.approx(in_m["radius"], rel=1e-6)
    assert in_cm["radius"] == pytest.approx(100 * in_m["radius"], rel=1e-6)
    assert 0.04 < in_m["radius"] < 0.09  # the ch5 convex cylinder, R 6.6 cm


@pytest.mark.slow
def test_the_replica_compares_with_the_thesis_in_cm(scara_run):
    _, _, results = scara_run
    assert results["tangent"].shape == "cylinder"
    assert 4.0 < results["tangent"].radius < 9.0  # cm, as tables 5-7 (true 6.6 cm)


# --- display units ----------------------------------------------------------------------------


@pytest.mark.parametrize(
    "shown, factor", [("m", 1e-2), ("mm", 10.0), ("um", 1e4), ("in", 1 / 2.54)]
)
def test_display_units_scale_lengths_and_shift_c(tmp_path, capsys, shown, factor):
    path = _sphere_csv(tmp_path / "s.csv", unit="cm")
    base = _analyze(capsys, path)
    other = _analyze(capsys, path, "--units", shown)
    for name in ("radius", "noise_pos"):
        assert other[name] == pytest.approx(base[name] * factor, rel=1e-12)
    for name in ("k1", "k2", "R_mean", "k1_std"):
        assert other[name] == pytest.approx(base[name] / factor, rel=1e-12)
    assert other["radius_interval"] == pytest.approx([v * factor for v in base["radius_interval"]])
    for name in ("C", "C_mean"):
        assert other[name] == pytest.approx(base[name] - 2 / math.pi * math.log(factor), abs=1e-12)
    for name in ("S", "S_mean", "confidence", "shape"):
        assert other[name] == base[name]
    assert other["units"]["k1"] == f"1/{shown}" and f"1/{shown}" in other["units"]["C"]


def test_noise_pos_is_given_in_the_display_unit(tmp_path, capsys):
    path = _sphere_csv(tmp_path / "s.csv", unit="cm")
    cm = _analyze(capsys, path, "--noise-pos", "0.01")
    mm = _analyze(capsys, path, "--noise-pos", "0.1", "--units", "mm")
    assert mm["noise_pos"] == pytest.approx(0.1) and cm["noise_pos"] == pytest.approx(0.01)
    assert mm["radius"] == pytest.approx(10 * cm["radius"], rel=1e-9)


def test_the_table_names_the_unit_of_every_column(tmp_path, capsys):
    path = _sphere_csv(tmp_path / "s.csv", unit="cm")
    code, out, _ = _cli(capsys, "ep2", "analyze", str(path), "--units", "mm")
    head, row, foot = out.strip().splitlines()
    for label in ("k1 (1/mm)", "k2 (1/mm)", "radius (mm)", "C (R in 1/mm)"):
        assert label in head
    assert "1/mm" in foot and "shifts C" in foot
    code, out_cm, _ = _cli(capsys, "ep2", "analyze", str(path), "--units", "cm")
    cm = float(out_cm.strip().splitlines()[1].split()[8])
    assert float(row.split()[8]) == pytest.approx(10.0 * cm, rel=1e-3)  # the same radius, in mm
    assert 0.9 * 8.0 < cm < 1.1 * 8.0  # radius 8 cm (a 2-jet over a wide patch: a few % low)


def test_c_shift_is_the_log_of_the_scale():
    assert units.c_shift(1.0) == 0.0
    r = 12.5  # 1/m
    for scale in (100.0, 1e-3, 2.54):
        c = 2 / math.pi * math.log(r)
        assert c + units.c_shift(scale) == pytest.approx(2 / math.pi * math.log(r / scale))


def test_length_vocabulary_is_shared_with_calibration_units():
    import tactile.calib as calib_units

    assert calib_units.LENGTH_M is units.LENGTH_M
    assert calib_units.torque_factor("N-mm") == pytest.approx(1e-3)
    assert units.parse_length("\u00b5m") == "um" and units.length_factor("in") == 0.0254
    with pytest.raises(ValueError, match="unknown length unit"):
        units.parse_length("cubit")


def test_plot_draws_in_the_display_unit_and_labels_an_unstated_file_as_told(tmp_path):
    from tactile.cli.cmd_plot import _display

    path = _sphere_csv(tmp_path / "s.csv", unit="cm")
    assert _display(path, None) == ("cm", 1.0) and _display(path, "mm") == ("mm", 10.0)
    old = _sphere_csv(tmp_path / "old.csv", line=False)
    assert _display(old, "cm") == ("cm", 1.0) and _display(old, None) == (None, 1.0)
    path.write_text(path.read_text().replace("# units: cm", "# units: furlong"))
    with pytest.raises(InputError, match=r"s\.csv:1: units 'furlong': not a length unit"):
        _display(path, None)
