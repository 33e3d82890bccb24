/* The emulator's ADS122C04 converters answered in C for the C firmware core (host only).
 *
 * The C core's HAL I2C calls land here instead of in a Python callback each.  RREG and
 * RDATA on a converter the bank mirrors are answered as tactile_sim.adc_model answers
 * them, to the bit (Python's float floor division and round-half-even included); a new
 * conversion's gauge values come from Python once per transducer instant (``gauges``).
 * Anything else (writes, other commands, unknown addresses, a bus with faults pending, a
 * converter the bank cannot mirror) goes to the Python callbacks, with ``sync`` before
 * (Python takes back what C changed) and after (C takes what Python changed).
 * Never built for the chip: it is the simulator's, next to the Python model it mirrors. */
#include <math.h>
#include <stddef.h>
#include <stdint.h>

#define AB_BUSES 4
#define AB_ADCS 32
#define AB_MODELS 8
#define AB_FS 8388608.0 /* FULL_SCALE_CODES */
#define AB_CODE_MAX 0x7FFFFF
#define AB_CODE_MIN (-0x800000)
#define AB_DATA (-1) /* ptr: the next plain read returns the conversion result */

typedef int (*ab_write_fn)(void *ctx, uint8_t bus, uint8_t addr, const uint8_t *data, size_t n);
typedef int (*ab_read_fn)(void *ctx, uint8_t bus, uint8_t addr, uint8_t cmd, uint8_t *buf,
                          size_t n);
typedef int (*ab_gauges_fn)(int model, double t_us); /* fills g[model]; 0, or an error code */
typedef void (*ab_sync_fn)(int after, int bus, int addr);

typedef struct {
    ab_write_fn py_write;
    ab_read_fn py_read;
    ab_gauges_fn gauges;
    ab_sync_fn sync;
    int64_t now;    /* the converters' clock during this call into the core */
    uint32_t epoch; /* a gauge cache entry is good for its epoch only */
    uint8_t fast[AB_BUSES];
    int8_t index[AB_BUSES][128]; /* converter by (bus, address), or -1 */
    /* per converter: pushed by Python; C updates n_read, code and ptr */
    int64_t t_start[AB_ADCS], n_read[AB_ADCS];
    double period[AB_ADCS], vref[AB_ADCS], gain[AB_ADCS], fs[AB_ADCS];
    int32_t code[AB_ADCS];
    uint8_t regs[AB_ADCS][4];
    uint8_t ok[AB_ADCS], running[AB_ADCS], continuous[AB_ADCS], stuck[AB_ADCS];
    uint8_t model[AB_ADCS], gauge[AB_ADCS]; /* model 255: no gauge source to mirror */
    int8_t saturate[AB_ADCS], ptr[AB_ADCS];
    /* what C did, for Python to take back */
    uint32_t transactions[AB_BUSES];
    uint64_t bits[AB_BUSES];
    uint8_t n_touched, touched[AB_ADCS], is_touched[AB_ADCS];
    /* gauge values by model, for one instant each */
    uint32_t g_epoch[AB_MODELS];
    double g_t[AB_MODELS];
    double g[AB_MODELS][6];
} ab_bank_t;

size_t ab_bank_size(void) { return sizeof(ab_bank_t); }

/* CPython's float floor division (floatobject.c, _float_div_mod) */
static double py_floordiv(double vx, double wx)
{
    double mod = fmod(vx, wx), div = (vx - mod) / wx, floordiv;
    if (mod != 0.0 && ((wx < 0) != (mod < 0))) {
        div -= 1.0;
    }
    if (div != 0.0) {
        floordiv = floor(div);
        if (div - floordiv > 0.5) {
            floordiv += 1.0;
        }
    } else {
        floordiv = copysign(0.0, vx / wx);
    }
    return floordiv;
}

/* ADS122C04Model.conversions */
static int64_t conversions(const ab_bank_t *b, int k)
{
    int64_t n;
    if (!b->running[k] || b->stuck[k]) {
        return b->n_read[k];
    }
    n = (int64_t)py_floordiv((double)(b->now - b->t_start[k]), b->period[k]);
    return (n > 1 && !b->continuous[k]) ? 1 : n;
}

