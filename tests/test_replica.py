"""The chapter 5 replica through the emulator's serial path (issue 7, in part)."""


def test_demo_prints_the_replica_beside_the_thesis(cli, tmp_path):
    code, out, err = cli("demo", "--object", "convex", "-o", tmp_path)
    assert code == 0 and err == ""
    lines = out.splitlines()
    ours = [ln for ln in lines if ln.startswith("convex") and "ours" in ln]
    assert len(ours) == 2
    for line in ours:
        s, radius = float(line.split()[3]), float(line.split()[-1])
        assert abs(s - 0.5) < 0.05 and abs(radius - 6.6) / 6.6 < 0.15
    assert "label 'cylinder'" in out and "0 frames lost" in out
    assert "72 localised readings" in out  # 3 passes x 6 points x 2 samples, none rejected
    for name in ("capture.bin", "frames.csv", "meta.json", "contacts.csv", "poses.csv"):
        assert (tmp_path / "convex" / name).stat().st_size > 0
