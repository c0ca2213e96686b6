/* SPDX-License-Identifier: MIT */
/*
 * Sparse matrices of a compiled system over its free DOFs: the pattern (built once per plan from
 * the pairs its terms couple, grown by body contact), the values of A = m M + md alpha M + k K +
 * kd B and the product A dx without forming A, as loops over the terms (term.h) in the order of
 * the matrix sums, with the scatter helpers terms share.
 *
 * Contents: pattern; scatter helpers; values and products.
 */
#include "assembly.h"

#include "array.h"

#include <stdlib.h>
#include <string.h>

/* Sparse matrices over free DOFs. Free DOFs come in vertex triples, so the pattern is made of
 * 3x3 blocks: column 3 fb + cb holds, for each neighbour fa of fb (sorted, itself included), the
 * rows 3 fa .. 3 fa + 2 (UPPER: neighbours fa < fb, then rows 3 fb .. 3 fb + cb). The rank of fa
 * in fb's neighbour list, stored per element node pair (blk), locates an entry in both. */

static int cmp_i32(const void *a, const void *b)
{
    int32_t x = *(const int32_t *)a, y = *(const int32_t *)b;
    return (x > y) - (x < y);
}

void defsim__element_pairs(const defsim__system *s, const int32_t *idx, int nodes, int64_t n,
                           int64_t *pos, int32_t *list)
{
    for (int64_t e = 0; e < n; ++e)
        for (int a = 0; a < nodes; ++a) {
            const int32_t va = idx[nodes * e + a];
            const int32_t fa = va >= 0 ? s->vfree[va] : -1;
            if (fa < 0) continue;
            for (int b = 0; b < nodes; ++b) {
                const int32_t vb = idx[nodes * e + b];
                const int32_t fb = vb >= 0 ? s->vfree[vb] : -1;
                if (fb < 0) continue;
                if (list) list[pos[fa]++] = fb;
                else pos[fa + 1]++;
            }
        }
}

/* Visits every pair of free vertices that a term's elements couple, then the extra pairs. */
static void element_pairs(const defsim__system *s, int64_t *pos, int32_t *list)
{
    for (int32_t i = 0; i < s->nterms; ++i)
        if (s->terms[i].ops->pairs) s->terms[i].ops->pairs(&s->terms[i], s, pos, list);
    const defsim__pattern *p = &s->pattern;
    for (int64_t k = 0; k < p->nextra; ++k) {
        const int32_t fa = (int32_t)(p->extra[k] >> 32), fb = (int32_t)(p->extra[k] & 0xFFFFFFFF);
        if (list) {
            list[pos[fa]++] = fb;
            list[pos[fb]++] = fa;
        } else {
            pos[fa + 1]++;
            pos[fb + 1]++;
        }
    }
}

/* Frees what defsim__pattern_build made (the extra pairs stay; terms remake their ranks). */
static void pattern_drop(defsim__system *s)
{
    defsim__pattern *p = &s->pattern;
    free(p->adj_ptr); free(p->adj); free(p->upper_rank0);
    free(p->full_col_ptr); free(p->full_row_idx); free(p->upper_col_ptr); free(p->upper_row_idx);
    p->adj_ptr = p->full_col_ptr = p->full_row_idx = p->upper_col_ptr = p->upper_row_idx = NULL;
    p->adj = p->upper_rank0 = NULL;
    p->built = 0;
}


defsim_status defsim__pattern_grow(defsim__system *s, const int64_t *pairs, int64_t n, int *grew)
{
    defsim__pattern *p = &s->pattern;
    *grew = 0;
    if (!p->built || n == 0) return DEFSIM_OK;
    int64_t nnew = 0;
    int64_t *add = malloc((size_t)n * sizeof *add);
    if (!add) return DEFSIM_ERR_OUT_OF_MEMORY;
    for (int64_t k = 0; k < n; ++k) {
        const int32_t fa = (int32_t)(pairs[k] >> 32), fb = (int32_t)(pairs[k] & 0xFFFFFFFF);
        if (defsim__pattern_rank(s, fa, fb) < 0) add[nnew++] = pairs[k];
    }
    if (nnew == 0) {
        free(add);
        return DEFSIM_OK;
    }
    int64_t *extra = realloc(p->extra, (size_t)(p->nextra + nnew) * sizeof *extra);
    if (!extra) {
        free(add);
        return DEFSIM_ERR_OUT_OF_MEMORY;
    }
    memcpy(extra + p->nextra, add, (size_t)nnew * sizeof *add);
    free(add);
    int64_t m = p->nextra + nnew;
    qsort(extra, (size_t)m, sizeof *extra, defsim__cmp_i64);
    int64_t u = 0;
    for (int64_t k = 0; k < m; ++k)
        if (k == 0 || extra[k] != extra[k - 1]) extra[u++] = extra[k];
    p->extra = extra;
    p->nextra = u;
    pattern_drop(s);
    const defsim_status st = defsim__pattern_build(s);
    if (st != DEFSIM_OK) return st;
    *grew = 1;
    return DEFSIM_OK;
}

