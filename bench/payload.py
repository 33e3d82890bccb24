"""The tool's weight and the gauges' drift: identification error, the weight left after
compensation, contacts from the weight, and EP1/EP2 with and without ``--payload`` against
the weightless, drift-free run (docs/rig.md, "Bench").

Parts (``--parts``, all by default):

- ``identify``: a tool identified from <= 9 poses (``tactile payload identify``'s
  ``identify_run``): mass and centre-of-mass error, and the force its weight leaves after
  compensation, rms over 2,000 random orientations (target <= 10 mN for 10-100 g tools).
  Synthetic runs from the physics (``payload_synth``: the thesis's sensor noise, 0.02 N/min
  of drift, 500 Hz, 1 s holds), then the simulator's ``payload_poses`` and its case
  generator's ``identify`` cases;
- ``turn``: contacts.csv rows from a 50-100 g tool turned through 180 deg touching nothing,
  without and with ``--payload`` (target 0 with);
- ``ep1``, ``ep2``: the simulator's ``ep1_roll_weighted`` (at 5 N and 1.5 N) and
  ``ep2_sweep_wrist`` (sphere, saddle) and its generator's cases, each recorded without and
  with ``--payload`` and as its weightless, drift-free twin (same seed); EP1's curvature
  error, EP2's S and radius errors (target: with ``--payload`` within 1.2 x the twin's).

The simulator's parts run when it has the weight (``tactile_sim.weight_cases``); ``--final``
adds the held-out cases (only for the final bench).  Run: ``.venv/bin/python
bench/payload.py [--seeds N] [--cases N] [--parts identify,turn,ep1,ep2]``.
"""

import argparse
import contextlib
import importlib.util
import io
import json
import pathlib
import re
import sys
import tempfile
import tomllib

import numpy as np
import payload_synth as synth
from bench_args import positive_int
from scipy.spatial.transform import Rotation

from tactile.cli.main import main as tactile
from tactile.commands.derive import derive
from tactile.errors import DataError
from tactile.logs.read import read_probe_log
from tactile.payload import Tool, write_tool
from tactile.payload import weight as tool_weight
from tactile.payload.fit import identify_run

PARTS = ("identify", "turn", "ep1", "ep2")
DRIFT = np.r_[np.array([0.6, -0.48, 0.64]) * 0.02 / 60, 0, 0, 0]  # 0.02 N/min
HAVE_SIM = importlib.util.find_spec("tactile_sim.weight_cases") is not None
SCENES = pathlib.Path(__file__).resolve().parents[1] / "sim" / "tactile_sim" / "scenes"


def weight_left_mN(truth, got, n=2000, seed=0):
    """rms |F| (mN) of the truth's weight less the identified one's over random poses."""
    R = Rotation.random(n, random_state=seed).as_matrix()
    left = tool_weight(R, truth)[:, :3] - tool_weight(R, got)[:, :3]
    return 1e3 * float(np.sqrt(np.mean(np.sum(left**2, axis=1))))


def _row(name, truth, got):
    return {
        "case": name,
        "mass_g": round(truth.mass_kg * 1e3, 1),
        "mass_err_g": round(abs(got.mass_kg - truth.mass_kg) * 1e3, 3),
        "com_err_mm": round(float(np.linalg.norm(got.com_m - truth.com_m)) * 1e3, 2),
        "left_mN": round(weight_left_mN(truth, got), 2),
    }


def identify_synthetic(seeds, tmp):
    rows = []
    for mass in (0.01, 0.03, 0.1):
        for seed in range(seeds):
            truth = Tool(mass, [0.02, 0.001 * seed, -0.002])
            d = tmp / f"id_{mass}_{seed}"
            synth.identification_run(d / "run", d / "poses.csv", mass, truth.com_m,
                                     bias=[0.3, -0.1, 0.2, 0.01, 0, -0.01], drift=DRIFT,
                                     seed=1000 * seed + round(mass * 1e3))  # fmt: skip
            got, _ = identify_run(d / "run", d / "poses.csv")
            rows.append(_row(f"synthetic {mass * 1e3:.0f} g seed {seed}", truth, got))
    return rows


def _quiet(argv):
    """``tactile ARGV`` in process, its output kept: (exit code, stdout)."""
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = tactile(argv)
    return code, out.getvalue() + err.getvalue()


def _toml(value):
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, str):
        return json.dumps(value)
    if isinstance(value, dict):
        return "{ " + ", ".join(f"{k} = {_toml(v)}" for k, v in value.items()) + " }"
    if isinstance(value, list | tuple):
        return "[" + ", ".join(_toml(v) for v in value) + "]"
    return repr(float(value)) if isinstance(value, float) else str(value)


