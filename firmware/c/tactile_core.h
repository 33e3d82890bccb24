/* tactile firmware core: the MicroPython firmware (firmware/tactile_fw) in portable C99.
 *
 * Same protocol, same behaviour, same bytes: for the same commands, clock and
 * sensor answers, tc_board_poll() writes exactly what tactile_fw.board.Board.poll()
 * writes (tests/test_ccore_diff.py checks it). No malloc: every byte of state is in
 * structs the caller owns (tc_board_t, the TX ring buffer), like Pigweed's decoders.
 * Hardware comes in through tc_hal_t, function pointers plus a context pointer, like
 * nanopb's streams; errors are return values.
 *
 * Protocol tables and constants are generated from the Python sources into tc_gen.h
 * (tactile_fw_tools/c_tables.py), so the two cannot drift.
 */
#ifndef TACTILE_CORE_H
#define TACTILE_CORE_H

#include <stddef.h>
#include <stdint.h>

#include "tc_gen.h"

#ifndef TC_TX_MIN
#define TC_TX_MIN TC_MAX_FRAME /* a TX ring must hold one frame */
#endif

/* --- protocol: CRC-16/CCITT-FALSE, COBS, pack/unpack, frames (PROTOCOL.md §2-§4) --- */
uint16_t tc_crc16(const uint8_t *data, size_t n, uint16_t crc);
/* COBS-encode src[0..n) into dst (n + n / 254 + 1 bytes); returns the encoded length. */
size_t tc_cobs_encode(const uint8_t *src, size_t n, uint8_t *dst);
/* Decode buf[0..n) in place; the decoded length, or -1 when it is not valid COBS. */
int tc_cobs_decode_in_place(uint8_t *buf, size_t n);

typedef struct {
    uint8_t version, type;
    uint16_t seq;
    uint32_t timestamp_us;
} tc_header_t;

enum { TC_UNPACK_OK = 0, TC_UNPACK_SHORT, TC_UNPACK_VERSION, TC_UNPACK_TYPE, TC_UNPACK_LENGTH };

const tc_msg_desc_t *tc_msg_desc(uint8_t type); /* NULL: no such message */
/* Header + payload of message `type` (fields from the struct `msg`) into body; its length. */
size_t tc_pack(uint8_t *body, uint8_t type, uint16_t seq, uint32_t ts, const void *msg);
/* Parse header + payload (CRC stripped); TC_UNPACK_OK or why not (as messages.unpack). */
int tc_unpack(const uint8_t *body, size_t n, tc_header_t *h, tc_msg_t *msg);
size_t tc_msg_size(void); /* sizeof(tc_msg_t), for foreign callers */

typedef struct {
    uint16_t seq;
    uint8_t body[TC_MAX_BODY];
    uint8_t out[TC_MAX_FRAME];
} tc_encoder_t;
/* One frame (COBS + delimiter) in e->out; returns its length; seq advances. */
size_t tc_encode(tc_encoder_t *e, uint8_t type, uint32_t ts, const void *msg);
/* The same frame into dst (TC_MAX_FRAME bytes free) instead of e->out. */
size_t tc_encode_into(tc_encoder_t *e, uint8_t type, uint32_t ts, const void *msg, uint8_t *dst);

enum { TC_FRAME_NONE = 0, TC_FRAME_OK, TC_FRAME_BAD, TC_FRAME_OVERSIZE };
typedef struct {
    uint8_t buf[TC_MAX_ENCODED];
    uint16_t n;
    uint8_t overflow;
    uint8_t body_len; /* after TC_FRAME_OK: header + payload in buf */
} tc_assembler_t;
void tc_assembler_init(tc_assembler_t *a);
int tc_assembler_feed(tc_assembler_t *a, uint8_t byte);

