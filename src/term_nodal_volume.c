/* SPDX-License-Identifier: MIT */
/*
 * The volume-averaged tets (defsim_body_def.volume_averaging): Bonet and Burton's averaged
 * nodal pressure tetrahedron (1998) in energy form, against the volumetric locking of linear
 * tets. A model with a split psi(F) = psi_iso(F) + U(J) (material.h) keeps psi_iso per element
 * and evaluates U per node n on the nodal volume ratio
 *
 *     J_n = v_n / V_n = sum_{e at n} w_ne J_e,   w_ne = V_e / (4 V_n),   V_n = sum_{e at n} V_e / 4,
 *
 * (v_n the current nodal volume), so E = sum_e V_e psi_iso(F_e) + sum_n V_n U(J_n). Where every
 * element has the same F, J_n = J_e and E is the standard element's energy.
 *
 * Forces: dJ_e/dx_a = cof(F_e) g_a, so f_a = -V_e (P_iso(F_e) + p_e cof F_e) g_a with the
 * element's averaged pressure p_e = sum_{n of e} U'(J_n) / 4: an element-local scatter once the
 * nodal U' are gathered.
 *
 * Hessian: sum_e V_e B_e^T (dP_iso/dF + p_e d2J/dF2) B_e + sum_n V_n U''(J_n) G_n G_n^T, with
 * G_n = dJ_n/dx = sum_{e at n} w_ne dJ_e/dx over the node's patch (the vertices of its tets: the
 * pattern grows to the patches). The element part is a tet's 12 x 12 matrix with
 * D = dP_iso/dF + p_e d2J/dF2, indefinite through p_e d2J/dF2; it is projected as a 9 x 9
 * (clamp or abs of its eigenvalues, the system's projection); the nodal part is rank one per node
 * and positive semi-definite where U'' >= 0 (for stable neo-Hookean wherever nu >= 0, J_n < e
 * for neo-Hookean), U'' clamped (abs) under projection. The sum is then positive semi-definite;
 * with projection none it is the exact Hessian. Products need no patch matrix: G_n . dx is the
 * weighted sum of the elements' cof(F_e) : dF_e(dx), and the product's rows are element-local
 * scatters again.
 *
 * Stiffness damping -beta K(x) v uses the clamped K, as the elastic term's does.
 *
 * Elements are coloured (scatters without atomics); node gathers read elements in a fixed
 * order, so every sum is the same for any thread count. Nodal parts of matrix values are added
 * node by node on one thread.
 */
#include "assembly.h"
#include "element.h"
#include "energy.h"
#include "mat3.h"
#include "material.h"
#include "system.h"
#include "term_cache.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

enum { PAR_MIN = 256 };

static int compile(defsim__system *s, defsim__term *out)
{
    if (!s->has_volume_averaging) return 0;
    if (!defsim__cache_reserve(&s->cache[DEFSIM__TERM_KIND_nodal_volume], 0, s->nv)) return -1;
    return defsim__term_one(1, s, NULL, 0, out);
}

static const defsim__vgroup *vgroup_of(const defsim__group *g)
{
    return (const defsim__vgroup *)(const void *)g;   /* g is the first member */
}

/* The nodal state at x: J_e into je, U'(J_n) into u1 and, if u2, U^(which)(J_n) into u2 (which
 * 0: U, 2: U''), and, if pe, the elements' averaged pressures. */
static void nodal_state(const defsim__vgroup *v, const double *x, int nthreads, double *je,
                        double *u1, double *u2, int which, double *pe)
{
    (void)nthreads;   /* used by OpenMP pragmas only */
    const defsim__group *g = &v->g;
    const defsim__model_split *sp = g->law->split;
#pragma omp parallel for schedule(static) num_threads(nthreads) if (g->n > PAR_MIN)
    for (int32_t e = 0; e < g->n; ++e) {
        double F[9];
        tet_deformation(x, g->idx + 4 * (int64_t)e, g->dminv + 9 * (int64_t)e, F);
        je[e] = defsim__m3_det(F);
    }
#pragma omp parallel for schedule(static) num_threads(nthreads) if (v->nn > PAR_MIN)
    for (int32_t n = 0; n < v->nn; ++n) {
        double J = 0.0, u[3];
        for (int64_t k = v->ne_ptr[n]; k < v->ne_ptr[n + 1]; ++k) J += v->wne[k] * je[v->ne[k] / 4];
        const int32_t e = v->ne[v->ne_ptr[n]] / 4;
        sp->U(g->mu[e], g->lambda[e], J, u);
        u1[n] = u[1];
        if (u2) u2[n] = u[which];
    }
    if (!pe) return;
#pragma omp parallel for schedule(static) num_threads(nthreads) if (g->n > PAR_MIN)
    for (int32_t e = 0; e < g->n; ++e) {
        const int32_t *nd = v->enode + 4 * (int64_t)e;
        pe[e] = 0.25 * (u1[nd[0]] + u1[nd[1]] + u1[nd[2]] + u1[nd[3]]);
    }
}

