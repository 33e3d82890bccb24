"""Synthetic recordings of a sensor carrying a tool, made from the physics, for the payload
bench and tests (independent of the simulator's own model of the weight and the drift).

In the sensor frame, at orientation R(t) of the sensor in the world:

    F = F_contact + m R^T g + b_F + drift_F t + noise
    T = T_contact + c x (m R^T g) + b_T + drift_T t + noise

The board is modelled as the firmware is: it subtracts the offset a TARE took (the whole
reading at the pose it was taken at), gates contacts on the result with its own gate
(``tactile_fw.gate``), streams SAMPLE and/or CONTACT frames, and the run folder is written
with the recorder's own writer (``tactile.recording.files.Recording``) and the protocol's
own framing, so ``tactile.load_recording``, ``derive`` and ``tactile payload identify``
read it as a real one.  Poses follow the simulator's ``poses`` motion: R = Rz Ry Rx of
(roll, pitch, yaw), held for ``hold_s``, turning along the shortest arc with a (1 - cos)/2
profile in ``move_s``.
"""

import json

import numpy as np
from scipy.spatial.transform import Rotation

from tactile import logs
from tactile.board.stream_decoder import decode_bytes
from tactile.recording.files import Recording
from tactile_fw import gate as fw_gate
from tactile_protocol import constants as C
from tactile_protocol import settings as board_settings
from tactile_protocol.framing import FrameEncoder

G = np.array([0.0, 0.0, -9.81])
# Nine orientations spread over the sphere of gravity directions (roll, pitch, yaw in deg)
NINE = [
    (0, 0, 0), (90, 0, 0), (-90, 0, 0), (0, 90, 0), (0, -90, 0),
    (180, 0, 0), (45, 45, 0), (-60, 30, 45), (120, -45, 30),
]  # fmt: skip
DEVICE = {
    "n_sensors": 1, "cal_ids": [4242], "cal_crcs": [0], "sensor_model": "SYNTH",
    "enter_threshold_N": 1.39, "exit_threshold_N": 1.112, "debounce": 3, "gate": "3d",
    "streams": ["samples", "contacts"], "rate_hz": 500,
}  # fmt: skip


class Poses:
    """Holds at ``rpy_deg`` orientations: windows (s) and R(t)."""

    def __init__(self, rpy_deg, hold_s=1.0, move_s=0.5, rest_s=0.5):
        self.rot = Rotation.from_euler("xyz", np.asarray(rpy_deg, dtype=float), degrees=True)
        n = len(self.rot)
        self.t0 = rest_s + np.arange(n) * (hold_s + move_s)
        self.t1 = self.t0 + hold_s
        self.duration_s = float(self.t1[-1] + rest_s)

    def at(self, t_s):
        """R (n, 3, 3) at times ``t_s``."""
        t = np.asarray(t_s, dtype=float)
        k = np.clip(np.searchsorted(self.t0, t, side="right") - 1, 0, len(self.t0) - 1)
        out = self.rot[k].as_matrix()
        moving = np.flatnonzero((t > self.t1[k]) & (k + 1 < len(self.t0)))
        if moving.size:
            a, b = k[moving], k[moving] + 1
            s = np.clip((t[moving] - self.t1[a]) / (self.t0[b] - self.t1[a]), 0, 1)
            frac = (1 - np.cos(np.pi * s)) / 2
            step = (self.rot[a].inv() * self.rot[b]).as_rotvec()
            out[moving] = (self.rot[a] * Rotation.from_rotvec(frac[:, None] * step)).as_matrix()
        return out

    def write_log(self, path, finger=0):
        q = self.rot.as_quat()  # x, y, z, w
        rows = [
            (round(a * 1e6), round(b * 1e6), finger, 0.0, 0.0, 0.0, *map(float, (w, x, y, z)))
            for a, b, (x, y, z, w) in zip(self.t0, self.t1, q)
        ]
        logs.write_log(path, "pose", rows, end_us=round(self.duration_s * 1e6))


def weight(R, mass, com, g=G):
    F = mass * np.einsum("nji,j->ni", R, g)
    return np.hstack([F, np.cross(np.broadcast_to(com, F.shape), F)])


def readings(t, R, mass, com, bias, drift=0.0, noise=0.0, contact=None, seed=0):
    """(n, 6) what the sensor reads (module docstring); ``drift`` (6,) per s, ``noise`` (6,)
    sd, ``contact`` (n, 6) the contact's wrench."""
    rng = np.random.default_rng(seed)
    W = weight(R, mass, com) + np.asarray(bias, dtype=float) + np.outer(t, drift)
    W = W + rng.normal(size=W.shape) * noise
    return W if contact is None else W + contact


def board_frames(t, W, device=DEVICE, tare_at=None, sensor=0):
    """Capture bytes of what the board sends for readings ``W`` at ``t`` (s): less the
    offset a TARE took at time ``tare_at`` (the reading there; None: no TARE), gated."""
    counts = np.rint(W * board_settings.COUNTS_PER_N).astype(np.int64)
    if tare_at is not None:
        counts = counts - counts[int(np.searchsorted(t, tare_at))]
    dev = device
    gate = fw_gate.ContactGate(
        board_settings.to_counts(dev["enter_threshold_N"]),
        board_settings.to_counts(dev["exit_threshold_N"]),
        dev["debounce"],
        dev["gate"] == "3d",
    )
    enc, out = FrameEncoder(), bytearray()
    for ts, ft in zip(np.rint(t * 1e6).astype(np.int64).tolist(), counts.tolist()):
        phase = gate.update(*ft[:3])
        flags = C.FLAG_IN_CONTACT if phase in (fw_gate.BEGIN, fw_gate.IN) else 0
        if "samples" in dev["streams"]:
            out += enc.encode(C.MSG_SAMPLE, ts, (sensor, flags, *ft))
        if phase != fw_gate.NONE and "contacts" in dev["streams"]:
            out += enc.encode(C.MSG_CONTACT, ts, (sensor, phase, gate.contact_id, flags, *ft))
    return bytes(out)


def write_run(folder, data, device=DEVICE, command=("tactile", "record")):
    """A run folder holding capture bytes ``data``, as ``tactile record`` writes one."""
    rec = Recording(folder)
    try:
        rec.raw(data)
        msgs, _ = decode_bytes(data)
        rec.messages(msgs)
        rec.write_meta(
            {"command": list(command), "device": dict(device), "ended": "duration",
             "tared": True, "samples": rec.rows, "bytes": rec.bytes, "gaps": []}
        )  # fmt: skip
    finally:
        rec.close()
    return folder


def identification_run(folder, log, mass, com, bias=(0.0,) * 6, rpy=NINE, noise=None,
                       drift=0.0, rate_hz=500, seed=0, device=DEVICE):  # fmt: skip
    """A run of the unloaded finger held at ``rpy`` and its pose log: (poses, folder)."""
    poses = Poses(rpy)
    t = np.arange(0.0, poses.duration_s, 1.0 / rate_hz)
    sd = np.array([0.0556, 0.0556, 0.1112, 0.00282, 0.00282, 0.00282]) if noise is None else noise
    W = readings(t, poses.at(t), mass, com, bias, drift, sd, seed=seed)
    write_run(folder, board_frames(t, W, device), device)
    poses.write_log(log)
    return poses, folder


def meta_of(folder):
    return json.loads((folder / "meta.json").read_text())
