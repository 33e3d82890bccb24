/* The board: one non-blocking poll that samples, gates, streams and obeys
 * (tactile_fw/board.py, timing.py Scheduler, link.py TxRing), transcribed step for step
 * so that both firmwares emit the same bytes. Faults: an I2C error or a DRDY that does
 * not come puts a sensor in a fault state, STATUS at once, re-init after a backoff that
 * doubles from TC_BACKOFF_MIN_US to TC_BACKOFF_MAX_US, FAULT_RECOVERED with the first
 * good sample; overruns and dropped frames by a STATUS at most once per period. */
#include <string.h>

#include "tactile_core.h"

#define SENSOR_FAULTS (TC_FAULT_I2C | TC_FAULT_DRDY_STUCK)

size_t tc_board_size(void)
{
    return sizeof(tc_board_t);
}

uint32_t tc_board_stat(const tc_board_t *b, int which)
{
    switch (which) {
    case TC_STAT_SAMPLES: return b->samples;
    case TC_STAT_I2C_ERRORS: return b->i2c_errors;
    case TC_STAT_DRDY_TIMEOUTS: return b->drdy_timeouts;
    case TC_STAT_SATURATIONS: return b->saturations;
    case TC_STAT_OVERRUNS: return b->overruns;
    case TC_STAT_TX_DROPPED: return b->tx_dropped;
    case TC_STAT_RX_ERRORS: return b->rx_errors;
    case TC_STAT_LAST_ERROR: return b->last_error;
    case TC_STAT_STREAMING: return b->streaming;
    case TC_STAT_TX_SEQ: return b->enc.seq;
    case TC_STAT_TIME_US: return b->time_us;
    case TC_STAT_MAX_RATE_HZ: return b->max_rate_hz;
    case TC_STAT_TX_USED: return (uint32_t)b->tx_used;
    default: return 0;
    }
}

uint32_t tc_ticks_add(const tc_board_t *b, uint32_t a, uint32_t d)
{
    return (a + d) & b->ticks_mask;
}

int32_t tc_ticks_diff(const tc_board_t *b, uint32_t a, uint32_t t)
{
    uint32_t d = (a - t + b->ticks_half) & b->ticks_mask;
    return d >= b->ticks_half ? (int32_t)(d - b->ticks_half) : -(int32_t)(b->ticks_half - d);
}

static uint32_t now_ticks(tc_board_t *b)
{
    return b->hal.ticks_us(b->hal.ctx) & b->ticks_mask;
}

/* --- TX ring: whole frames or nothing, never waits for the host --------------------- */
static void tx_flush(tc_board_t *b)
{
    while (b->tx_used) {
        size_t chunk = b->tx_size - b->tx_tail, w;
        if (chunk > b->tx_used) {
            chunk = b->tx_used;
        }
        w = b->hal.write(b->hal.ctx, b->tx + b->tx_tail, chunk);
        if (!w) {
            return;
        }
        if (w > chunk) {
            w = chunk;
        }
        b->tx_tail += w; /* (no %: ARMv6-M has no divide instruction) */
        if (b->tx_tail == b->tx_size) {
            b->tx_tail = 0;
        }
        b->tx_used -= w;
        if (w < chunk) {
            return;
        }
    }
}

static void tx_send(tc_board_t *b, const uint8_t *frame, size_t n)
{
    size_t first;
    if (b->tx_size - b->tx_used < n) {
        b->tx_dropped++;
        tx_flush(b);
        return;
    }
    first = b->tx_size - b->tx_head;
    if (n <= first) {
        memcpy(b->tx + b->tx_head, frame, n);
    } else {
        memcpy(b->tx + b->tx_head, frame, first);
        memcpy(b->tx, frame + first, n - first);
    }
    b->tx_head += n;
    if (b->tx_head >= b->tx_size) {
        b->tx_head -= b->tx_size;
    }
    b->tx_used += n;
    b->tx_sent++;
    tx_flush(b);
}