/* Element energy V_e (psi_iso(F_e) - psi(I)): the whole rest energy here, U's included. */
static double element_energy(const defsim__group *g, const double *x, int32_t e)
{
    double F[9], P[9];
    tet_deformation(x, g->idx + 4 * (int64_t)e, g->dminv + 9 * (int64_t)e, F);
    const double mu = g->mu[e], la = g->lambda[e];
    double psi = g->law->split->P(mu, la, F, P);
    if (g->law->psi_rest) psi -= g->law->psi_rest(mu, la);
    return g->vol[e] * psi;
}

static double energy(const defsim__term *t, const defsim__system *s, defsim__work *wk,
                     const double *x, double total)
{
    (void)t;
    for (int m = 0; m < DEFSIM__TET_MODELS; ++m) {
        const defsim__vgroup *v = &s->vgroups[m];
        if (v->g.n == 0) continue;
        total = defsim__group_energy(s, wk, &v->g, element_energy, x, total);
        nodal_state(v, x, s->nthreads, v->se, v->sn, v->sn + v->nn, 0, NULL);
        /* sum_n V_n U(J_n) in the blocks of the reductions (energy.h) */
        const double *un = v->sn + v->nn;
        const int32_t nb = (v->nn + DEFSIM__REDUCE_BLOCK - 1) / DEFSIM__REDUCE_BLOCK;
        double *part = wk->partial;
#pragma omp parallel for schedule(static) num_threads(s->nthreads) if (nb > 1)
        for (int32_t b = 0; b < nb; ++b) {
            const int32_t n1 = (b + 1) * DEFSIM__REDUCE_BLOCK < v->nn ? (b + 1) * DEFSIM__REDUCE_BLOCK
                                                                      : v->nn;
            double sum = 0.0;
            for (int32_t n = b * DEFSIM__REDUCE_BLOCK; n < n1; ++n) sum += v->vn[n] * un[n];
            part[b] = sum;
        }
        for (int32_t b = 0; b < nb; ++b) total += part[b];
    }
    return total;
}

/* Adds s P g_a to out at the element's free vertices. */
static void scatter_free(double *out, const int32_t *id, const double *dm, const double P[9],
                         double s, const uint8_t *pinned)
{
    double h[4][3];   /* h[a] = s P g_a */
    double gr[4][3];
    tet_gradients(dm, gr);
    for (int a = 0; a < 4; ++a)
        for (int i = 0; i < 3; ++i)
            h[a][i] = s * (P[3 * i] * gr[a][0] + P[3 * i + 1] * gr[a][1] + P[3 * i + 2] * gr[a][2]);
    for (int a = 0; a < 4; ++a) {
        if (pinned && pinned[id[a]]) continue;
        double *o = out + 3 * (int64_t)id[a];
        o[0] += h[a][0];
        o[1] += h[a][1];
        o[2] += h[a][2];
    }
}

/* out_a += scale V_e (P_iso(F_e) [iso] + c_e cof F_e) g_a over group v's elements at x, colour
 * by colour (pinned: as scatter_free); elements with neither part skipped. */
static void pressure_pass(const defsim__system *s, const defsim__vgroup *v, const double *x,
                          const double *c, int iso, double scale, const uint8_t *pinned,
                          double *out)
{
    const defsim__group *g = &v->g;
    for (int32_t col = 0; col < g->ncolors; ++col) {
        const int32_t e0 = g->color_ptr[col], e1 = g->color_ptr[col + 1];
#pragma omp parallel for schedule(static) num_threads(s->nthreads) if (e1 - e0 > PAR_MIN)
        for (int32_t e = e0; e < e1; ++e) {
            if (!iso && c[e] == 0.0) continue;
            const int32_t *id = g->idx + 4 * (int64_t)e;
            const double *dm = g->dminv + 9 * (int64_t)e;
            double F[9], P[9], C[9];
            tet_deformation(x, id, dm, F);
            if (iso) (void)g->law->split->P(g->mu[e], g->lambda[e], F, P);
            else memset(P, 0, sizeof P);
            defsim__m3_cofactor(F, C);
            for (int i = 0; i < 9; ++i) P[i] += c[e] * C[i];
            scatter_free(out, id, dm, P, scale * g->vol[e], pinned);
        }
    }
}

