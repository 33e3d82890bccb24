/* tactile_native: the C core (firmware/c) as a MicroPython native module (.mpy, armv6m).
 *
 * `Board` runs the whole C board (tc_board_*: commands, sampling, calibration, gate,
 * framing, TX ring) on the hardware it is given; the Python loop (port_mpy.run) calls
 * poll(), sleeps idle_us() and feeds the watchdog, as it does for tactile_fw.board.Board.
 *
 *   Board(buses, layout, link, clock, storage[, boot_id[, max_rate_hz[, break_in[,
 *         board_id]]]])
 *
 * - buses: a sequence of I2C buses by number. A machine.I2C or machine.SoftI2C object is
 *   driven through its C protocol (mp_machine_i2c_p_t's `transfer`, below); any other
 *   object through its Python methods writeto, writeto_mem and readfrom_mem_into.
 * - layout: one (bus, slot) or (bus, slot, bus_hz) per sensor (tactile_fw.frontend's plan).
 * - link: a pair (stdin.buffer, stdout.buffer): streams polled with MP_STREAM_POLL and never
 *   blocked on, read a byte at a time with the break-in rule of port_mpy.UsbLink (raising
 *   `break_in`); or an object with readinto, write and optionally opened and streaming.
 * - clock: the address of a free-running 32-bit microsecond counter (RP2040: TIMERAWL,
 *   0x40054028); or an object with ticks_us() wrapping at 2^30 (time, ManualClock).
 * - storage: an object with read(name) -> bytes or None and write(name, data) (DirStorage):
 *   settings.bin and cal<N>.bin, in the Python firmware's byte layouts.
 * - board_id: HELLO/INFO's board id, 8 bytes (tactile_fw.identity.board_id_from); none: zeros.
 *
 * An OSError from a Python callable is the HAL's error code (its errno), as
 * tactile_fw_tools.ccore does on the host; any other exception propagates.
 *
 * Built by tactile_fw_tools.natmod with MicroPython's py/dynruntime.mk (ARCH=armv6m).
 */
#include "py/dynruntime.h"
#include "py/stream.h"

#include "tactile_core.h"

#define TN_API 2              /* the Python side's contract with this file (port_mpy) */
#define TN_MAX_BUSES 4
#define TN_TX_SIZE 4096       /* the TX ring, as tactile_fw.board.Board's default */
#define TN_TICKS_BITS_PY 30   /* MicroPython's ticks_us wraps at 2^30 */

/* The I2C protocol of extmod/modmachine.h (mp_machine_i2c_p_t) at MicroPython af47daf3b0,
 * the image's commit, as the rp2 port builds it: MICROPY_PY_MACHINE_I2C_TRANSFER_WRITE1 is 0
 * there, so the struct has no leading transfer_supports_write1 flag. natmod's build has no
 * MICROPY_PY_MACHINE_I2C, hence this copy of the layout. */
#define TN_I2C_FLAG_READ (0x01)
#define TN_I2C_FLAG_STOP (0x02)
typedef struct {
    size_t len;
    uint8_t *buf;
} tn_i2c_buf_t;
typedef struct {
    void (*init)(mp_obj_base_t *obj, size_t n_args, const mp_obj_t *pos_args, mp_map_t *kw);
    void (*deinit)(mp_obj_base_t *obj);
    int (*start)(mp_obj_base_t *obj);
    int (*stop)(mp_obj_base_t *obj);
    int (*read)(mp_obj_base_t *obj, uint8_t *dest, size_t len, bool nack);
    int (*write)(mp_obj_base_t *obj, const uint8_t *src, size_t len);
    int (*transfer)(mp_obj_base_t *obj, uint16_t addr, size_t n, tn_i2c_buf_t *bufs,
                    unsigned int flags);
    int (*transfer_single)(mp_obj_base_t *obj, uint16_t addr, size_t len, uint8_t *buf,
                           unsigned int flags);
} tn_i2c_p_t;

/* port_mpy.BREAK_IN: CR, Ctrl-C, CR as the first bytes of a frame (mpremote's break-in) */
static const uint8_t break_in_seq[3] = {0x0D, 0x03, 0x0D};