defsim_status defsim__pattern_retain(defsim__system *s, const int64_t *keep, int64_t n,
                                     double stale, int *pruned)
{
    defsim__pattern *p = &s->pattern;
    *pruned = 0;
    if (!p->built || p->nextra == 0) return DEFSIM_OK;
    /* extras and keep are both sorted: their intersection by one merge, counted first and
     * written in place (the write never overtakes the read) only if enough go */
    for (int pass = 0; pass < 2; ++pass) {
        int64_t u = 0;
        for (int64_t i = 0, j = 0; i < p->nextra && j < n;) {
            if (p->extra[i] < keep[j]) ++i;
            else if (keep[j] < p->extra[i]) ++j;
            else {
                if (pass == 1) p->extra[u] = p->extra[i];
                ++u, ++i, ++j;
            }
        }
        if (pass == 1) p->nextra = u;
        else if ((double)(p->nextra - u) <= stale * (double)p->nextra) return DEFSIM_OK;
    }
    pattern_drop(s);
    const defsim_status st = defsim__pattern_build(s);
    if (st != DEFSIM_OK) return st;
    *pruned = 1;
    return DEFSIM_OK;
}

defsim_status defsim__pattern_build(defsim__system *s)
{
    defsim__pattern *p = &s->pattern;
    if (p->built) return DEFSIM_OK;
    const int32_t nfv = s->nfree_v;
    int64_t *cnt = calloc((size_t)nfv + 1, sizeof *cnt);
    if (!cnt) return DEFSIM_ERR_OUT_OF_MEMORY;
    element_pairs(s, cnt, NULL);
    for (int32_t i = 0; i < nfv; ++i) cnt[i + 1] += cnt[i] + 1;   /* + self */
    int32_t *tmp = malloc((size_t)(cnt[nfv] > 0 ? cnt[nfv] : 1) * sizeof *tmp);
    int64_t *fill = malloc(((size_t)nfv + 1) * sizeof *fill);
    if (!tmp || !fill) { free(cnt); free(tmp); free(fill); return DEFSIM_ERR_OUT_OF_MEMORY; }
    for (int32_t i = 0; i < nfv; ++i) { fill[i] = cnt[i]; tmp[fill[i]++] = i; }
    element_pairs(s, fill, tmp);
    /* Sort and deduplicate each list in place, compacting into adj. */
    p->adj_ptr = malloc(((size_t)nfv + 1) * sizeof *p->adj_ptr);
    p->upper_rank0 = malloc(((size_t)nfv + 1) * sizeof *p->upper_rank0);
    if (!p->adj_ptr || !p->upper_rank0) { free(cnt); free(tmp); free(fill); return DEFSIM_ERR_OUT_OF_MEMORY; }
    int64_t out = 0;
    p->adj_ptr[0] = 0;
    for (int32_t i = 0; i < nfv; ++i) {
        int32_t *l = tmp + cnt[i];
        int64_t n = cnt[i + 1] - cnt[i];
        qsort(l, (size_t)n, sizeof *l, cmp_i32);
        int64_t start = out;
        for (int64_t k = 0; k < n; ++k)
            if (k == 0 || l[k] != l[k - 1]) tmp[out++] = l[k];
        p->adj_ptr[i + 1] = out;
        p->upper_rank0[i] = defsim__lower_rank(tmp + start, out - start, i);
    }
    free(cnt);
    free(fill);
    p->adj = realloc(tmp, (size_t)(out > 0 ? out : 1) * sizeof *tmp);
    if (!p->adj) { free(tmp); return DEFSIM_ERR_OUT_OF_MEMORY; }

    /* The terms' node-pair ranks. */
    for (int32_t i = 0; i < s->nterms; ++i) {
        const defsim__term *t = &s->terms[i];
        defsim_status st;
        if (t->ops->ranks && (st = t->ops->ranks(t, s)) != DEFSIM_OK) return st;
    }
    /* Column pointers and row indices of both layouts. */
    const int64_t n = 3 * (int64_t)nfv;
    p->full_col_ptr = malloc(((size_t)n + 1) * sizeof(int64_t));
    p->upper_col_ptr = malloc(((size_t)n + 1) * sizeof(int64_t));
    if (!p->full_col_ptr || !p->upper_col_ptr) return DEFSIM_ERR_OUT_OF_MEMORY;
    p->full_col_ptr[0] = p->upper_col_ptr[0] = 0;
    for (int32_t fb = 0; fb < nfv; ++fb) {
        int64_t deg = p->adj_ptr[fb + 1] - p->adj_ptr[fb];
        for (int cb = 0; cb < 3; ++cb) {
            int64_t j = 3 * (int64_t)fb + cb;
            p->full_col_ptr[j + 1] = p->full_col_ptr[j] + 3 * deg;
            p->upper_col_ptr[j + 1] = p->upper_col_ptr[j] + 3 * (int64_t)p->upper_rank0[fb] + cb + 1;
        }
    }
    p->full_nnz = p->full_col_ptr[n];
    p->upper_nnz = p->upper_col_ptr[n];
    p->full_row_idx = malloc((size_t)(p->full_nnz > 0 ? p->full_nnz : 1) * sizeof(int64_t));
    p->upper_row_idx = malloc((size_t)(p->upper_nnz > 0 ? p->upper_nnz : 1) * sizeof(int64_t));
    if (!p->full_row_idx || !p->upper_row_idx) return DEFSIM_ERR_OUT_OF_MEMORY;
    for (int32_t fb = 0; fb < nfv; ++fb)
        for (int cb = 0; cb < 3; ++cb) {
            int64_t j = 3 * (int64_t)fb + cb;
            int64_t pf = p->full_col_ptr[j], pu = p->upper_col_ptr[j];
            for (int64_t k = p->adj_ptr[fb]; k < p->adj_ptr[fb + 1]; ++k) {
                int32_t fa = p->adj[k];
                for (int ca = 0; ca < 3; ++ca) {
                    int64_t row = 3 * (int64_t)fa + ca;
                    p->full_row_idx[pf++] = row;
                    if (row <= j) p->upper_row_idx[pu++] = row;
                }
            }
        }
    p->built = 1;
    p->version++;
    return DEFSIM_OK;
}