static void tx_clear(tc_board_t *b) /* a new host session: queued frames count as dropped */
{
    size_t k;
    for (k = 0; k < b->tx_used; k++) {
        if (b->tx[(b->tx_tail + k) % b->tx_size] == 0) {
            b->tx_dropped++;
        }
    }
    b->tx_head = b->tx_tail = b->tx_used = 0;
}

/* Free bytes from the ring's head on without wrapping (an empty ring starts over at 0). */
static size_t tx_room(tc_board_t *b)
{
    if (b->tx_used == b->tx_size) {
        return 0;
    }
    if (b->tx_used == 0) {
        b->tx_head = b->tx_tail = 0;
    }
    return b->tx_head < b->tx_tail ? b->tx_tail - b->tx_head : b->tx_size - b->tx_head;
}

void tc_board_send(tc_board_t *b, uint8_t type, const void *msg)
{
    size_t n;
    if (tx_room(b) >= TC_MAX_FRAME) { /* encode in place: the same bytes, without a copy */
        n = tc_encode_into(&b->enc, type, b->time_us, msg, b->tx + b->tx_head);
        b->tx_head += n;
        if (b->tx_head == b->tx_size) {
            b->tx_head = 0;
        }
        b->tx_used += n;
        b->tx_sent++;
        tx_flush(b);
        return;
    }
    n = tc_encode(&b->enc, type, b->time_us, msg);
    tx_send(b, b->enc.out, n);
}

void tc_board_ack(tc_board_t *b, uint8_t cmd, uint16_t seq)
{
    tc_msg_ack_t m;
    m.cmd_type = cmd;
    m.cmd_seq = seq;
    tc_board_send(b, TC_MSG_ACK, &m);
}

void tc_board_nak(tc_board_t *b, uint8_t cmd, uint16_t seq, uint8_t reason, uint8_t detail)
{
    tc_msg_nak_t m;
    m.cmd_type = cmd;
    m.cmd_seq = seq;
    m.reason = reason;
    m.detail = detail;
    tc_board_send(b, TC_MSG_NAK, &m);
}

void tc_board_send_info(tc_board_t *b, uint8_t type)
{
    tc_msg_info_t m;
    int i;
    memset(&m, 0, sizeof(m));
    m.fw_major = TC_FW_MAJOR;
    m.fw_minor = TC_FW_MINOR;
    m.fw_patch = TC_FW_PATCH;
    m.protocol_version = TC_PROTOCOL_VERSION;
    memcpy(m.sensor_model, TC_SENSOR_MODEL, sizeof(TC_SENSOR_MODEL) - 1);
    m.n_sensors = b->n;
    m.max_rate_hz = b->max_rate_hz;
    for (i = 0; i < b->n; i++) {
        m.cal_id[i] = b->cals[i].cal_id;
        m.cal_crc[i] = b->cals[i].crc;
    }
    m.rate_hz = b->settings.rate_hz;
    m.enter_threshold = b->settings.enter;
    m.exit_threshold = b->settings.exit;
    m.debounce = b->settings.debounce;
    m.flags = (uint8_t)(b->settings.flags | (b->streaming ? TC_CFG_STREAMING : 0));
    m.boot_id = b->boot_id;
    memcpy(m.board_id, b->board_id, TC_BOARD_ID_SIZE);
    tc_board_send(b, type, &m);
}

static void send_status(tc_board_t *b, uint16_t bits, uint8_t sensor)
{
    tc_msg_status_t m;
    uint16_t faults = bits;
    int i;
    if (sensor == TC_SENSOR_ALL) {
        for (i = 0; i < b->n; i++) {
            faults = (uint16_t)(faults | b->faults[i]);
        }
    } else if (!(bits & TC_FAULT_RECOVERED)) {
        faults = (uint16_t)(faults | b->faults[sensor]);
    }
    m.faults = faults;
    m.sensor = sensor;
    m.last_error = b->last_error;
    m.i2c_errors = b->i2c_errors;
    m.drdy_timeouts = b->drdy_timeouts;
    m.saturations = b->saturations;
    m.overruns = b->overruns;
    m.tx_dropped = b->tx_dropped;
    m.samples = b->samples;
    b->reported_overruns = b->overruns;
    b->reported_dropped = b->tx_dropped;
    tc_board_send(b, TC_MSG_STATUS, &m);
}