def write_scene(path, tables):
    lines = []
    for name, keys in tables.items():
        lines += [f"[{name}]", *(f"{k} = {_toml(v)}" for k, v in keys.items()), ""]
    path.write_text("\n".join(lines))
    return path


def weightless(tables):
    """The scene's twin without the tool and the drift (same seed, same motion)."""
    out = {k: dict(v) for k, v in tables.items()}
    out["tool"] = {"mass_kg": 0.0, "com_m": [0.0, 0.0, 0.0]}
    for key in ("drift_counts_per_s", "bias_walk_counts_per_sqrt_s", "temperature_C",
                "bias_counts_per_C"):  # fmt: skip
        out.get("sensor", {}).pop(key, None)
    return out


def record(scene, tmp, name, tools=()):
    """Record ``scene`` (a TOML path) through sim:// with its robot log; the run folder."""
    from tactile_sim.emulator.device import build_motion
    from tactile_sim.emulator.scene import load_scene

    motion = build_motion(load_scene(str(scene)))
    log = tmp / f"{name}.log.csv"
    (motion.write_probe_log if hasattr(motion, "write_probe_log") else motion.write_pose_log)(log)
    _with_probe(log)
    out = tmp / name
    more = [a for t in tools for a in ("--payload", str(t))]
    code, said = _quiet(["record", "--port", f"sim://{scene}", "--pose-log", str(log), "-o",
                         str(out), "--quiet", *more])  # fmt: skip
    return out, log, motion, code, said


def _with_probe(log):
    """A poses log has no fingertip: give it one, so derive can run (contacts.csv)."""
    text = log.read_text()
    if "# probe:" not in text:
        head, rest = text.split("\n", 1)
        log.write_text(f"{head}\n# probe: sphere radius_m=0.012 centre_m=0.03,0,0\n{rest}")


def tool_files(tables, tmp, name):
    t = tables.get("tool", {})
    n = tables.get("board", {}).get("sensors", 1)
    cal = tables.get("sensor", {}).get("cal_id", 1)
    paths = []
    for s in range(n):
        path = tmp / f"{name}.tool{s}.json"
        write_tool(path, Tool(t.get("mass_kg", 0.0), t.get("com_m", [0, 0, 0]), sensor=s,
                              cal_id=cal))  # fmt: skip
        paths.append(path)
    return paths


def sim_cases(family, final, limit):
    from tactile_sim.weight_cases import cases

    picked = [c for c in cases("bench") if c.family == family][:limit]
    if final:
        picked += [c for c in cases("held_out", final=True) if c.family == family][:limit]
    return [(f"{c.name} ({c.split})", c.scene, c.truth) for c in picked]


def reseeded(cases, seeds):
    """Each generator case with its scene's seed and the next ``seeds - 1``: one run's
    error is mostly noise, so a case is judged over several."""
    out = []
    for name, tables, _ in cases:
        for i in range(seeds):
            t = {k: dict(v) for k, v in tables.items()}
            t["scene"]["seed"] = int(t["scene"]["seed"]) + i
            out.append((f"{name} seed {i}", t))  # e.g. "case005_ep1 (held_out) seed 2"
    return out


def _safe(name):
    """``name`` as a file name: runs of anything but letters, digits, dots and dashes as _."""
    return re.sub(r"[^\w.-]+", "_", name)


def _group(name):
    """A run's group: its shipped scene and force or object, or the generator's split."""
    if name.startswith("case"):
        return "held-out cases" if "(held_out)" in name else "generator bench cases"
    return name.rsplit(" seed", 1)[0]


def shipped(name):
    return name, tomllib.loads((SCENES / f"{name}.toml").read_text()), {}


def identify_sim(tmp, final, limit):
    rows = []
    for name, tables, truth in [shipped("payload_poses"), *sim_cases("identify", final, limit)]:
        tag = name.split(" ")[0]
        scene = write_scene(tmp / f"{tag}.toml", tables)
        out, log, *_ = record(scene, tmp, tag)
        t = tables["tool"]
        want = Tool(t["mass_kg"], t["com_m"])
        try:
            got, _ = identify_run(out, log)
        except DataError as exc:
            refused = truth.get("orientations") == "one_axis" or want.mass_kg == 0
            rows.append({"case": name, "mass_g": round(want.mass_kg * 1e3, 1),
                         "refused": str(exc)[:60], "as_it_should": refused})  # fmt: skip
            continue
        rows.append(_row(name, want, got))
    return rows


def _contacts(folder):
    path = folder / "contacts.csv"
    if not path.exists():
        return None
    return sum(1 for ln in path.read_text().splitlines() if ln and ln[0] not in "#x")


