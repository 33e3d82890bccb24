/* ADS122C04 driver and the six-converter sensor front end (tactile_fw/ads122c04.py,
 * frontend.py). The bus transactions are the Python driver's, one for one: RESET,
 * WREG CONFIG0/1, read back, START; per sample RREG CONFIG2 (DRDY) then RDATA. */
#include "tactile_core.h"

void tc_sensor_defaults(tc_sensor_cfg_t *s, uint8_t bus, uint8_t slot)
{
    s->bus = bus;
    s->slot = slot;
    s->bus_hz = 1000000;
    s->mux = TC_ADS_MUX_AIN0_AIN1;
    s->gain = 128;
    s->dr_code = 6;
    s->turbo = 1;
    s->vref = TC_ADS_VREF_EXTERNAL;
}

static int command(tc_board_t *b, const tc_sensor_t *s, int j, uint8_t cmd)
{
    return b->hal.i2c_write(b->hal.ctx, s->bus, s->addr[j], &cmd, 1);
}

static int write_reg(tc_board_t *b, const tc_sensor_t *s, int j, uint8_t reg, uint8_t value)
{
    uint8_t data[2];
    data[0] = (uint8_t)(TC_ADS_CMD_WREG | (reg << 2));
    data[1] = value;
    return b->hal.i2c_write(b->hal.ctx, s->bus, s->addr[j], data, 2);
}

static int read_reg(tc_board_t *b, const tc_sensor_t *s, int j, uint8_t reg, uint8_t *value)
{
    return b->hal.i2c_read(b->hal.ctx, s->bus, s->addr[j], (uint8_t)(TC_ADS_CMD_RREG | (reg << 2)),
                           value, 1);
}

/* RESET, write and verify CONFIG0/1, START continuous conversions (ADS122C04.init) */
static int adc_init(tc_board_t *b, const tc_sensor_t *s, int j)
{
    uint8_t v;
    int err = command(b, s, j, TC_ADS_CMD_RESET);
    if (!err) err = write_reg(b, s, j, TC_ADS_REG_CONFIG0, s->config0);
    if (!err) err = write_reg(b, s, j, TC_ADS_REG_CONFIG1, s->config1);
    if (!err) err = read_reg(b, s, j, TC_ADS_REG_CONFIG0, &v);
    if (!err && v != s->config0) return 5; /* EIO: config readback mismatch */
    if (!err) err = read_reg(b, s, j, TC_ADS_REG_CONFIG1, &v);
    if (!err && v != s->config1) return 5;
    if (!err) err = command(b, s, j, TC_ADS_CMD_START);
    return err;
}

int tc_sensor_init(tc_board_t *b, int i)
{
    tc_sensor_t *s = &b->sensors[i];
    int j, err;
    for (j = 0; j < TC_N_GAUGES; j++) {
        err = adc_init(b, s, j);
        if (err) {
            return err;
        }
    }
    s->fresh = 0;
    return 0;
}

int tc_sensor_poll(tc_board_t *b, int i, int *done)
{
    tc_sensor_t *s = &b->sensors[i];
    int (*i2c_read)(void *, uint8_t, uint8_t, uint8_t, uint8_t *, size_t) = b->hal.i2c_read;
    void *ctx = b->hal.ctx;
    uint8_t fresh = s->fresh, sat = 0, bus = s->bus, buf[3];
    int j, err;
    *done = 0;
    for (j = 0; j < TC_N_GAUGES; j++) {
        uint8_t bit = (uint8_t)(1u << j);
        if (fresh & bit) {
            continue;
        }
        /* RREG CONFIG2 for DRDY, then RDATA */
        err = i2c_read(ctx, bus, s->addr[j], TC_ADS_CMD_RREG | (TC_ADS_REG_CONFIG2 << 2), buf, 1);
        if (err) {
            return err;
        }
        if (buf[0] & TC_ADS_DRDY) {
            uint32_t u;
            err = i2c_read(ctx, bus, s->addr[j], TC_ADS_CMD_RDATA, buf, 3);
            if (err) {
                return err;
            }
            u = ((uint32_t)buf[0] << 16) | ((uint32_t)buf[1] << 8) | buf[2];
            s->counts[j] = (u & 0x800000u) ? (int32_t)u - 0x1000000 : (int32_t)u;
            fresh |= bit;
        }
    }
    if (fresh != 0x3F) {
        s->fresh = fresh;
        return 0;
    }
    s->fresh = 0;
    for (j = 0; j < TC_N_GAUGES; j++) {
        if (s->counts[j] >= TC_ADS_CODE_MAX || s->counts[j] <= TC_ADS_CODE_MIN) {
            sat = (uint8_t)(sat | (1u << j));
        }
    }
    s->saturated = sat;
    *done = 1;
    return 0;
}
