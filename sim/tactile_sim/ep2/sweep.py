"""The three-finger sweep of EP2 (§4.1, fig. 24; §5.1: 3 passes x 6 points x 2 samples).

Fingers sit ``spacing`` apart along x and sweep ``length`` along y; each
takes ``samples`` stops, ``repeats`` readings per stop.  Noise (seeded):
Gaussian on each position coordinate (``noise_pos``, length unit) and a tilt
of each normal by a Gaussian angle about each tangent axis
(``noise_normal``, rad per axis).  ``tilt_deg`` turns the whole scene about the world x
axis so the data arrive in a robot frame that is not the patch frame.
"""

import numpy as np

from tactile.files.writing import atomic_write


def sweep(
    obj,
    fingers=3,
    spacing=2.0,
    length=4.0,
    samples=6,
    repeats=2,
    origin=(0.0, 0.0),
    noise_pos=0.0,
    noise_normal=0.0,
    tilt_deg=0.0,
    seed=0,
):
    """Contacts as a dict of arrays: points (n, 3), normals (n, 3), finger (n,), stop (n,)."""
    rng = np.random.default_rng(seed)
    fx = origin[0] + spacing * np.arange(fingers)
    sy = origin[1] + np.linspace(0.0, length, samples)
    x = np.repeat(fx, samples * repeats)
    y = np.tile(np.repeat(sy, repeats), fingers)
    z, _, _ = obj.eval(x, y)
    pts = np.column_stack([x, y, z])
    nrm = obj.normals(x, y)
    if noise_pos > 0:
        pts = pts + noise_pos * rng.standard_normal(pts.shape)
    if noise_normal > 0:
        nrm = _tilt_normals(nrm, noise_normal, rng)
    if tilt_deg:
        a = np.radians(tilt_deg)
        rot = np.array([[1, 0, 0], [0, np.cos(a), -np.sin(a)], [0, np.sin(a), np.cos(a)]])
        pts = pts @ rot.T
        nrm = nrm @ rot.T
    finger = np.repeat(np.arange(fingers), samples * repeats)
    stop = np.tile(np.repeat(np.arange(samples), repeats), fingers)
    return {"points": pts, "normals": nrm, "finger": finger, "stop": stop}


def _tilt_normals(n, sigma, rng):
    """Perturb each unit normal by sigma * (g1 t1 + g2 t2), g ~ N(0, 1), and renormalise:
    an angular error of sigma rad per tangent axis (isotropic direction noise)."""
    ref = np.where(np.abs(n[:, :1]) < 0.9, [[1.0, 0.0, 0.0]], [[0.0, 1.0, 0.0]])
    t1 = np.cross(n, ref)
    t1 /= np.linalg.norm(t1, axis=1, keepdims=True)
    t2 = np.cross(n, t1)
    g = sigma * rng.standard_normal((len(n), 2))
    out = n + g[:, :1] * t1 + g[:, 1:] * t2
    return out / np.linalg.norm(out, axis=1, keepdims=True)


UNIT = "cm"  # the scene's lengths (§4.9's numbers carry none; cm makes them hand-sized)


def write_csv(path, data, patch=None, unit=UNIT):
    """Write the EP2 CSV contract: ``# units: UNIT``, x,y,z,nx,ny,nz,finger[,patch]."""
    with atomic_write(path, text=True) as fh:
        write_rows(fh, data, patch, unit=unit)


def write_rows(fh, data, patch=None, header=True, unit=UNIT):
    """Append one sweep's rows to an open file (units line and header first if asked)."""
    if header:
        fh.write(f"# units: {unit}\n")
        fh.write("x,y,z,nx,ny,nz,finger" + (",patch" if patch is not None else "") + "\n")
    rows = np.column_stack([data["points"], data["normals"]])
    tail = f",{patch}" if patch is not None else ""
    for r, f in zip(rows, data["finger"], strict=True):
        fh.write(",".join(f"{v:.10g}" for v in r) + f",{int(f)}{tail}\n")
