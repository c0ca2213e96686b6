/* SPDX-License-Identifier: MIT */
/*
 * Broad phase (broad_phase.h). The hash: every box of B is inserted in the cells it overlaps
 * (cell coordinates hashed into a bucket), the boxes are counting-sorted by bucket in box order,
 * and every box of A visits the buckets of the cells it overlaps and tests the boxes found there,
 * reporting each overlapping pair from one cell only. The result does not depend on the thread
 * count; the cost is linear in the boxes (and the cells they overlap, at most 8 per box of B on
 * average).
 */
#include "broad_phase.h"

#include "array.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

void defsim__hash_free(defsim__hash *h)
{
    free(h->keys);
    free(h->bucket);
    free(h->start);
    free(h->pairs);
    memset(h, 0, sizeof *h);
}

static int reserve(void **p, int64_t *cap, int64_t need, size_t size)
{
    return defsim__grow(p, cap, need, size, 256);
}

static double dmin(double a, double b) { return b < a ? b : a; }
static double dmax(double a, double b) { return b > a ? b : a; }

/* Cell coordinates are clamped to 21 bits per axis (2M cells): the key of (i, j, k) fits in 63
 * bits, and boxes beyond the clamped range share the border cells (correct, only slower). The
 * test is written so that NaN lands in cell 0; truncation is floor for the positive values left. */
static int32_t cell_of(double v, double origin, double inv)
{
    const double c = (v - origin) * inv;
    if (!(c > 0.0)) return 0;
    if (c >= 2097151.0) return 2097151;
    return (int32_t)c;
}

static uint32_t key_of(int64_t i, int64_t j, int64_t k)
{
    /* A 32-bit hash of the cell: boxes in different cells may share a key (they are then
     * compared for nothing), never the other way round. */
    uint64_t z = (uint64_t)i * 0x9E3779B97F4A7C15ull ^ (uint64_t)j * 0xC2B2AE3D27D4EB4Full ^
                 (uint64_t)k * 0x165667B19E3779F9ull;
    z ^= z >> 29;
    return (uint32_t)(z * 0xBF58476D1CE4E5B9ull >> 32);
}

static int overlap(const double *lo_a, const double *hi_a, const double *lo_b, const double *hi_b)
{
    return lo_a[0] <= hi_b[0] && lo_b[0] <= hi_a[0] && lo_a[1] <= hi_b[1] &&
           lo_b[1] <= hi_a[1] && lo_a[2] <= hi_b[2] && lo_b[2] <= hi_a[2];
}

/* The cell range of a box along each axis. */
static void range(const double *lo, const double *hi, const double *origin, const double *inv,
                  int32_t r[3][2])
{
    for (int a = 0; a < 3; ++a) {
        r[a][0] = cell_of(lo[a], origin[a], inv[a]);
        r[a][1] = cell_of(hi[a], origin[a], inv[a]);
    }
}

static int64_t cells_in(const int32_t r[3][2])
{
    return (int64_t)(r[0][1] - r[0][0] + 1) * (r[1][1] - r[1][0] + 1) * (r[2][1] - r[2][0] + 1);
}

/* Cells that the boxes of B overlap in all, with cell sizes 1 / inv. */
static int64_t count_cells(const double *lo_b, const double *hi_b, int32_t nb,
                           const double *origin, const double *inv)
{
    int64_t n = 0;
    for (int32_t b = 0; b < nb; ++b) {
        int32_t r[3][2];
        range(lo_b + 3 * b, hi_b + 3 * b, origin, inv, r);
        n += cells_in(r);
    }
    return n;
}

