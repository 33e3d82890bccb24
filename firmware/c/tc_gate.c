/* Contact gate: enter/exit hysteresis plus a debounce count (tactile_fw/gate.py, thesis
 * §5.1). Integer bounds max|f_i| <= |F| <= sum|f_i| decide most samples; the rest compare
 * exact squared magnitudes in 64 bits, as the Python gate does with its exact ints. */
#include "tactile_core.h"

size_t tc_gate_size(void)
{
    return sizeof(tc_gate_t);
}

void tc_gate_reset(tc_gate_t *g)
{
    g->in_contact = 0;
    g->count = 0;
}

void tc_gate_configure(tc_gate_t *g, int32_t enter, int32_t exit_, uint8_t debounce, int three_d)
{
    g->enter = enter;
    g->exit = exit_;
    g->debounce = debounce;
    g->three_d = (uint8_t)(three_d != 0);
    tc_gate_reset(g);
}

static int64_t iabs(int32_t v)
{
    return v >= 0 ? (int64_t)v : -(int64_t)v;
}

/* +1, 0, -1 as |F| is above, at or below level (level >= 0) */
static int cmp(const tc_gate_t *g, int32_t fx, int32_t fy, int32_t fz, int32_t level)
{
    int64_t ax = iabs(fx), ay = iabs(fy), lo = ax > ay ? ax : ay, hi = ax + ay;
    uint64_t m2, l2;
    if (g->three_d) {
        int64_t az = iabs(fz);
        if (az > lo) {
            lo = az;
        }
        hi += az;
    }
    if (lo > level) {
        return 1;
    }
    if (hi < level) {
        return -1;
    }
    /* here every |f_i| <= level < 2^31: each square < 2^62, their sum < 2^64 */
    m2 = (uint64_t)(ax * ax) + (uint64_t)(ay * ay);
    if (g->three_d) {
        int64_t az = iabs(fz);
        m2 += (uint64_t)(az * az);
    }
    l2 = (uint64_t)((int64_t)level * level);
    return m2 > l2 ? 1 : (m2 < l2 ? -1 : 0);
}

int tc_gate_loaded(const tc_gate_t *g, int32_t fx, int32_t fy, int32_t fz)
{
    return cmp(g, fx, fy, fz, g->enter) > 0;
}

int tc_gate_update(tc_gate_t *g, int32_t fx, int32_t fy, int32_t fz)
{
    if (!g->in_contact) {
        if (cmp(g, fx, fy, fz, g->enter) > 0) {
            g->count++;
            if (g->count >= g->debounce) {
                g->in_contact = 1;
                g->count = 0;
                g->contact_id++;
                return TC_GATE_BEGIN;
            }
        } else {
            g->count = 0;
        }
        return TC_GATE_NONE;
    }
    if (cmp(g, fx, fy, fz, g->exit) < 0) {
        g->count++;
        if (g->count >= g->debounce) {
            g->in_contact = 0;
            g->count = 0;
            return TC_GATE_END;
        }
    } else {
        g->count = 0;
    }
    return TC_GATE_IN;
}
