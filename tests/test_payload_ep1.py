"""EP1 through a weighted fingertip: the probe log's orientation columns, and probes.csv with
the weight removed as without it (derive with a payload)."""

import numpy as np
import pytest
from conftest import load_bench

from tactile.commands.derive import derive
from tactile.ep1.probes import read_probes
from tactile.errors import InputError
from tactile.logs.read import read_probe_log
from tactile.payload import Tool
from tactile_sim.emulator.device import build_motion
from tactile_sim.emulator.scene import load_scene

synth = load_bench("payload_synth")
TIP = Tool(0.03, [0.02, 0.0, 0.0], cal_id=4242)
DEVICE = {**synth.DEVICE, "enter_threshold_N": 1.0, "exit_threshold_N": 0.8}


@pytest.fixture(scope="module")
def rolled(tmp_path_factory):
    """The ep1_roll scene's contact wrench on the simulator's rolling finger (pointing down,
    turning as it rolls), with and without a 30 g fingertip, as synthetic board runs whose
    weight follows the finger's true attitude (the host sees only the probe log's holds)."""
    d = tmp_path_factory.mktemp("roll")
    motion = build_motion(load_scene("ep1_roll"))
    log = d / "probes_log.csv"
    motion.write_probe_log(log)
    t = np.arange(0.0, motion.duration_s, 1 / 1000)
    contact = motion.wrench_at(t).T
    R = np.array([motion.orientation_at(x) for x in t])
    for name, mass in (("weightless", 0.0), ("weighted", TIP.mass_kg)):
        W = synth.readings(t, R, mass, TIP.com_m, 0.0, 0.0, [0.005] * 3 + [2e-4] * 3, contact)
        synth.write_run(d / name, synth.board_frames(t, W, DEVICE, tare_at=0.2), DEVICE)
    return d, log


def test_the_probe_logs_orientations_are_read(rolled):
    d, log = rolled
    got = read_probe_log(log)
    assert got.q_start.shape == (8, 4) and np.allclose(np.linalg.norm(got.q_end, axis=1), 1)
    lines = log.read_text().splitlines()
    half = [ln.rsplit(",", 4)[0] if ln[0].isdigit() else ln for ln in lines]
    half = [ln.replace(",qw_end,qx_end,qy_end,qz_end", "") for ln in half]
    bad = d / "half.csv"
    bad.write_text("\n".join(half) + "\n")
    with pytest.raises(InputError, match="orientation columns without qw_end,qx_end,qy_end,qz_end"):
        read_probe_log(bad)
    k = next(i for i, ln in enumerate(lines) if ln.startswith("probe,")) + 1
    first = lines[k].split(",")
    first[5] = "0.9"  # qw of probe 0: |q| no longer 1
    long = lines[:k] + [",".join(first)] + lines[k + 1 :]
    bad.write_text("\n".join(long) + "\n")
    with pytest.raises(InputError, match=r":6: column 'qw': quaternion .* is not unit length"):
        read_probe_log(bad)


def test_probes_with_the_weight_removed_match_the_weightless_run(rolled):
    d, log = rolled
    derive(d / "weightless", log)
    derive(d / "weighted", log, payload=[("tip.json", TIP)])
    plain = np.hstack(read_probes(d / "weightless" / "probes.csv"))
    removed = np.hstack(read_probes(d / "weighted" / "probes.csv"))
    assert np.abs(removed - plain)[:, 2:].max() < 0.02 * np.abs(plain[:, 2:]).max()


def test_without_the_payload_the_weight_shows(rolled):
    d, log = rolled
    derive(d / "weightless", log)
    plain = np.hstack(read_probes(d / "weightless" / "probes.csv"))
    derive(d / "weighted", log)
    left = np.hstack(read_probes(d / "weighted" / "probes.csv"))
    assert np.abs(left - plain)[:, 2:].max() > 0.1 * np.abs(plain[:, 2:]).max()