int32_t *defsim__element_ranks(const defsim__system *s, const int32_t *idx, int nodes,
                               int64_t n)
{
    const defsim__pattern *p = &s->pattern;
    const int nn = nodes;
    int32_t *blk = malloc((size_t)(n > 0 ? n : 1) * nn * nn * sizeof *blk);
    if (!blk) return NULL;
    for (int64_t e = 0; e < n; ++e)
        for (int a = 0; a < nn; ++a)
            for (int b = 0; b < nn; ++b) {
                const int32_t va = idx[nn * e + a], vb = idx[nn * e + b];
                const int32_t fa = va >= 0 ? s->vfree[va] : -1, fb = vb >= 0 ? s->vfree[vb] : -1;
                int32_t r = -1;
                if (fa >= 0 && fb >= 0)
                    r = defsim__lower_rank(p->adj + p->adj_ptr[fb], p->adj_ptr[fb + 1] - p->adj_ptr[fb], fa);
                blk[(nn * e + a) * nn + b] = r;
            }
    return blk;
}

defsim_status defsim__matrix_pattern(const defsim__system *s, defsim_triangle tri,
                                     defsim_csc *out)
{
    if (!out || (tri != DEFSIM_TRIANGLE_FULL && tri != DEFSIM_TRIANGLE_UPPER) ||
        !s->pattern.built)
        return DEFSIM_ERR_INVALID_ARGUMENT;
    out->n = 3 * (int64_t)s->nfree_v;
    if (tri == DEFSIM_TRIANGLE_FULL) {
        out->nnz = s->pattern.full_nnz;
        out->col_ptr = s->pattern.full_col_ptr;
        out->row_idx = s->pattern.full_row_idx;
    } else {
        out->nnz = s->pattern.upper_nnz;
        out->col_ptr = s->pattern.upper_col_ptr;
        out->row_idx = s->pattern.upper_row_idx;
    }
    return DEFSIM_OK;
}

