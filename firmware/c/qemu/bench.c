/* Instructions per stage on ARMv6-M, for bench/fw_c_qemu.py: QEMU runs this image with
 * -icount shift=0, so one instruction is one nanosecond of virtual time, read from TIMER1
 * at 16 MHz (62.5 instructions per tick; the bench divides over many repetitions).
 * bench/fw_c_profile.py runs it with reps = 1 (the stage loops once, the polls as here)
 * while QEMU logs every instruction. */
#include "tactile_core.h"

#define REG(addr) (*(volatile uint32_t *)(addr))
#define T1 0x40009000u
#define T1_START REG(T1 + 0x000)
#define T1_CAPTURE REG(T1 + 0x040)
#define T1_MODE REG(T1 + 0x504)
#define T1_BITMODE REG(T1 + 0x508)
#define T1_PRESCALER REG(T1 + 0x510)
#define T1_CC REG(T1 + 0x540)

enum { POLLS = 400 };

static uint32_t ticks16(void)
{
    T1_CAPTURE = 1;
    return T1_CC;
}

static volatile int32_t sink;

void port_sleep_us(uint32_t us);

void tc_qemu_bench(tc_board_t *b, void (*report)(const uint32_t *, uint8_t), int reps)
{
    uint32_t out[10], t0, s0, sampled = 0, t_sampled = 0, idle = 0, t_idle = 0;
    int32_t counts[6] = {120000, -3400, 56000, 700, -8000, 91000}, ft[6];
    tc_msg_sample_t m;
    int k;
    T1_MODE = 0;
    T1_BITMODE = 3;
    T1_PRESCALER = 0;
    T1_START = 1;
    tc_board_boot(b); /* the settings and calibration the bench's device server stores */
    t0 = ticks16();
    for (k = 0; k < reps; k++) {
        sink = k;
    }
    out[0] = ticks16() - t0; /* the loop alone */
    t0 = ticks16();
    for (k = 0; k < reps; k++) {
        counts[0] = k;
        tc_cal_apply(&b->cals[0], counts, ft);
        sink = ft[0];
    }
    out[1] = ticks16() - t0;
    t0 = ticks16();
    for (k = 0; k < reps; k++) {
        sink = tc_gate_update(&b->gates[0], (k & 64) ? 2000000 : 0, k, 0);
    }
    out[2] = ticks16() - t0;
    m.sensor = 0;
    m.flags = 0;
    m.fx = 1234567, m.fy = -7654321, m.fz = 42, m.tx = -1, m.ty = 99999, m.tz = 0;
    t0 = ticks16();
    for (k = 0; k < reps; k++) {
        m.fz = k;
        sink = (int32_t)tc_encode(&b->enc, TC_MSG_SAMPLE, (uint32_t)k, &m);
    }
    out[3] = ticks16() - t0;
    while (sampled < POLLS) { /* the whole poll, as the port's loop runs it */
        uint32_t due = b->samples, dt;
        s0 = ticks16();
        tc_board_poll(b);
        dt = ticks16() - s0;
        if (b->samples != due) {
            sampled++;
            t_sampled += dt;
        } else {
            idle++;
            t_idle += dt;
        }
        dt = tc_board_idle_us(b);
        port_sleep_us(dt ? dt : 20); /* as the port's loop: WFI, which -icount skips */
    }
    out[4] = (uint32_t)reps;
    out[5] = sampled;
    out[6] = t_sampled;
    out[7] = idle;
    out[8] = t_idle;
    out[9] = b->n;
    report(out, 10);
}
