"""A stream of readings with the tool's weight and the bias removed, and its contacts gated
again on what is left.

Per sensor carrying a tool, each reading (the sensor's SAMPLE frames when the board streams
them, else its CONTACT frames: ``tactile.payload.fit.reading_rows``) gets the orientation
of its time (``tactile.payload.apply``), loses the tool's weight there and the bias
(``tactile.payload.drift.BiasTracker``: a tare on the host, then drift tracking), and goes
through a contact gate of the board's own rules and settings (``tactile_fw.gate``: the
enter and exit levels, the debounce, x-y or 3-D) on the host.

**Why the host gates again.**  The board's gate sees the raw force: a 100 g tool turned over
moves it by 2 N, above a 1.4 N gate, with nothing touching; and a press can hide under a
weight that pulls the other way.  The board could instead be told a new offset as the pose
changes, but that is a protocol command (versioned, with its vectors, in firmware and C
core) sent at the rate the wrist turns, and it would still lag the motion.  The host has the
pose log and every reading already, so contacts are gated again on the compensated wrench:
what the board called a contact but the host's gate does not is dropped; what the host's
gate finds is a contact even where the board saw none, as long as the board streams SAMPLE
frames (with CONTACT frames alone, only the board's contacts can be kept or dropped, and
nothing out of contact is seen to tare or to track the drift with: the tool's identified
bias is used).

``Compensator.arrays`` works on a recording's rows (``tactile.load_recording``),
``Compensator.messages`` on decoded frames (``derive``, ``live``, Foxglove); both keep state
between calls, so a live stream is fed batch by batch.
"""

from dataclasses import dataclass

import numpy as np

from tactile.board.stream_decoder import Contact, Sample
from tactile.errors import InputError
from tactile.payload.drift import BLOCK_S, BiasTracker
from tactile.payload.tool import weight
from tactile_fw import gate as fw_gate
from tactile_protocol import constants as C
from tactile_protocol import settings as board_settings

__all__ = ["GUARD_S", "QUIET", "Compensator", "Gate"]

QUIET = 0.5  # a reading that may move the bias: |F| below this fraction of the exit level
GUARD_S = 0.2  # ... and this long after the end of a contact (the release settling)
GAP_S = 0.05  # a silence this long (or time stepping back) ends a contact on the host
NONE = fw_gate.NONE
FRAMES = (C.MSG_SAMPLE, C.MSG_CONTACT)


@dataclass(frozen=True)
class Gate:
    """The board's contact gate settings: levels in N, debounce in readings, 3-D or x-y."""

    enter_N: float
    exit_N: float
    debounce: int = 1
    three_d: bool = False

    @classmethod
    def of_device(cls, device):
        """The gate of a board's INFO (meta.json's "device")."""
        d = device or {}
        return cls(
            float(d.get("enter_threshold_N", 0.0)),
            float(d.get("exit_threshold_N", 0.0)),
            int(d.get("debounce", 1) or 1),
            d.get("gate", "xy") == "3d",
        )

    def make(self):
        counts = board_settings.to_counts
        return fw_gate.ContactGate(
            counts(self.enter_N), counts(self.exit_N), self.debounce, self.three_d
        )


class _Sensor:
    """One sensor's orientation, tool, bias and host gate."""

    def __init__(self, sensor, tool, orient, gate, bias, track):
        self.sensor, self.tool, self.orient, self.track = sensor, tool, orient, track
        self.gate_settings = gate
        self.gate = gate.make()
        self.tracker = BiasTracker(bias)
        self.last_t = None
        self.last_contact_t = -np.inf
        self.readings = self.contacts = 0

    def bias(self):
        return self.tool.bias if self.tracker.bias is None else self.tracker.bias

    def process(self, t_us, wrench):
        """(compensated (k, 6), host phase (k,), host contact id (k,)) of readings at
        ``t_us`` (k,) (the log's clock) reading ``wrench`` (k, 6) in N and N*m."""
        R, _ = self.orient.at(self.sensor, t_us)
        x = np.asarray(wrench, dtype=float) - weight(R, self.tool)
        t_s = np.asarray(t_us, dtype=np.int64) * 1e-6
        comp = np.empty_like(x)
        phase = np.empty(len(x), dtype=np.int64)
        cid = np.empty(len(x), dtype=np.int64)
        block = np.floor(t_s / BLOCK_S).astype(np.int64)
        cuts = np.flatnonzero(np.diff(block)) + 1
        for a, b in zip(np.r_[0, cuts], np.r_[cuts, len(x)]):
            if self.track:
                self.tracker.advance(t_s[a])  # the block before closes first
            comp[a:b] = x[a:b] - self.bias()
            since = self._gate(t_s[a:b], comp[a:b], phase[a:b], cid[a:b])
            if self.track:
                low = np.linalg.norm(comp[a:b, :3], axis=1) < QUIET * self.gate_settings.exit_N
                quiet = (phase[a:b] == NONE) & low & (since > GUARD_S)
                self.tracker.add(t_s[a:b], x[a:b], quiet)
        self.readings += len(x)
        return comp, phase, cid

    def _gate(self, t_s, comp, phase, cid):
        """Run the host gate over one block; fills ``phase`` and ``cid``; returns the time
        since the last reading in contact, per reading."""
        counts = np.rint(comp[:, :3] * board_settings.COUNTS_PER_N).astype(np.int64).tolist()
        since = np.empty(len(t_s))
        gate = self.gate
        for i, (t, (fx, fy, fz)) in enumerate(zip(t_s.tolist(), counts)):
            if self.last_t is not None and not 0 <= t - self.last_t <= GAP_S:
                gate.reset()  # a silence (contacts-only stream) or a reboot ends a contact
            self.last_t = t
            p = gate.update(fx, fy, fz)
            phase[i], cid[i] = p, gate.contact_id
            if p != NONE:
                self.last_contact_t = t
                self.contacts += p == fw_gate.BEGIN
            since[i] = t - self.last_contact_t
        return since

    def report(self):
        t = self.tracker
        return {
            "sensor": self.sensor,
            "readings": self.readings,
            "contacts": self.contacts,
            "bias": [float(v) for v in self.bias()],
            "bias_from": "the tool's identified bias" if t.bias is None else "the host's tare",
            "moves": t.moves,
            "rebias": t.log,
        }