/* --- set-up ---------------------------------------------------------------------------- */
static uint16_t rate_sps(uint8_t config1)
{
    uint16_t sps = tc_ads_data_rates[(config1 >> TC_ADS_DR_SHIFT) & 0x07];
    return (config1 & TC_ADS_MODE_TURBO) ? (uint16_t)(sps * 2) : sps;
}

static int setup_sensor(tc_sensor_t *s, const tc_sensor_cfg_t *c)
{
    int g, j;
    for (g = 0; g < TC_ADS_N_GAINS && tc_ads_gains[g] != c->gain; g++) {
    }
    if (g == TC_ADS_N_GAINS || c->dr_code >= TC_ADS_N_DATA_RATES) {
        return TC_INIT_ADC;
    }
    if (c->slot >= TC_N_SLOTS) {
        return TC_INIT_SLOT;
    }
    memset(s, 0, sizeof(*s));
    s->bus = c->bus;
    s->bus_hz = c->bus_hz ? c->bus_hz : 1000000u;
    for (j = 0; j < TC_N_GAUGES; j++) {
        s->addr[j] = tc_address_plan[c->slot][j];
    }
    s->config0 = (uint8_t)((c->mux << TC_ADS_MUX_SHIFT) | (g << TC_ADS_GAIN_SHIFT));
    s->config1 = (uint8_t)((c->dr_code << TC_ADS_DR_SHIFT) | c->vref | TC_ADS_CM_CONTINUOUS |
                           (c->turbo ? TC_ADS_MODE_TURBO : 0));
    s->rate_sps = rate_sps(s->config1);
    return TC_INIT_OK;
}

/* the converter data rate and the I2C time per bus, whichever binds, down to 10 Hz */
static uint16_t hardware_ceiling(const tc_board_t *b)
{
    uint32_t ceiling = 0xFFFFFFFFu;
    int i, k;
    for (i = 0; i < b->n; i++) {
        uint32_t load = 0;
        if (b->sensors[i].rate_sps < ceiling) {
            ceiling = b->sensors[i].rate_sps;
        }
        for (k = 0; k < b->n; k++) {
            if (b->sensors[k].bus == b->sensors[i].bus) {
                load += TC_N_GAUGES * TC_BITS_PER_CONVERTER;
            }
        }
        if (b->sensors[i].bus_hz / load < ceiling) {
            ceiling = b->sensors[i].bus_hz / load;
        }
    }
    return (uint16_t)((ceiling / 10) * 10);
}