defsim_status defsim__hash_pairs(defsim__hash *h, const double *lo_a, const double *hi_a,
                                 int32_t na, const double *lo_b, const double *hi_b, int32_t nb,
                                 int self, double cell)
{
    h->nkeys = h->npairs = 0;
    if (na == 0 || nb == 0) return DEFSIM_OK;
    double origin[3] = {INFINITY, INFINITY, INFINITY}, far[3] = {-INFINITY, -INFINITY, -INFINITY};
    for (int32_t b = 0; b < nb; ++b)
        for (int a = 0; a < 3; ++a) {
            origin[a] = dmin(origin[a], lo_b[3 * b + a]);
            far[a] = dmax(far[a], hi_b[3 * b + a]);
        }
    /* Cells: with the automatic size, each axis's 1.4 times the mean extent of B's boxes along
     * it (at least a quarter of the largest such mean), so that flat boxes, as a surface's
     * primitives near an axis plane, are not stacked in one layer of cubic cells (1.4: fewer
     * cells per box than at 1, for 20 % less time on the fold's edges, measured at 0.7, 1 and
     * 1.4). Coarsened, doubling, until
     * the boxes of B overlap at most 8 cells each on average (a few long boxes must not make the
     * hash quadratic). */
    double extent = 0.0;
    for (int a = 0; a < 3; ++a) extent = dmax(extent, far[a] - origin[a]);
    double size[3] = {cell, cell, cell};
    if (!(cell > 0.0) || !isfinite(cell)) {   /* automatic */
        double m[3] = {0.0, 0.0, 0.0}, mmax = 0.0;
        for (int32_t b = 0; b < nb; ++b)
            for (int a = 0; a < 3; ++a) m[a] += (hi_b[3 * b + a] - lo_b[3 * b + a]) / nb;
        for (int a = 0; a < 3; ++a) mmax = dmax(mmax, m[a]);
        if (!(mmax > 0.0)) mmax = extent > 0.0 ? extent : 1.0;
        for (int a = 0; a < 3; ++a) size[a] = 1.4 * dmax(m[a], 0.25 * mmax);
    }
    double inv[3];
    int64_t n = 0;
    for (;;) {
        for (int a = 0; a < 3; ++a) inv[a] = 1.0 / size[a];
        n = count_cells(lo_b, hi_b, nb, origin, inv);
        if (n <= 8 * (int64_t)nb || !(size[0] < extent || size[1] < extent || size[2] < extent))
            break;
        for (int a = 0; a < 3; ++a) size[a] *= 2.0;
    }
    int32_t top[3];
    for (int a = 0; a < 3; ++a) top[a] = cell_of(far[a], origin[a], inv[a]);
    /* Buckets: a power of two at least the (box, cell) entries; a counting sort by bucket, in
     * box order within each. Each entry carries its box's lowest cell (the reporting rule
     * below), so that a bucket is read in one sweep. */
    if (n > INT32_MAX / 2) return DEFSIM_ERR_OUT_OF_MEMORY;   /* int32 bucket offsets */
    int64_t nbk = 1;
    while (nbk < n) nbk *= 2;
    const uint32_t mask = (uint32_t)(nbk - 1);
    if (!reserve((void **)&h->keys, &h->cap_keys, n, sizeof *h->keys) ||
        !reserve((void **)&h->bucket, &h->cap_bucket, n, sizeof *h->bucket) ||
        !reserve((void **)&h->start, &h->cap_start, nbk + 1, sizeof *h->start))
        return DEFSIM_ERR_OUT_OF_MEMORY;
    int32_t *start = h->start;
    uint32_t *bucket = h->bucket;
    defsim__hash_entry *ent = h->keys;
    memset(start, 0, (size_t)(nbk + 1) * sizeof *start);
    int64_t e = 0;
    for (int32_t b = 0; b < nb; ++b) {
        int32_t r[3][2];
        range(lo_b + 3 * b, hi_b + 3 * b, origin, inv, r);
        for (int32_t i = r[0][0]; i <= r[0][1]; ++i)
            for (int32_t j = r[1][0]; j <= r[1][1]; ++j)
                for (int32_t k = r[2][0]; k <= r[2][1]; ++k) {
                    const uint32_t bk = key_of(i, j, k) & mask;
                    bucket[e++] = bk;
                    start[bk + 1]++;
                }
    }
    for (int64_t q = 0; q < nbk; ++q) start[q + 1] += start[q];
    e = 0;
    for (int32_t b = 0; b < nb; ++b) {
        int32_t r[3][2];
        range(lo_b + 3 * b, hi_b + 3 * b, origin, inv, r);
        const defsim__hash_entry en = {b, {r[0][0], r[1][0], r[2][0]}};
        const int64_t m = cells_in(r);
        for (int64_t q = 0; q < m; ++q) ent[start[bucket[e++]]++] = en;
    }
    /* the scatter advanced each start to its end: shift back */
    for (int64_t q = nbk; q > 0; --q) start[q] = start[q - 1];
    start[0] = 0;
    h->nkeys = n;
    /* Query A. A pair is reported from one cell only, the one holding the larger of the two
     * boxes' lower corners (it lies in both boxes, so both visit it; cells are monotone in the
     * coordinates, so it is the larger of their lowest cells); a box that two of its cells put
     * twice in one bucket is found twice there, which the per-box sort removes. A bucket is read
     * from its end, so that with self its entries (in box order) up to b = a are never read. */
    for (int32_t a = 0; a < na; ++a) {
        int32_t r[3][2];
        const double *la = lo_a + 3 * a, *ha = hi_a + 3 * a;
        range(la, ha, origin, inv, r);
        const int32_t a0[3] = {r[0][0], r[1][0], r[2][0]};
        for (int ax = 0; ax < 3; ++ax) {   /* no box of B beyond its far corner's cell */
            if (r[ax][0] > top[ax]) r[ax][0] = top[ax] + 1;
            if (r[ax][1] > top[ax]) r[ax][1] = top[ax];
        }
        const int64_t first = h->npairs;
        int64_t np = first;
        for (int32_t i = r[0][0]; i <= r[0][1]; ++i)
            for (int32_t j = r[1][0]; j <= r[1][1]; ++j)
                for (int32_t k = r[2][0]; k <= r[2][1]; ++k) {
                    const uint32_t bk = key_of(i, j, k) & mask;
                    /* room for every entry of the bucket, so that the sweep needs no check */
                    if (np + (start[bk + 1] - start[bk]) > h->cap_pairs &&
                        !reserve((void **)&h->pairs, &h->cap_pairs, np + start[bk + 1] - start[bk],
                                 sizeof *h->pairs))
                        return DEFSIM_ERR_OUT_OF_MEMORY;
                    int64_t *pairs = h->pairs;
                    const int32_t beg = start[bk];
                    /* the reporting cell, axis by axis: the entry's lowest cell where it
                     * exceeds a's, a's own otherwise */
                    const int ei = i == a0[0], ej = j == a0[1], ek = k == a0[2];
                    const int64_t run = np;
                    /* from the bucket's end: with self, down to the first b <= a */
                    for (int32_t m = start[bk + 1] - 1; m >= beg; --m) {
                        const defsim__hash_entry *en = ent + m;
                        const int32_t b = en->b;
                        if (self && b <= a) break;
                        if ((ei ? en->c0[0] > i : en->c0[0] != i) ||
                            (ej ? en->c0[1] > j : en->c0[1] != j) ||
                            (ek ? en->c0[2] > k : en->c0[2] != k))
                            continue;
                        if (!overlap(la, ha, lo_b + 3 * b, hi_b + 3 * b)) continue;
                        pairs[np++] = (int64_t)a << 32 | b;
                    }
                    for (int64_t p = run, q = np - 1; p < q; ++p, --q) {   /* ascending */
                        const int64_t t = pairs[p];
                        pairs[p] = pairs[q];
                        pairs[q] = t;
                    }
                }
        /* a's pairs in b order, unique (a few: insertion sort) */
        int64_t *pairs = h->pairs;
        for (int64_t m = first + 1; m < np; ++m) {
            const int64_t v = pairs[m];
            int64_t q = m;
            while (q > first && pairs[q - 1] > v) {
                pairs[q] = pairs[q - 1];
                --q;
            }
            pairs[q] = v;
        }
        int64_t u = first;
        for (int64_t m = first; m < np; ++m)
            if (m == first || pairs[m] != pairs[u - 1]) pairs[u++] = pairs[m];
        h->npairs = u;
    }
    return DEFSIM_OK;
}

