/* Calibration in fixed point: the definition in tactile_fw/calibration.py's docstring.
 * Per sample the products are split as the Python firmware splits them, A = Ah 2^12 + Al
 * and g = gh 2^12 + gl (Al, gl in 0..4095): three sums of 32x32->32 products, each below
 * 2^30, so ARMv6-M (no 32x32->64 multiply) needs no __aeabi_lmul; the sums are joined
 * and rounded once per row in 64 bits. Same exact integers, same outputs. */
#include <string.h>

#include "tactile_core.h"

#define N TC_N_GAUGES

/* floor(v / 2^k), 0 < k < 63, whatever the sign (C99 leaves >> of negatives open) */
static int64_t floor_shift(int64_t v, int k)
{
    return v >= 0 ? v >> k : -(((-v) - 1) >> k) - 1;
}

size_t tc_cal_size(void)
{
    return sizeof(tc_cal_t);
}

int tc_cal_bad_coefficient(const uint32_t *bits, size_t n)
{
    size_t k;
    for (k = 0; k < n; k++) {
        if (((bits[k] >> 23) & 0xFF) == 0xFF) { /* NaN or infinity */
            return (int)k;
        }
    }
    return -1;
}

/* 1e6 |v| = p 2^e for the float32 with these bits (calibration.micro_units) */
static void micro_units(uint32_t bits, uint64_t *p, int *e)
{
    uint32_t exp = (bits >> 23) & 0xFF, frac = bits & 0x7FFFFF;
    if (exp == 0) {
        *p = (uint64_t)frac * 1000000u;
        *e = -149;
    } else {
        *p = (uint64_t)(frac | 0x800000u) * 1000000u;
        *e = (int)exp - 150;
    }
}

static int bit_length(uint64_t p)
{
    int n = 0;
    while (p) {
        p >>= 1;
        n++;
    }
    return n;
}

/* round(p 2^k), halves up; the caller keeps the result below 2^27 */
static int64_t round_shift(uint64_t p, int k)
{
    if (k >= 0) {
        return (int64_t)(p << k);
    }
    if (-k > 62) {
        return 0; /* p < 2^44 */
    }
    return (int64_t)((p + ((uint64_t)1 << (-k - 1))) >> -k);
}

static void set_row(tc_cal_t *c, int r, const uint32_t *bits)
{
    uint64_t p[N];
    int e[N], j, top = 0, have = 0, s;
    for (j = 0; j < N; j++) {
        micro_units(bits[j], &p[j], &e[j]);
        if (p[j]) {
            int len = bit_length(p[j]) + e[j];
            if (!have || len > top) {
                top = len;
            }
            have = 1;
        }
    }
    s = !have ? TC_CAL_S_MAX : (TC_CAL_A_BITS - top < TC_CAL_S_MAX ? TC_CAL_A_BITS - top
                                                                     : TC_CAL_S_MAX);
    c->shift[r] = (int16_t)s;
    for (j = 0; j < N; j++) {
        int64_t a = round_shift(p[j], e[j] + s);
        int32_t v = (int32_t)((bits[j] >> 31) ? -a : a), lo;
        lo = (int32_t)(((uint32_t)v + ((uint32_t)1 << 27)) & 0xFFFu); /* |v| <= 2^26 */
        c->a_lo[N * r + j] = (uint16_t)lo;
        c->a_hi[N * r + j] = (int16_t)((v - lo) / 4096);
    }
}

static int64_t coefficient(const tc_cal_t *c, int k) /* A = Ah 2^12 + Al */
{
    return (int64_t)c->a_hi[k] * 4096 + c->a_lo[k];
}

static void offsets(tc_cal_t *c)
{
    int r, j;
    for (r = 0; r < N; r++) {
        int t = c->shift[r] + TC_CAL_BIAS_FRAC;
        int64_t o = 0;
        for (j = 0; j < N; j++) {
            o += coefficient(c, N * r + j) * c->bias_q8[j];
        }
        c->offset[r] = o = t > 0 ? o - ((int64_t)1 << (t - 1)) : o;
        /* -O = o_hi 2^32 + o_mid 2^20 + o_lo 2^8 + (bits below 2^8, which T >= 20 drops) */
        o = -o;
        c->o_lo[r] = (int32_t)((uint64_t)o >> 8 & 0xFFFu);
        c->o_mid[r] = (int32_t)((uint64_t)o >> 20 & 0xFFFu);
        c->o_hi[r] = (int32_t)((o - (int64_t)((uint64_t)o & 0xFFFFFFFFu)) / ((int64_t)1 << 32));
    }
}

