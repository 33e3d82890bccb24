/* Host commands: validate, then apply; every command gets ACK or NAK (tactile_fw/commands.py,
 * PROTOCOL.md §4). A value out of range is refused with NAK_OUT_OF_RANGE and detail = the
 * field's index; nothing is applied. TARE is refused with NAK_LOADED (detail: the sensor)
 * while a sensor it names is loaded. A frame whose CRC is good but whose layout is not a
 * command's gets NAK (unknown command, bad length, bad version) with detail 0xFF. */
#include <string.h>

#include "tactile_core.h"

#define TARE_SENSOR 0
#define TARE_N 1
#define CAL_SENSOR 0
#define CAL_COEFF0 2

static void config(tc_board_t *b, uint16_t seq, const tc_msg_config_t *m)
{
    tc_settings_t s;
    int bad = tc_settings_check(m->rate_hz, m->enter_threshold, m->exit_threshold, m->debounce,
                                m->flags, b->max_rate_hz);
    if (bad >= 0) {
        tc_board_nak(b, TC_CMD_CONFIG, seq, TC_NAK_OUT_OF_RANGE, (uint8_t)bad);
        return;
    }
    s.rate_hz = m->rate_hz;
    s.enter = m->enter_threshold;
    s.exit = m->exit_threshold;
    s.debounce = m->debounce;
    s.flags = (uint8_t)(m->flags & TC_CFG_WRITABLE & ~TC_CFG_PERSIST);
    if ((m->flags & TC_CFG_PERSIST) && tc_settings_save(b, &s) != 0) {
        tc_board_nak(b, TC_CMD_CONFIG, seq, TC_NAK_STORAGE, TC_NAK_DETAIL_NONE);
        return;
    }
    b->settings = s;
    tc_board_apply_settings(b);
    tc_board_ack(b, TC_CMD_CONFIG, seq);
}

static void tare(tc_board_t *b, uint16_t seq, const tc_msg_tare_t *m)
{
    uint8_t mask;
    uint16_t n = m->n_samples;
    int i;
    if (m->sensor == TC_SENSOR_ALL) {
        mask = (uint8_t)((1u << b->n) - 1);
    } else if (m->sensor < b->n) {
        mask = (uint8_t)(1u << m->sensor);
    } else {
        tc_board_nak(b, TC_CMD_TARE, seq, TC_NAK_OUT_OF_RANGE, TARE_SENSOR);
        return;
    }
    if (n == 0) {
        n = TC_DEFAULT_TARE_SAMPLES;
    }
    if (n > TC_MAX_TARE_SAMPLES) {
        tc_board_nak(b, TC_CMD_TARE, seq, TC_NAK_OUT_OF_RANGE, TARE_N);
        return;
    }
    if (b->tare_mask) {
        tc_board_nak(b, TC_CMD_TARE, seq, TC_NAK_BAD_STATE, TC_NAK_DETAIL_NONE);
        return;
    }
    for (i = 0; i < b->n; i++) {
        if ((mask & (1u << i)) && b->state[i] != TC_S_OK) {
            tc_board_nak(b, TC_CMD_TARE, seq, TC_NAK_HARDWARE, TARE_SENSOR);
            return;
        }
    }
    i = tc_board_loaded_sensor(b, mask);
    if (i >= 0) { /* a bias taken under load would offset every later reading by it */
        tc_board_nak(b, TC_CMD_TARE, seq, TC_NAK_LOADED, (uint8_t)i);
        return;
    }
    tc_board_start_tare(b, mask, n, seq); /* ACK when the bias is captured (or NAK_LOADED) */
}

static void set_cal(tc_board_t *b, uint16_t seq, const tc_msg_set_cal_t *m)
{
    uint32_t bits[36];
    int bad;
    if (m->sensor >= b->n) {
        tc_board_nak(b, TC_CMD_SET_CAL, seq, TC_NAK_OUT_OF_RANGE, CAL_SENSOR);
        return;
    }
    memcpy(bits, m->c, sizeof(bits));
    bad = tc_cal_bad_coefficient(bits, 36);
    if (bad >= 0) {
        tc_board_nak(b, TC_CMD_SET_CAL, seq, TC_NAK_OUT_OF_RANGE, (uint8_t)(CAL_COEFF0 + bad));
        return;
    }
    if (tc_cal_save(b, m->sensor, m->cal_id, bits) != 0) {
        tc_board_nak(b, TC_CMD_SET_CAL, seq, TC_NAK_STORAGE, TC_NAK_DETAIL_NONE);
        return;
    }
    tc_cal_set(&b->cals[m->sensor], bits, m->cal_id); /* keeps the bias captured by TARE */
    tc_board_ack(b, TC_CMD_SET_CAL, seq);
}

static int known(uint8_t type)
{
    return type >= TC_CMD_PING && type <= TC_CMD_SET_CAL;
}

void tc_dispatch(tc_board_t *b)
{
    tc_header_t h;
    tc_msg_t m;
    int r = tc_unpack(b->asm_.buf, b->asm_.body_len, &h, &m);
    if (r == TC_UNPACK_SHORT) {
        return; /* no sequence number to answer */
    }
    if (r == TC_UNPACK_VERSION) {
        tc_board_nak(b, h.type, h.seq, TC_NAK_BAD_VERSION, TC_NAK_DETAIL_NONE);
        return;
    }
    if (r != TC_UNPACK_OK || !known(h.type)) {
        tc_board_nak(b, h.type, h.seq, known(h.type) ? TC_NAK_BAD_LENGTH : TC_NAK_UNKNOWN_COMMAND,
                     TC_NAK_DETAIL_NONE);
        return;
    }
    switch (h.type) {
    case TC_CMD_PING:
        tc_board_ack(b, h.type, h.seq);
        break;
    case TC_CMD_GET_INFO:
        tc_board_send_info(b, TC_MSG_INFO);
        tc_board_ack(b, h.type, h.seq);
        break;
    case TC_CMD_CONFIG:
        config(b, h.seq, &m.config);
        break;
    case TC_CMD_TARE:
        tare(b, h.seq, &m.tare);
        break;
    case TC_CMD_START:
        tc_board_start_streaming(b);
        tc_board_ack(b, h.type, h.seq);
        break;
    case TC_CMD_STOP:
        tc_board_stop_streaming(b);
        tc_board_ack(b, h.type, h.seq);
        break;
    default: /* TC_CMD_SET_CAL */
        set_cal(b, h.seq, &m.set_cal);
        break;
    }
}