void defsim__element_scatter(const defsim__system *s, const int32_t *id, const int32_t *blk,
                             int nn, const double *K, int upper, const int64_t *cp,
                             double *values)
{
    const int nd = 3 * nn;
    for (int b = 0; b < nn; ++b) {
        int32_t fb = s->vfree[id[b]];
        if (fb < 0) continue;
        for (int a = 0; a < nn; ++a) {
            int32_t r = blk[a * nn + b];
            if (r < 0) continue;
            int32_t fa = s->vfree[id[a]];
            if (upper && fa > fb) continue;
            for (int cb = 0; cb < 3; ++cb) {
                int64_t base = cp[3 * (int64_t)fb + cb] + 3 * (int64_t)r;
                int camax = (upper && fa == fb) ? cb : 2;
                for (int ca = 0; ca <= camax; ++ca)
                    values[base + ca] += K[(3 * a + ca) * nd + 3 * b + cb];
            }
        }
    }
}

void defsim__diagonal_values(const defsim__term *t, const defsim__system *s, const double *x,
                             const defsim_matrix_coeffs *c, int upper, const int64_t *cp,
                             double *values, uint32_t *passes)
{
    (void)x;
    (void)passes;
    double k;
    const double *blocks = t->ops->diagonal(t, c, &k);
    if (!blocks) return;
    const int32_t *rank0 = s->pattern.upper_rank0;
    for (int32_t v = 0; v < s->nv; ++v) {
        const int32_t fv = s->vfree[v];
        if (fv < 0) continue;
        const double *B = blocks + 9 * (int64_t)v;
        /* the diagonal block's rank: below-diagonal neighbours come first in both layouts */
        const int64_t r = rank0[fv];
        for (int cb = 0; cb < 3; ++cb)
            for (int ca = 0; ca <= (upper ? cb : 2); ++ca)
                values[cp[3 * (int64_t)fv + cb] + 3 * r + ca] += k * B[3 * ca + cb];
    }
}

void defsim__diagonal_apply(const defsim__term *t, const defsim__system *s, const double *x,
                            const defsim_matrix_coeffs *c, int proj, const double *dx,
                            double *out)
{
    (void)x;
    (void)proj;
    double k;
    const double *blocks = t->ops->diagonal(t, c, &k);
    if (!blocks) return;
    for (int32_t v = 0; v < s->nv; ++v) {
        if (s->pinned[v]) continue;
        const double *B = blocks + 9 * (int64_t)v, *u = dx + 3 * (int64_t)v;
        for (int i = 0; i < 3; ++i)
            out[3 * (int64_t)v + i] += k * (B[3 * i] * u[0] + B[3 * i + 1] * u[1] + B[3 * i + 2] * u[2]);
    }
}

/* Every term linearises at x before the matrix is read: VALUES evaluates, the others only
 * where x or the coefficients changed (term.h). */
static defsim_status linearise(const defsim__system *s, const double *x,
                               const defsim_matrix_coeffs *c, int mode)
{
    for (int32_t k = 0; k < s->nmatrix; ++k) {
        const defsim__term *t = &s->terms[s->matrix_order[k]];
        defsim_status st;
        if (t->ops->linearise && (st = t->ops->linearise(t, s, x, c, mode)) != DEFSIM_OK)
            return st;
    }
    return DEFSIM_OK;
}

defsim_status defsim__matrix_values(const defsim__system *s, const double *x,
                                    const defsim_matrix_coeffs *c, defsim_triangle tri,
                                    double *values, uint32_t *passes)
{
    defsim_csc pat;
    defsim_status st = defsim__matrix_pattern(s, tri, &pat);
    if (st != DEFSIM_OK) return st;
    if (!x || !c || !values) return DEFSIM_ERR_INVALID_ARGUMENT;
    if ((st = linearise(s, x, c, DEFSIM__LIN_VALUES)) != DEFSIM_OK) return st;
    const int upper = tri == DEFSIM_TRIANGLE_UPPER;
    memset(values, 0, (size_t)pat.nnz * sizeof *values);
    for (int32_t k = 0; k < s->nmatrix; ++k) {
        const defsim__term *t = &s->terms[s->matrix_order[k]];
        if (t->ops->values) t->ops->values(t, s, x, c, upper, pat.col_ptr, values, passes);
    }
    return DEFSIM_OK;
}

void defsim__matrix_apply_skip(const defsim__system *s, const double *x,
                               const defsim_matrix_coeffs *c, int proj, uint32_t skip,
                               const double *dx, double *out)
{
    memset(out, 0, 3 * (size_t)s->nv * sizeof *out);
    for (int32_t k = 0; k < s->nmatrix; ++k) {
        const defsim__term *t = &s->terms[s->matrix_order[k]];
        if (!t->ops->apply || (t->ops->flags & skip)) continue;
        /* a cache that cannot be refreshed (out of memory) leaves its term out, with the
         * failure recorded where the term keeps it */
        if (t->ops->linearise && t->ops->linearise(t, s, x, c, DEFSIM__LIN_LAZY) != DEFSIM_OK)
            continue;
        t->ops->apply(t, s, x, c, proj, dx, out);
    }
}

