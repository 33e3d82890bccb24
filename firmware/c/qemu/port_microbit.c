/* The C core on a BBC micro:bit as QEMU emulates it (-M microbit: nRF51822, Cortex-M0,
 * ARMv6-M like the RP2040's M0+), the image `tactile emulate --core qemu` runs.
 *
 * Host bytes go through the nRF51 UART (QEMU binds it to a chardev); the microsecond clock
 * is TIMER0 at 1 MHz, 32 bits; between samples the core sleeps in WFI until a TIMER0
 * compare or a host byte. QEMU has no model of our ADCs, so the I2C bus and the flash
 * (settings, calibration) are reached over a device channel: two host FIFOs opened by
 * semihosting, "dev.req" and "dev.rep", served by tactile_sim.emulator.qemu_core with the
 * scene's simulated ADS122C04s at the board's own time (each I2C request carries it).
 *
 * Requests (little-endian), each answered before the next:
 *   'C'                                  -> n, mode, max_rate_hz u16, boot_id u32,
 *                                           tx_size u16, board_id[8], then (bus, slot)
 *                                           per sensor
 *   'R' bus addr cmd n t_us u32          -> err u16, n bytes
 *   'W' bus addr n t_us u32 data[n]      -> err u16
 *   'B' key cap u16                      -> len i16 (-1: none), min(len, cap) bytes
 *   'S' key n u16 data[n]                -> err u16
 *   'M' count u32[count]                 -> err u16  (bench results)
 * A broken channel ends the run (exit status 3).
 */
#include <string.h>

#include "semihost.h"
#include "tactile_core.h"

#define REG(addr) (*(volatile uint32_t *)(addr))
/* nRF51 UART0 */
#define UART 0x40002000u
#define UART_STARTRX REG(UART + 0x000)
#define UART_STARTTX REG(UART + 0x008)
#define UART_EV_RXDRDY REG(UART + 0x108)
#define UART_EV_TXDRDY REG(UART + 0x11C)
#define UART_INTENSET REG(UART + 0x304)
#define UART_ENABLE REG(UART + 0x500)
#define UART_RXD REG(UART + 0x518)
#define UART_TXD REG(UART + 0x51C)
#define UART_IRQ 2u
/* nRF51 TIMER0: 16 MHz / 2^PRESCALER */
#define TIMER 0x40008000u
#define TIMER_START REG(TIMER + 0x000)
#define TIMER_CAPTURE(n) REG(TIMER + 0x040 + 4 * (n))
#define TIMER_EV_COMPARE(n) REG(TIMER + 0x140 + 4 * (n))
#define TIMER_INTENSET REG(TIMER + 0x304)
#define TIMER_MODE REG(TIMER + 0x504)
#define TIMER_BITMODE REG(TIMER + 0x508)
#define TIMER_PRESCALER REG(TIMER + 0x510)
#define TIMER_CC(n) REG(TIMER + 0x540 + 4 * (n))
#define TIMER_IRQ 8u
/* NVIC */
#define NVIC_ISER REG(0xE000E100u)
#define NVIC_ICPR REG(0xE000E280u)

enum { MODE_RUN = 0, MODE_BENCH = 1, MODE_PROFILE = 2 };
enum { TX_RING = 4096, POLL_NAP_US = 20 };

static tc_board_t board;
static uint8_t tx_ring[TX_RING];
static int dev_req = -1, dev_rep = -1;

/* --- device channel ------------------------------------------------------------------ */
static void dev_send(const void *data, size_t n)
{
    if (sh_write(dev_req, data, n) != 0) {
        sh_exit(3);
    }
}

static void dev_recv(void *buf, size_t n)
{
    uint8_t *p = buf;
    while (n) {
        int left = sh_read(dev_rep, p, n);
        size_t got = n - (size_t)left;
        if (left < 0 || got == 0) {
            sh_exit(3); /* the device server is gone */
        }
        p += got;
        n -= got;
    }
}

static uint16_t dev_status(void)
{
    uint8_t r[2];
    dev_recv(r, 2);
    return (uint16_t)(r[0] | (r[1] << 8));
}

static void put32(uint8_t *p, uint32_t v)
{
    p[0] = (uint8_t)v;
    p[1] = (uint8_t)(v >> 8);
    p[2] = (uint8_t)(v >> 16);
    p[3] = (uint8_t)(v >> 24);
}