def turn_part(tmp, final, limit, seeds):
    rows = []
    for seed in range(seeds):  # synthetic: tared pointing down, turned over in 30 deg steps
        poses = synth.Poses([(0, 90 - a, 0) for a in range(0, 181, 30)], hold_s=0.5, move_s=1.0)
        t = np.arange(0.0, poses.duration_s, 1 / 500)
        sd = np.r_[[0.0556, 0.0556, 0.1112], [0.00282] * 3]
        W = synth.readings(t, poses.at(t), 0.1, [0.02, 0, 0], 0.0, 0.0, sd, seed=seed)
        device = {**synth.DEVICE, "enter_threshold_N": 1.0, "exit_threshold_N": 0.8}
        for pay in (False, True):
            d = tmp / f"turn{seed}{pay}"
            synth.write_run(d, synth.board_frames(t, W, device, tare_at=0.2), device)
            poses.write_log(tmp / "turn.csv")
            _with_probe(tmp / "turn.csv")

            tools = [("tool.json", Tool(0.1, [0.02, 0, 0], cal_id=4242))] if pay else None
            with contextlib.suppress(DataError):
                derive(d, tmp / "turn.csv", payload=tools)
            rows.append({"case": f"synthetic 100 g seed {seed}", "payload": pay,
                         "contacts": _contacts(d) or 0})  # fmt: skip
    if HAVE_SIM:
        for name, tables, _ in [shipped("payload_turn"), *sim_cases("turn", final, limit)]:
            tag = name.split(" ")[0]
            scene = write_scene(tmp / f"{tag}.toml", tables)
            tools = tool_files(tables, tmp, tag)
            for pay in (False, True):
                out, *_ = record(scene, tmp, f"{tag}{pay}", tools if pay else ())
                rows.append({"case": name, "payload": pay, "contacts": _contacts(out) or 0})
    return rows


def _ep1_error(folder, log, truth):
    """Error of kx and ky (rms) relative to the truth's largest |curvature| (a cylinder has
    a zero one), or None without an estimate."""
    radius = read_probe_log(log).radius_m
    code, said = _quiet(["ep1", "estimate", str(folder / "probes.csv"), "--finger-radius",
                         repr(radius), "--json"])  # fmt: skip
    if code != 0:
        return None
    got = json.loads(said.splitlines()[0])
    k = np.array([truth["kx"], truth["ky"]], dtype=float)
    return float(np.sqrt(np.mean((np.array([got["kx"], got["ky"]]) - k) ** 2)) / np.abs(k).max())


def _shipped(scene, key, values, label, seeds):
    """(name, tables) of the shipped ``scene`` with ``[motion] key`` at each of ``values``,
    each at ``seeds`` seeds from 11."""
    base = tomllib.loads((SCENES / f"{scene}.toml").read_text())
    cases = []
    for value in values:
        for seed in range(seeds):
            tables = {k: dict(v) for k, v in base.items()}
            tables["scene"]["seed"] = 11 + seed
            tables["motion"][key] = value
            cases.append((f"{scene} {label.format(value)} seed {seed}", tables))
    return cases


def ep1_part(tmp, final, limit, seeds):
    rows = []
    cases = _shipped("ep1_roll_weighted", "normal_force_N", (5.0, 1.5), "{:g} N", seeds)
    cases += reseeded(sim_cases("ep1", final, limit), seeds)
    for name, tables in cases:
        group = _group(name)
        errs = {}
        for kind, scene_tables, tools in (
            ("weightless", weightless(tables), ()),
            ("without", tables, ()),
            ("with", tables, tool_files(tables, tmp, _safe(name))),
        ):
            scene = write_scene(tmp / f"{name}_{kind}.toml".replace(" ", "_"), scene_tables)
            out, log, motion, code, _ = record(
                scene, tmp, f"{name}_{kind}".replace(" ", "_"), tools
            )
            errs[kind] = _ep1_error(out, log, motion.true_curvature()) if code == 0 else None
        rows.append({"case": name, **{k: _pct(v) for k, v in errs.items()},
                     "ratio": _ratio(errs), "_group": group, "_errs": errs})  # fmt: skip
    return rows, summary(rows, lambda e: e, "curvature error, %")


def _pct(v):
    return None if v is None else round(100 * v, 1)


def _ratio(errs):
    if errs.get("with") is None or not errs.get("weightless"):
        return None
    return round(errs["with"] / errs["weightless"], 2)


S_TRUE = {"sphere": 1.0, "cylinder": 0.5, "saddle": 0.0}  # the saddles have k1 = -k2


def _ep2(folder, truth_radius, obj):
    code, said = _quiet(["ep2", "analyze", str(folder / "contacts.csv"), "--json"])
    if code != 0:
        return None
    got = json.loads(said.splitlines()[0])
    patch = got["patches"][0] if "patches" in got else got
    radius = patch.get("radius")
    off = None if obj == "saddle" or radius is None else abs(radius - truth_radius)
    return {"S_err": abs(patch["S"] - S_TRUE[obj]), "radius_err": off}


