/* SPDX-License-Identifier: MIT */
/*
 * Sparse matrices of a compiled system over its free DOFs: the pattern (built once per plan, with
 * the couplings of attachments between bodies), the values of A = m M + md alpha M + k K + kd B
 * (K the stiffness, projected as the system says, plus attachment springs and the force
 * callback's blocks; B the stiffness-damping matrix plus attachment dampers), and the product
 * A dx without forming A.
 *
 * Contents: pattern; element matrices and values; element products and defsim__matrix_apply.
 */
#include "assembly.h"

#include "body_contact.h"
#include "contact.h"
#include "element.h"
#include "mat3.h"
#include "material.h"

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

/* Free vertex of attachment e's node a, or -1 (unused node or pinned vertex). */
static int32_t attach_free(const defsim__system *s, const defsim__attachments *at, int64_t e,
                           int a)
{
    const int32_t v = at->node[DEFSIM__ATTACH_NODES * e + a];
    return v >= 0 ? s->vfree[v] : -1;
}

/* Visits every pair (fa, fb) of free vertices of one element or attachment: counts it in
 * pos[fa + 1] (list NULL) or appends fb to fa's list at pos[fa]. */
static void element_pairs(const defsim__system *s, int64_t *pos, int32_t *list)
{
    for (int m = 0; m <= DEFSIM__TET_MODELS; ++m) {
        const defsim__group *g = &s->groups[m];
        for (int64_t e = 0; e < g->n; ++e)
            for (int a = 0; a < g->nodes; ++a) {
                int32_t fa = s->vfree[g->idx[g->nodes * e + a]];
                if (fa < 0) continue;
                for (int b = 0; b < g->nodes; ++b) {
                    int32_t fb = s->vfree[g->idx[g->nodes * e + b]];
                    if (fb < 0) continue;
                    if (list) list[pos[fa]++] = fb;
                    else pos[fa + 1]++;
                }
            }
    }
    const defsim__attachments *at = &s->att;
    for (int64_t e = 0; e < at->n; ++e)
        for (int a = 0; a < DEFSIM__ATTACH_NODES; ++a) {
            int32_t fa = attach_free(s, at, e, a);
            if (fa < 0) continue;
            for (int b = 0; b < DEFSIM__ATTACH_NODES; ++b) {
                int32_t fb = attach_free(s, at, e, b);
                if (fb < 0) continue;
                if (list) list[pos[fa]++] = fb;
                else pos[fa + 1]++;
            }
        }
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

/* Frees what defsim__pattern_build made (the extra pairs stay). */
static void pattern_drop(defsim__system *s)
{
    defsim__pattern *p = &s->pattern;
    free(p->adj_ptr); free(p->adj); free(p->upper_rank0);
    free(p->full_col_ptr); free(p->full_row_idx); free(p->upper_col_ptr); free(p->upper_row_idx);
    p->adj_ptr = p->full_col_ptr = p->full_row_idx = p->upper_col_ptr = p->upper_row_idx = NULL;
    p->adj = p->upper_rank0 = NULL;
    for (int m = 0; m <= DEFSIM__TET_MODELS; ++m) {
        free(s->groups[m].blk);
        s->groups[m].blk = NULL;
    }
    free(s->att.blk);
    s->att.blk = NULL;
    p->built = 0;
}

static int cmp_i64(const void *a, const void *b)
{
    int64_t x = *(const int64_t *)a, y = *(const int64_t *)b;
    return (x > y) - (x < y);
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
    qsort(extra, (size_t)m, sizeof *extra, cmp_i64);
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

    /* Element node-pair ranks. */
    for (int m = 0; m <= DEFSIM__TET_MODELS; ++m) {
        defsim__group *g = &s->groups[m];
        if (g->n == 0) continue;
        const int nn = g->nodes;
        g->blk = malloc((size_t)g->n * nn * nn * sizeof *g->blk);
        if (!g->blk) return DEFSIM_ERR_OUT_OF_MEMORY;
        for (int64_t e = 0; e < g->n; ++e)
            for (int a = 0; a < nn; ++a)
                for (int b = 0; b < nn; ++b) {
                    int32_t fa = s->vfree[g->idx[nn * e + a]], fb = s->vfree[g->idx[nn * e + b]];
                    int32_t r = -1;
                    if (fa >= 0 && fb >= 0)
                        r = defsim__lower_rank(p->adj + p->adj_ptr[fb], p->adj_ptr[fb + 1] - p->adj_ptr[fb], fa);
                    g->blk[(nn * e + a) * nn + b] = r;
                }
    }

    const defsim__attachments *at = &s->att;
    const int an = DEFSIM__ATTACH_NODES;
    if (at->n > 0) {
        int32_t *blk = malloc((size_t)at->n * an * an * sizeof *blk);
        if (!blk) return DEFSIM_ERR_OUT_OF_MEMORY;
        for (int64_t e = 0; e < at->n; ++e)
            for (int a = 0; a < an; ++a)
                for (int b = 0; b < an; ++b) {
                    int32_t fa = attach_free(s, at, e, a), fb = attach_free(s, at, e, b);
                    int32_t r = -1;
                    if (fa >= 0 && fb >= 0)
                        r = defsim__lower_rank(p->adj + p->adj_ptr[fb], p->adj_ptr[fb + 1] - p->adj_ptr[fb], fa);
                    blk[(an * e + a) * an + b] = r;
                }
        s->att.blk = blk;
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

/* Element matrix over its nodes: K[(a c),(b d)], 12x12 for tets, 6x6 for springs, scaled by
 * k + kd beta (kd part always with clamped projection). Returns 0 if the element adds nothing. */
static int element_matrix(const defsim__system *s, const defsim__group *g, const double *x,
                          int32_t e, const defsim_matrix_coeffs *c, double *K)
{
    const double sk = c->k, sd = c->kd * g->beta[e];
    if (sk == 0.0 && sd == 0.0) return 0;
    const int proj = s->projection;
    const int nn = g->nodes, nd = 3 * nn;
    if (nn == 2) {
        const double *xa = x + 3 * (int64_t)g->idx[2 * (int64_t)e];
        const double *xb = x + 3 * (int64_t)g->idx[2 * (int64_t)e + 1];
        double Kb[9], Kd[9];
        defsim__model_spring.block(xa, xb, g->k[e], g->l0[e], proj, Kb);
        if (sd != 0.0)
            defsim__model_spring.block(xa, xb, g->k[e], g->l0[e], DEFSIM_PROJECTION_CLAMP, Kd);
        for (int i = 0; i < 9; ++i) Kb[i] = sk * Kb[i] + (sd != 0.0 ? sd * Kd[i] : 0.0);
        for (int a = 0; a < 2; ++a)
            for (int b = 0; b < 2; ++b)
                for (int i = 0; i < 3; ++i)
                    for (int j = 0; j < 3; ++j)
                        K[(3 * a + i) * nd + 3 * b + j] = (a == b ? 1.0 : -1.0) * Kb[3 * i + j];
        return 1;
    }
    double F[9], D[81], gr[4][3];
    tet_deformation(x, g->idx + 4 * (int64_t)e, g->dminv + 9 * (int64_t)e, F);
    if (proj == DEFSIM_PROJECTION_NONE) {
        g->law->dPdF(g->mu[e], g->lambda[e], F, D);
        if (sd != 0.0) {
            double Dd[81];
            defsim__model_dpdf_projected(g->law, g->mu[e], g->lambda[e], F,
                                         DEFSIM_PROJECTION_CLAMP, Dd, 0, NULL);
            for (int i = 0; i < 81; ++i) D[i] = sk * D[i] + sd * Dd[i];
        } else {
            for (int i = 0; i < 81; ++i) D[i] *= sk;
        }
    } else if (sd != 0.0 && proj != DEFSIM_PROJECTION_CLAMP) {
        double Dd[81];
        defsim__model_dpdf_projected(g->law, g->mu[e], g->lambda[e], F, proj, D,
                                     DEFSIM_PROJECTION_CLAMP, Dd);
        for (int i = 0; i < 81; ++i) D[i] = sk * D[i] + sd * Dd[i];
    } else {
        defsim__model_dpdf_projected(g->law, g->mu[e], g->lambda[e], F, proj, D, 0, NULL);
        for (int i = 0; i < 81; ++i) D[i] *= sk + sd;
    }
    tet_gradients(g->dminv + 9 * (int64_t)e, gr);
    const double vol = g->vol[e];
    /* K[(a,i),(b,k)] = vol sum_{j,l} g_a[j] D[(i,j),(k,l)] g_b[l]. D is symmetric, so K is; and
     * g_3 = -(g_0 + g_1 + g_2) makes node 3's blocks minus sums of the others: only the six
     * blocks a <= b < 3 need the products. */
    for (int b = 0; b < 3; ++b) {
        double Dg[9][3];   /* Dg[(i,j)][k] = sum_l D[(i,j),(k,l)] g_b[l] */
        for (int r = 0; r < 9; ++r)
            for (int k = 0; k < 3; ++k)
                Dg[r][k] = D[9 * r + 3 * k] * gr[b][0] + D[9 * r + 3 * k + 1] * gr[b][1] +
                           D[9 * r + 3 * k + 2] * gr[b][2];
        for (int a = 0; a <= b; ++a)
            for (int i = 0; i < 3; ++i)
                for (int k = 0; k < 3; ++k) {
                    const double v = vol * (gr[a][0] * Dg[3 * i][k] + gr[a][1] * Dg[3 * i + 1][k] +
                                            gr[a][2] * Dg[3 * i + 2][k]);
                    K[(3 * a + i) * nd + 3 * b + k] = v;
                    K[(3 * b + k) * nd + 3 * a + i] = v;
                }
    }
    for (int a = 0; a < 3; ++a)
        for (int i = 0; i < 3; ++i)
            for (int k = 0; k < 3; ++k) {
                const double *row = K + (3 * a + i) * nd;
                const double v = -(row[k] + row[3 + k] + row[6 + k]);
                K[(3 * a + i) * nd + 9 + k] = v;
                K[(9 + k) * nd + 3 * a + i] = v;
            }
    for (int i = 0; i < 3; ++i)
        for (int k = 0; k < 3; ++k) {
            const double *row = K + (9 + i) * nd;
            K[(9 + i) * nd + 9 + k] = -(row[k] + row[3 + k] + row[6 + k]);
        }
    return 1;
}

/* Attachments: (k k_e + kd c_e) a_r a_s I3 in the block of node pair (r, s). */
static void add_attachments(const defsim__system *s, const defsim_matrix_coeffs *c, int upper,
                            const int64_t *cp, double *values, uint32_t *passes)
{
    const defsim__attachments *at = &s->att;
    const int an = DEFSIM__ATTACH_NODES;
    for (int32_t e = 0; e < at->n; ++e) {
        const double w = c->k * at->k[e] + c->kd * at->c[e];
        const double *a = at->a + an * (int64_t)e;
        const int32_t *blk = at->blk + (int64_t)an * an * e;
        for (int rb = 0; rb < an; ++rb) {
            const int32_t fb = attach_free(s, at, e, rb);
            if (fb < 0) continue;
            for (int ra = 0; ra < an; ++ra) {
                const int32_t r = blk[ra * an + rb], fa = attach_free(s, at, e, ra);
                if (r < 0 || (upper && fa > fb)) continue;
                for (int cc = 0; cc < 3; ++cc)
                    values[cp[3 * (int64_t)fb + cc] + 3 * (int64_t)r + cc] += w * a[ra] * a[rb];
            }
        }
    }
    if (at->n > 0 && passes) *passes |= DEFSIM_PASS_HESSIAN | DEFSIM_PASS_ATTACHMENTS;
}

/* Symmetric 3x3 blocks per vertex (9 nv, scaled by k) on the diagonal blocks: the force
 * callback's stiffness, and contact's (which touches only its vertex's own block, so the pattern
 * never grows for it). */
static void add_diagonal(const defsim__system *s, const double *blocks, double k, int upper,
                         const int64_t *cp, double *values)
{
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

defsim_status defsim__matrix_values(const defsim__system *s, const double *x,
                                    const defsim_matrix_coeffs *c, defsim_triangle tri,
                                    double *values, uint32_t *passes)
{
    defsim_csc pat;
    defsim_status st = defsim__matrix_pattern(s, tri, &pat);
    if (st != DEFSIM_OK) return st;
    if (!x || !c || !values) return DEFSIM_ERR_INVALID_ARGUMENT;
    const int upper = tri == DEFSIM_TRIANGLE_UPPER;
    const int64_t *cp = pat.col_ptr;
    memset(values, 0, (size_t)pat.nnz * sizeof *values);
    if (c->k != 0.0 || c->kd != 0.0) {
        for (int m = 0; m <= DEFSIM__TET_MODELS; ++m) {
            const defsim__group *g = &s->groups[m];
            const int nn = g->nodes, nd = 3 * nn;
            for (int32_t col = 0; col < g->ncolors; ++col) {
                const int32_t e0 = g->color_ptr[col], e1 = g->color_ptr[col + 1];
#pragma omp parallel for schedule(static) num_threads(s->nthreads) if (e1 - e0 > 64)
                for (int32_t e = e0; e < e1; ++e) {
                    double K[144];
                    if (!element_matrix(s, g, x, e, c, K)) continue;
                    const int32_t *id = g->idx + (int64_t)nn * e;
                    const int32_t *blk = g->blk + (int64_t)nn * nn * e;
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
            }
            if (g->n > 0 && passes) *passes |= DEFSIM_PASS_HESSIAN;
        }
    }
    if (c->k != 0.0 || c->kd != 0.0) add_attachments(s, c, upper, cp, values, passes);
    if (c->k != 0.0 && s->cb_stiffness) add_diagonal(s, s->cb_stiffness, c->k, upper, cp, values);
    if (s->contact && (c->k != 0.0 || c->kd != 0.0) &&
        defsim__contact_blocks(s->contact, x, c->k, c->kd, s->contact->blk))
        add_diagonal(s, s->contact->blk, 1.0, upper, cp, values);
    if (s->body_contact && c->k != 0.0)
        defsim__body_contact_values(s->body_contact, s, x, c->k, upper, cp, values);
    if (c->m != 0.0 || c->md != 0.0) {
        const int32_t *rank0 = s->pattern.upper_rank0;
        for (int32_t fv = 0; fv < s->nfree_v; ++fv)
            for (int cc = 0; cc < 3; ++cc) {
                int64_t dof = s->free_dofs[3 * (int64_t)fv + cc];
                int64_t pos = cp[3 * (int64_t)fv + cc] + 3 * (int64_t)rank0[fv] + cc;
                values[pos] += (c->m + c->md * s->alpha3[dof]) * s->mass3[dof];
            }
    }
    return DEFSIM_OK;
}

/* out += A dx for one element without forming its matrix: for tets dF = sum_a dx_a g_a^T,
 * dP = (k D + kd beta Dclamped) : dF, out_a += vol dP g_a. */
static void element_apply(const defsim__group *g, const double *x, int32_t e,
                          const defsim_matrix_coeffs *c, int proj, const uint8_t *pinned,
                          const double *dx, double *out)
{
    const double sk = c->k, sd = c->kd * g->beta[e];
    if (sk == 0.0 && sd == 0.0) return;
    if (g->nodes == 2) {
        const int32_t a = g->idx[2 * (int64_t)e], b = g->idx[2 * (int64_t)e + 1];
        const double *xa = x + 3 * (int64_t)a, *xb = x + 3 * (int64_t)b;
        double Kb[9], Kd[9], d[3];
        defsim__model_spring.block(xa, xb, g->k[e], g->l0[e], proj, Kb);
        if (sd != 0.0)
            defsim__model_spring.block(xa, xb, g->k[e], g->l0[e], DEFSIM_PROJECTION_CLAMP, Kd);
        for (int i = 0; i < 3; ++i) {
            double ua = pinned[a] ? 0.0 : dx[3 * (int64_t)a + i];
            double ub = pinned[b] ? 0.0 : dx[3 * (int64_t)b + i];
            d[i] = ua - ub;
        }
        for (int i = 0; i < 3; ++i) {
            double s = 0.0;
            for (int j = 0; j < 3; ++j)
                s += (sk * Kb[3 * i + j] + (sd != 0.0 ? sd * Kd[3 * i + j] : 0.0)) * d[j];
            if (!pinned[a]) out[3 * (int64_t)a + i] += s;
            if (!pinned[b]) out[3 * (int64_t)b + i] -= s;
        }
        return;
    }
    const int32_t *id = g->idx + 4 * (int64_t)e;
    const double *dm = g->dminv + 9 * (int64_t)e;
    double F[9], D[81], dF[9], dP[9], gr[4][3];
    tet_deformation(x, id, dm, F);
    g->law->dPdF(g->mu[e], g->lambda[e], F, D);
    if (sd != 0.0 && proj != DEFSIM_PROJECTION_CLAMP) {
        double Dd[81];
        memcpy(Dd, D, sizeof Dd);
        defsim__project_psd(9, Dd, DEFSIM_PROJECTION_CLAMP);
        defsim__project_psd(9, D, proj);
        for (int i = 0; i < 81; ++i) D[i] = sk * D[i] + sd * Dd[i];
    } else {
        defsim__project_psd(9, D, proj);
        for (int i = 0; i < 81; ++i) D[i] *= sk + sd;
    }
    tet_gradients(dm, gr);
    memset(dF, 0, sizeof dF);
    for (int a = 0; a < 4; ++a) {
        if (pinned[id[a]]) continue;
        const double *u = dx + 3 * (int64_t)id[a];
        for (int i = 0; i < 3; ++i)
            for (int j = 0; j < 3; ++j) dF[3 * i + j] += u[i] * gr[a][j];
    }
    apply_dpdf(D, dF, dP);
    const double vol = g->vol[e];
    for (int a = 0; a < 4; ++a) {
        if (pinned[id[a]]) continue;
        double *o = out + 3 * (int64_t)id[a];
        for (int i = 0; i < 3; ++i)
            o[i] += vol * (dP[3 * i] * gr[a][0] + dP[3 * i + 1] * gr[a][1] + dP[3 * i + 2] * gr[a][2]);
    }
}

/* out += k B dx for 3x3 blocks B per vertex (9 nv) on the diagonal. */
static void apply_diagonal(const defsim__system *s, const double *blocks, double k,
                           const double *dx, double *out)
{
    for (int32_t v = 0; v < s->nv; ++v) {
        if (s->pinned[v]) continue;
        const double *B = blocks + 9 * (int64_t)v, *u = dx + 3 * (int64_t)v;
        for (int i = 0; i < 3; ++i)
            out[3 * (int64_t)v + i] += k * (B[3 * i] * u[0] + B[3 * i + 1] * u[1] + B[3 * i + 2] * u[2]);
    }
}

void defsim__matrix_apply(const defsim__system *s, const double *x,
                          const defsim_matrix_coeffs *c, int proj, const double *dx, double *out)
{
    const int64_t ndof = 3 * (int64_t)s->nv;
    memset(out, 0, (size_t)ndof * sizeof *out);
    if (c->k != 0.0 || c->kd != 0.0) {
        for (int m = 0; m <= DEFSIM__TET_MODELS; ++m) {
            const defsim__group *g = &s->groups[m];
            for (int32_t col = 0; col < g->ncolors; ++col) {
                const int32_t e0 = g->color_ptr[col], e1 = g->color_ptr[col + 1];
#pragma omp parallel for schedule(static) num_threads(s->nthreads) if (e1 - e0 > 256)
                for (int32_t e = e0; e < e1; ++e) element_apply(g, x, e, c, proj, s->pinned, dx, out);
            }
        }
    }
    if (c->k != 0.0 || c->kd != 0.0) {
        const defsim__attachments *at = &s->att;
        for (int32_t e = 0; e < at->n; ++e) {
            const int32_t *nd = at->node + DEFSIM__ATTACH_NODES * (int64_t)e;
            const double *a = at->a + DEFSIM__ATTACH_NODES * (int64_t)e;
            const double w = c->k * at->k[e] + c->kd * at->c[e];
            double d[3] = {0.0, 0.0, 0.0};
            for (int j = 0; j < DEFSIM__ATTACH_NODES; ++j)
                if (nd[j] >= 0 && !s->pinned[nd[j]])
                    for (int i = 0; i < 3; ++i) d[i] += a[j] * dx[3 * (int64_t)nd[j] + i];
            for (int j = 0; j < DEFSIM__ATTACH_NODES; ++j)
                if (nd[j] >= 0 && !s->pinned[nd[j]])
                    for (int i = 0; i < 3; ++i) out[3 * (int64_t)nd[j] + i] += w * a[j] * d[i];
        }
    }
    if (c->k != 0.0 && s->cb_stiffness) apply_diagonal(s, s->cb_stiffness, c->k, dx, out);
    if (s->contact && (c->k != 0.0 || c->kd != 0.0) &&
        defsim__contact_blocks(s->contact, x, c->k, c->kd, s->contact->blk))
        apply_diagonal(s, s->contact->blk, 1.0, dx, out);
    if (s->body_contact && c->k != 0.0)
        defsim__body_contact_apply(s->body_contact, x, c->k, dx, out);
    if (c->m != 0.0 || c->md != 0.0)
        for (int64_t i = 0; i < ndof; ++i)
            if (!s->pinned[i / 3]) out[i] += (c->m + c->md * s->alpha3[i]) * s->mass3[i] * dx[i];
}

defsim_status defsim__matrix_product(const defsim__system *s, const double *x,
                                     const defsim_matrix_coeffs *c, const double *dx,
                                     double *out)
{
    if (!x || !c || !dx || !out) return DEFSIM_ERR_INVALID_ARGUMENT;
    defsim__matrix_apply(s, x, c, s->projection, dx, out);
    return DEFSIM_OK;
}

