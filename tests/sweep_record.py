"""Shared by the sweep tests: run an EP2 sweep scene through ``sim://`` to its end."""

import numpy as np
import serial

from tactile.board.stream_decoder import StreamDecoder
from tactile_protocol import constants as C
from tactile_sim.urlhandler import register


def record_sweep(url):
    """(motion, t_us, sensor, wrench (N, N m), phase, decoder counters) of its CONTACT frames."""
    register()
    port = serial.serial_for_url(url, timeout=0.005)
    decoder, msgs = StreamDecoder(), []
    end = port.emulator.motion.duration_s * 1e6 + 10_000
    while port.emulator.t_us < end:
        msgs += decoder.feed(port.read(65536))
    c = [m for m in msgs if m.type_name == "CONTACT"]
    t = np.array([m.timestamp_us for m in c], dtype=np.int64)
    sensor = np.array([m.sensor for m in c])
    wrench = np.array([[m.fx, m.fy, m.fz, m.tx, m.ty, m.tz] for m in c]) * C.FORCE_LSB_N
    phase = np.array([m.phase for m in c])
    return port.emulator.motion, t, sensor, wrench, phase, decoder.counters
