/* SPDX-License-Identifier: MIT */
/* The bytes of a checkpoint's chunks (chunk.h): CRC-32, the writer and its chunk frame, the
 * reader. */
#include "chunk.h"

#include <stdlib.h>
#include <string.h>

uint32_t defsim__crc32(uint32_t crc, const void *data, size_t n)
{
    const unsigned char *p = data;
    crc = ~crc;
    for (size_t i = 0; i < n; ++i) {
        crc ^= p[i];
        for (int k = 0; k < 8; ++k) crc = (crc >> 1) ^ (0xEDB88320u & (0u - (crc & 1u)));
    }
    return ~crc;
}

/* ------------------------------------------------------------------------------------------ */
/* Writer */

void defsim__put(defsim__bw *b, const void *data, size_t n)
{
    if (b->oom || n == 0) return;
    if (b->n + n > b->cap) {
        size_t cap = b->cap ? b->cap : 4096;
        while (cap < b->n + n) cap *= 2;
        unsigned char *q = realloc(b->p, cap);
        if (!q) {
            b->oom = 1;
            return;
        }
        b->p = q;
        b->cap = cap;
    }
    memcpy(b->p + b->n, data, n);
    b->n += n;
}

void defsim__put_u32(defsim__bw *b, uint32_t v)
{
    const unsigned char c[4] = {(unsigned char)v, (unsigned char)(v >> 8),
                                (unsigned char)(v >> 16), (unsigned char)(v >> 24)};
    defsim__put(b, c, 4);
}

void defsim__put_u64(defsim__bw *b, uint64_t v)
{
    unsigned char c[8];
    for (int k = 0; k < 8; ++k) c[k] = (unsigned char)(v >> (8 * k));
    defsim__put(b, c, 8);
}

void defsim__put_i32(defsim__bw *b, int32_t v) { defsim__put_u32(b, (uint32_t)v); }

void defsim__put_f64(defsim__bw *b, double v)
{
    uint64_t u;
    memcpy(&u, &v, sizeof u);
    defsim__put_u64(b, u);
}

void defsim__put_f64s(defsim__bw *b, const double *v, int64_t n)
{
    for (int64_t i = 0; i < n; ++i) defsim__put_f64(b, v[i]);
}

void defsim__put_i32s(defsim__bw *b, const int32_t *v, int64_t n)
{
    for (int64_t i = 0; i < n; ++i) defsim__put_i32(b, v[i]);
}

void defsim__put_str(defsim__bw *b, const char *s)
{
    const size_t n = strlen(s);
    defsim__put_u32(b, (uint32_t)n);
    defsim__put(b, s, n);
}

size_t defsim__chunk_begin(defsim__bw *b, const char tag[4])
{
    const size_t at = b->n;
    defsim__put(b, tag, 4);
    defsim__put_u64(b, 0);
    return at;
}

void defsim__chunk_end(defsim__bw *b, size_t at)
{
    if (b->oom) return;
    const uint64_t len = b->n - at - 12;
    for (int k = 0; k < 8; ++k) b->p[at + 4 + k] = (unsigned char)(len >> (8 * k));
    defsim__put_u32(b, defsim__crc32(0, b->p + at, b->n - at));
}

/* ------------------------------------------------------------------------------------------ */
/* Reader */

const unsigned char *defsim__take(defsim__br *r, size_t n)
{
    if (r->bad || n > r->n - r->at) {
        r->bad = 1;
        return NULL;
    }
    const unsigned char *q = r->p + r->at;
    r->at += n;
    return q;
}

uint32_t defsim__get_u32(defsim__br *r)
{
    const unsigned char *c = defsim__take(r, 4);
    return c ? (uint32_t)c[0] | (uint32_t)c[1] << 8 | (uint32_t)c[2] << 16 | (uint32_t)c[3] << 24
             : 0;
}

uint64_t defsim__get_u64(defsim__br *r)
{
    const unsigned char *c = defsim__take(r, 8);
    uint64_t v = 0;
    if (c)
        for (int k = 0; k < 8; ++k) v |= (uint64_t)c[k] << (8 * k);
    return v;
}

int32_t defsim__get_i32(defsim__br *r) { return (int32_t)defsim__get_u32(r); }

double defsim__get_f64(defsim__br *r)
{
    const uint64_t u = defsim__get_u64(r);
    double v;
    memcpy(&v, &u, sizeof v);
    return v;
}

void defsim__get_f64s(defsim__br *r, double *v, int64_t n)
{
    for (int64_t i = 0; i < n; ++i) v[i] = defsim__get_f64(r);
}

void defsim__get_i32s(defsim__br *r, int32_t *v, int64_t n)
{
    for (int64_t i = 0; i < n; ++i) v[i] = defsim__get_i32(r);
}

void defsim__get_str(defsim__br *r, char *buf, size_t cap)
{
    const uint32_t n = defsim__get_u32(r);
    const unsigned char *c = n < cap ? defsim__take(r, n) : NULL;
    if (!c) {
        r->bad = 1;
        buf[0] = '\0';
        return;
    }
    memcpy(buf, c, n);
    buf[n] = '\0';
}

int defsim__fits(const defsim__br *r, int64_t count, size_t unit)
{
    return !r->bad && count >= 0 && (uint64_t)count <= (r->n - r->at) / unit;
}

int defsim__read_whole(const defsim__br *r) { return !r->bad && r->at == r->n; }

/* ------------------------------------------------------------------------------------------ */
/* A backend's history over the writer and the reader */

static defsim_status sw_f64(void *ctx, const double *v, int64_t n)
{
    defsim__put_f64s(ctx, v, n);
    return ((defsim__bw *)ctx)->oom ? DEFSIM_ERR_OUT_OF_MEMORY : DEFSIM_OK;
}

static defsim_status sw_i64(void *ctx, const int64_t *v, int64_t n)
{
    for (int64_t i = 0; i < n; ++i) defsim__put_u64(ctx, (uint64_t)v[i]);
    return ((defsim__bw *)ctx)->oom ? DEFSIM_ERR_OUT_OF_MEMORY : DEFSIM_OK;
}

static defsim_status sr_f64(void *ctx, double *v, int64_t n)
{
    defsim__br *r = ctx;
    if (!defsim__fits(r, n, 8)) return DEFSIM_ERR_IO;
    defsim__get_f64s(r, v, n);
    return DEFSIM_OK;
}

static defsim_status sr_i64(void *ctx, int64_t *v, int64_t n)
{
    defsim__br *r = ctx;
    if (!defsim__fits(r, n, 8)) return DEFSIM_ERR_IO;
    for (int64_t i = 0; i < n; ++i) v[i] = (int64_t)defsim__get_u64(r);
    return DEFSIM_OK;
}

static int64_t sr_remaining(void *ctx)
{
    const defsim__br *r = ctx;
    return r->bad ? 0 : (int64_t)((r->n - r->at) / 8);
}

defsim_state_writer defsim__state_writer(defsim__bw *b)
{
    return (defsim_state_writer){b, sw_f64, sw_i64};
}

defsim_state_reader defsim__state_reader(defsim__br *r)
{
    return (defsim_state_reader){r, sr_f64, sr_i64, sr_remaining};
}