int tc_board_init(tc_board_t *b, const tc_config_t *cfg, const tc_hal_t *hal)
{
    int i, err;
    uint32_t slowest = 0xFFFFFFFFu;
    if (cfg->n_sensors < 1 || cfg->n_sensors > TC_MAX_SENSORS) {
        return TC_INIT_SENSORS;
    }
    if (cfg->tx_buf == NULL || cfg->tx_size < TC_TX_MIN) {
        return TC_INIT_TX;
    }
    if (!hal->i2c_write || !hal->i2c_read || !hal->write || !hal->read || !hal->ticks_us ||
        !hal->blob_read || !hal->blob_write) {
        return TC_INIT_HAL;
    }
    memset(b, 0, sizeof(*b));
    b->hal = *hal;
    b->n = cfg->n_sensors;
    for (i = 0; i < b->n; i++) {
        err = setup_sensor(&b->sensors[i], &cfg->sensors[i]);
        if (err) {
            return err;
        }
        if (b->sensors[i].rate_sps < slowest) {
            slowest = b->sensors[i].rate_sps;
        }
    }
    b->ticks_mask = (cfg->ticks_bits == 0 || cfg->ticks_bits >= 32)
                        ? 0xFFFFFFFFu
                        : (((uint32_t)1 << cfg->ticks_bits) - 1);
    b->ticks_half = (b->ticks_mask >> 1) + 1;
    b->max_rate_hz = cfg->max_rate_hz ? cfg->max_rate_hz : hardware_ceiling(b);
    b->drdy_timeout_us = cfg->drdy_timeout_us ? cfg->drdy_timeout_us : 4 * (1000000u / slowest);
    b->status_period_us = cfg->status_period_us ? cfg->status_period_us : TC_STATUS_PERIOD_US;
    b->boot_id = cfg->boot_id;
    memcpy(b->board_id, cfg->board_id, TC_BOARD_ID_SIZE);
    b->tx = cfg->tx_buf;
    b->tx_size = cfg->tx_size;
    tc_assembler_init(&b->asm_);
    b->settings.rate_hz = TC_DEFAULT_RATE_HZ < b->max_rate_hz ? TC_DEFAULT_RATE_HZ : b->max_rate_hz;
    b->settings.enter = TC_DEFAULT_ENTER_UN;
    b->settings.exit = TC_DEFAULT_EXIT_UN;
    b->settings.debounce = TC_DEFAULT_DEBOUNCE;
    b->settings.flags = TC_DEFAULT_FLAGS;
    for (i = 0; i < b->n; i++) {
        tc_cal_identity(&b->cals[i]);
        tc_gate_configure(&b->gates[i], b->settings.enter, b->settings.exit,
                          b->settings.debounce, 0);
        b->backoff_us[i] = TC_BACKOFF_MIN_US;
    }
    b->period_us = 1000000u / b->settings.rate_hz;
    b->tare_seq = -1;
    b->ticks_base = now_ticks(b);
    return TC_INIT_OK;
}

void tc_board_apply_settings(tc_board_t *b)
{
    const tc_settings_t *s = &b->settings;
    int i;
    for (i = 0; i < b->n; i++) {
        tc_gate_configure(&b->gates[i], s->enter, s->exit, s->debounce,
                          (s->flags & TC_CFG_GATE_3D) != 0);
    }
    b->period_us = 1000000u / s->rate_hz;
    b->due = tc_ticks_add(b, now_ticks(b), b->period_us);
}

/* --- faults ------------------------------------------------------------------------------ */
static void tare_fail(tc_board_t *b)
{
    b->tare_mask = 0;
    if (b->tare_seq >= 0) {
        tc_board_nak(b, TC_CMD_TARE, (uint16_t)b->tare_seq, TC_NAK_HARDWARE, TC_NAK_DETAIL_NONE);
    }
    b->tare_seq = -1;
}

static void fault(tc_board_t *b, int i, uint8_t bit, int err, uint32_t now)
{
    int is_new;
    if (bit == TC_FAULT_I2C) {
        b->i2c_errors++;
    }
    b->last_error = (uint8_t)(err & 0xFF);
    if (b->faults[i] & SENSOR_FAULTS) { /* failed again before a good sample */
        uint32_t twice = b->backoff_us[i] * 2;
        b->backoff_us[i] = twice < TC_BACKOFF_MAX_US ? twice : TC_BACKOFF_MAX_US;
    }
    is_new = !(b->faults[i] & bit);
    b->faults[i] |= bit;
    b->state[i] = TC_S_FAULT;
    b->retry_at[i] = tc_ticks_add(b, now, b->backoff_us[i]);
    if (b->gates[i].in_contact) {
        tc_gate_reset(&b->gates[i]); /* a contact cannot continue through a dead sensor */
    }
    if (is_new) {
        send_status(b, bit, (uint8_t)i);
    }
    if (b->tare_mask & (1u << i)) {
        tare_fail(b);
    }
}

static int init_sensor(tc_board_t *b, int i, uint32_t now)
{
    int err = tc_sensor_init(b, i);
    if (err) {
        fault(b, i, TC_FAULT_I2C, err, now);
        return 0;
    }
    return 1;
}

static void retry(tc_board_t *b, int i, uint32_t now)
{
    b->pending[i] = 0;
    if (init_sensor(b, i, now)) {
        b->state[i] = TC_S_OK; /* FAULT_RECOVERED goes out with the first good sample */
    }
}