static void dev_open(void)
{
    static const char req[] = "dev.req", rep[] = "dev.rep";
    dev_req = sh_open(req, sizeof(req) - 1, SH_MODE_WB); /* the server opens them in this order */
    dev_rep = sh_open(rep, sizeof(rep) - 1, SH_MODE_RB);
    if (dev_req < 0 || dev_rep < 0) {
        sh_exit(2);
    }
}

/* --- clock and sleep ------------------------------------------------------------------ */
static uint32_t now_us(void)
{
    TIMER_CAPTURE(0) = 1;
    return TIMER_CC(0);
}

static void timer_init(void)
{
    TIMER_MODE = 0;      /* timer */
    TIMER_BITMODE = 3;   /* 32 bits */
    TIMER_PRESCALER = 4; /* 1 MHz */
    TIMER_INTENSET = 1u << 17; /* COMPARE[1]: wakes WFI (PRIMASK keeps it from being taken) */
    TIMER_START = 1;
}

/* Sleep in WFI until `us` have passed or a host byte arrives. */
void port_sleep_us(uint32_t us)
{
    TIMER_EV_COMPARE(1) = 0;
    TIMER_CC(1) = now_us() + us;
    NVIC_ISER = (1u << TIMER_IRQ) | (1u << UART_IRQ);
    while (!TIMER_EV_COMPARE(1) && !UART_EV_RXDRDY) {
        __asm__ volatile("wfi");
        NVIC_ICPR = (1u << TIMER_IRQ) | (1u << UART_IRQ);
    }
    TIMER_EV_COMPARE(1) = 0;
    NVIC_ICPR = (1u << TIMER_IRQ) | (1u << UART_IRQ);
}

/* --- HAL ------------------------------------------------------------------------------- */
static int tx_busy;

static void uart_init(void)
{
    UART_ENABLE = 4;
    UART_INTENSET = 1u << 2; /* RXDRDY: a host byte wakes WFI */
    UART_STARTTX = 1;
    UART_STARTRX = 1;
}

static size_t hal_write(void *ctx, const uint8_t *data, size_t n)
{
    size_t k;
    (void)ctx;
    for (k = 0; k < n; k++) {
        if (tx_busy) { /* the UART has not taken the previous byte: the TX ring keeps the rest */
            if (!UART_EV_TXDRDY) {
                return k;
            }
            tx_busy = 0;
        }
        UART_EV_TXDRDY = 0;
        UART_TXD = data[k];
        tx_busy = 1;
    }
    return n;
}

static size_t hal_read(void *ctx, uint8_t *buf, size_t n)
{
    size_t k = 0;
    (void)ctx;
    while (k < n && UART_EV_RXDRDY) {
        UART_EV_RXDRDY = 0; /* reading RXD raises it again while more wait */
        buf[k++] = (uint8_t)UART_RXD;
    }
    return k;
}

static uint32_t hal_ticks(void *ctx)
{
    (void)ctx;
    return now_us();
}

/* (Requests are filled byte by byte: a partial initializer costs a memset per transfer.) */
static int hal_i2c_read(void *ctx, uint8_t bus, uint8_t addr, uint8_t cmd, uint8_t *buf, size_t n)
{
    uint8_t req[9], rep[2 + 3];
    (void)ctx;
    if (n > 3) {
        return 22; /* EINVAL: the driver reads 1 or 3 bytes */
    }
    req[0] = 'R';
    req[1] = bus;
    req[2] = addr;
    req[3] = cmd;
    req[4] = (uint8_t)n;
    put32(req + 5, now_us());
    dev_send(req, sizeof(req));
    dev_recv(rep, 2 + n); /* the status, then n bytes (zeros when the transfer failed) */
    if (n > 0) { /* (not a loop: GCC would make it a call to memcpy) */
        buf[0] = rep[2];
    }
    if (n > 1) {
        buf[1] = rep[3];
    }
    if (n > 2) {
        buf[2] = rep[4];
    }
    return rep[0] | (rep[1] << 8);
}

static int hal_i2c_write(void *ctx, uint8_t bus, uint8_t addr, const uint8_t *data, size_t n)
{
    uint8_t req[8 + 8];
    size_t k;
    (void)ctx;
    if (n > 8) {
        return 22; /* EINVAL: the driver writes at most a command and a register */
    }
    req[0] = 'W';
    req[1] = bus;
    req[2] = addr;
    req[3] = (uint8_t)n;
    put32(req + 4, now_us());
    for (k = 0; k < n; k++) {
        req[8 + k] = data[k];
    }
    dev_send(req, 8 + n);
    return dev_status();
}