void tc_cal_set(tc_cal_t *c, const uint32_t bits[36], uint32_t cal_id)
{
    int r, k;
    uint16_t crc = 0xFFFF;
    for (r = 0; r < N; r++) {
        set_row(c, r, bits + N * r);
    }
    for (k = 0; k < N * N; k++) { /* little-endian float32, as on the wire */
        uint8_t le[4];
        le[0] = (uint8_t)bits[k];
        le[1] = (uint8_t)(bits[k] >> 8);
        le[2] = (uint8_t)(bits[k] >> 16);
        le[3] = (uint8_t)(bits[k] >> 24);
        crc = tc_crc16(le, 4, crc);
    }
    c->crc = crc;
    c->cal_id = cal_id;
    c->present = 1;
    offsets(c);
}

void tc_cal_identity(tc_cal_t *c)
{
    uint32_t bits[N * N];
    int k;
    for (k = 0; k < N * N; k++) {
        bits[k] = (k / N == k % N) ? TC_CAL_IDENTITY_BITS : 0;
    }
    memset(c->bias_q8, 0, sizeof(c->bias_q8));
    tc_cal_set(c, bits, 0);
    c->present = 0;
}

void tc_cal_set_bias_sums(tc_cal_t *c, const int64_t sums[6], uint32_t n)
{
    int j;
    for (j = 0; j < N; j++) { /* floor((512 sum + n) / 2n): round(256 sum / n), halves up */
        int64_t num = sums[j] * 512 + (int64_t)n, den = 2 * (int64_t)n;
        int64_t q = num / den;
        if ((num % den) != 0 && num < 0) {
            q -= 1;
        }
        c->bias_q8[j] = (int32_t)q;
    }
    offsets(c);
}

/* floor(v / 2^k), 0 <= k < 32 (C99 leaves >> of a negative value to the compiler) */
static int32_t floor_shift32(int32_t v, int k)
{
    return v >= 0 ? v >> k : ~(~v >> k);
}

/* Row r from its three sums (256 sum A g = hh 2^32 + mid 2^20 + ll 2^8): floor((that - O)
 * / 2^T) clamped. For T >= 20 (S >= 12: coefficients below about 0.25 N per count) carries
 * in 32 bits, as calibration._finish; otherwise the whole total in 64 bits. */
static int32_t finish(const tc_cal_t *c, int r, int32_t hh, int32_t mid, int32_t ll)
{
    int t = c->shift[r] + TC_CAL_BIAS_FRAC;
    int64_t total, v;
    if (t >= 20) {
        int32_t a1 = ll + c->o_lo[r]; /* >= 0 */
        int32_t a2 = mid + c->o_mid[r] + (a1 >> 12);
        int32_t a3 = hh + c->o_hi[r] + floor_shift32(a2, 12); /* |a3| < 2^30 */
        if (t >= 32) {
            return floor_shift32(a3, t - 32); /* t <= S_MAX + 8 = 48 */
        }
        if (a3 >= ((int32_t)1 << (t - 1))) {
            return INT32_MAX;
        }
        if (a3 < -((int32_t)1 << (t - 1))) {
            return INT32_MIN;
        }
        return a3 * ((int32_t)1 << (32 - t)) + (int32_t)(((uint32_t)a2 & 0xFFFu) >> (t - 20));
    }
    total = (int64_t)hh * ((int64_t)1 << 32) + (int64_t)mid * (1 << 20) + (int64_t)ll * 256 -
            c->offset[r];
    if (t > 0) {
        v = floor_shift(total, t);
    } else if (total == 0) {
        v = 0;
    } else if (-t >= 32) {
        v = total > 0 ? INT32_MAX : INT32_MIN;
    } else if (total > (INT32_MAX >> -t)) {
        v = INT32_MAX;
    } else if (total < -((int64_t)1 << (31 + t))) {
        v = INT32_MIN;
    } else {
        v = total * ((int64_t)1 << -t);
    }
    return v > INT32_MAX ? INT32_MAX : v < INT32_MIN ? INT32_MIN : (int32_t)v;
}

void tc_cal_apply(const tc_cal_t *c, const int32_t counts[6], int32_t out[6])
{
    int32_t g[2 * N]; /* gh_j, gl_j: g = gh 2^12 + gl, |g| <= 2^23 (a 24-bit code) */
    int r, j;
    for (j = 0; j < N; j++) {
        uint32_t u = (uint32_t)counts[j] + 0x800000u;
        g[2 * j] = (int32_t)(u >> 12) - 2048;
        g[2 * j + 1] = (int32_t)(u & 0xFFFu);
    }
    for (r = 0; r < N; r++) {
        const int16_t *ah = c->a_hi + N * r;
        const uint16_t *al = c->a_lo + N * r;
        int32_t hh = 0, mid = 0, ll = 0; /* each below 2^30 */
#pragma GCC unroll 6
        for (j = 0; j < N; j++) {
            int32_t h = ah[j], l = al[j], gh = g[2 * j], gl = g[2 * j + 1];
            hh += h * gh;
            mid += h * gl + l * gh;
            ll += l * gl;
        }
        out[r] = finish(c, r, hh, mid, ll);
    }
}