class Compensator:
    """Compensation and host gating of the sensors ``tools`` (``Tool`` or a list, one per
    sensor) are for, through ``orient`` (``Orientations``), on a board of ``device`` (its
    INFO: the gate and the streams).  ``bias``: {sensor: (6,)} to start from (default: a
    tare on the host); ``track``: follow the drift."""

    def __init__(self, tools, orient, device, bias=None, track=True):
        tools = [tools] if not isinstance(tools, list | tuple) else list(tools)
        gate = Gate.of_device(device)
        self.samples = "samples" in ((device or {}).get("streams") or [])
        self.sensors = {}
        for tool in tools:
            if tool.sensor in self.sensors:
                raise InputError(f"two tools for sensor {tool.sensor}")
            if not orient.covers(tool.sensor):
                raise InputError(
                    f"{orient.path}: no pose of sensor {tool.sensor}, whose tool is given"
                )
            start = (bias or {}).get(tool.sensor)
            follow = track and self.samples  # CONTACT frames alone are all loaded
            self.sensors[tool.sensor] = _Sensor(tool.sensor, tool, orient, gate, start, follow)

    def report(self):
        """Per sensor: readings, host contacts, the bias now and where it came from, and the
        tracker's log (meta.json's "payload")."""
        return [s.report() for s in self.sensors.values()]

    def flush(self):
        for s in self.sensors.values():
            s.tracker.flush()

    def _readings(self, s, sensor, is_sample):
        mine = sensor == s
        return mine, np.flatnonzero(mine & (is_sample if self.samples else ~is_sample))

    def prime(self, sensor, is_sample, t_us, wrench):
        """Tare each sensor from the first steady stretch of these rows (a whole recording,
        before ``arrays`` runs over it from its start): every reading then has the bias,
        those before the tare too."""
        sensor, is_sample = np.asarray(sensor), np.asarray(is_sample, dtype=bool)
        t_us, W = np.asarray(t_us, dtype=np.int64), np.asarray(wrench, dtype=float)
        for s, state in self.sensors.items():
            _, rows = self._readings(s, sensor, is_sample)
            if state.track and state.tracker.bias is None and rows.size:
                state.tracker.bias = first_tare(state, t_us[rows], W[rows], state.tracker.log)

    def arrays(self, sensor, is_sample, t_us, wrench, phase, contact_id):
        """Per row (n,) of frames: (wrench (n, 6) compensated, host phase (n,), host contact
        id (n,)).  Rows of sensors without a tool keep theirs; a CONTACT row that repeats a
        SAMPLE row's reading takes that row's values."""
        W = np.array(wrench, dtype=float).reshape(-1, 6)
        ph, cid = np.array(phase, dtype=np.int64), np.array(contact_id, dtype=np.int64)
        sensor, is_sample = np.asarray(sensor), np.asarray(is_sample, dtype=bool)
        t_us = np.asarray(t_us, dtype=np.int64)
        for s, state in self.sensors.items():
            mine, rows = self._readings(s, sensor, is_sample)
            W[rows], ph[rows], cid[rows] = state.process(t_us[rows], W[rows])
            twins = np.flatnonzero(mine & ~is_sample) if self.samples else rows[:0]
            if twins.size and rows.size:
                k = rows[np.clip(np.searchsorted(rows, twins) - 1, 0, None)]
                W[twins], ph[twins], cid[twins] = W[k], ph[k], cid[k]
        return W, ph, cid

    def _frames_of(self, msgs, times_us):
        """(indices, sensor, is_sample, t_us, wrench) of the SAMPLE/CONTACT frames of the
        tools' sensors in ``msgs``."""
        frame = [
            i for i, m in enumerate(msgs) if m.type_code in FRAMES and m.sensor in self.sensors
        ]
        sub = [msgs[i] for i in frame]
        if times_us is None:
            t = np.array([m.timestamp_us for m in sub], dtype=np.int64)
        else:
            t = np.asarray(times_us, dtype=np.int64)[frame]
        wrench = np.array([(m.fx, m.fy, m.fz, m.tx, m.ty, m.tz) for m in sub], dtype=float)
        wrench = wrench.reshape(-1, 6) * np.array(board_settings.WRENCH_LSB)
        is_sample = np.array([m.type_code == C.MSG_SAMPLE for m in sub], dtype=bool)
        return (
            np.array(frame, dtype=np.int64),
            np.array([m.sensor for m in sub]),
            is_sample,
            t,
            wrench,
        )

    def whole(self, msgs, times_us=None):
        """``messages`` of a whole recording: the host tares first (``prime``), so every
        reading has the bias, and the last block of readings is closed."""
        _, sensor, is_sample, t, wrench = self._frames_of(msgs, times_us)
        self.prime(sensor, is_sample, t, wrench)
        out = self.messages(msgs, times_us)
        self.flush()
        return out

    def messages(self, msgs, times_us=None):
        """(frames, index): ``msgs`` with every reading of a tool's sensor compensated and its
        contacts those of the host's gate (module docstring); ``index`` (m,) the input frame
        each output one comes from.  ``times_us``: each message's time in the log's clock
        (default: the board's stamps)."""
        frame, sensor, is_sample, t, wrench = self._frames_of(msgs, times_us)
        if not len(frame):
            return list(msgs), np.arange(len(msgs))
        none = np.full(len(frame), -1)
        W, ph, cid = self.arrays(sensor, is_sample, t, wrench, none, np.zeros(len(frame)))
        counts = np.rint(W / np.array(board_settings.WRENCH_LSB)).astype(np.int64).tolist()
        out, index = [], []
        at = dict(zip(frame.tolist(), range(len(frame))))
        for i, m in enumerate(msgs):
            j = at.get(i)
            made = (
                [m]
                if j is None
                else self._frames(m, is_sample[j], int(ph[j]), int(cid[j]), counts[j])
            )
            out.extend(made)
            index.extend([i] * len(made))
        return out, np.array(index, dtype=np.int64)

    def _frames(self, m, is_sample, phase, cid, ft):
        """The frames one input frame becomes: its SAMPLE compensated, and a CONTACT where
        the host's gate has one (a board's CONTACT beside a SAMPLE stream: none)."""
        if self.samples and not is_sample:
            return []
        flags = m.flags & ~C.FLAG_IN_CONTACT
        if phase in (fw_gate.BEGIN, fw_gate.IN):
            flags |= C.FLAG_IN_CONTACT
        out = [Sample(m.seq, m.timestamp_us, m.sensor, flags, *ft)] if is_sample else []
        if phase != NONE:
            out.append(Contact(m.seq, m.timestamp_us, m.sensor, phase, cid & 0xFFFF, flags, *ft))
        return out


