/* Protocol: CRC-16/CCITT-FALSE, COBS, table-driven pack/unpack, frame encoder and the
 * byte-at-a-time assembler (tactile_protocol: crc16.py, cobs_codec.py, messages.py,
 * framing.py). The tables come from tc_gen.c, generated from messages.SPECS. */
#include <string.h>

#include "tactile_core.h"

/* One table step with the CRC in bits 16-31 of c: c >> 24 is its high byte, unmasked. */
#define CRC_STEP(c, byte) ((c) << 8 ^ (uint32_t)tc_crc_table[(c) >> 24 ^ (byte)] << 16)

uint16_t tc_crc16(const uint8_t *data, size_t n, uint16_t crc)
{
    const uint8_t *end = data + n;
    uint32_t c = (uint32_t)crc << 16;
    if (n & 1) {
        c = CRC_STEP(c, *data++);
    }
    while (data != end) { /* two bytes a turn: half the loop's own instructions */
        c = CRC_STEP(c, data[0]);
        c = CRC_STEP(c, data[1]);
        data += 2;
    }
    return (uint16_t)(c >> 16);
}

size_t tc_cobs_encode(const uint8_t *src, size_t n, uint8_t *dst)
{
    const uint8_t *end = src + n;
    uint8_t *code = dst, *out = dst + 1; /* code: where the current block's length goes */
    if (n < 254) { /* a frame (at most TC_MAX_BODY + 2 bytes): no block can fill up */
        for (; src != end; out++) {
            uint8_t byte = *src++;
            if (byte) {
                *out = byte;
            } else { /* this byte's place holds the next block's length */
                *code = (uint8_t)(out - code);
                code = out;
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

size_t tc_pack(uint8_t *body, uint8_t type, uint16_t seq, uint32_t ts, const void *msg)
{
    const tc_msg_desc_t *d = tc_msg_desc(type);
    const uint8_t *m = (const uint8_t *)msg;
    const tc_field_t *fd = d->fields, *last = fd + d->n_fields;
    body[0] = TC_PROTOCOL_VERSION;
    body[1] = type;
    put_le(body + 2, seq, 2);
    put_le(body + 4, ts, 4);
    for (; fd != last; fd++) {
        uint8_t *dst = body + fd->wire;
        const void *src = m + fd->mem; /* a struct member: aligned for its type */
        int k, count = fd->count;
        if (fd->kind == TC_U32 || fd->kind == TC_I32) { /* (int32_t read as its unsigned twin) */
            const uint32_t *w = (const uint32_t *)src;
            for (k = 0; k < count; k++, dst += 4) {
                uint32_t v = w[k];
                dst[0] = (uint8_t)v;
                dst[1] = (uint8_t)(v >> 8);
                dst[2] = (uint8_t)(v >> 16);
                dst[3] = (uint8_t)(v >> 24);
            }
        } else if (fd->kind == TC_U16) {
            const uint16_t *h = (const uint16_t *)src;
            for (k = 0; k < count; k++, dst += 2) {
                dst[0] = (uint8_t)h[k];
                dst[1] = (uint8_t)(h[k] >> 8);
            }
        } else if (fd->kind == TC_F32) {
            for (k = 0; k < count; k++) {
                uint32_t v;
                memcpy(&v, (const uint8_t *)src + 4 * k, 4); /* float32 bits */
                put_le(dst + 4 * k, v, 4);
            }
        } else { /* TC_U8, TC_BYTES */
            const uint8_t *b = (const uint8_t *)src;
            for (k = 0; k < count; k++) { /* a few bytes: cheaper than a call to memcpy */
                dst[k] = b[k];
            }
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

size_t tc_encode(tc_encoder_t *e, uint8_t type, uint32_t ts, const void *msg)
{
    return tc_encode_into(e, type, ts, msg, e->out);
}

size_t tc_encode_into(tc_encoder_t *e, uint8_t type, uint32_t ts, const void *msg, uint8_t *dst)
{
    size_t n = tc_pack(e->body, type, e->seq, ts, msg);
    uint16_t crc = tc_crc16(e->body, n, 0xFFFF);
    size_t end;
    e->body[n] = (uint8_t)(crc & 0xFF);
    e->body[n + 1] = (uint8_t)(crc >> 8);
    end = tc_cobs_encode(e->body, n + TC_CRC_SIZE, dst);
    dst[end] = 0;
    e->seq = (uint16_t)(e->seq + 1);
    return end + 1;
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
