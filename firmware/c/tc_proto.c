/* Protocol: CRC-16/CCITT-FALSE, COBS, table-driven pack/unpack, frame encoder and the
 * byte-at-a-time assembler (tactile_protocol: crc16.py, cobs_codec.py, messages.py,
 * framing.py). The tables come from tc_gen.c, generated from messages.SPECS. */
#include <string.h>

#include "tactile_core.h"

uint16_t tc_crc16(const uint8_t *data, size_t n, uint16_t crc)
{
    size_t i;
    for (i = 0; i < n; i++) {
        crc = (uint16_t)((crc << 8) ^ tc_crc_table[(crc >> 8) ^ data[i]]);
    }
    return crc;
}

size_t tc_cobs_encode(const uint8_t *src, size_t n, uint8_t *dst)
{
    const uint8_t *end = src + n;
    uint8_t *code = dst, *out = dst + 1; /* code: where the current block's length goes */
    if (n < 254) { /* a frame (at most TC_MAX_BODY + 2 bytes): no block can fill up */
        while (src != end) {
            uint8_t byte = *src++;
            if (byte) {
                *out++ = byte;
            } else {
                *code = (uint8_t)(out - code);
                code = out++;
            }
        }
    } else {
        while (src != end) {
            uint8_t byte = *src++;
            if (byte) {
                *out++ = byte;
                if (out - code == 0xFF && src != end) { /* full block, more data follows */
                    *code = 0xFF;
                    code = out++;
                }
            } else {
                *code = (uint8_t)(out - code);
                code = out++;
            }
        }
    }
    *code = (uint8_t)(out - code);
    return (size_t)(out - dst);
}

int tc_cobs_decode_in_place(uint8_t *buf, size_t n)
{
    size_t i = 0, out = 0, j;
    while (i < n) {
        size_t code = buf[i];
        if (code == 0 || i + code > n) {
            return -1;
        }
        for (j = i + 1; j < i + code; j++) {
            buf[out++] = buf[j];
        }
        i += code;
        if (code != 0xFF && i < n) {
            buf[out++] = 0;
        }
    }
    return (int)out;
}

const tc_msg_desc_t *tc_msg_desc(uint8_t type)
{
    int k;
    for (k = 0; k < TC_N_MESSAGES; k++) {
        if (tc_messages[k].type == type) {
            return &tc_messages[k];
        }
    }
    return NULL;
}

static void put_le(uint8_t *p, uint32_t v, int size)
{
    int k;
    for (k = 0; k < size; k++) {
        p[k] = (uint8_t)(v >> (8 * k));
    }
}

static uint32_t get_le(const uint8_t *p, int size)
{
    uint32_t v = 0;
    int k;
    for (k = size - 1; k >= 0; k--) {
        v = (v << 8) | p[k];
    }
    return v;
}

static const uint8_t kind_size[] = {1, 2, 4, 4, 4, 1}; /* TC_U8 .. TC_BYTES */

/* Message structs hold native integers; on a little-endian CPU (ARM, x86) their bytes are
 * already the wire's, so a field is a byte copy; elsewhere values are moved one by one. */
#if defined(__BYTE_ORDER__) && __BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__
#define NATIVE_LE 1
#else
#define NATIVE_LE 0
#endif

static void copy_bytes(uint8_t *dst, const uint8_t *src, size_t n)
{
    size_t k;
    for (k = 0; k < n; k++) { /* a few bytes: cheaper than a call to memcpy */
        dst[k] = src[k];
    }
}

size_t tc_pack(uint8_t *body, uint8_t type, uint16_t seq, uint32_t ts, const void *msg)
{
    const tc_msg_desc_t *d = tc_msg_desc(type);
    const uint8_t *m = (const uint8_t *)msg;
    int f, k;
    body[0] = TC_PROTOCOL_VERSION;
    body[1] = type;
    put_le(body + 2, seq, 2);
    put_le(body + 4, ts, 4);
    for (f = 0; f < d->n_fields; f++) {
        const tc_field_t *fd = &d->fields[f];
        int size = kind_size[fd->kind];
        if (NATIVE_LE || size == 1) {
            copy_bytes(body + fd->wire, m + fd->mem, (size_t)size * fd->count);
            continue;
        }
        for (k = 0; k < fd->count; k++) {
            const uint8_t *src = m + fd->mem + (size_t)k * (size_t)size;
            uint32_t v;
            if (fd->kind == TC_U16) {
                uint16_t h;
                memcpy(&h, src, 2);
                v = h;
            } else {
                memcpy(&v, src, 4); /* u32, i32 (two's complement) and float32 bits */
            }
            put_le(body + fd->wire + k * size, v, size);
        }
    }
    return d->body_len;
}