def first_tare(state, t_us, wrench, log):
    """The bias a fresh tracker takes at the first steady stretch of one sensor's readings
    (``t_us``, ``wrench``) at ``state``'s orientations, or None; its entry goes to ``log``."""
    R, _ = state.orient.at(state.sensor, t_us)
    x = np.asarray(wrench, dtype=float) - weight(R, state.tool)
    tracker = BiasTracker()
    t_s = np.asarray(t_us, dtype=np.int64) * 1e-6
    step = max(1, round(len(x) * 0.02))
    for a in range(0, len(x), step):  # in pieces: stop at the tare, not the end
        tracker.add(t_s[a : a + step], x[a : a + step], np.ones(len(x[a : a + step]), bool))
        if tracker.bias is not None:
            log.extend(tracker.log)
            return tracker.bias
    return None


def words(report):
    """One line of a sensor's ``Compensator.report`` entry, for a command's summary."""
    moved = [e for e in report["rebias"] if "moves" in e]
    most = max(
        (np.linalg.norm(np.subtract(e["bias_after"][:3], e["bias_before"][:3])) for e in moved),
        default=0.0,
    )
    bias = np.asarray(report["bias"])
    return (
        f"payload: sensor {report['sensor']}: the tool's weight removed from"
        f" {report['readings']:,} readings; {report['contacts']:,} contact"
        f"{'s' * (report['contacts'] != 1)} on the host's gate; bias"
        f" ({', '.join(f'{v * 1e3:.1f}' for v in bias[:3])}) mN from {report['bias_from']},"
        f" moved {report['moves']:,} times by drift tracking ({len(moved):,} runs between"
        f" contacts, at most {most * 1e3:.1f} mN a run)"
    )
