"""Host commands: validate, then apply; every command gets ACK or NAK (PROTOCOL §4).

A registry maps the command type to its handler.  A value out of range is
refused with NAK_OUT_OF_RANGE and ``detail`` = the index of the offending
field in the command's payload; nothing is applied.  A frame that parses
but is not a command, or whose layout is wrong, gets NAK with the reason
(unknown command, bad length, bad version).  TARE is refused with
NAK_LOADED (detail: the sensor) while a sensor it names is loaded (PROTOCOL §4).
"""

from tactile_fw import calibration, settings
from tactile_protocol.constants import (
    CFG_PERSIST,
    CMD_CONFIG,
    CMD_GET_INFO,
    CMD_PING,
    CMD_SET_CAL,
    CMD_START,
    CMD_STOP,
    CMD_TARE,
    HEADER_SIZE,
    MAX_TARE_SAMPLES,
    MSG_INFO,
    NAK_BAD_LENGTH,
    NAK_BAD_STATE,
    NAK_BAD_VERSION,
    NAK_HARDWARE,
    NAK_LOADED,
    NAK_OUT_OF_RANGE,
    NAK_STORAGE,
    NAK_UNKNOWN_COMMAND,
    PROTOCOL_VERSION,
    SENSOR_ALL,
)

DEFAULT_TARE_SAMPLES = 100  # TARE n_samples = 0 asks for this
_TARE_SENSOR = 0
_TARE_N = 1
_CAL_SENSOR = 0
_CAL_COEFF0 = 2


def _ping(board, seq, values):
    board.ack(CMD_PING, seq)


def _get_info(board, seq, values):
    board.send_info(MSG_INFO)
    board.ack(CMD_GET_INFO, seq)


def _config(board, seq, values):
    rate, enter, exit_, debounce, flags = values
    bad = settings.check(rate, enter, exit_, debounce, flags, board.max_rate_hz)
    if bad >= 0:
        board.nak(CMD_CONFIG, seq, NAK_OUT_OF_RANGE, bad)
        return
    new = settings.Settings(rate, enter, exit_, debounce, flags)
    if flags & CFG_PERSIST:
        try:
            new.save(board.storage)
        except OSError:
            board.nak(CMD_CONFIG, seq, NAK_STORAGE)
            return
    board.configure(new)
    board.ack(CMD_CONFIG, seq)


def _tare(board, seq, values):
    sensor, n_samples = values
    if sensor == SENSOR_ALL:
        mask = (1 << board.n) - 1
    elif sensor < board.n:
        mask = 1 << sensor
    else:
        board.nak(CMD_TARE, seq, NAK_OUT_OF_RANGE, _TARE_SENSOR)
        return
    if n_samples == 0:
        n_samples = DEFAULT_TARE_SAMPLES
    if n_samples > MAX_TARE_SAMPLES:
        board.nak(CMD_TARE, seq, NAK_OUT_OF_RANGE, _TARE_N)
        return
    if board.tare_mask:
        board.nak(CMD_TARE, seq, NAK_BAD_STATE)
        return
    for i in range(board.n):
        if mask & (1 << i) and board.state[i] != 0:
            board.nak(CMD_TARE, seq, NAK_HARDWARE, _TARE_SENSOR)
            return
    loaded = board.loaded_sensor(mask)
    if loaded >= 0:  # a bias taken under load would offset every later reading by it
        board.nak(CMD_TARE, seq, NAK_LOADED, loaded)
        return
    board.start_tare(mask, n_samples, seq)  # ACK when the bias is captured (or NAK_LOADED)


def _start(board, seq, values):
    board.start_streaming()
    board.ack(CMD_START, seq)


def _stop(board, seq, values):
    board.stop_streaming()
    board.ack(CMD_STOP, seq)


def _set_cal(board, seq, values):
    sensor = values[0]
    if sensor >= board.n:
        board.nak(CMD_SET_CAL, seq, NAK_OUT_OF_RANGE, _CAL_SENSOR)
        return
    coeffs = values[2:]
    bad = calibration.bad_coefficient(coeffs)
    if bad >= 0:
        board.nak(CMD_SET_CAL, seq, NAK_OUT_OF_RANGE, _CAL_COEFF0 + bad)
        return
    new = calibration.Calibration(coeffs, values[1])
    try:
        new.save(board.storage, sensor)
    except OSError:
        board.nak(CMD_SET_CAL, seq, NAK_STORAGE)
        return
    cal = board.cals[sensor]
    cal.set(coeffs, values[1])  # keeps the bias captured by TARE
    board.ack(CMD_SET_CAL, seq)


HANDLERS = {
    CMD_PING: _ping,
    CMD_GET_INFO: _get_info,
    CMD_CONFIG: _config,
    CMD_TARE: _tare,
    CMD_START: _start,
    CMD_STOP: _stop,
    CMD_SET_CAL: _set_cal,
}


def _reject(board, body, n):
    """NAK a frame whose CRC is good but whose layout is not a command's (detail 0xFF)."""
    if n < HEADER_SIZE:
        return  # no sequence number to answer
    mtype = body[1]
    seq = body[2] | (body[3] << 8)
    if body[0] != PROTOCOL_VERSION:
        board.nak(mtype, seq, NAK_BAD_VERSION)
    elif mtype not in HANDLERS:
        board.nak(mtype, seq, NAK_UNKNOWN_COMMAND)
    else:
        board.nak(mtype, seq, NAK_BAD_LENGTH)


def dispatch(board):
    """Handle the frame the board's assembler just completed."""
    asm = board.asm
    try:
        mtype, seq, _ts, values = asm.message()
    except ValueError:
        _reject(board, asm._buf, asm._body_len)
        return
    handler = HANDLERS.get(mtype)
    if handler is None:
        board.nak(mtype, seq, NAK_UNKNOWN_COMMAND)
        return
    handler(board, seq, values)
