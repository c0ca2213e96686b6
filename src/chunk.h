/* SPDX-License-Identifier: MIT */
/*
 * The bytes of a checkpoint's chunks (docs/checkpoints.md), below every sub-object that writes
 * one: a growing little-endian writer with the chunk frame (tag, length, payload, CRC-32) and a
 * reader over one chunk's payload. checkpoint.c sequences the chunks; body.c, coupling_set.c,
 * collider.c and the backend slot write and read their own through these.
 */
#ifndef DEFSIM_CHUNK_H
#define DEFSIM_CHUNK_H

#include "defsim/backend.h"

#include <stddef.h>
#include <stdint.h>

/* CRC-32 (IEEE 802.3, reflected, polynomial 0xEDB88320) of n bytes, continuing from crc (0 to
 * start). */
uint32_t defsim__crc32(uint32_t crc, const void *data, size_t n);

/* Writer: owns p (free it); after an allocation failure every put is ignored and oom stays
 * set. Numbers go little-endian, doubles as their IEEE binary64 bit patterns. */
typedef struct defsim__bw {
    unsigned char *p;
    size_t n, cap;
    int oom;
} defsim__bw;

void defsim__put(defsim__bw *b, const void *data, size_t n);
void defsim__put_u32(defsim__bw *b, uint32_t v);
void defsim__put_u64(defsim__bw *b, uint64_t v);
void defsim__put_i32(defsim__bw *b, int32_t v);
void defsim__put_f64(defsim__bw *b, double v);
void defsim__put_f64s(defsim__bw *b, const double *v, int64_t n);
void defsim__put_i32s(defsim__bw *b, const int32_t *v, int64_t n);
void defsim__put_str(defsim__bw *b, const char *s);   /* u32 length, then the bytes */

/* A chunk: tag (4 ASCII bytes), payload length (u64), payload, CRC-32 of all of those. begin
 * returns where the chunk starts, for end, which fills in its length and CRC. */
size_t defsim__chunk_begin(defsim__bw *b, const char tag[4]);
void defsim__chunk_end(defsim__bw *b, size_t at);

/* Reader over one payload (borrowed): a read past the end sets bad and yields zeros. */
typedef struct defsim__br {
    const unsigned char *p;
    size_t n, at;
    int bad;
} defsim__br;

const unsigned char *defsim__take(defsim__br *r, size_t n);
uint32_t defsim__get_u32(defsim__br *r);
uint64_t defsim__get_u64(defsim__br *r);
int32_t defsim__get_i32(defsim__br *r);
double defsim__get_f64(defsim__br *r);
void defsim__get_f64s(defsim__br *r, double *v, int64_t n);
void defsim__get_i32s(defsim__br *r, int32_t *v, int64_t n);
/* A string into buf (NUL-terminated); one longer than cap - 1 bytes sets bad. */
void defsim__get_str(defsim__br *r, char *buf, size_t cap);
/* 1 if count elements of at least `unit` bytes each still fit in the payload: counts read from
 * a file are checked so before anything is allocated for them. */
int defsim__fits(const defsim__br *r, int64_t count, size_t unit);
/* 1 if the payload was read to its end and nothing was missing. */
int defsim__read_whole(const defsim__br *r);

/* A backend's history (save_state, load_state) through b or r: the writer and the reader of
 * backend.h over them (checkpoints' BKND chunk, recordings' checkpoints in tape.c). */
defsim_state_writer defsim__state_writer(defsim__bw *b);
defsim_state_reader defsim__state_reader(defsim__br *r);

#endif /* DEFSIM_CHUNK_H */
