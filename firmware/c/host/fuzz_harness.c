/* Fuzz harness for the C core, built with -fsanitize=address,undefined by
 * tests/test_ccore_fuzz.py. A fake HAL in C (six-register converters that are always
 * ready, a byte queue, a settable clock, two blob slots) runs a fresh board per script.
 *
 * stdin:  repeated [u32 length][script]; stdout: [u32 length][bytes the board wrote].
 * A script is a sequence of operations, each an opcode byte then its arguments:
 *   0 len bytes..   host bytes to the board        4        host stops/starts reading
 *   1 u16           run that many us (50 us polls)  5        host opens the port
 *   2 n errno       the next n I2C transfers fail   6 s      sensor s: DRDY stuck/free
 *   3 s 6 x i24     sensor s's gauge codes          7        flash refuses/accepts writes
 * The first byte chooses the number of sensors (1..4). A sanitizer report aborts. */
#include <stdio.h>
#include <string.h>

#include "tactile_core.h"

#define MAX_OUT (1u << 20)

typedef struct {
    uint8_t regs[4][16]; /* per bus (2) x address 0x40..0x4F: config0, config1 */
    uint8_t running[2][16], stuck[2][16];
    int32_t codes[TC_MAX_SENSORS][6];
    const uint8_t *in;
    size_t in_len, in_pos;
    uint8_t rx[4096];
    size_t rx_head, rx_len;
    uint8_t out[MAX_OUT];
    size_t out_len;
    int paused, opened, fail_n, fail_errno, flash_fails;
    uint32_t t_us;
    uint8_t blobs[1 + TC_MAX_SENSORS][256];
    int blob_len[1 + TC_MAX_SENSORS];
} world_t;

static world_t W;
static tc_board_t B;
static uint8_t TX[4096];

static int fail(void)
{
    if (W.fail_n > 0) {
        W.fail_n--;
        return W.fail_errno ? W.fail_errno : 110;
    }
    return 0;
}

static int i2c_write(void *ctx, uint8_t bus, uint8_t addr, const uint8_t *data, size_t n)
{
    int err = fail(), a = addr - 0x40;
    (void)ctx;
    if (err) return err;
    if (a < 0 || a > 15 || bus > 1 || n == 0) return 19;
    if (data[0] == TC_ADS_CMD_RESET) {
        W.regs[bus][a] = 0;
        W.running[bus][a] = 0;
    } else if (data[0] == TC_ADS_CMD_START) {
        W.running[bus][a] = 1;
    } else if ((data[0] & 0xF0) == TC_ADS_CMD_WREG && n == 2) {
        int reg = (data[0] >> 2) & 3;
        if (reg == 0) W.regs[bus][a] = data[1];
        if (reg == 1) W.regs[2 + bus][a] = data[1];
    }
    return 0;
}

static int i2c_read(void *ctx, uint8_t bus, uint8_t addr, uint8_t cmd, uint8_t *buf, size_t n)
{
    int err = fail(), a = addr - 0x40;
    (void)ctx;
    if (err) return err;
    if (a < 0 || a > 15 || bus > 1 || n == 0) return 19;
    memset(buf, 0, n);
    if ((cmd & 0xF0) == TC_ADS_CMD_RREG) {
        int reg = (cmd >> 2) & 3;
        buf[0] = reg == 0 ? W.regs[bus][a] : reg == 1 ? W.regs[2 + bus][a] : 0;
        if (reg == 2 && W.running[bus][a] && !W.stuck[bus][a]) buf[0] |= TC_ADS_DRDY;
    } else if (cmd == TC_ADS_CMD_RDATA && n >= 3) {
        int slot = a / 6, gauge = a % 6, sensor = bus + 2 * slot;
        uint32_t u = (uint32_t)W.codes[sensor < TC_MAX_SENSORS ? sensor : 0][gauge] & 0xFFFFFF;
        buf[0] = (uint8_t)(u >> 16);
        buf[1] = (uint8_t)(u >> 8);
        buf[2] = (uint8_t)u;
    }
    return 0;
}

static size_t link_write(void *ctx, const uint8_t *data, size_t n)
{
    (void)ctx;
    if (W.paused) return 0;
    if (n > MAX_OUT - W.out_len) n = MAX_OUT - W.out_len;
    memcpy(W.out + W.out_len, data, n);
    W.out_len += n;
    return n;
}

static size_t link_read(void *ctx, uint8_t *buf, size_t n)
{
    size_t k;
    (void)ctx;
    for (k = 0; k < n && W.rx_len; k++) {
        buf[k] = W.rx[W.rx_head];
        W.rx_head = (W.rx_head + 1) % sizeof(W.rx);
        W.rx_len--;
    }
    return k;
}

static uint32_t ticks(void *ctx)
{
    (void)ctx;
    return W.t_us;
}

