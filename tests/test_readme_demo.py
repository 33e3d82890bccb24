"""The README's demo part is the demo's own output, pasted by ``bench/readme_demo.py``: one run
of ``tactile demo`` here, as ``make demo`` runs it, must agree with the README's table within
the tolerances the README states, and the README's sentences must be what the script makes
of its table.  The same run checks the replica itself, end to end over a pty, and its three
recordings as ``tactile ep2 analyze`` reads them (the suite runs the demo once)."""

import json

import pytest
from conftest import ROOT, load_bench

from tactile_studies import replica

README = ROOT / "README.md"


@pytest.mark.slow
def test_the_readme_shows_what_the_demo_prints(cli, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)  # (its recordings: demo-out/, as make demo's)
    code, out, err = cli("demo")
    assert code == 0 and err == ""
    demo = load_bench("readme_demo")
    part, quoted = demo.of_readme(README.read_text(encoding="utf-8"))
    assert part == demo.part(quoted), "the README's sentences are not its table's"
    assert not demo.differences(quoted, out), "the README's table is not the demo's"
    # the replica: every line fits 80 columns, the cylinder's S and radius, nothing lost
    assert max(len(line) for line in out.splitlines()) <= 80
    ours = [ln.split() for ln in out.splitlines() if ln.startswith("cylinder ")]
    assert len(ours) == 2 and all(row[2] == "ours" for row in ours)
    for row in ours:
        assert abs(float(row[3]) - 0.5) < 0.05 and abs(float(row[-1]) - 6.6) / 6.6 < 0.15
    for name in ("plane", "cylinder", "concave_cylinder"):  # 3 x 6 x 2, none rejected
        assert f"label {name}; 36 contacts, 72 localised, 0 lost" in out
        for file in ("capture.bin", "frames.csv", "meta.json", "contacts.csv", "poses.csv"):
            assert (tmp_path / "demo-out" / name / file).stat().st_size > 0
    # each recording over the pty: the scene's end, nothing lost, TAREd, every reading
    # localised; the thesis's tangent-weighted spline labels it and finds its radius
    args = ("--method", "spline", "--weighting", "tangent", "--units", "cm", "--json")
    for kind, name in (("plane", "plane"), ("convex", "cylinder"), ("concave", "concave_cylinder")):
        run = tmp_path / "demo-out" / name
        meta = json.loads((run / "meta.json").read_text())
        assert meta["ended"] == "scene end" and meta["decoder"]["lost_frames"] == 0
        assert meta["contacts_ended"] == 36 and meta["tared"]
        code, out, err = cli("ep2", "analyze", run, *args)  # the run folder, in m
        result = json.loads(out.splitlines()[0])
        assert code == 0 and result["shape"] == name, err
        true = replica.TRUE_RADIUS_CM[kind]
        assert true is None or abs(result["radius"] - true) / true < 0.10
