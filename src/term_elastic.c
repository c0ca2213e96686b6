/* SPDX-License-Identifier: MIT */
/*
 * The elastic energy of one tet element group (one term per material model that the scene
 * uses): forces by the batched SIMD kernels of tet_forces.c when chosen, else the model's scalar
 * kernel, unchanged; energy as deterministic blocked sums; element matrices k K + kd beta B
 * (the group's stiffness damping B shares the element matrix, so each element is scattered
 * once); products element by element without forming the matrix. Elements are sorted by
 * colour, so each colour scatters in parallel without atomics, bit-identical for any thread
 * count.
 */
#include "adjoint.h"
#include "assembly.h"
#include "element.h"
#include "energy.h"
#include "mat3.h"
#include "material.h"
#include "system.h"
#include "term_cache.h"
#include "tet_forces.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

static const defsim__group *group(const defsim__term *t) { return t->model; }

static int compile(defsim__system *s, defsim__term *out)
{
    return defsim__term_groups(s, 0, out);
}

static double element_energy(const defsim__group *g, const double *x, int32_t e)
{
    double F[9];
    tet_deformation(x, g->idx + 4 * (int64_t)e, g->dminv + 9 * (int64_t)e, F);
    const double mu = g->mu[e], la = g->lambda[e];
    double psi = g->law->psi(mu, la, F);
    if (g->law->psi_rest) psi -= g->law->psi_rest(mu, la);
    return g->vol[e] * psi;
}

DEFSIM__GROUP_ENERGY_OP(element_energy)

static defsim_status forces(const defsim__term *t, const defsim__system *s, const defsim__eval *ev,
                            double *f, uint32_t *used)
{
    if (!(ev->which & DEFSIM_FORCE_ELASTIC)) return DEFSIM_OK;
    const defsim__group *g = group(t);
    if (s->tet_kernels) s->tet_kernels->forces[t->index](g, ev->x, f, s->nthreads);
    else g->law->forces(g, ev->x, f, s->nthreads);
    *used |= g->pass;
    return DEFSIM_OK;
}

/* Element matrix over its nodes: K[(a c),(b d)], 12x12, scaled by k + kd beta (kd part always
 * with clamped projection). Returns 0 if the element adds nothing. */
static int element_matrix(const defsim__system *s, const defsim__group *g, const double *x,
                          int32_t e, double sk, double sd, double *K)
{
    const int proj = s->projection;
    double F[9], D[81];
    tet_deformation(x, g->idx + 4 * (int64_t)e, g->dminv + 9 * (int64_t)e, F);
    defsim__model_dpdf_scaled(g->law, g->mu[e], g->lambda[e], F, proj, sk, sd, D);
    tet_stiffness(g->dminv + 9 * (int64_t)e, g->vol[e], D, K);
    return 1;
}

/* out += A dx for one element without forming its matrix: dF = sum_a dx_a g_a^T,
 * dP = (k D + kd beta Dclamped) : dF, out_a += vol dP g_a. */
static void element_apply(const defsim__group *g, const double *x, int32_t e, double sk,
                          double sd, int proj, const uint8_t *pinned, const double *dx,
                          double *out)
{
    const int32_t *id = g->idx + 4 * (int64_t)e;
    const double *dm = g->dminv + 9 * (int64_t)e;
    double F[9], D[81], dF[9], dP[9], gr[4][3];
    tet_deformation(x, id, dm, F);
    g->law->dPdF(g->mu[e], g->lambda[e], F, D);
    tet_damped_dpdf(D, proj, sk, sd);
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

DEFSIM__GROUP_MATRIX_OPS(element_matrix, element_apply)

/* Reverse mode: f_e = -vol P(F) Dm^-T scattered, so w . f_e = -vol P : dF(w) with
 * dF(w) = sum_a w_a g_a^T; its x-derivative is -K w with the exact (unprojected) dP/dF, its
 * (mu, lambda)-derivatives -vol dP/dmu : dF(w) and -vol dP/dlambda : dF(w). */
static defsim_status vjp(const defsim__term *t, const defsim__system *s, const defsim__eval *ev,
                         const double *w, double *gx, double *gv, defsim__grad *g)
{
    (void)s;
    (void)gv;
    if (!(ev->which & DEFSIM_FORCE_ELASTIC)) return DEFSIM_OK;
    const defsim__group *gr = group(t);
    for (int32_t e = 0; e < gr->n; ++e) {
        const int32_t *id = gr->idx + 4 * (int64_t)e;
        const double *dm = gr->dminv + 9 * (int64_t)e;
        double F[9], dFw[9];
        tet_deformation(ev->x, id, dm, F);
        tet_deformation(w, id, dm, dFw);
        if (gx) {
            double D[81], dP[9];
            gr->law->dPdF(gr->mu[e], gr->lambda[e], F, D);
            apply_dpdf(D, dFw, dP);
            tet_scatter(gx, id, dm, dP, -gr->vol[e]);
        }
        if (g && (g->want & DEFSIM__WANT_LAME)) {
            double Pmu[9], Pla[9];
            defsim__model_dP_dlame(gr->law, gr->mu[e], gr->lambda[e], F, Pmu, Pla);
            g->mu[t->index][e] -= gr->vol[e] * defsim__m3_ddot(Pmu, dFw);
            g->lambda[t->index][e] -= gr->vol[e] * defsim__m3_ddot(Pla, dFw);
        }
    }
    return DEFSIM_OK;
}

const defsim__term_ops defsim__term_elastic = {
    .name = "elastic", .flags = DEFSIM__TERM_ELASTIC, .energy_rank = 0, .matrix_rank = 0,
    DEFSIM__TERM_FORCES, DEFSIM__TERM_MATRIX,
    .pairs = defsim__group_pairs, .ranks = defsim__group_ranks, .vjp = vjp};