typedef struct {
    mp_obj_base_t base;
    tc_board_t board;
    uint8_t n_buses;
    mp_obj_t buses[TN_MAX_BUSES];
    const tn_i2c_p_t *i2c_p[TN_MAX_BUSES]; /* NULL: the bus's Python methods */
    mp_obj_t link;                          /* a Python link, or MP_OBJ_NULL: the streams */
    mp_obj_t in, out;
    const mp_stream_p_t *in_p, *out_p;
    uint8_t at, match;                      /* break-in: bytes since a 0x00, and how many matched */
    mp_obj_t break_in;
    volatile const uint32_t *timer;         /* NULL: clock.ticks_us() */
    mp_obj_t clock;
    mp_obj_t storage;
    mp_obj_t oserror;                       /* the OSError type */
    uint8_t *tx;
} tn_board_obj_t;

mp_obj_full_type_t tn_board_type;
mp_map_elem_t tn_board_locals_table[3];
static MP_DEFINE_CONST_DICT(tn_board_locals, tn_board_locals_table);

/* --- libc for the core: natmod links libgcc (LINK_RUNTIME=1) but no libc --------------- */
void *memcpy(void *dst, const void *src, size_t n)
{
    return mp_fun_table.memmove_(dst, src, n);
}

void *memset(void *s, int c, size_t n)
{
    return mp_fun_table.memset_(s, c, n);
}

int memcmp(const void *a, const void *b, size_t n)
{
    const uint8_t *p = a, *q = b;
    for (; n; n--, p++, q++) {
        if (*p != *q) {
            return *p < *q ? -1 : 1;
        }
    }
    return 0;
}

/* --- calling Python from the HAL --------------------------------------------------------- */
/* An OSError as the HAL's nonzero error code: its errno (errno 0 still a failure), 0xFF
 * without one; tactile_fw_tools.ccore._code does the same. */
static int oserror_code(mp_obj_t exc)
{
    mp_obj_t args = mp_load_attr(exc, MP_QSTR_args);
    size_t n;
    mp_obj_t *items;
    mp_obj_get_array(args, &n, &items);
    if (n && mp_obj_is_small_int(items[0])) {
        mp_int_t e = MP_OBJ_SMALL_INT_VALUE(items[0]);
        return (e & 0xFF) ? (int)e : (int)(e | 0x100);
    }
    return 0xFF;
}

/* Call fun(*args): 0, or the code of the OSError it raised; other exceptions propagate. */
static int call_guarded(tn_board_obj_t *self, mp_obj_t fun, size_t n_args, const mp_obj_t *args,
                        mp_obj_t *result)
{
    nlr_buf_t nlr;
    if (mp_fun_table.nlr_push(&nlr) == 0) {
        mp_obj_t r = mp_call_function_n_kw(fun, n_args, 0, args);
        mp_fun_table.nlr_pop();
        if (result) {
            *result = r;
        }
        return 0;
    }
    mp_obj_t exc = MP_OBJ_FROM_PTR(nlr.ret_val);
    mp_obj_t check[2] = {exc, self->oserror};
    if (!mp_obj_is_true(mp_call_function_n_kw(mp_load_global(MP_QSTR_isinstance), 2, 0, check))) {
        nlr_raise(exc);
    }
    return oserror_code(exc);
}

/* --- HAL: I2C ------------------------------------------------------------------------------ */
static int i2c_write(void *ctx, uint8_t bus, uint8_t addr, const uint8_t *data, size_t n)
{
    tn_board_obj_t *self = ctx;
    if (bus >= self->n_buses) {
        return MP_ENODEV;
    }
    const tn_i2c_p_t *p = self->i2c_p[bus];
    if (p) { /* machine.I2C.writeto / writeto_mem put these bytes on the bus */
        tn_i2c_buf_t b = {n, (uint8_t *)data};
        int r = p->transfer(MP_OBJ_TO_PTR(self->buses[bus]), addr, 1, &b, TN_I2C_FLAG_STOP);
        return r < 0 ? -r : 0;
    }
    mp_obj_t fun, args[3];
    args[0] = MP_OBJ_NEW_SMALL_INT(addr);
    if (n >= 2) { /* WREG: the driver's writeto_mem(addr, reg, value) */
        fun = mp_load_attr(self->buses[bus], MP_QSTR_writeto_mem);
        args[1] = MP_OBJ_NEW_SMALL_INT(data[0]);
        args[2] = mp_obj_new_bytes(data + 1, n - 1);
        return call_guarded(self, fun, 3, args, NULL);
    }
    fun = mp_load_attr(self->buses[bus], MP_QSTR_writeto);
    args[1] = mp_obj_new_bytes(data, n);
    return call_guarded(self, fun, 2, args, NULL);
}