/* --- calibration in fixed point (tactile_fw/calibration.py's docstring) --- */
typedef struct {
    /* A = round(1e6 C 2^S), |A| <= 2^26, kept as A = a_hi 2^12 + a_lo, a_lo in 0..4095 */
    int16_t a_hi[TC_N_GAUGES * TC_N_GAUGES];
    uint16_t a_lo[TC_N_GAUGES * TC_N_GAUGES];
    int16_t shift[TC_N_GAUGES];           /* S per row */
    int32_t bias_q8[TC_N_GAUGES];         /* TARE bias in 1/256 counts */
    int64_t offset[TC_N_GAUGES];          /* O = sum A bias_q8 - 2^(S+7) */
    int32_t o_hi[TC_N_GAUGES], o_mid[TC_N_GAUGES], o_lo[TC_N_GAUGES]; /* -O in limbs */
    uint32_t cal_id;
    uint16_t crc; /* CRC-16 of the 36 float32 as SET_CAL carried them (HELLO/INFO cal_crc) */
    uint8_t present;
} tc_cal_t;
/* Coefficients as float32 bit patterns; -1 if all finite, else the first bad index. */
int tc_cal_bad_coefficient(const uint32_t *bits, size_t n);
void tc_cal_set(tc_cal_t *c, const uint32_t bits[36], uint32_t cal_id); /* keeps the bias */
void tc_cal_identity(tc_cal_t *c); /* 1 uN per count, id 0, not present, bias 0 */
void tc_cal_set_bias_sums(tc_cal_t *c, const int64_t sums[6], uint32_t n);
/* counts: 24-bit codes (|g| <= 2^23), as the ADS122C04 gives them */
void tc_cal_apply(const tc_cal_t *c, const int32_t counts[6], int32_t out[6]);
size_t tc_cal_size(void); /* sizeof(tc_cal_t), for foreign callers */

/* --- contact gate: hysteresis + debounce (tactile_fw/gate.py, thesis §5.1) --- */
enum { TC_GATE_NONE = -1, TC_GATE_BEGIN = 0, TC_GATE_IN = 1, TC_GATE_END = 2 };
typedef struct {
    int32_t enter, exit;
    uint8_t debounce, three_d, in_contact, count;
    uint16_t contact_id;
} tc_gate_t;
void tc_gate_configure(tc_gate_t *g, int32_t enter, int32_t exit_, uint8_t debounce, int three_d);
void tc_gate_reset(tc_gate_t *g);
int tc_gate_update(tc_gate_t *g, int32_t fx, int32_t fy, int32_t fz);
/* |F| above the enter level: a sample the gate counts toward a contact (TARE refuses it) */
int tc_gate_loaded(const tc_gate_t *g, int32_t fx, int32_t fy, int32_t fz);
size_t tc_gate_size(void); /* sizeof(tc_gate_t), for foreign callers */

/* --- hardware --- */
typedef struct {
    void *ctx; /* passed back to every call */
    /* I2C write of data[0..n) to addr: 0, or an errno (the board reports errno & 0xFF) */
    int (*i2c_write)(void *ctx, uint8_t bus, uint8_t addr, const uint8_t *data, size_t n);
    /* I2C: write cmd, repeated start, read n bytes into buf: 0 or an errno */
    int (*i2c_read)(void *ctx, uint8_t bus, uint8_t addr, uint8_t cmd, uint8_t *buf, size_t n);
    /* bytes to the host: how many were accepted (0: the host is not reading); never blocks */
    size_t (*write)(void *ctx, const uint8_t *data, size_t n);
    /* bytes from the host: how many were read into buf (0: none waiting); never blocks */
    size_t (*read)(void *ctx, uint8_t *buf, size_t n);
    /* free-running microsecond counter, wrapping at 2^ticks_bits (tc_config_t) */
    uint32_t (*ticks_us)(void *ctx);
    /* settings blob `key` (TC_BLOB_*): its length (copying at most cap bytes), -1 if absent */
    int (*blob_read)(void *ctx, uint8_t key, uint8_t *buf, size_t cap);
    /* store blob `key` (atomically): 0 or an errno */
    int (*blob_write)(void *ctx, uint8_t key, const uint8_t *data, size_t n);
    /* optional (NULL: never): nonzero once each time a host opens the port */
    int (*opened)(void *ctx);
    /* optional: streaming on/off (a USB console turns its break character off) */
    void (*streaming)(void *ctx, int on);
} tc_hal_t;

