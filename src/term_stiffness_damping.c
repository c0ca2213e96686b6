/* SPDX-License-Identifier: MIT */
/*
 * Stiffness damping, forces -beta K_e(x) v_e per element (tets of every group, then springs, then quadratic tets)
 * with the element stiffness made positive semi-definite (analytic eigenvalue clamping of
 * dP/dF): linear in v, never injects energy. Its matrix B shares each element's matrix with the
 * elastic term (term_elastic.c, term_spring.c), so that an element is scattered once.
 */
#include "element.h"
#include "material.h"
#include "system.h"
#include "term_cache.h"
#include "tet10.h"

enum { PAR_MIN = 1024 };

static int compile(defsim__system *s, defsim__term *out)
{
    return defsim__term_one(s->has_stiffness_damping, s, NULL, 0, out);
}

static void damping_tets(const defsim__group *g, const double *x, const double *v, double *f,
                         int nthreads)
{
    (void)nthreads;   /* used by OpenMP pragmas only */
    for (int32_t c = 0; c < g->ncolors; ++c) {
        const int32_t e0 = g->color_ptr[c], e1 = g->color_ptr[c + 1];
#pragma omp parallel for schedule(static) num_threads(nthreads) if (e1 - e0 > PAR_MIN / 8)
        for (int32_t e = e0; e < e1; ++e) {
            if (g->beta[e] == 0.0) continue;
            const int32_t *id = g->idx + 4 * (int64_t)e;
            const double *dm = g->dminv + 9 * (int64_t)e;
            double F[9], dF[9], D[81], dP[9];
            tet_deformation(x, id, dm, F);
            tet_deformation(v, id, dm, dF);
            defsim__model_dpdf_projected(g->law, g->mu[e], g->lambda[e], F,
                                         DEFSIM_PROJECTION_CLAMP, D, 0, NULL);
            apply_dpdf(D, dF, dP);
            tet_scatter(f, id, dm, dP, -g->beta[e] * g->vol[e]);
        }
    }
}

static void damping_springs(const defsim__group *g, const double *x, const double *v, double *f,
                            int nthreads)
{
    (void)nthreads;   /* used by OpenMP pragmas only */
    for (int32_t c = 0; c < g->ncolors; ++c) {
        const int32_t e0 = g->color_ptr[c], e1 = g->color_ptr[c + 1];
#pragma omp parallel for schedule(static) num_threads(nthreads) if (e1 - e0 > PAR_MIN)
        for (int32_t e = e0; e < e1; ++e) {
            if (g->beta[e] == 0.0) continue;
            const int32_t a = g->idx[2 * (int64_t)e], b = g->idx[2 * (int64_t)e + 1];
            double Kb[9];
            defsim__model_spring.block(x + 3 * (int64_t)a, x + 3 * (int64_t)b, g->k[e], g->l0[e],
                                       DEFSIM_PROJECTION_CLAMP, Kb);
            const double *va = v + 3 * (int64_t)a, *vb = v + 3 * (int64_t)b;
            double dv[3] = {vb[0] - va[0], vb[1] - va[1], vb[2] - va[2]};
            for (int i = 0; i < 3; ++i) {
                double s = g->beta[e] * (Kb[3 * i] * dv[0] + Kb[3 * i + 1] * dv[1] +
                                         Kb[3 * i + 2] * dv[2]);
                f[3 * (int64_t)a + i] += s;
                f[3 * (int64_t)b + i] -= s;
            }
        }
    }
}

static defsim_status forces(const defsim__term *t, const defsim__system *s, const defsim__eval *ev,
                            double *f, uint32_t *used)
{
    (void)t;
    if (!(ev->which & DEFSIM_FORCE_DAMPING) || !ev->v) return DEFSIM_OK;
    for (int m = 0; m < DEFSIM__TET_MODELS; ++m)
        if (s->groups[m].n > 0) damping_tets(&s->groups[m], ev->x, ev->v, f, s->nthreads);
    const defsim__group *sg = &s->groups[DEFSIM__TET_MODELS];
    if (sg->n > 0) damping_springs(sg, ev->x, ev->v, f, s->nthreads);
    for (int m = DEFSIM__QUAD_GROUP; m < DEFSIM__GROUPS; ++m)
        if (s->groups[m].n > 0)
            defsim__tet10_damping_forces(&s->groups[m], ev->x, ev->v, f, s->nthreads);
    *used |= DEFSIM_PASS_STIFFNESS_DAMPING;
    return DEFSIM_OK;
}

static void rates(const defsim__term *t, const defsim__system *s, const double *x,
                  defsim__rates *r)
{
    (void)t;
    (void)x;
    for (int m = 0; m < DEFSIM__GROUPS; ++m)
        for (int32_t e = 0; e < s->groups[m].n; ++e)
            if (s->groups[m].beta[e] > r->beta) r->beta = s->groups[m].beta[e];
}

const defsim__term_ops defsim__term_stiffness_damping = {
    .name = "stiffness_damping", .compile = compile, .forces = forces, .rates = rates};