static int i2c_read(void *ctx, uint8_t bus, uint8_t addr, uint8_t cmd, uint8_t *buf, size_t n)
{
    tn_board_obj_t *self = ctx;
    if (bus >= self->n_buses) {
        return MP_ENODEV;
    }
    const tn_i2c_p_t *p = self->i2c_p[bus];
    if (p) { /* machine.I2C.readfrom_mem_into: extmod/machine_i2c.c's read_mem, step by step */
        mp_obj_base_t *i2c = MP_OBJ_TO_PTR(self->buses[bus]);
        tn_i2c_buf_t w = {1, &cmd}, r = {n, buf};
        int ret = p->transfer(i2c, addr, 1, &w, 0);
        if (ret != 1) {
            tn_i2c_buf_t none = {0, NULL};
            p->transfer(i2c, addr, 1, &none, TN_I2C_FLAG_STOP); /* a STOP after the failure */
            return ret < 0 ? -ret : 0;
        }
        ret = p->transfer(i2c, addr, 1, &r, TN_I2C_FLAG_READ | TN_I2C_FLAG_STOP);
        return ret < 0 ? -ret : 0;
    }
    mp_obj_t args[3] = {MP_OBJ_NEW_SMALL_INT(addr), MP_OBJ_NEW_SMALL_INT(cmd),
                        mp_obj_new_bytearray_by_ref(n, buf)};
    return call_guarded(self, mp_load_attr(self->buses[bus], MP_QSTR_readfrom_mem_into), 3, args,
                        NULL);
}

/* --- HAL: host bytes ------------------------------------------------------------------------ */
static int stream_ready(mp_obj_t s, const mp_stream_p_t *p, uintptr_t flag)
{
    int err;
    mp_uint_t r = p->ioctl(s, MP_STREAM_POLL, flag, &err);
    return r != MP_STREAM_ERROR && (r & flag);
}

/* port_mpy.UsbLink.readinto: a byte at a time while one waits; the third byte of a break-in
 * raises break_in at once (the bytes of this call go nowhere, and the rest of the host's
 * bytes, mpremote's Ctrl-A, stay for the REPL). */
static size_t stream_read(tn_board_obj_t *self, uint8_t *buf, size_t n)
{
    size_t got = 0;
    while (got < n && stream_ready(self->in, self->in_p, MP_STREAM_POLL_RD)) {
        int err;
        uint8_t b;
        mp_uint_t r = self->in_p->read(self->in, &b, 1, &err);
        if (r == MP_STREAM_ERROR || r == 0) {
            break;
        }
        buf[got++] = b;
        if (b == 0) {
            self->at = self->match = 0;
        } else if (self->at < 3) {
            if (self->match == self->at && b == break_in_seq[self->at]) {
                if (++self->match == 3) { /* (the state stays as UsbLink leaves it) */
                    nlr_raise(mp_call_function_n_kw(self->break_in, 0, 0, NULL));
                }
            }
            self->at++;
        }
    }
    return got;
}

static size_t link_read(void *ctx, uint8_t *buf, size_t n)
{
    tn_board_obj_t *self = ctx;
    if (self->link == MP_OBJ_NULL) {
        return stream_read(self, buf, n);
    }
    mp_obj_t arg = mp_obj_new_bytearray_by_ref(n, buf), r;
    if (call_guarded(self, mp_load_attr(self->link, MP_QSTR_readinto), 1, &arg, &r)) {
        return 0;
    }
    return r == mp_const_none ? 0 : (size_t)mp_obj_get_int(r);
}

static size_t link_write(void *ctx, const uint8_t *data, size_t n)
{
    tn_board_obj_t *self = ctx;
    if (self->link == MP_OBJ_NULL) { /* UsbLink.write: only when the host can take bytes */
        int err;
        if (!stream_ready(self->out, self->out_p, MP_STREAM_POLL_WR)) {
            return 0;
        }
        mp_uint_t w = self->out_p->write(self->out, data, n, &err);
        return w == MP_STREAM_ERROR ? 0 : (size_t)w;
    }
    mp_obj_t arg = mp_obj_new_bytearray_by_ref(n, (void *)data), r;
    if (call_guarded(self, mp_load_attr(self->link, MP_QSTR_write), 1, &arg, &r)) {
        return 0;
    }
    return r == mp_const_none ? 0 : (size_t)mp_obj_get_int(r);
}