enum { TC_BLOB_SETTINGS = 0, TC_BLOB_CAL0 = 1 }; /* calibration of sensor i: TC_BLOB_CAL0 + i */

/* --- ADS122C04 x 6 per sensor (tactile_fw/ads122c04.py, frontend.py) --- */
typedef struct {
    uint8_t bus;     /* handed to the HAL; sensors on one bus share its time */
    uint8_t slot;    /* address block: tc_address_plan[slot] */
    uint32_t bus_hz; /* 0: 1 MHz */
    uint8_t mux, gain, dr_code, turbo, vref; /* converter settings (tc_sensor_defaults) */
} tc_sensor_cfg_t;
void tc_sensor_defaults(tc_sensor_cfg_t *s, uint8_t bus, uint8_t slot);

typedef struct {
    uint8_t bus;
    uint8_t addr[TC_N_GAUGES];
    uint8_t config0, config1;
    uint16_t rate_sps;
    uint32_t bus_hz;
    int32_t counts[TC_N_GAUGES];
    uint8_t fresh, saturated;
} tc_sensor_t;

/* --- settings (tactile_fw/settings.py) --- */
typedef struct {
    uint16_t rate_hz;
    int32_t enter, exit;
    uint8_t debounce, flags;
} tc_settings_t;
/* Index of the first CONFIG field out of range, or -1 (settings.check). */
int tc_settings_check(uint32_t rate, int32_t enter, int32_t exit_, uint32_t debounce,
                      uint32_t flags, uint16_t max_rate_hz);

/* --- the board --- */
typedef struct {
    uint8_t n_sensors; /* 1..TC_MAX_SENSORS */
    tc_sensor_cfg_t sensors[TC_MAX_SENSORS];
    uint16_t max_rate_hz;      /* 0: the hardware's ceiling */
    uint32_t drdy_timeout_us;  /* 0: four conversion periods of the slowest converter */
    uint32_t status_period_us; /* 0: TC_STATUS_PERIOD_US */
    uint32_t boot_id;          /* differs per power-up (HELLO/INFO) */
    uint8_t board_id[TC_BOARD_ID_SIZE]; /* names the board for its life (HELLO/INFO) */
    uint8_t ticks_bits;        /* 0: 32; MicroPython's ticks_us wraps at 2^30 */
    uint8_t *tx_buf;           /* the TX ring, owned by the caller */
    size_t tx_size;            /* >= TC_TX_MIN */
} tc_config_t;

enum { TC_S_OK = 0, TC_S_FAULT = 1 };

typedef struct {
    tc_hal_t hal;
    uint8_t n;
    uint16_t max_rate_hz;
    uint32_t drdy_timeout_us, status_period_us, boot_id;
    uint8_t board_id[TC_BOARD_ID_SIZE];
    uint32_t ticks_mask, ticks_half;
    tc_encoder_t enc;
    tc_assembler_t asm_;
    uint8_t rx[TC_RX_CHUNK];
    /* TX ring (tactile_fw/link.py TxRing) */
    uint8_t *tx;
    size_t tx_size, tx_head, tx_tail, tx_used;
    uint32_t tx_dropped, tx_sent;
    tc_settings_t settings;
    tc_sensor_t sensors[TC_MAX_SENSORS];
    tc_cal_t cals[TC_MAX_SENSORS];
    tc_gate_t gates[TC_MAX_SENSORS];
    /* scheduler (tactile_fw/timing.py) */
    uint32_t period_us, due, overruns;
    uint8_t streaming, late;
    /* faults, per sensor */
    uint8_t state[TC_MAX_SENSORS], faults[TC_MAX_SENSORS], pending[TC_MAX_SENSORS];
    uint32_t retry_at[TC_MAX_SENSORS], backoff_us[TC_MAX_SENSORS];
    uint32_t pending_since[TC_MAX_SENSORS];
    /* STATUS counters */
    uint32_t i2c_errors, drdy_timeouts, saturations, samples, rx_errors;
    uint8_t last_error;
    uint32_t reported_overruns, reported_dropped, status_due;
    /* TARE: the sensors still averaging, those it began with, samples above the gate */
    uint8_t tare_mask, tare_all;
    uint8_t tare_loaded[TC_MAX_SENSORS];
    uint16_t tare_left[TC_MAX_SENSORS], tare_n;
    int32_t tare_seq; /* -1: none to answer */
    int64_t tare_sums[TC_MAX_SENSORS][TC_N_GAUGES];
    /* device time */
    uint32_t ticks_base, time_us;
    int32_t ft[TC_N_GAUGES];
} tc_board_t;