static void recovered(tc_board_t *b, int i, uint8_t bits)
{
    b->faults[i] &= (uint8_t)~bits;
    b->backoff_us[i] = TC_BACKOFF_MIN_US;
    send_status(b, (uint16_t)(bits | TC_FAULT_RECOVERED), (uint8_t)i);
}

static void periodic_status(tc_board_t *b, uint32_t now)
{
    uint16_t bits = 0;
    if (tc_ticks_diff(b, now, b->status_due) < 0) {
        return;
    }
    b->status_due = tc_ticks_add(b, now, b->status_period_us);
    if (b->overruns != b->reported_overruns) {
        bits |= TC_FAULT_OVERRUN;
    }
    if (b->tx_dropped != b->reported_dropped) {
        bits |= TC_FAULT_TX_DROPPED;
    }
    if (bits) {
        send_status(b, bits, TC_SENSOR_ALL);
    }
}

/* --- start-up ------------------------------------------------------------------------------ */
void tc_board_boot(tc_board_t *b)
{
    uint32_t now;
    int i;
    tc_settings_load(b, &b->settings);
    tc_board_apply_settings(b);
    for (i = 0; i < b->n; i++) {
        tc_cal_load(b, i);
    }
    tc_board_send_info(b, TC_MSG_HELLO); /* first frame after power-up, seq 0 */
    now = now_ticks(b);
    for (i = 0; i < b->n; i++) {
        init_sensor(b, i, now);
    }
    if (b->settings.flags & TC_CFG_AUTOSTART) {
        tc_board_start_streaming(b);
    }
}

/* --- TARE: refused while a sensor is loaded (PROTOCOL.md §4) ------------------------------ */
/* Whether TARE checks sensor i for load: calibrated (else its forces mean nothing yet)
 * and gated (an enter level of 0 gates nothing). */
static int checks_load(const tc_board_t *b, int i)
{
    return b->cals[i].present && b->settings.enter > 0;
}

int tc_board_loaded_sensor(const tc_board_t *b, uint8_t mask)
{
    int i;
    if (!b->streaming) {
        return -1; /* no recent sample: the tare's own samples are checked */
    }
    for (i = 0; i < b->n; i++) {
        if ((mask & (1u << i)) && b->gates[i].in_contact && checks_load(b, i)) {
            return i;
        }
    }
    return -1;
}

static void tare_refuse(tc_board_t *b, int i) /* keep the old bias everywhere, NAK */
{
    b->tare_mask = 0;
    if (b->tare_seq >= 0) {
        tc_board_nak(b, TC_CMD_TARE, (uint16_t)b->tare_seq, TC_NAK_LOADED, (uint8_t)i);
    }
    b->tare_seq = -1;
}

/* --- sampling ------------------------------------------------------------------------------- */
static void tare_accumulate(tc_board_t *b, int i)
{
    int j, k;
    if (checks_load(b, i)) {
        int32_t ft[TC_N_GAUGES];
        tc_cal_apply(&b->cals[i], b->sensors[i].counts, ft); /* under the bias in force */
        if (tc_gate_loaded(&b->gates[i], ft[0], ft[1], ft[2])) {
            if (++b->tare_loaded[i] >= b->settings.debounce) {
                tare_refuse(b, i);
                return;
            }
        } else {
            b->tare_loaded[i] = 0;
        }
    }
    for (k = 0; k < TC_N_GAUGES; k++) {
        b->tare_sums[i][k] += b->sensors[i].counts[k];
    }
    if (--b->tare_left[i] == 0) {
        b->tare_mask &= (uint8_t)~(1u << i);
        if (!b->tare_mask) { /* every sensor done: the new biases apply together */
            for (j = 0; j < b->n; j++) {
                if (b->tare_all & (1u << j)) {
                    tc_cal_set_bias_sums(&b->cals[j], b->tare_sums[j], b->tare_n);
                }
            }
            tc_board_ack(b, TC_CMD_TARE, (uint16_t)b->tare_seq);
            b->tare_seq = -1;
        }
    }
}