static int link_opened(void *ctx)
{
    tn_board_obj_t *self = ctx;
    return mp_obj_is_true(mp_call_function_n_kw(mp_load_attr(self->link, MP_QSTR_opened), 0, 0,
                                                NULL));
}

static void link_streaming(void *ctx, int on)
{
    tn_board_obj_t *self = ctx;
    mp_obj_t arg = mp_obj_new_bool(on);
    mp_call_function_n_kw(mp_load_attr(self->link, MP_QSTR_streaming), 1, 0, &arg);
}

/* --- HAL: clock and storage ----------------------------------------------------------------- */
static uint32_t ticks_us(void *ctx)
{
    tn_board_obj_t *self = ctx;
    if (self->timer) {
        return *self->timer;
    }
    return (uint32_t)mp_obj_get_int_truncated(
        mp_call_function_n_kw(mp_load_attr(self->clock, MP_QSTR_ticks_us), 0, 0, NULL));
}

static mp_obj_t blob_name(uint8_t key)
{
    if (key == TC_BLOB_SETTINGS) {
        return mp_obj_new_str("settings.bin", 12);
    }
    char name[] = "cal0.bin";
    name[3] = (char)('0' + (key - TC_BLOB_CAL0));
    return mp_obj_new_str(name, 8);
}

static int blob_read(void *ctx, uint8_t key, uint8_t *buf, size_t cap)
{
    tn_board_obj_t *self = ctx;
    mp_obj_t name = blob_name(key), data;
    if (call_guarded(self, mp_load_attr(self->storage, MP_QSTR_read), 1, &name, &data) ||
        data == mp_const_none) {
        return -1;
    }
    mp_buffer_info_t info;
    mp_get_buffer_raise(data, &info, MP_BUFFER_READ);
    memcpy(buf, info.buf, info.len < cap ? info.len : cap);
    return (int)info.len;
}

static int blob_write(void *ctx, uint8_t key, const uint8_t *data, size_t n)
{
    tn_board_obj_t *self = ctx;
    mp_obj_t args[2] = {blob_name(key), mp_obj_new_bytes(data, n)};
    return call_guarded(self, mp_load_attr(self->storage, MP_QSTR_write), 2, args, NULL);
}

/* --- the Board type -------------------------------------------------------------------------- */
static const char *const init_errors[] = {
    "ok", "sensor count", "address slot", "converter setting", "tx buffer", "hal",
};

/* The C protocol of a machine.I2C or machine.SoftI2C object; NULL for any other bus. */
static const tn_i2c_p_t *i2c_protocol(mp_obj_t bus, mp_obj_t machine)
{
    const mp_obj_type_t *t = mp_obj_get_type(bus);
    const qstr types[2] = {MP_QSTR_I2C, MP_QSTR_SoftI2C};
    for (size_t k = 0; k < MP_ARRAY_SIZE(types); k++) {
        mp_obj_t dest[2];
        mp_load_method_maybe(machine, types[k], dest);
        if (dest[0] != MP_OBJ_NULL && MP_OBJ_TO_PTR(dest[0]) == t &&
            MP_OBJ_TYPE_HAS_SLOT(t, protocol)) {
            const tn_i2c_p_t *p = MP_OBJ_TYPE_GET_SLOT(t, protocol);
            return p->transfer ? p : NULL;
        }
    }
    return NULL;
}

