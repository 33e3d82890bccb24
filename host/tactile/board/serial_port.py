"""Opening a board's serial port, with the reasons it fails put in words.

``open_port`` accepts a device path (``/dev/ttyACM0``, ``COM3``, an emulator's
pty) or a pyserial URL; ``sim://SCENE`` reaches the in-process emulator (its
handler is registered only when such a URL is used).  pyserial raises
``SerialException`` with the OS errno; each common one becomes a
``PortError`` with a one-line message and, where there is one, the fix.

A port that dies once open (the board unplugged or reset, the emulator
killed) fails in three ways: ``read`` raises ``SerialException`` ("device
reports readiness to read but returned no data"), ``in_waiting`` raises
``OSError(EIO)``, ``write`` raises ``SerialException("write failed: [Errno
5] ...")``.  ``describe_lost`` puts any of them in one line; the board client
raises it as ``PortLost``.
"""

import errno
import re
import sys

from tactile.errors import InputError, PortError

BAUDRATE = 115200  # USB CDC ignores it; a UART bridge needs it
READ_TIMEOUT_S = 0.05

_BUSY = {errno.EBUSY, errno.EAGAIN, errno.EWOULDBLOCK}
_GONE = {errno.ENOENT, errno.ENODEV, errno.ENXIO}


def _permission_hint():
    if sys.platform.startswith("linux"):
        return (
            "add yourself to the 'dialout' group (sudo usermod -aG dialout $USER) and log in again"
        )
    if sys.platform == "darwin":
        return "check the device's permissions (ls -l)"
    return "close other programs and check the port's permissions"


def no_such_port(port):
    """The one line of every command for a port that is not there."""
    return f"{port}: no such port (is the board plugged in? 'tactile ports' lists them)"


def describe_open_error(port, exc):
    """One line naming ``port`` and why opening it failed (``exc``: an OSError)."""
    code = getattr(exc, "errno", None)
    text = str(exc).lower()
    if code in _GONE or "no such file" in text or "filenotfound" in text:
        return no_such_port(port)
    if code in (errno.EACCES, errno.EPERM) or "permission denied" in text:
        return f"{port}: permission denied; {_permission_hint()}"
    if code in _BUSY or "exclusively lock" in text or "busy" in text:
        return f"{port}: port busy (another program has it open: close it and retry)"
    return f"{port}: cannot open: {exc}"


def _lost_reason(exc):
    text = getattr(exc, "strerror", None) or str(exc) or type(exc).__name__
    if "returned no data" in text:  # pyserial's words for a vanished device
        return "the device disconnected"
    text = re.sub(r"^(read|write) failed: ", "", text)
    return re.sub(r"^\[Errno \d+\] ", "", text)


def describe_lost(port, exc, doing):
    """One line naming ``port``, what was being done (``reading``) and why it failed."""
    return (
        f"{port}: port lost while {doing}: {_lost_reason(exc)} "
        "(board unplugged or reset? 'tactile ports' lists the ports)"
    )


def open_port(port, timeout=READ_TIMEOUT_S):
    """An open pyserial port for ``port`` (path or URL); raises PortError with the reason."""
    import serial

    if (
        port.startswith("sim://")
        and "tactile_sim.urlhandler" not in serial.protocol_handler_packages
    ):
        raise InputError(
            f"{port}: sim:// ports are served by the simulator: run through the tactile CLI, or"
            " call tactile_sim.urlhandler.register() first"
        )
    try:
        if "://" in port:
            return serial.serial_for_url(port, baudrate=BAUDRATE, timeout=timeout)
        return serial.Serial(port, baudrate=BAUDRATE, timeout=timeout, exclusive=True)
    except InputError:
        raise  # sim://SCENE: the scene's own one-line error (exit 2), not a port problem
    except (serial.SerialException, OSError, ValueError) as exc:
        raise PortError(describe_open_error(port, exc)) from None


def list_ports():
    """Rows (device, description, hwid) of the serial ports the OS knows, sorted."""
    from serial.tools import list_ports as lp

    rows = [(p.device, p.description or "", p.hwid or "") for p in lp.comports()]
    return sorted(rows)
