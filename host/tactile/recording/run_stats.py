"""What a recording run counts as it reads: frames, readings, contacts, the board's own
STATUS counters, and the device time its frames cover (meta.json's counts)."""

from tactile_protocol import constants as C


def span_s(first_us, last_us):
    """Device time covered, across one wrap of the u32 microsecond timestamp."""
    if first_us is None:
        return 0.0
    return ((last_us - first_us) % C.TIMESTAMP_MODULO) / 1e6


class Stats:
    """What the progress display shows; also the counters in meta.json."""

    def __init__(self):
        self.frames = 0
        self.samples = 0  # SAMPLE and CONTACT frames (one per sensor reading sent)
        self.late_samples = 0  # ... of them flagged late by the board (it missed a period)
        self.contacts_begun = 0
        self.contacts_ended = 0
        self.first_ts = None
        self.last_ts = None
        self.status = {}  # the latest STATUS per sensor (0xFF: the board)
        self.tx_dropped = 0  # frames the board says it dropped (STATUS), over its boots
        self._dropped_seen = 0  # ... the count of this boot's latest board STATUS

    def new_boot(self):
        """The board rebooted: its STATUS counters start again from 0."""
        self._dropped_seen = 0

    def add(self, msgs):
        for m in msgs:
            self.frames += 1
            if m.type_code in (C.MSG_SAMPLE, C.MSG_CONTACT):
                self.samples += 1
                self.late_samples += bool(m.flags & C.FLAG_LATE)
                self.first_ts = m.timestamp_us if self.first_ts is None else self.first_ts
                self.last_ts = m.timestamp_us
            elif m.type_code == C.MSG_STATUS:
                self.status[m.sensor] = m.to_dict()
                if m.sensor == C.SENSOR_ALL:  # (u32 counters: wrap)
                    self.tx_dropped += (m.tx_dropped - self._dropped_seen) % (1 << 32)
                    self._dropped_seen = m.tx_dropped
            if m.type_code == C.MSG_CONTACT:
                self.contacts_begun += m.phase == C.PHASE_BEGIN
                self.contacts_ended += m.phase == C.PHASE_END