static mp_obj_t board_make_new(const mp_obj_type_t *type, size_t n_args, size_t n_kw,
                               const mp_obj_t *args)
{
    mp_arg_check_num(n_args, n_kw, 5, 9, false);
    tn_board_obj_t *self = mp_obj_malloc(tn_board_obj_t, type);
    memset((uint8_t *)self + sizeof(mp_obj_base_t), 0, sizeof(*self) - sizeof(mp_obj_base_t));
    mp_obj_t machine = mp_import_name(MP_QSTR_machine, mp_const_none, MP_OBJ_NEW_SMALL_INT(0));
    size_t n, k;
    mp_obj_t *items;

    self->oserror = mp_load_global(MP_QSTR_OSError);
    mp_obj_get_array(args[0], &n, &items);
    if (n > TN_MAX_BUSES) {
        mp_raise_ValueError("at most 4 buses");
    }
    self->n_buses = (uint8_t)n;
    for (k = 0; k < n; k++) {
        self->buses[k] = items[k];
        self->i2c_p[k] = i2c_protocol(items[k], machine);
    }

    tc_config_t cfg;
    memset(&cfg, 0, sizeof(cfg));
    mp_obj_get_array(args[1], &n, &items);
    if (n < 1 || n > TC_MAX_SENSORS) {
        mp_raise_ValueError("a board reads 1..4 sensors");
    }
    cfg.n_sensors = (uint8_t)n;
    for (k = 0; k < n; k++) {
        size_t m;
        mp_obj_t *entry;
        mp_obj_get_array(items[k], &m, &entry);
        if (m < 2) {
            mp_raise_ValueError("layout: (bus, slot[, bus_hz]) per sensor");
        }
        tc_sensor_defaults(&cfg.sensors[k], (uint8_t)mp_obj_get_int(entry[0]),
                           (uint8_t)mp_obj_get_int(entry[1]));
        if (m > 2) {
            cfg.sensors[k].bus_hz = (uint32_t)mp_obj_get_int(entry[2]);
        }
    }

    if (mp_obj_get_type(args[2]) == &mp_type_tuple) { /* (stdin.buffer, stdout.buffer) */
        mp_obj_get_array(args[2], &n, &items);
        if (n != 2) {
            mp_raise_ValueError("link: (in stream, out stream) or a link object");
        }
        self->link = MP_OBJ_NULL;
        self->in = items[0];
        self->out = items[1];
        self->in_p = mp_get_stream_raise(self->in, MP_STREAM_OP_READ | MP_STREAM_OP_IOCTL);
        self->out_p = mp_get_stream_raise(self->out, MP_STREAM_OP_WRITE | MP_STREAM_OP_IOCTL);
    } else {
        self->link = args[2];
    }
    self->break_in = n_args > 7 && args[7] != mp_const_none
                         ? args[7]
                         : mp_load_global(MP_QSTR_KeyboardInterrupt);

    if (mp_obj_is_small_int(args[3]) || mp_obj_get_type(args[3]) == &mp_type_int) {
        self->timer = (volatile const uint32_t *)mp_obj_get_int_truncated(args[3]);
        cfg.ticks_bits = 32;
    } else {
        self->clock = args[3];
        cfg.ticks_bits = TN_TICKS_BITS_PY;
    }
    self->storage = args[4];
    cfg.boot_id = n_args > 5 ? (uint32_t)mp_obj_get_int_truncated(args[5]) : 0;
    cfg.max_rate_hz = n_args > 6 ? (uint16_t)mp_obj_get_int(args[6]) : 0;
    if (n_args > 8 && args[8] != mp_const_none) {
        mp_buffer_info_t id;
        mp_get_buffer_raise(args[8], &id, MP_BUFFER_READ);
        if (id.len != TC_BOARD_ID_SIZE) {
            mp_raise_ValueError("board_id: 8 bytes");
        }
        memcpy(cfg.board_id, id.buf, TC_BOARD_ID_SIZE);
    }
    self->tx = m_new(uint8_t, TN_TX_SIZE);
    cfg.tx_buf = self->tx;
    cfg.tx_size = TN_TX_SIZE;

    tc_hal_t hal = {
        .ctx = self,
        .i2c_write = i2c_write,
        .i2c_read = i2c_read,
        .write = link_write,
        .read = link_read,
        .ticks_us = ticks_us,
        .blob_read = blob_read,
        .blob_write = blob_write,
        .opened = NULL,
        .streaming = NULL,
    };
    if (self->link != MP_OBJ_NULL) {
        mp_obj_t dest[2];
        mp_load_method_maybe(self->link, MP_QSTR_opened, dest);
        hal.opened = dest[0] != MP_OBJ_NULL ? link_opened : NULL;
        mp_load_method_maybe(self->link, MP_QSTR_streaming, dest);
        hal.streaming = dest[0] != MP_OBJ_NULL ? link_streaming : NULL;
    }
    int r = tc_board_init(&self->board, &cfg, &hal);
    if (r != TC_INIT_OK) {
        mp_raise_ValueError(init_errors[r]);
    }
    return MP_OBJ_FROM_PTR(self);
}

static mp_obj_t board_boot(mp_obj_t self_in)
{
    tn_board_obj_t *self = MP_OBJ_TO_PTR(self_in);
    tc_board_boot(&self->board);
    return mp_const_none;
}
static MP_DEFINE_CONST_FUN_OBJ_1(board_boot_obj, board_boot);

