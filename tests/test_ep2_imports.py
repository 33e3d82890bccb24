"""EP2 imports only what a run uses (issue 28): the default fit and the CLI on one patch load
numpy and the package, not scipy; the spline loads scipy when it runs, and only then."""

import json
import subprocess
import sys

import numpy as np
import pytest

HEAVY = ("scipy", "matplotlib", "pandas", "serial", "mcap", "hypothesis")


def _loaded_after(code):
    """The heavy top-level packages in ``sys.modules`` after ``code`` ran in a fresh Python."""
    tail = (
        "import json, sys; top = {m.split('.')[0] for m in sys.modules}; "
        f"print(json.dumps(sorted(top & set({HEAVY!r}))))"
    )
    out = subprocess.run(
        [sys.executable, "-c", code + "\n" + tail], capture_output=True, text=True, check=True
    )
    return set(json.loads(out.stdout.splitlines()[-1]))


def _sphere_csv(path, n=24, seed=0):
    rng = np.random.default_rng(seed)
    xy = rng.uniform(-1.0, 1.0, (n, 2))
    z = np.sqrt(25.0 - (xy**2).sum(1))
    pts = np.column_stack([xy, z])
    nrm = pts / 5.0
    rows = ["x,y,z,nx,ny,nz"] + [
        ",".join(f"{v:.9g}" for v in (*p, *q)) for p, q in zip(pts, nrm, strict=True)
    ]
    path.write_text("\n".join(rows) + "\n", encoding="utf-8")
    return path


def test_the_cli_on_one_patch_imports_no_scipy(tmp_path):
    csv = _sphere_csv(tmp_path / "one.csv")
    code = (
        "import sys; from tactile.cli.main import main\n"
        f"sys.argv = ['tactile', 'ep2', 'analyze', {str(csv)!r}]\n"
        "try:\n    main()\nexcept SystemExit as e:\n    assert not e.code, e.code\n"
    )
    assert _loaded_after(code) == set()


@pytest.mark.parametrize("method, heavy", [("jet", set()), ("spline", {"scipy"})])
def test_the_library_loads_scipy_for_the_spline_only(tmp_path, method, heavy):
    csv = _sphere_csv(tmp_path / "one.csv")
    code = (
        "import numpy as np; from tactile.ep2 import analyze_patch\n"
        f"a = np.loadtxt({str(csv)!r}, delimiter=',', skiprows=1)\n"
        f"r = analyze_patch(a[:, :3], a[:, 3:], method={method!r})\n"
        "assert r.shape == 'sphere', r.shape\n"
    )
    assert _loaded_after(code) == heavy