void defsim__matrix_apply(const defsim__system *s, const double *x,
                          const defsim_matrix_coeffs *c, int proj, const double *dx, double *out)
{
    defsim__matrix_apply_skip(s, x, c, proj, 0, dx, out);
}

defsim_status defsim__matrix_product(const defsim__system *s, const double *x,
                                     const defsim_matrix_coeffs *c, const double *dx,
                                     double *out)
{
    if (!x || !c || !dx || !out) return DEFSIM_ERR_INVALID_ARGUMENT;
    const defsim_status st = linearise(s, x, c, DEFSIM__LIN_PRODUCT);
    if (st != DEFSIM_OK) return st;
    defsim__matrix_apply(s, x, c, s->projection, dx, out);
    return DEFSIM_OK;
}

void defsim__group_values(const defsim__system *s, const defsim__group *g,
                          defsim__element_matrix_fn matrix, const double *x,
                          const defsim_matrix_coeffs *c, int upper, const int64_t *cp,
                          double *values, uint32_t *passes)
{
    if (c->k == 0.0 && c->kd == 0.0) return;
    const int nn = g->nodes;
    for (int32_t col = 0; col < g->ncolors; ++col) {
        const int32_t e0 = g->color_ptr[col], e1 = g->color_ptr[col + 1];
#pragma omp parallel for schedule(static) num_threads(s->nthreads) if (e1 - e0 > 64)
        for (int32_t e = e0; e < e1; ++e) {
            const double sk = c->k, sd = c->kd * g->beta[e];
            double K[DEFSIM__ELEMENT_DOFS_MAX * DEFSIM__ELEMENT_DOFS_MAX];
            if ((sk == 0.0 && sd == 0.0) || !matrix(s, g, x, e, sk, sd, K)) continue;
            defsim__element_scatter(s, g->idx + nn * (int64_t)e, g->blk + nn * nn * (int64_t)e,
                                    nn, K, upper, cp, values);
        }
    }
    if (passes) *passes |= DEFSIM_PASS_HESSIAN;
}

void defsim__group_apply(const defsim__system *s, const defsim__group *g,
                         defsim__element_apply_fn apply, const double *x,
                         const defsim_matrix_coeffs *c, int proj, const double *dx, double *out)
{
    if (c->k == 0.0 && c->kd == 0.0) return;
    for (int32_t col = 0; col < g->ncolors; ++col) {
        const int32_t e0 = g->color_ptr[col], e1 = g->color_ptr[col + 1];
#pragma omp parallel for schedule(static) num_threads(s->nthreads) if (e1 - e0 > 256)
        for (int32_t e = e0; e < e1; ++e) {
            const double sk = c->k, sd = c->kd * g->beta[e];
            if (sk != 0.0 || sd != 0.0) apply(g, x, e, sk, sd, proj, s->pinned, dx, out);
        }
    }
}

void defsim__group_pairs(const defsim__term *t, const defsim__system *s, int64_t *pos,
                         int32_t *list)
{
    const defsim__group *g = t->model;
    defsim__element_pairs(s, g->idx, g->nodes, g->n, pos, list);
}

defsim_status defsim__group_ranks(const defsim__term *t, defsim__system *s)
{
    /* The term's model is one of s's groups (tets, springs, shells), which s owns mutable. */
    defsim__group *g = (defsim__group *)t->model;
    free(g->blk);
    g->blk = defsim__element_ranks(s, g->idx, g->nodes, g->n);
    return g->blk ? DEFSIM_OK : DEFSIM_ERR_OUT_OF_MEMORY;
}

void defsim__element_product(const int32_t *id, int nn, const double *H, double sk,
                             const uint8_t *pinned, const double *dx, double *out)
{
    const int nd = 3 * nn;
    double u[12];
    for (int a = 0; a < nn; ++a)
        for (int i = 0; i < 3; ++i) u[3 * a + i] = pinned[id[a]] ? 0.0 : dx[3 * (int64_t)id[a] + i];
    for (int a = 0; a < nn; ++a) {
        if (pinned[id[a]]) continue;
        for (int i = 0; i < 3; ++i) {
            double v = 0.0;
            for (int j = 0; j < nd; ++j) v += H[nd * (3 * a + i) + j] * u[j];
            out[3 * (int64_t)id[a] + i] += sk * v;
        }
    }
}