static mp_obj_t board_poll(mp_obj_t self_in)
{
    tn_board_obj_t *self = MP_OBJ_TO_PTR(self_in);
    tc_board_poll(&self->board);
    return mp_const_none;
}
static MP_DEFINE_CONST_FUN_OBJ_1(board_poll_obj, board_poll);

static mp_obj_t board_idle_us(mp_obj_t self_in)
{
    tn_board_obj_t *self = MP_OBJ_TO_PTR(self_in);
    return mp_obj_new_int_from_uint(tc_board_idle_us(&self->board));
}
static MP_DEFINE_CONST_FUN_OBJ_1(board_idle_us_obj, board_idle_us);

/* Counters read as attributes (board.samples, ...), as tactile_fw_tools.ccore.STATS
 * names them; last_error can be set (port_mpy.run records an exception there). */
static void board_attr(mp_obj_t self_in, qstr attr, mp_obj_t *dest)
{
    tn_board_obj_t *self = MP_OBJ_TO_PTR(self_in);
    const qstr names[] = {
        MP_QSTR_samples, MP_QSTR_i2c_errors, MP_QSTR_drdy_timeouts, MP_QSTR_saturations,
        MP_QSTR_overruns, MP_QSTR_tx_dropped, MP_QSTR_rx_errors, MP_QSTR_last_error,
        MP_QSTR_streaming, MP_QSTR_tx_seq, MP_QSTR_time_us, MP_QSTR_max_rate_hz,
        MP_QSTR_tx_used,
    };
    if (dest[0] == MP_OBJ_SENTINEL) { /* store */
        if (attr == MP_QSTR_last_error && dest[1] != MP_OBJ_NULL) {
            self->board.last_error = (uint8_t)mp_obj_get_int(dest[1]);
            dest[0] = MP_OBJ_NULL;
        }
        return;
    }
    if (dest[0] != MP_OBJ_NULL) {
        return;
    }
    for (size_t k = 0; k < MP_ARRAY_SIZE(names); k++) {
        if (attr == names[k]) {
            dest[0] = mp_obj_new_int_from_uint(tc_board_stat(&self->board, (int)k));
            return;
        }
    }
    dest[1] = MP_OBJ_SENTINEL; /* methods: the locals dict */
}

mp_obj_t mpy_init(mp_obj_fun_bc_t *self, size_t n_args, size_t n_kw, mp_obj_t *args)
{
    MP_DYNRUNTIME_INIT_ENTRY

    tn_board_type.base.type = (void *)&mp_type_type;
    tn_board_type.flags = MP_TYPE_FLAG_NONE;
    tn_board_type.name = MP_QSTR_Board;
    MP_OBJ_TYPE_SET_SLOT(&tn_board_type, make_new, board_make_new, 0);
    MP_OBJ_TYPE_SET_SLOT(&tn_board_type, attr, board_attr, 1);
    tn_board_locals_table[0] =
        (mp_map_elem_t){MP_OBJ_NEW_QSTR(MP_QSTR_boot), MP_OBJ_FROM_PTR(&board_boot_obj)};
    tn_board_locals_table[1] =
        (mp_map_elem_t){MP_OBJ_NEW_QSTR(MP_QSTR_poll), MP_OBJ_FROM_PTR(&board_poll_obj)};
    tn_board_locals_table[2] =
        (mp_map_elem_t){MP_OBJ_NEW_QSTR(MP_QSTR_idle_us), MP_OBJ_FROM_PTR(&board_idle_us_obj)};
    MP_OBJ_TYPE_SET_SLOT(&tn_board_type, locals_dict, (void *)&tn_board_locals, 2);
    mp_store_global(MP_QSTR_Board, MP_OBJ_FROM_PTR(&tn_board_type));

    mp_obj_t fw[3] = {MP_OBJ_NEW_SMALL_INT(TC_FW_MAJOR), MP_OBJ_NEW_SMALL_INT(TC_FW_MINOR),
                      MP_OBJ_NEW_SMALL_INT(TC_FW_PATCH)};
    mp_store_global(MP_QSTR_FW_VERSION, mp_obj_new_tuple(3, fw));
    mp_store_global(MP_QSTR_PROTOCOL_VERSION, MP_OBJ_NEW_SMALL_INT(TC_PROTOCOL_VERSION));
    mp_store_global(MP_QSTR_API, MP_OBJ_NEW_SMALL_INT(TN_API));

    MP_DYNRUNTIME_INIT_EXIT
}
