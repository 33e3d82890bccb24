"""``sim://SCENE[?realtime=1&faults=0&core=c&board_id=HEX]``: an emulated board as an in-process
pyserial port.

SCENE is a shipped scene name (``sim://press``) or a path
(``sim:///abs/path.toml``).  Reading advances the emulator's simulated time
(as fast as possible by default, or paced by the wall clock with
``realtime=1``) until the bytes asked for exist or the timeout has passed
in simulated time; unpaced, the port says so (``simulated_time``), and a recorder claims no
host time for its frames.  ``faults=0`` ignores the scene's ``[link]`` faults;
``core=c`` (or ``python``) runs that firmware core instead of the scene's.  Each open is
a board of its own (its own HELLO ``board_id``, drawn at random); ``board_id=`` and 16 hex
digits names it, so that a port opened again is the same board, rebooted.
Modelled on pyserial's ``protocol_loop``: everything the host does with a
real port works here, so one code path serves both.
"""

import time
import urllib.parse

from serial.serialutil import PortNotOpenError, SerialBase, SerialException, Timeout

from tactile_sim.emulator import load_scene
from tactile_sim.emulator.cores import CORES
from tactile_sim.emulator.device import EmulatedBoard
from tactile_sim.emulator.link_faults import LinkFaults

STEP_US = 2000


def _board_id(url, text):
    try:
        board_id = bytes.fromhex(text)
    except ValueError:
        board_id = b""
    if len(board_id) != 8:
        raise SerialException(f"{url}: board_id must be 16 hex digits (8 bytes), got {text!r}")
    return board_id


class Serial(SerialBase):
    def open(self):
        if self.is_open:
            raise SerialException("Port is already open.")
        if self._port is None:
            raise SerialException("Port must be configured before it can be used.")
        scene_name, options = self._parse(self.port)
        # A bad scene raises its SceneError (a ValueError, as pyserial's bad settings do):
        # the CLI reports it as bad input (exit 2), naming file, section and key.
        scene = load_scene(scene_name)
        self.emulator = EmulatedBoard(scene, core=options["core"], board_id=options["board_id"])
        self.faults = LinkFaults.from_scene(scene.link) if options["faults"] else None
        self.realtime = options["realtime"]
        self.simulated_time = not self.realtime  # the host maps no wall clock onto its stamps
        self._buffer = bytearray()
        self._t0 = time.monotonic()
        self.is_open = True
        self.emulator.host_opened()

    @staticmethod
    def _parse(url):
        parts = urllib.parse.urlsplit(url)
        if parts.scheme != "sim":
            raise SerialException(f"expected sim://SCENE, got {url!r}")
        name = parts.netloc + parts.path
        query = urllib.parse.parse_qs(parts.query)
        options = {"realtime": False, "faults": True, "core": None, "board_id": None}
        for key, values in query.items():
            if key not in options:
                raise SerialException(
                    f"{url}: unknown option {key!r} (realtime, faults, core, board_id)"
                )
            if key == "board_id":
                options[key] = _board_id(url, values[-1])
            elif key == "core":
                if values[-1] not in CORES:
                    raise SerialException(f"{url}: core must be one of {', '.join(CORES)}")
                options[key] = values[-1]
            else:
                options[key] = values[-1] not in ("0", "false", "no")
        return name, options

    def _reconfigure_port(self):
        pass

    def close(self):
        self.is_open = False
        super().close()

    def _advance(self, dt_us):
        emu = self.emulator
        target = emu.t_us + dt_us
        if self.realtime:
            wait = target / 1e6 - (time.monotonic() - self._t0)
            if wait > 0:
                time.sleep(wait)
        emu.run_until(target)
        data = emu.read_host()
        if self.faults is not None and data:
            data = self.faults.apply(data)
        self._buffer += data

    @property
    def in_waiting(self):
        if not self.is_open:
            raise PortNotOpenError()
        if not self._buffer:
            self._advance(0)
        return len(self._buffer)

    def read(self, size=1):
        if not self.is_open:
            raise PortNotOpenError()
        budget_us = None if self._timeout is None else int(self._timeout * 1e6)
        spent = 0
        while len(self._buffer) < size:
            if budget_us is not None and spent >= budget_us:
                break
            step = STEP_US if budget_us is None else max(1, min(STEP_US, budget_us - spent))
            self._advance(step)
            spent += step
        out = bytes(self._buffer[:size])
        del self._buffer[:size]
        return out

    def write(self, data):
        if not self.is_open:
            raise PortNotOpenError()
        data = bytes(data)
        self.emulator.write_host(data)
        return len(data)

    def reset_input_buffer(self):
        self._buffer.clear()

    def reset_output_buffer(self):
        pass

    @property
    def out_waiting(self):
        return 0

    def _update_dtr_state(self):
        pass

    def _update_rts_state(self):
        pass

    def _update_break_state(self):
        pass

    @property
    def cts(self):
        return True

    @property
    def dsr(self):
        return True

    @property
    def ri(self):
        return False

    @property
    def cd(self):
        return True


__all__ = ["Serial", "Timeout"]
