/* Settings and calibration blobs: the byte layouts of tactile_fw/settings.py
 * ("<4sBHiiBB" + CRC) and calibration.py ("<4sBI36f" + CRC), so the two firmwares
 * read each other's flash. A missing, corrupt or out-of-range blob gives the defaults. */
#include <string.h>

#include "tactile_core.h"

static void put32(uint8_t *p, uint32_t v)
{
    p[0] = (uint8_t)v;
    p[1] = (uint8_t)(v >> 8);
    p[2] = (uint8_t)(v >> 16);
    p[3] = (uint8_t)(v >> 24);
}

static uint32_t get32(const uint8_t *p)
{
    return (uint32_t)p[0] | ((uint32_t)p[1] << 8) | ((uint32_t)p[2] << 16) | ((uint32_t)p[3] << 24);
}

static int32_t to_i32(uint32_t u)
{
    return u < 0x80000000u ? (int32_t)u : -(int32_t)(~u) - 1;
}

static void seal(uint8_t *blob, size_t n) /* CRC of blob[0..n) after it, low byte first */
{
    uint16_t crc = tc_crc16(blob, n, 0xFFFF);
    blob[n] = (uint8_t)(crc & 0xFF);
    blob[n + 1] = (uint8_t)(crc >> 8);
}

static int intact(const uint8_t *blob, int len, int size, const char *magic)
{
    size_t n = (size_t)size - 2;
    if (len != size || memcmp(blob, magic, 4) != 0 || blob[4] != 1) {
        return 0;
    }
    return tc_crc16(blob, n, 0xFFFF) == (blob[n] | (blob[n + 1] << 8));
}

int tc_settings_check(uint32_t rate, int32_t enter, int32_t exit_, uint32_t debounce,
                      uint32_t flags, uint16_t max_rate_hz)
{
    if (rate < TC_MIN_RATE_HZ || rate > max_rate_hz) return TC_CFG_F_RATE;
    if (enter < 0) return TC_CFG_F_ENTER;
    if (exit_ < 0 || exit_ > enter) return TC_CFG_F_EXIT;
    if (debounce < 1 || debounce > TC_MAX_DEBOUNCE) return TC_CFG_F_DEBOUNCE;
    if (flags & ~(uint32_t)TC_CFG_WRITABLE) return TC_CFG_F_FLAGS;
    return -1;
}

int tc_settings_load(tc_board_t *b, tc_settings_t *s)
{
    uint8_t blob[TC_SETTINGS_BLOB_SIZE];
    int len = b->hal.blob_read(b->hal.ctx, TC_BLOB_SETTINGS, blob, sizeof(blob));
    uint16_t rate;
    int32_t enter, exit_;
    s->rate_hz = TC_DEFAULT_RATE_HZ < b->max_rate_hz ? TC_DEFAULT_RATE_HZ : b->max_rate_hz;
    s->enter = TC_DEFAULT_ENTER_UN;
    s->exit = TC_DEFAULT_EXIT_UN;
    s->debounce = TC_DEFAULT_DEBOUNCE;
    s->flags = TC_DEFAULT_FLAGS;
    if (!intact(blob, len, TC_SETTINGS_BLOB_SIZE, TC_SETTINGS_MAGIC)) {
        return 0;
    }
    rate = (uint16_t)(blob[5] | (blob[6] << 8));
    enter = to_i32(get32(blob + 7));
    exit_ = to_i32(get32(blob + 11));
    if (tc_settings_check(rate, enter, exit_, blob[15], blob[16], b->max_rate_hz) >= 0) {
        return 0;
    }
    s->rate_hz = rate;
    s->enter = enter;
    s->exit = exit_;
    s->debounce = blob[15];
    s->flags = (uint8_t)(blob[16] & TC_CFG_WRITABLE & ~TC_CFG_PERSIST);
    return 1;
}

int tc_settings_save(tc_board_t *b, const tc_settings_t *s)
{
    uint8_t blob[TC_SETTINGS_BLOB_SIZE];
    memcpy(blob, TC_SETTINGS_MAGIC, 4);
    blob[4] = 1;
    blob[5] = (uint8_t)s->rate_hz;
    blob[6] = (uint8_t)(s->rate_hz >> 8);
    put32(blob + 7, (uint32_t)s->enter);
    put32(blob + 11, (uint32_t)s->exit);
    blob[15] = s->debounce;
    blob[16] = s->flags;
    seal(blob, TC_SETTINGS_BLOB_SIZE - 2);
    return b->hal.blob_write(b->hal.ctx, TC_BLOB_SETTINGS, blob, sizeof(blob));
}

void tc_cal_load(tc_board_t *b, int i)
{
    uint8_t blob[TC_CAL_BLOB_SIZE];
    uint32_t bits[36];
    int k, len = b->hal.blob_read(b->hal.ctx, (uint8_t)(TC_BLOB_CAL0 + i), blob, sizeof(blob));
    tc_cal_t *c = &b->cals[i];
    tc_cal_identity(c);
    if (!intact(blob, len, TC_CAL_BLOB_SIZE, TC_CAL_MAGIC)) {
        return;
    }
    for (k = 0; k < 36; k++) {
        bits[k] = get32(blob + 9 + 4 * k);
    }
    if (tc_cal_bad_coefficient(bits, 36) >= 0) {
        return;
    }
    tc_cal_set(c, bits, get32(blob + 5));
}

int tc_cal_save(tc_board_t *b, int i, uint32_t cal_id, const uint32_t bits[36])
{
    uint8_t blob[TC_CAL_BLOB_SIZE];
    int k;
    memcpy(blob, TC_CAL_MAGIC, 4);
    blob[4] = 1;
    put32(blob + 5, cal_id);
    for (k = 0; k < 36; k++) {
        put32(blob + 9 + 4 * k, bits[k]);
    }
    seal(blob, TC_CAL_BLOB_SIZE - 2);
    return b->hal.blob_write(b->hal.ctx, (uint8_t)(TC_BLOB_CAL0 + i), blob, sizeof(blob));
}