/* D = (k D_e + kd beta D_e^clamp) for the element's D_e = dP_iso/dF + p d2J/dF2 at F projected
 * with proj, sk = k and sd = kd beta (as term_elastic.c combines them). */
static void element_D(const defsim__group *g, int32_t e, const double F[9], double p, int proj,
                      double sk, double sd, double D[81])
{
    g->law->split->dPdF(g->mu[e], g->lambda[e], F, D);
    tet_add_det_hessian(F, p, D);
    tet_damped_dpdf(D, proj, sk, sd);
}

/* The nodal coefficient k U'' + kd beta_n max(U'', 0) with k's U'' projected by proj. */
static double nodal_coef(double upp, int proj, double sk, double sd)
{
    const double pos = upp > 0.0 ? upp : 0.0;
    const double kp = proj == DEFSIM_PROJECTION_CLAMP ? pos
                      : proj == DEFSIM_PROJECTION_ABS ? fabs(upp) : upp;
    return sk * kp + sd * pos;
}

/* out += (k K + kd B) u over group v at x, with the element pressures pe and nodal U'' un at x
 * (the rows and columns of pinned vertices zero; pinned NULL: none; beta scales the damping per
 * element and node). The element
 * part and the elements' J rates cof F_e : dF_e(u) in one pass, the nodal part after the
 * gather. */
static void group_apply(const defsim__system *s, const defsim__vgroup *v, const double *x,
                        const double *pe, const double *un, double k, double kd, int proj,
                        const uint8_t *pinned, const double *u, double *out)
{
    const defsim__group *g = &v->g;
    double *jd = v->se, *sn = v->sn, *q = v->se + g->n;
    for (int32_t c = 0; c < g->ncolors; ++c) {
        const int32_t e0 = g->color_ptr[c], e1 = g->color_ptr[c + 1];
#pragma omp parallel for schedule(static) num_threads(s->nthreads) if (e1 - e0 > PAR_MIN)
        for (int32_t e = e0; e < e1; ++e) {
            const int32_t *id = g->idx + 4 * (int64_t)e;
            const double *dm = g->dminv + 9 * (int64_t)e;
            const double sd = kd * g->beta[e];
            double F[9], C[9], D[81], dF[9], dP[9], gr[4][3];
            tet_deformation(x, id, dm, F);
            tet_gradients(dm, gr);
            memset(dF, 0, sizeof dF);
            for (int a = 0; a < 4; ++a) {
                if (pinned && pinned[id[a]]) continue;
                const double *ua = u + 3 * (int64_t)id[a];
                for (int i = 0; i < 3; ++i)
                    for (int j = 0; j < 3; ++j) dF[3 * i + j] += ua[i] * gr[a][j];
            }
            defsim__m3_cofactor(F, C);
            jd[e] = defsim__m3_ddot(C, dF);
            if (k == 0.0 && sd == 0.0) continue;
            element_D(g, e, F, pe[e], proj, k, sd, D);
            apply_dpdf(D, dF, dP);
            scatter_free(out, id, dm, dP, g->vol[e], pinned);
        }
    }
#pragma omp parallel for schedule(static) num_threads(s->nthreads) if (v->nn > PAR_MIN)
    for (int32_t n = 0; n < v->nn; ++n) {
        double r = 0.0;
        for (int64_t i = v->ne_ptr[n]; i < v->ne_ptr[n + 1]; ++i) r += v->wne[i] * jd[v->ne[i] / 4];
        sn[n] = nodal_coef(un[n], proj, k, kd * v->beta_n[n]) * r;
    }
#pragma omp parallel for schedule(static) num_threads(s->nthreads) if (g->n > PAR_MIN)
    for (int32_t e = 0; e < g->n; ++e) {
        const int32_t *nd = v->enode + 4 * (int64_t)e;
        q[e] = 0.25 * (sn[nd[0]] + sn[nd[1]] + sn[nd[2]] + sn[nd[3]]);
    }
    pressure_pass(s, v, x, q, 0, 1.0, pinned, out);
}

