"""EP1 through the F/T path on the emulator: curvature error against the scene's truth.

Run: ``.venv/bin/python bench/ep1_roll_emulated.py [--seeds 20]`` (about 30 s).

The shipped scene ``ep1_roll`` (fingertip R1 = 1 cm on a wrist sensor 5 cm behind it, an
ellipsoid with principal radii 2 cm and 4.5 cm, eight probes of 0.5 rad, 5 N, friction load
0.2, the thesis's ch. 5 sensor noise) runs through ``sim://`` (real firmware, ADC models,
host decoder); the host turns the CONTACT frames and the robot's probe log into probes
(``tactile.ep1.probes``) and estimates the curvature (``tactile.ep1.estimator``).
The "eq. 29 floor" is the error of the estimate from the simulator's exact probes (eq. 29
takes the curvature as constant over the roll).  Rows: the noiseless chain, and the noisy
chain over several seeds with the wrench averaged over all frames of each hold, the 10
nearest, or a single reading; then with the thesis's dtheta = pi/2 (§3.3.3) and with 1 s
holds.
"""

import argparse
import pathlib
import re
import tempfile
import time

import numpy as np
import serial

from tactile.board.stream_decoder import StreamDecoder
from tactile.ep1.estimator import estimate
from tactile.ep1.probes import probes_from_frames
from tactile.logs.read import read_probe_log
from tactile_protocol import constants as C
from tactile_sim.emulator.scene import SCENE_DIR
from tactile_sim.urlhandler import register

SHIPPED = SCENE_DIR / "ep1_roll.toml"
GATE_N = 1.0


def variant(folder, name, **subs):
    text = SHIPPED.read_text()
    for key, value in subs.items():
        text, n = re.subn(rf"(?m)^{key} = .*$", f"{key} = {value}", text)
        assert n == 1, key
    path = pathlib.Path(folder) / f"{name}.toml"
    path.write_text(text)
    return path


def record(url):
    """Run a scene to its end through sim://; (motion, t_us, wrench, wall seconds)."""
    t0 = time.perf_counter()
    port = serial.serial_for_url(url, timeout=0.005)
    decoder, msgs = StreamDecoder(), []
    end = port.emulator.motion.duration_s * 1e6
    while port.emulator.t_us < end:
        msgs += decoder.feed(port.read(65536))
    wall = time.perf_counter() - t0
    c = [m for m in msgs if m.type_name == "CONTACT"]
    t = np.array([m.timestamp_us for m in c], np.int64)
    w = np.array([[m.fx, m.fy, m.fz, m.tx, m.ty, m.tz] for m in c], float)
    w[:, :3] *= C.FORCE_LSB_N
    w[:, 3:] *= C.TORQUE_LSB_NM
    return port.emulator.motion, t, w, wall


def errors(est, truth):
    """Relative errors of kx and ky (None when the estimate gives no number)."""
    if est.kx is None:
        return None
    return abs(est.kx / truth["kx"] - 1.0), abs(est.ky / truth["ky"] - 1.0)


def derive(motion, t, w, folder, average=None):
    path = pathlib.Path(folder) / "probe_log.csv"
    motion.write_probe_log(path)
    log = read_probe_log(path)
    t0 = time.perf_counter()
    rows, ok = probes_from_frames(log, t, w, GATE_N, average=average)
    est = estimate(rows[ok, :2], rows[ok, 2:], log.radius_m)
    return est, int(ok.sum()), time.perf_counter() - t0


def pct(x):
    return f"{100 * x:.2f}"


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=20)
    args = parser.parse_args()
    register()
    out = []
    with tempfile.TemporaryDirectory() as folder:
        cases = (
            ("thesis noise", {}, (("all frames of each hold", None), ("10 nearest", 10),
                                  ("one reading", 1))),
            ("thesis noise, dtheta = pi/2 (§3.3.3)", {"dtheta_rad": "1.5707963"},
             (("all frames", None),)),
            ("thesis noise, 1 s holds", {"hold_s": "1.0"}, (("all frames", None),)),
        )  # fmt: skip
        for name, subs, averages in cases:
            runs = []
            for seed in range(args.seeds):
                path = variant(folder, f"s{seed}", seed=str(11 + seed), **subs)
                runs.append(record(f"sim://{path}"))
            first = runs[0][0]
            truth = first.true_curvature()
            floor = errors(
                estimate(first.true_rows()[:, :2], first.true_rows()[:, 2:], 0.01), truth
            )
            for label, average in averages:
                errs, usable, hosts = [], [], []
                for motion, t, w, _ in runs:
                    est, n_ok, host = derive(motion, t, w, folder, average)
                    e = errors(est, truth)
                    errs.append(e if e is not None else (np.inf, np.inf))
                    usable.append(n_ok)
                    hosts.append(host)
                e = np.array(errs)
                med, p90 = np.median(e, axis=0), np.percentile(e, 90, axis=0)
                out.append((
                    f"{name}, {label}: median / p90 of {len(runs)} seeds",
                    f"{min(usable)}-{max(usable)}/8",
                    f"{pct(floor[0])} / {pct(floor[1])}",
                    f"{pct(med[0])} / {pct(p90[0])}",
                    f"{pct(med[1])} / {pct(p90[1])}",
                    f"{np.median([r[3] for r in runs]):.2f}",
                    f"{1e3 * np.median(hosts):.1f}",
                ))  # fmt: skip
        zero = "[0.0, 0.0, 0.0]"
        quiet = variant(folder, "quiet", noise_force_N=zero, noise_torque_Nm=zero)
        motion, t, w, wall = record(f"sim://{quiet}")
        truth = motion.true_curvature()
        exact = estimate(motion.true_rows()[:, :2], motion.true_rows()[:, 2:], 0.01)
        est, n_ok, host = derive(motion, t, w, folder)
        floor = "{} / {}".format(*map(pct, errors(exact, truth)))
        err = list(map(pct, errors(est, truth)))
        out.insert(0, ("F/T chain, noiseless", f"{n_ok}/8", floor, *err, f"{wall:.2f}",
                       f"{1e3 * host:.1f}"))  # fmt: skip
    kx, ky = truth["kx"], truth["ky"]
    print(
        f"truth at the start contact: kx = {kx:.4g} 1/m (radius {100 / kx:.3g} cm), "
        f"ky = {ky:.4g} 1/m (radius {100 / ky:.3g} cm); scene time per run 5.6 s, "
        "9.6 s with 1 s holds\n"
    )
    print(
        "| case | usable probes | eq. 29 floor kx / ky % | kx error % | ky error % "
        "| emulate s | host ms |"
    )
    print("|---|---|---:|---:|---:|---:|---:|")
    for row in out:
        print("| " + " | ".join(row) + " |")


if __name__ == "__main__":
    main()