enum { TC_INIT_OK = 0, TC_INIT_SENSORS, TC_INIT_SLOT, TC_INIT_ADC, TC_INIT_TX, TC_INIT_HAL };
/* Check the configuration and set up b; TC_INIT_OK or the first problem found. */
int tc_board_init(tc_board_t *b, const tc_config_t *cfg, const tc_hal_t *hal);
void tc_board_boot(tc_board_t *b);          /* settings, calibration, HELLO, sensors, autostart */
void tc_board_poll(tc_board_t *b);          /* one bounded step; call forever */
uint32_t tc_board_idle_us(tc_board_t *b);   /* microseconds until work is due (0: now) */
size_t tc_board_size(void);                 /* sizeof(tc_board_t), for foreign callers */
enum {
    TC_STAT_SAMPLES, TC_STAT_I2C_ERRORS, TC_STAT_DRDY_TIMEOUTS, TC_STAT_SATURATIONS,
    TC_STAT_OVERRUNS, TC_STAT_TX_DROPPED, TC_STAT_RX_ERRORS, TC_STAT_LAST_ERROR,
    TC_STAT_STREAMING, TC_STAT_TX_SEQ, TC_STAT_TIME_US, TC_STAT_MAX_RATE_HZ, TC_STAT_TX_USED
};
uint32_t tc_board_stat(const tc_board_t *b, int which); /* counters for foreign callers */

/* internal, shared between the board's files */
void tc_board_send(tc_board_t *b, uint8_t type, const void *msg);
void tc_board_ack(tc_board_t *b, uint8_t cmd, uint16_t seq);
void tc_board_nak(tc_board_t *b, uint8_t cmd, uint16_t seq, uint8_t reason, uint8_t detail);
void tc_board_send_info(tc_board_t *b, uint8_t type);
void tc_board_apply_settings(tc_board_t *b);
void tc_board_start_streaming(tc_board_t *b);
void tc_board_stop_streaming(tc_board_t *b);
void tc_board_start_tare(tc_board_t *b, uint8_t mask, uint16_t n, uint16_t seq);
int tc_board_loaded_sensor(const tc_board_t *b, uint8_t mask); /* in contact now, or -1 */
void tc_dispatch(tc_board_t *b); /* the frame the assembler just completed */
int tc_sensor_init(tc_board_t *b, int i);               /* 0 or an errno */
int tc_sensor_poll(tc_board_t *b, int i, int *done);    /* 0 or an errno */
int tc_settings_load(tc_board_t *b, tc_settings_t *s);  /* 1 if the stored ones were used */
int tc_settings_save(tc_board_t *b, const tc_settings_t *s); /* 0 or an errno */
void tc_cal_load(tc_board_t *b, int i);
int tc_cal_save(tc_board_t *b, int i, uint32_t cal_id, const uint32_t bits[36]);
uint32_t tc_ticks_add(const tc_board_t *b, uint32_t a, uint32_t d);
int32_t tc_ticks_diff(const tc_board_t *b, uint32_t a, uint32_t t);

#endif /* TACTILE_CORE_H */