static void touch(ab_bank_t *b, int k)
{
    if (!b->is_touched[k]) {
        b->is_touched[k] = 1;
        b->touched[b->n_touched++] = (uint8_t)k;
    }
}

/* The new conversion's code (code_for(source(t))), or -1 to let Python answer */
static int new_code(ab_bank_t *b, int k, int64_t n, int *err)
{
    int m = b->model[k];
    double t = (double)b->t_start[k] + (double)n * b->period[k], volts, c;
    if (b->saturate[k]) {
        b->code[k] = b->saturate[k] > 0 ? AB_CODE_MAX : AB_CODE_MIN;
        return 0;
    }
    if (b->g_epoch[m] != b->epoch || b->g_t[m] != t) {
        *err = b->gauges(m, t);
        if (*err) {
            return 0;
        }
        b->g_epoch[m] = b->epoch;
        b->g_t[m] = t;
    }
    volts = b->g[m][b->gauge[k]] * b->vref[k] / b->gain[k] / AB_FS;
    c = rint(volts / b->fs[k] * AB_FS); /* round() of a float: half to even */
    if (!isfinite(c)) {
        return -1; /* Python's round() raises: let it */
    }
    b->code[k] = c > AB_CODE_MAX ? AB_CODE_MAX : c < AB_CODE_MIN ? AB_CODE_MIN : (int32_t)c;
    return 0;
}

/* ADS122C04Model.read_mem_into for RREG and RDATA; -1: not answered here */
static int answer(ab_bank_t *b, int k, uint8_t cmd, uint8_t *buf, size_t len)
{
    size_t i;
    int err = 0;
    if ((cmd & 0xF0) == 0x20) { /* RREG */
        int reg = (cmd >> 2) & 0x3;
        uint8_t v = b->regs[k][reg];
        if (reg == 2 && conversions(b, k) > b->n_read[k]) {
            v |= 0x80; /* DRDY */
        }
        for (i = 0; i < len; i++) {
            buf[i] = v;
        }
        b->ptr[k] = (int8_t)reg;
    } else { /* RDATA: the latest conversion, sampled at its end; clears DRDY */
        int64_t n = conversions(b, k);
        uint32_t u;
        if (n > 0 && n != b->n_read[k] && new_code(b, k, n, &err)) {
            return -1;
        }
        b->ptr[k] = AB_DATA;
        if (err) { /* the gauge model raised: the callback path's error code */
            touch(b, k);
            return err;
        }
        b->n_read[k] = n;
        u = (uint32_t)b->code[k] & 0xFFFFFFu;
        for (i = 0; i < len && i < 3; i++) {
            buf[i] = (uint8_t)(u >> (16 - 8 * i));
        }
    }
    touch(b, k);
    return 0;
}

int ab_i2c_read(void *ctx, uint8_t bus, uint8_t addr, uint8_t cmd, uint8_t *buf, size_t n)
{
    ab_bank_t *b = ctx;
    int k = (bus < AB_BUSES && addr < 128) ? b->index[bus][addr] : -1, r;
    if (k >= 0 && b->fast[bus] && b->ok[k] && ((cmd & 0xF0) == 0x20 || (cmd & 0xF0) == 0x10)) {
        r = answer(b, k, cmd, buf, n);
        if (r >= 0) {
            b->transactions[bus]++;
            b->bits[bus] += 9 * n + 30; /* SimI2C.readfrom_mem_into */
            return r;
        }
    }
    b->sync(0, bus, addr);
    r = b->py_read(NULL, bus, addr, cmd, buf, n);
    b->sync(1, bus, addr);
    return r;
}

int ab_i2c_write(void *ctx, uint8_t bus, uint8_t addr, const uint8_t *data, size_t n)
{
    ab_bank_t *b = ctx;
    int r;
    b->sync(0, bus, addr);
    r = b->py_write(NULL, bus, addr, data, n);
    b->sync(1, bus, addr);
    return r;
}
