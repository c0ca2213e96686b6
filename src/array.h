/* SPDX-License-Identifier: MIT */
/*
 * Heap arrays that grow by doubling, and the order of 64-bit keys, for the files that keep
 * growing lists (body contact, collider contact, the broad phase, the pattern's extra pairs).
 */
#ifndef DEFSIM_ARRAY_H
#define DEFSIM_ARRAY_H

#include <stddef.h>
#include <stdint.h>
#include <stdlib.h>

/* The capacity after growing `cap` (0: start at `first`) by doubling until it holds `need`. */
static inline int64_t defsim__grown_cap(int64_t cap, int64_t need, int64_t first)
{
    int64_t c = cap > 0 ? cap : first;
    while (c < need) c *= 2;
    return c;
}

/* Makes *p hold at least `need` elements of `elem` bytes (*cap of them now); 0 if out of
 * memory (then *p and *cap are unchanged). */
static inline int defsim__grow(void **p, int64_t *cap, int64_t need, size_t elem, int64_t first)
{
    if (need <= *cap) return 1;
    const int64_t c = defsim__grown_cap(*cap, need, first);
    void *q = realloc(*p, (size_t)c * elem);
    if (!q) return 0;
    *p = q;
    *cap = c;
    return 1;
}

/* Reallocates n parallel arrays (arrays[k] of elem[k] bytes per entry) to `cap` entries; 0 if
 * one failed (those that succeeded keep their new size, so the caller keeps its old capacity). */
static inline int defsim__grow_parallel(void **const arrays[], const size_t elem[], int n,
                                        int64_t cap)
{
    int ok = 1;
    for (int k = 0; k < n; ++k) {
        void *q = realloc(*arrays[k], (size_t)cap * elem[k]);
        if (q) *arrays[k] = q;
        else ok = 0;
    }
    return ok;
}

/* qsort's comparison of int64_t keys. */
static inline int defsim__cmp_i64(const void *a, const void *b)
{
    const int64_t x = *(const int64_t *)a, y = *(const int64_t *)b;
    return (x > y) - (x < y);
}

#endif /* DEFSIM_ARRAY_H */