static int blob_read(void *ctx, uint8_t key, uint8_t *buf, size_t cap)
{
    (void)ctx;
    if (key > TC_MAX_SENSORS || W.blob_len[key] < 0) return -1;
    memcpy(buf, W.blobs[key], (size_t)W.blob_len[key] < cap ? (size_t)W.blob_len[key] : cap);
    return W.blob_len[key];
}

static int blob_write(void *ctx, uint8_t key, const uint8_t *data, size_t n)
{
    (void)ctx;
    if (W.flash_fails) return 28;
    if (key > TC_MAX_SENSORS || n > sizeof(W.blobs[0])) return 22;
    memcpy(W.blobs[key], data, n);
    W.blob_len[key] = (int)n;
    return 0;
}

static int opened(void *ctx)
{
    int o = W.opened;
    (void)ctx;
    W.opened = 0;
    return o;
}

static int next(void)
{
    return W.in_pos < W.in_len ? W.in[W.in_pos++] : -1;
}

static void run_script(const uint8_t *in, size_t len)
{
    tc_config_t cfg;
    tc_hal_t hal = {NULL, i2c_write, i2c_read, link_write, link_read, ticks,
                    blob_read, blob_write, opened, NULL};
    int i, op, k;
    memset(&W, 0, sizeof(W));
    memset(&cfg, 0, sizeof(cfg));
    for (i = 0; i <= TC_MAX_SENSORS; i++) W.blob_len[i] = -1;
    W.in = in;
    W.in_len = len;
    op = next();
    cfg.n_sensors = (uint8_t)(1 + (op < 0 ? 0 : op % TC_MAX_SENSORS));
    for (i = 0; i < cfg.n_sensors; i++) tc_sensor_defaults(&cfg.sensors[i], (uint8_t)(i % 2), (uint8_t)(i / 2));
    cfg.boot_id = 0x1234;
    cfg.tx_buf = TX;
    cfg.tx_size = sizeof(TX);
    W.t_us = 0xFFFFF000u; /* the clock wraps early */
    if (tc_board_init(&B, &cfg, &hal) != TC_INIT_OK) return;
    tc_board_boot(&B);
    while ((op = next()) >= 0) {
        switch (op % 8) {
        case 0: {
            int n = next();
            for (k = 0; k < n && W.in_pos < W.in_len; k++) {
                if (W.rx_len < sizeof(W.rx)) {
                    W.rx[(W.rx_head + W.rx_len) % sizeof(W.rx)] = W.in[W.in_pos];
                    W.rx_len++;
                }
                W.in_pos++;
            }
            break;
        }
        case 1: {
            int lo = next(), hi = next();
            uint32_t us = (uint32_t)(lo < 0 ? 0 : lo) | (uint32_t)((hi < 0 ? 0 : hi) << 8), t;
            for (t = 0; t < us; t += 50) {
                tc_board_poll(&B);
                (void)tc_board_idle_us(&B);
                W.t_us += 50;
            }
            break;
        }
        case 2:
            W.fail_n = next() % 8;
            W.fail_errno = next();
            break;
        case 3: {
            int s = next(), g;
            s = s < 0 ? 0 : s % TC_MAX_SENSORS;
            for (g = 0; g < 6; g++) {
                uint32_t u = 0;
                for (k = 0; k < 3; k++) u = (u << 8) | (uint32_t)(next() & 0xFF);
                W.codes[s][g] = (u & 0x800000u) ? (int32_t)u - 0x1000000 : (int32_t)u;
            }
            break;
        }
        case 4: W.paused = !W.paused; break;
        case 5: W.opened = 1; break;
        case 6: {
            int s = next(), j;
            s = s < 0 ? 0 : s % TC_MAX_SENSORS;
            for (j = 0; j < 6; j++) W.stuck[s % 2][(s / 2) * 6 + j] ^= 1;
            break;
        }
        default: W.flash_fails = !W.flash_fails; break;
        }
    }
    W.paused = 0;
    for (k = 0; k < 200; k++) { /* drain: 10 ms */
        tc_board_poll(&B);
        W.t_us += 50;
    }
}

static int read_exact(void *buf, size_t n)
{
    return fread(buf, 1, n, stdin) == n;
}

int main(void)
{
    static uint8_t script[1 << 16];
    uint8_t hdr[4];
    while (read_exact(hdr, 4)) {
        uint32_t len = (uint32_t)hdr[0] | ((uint32_t)hdr[1] << 8) | ((uint32_t)hdr[2] << 16) |
                       ((uint32_t)hdr[3] << 24);
        if (len > sizeof(script) || !read_exact(script, len)) return 2;
        run_script(script, len);
        hdr[0] = (uint8_t)W.out_len;
        hdr[1] = (uint8_t)(W.out_len >> 8);
        hdr[2] = (uint8_t)(W.out_len >> 16);
        hdr[3] = (uint8_t)(W.out_len >> 24);
        fwrite(hdr, 1, 4, stdout);
        fwrite(W.out, 1, W.out_len, stdout);
        fflush(stdout);
    }
    return 0;
}