static void emit(tc_board_t *b, int i, uint8_t sat)
{
    int32_t *ft = b->ft;
    uint8_t flags = sat, streams = b->settings.flags;
    int phase;
    tc_cal_apply(&b->cals[i], b->sensors[i].counts, ft);
    if (b->late) {
        flags |= TC_FLAG_LATE;
    }
    phase = tc_gate_update(&b->gates[i], ft[0], ft[1], ft[2]);
    if (phase == TC_GATE_BEGIN || phase == TC_GATE_IN) {
        flags |= TC_FLAG_IN_CONTACT;
    }
    if (streams & TC_CFG_STREAM_SAMPLES) {
        tc_msg_sample_t m;
        m.sensor = (uint8_t)i;
        m.flags = flags;
        m.fx = ft[0], m.fy = ft[1], m.fz = ft[2], m.tx = ft[3], m.ty = ft[4], m.tz = ft[5];
        tc_board_send(b, TC_MSG_SAMPLE, &m);
    }
    if (phase != TC_GATE_NONE && (streams & TC_CFG_STREAM_CONTACTS)) {
        tc_msg_contact_t m;
        m.sensor = (uint8_t)i;
        m.phase = (uint8_t)phase;
        m.contact_id = b->gates[i].contact_id;
        m.flags = flags;
        m.fx = ft[0], m.fy = ft[1], m.fz = ft[2], m.tx = ft[3], m.ty = ft[4], m.tz = ft[5];
        tc_board_send(b, TC_MSG_CONTACT, &m);
    }
}

static void read_sensor(tc_board_t *b, int i, uint32_t now)
{
    int done, err = tc_sensor_poll(b, i, &done);
    uint8_t sat;
    if (err) {
        b->pending[i] = 0;
        fault(b, i, TC_FAULT_I2C, err, now);
        return;
    }
    if (!done) {
        if (tc_ticks_diff(b, now, b->pending_since[i]) > (int32_t)b->drdy_timeout_us) {
            b->pending[i] = 0;
            b->drdy_timeouts++;
            fault(b, i, TC_FAULT_DRDY_STUCK, 0, now);
        }
        return;
    }
    b->pending[i] = 0;
    b->samples++;
    if (b->faults[i] & SENSOR_FAULTS) {
        recovered(b, i, (uint8_t)(b->faults[i] & SENSOR_FAULTS));
    }
    sat = b->sensors[i].saturated;
    if (sat && !(b->faults[i] & TC_FAULT_SATURATION)) {
        b->saturations++;
        b->faults[i] |= TC_FAULT_SATURATION;
        send_status(b, TC_FAULT_SATURATION, (uint8_t)i);
    } else if (!sat && (b->faults[i] & TC_FAULT_SATURATION)) {
        b->faults[i] &= (uint8_t)~TC_FAULT_SATURATION;
        send_status(b, TC_FAULT_SATURATION | TC_FAULT_RECOVERED, (uint8_t)i);
    }
    if (b->tare_mask & (1u << i)) {
        tare_accumulate(b, i);
    }
    if (b->streaming) {
        emit(b, i, sat);
    }
}

/* Scheduler.check: -1 when no sample is due, else the whole periods missed */
static int32_t sched_check(tc_board_t *b, uint32_t now)
{
    int32_t late = tc_ticks_diff(b, now, b->due);
    uint32_t missed;
    if (late < 0) {
        return -1;
    }
    /* (on time is the rule: no division, which ARMv6-M does in software) */
    missed = (uint32_t)late < b->period_us ? 0 : (uint32_t)late / b->period_us;
    b->due = tc_ticks_add(b, b->due, (missed + 1) * b->period_us);
    b->overruns += missed;
    return (int32_t)missed;
}

static void tick(tc_board_t *b, uint32_t now, int32_t missed)
{
    int i;
    b->late = missed > 0;
    for (i = 0; i < b->n; i++) {
        if (b->state[i] == TC_S_FAULT) {
            if (tc_ticks_diff(b, now, b->retry_at[i]) >= 0) {
                retry(b, i, now);
            }
            continue;
        }
        if (b->pending[i]) { /* the previous sample never completed within a period */
            b->overruns++;
            continue;
        }
        b->pending[i] = 1;
        b->pending_since[i] = now;
    }
}