int tc_unpack(const uint8_t *body, size_t n, tc_header_t *h, tc_msg_t *msg)
{
    const tc_msg_desc_t *d;
    uint8_t *m = (uint8_t *)msg;
    int f, k;
    if (n < TC_HEADER_SIZE) {
        return TC_UNPACK_SHORT;
    }
    h->version = body[0];
    h->type = body[1];
    h->seq = (uint16_t)get_le(body + 2, 2);
    h->timestamp_us = get_le(body + 4, 4);
    if (body[0] != TC_PROTOCOL_VERSION) {
        return TC_UNPACK_VERSION;
    }
    d = tc_msg_desc(body[1]);
    if (d == NULL) {
        return TC_UNPACK_TYPE;
    }
    if (n != d->body_len) {
        return TC_UNPACK_LENGTH;
    }
    memset(msg, 0, sizeof(*msg));
    for (f = 0; f < d->n_fields; f++) {
        const tc_field_t *fd = &d->fields[f];
        int size = kind_size[fd->kind];
        if (fd->kind == TC_BYTES) {
            memcpy(m + fd->mem, body + fd->wire, fd->count);
            continue;
        }
        for (k = 0; k < fd->count; k++) {
            uint8_t *dst = m + fd->mem + (size_t)k * (size_t)size;
            uint32_t v = get_le(body + fd->wire + k * size, size);
            if (fd->kind == TC_U8) {
                *dst = (uint8_t)v;
            } else if (fd->kind == TC_U16) {
                uint16_t s = (uint16_t)v;
                memcpy(dst, &s, 2);
            } else {
                memcpy(dst, &v, 4);
            }
        }
    }
    return TC_UNPACK_OK;
}

size_t tc_msg_size(void)
{
    return sizeof(tc_msg_t);
}

/* One byte of tc_encode's single pass: into the CRC, then COBS-encoded. */
#define CRC_COBS(byte)                                                        \
    do {                                                                      \
        crc = (crc << 8) ^ tc_crc_table[((crc >> 8) ^ (byte)) & 0xFFu];       \
        if (byte) {                                                           \
            *out++ = (byte);                                                  \
        } else {                                                              \
            *code = (uint8_t)(out - code);                                    \
            code = out++;                                                     \
        }                                                                     \
    } while (0)

size_t tc_encode(tc_encoder_t *e, uint8_t type, uint32_t ts, const void *msg)
{
    return tc_encode_into(e, type, ts, msg, e->out);
}

size_t tc_encode_into(tc_encoder_t *e, uint8_t type, uint32_t ts, const void *msg, uint8_t *dst)
{
    size_t n = tc_pack(e->body, type, e->seq, ts, msg);
    const uint8_t *src = e->body, *end = src + n;
    uint8_t *code = dst, *out = dst + 1, lo, hi; /* code: the COBS block's length byte */
    uint32_t crc = 0xFFFF; /* bits above 16 are stale; the table index takes bits 8-15 */
    /* tc_crc16 and tc_cobs_encode in one pass: a body and its CRC (at most TC_MAX_BODY + 2
     * < 254 bytes) never fill a COBS block, so no byte needs the long form */
    while (src != end) {
        uint8_t byte = *src++;
        CRC_COBS(byte);
    }
    lo = (uint8_t)crc;
    hi = (uint8_t)(crc >> 8);
    e->body[n] = lo;
    e->body[n + 1] = hi;
    CRC_COBS(lo);
    CRC_COBS(hi);
    *code = (uint8_t)(out - code);
    *out++ = 0;
    e->seq = (uint16_t)(e->seq + 1);
    return (size_t)(out - dst);
}

void tc_assembler_init(tc_assembler_t *a)
{
    a->n = 0;
    a->overflow = 0;
    a->body_len = 0;
}

int tc_assembler_feed(tc_assembler_t *a, uint8_t byte)
{
    uint16_t n;
    int m, body_len;
    uint16_t crc;
    if (byte != 0) {
        if (a->n < TC_MAX_ENCODED) {
            a->buf[a->n++] = byte;
        } else {
            a->overflow = 1;
        }
        return TC_FRAME_NONE;
    }
    n = a->n;
    a->n = 0;
    if (a->overflow) {
        a->overflow = 0;
        return TC_FRAME_OVERSIZE;
    }
    if (n == 0) {
        return TC_FRAME_NONE;
    }
    m = tc_cobs_decode_in_place(a->buf, n);
    if (m < TC_CRC_SIZE + 1) {
        return TC_FRAME_BAD;
    }
    body_len = m - TC_CRC_SIZE;
    crc = tc_crc16(a->buf, (size_t)body_len, 0xFFFF);
    if (crc != (a->buf[body_len] | (a->buf[body_len + 1] << 8))) {
        return TC_FRAME_BAD;
    }
    a->body_len = (uint8_t)body_len;
    return TC_FRAME_OK;
}