static defsim_status forces(const defsim__term *t, const defsim__system *s, const defsim__eval *ev,
                            double *f, uint32_t *used)
{
    (void)t;
    const int damp = (ev->which & DEFSIM_FORCE_DAMPING) && ev->v && s->has_stiffness_damping;
    if (!(ev->which & DEFSIM_FORCE_ELASTIC) && !damp) return DEFSIM_OK;
    for (int m = 0; m < DEFSIM__TET_MODELS; ++m) {
        const defsim__vgroup *v = &s->vgroups[m];
        const defsim__group *g = &v->g;
        if (g->n == 0) continue;
        double *pe = v->se + 2 * (int64_t)g->n, *upp = v->sn + v->nn;
        nodal_state(v, ev->x, s->nthreads, v->se, v->sn, upp, 2, pe);
        if (ev->which & DEFSIM_FORCE_ELASTIC) {
            pressure_pass(s, v, ev->x, pe, 1, -1.0, NULL, f);
            *used |= g->pass;
        }
        if (damp) {
            /* -beta K v with the clamped K: the product with kd = -1, over every vertex (a
             * driven pin's velocity counts, and pinned rows are kept for the pin forces) */
            group_apply(s, v, ev->x, pe, upp, 0.0, -1.0, DEFSIM_PROJECTION_CLAMP, NULL, ev->v, f);
            *used |= DEFSIM_PASS_STIFFNESS_DAMPING;
        }
    }
    return DEFSIM_OK;
}

/* ------------------------------------------------------------------------------------------ */
/* Pattern, linearisation, matrices */

static void pairs(const defsim__term *t, const defsim__system *s, int64_t *pos, int32_t *list)
{
    (void)t;
    for (int m = 0; m < DEFSIM__TET_MODELS; ++m) {
        const defsim__vgroup *v = &s->vgroups[m];
        for (int32_t n = 0; n < v->nn; ++n) {
            const int32_t *p = v->patch + v->patch_ptr[n];
            const int64_t np = v->patch_ptr[n + 1] - v->patch_ptr[n];
            for (int64_t a = 0; a < np; ++a) {
                const int32_t fa = s->vfree[p[a]];
                if (fa < 0) continue;
                for (int64_t b = 0; b < np; ++b) {
                    const int32_t fb = s->vfree[p[b]];
                    if (fb < 0) continue;
                    if (list) list[pos[fa]++] = fb;
                    else pos[fa + 1]++;
                }
            }
        }
    }
}

static defsim_status ranks(const defsim__term *t, defsim__system *s)
{
    (void)t;
    const defsim__pattern *pt = &s->pattern;
    for (int m = 0; m < DEFSIM__TET_MODELS; ++m) {
        defsim__vgroup *v = &s->vgroups[m];
        if (v->g.n == 0) continue;
        free(v->g.blk);
        v->g.blk = defsim__element_ranks(s, v->g.idx, 4, v->g.n);
        if (!v->g.blk) return DEFSIM_ERR_OUT_OF_MEMORY;
        for (int32_t n = 0; n < v->nn; ++n) {
            const int32_t *p = v->patch + v->patch_ptr[n];
            const int64_t np = v->patch_ptr[n + 1] - v->patch_ptr[n];
            int32_t *r = v->prank + v->prank_ptr[n];
            for (int64_t a = 0; a < np; ++a)
                for (int64_t b = 0; b < np; ++b) {
                    const int32_t fa = s->vfree[p[a]], fb = s->vfree[p[b]];
                    r[a * np + b] = fa < 0 || fb < 0
                                        ? -1
                                        : defsim__lower_rank(pt->adj + pt->adj_ptr[fb],
                                                             pt->adj_ptr[fb + 1] - pt->adj_ptr[fb],
                                                             fa);
                }
        }
    }
    return DEFSIM_OK;
}

/* The nodal state at x for the matrices (the elements' pressures, the nodes' U''), kept while
 * x is the cache's. */
static defsim_status linearise(const defsim__term *t, const defsim__system *s, const double *x,
                               const defsim_matrix_coeffs *c, int mode)
{
    defsim__term_cache *cc = t->cache;
    if (mode != DEFSIM__LIN_VALUES && defsim__cache_hit(cc, s->nv, x, c)) return DEFSIM_OK;
    for (int m = 0; m < DEFSIM__TET_MODELS; ++m) {
        const defsim__vgroup *v = &s->vgroups[m];
        if (v->g.n > 0)
            nodal_state(v, x, s->nthreads, v->se, v->sn, v->lin_un, 2, v->lin_pe);
    }
    defsim__cache_store(cc, s->nv, x, c);
    return DEFSIM_OK;
}

static int element_matrix(const defsim__system *s, const defsim__group *g, const double *x,
                          int32_t e, double sk, double sd, double *K)
{
    double F[9], D[81];
    tet_deformation(x, g->idx + 4 * (int64_t)e, g->dminv + 9 * (int64_t)e, F);
    element_D(g, e, F, vgroup_of(g)->lin_pe[e], s->projection, sk, sd, D);
    tet_stiffness(g->dminv + 9 * (int64_t)e, g->vol[e], D, K);
    return 1;
}