static void receive(tc_board_t *b)
{
    size_t n = b->hal.read(b->hal.ctx, b->rx, sizeof(b->rx)), k;
    if (n > sizeof(b->rx)) {
        n = sizeof(b->rx);
    }
    for (k = 0; k < n; k++) {
        int r = tc_assembler_feed(&b->asm_, b->rx[k]);
        if (r == TC_FRAME_OK) {
            tc_dispatch(b);
        } else if (r > TC_FRAME_OK) {
            b->rx_errors++;
        }
    }
}

void tc_board_poll(tc_board_t *b)
{
    uint32_t now = now_ticks(b);
    int i;
    b->time_us += (uint32_t)tc_ticks_diff(b, now, b->ticks_base);
    b->ticks_base = now;
    if (b->hal.opened && b->hal.opened(b->hal.ctx)) {
        /* a new host session: HELLO must not wait behind frames for a host that left */
        tx_clear(b);
        tc_board_send_info(b, TC_MSG_HELLO);
    }
    receive(b);
    if (b->streaming || b->tare_mask) {
        int32_t missed = sched_check(b, now);
        if (missed >= 0) {
            tick(b, now, missed);
        }
        for (i = 0; i < b->n; i++) {
            if (b->pending[i]) {
                read_sensor(b, i, now);
            }
        }
        periodic_status(b, now);
    } else {
        for (i = 0; i < b->n; i++) {
            if (b->state[i] == TC_S_FAULT && tc_ticks_diff(b, now, b->retry_at[i]) >= 0) {
                retry(b, i, now);
            }
        }
    }
    tx_flush(b);
}

uint32_t tc_board_idle_us(tc_board_t *b)
{
    int32_t d;
    int i;
    if (!(b->streaming || b->tare_mask)) {
        return 1000;
    }
    for (i = 0; i < b->n; i++) {
        if (b->pending[i]) {
            return 0;
        }
    }
    d = tc_ticks_diff(b, b->due, now_ticks(b));
    return d > 0 ? (uint32_t)d : 0;
}

/* --- state changes used by commands -------------------------------------------------------- */
void tc_board_start_streaming(tc_board_t *b)
{
    uint32_t now;
    int i;
    if (b->streaming) {
        return;
    }
    now = now_ticks(b);
    if (!b->tare_mask) {
        b->due = tc_ticks_add(b, now, b->period_us);
    }
    b->streaming = 1;
    b->status_due = tc_ticks_add(b, now, b->status_period_us);
    for (i = 0; i < b->n; i++) {
        tc_gate_reset(&b->gates[i]);
    }
    if (b->hal.streaming) {
        b->hal.streaming(b->hal.ctx, 1);
    }
    for (i = 0; i < b->n; i++) {
        if (!b->cals[i].present) {
            send_status(b, TC_FAULT_NO_CALIBRATION, (uint8_t)i);
        }
    }
}

void tc_board_stop_streaming(tc_board_t *b)
{
    int i;
    b->streaming = 0;
    for (i = 0; i < b->n; i++) {
        b->pending[i] = 0;
    }
    if (b->hal.streaming) {
        b->hal.streaming(b->hal.ctx, 0);
    }
}

void tc_board_start_tare(tc_board_t *b, uint8_t mask, uint16_t n, uint16_t seq)
{
    int i, k;
    if (!(b->streaming || b->tare_mask)) {
        b->due = tc_ticks_add(b, now_ticks(b), b->period_us);
    }
    b->tare_mask = mask;
    b->tare_all = mask;
    b->tare_n = n;
    b->tare_seq = seq;
    for (i = 0; i < b->n; i++) {
        b->tare_left[i] = (mask & (1u << i)) ? n : 0;
        b->tare_loaded[i] = 0;
        for (k = 0; k < TC_N_GAUGES; k++) {
            b->tare_sums[i][k] = 0;
        }
    }
}
