"""EP2 study replicas write their CSV and reproduce the thesis's rotation trend (fig. 32)."""

import csv

from tactile_studies.ep2 import studies


def test_rotation_study_worst_at_45_and_zero_when_aligned(tmp_path):
    rows, paths = studies.run("rotation", str(tmp_path))
    assert paths == [str(tmp_path / f"ep2_fig32_rotation.{ext}") for ext in ("csv", "png")]
    assert (tmp_path / "ep2_fig32_rotation.png").stat().st_size > 1000
    r6 = {
        r["rotation"]: r["rms_S_error"]
        for r in rows
        if r["radius"] == 6 and r["weighting"] == "tangent"
    }
    assert max(r6, key=r6.get) == 45
    assert r6[0] < 1e-6 and r6[90] < 1e-6
    with open(tmp_path / "ep2_fig32_rotation.csv") as fh:
        assert fh.readline().startswith("# units: lengths cm")
        assert len(list(csv.DictReader(fh))) == len(rows) == 42


def test_tables_replica_has_thesis_columns_and_right_labels(tmp_path):
    rows, paths = studies.run("tables", str(tmp_path), png=False, trials=3)
    assert paths == [str(tmp_path / "ep2_tables5_7.csv")]
    by = {(r["surface"], r["weighting"]): r for r in rows}
    assert by[("cylinder", "tangent")]["thesis_S"] == 0.4980
    assert abs(by[("cylinder", "tangent")]["S_mean"] - 0.5) < 0.05
    assert abs(by[("concave_cylinder", "auto")]["S_mean"] + 0.5) < 0.05
    assert by[("cylinder", "auto")]["label_share"] == 1.0
    with open(tmp_path / "ep2_tables5_7.csv") as fh:
        assert fh.readline().startswith("# units: lengths cm")
        assert len(list(csv.DictReader(fh))) == len(rows) == 9