static void values(const defsim__term *t, const defsim__system *s, const double *x,
                   const defsim_matrix_coeffs *c, int upper, const int64_t *cp, double *val,
                   uint32_t *passes)
{
    (void)t;
    if (c->k == 0.0 && c->kd == 0.0) return;
    for (int m = 0; m < DEFSIM__TET_MODELS; ++m) {
        const defsim__vgroup *v = &s->vgroups[m];
        const defsim__group *g = &v->g;
        if (g->n == 0) continue;
        defsim__group_values(s, g, element_matrix, x, c, upper, cp, val, passes);
        /* G_n over each patch, then V_n coef G_n G_n^T into the node's patch blocks */
#pragma omp parallel for schedule(static) num_threads(s->nthreads) if (v->nn > PAR_MIN)
        for (int32_t n = 0; n < v->nn; ++n) {
            double *G = v->gn + 3 * v->patch_ptr[n];
            memset(G, 0, 3 * (size_t)(v->patch_ptr[n + 1] - v->patch_ptr[n]) * sizeof *G);
            for (int64_t k = v->ne_ptr[n]; k < v->ne_ptr[n + 1]; ++k) {
                const int32_t e = v->ne[k] / 4;
                const double *dm = g->dminv + 9 * (int64_t)e;
                double F[9], C[9], gr[4][3];
                tet_deformation(x, g->idx + 4 * (int64_t)e, dm, F);
                defsim__m3_cofactor(F, C);
                tet_gradients(dm, gr);
                for (int a = 0; a < 4; ++a) {
                    double *Ga = G + 3 * (int64_t)v->ploc[4 * k + a];
                    for (int i = 0; i < 3; ++i)
                        Ga[i] += v->wne[k] * (C[3 * i] * gr[a][0] + C[3 * i + 1] * gr[a][1] +
                                              C[3 * i + 2] * gr[a][2]);
                }
            }
        }
        for (int32_t n = 0; n < v->nn; ++n) {
            const double w = v->vn[n] * nodal_coef(v->lin_un[n], s->projection, c->k,
                                                   c->kd * v->beta_n[n]);
            if (w == 0.0) continue;
            const int32_t *p = v->patch + v->patch_ptr[n];
            const int64_t np = v->patch_ptr[n + 1] - v->patch_ptr[n];
            const int32_t *r = v->prank + v->prank_ptr[n];
            const double *G = v->gn + 3 * v->patch_ptr[n];
            for (int64_t b = 0; b < np; ++b) {
                const int32_t fb = s->vfree[p[b]];
                if (fb < 0) continue;
                for (int64_t a = 0; a < np; ++a) {
                    const int32_t rk = r[a * np + b];
                    if (rk < 0) continue;
                    const int32_t fa = s->vfree[p[a]];
                    if (upper && fa > fb) continue;
                    for (int cb = 0; cb < 3; ++cb) {
                        const int64_t base = cp[3 * (int64_t)fb + cb] + 3 * (int64_t)rk;
                        const int camax = (upper && fa == fb) ? cb : 2;
                        for (int ca = 0; ca <= camax; ++ca)
                            val[base + ca] += w * G[3 * a + ca] * G[3 * b + cb];
                    }
                }
            }
        }
    }
}

static void apply(const defsim__term *t, const defsim__system *s, const double *x,
                  const defsim_matrix_coeffs *c, int proj, const double *dx, double *out)
{
    (void)t;
    if (c->k == 0.0 && c->kd == 0.0) return;
    for (int m = 0; m < DEFSIM__TET_MODELS; ++m) {
        const defsim__vgroup *v = &s->vgroups[m];
        if (v->g.n > 0) group_apply(s, v, x, v->lin_pe, v->lin_un, c->k, c->kd, proj, s->pinned, dx,
                                     out);
    }
}

static void rates(const defsim__term *t, const defsim__system *s, const double *x,
                  defsim__rates *r)
{
    (void)t;
    (void)x;
    for (int m = 0; m < DEFSIM__TET_MODELS; ++m)
        for (int32_t e = 0; e < s->vgroups[m].g.n; ++e)
            if (s->vgroups[m].g.beta[e] > r->beta) r->beta = s->vgroups[m].g.beta[e];
}

const defsim__term_ops defsim__term_nodal_volume = {
    .name = "nodal_volume", .flags = DEFSIM__TERM_ELASTIC, .energy_rank = 0, .matrix_rank = 0,
    DEFSIM__TERM_FORCES, DEFSIM__TERM_MATRIX, .pairs = pairs, .ranks = ranks,
    .linearise = linearise, .rates = rates};
