"""Protocol constants (PROTOCOL.md §2-§5).

Integers only: MicroPython has no ``enum``.  ``const`` makes them free on
the board and is an identity function under CPython.
"""

try:
    from micropython import const
except ImportError:  # CPython

    def const(x):
        return x


PROTOCOL_VERSION = const(4)  # 2: HELLO/INFO carry boot_id; 3: cal_crc per sensor; 4: board_id

# --- sizes (bytes) -----------------------------------------------------------
HEADER_SIZE = const(8)  # version u8, type u8, seq u16, timestamp_us u32
CRC_SIZE = const(2)
MAX_PAYLOAD = const(240)
MAX_BODY = const(250)  # HEADER_SIZE + MAX_PAYLOAD + CRC_SIZE
MAX_ENCODED = const(251)  # COBS adds exactly one byte to a body under 254 bytes
MAX_FRAME = const(252)  # MAX_ENCODED + the 0x00 delimiter
DELIMITER = const(0)

BOARD_ID_SIZE = const(8)  # HELLO/INFO board_id: the RP2040's flash unique id

SEQ_MODULO = const(65536)
TIMESTAMP_MODULO = 1 << 32  # not const(): exceeds a MicroPython small int

# --- message types: device -> host 0x01-0x3F, host -> device 0x40-0x7F --------
MSG_HELLO = const(0x01)
MSG_INFO = const(0x02)
MSG_SAMPLE = const(0x03)
MSG_CONTACT = const(0x04)
MSG_STATUS = const(0x05)
MSG_ACK = const(0x06)
MSG_NAK = const(0x07)

CMD_PING = const(0x40)
CMD_GET_INFO = const(0x41)
CMD_CONFIG = const(0x42)
CMD_TARE = const(0x43)
CMD_START = const(0x44)
CMD_STOP = const(0x45)
CMD_SET_CAL = const(0x46)

# --- units of the fixed-point F/T fields --------------------------------------
FORCE_LSB_N = 1e-6  # one count of fx, fy, fz and of the gate thresholds: 1 uN
TORQUE_LSB_NM = 1e-6  # one count of tx, ty, tz: 1 uN*m

# --- SAMPLE / CONTACT flags ----------------------------------------------------
FLAG_SAT_MASK = const(0x3F)  # bit i: gauge channel i saturated
FLAG_IN_CONTACT = const(0x40)
FLAG_LATE = const(0x80)  # this sample was taken late (an overrun)

# --- CONTACT phases ------------------------------------------------------------
PHASE_BEGIN = const(0)
PHASE_IN = const(1)
PHASE_END = const(2)

# --- CONFIG / INFO flags ---------------------------------------------------------
CFG_STREAM_SAMPLES = const(0x01)
CFG_STREAM_CONTACTS = const(0x02)
CFG_GATE_3D = const(0x04)  # gate on |F| in 3-D; clear: |F| in the x-y plane (thesis §5.1)
CFG_AUTOSTART = const(0x08)  # stream from boot (persisted)
CFG_PERSIST = const(0x10)  # CONFIG only: also save the settings on the board
CFG_STREAMING = const(0x20)  # INFO only, read-only: streaming now
CFG_WRITABLE = const(0x1F)

# --- STATUS fault bits ----------------------------------------------------------
FAULT_I2C = const(0x01)
FAULT_DRDY_STUCK = const(0x02)
FAULT_SATURATION = const(0x04)
FAULT_OVERRUN = const(0x08)
FAULT_TX_DROPPED = const(0x10)
FAULT_NO_CALIBRATION = const(0x20)
FAULT_RECOVERED = const(0x80)  # the fault above has cleared

SENSOR_ALL = const(0xFF)
MAX_SENSORS = const(4)
MAX_TARE_SAMPLES = const(10000)  # TARE n_samples above this is refused (NAK 3)

# --- NAK reasons ------------------------------------------------------------------
NAK_UNKNOWN_COMMAND = const(1)
NAK_BAD_LENGTH = const(2)
NAK_OUT_OF_RANGE = const(3)
NAK_BAD_STATE = const(4)
NAK_HARDWARE = const(5)
NAK_BAD_VERSION = const(6)
NAK_STORAGE = const(7)
NAK_LOADED = const(8)  # TARE while a sensor's force is above the gate (detail: the sensor)
NAK_DETAIL_NONE = const(0xFF)
