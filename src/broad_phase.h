/* SPDX-License-Identifier: MIT */
/*
 * Broad phase for body-body and self-contact (broad_phase.c): a spatial hash of axis-aligned
 * boxes (uniform cells hashed into buckets, counting-sorted in box order, so the pairs come out
 * in one deterministic order whatever the thread count; cost linear in the boxes), and the
 * unique edges of triangle lists (the
 * boundary triangles of tet meshes come from defsim__tet_boundary, mesh.h).
 */
#ifndef DEFSIM_BROAD_PHASE_H
#define DEFSIM_BROAD_PHASE_H

#include "defsim/defsim.h"

#include <stdint.h>

/* Growable scratch of the hash: reused across steps, so a step allocates only when a scene
 * needs more room than before. Zero-initialise; free with defsim__hash_free. */
typedef struct defsim__hash_entry {
    int32_t b;                /* a box of B */
    int32_t c0[3];            /* its lowest cell */
} defsim__hash_entry;

typedef struct defsim__hash {
    defsim__hash_entry *keys; /* the inserted boxes of B, grouped by the bucket of each cell they
                                 overlap (box order within a bucket) */
    int64_t nkeys, cap_keys;
    uint32_t *bucket;         /* the bucket of each entry, in insertion order */
    int64_t cap_bucket;
    int32_t *start;           /* buckets + 1: where each bucket's boxes start in keys */
    int64_t cap_start;
    int64_t *pairs;           /* (a << 32 | b) of the last query, sorted, unique */
    int64_t npairs, cap_pairs;
} defsim__hash;

void defsim__hash_free(defsim__hash *h);

/* Pairs (a, b) of overlapping closed boxes, a from set A (na boxes) and b from set B (nb boxes;
 * lo and hi are 3 doubles per box), each reported once. With self != 0, A and B must be the same set and only
 * pairs a < b are reported. cell (m) is the hash's cell size: about the size of a typical box
 * (coarsened, doubling, while B's boxes overlap more than 8 cells each on average; 0: per axis,
 * 1.4 times the mean extent of B's boxes along it, at least a quarter of the largest such). The pairs land in h->pairs (sorted, unique), each
 * packed as ((int64_t)a << 32) | b. Returns DEFSIM_OK or DEFSIM_ERR_OUT_OF_MEMORY. */
defsim_status defsim__hash_pairs(defsim__hash *h, const double *lo_a, const double *hi_a,
                                 int32_t na, const double *lo_b, const double *hi_b, int32_t nb,
                                 int self, double cell);

/* The unique edges of a triangle list, each as (min, max), sorted. *edges is allocated (2 *ne
 * ints; free()). Returns DEFSIM_OK or DEFSIM_ERR_OUT_OF_MEMORY. */
defsim_status defsim__triangle_edges(const int32_t *tris, int32_t nf, int32_t **edges,
                                     int32_t *ne);

#endif /* DEFSIM_BROAD_PHASE_H */