def ep2_part(tmp, final, limit, seeds):
    rows = []
    cases = _shipped("ep2_sweep_wrist", "object", ("sphere", "saddle"), "{}", seeds)
    cases += reseeded(sim_cases("ep2", final, limit), seeds)
    for name, tables in cases:
        obj = tables["motion"]["object"]
        radius = tables["motion"].get("radius_m", 0.05)
        got = {}
        for kind, scene_tables, tools in (
            ("weightless", weightless(tables), ()),
            ("without", tables, ()),
            ("with", tables, tool_files(tables, tmp, _safe(name))),
        ):
            tag = _safe(f"{name}_{kind}")
            out, _, _, code, _ = record(
                write_scene(tmp / f"{tag}.toml", scene_tables), tmp, tag, tools
            )
            got[kind] = _ep2(out, radius, obj) if code == 0 else None
        group = _group(name)
        rows.append({"case": name, **{k: _ep2_text(v) for k, v in got.items()},
                     "_group": group, "_errs": got})  # fmt: skip
    return rows, summary(rows, lambda e: e["S_err"], "S error", 1.0) + summary(
        rows, lambda e: e["radius_err"], "radius error, mm", 1e3
    )


def summary(rows, value, what, scale=100.0):
    """Per group of cases: the rms of ``value`` over its cases for the weightless twin and
    with ``--payload``, their ratio (target <= 1.2), and the runs without an answer."""
    out = []
    for group in dict.fromkeys(r["_group"] for r in rows):
        mine = [r["_errs"] for r in rows if r["_group"] == group]
        rms, missing = {}, {}
        for kind in ("weightless", "without", "with"):
            got = [value(e[kind]) for e in mine if e.get(kind) is not None]
            got = [v for v in got if v is not None]
            missing[kind] = len(mine) - len(got)
            rms[kind] = float(np.sqrt(np.mean(np.square(got)))) * scale if got else None
        ratio = rms["with"] / rms["weightless"] if rms["with"] and rms["weightless"] else None
        none = "/".join(str(missing[k]) for k in ("weightless", "without", "with"))
        out.append({"group": group, "what": what, "runs": len(mine),
                    **{k: None if v is None else round(v, 3) for k, v in rms.items()},
                    "ratio": None if ratio is None else round(ratio, 2),
                    "no answer (weightless/without/with)": none})  # fmt: skip
    return out


def _ep2_text(v):
    if v is None:
        return "refused"
    r = "" if v["radius_err"] is None else f", radius {v['radius_err'] * 1e3:.2f} mm"
    return f"S {v['S_err']:.3f}{r}"


def table(rows):
    if not rows:
        return "(none)"
    keys = [k for k in dict.fromkeys(k for r in rows for k in r) if not k.startswith("_")]
    out = ["| " + " | ".join(keys) + " |", "|" + "---|" * len(keys)]
    out += ["| " + " | ".join(str(r.get(k, "")) for k in keys) + " |" for r in rows]
    return "\n".join(out)


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--seeds", type=positive_int, default=3, help="synthetic seeds per case")
    p.add_argument("--cases", type=positive_int, default=4, help="generator cases per family")
    p.add_argument("--parts", default=",".join(PARTS), help="which parts, comma-separated")
    p.add_argument("--final", action="store_true", help="add the held-out cases")
    args = p.parse_args(argv)
    parts = args.parts.split(",")
    with tempfile.TemporaryDirectory() as d:
        tmp = pathlib.Path(d)
        if "identify" in parts:
            rows = identify_synthetic(args.seeds, tmp)
            if HAVE_SIM:
                rows += identify_sim(tmp, args.final, args.cases)
            left = [r["left_mN"] for r in rows if "left_mN" in r]
            print(f"## identify (weight left after compensation: max {max(left):.2f} mN rms)\n")
            print(table(rows) + "\n")
        if "turn" in parts:
            print("## turn (contacts.csv rows, a tool turned over touching nothing)\n")
            print(table(turn_part(tmp, args.final, args.cases, args.seeds)) + "\n")
        for name, part in (("ep1", ep1_part), ("ep2", ep2_part)):
            if name not in parts:
                continue
            if not HAVE_SIM:
                print(
                    f"## {name}: the simulator has no tool weight yet (tactile_sim.weight_cases)\n"
                )
                continue
            rows, sums = part(tmp, args.final, args.cases, args.seeds)
            print(f"## {name} (error: weightless twin, without and with --payload)\n")
            print(table(rows) + "\n")
            print(f"## {name}: rms over the runs of each group (ratio: with / weightless)\n")
            print(table(sums) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