static int hal_blob_read(void *ctx, uint8_t key, uint8_t *buf, size_t cap)
{
    uint8_t req[4] = {'B', key, (uint8_t)cap, (uint8_t)(cap >> 8)};
    int16_t len;
    (void)ctx;
    dev_send(req, sizeof(req));
    len = (int16_t)dev_status();
    if (len > 0) {
        dev_recv(buf, (size_t)len < cap ? (size_t)len : cap);
    }
    return len;
}

static int hal_blob_write(void *ctx, uint8_t key, const uint8_t *data, size_t n)
{
    uint8_t req[4] = {'S', key, (uint8_t)n, (uint8_t)(n >> 8)};
    (void)ctx;
    dev_send(req, sizeof(req));
    dev_send(data, n);
    return dev_status();
}

/* --- bench: instructions per stage, counted by QEMU's -icount ------------------------- */
void tc_qemu_bench(tc_board_t *b, void (*report)(const uint32_t *, uint8_t), int reps);

static void report(const uint32_t *values, uint8_t count)
{
    uint8_t head[2] = {'M', count}, word[4];
    uint8_t k;
    dev_send(head, 2);
    for (k = 0; k < count; k++) {
        put32(word, values[k]);
        dev_send(word, 4);
    }
    (void)dev_status();
}

/* --- main ------------------------------------------------------------------------------- */
int main(void)
{
    uint8_t head[10 + TC_BOARD_ID_SIZE], layout[2 * TC_MAX_SENSORS];
    tc_config_t cfg;
    tc_hal_t hal;
    int i, r;
    uint32_t samples;

    __asm__ volatile("cpsid i"); /* interrupts only wake WFI; none is ever taken */
    timer_init();
    uart_init();
    dev_open();
    head[0] = 'C';
    dev_send(head, 1);
    dev_recv(head, sizeof(head));
    memset(&cfg, 0, sizeof(cfg));
    cfg.n_sensors = head[0];
    if (cfg.n_sensors < 1 || cfg.n_sensors > TC_MAX_SENSORS) {
        sh_exit(4);
    }
    dev_recv(layout, 2u * cfg.n_sensors);
    for (i = 0; i < cfg.n_sensors; i++) {
        tc_sensor_defaults(&cfg.sensors[i], layout[2 * i], layout[2 * i + 1]);
    }
    cfg.max_rate_hz = (uint16_t)(head[2] | (head[3] << 8));
    cfg.boot_id = (uint32_t)head[4] | ((uint32_t)head[5] << 8) | ((uint32_t)head[6] << 16) |
                  ((uint32_t)head[7] << 24);
    memcpy(cfg.board_id, head + 10, TC_BOARD_ID_SIZE);
    cfg.ticks_bits = 32;
    cfg.tx_buf = tx_ring;
    cfg.tx_size = (size_t)(head[8] | (head[9] << 8));
    if (cfg.tx_size < TC_TX_MIN || cfg.tx_size > sizeof(tx_ring)) {
        cfg.tx_size = sizeof(tx_ring);
    }
    memset(&hal, 0, sizeof(hal));
    hal.i2c_write = hal_i2c_write;
    hal.i2c_read = hal_i2c_read;
    hal.write = hal_write;
    hal.read = hal_read;
    hal.ticks_us = hal_ticks;
    hal.blob_read = hal_blob_read;
    hal.blob_write = hal_blob_write; /* opened: none; the host asks GET_INFO, as on a Pico */
    r = tc_board_init(&board, &cfg, &hal);
    if (r != TC_INIT_OK) {
        sh_exit(10u + (uint32_t)r);
    }
    if (head[1] == MODE_BENCH || head[1] == MODE_PROFILE) {
        tc_qemu_bench(&board, report, head[1] == MODE_BENCH ? 2000 : 1);
        sh_exit(0);
    }
    tc_board_boot(&board);
    for (;;) {
        uint32_t idle;
        samples = board.samples;
        tc_board_poll(&board);
        idle = tc_board_idle_us(&board);
        if (idle == 0 && board.samples == samples) {
            idle = POLL_NAP_US; /* waiting for DRDY: look again shortly, not at once */
        }
        if (idle) {
            port_sleep_us(idle);
        }
    }
}
