"""The chapter 5 replica through the emulator's serial path (issue 7, in part)."""

import pytest


@pytest.mark.slow
def test_demo_prints_the_replica_beside_the_thesis(cli, tmp_path):
    code, out, err = cli("demo", "--object", "cylinder", "-o", tmp_path)
    assert code == 0 and err == ""
    lines = out.splitlines()
    assert max(len(ln) for ln in lines if "recording:" not in ln) <= 80
    ours = [ln for ln in lines if ln.startswith("cylinder") and "ours" in ln]
    assert len(ours) == 2
    for line in ours:
        s, radius = float(line.split()[3]), float(line.split()[-1])
        assert abs(s - 0.5) < 0.05 and abs(radius - 6.6) / 6.6 < 0.15
    assert "label 'cylinder'" in out and "0 frames lost" in out
    assert "72 localised readings" in out  # 3 passes x 6 points x 2 samples, none rejected
    for name in ("capture.bin", "frames.csv", "meta.json", "contacts.csv", "poses.csv"):
        assert (tmp_path / "cylinder" / name).stat().st_size > 0


@pytest.mark.slow
def test_demo_takes_the_old_object_names_with_a_note(cli, tmp_path):
    code, out, err = cli("demo", "--object", "concave", "--via", "sim", "-o", tmp_path)
    assert code == 0, err
    assert err == "tactile demo: note: 'concave' is deprecated, use 'concave_cylinder'\n"
    assert "label 'concave_cylinder'" in out and (tmp_path / "concave_cylinder").is_dir()