/* ------------------------------------------------------------------------------------------ */
/* Surfaces */

defsim_status defsim__triangle_edges(const int32_t *tris, int32_t nf, int32_t **edges,
                                     int32_t *ne)
{
    *edges = NULL;
    *ne = 0;
    const int64_t n = 3 * (int64_t)nf;
    int64_t *e = malloc((size_t)(n + 1) * sizeof *e);
    if (!e) return DEFSIM_ERR_OUT_OF_MEMORY;
    for (int64_t f = 0; f < nf; ++f)
        for (int k = 0; k < 3; ++k) {
            int64_t a = tris[3 * f + k], b = tris[3 * f + (k + 1) % 3];
            if (a > b) { const int64_t t = a; a = b; b = t; }
            e[3 * f + k] = a << 32 | b;
        }
    if (n > 1) qsort(e, (size_t)n, sizeof *e, defsim__cmp_i64);
    int64_t m = 0;
    for (int64_t i = 0; i < n; ++i)
        if (m == 0 || e[i] != e[m - 1]) e[m++] = e[i];
    int32_t *out = malloc((size_t)(2 * m + 1) * sizeof *out);
    if (!out) {
        free(e);
        return DEFSIM_ERR_OUT_OF_MEMORY;
    }
    for (int64_t i = 0; i < m; ++i) {
        out[2 * i] = (int32_t)(e[i] >> 32);
        out[2 * i + 1] = (int32_t)(e[i] & 0xffffffff);
    }
    free(e);
    *edges = out;
    *ne = (int32_t)m;
    return DEFSIM_OK;
}
