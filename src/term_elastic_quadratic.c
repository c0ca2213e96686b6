/* SPDX-License-Identifier: MIT */
/*
 * The elastic energy of one quadratic-tet element group (one term per material model whose
 * bodies have 10-node tets; tet10.h): per element the sum over the 4 quadrature points of
 * weight times the model's law at F_q, so every model of material_list.h works unchanged.
 * Forces by the batched SIMD kernels of tet_forces.c when chosen (the model's lane-wise law at
 * each point, tet_batch.h), else by a scalar kernel, colour by colour either way (conflict-free
 * parallel scatter, bit-identical for any thread count), energy as deterministic blocked sums
 * (of batches by the batched kernels' lane-wise psi, else of elements by the scalar law),
 * element matrices k K + kd beta B (30 x 30) with each point's dP/dF projected as the linear
 * tets' (positive weights keep the sum positive semi-definite), products element by element
 * without forming the matrix.
 */
#include "assembly.h"
#include "energy.h"
#include "material.h"
#include "system.h"
#include "term_cache.h"
#include "tet10.h"
#include "tet_forces.h"

#include <string.h>

static const defsim__group *group(const defsim__term *t) { return t->model; }

static int compile(defsim__system *s, defsim__term *out)
{
    return defsim__term_groups(s, DEFSIM__QUAD_GROUP, out);
}

static const double *rest_of(const defsim__group *g, int32_t e)
{
    return g->qrest + DEFSIM__TET10_REST * (int64_t)e;
}

static double element_energy(const defsim__group *g, const double *x, int32_t e)
{
    const int32_t *id = g->idx + 10 * (int64_t)e;
    const double *r = rest_of(g, e);
    const double mu = g->mu[e], la = g->lambda[e];
    const double rest = g->law->psi_rest ? g->law->psi_rest(mu, la) : 0.0;
    double sum = 0.0;
    for (int q = 0; q < DEFSIM__TET10_QP; ++q) {
        const double *G = r + DEFSIM__TET10_QSTRIDE * q;
        double F[9];
        defsim__tet10_F(x, id, G, F);
        sum += G[30] * (g->law->psi(mu, la, F) - rest);
    }
    return sum;
}

/* The energy: by the batched kernel when chosen, else element by element (energy.c). */
static double energy(const defsim__term *t, const defsim__system *s, defsim__work *wk,
                     const double *x, double total)
{
    const defsim__group *g = group(t);
    if (!s->tet_kernels) return defsim__group_energy(s, wk, g, element_energy, x, total);
    return defsim__group_batched_energy(
        s, wk, g, s->tet_kernels->qenergy[t->index - DEFSIM__QUAD_GROUP], x, total);
}

static defsim_status forces(const defsim__term *t, const defsim__system *s, const defsim__eval *ev,
                            double *f, uint32_t *used)
{
    if (!(ev->which & DEFSIM_FORCE_ELASTIC)) return DEFSIM_OK;
    const defsim__group *g = group(t);
    const double *x = ev->x;
    if (s->tet_kernels) {
        s->tet_kernels->qforces[t->index - DEFSIM__QUAD_GROUP](g, x, f, s->nthreads);
        *used |= g->pass;
        return DEFSIM_OK;
    }
    for (int32_t c = 0; c < g->ncolors; ++c) {
        const int32_t e0 = g->color_ptr[c], e1 = g->color_ptr[c + 1];
#pragma omp parallel for schedule(static) num_threads(s->nthreads) if (e1 - e0 > 256)
        for (int32_t e = e0; e < e1; ++e) {
            const int32_t *id = g->idx + 10 * (int64_t)e;
            const double *r = rest_of(g, e);
            for (int q = 0; q < DEFSIM__TET10_QP; ++q) {
                const double *G = r + DEFSIM__TET10_QSTRIDE * q;
                double F[9], P[9];
                defsim__tet10_F(x, id, G, F);
                (void)g->law->P(g->mu[e], g->lambda[e], F, P);
                defsim__tet10_scatter(f, id, G, P, -G[30]);
            }
        }
    }
    *used |= g->pass;
    return DEFSIM_OK;
}

/* Element matrix over its ten nodes: K[(a i),(b k)] = sum_q w_q G_a[j] D_q[(i j),(k l)] G_b[l],
 * 30 x 30, D_q the tangent scaled by k + kd beta (material.h). */
static int element_matrix(const defsim__system *s, const defsim__group *g, const double *x,
                          int32_t e, double sk, double sd, double *K)
{
    const int32_t *id = g->idx + 10 * (int64_t)e;
    const double *r = rest_of(g, e);
    double D[DEFSIM__TET10_QP][81];
    for (int q = 0; q < DEFSIM__TET10_QP; ++q) {
        double F[9];
        defsim__tet10_F(x, id, r + DEFSIM__TET10_QSTRIDE * q, F);
        defsim__model_dpdf_scaled(g->law, g->mu[e], g->lambda[e], F, s->projection, sk, sd, D[q]);
    }
    defsim__tet10_stiffness(r, D, 0.0, NULL, K);
    return 1;
}

/* out += A dx for one element without forming its matrix: per point dF = sum_b dx_b G_b^T,
 * out_a += w_q (D_q : dF) G_a. */
static void element_apply(const defsim__group *g, const double *x, int32_t e, double sk,
                          double sd, int proj, const uint8_t *pinned, const double *dx,
                          double *out)
{
    const int32_t *id = g->idx + 10 * (int64_t)e;
    const double *r = rest_of(g, e);
    double u[30];
    for (int a = 0; a < 10; ++a)
        for (int i = 0; i < 3; ++i) u[3 * a + i] = pinned[id[a]] ? 0.0 : dx[3 * (int64_t)id[a] + i];
    for (int q = 0; q < DEFSIM__TET10_QP; ++q) {
        const double *G = r + DEFSIM__TET10_QSTRIDE * q;
        double F[9], D[81], dF[9], dP[9];
        defsim__tet10_F(x, id, G, F);
        defsim__model_dpdf_scaled(g->law, g->mu[e], g->lambda[e], F, proj, sk, sd, D);
        memset(dF, 0, sizeof dF);
        for (int a = 0; a < 10; ++a)
            for (int i = 0; i < 3; ++i)
                for (int j = 0; j < 3; ++j) dF[3 * i + j] += u[3 * a + i] * G[3 * a + j];
        for (int rr = 0; rr < 9; ++rr) {
            double v = 0.0;
            for (int c = 0; c < 9; ++c) v += D[9 * rr + c] * dF[c];
            dP[rr] = v;
        }
        for (int a = 0; a < 10; ++a) {
            if (pinned[id[a]]) continue;
            const double *ga = G + 3 * a;
            double *o = out + 3 * (int64_t)id[a];
            for (int i = 0; i < 3; ++i)
                o[i] += G[30] * (dP[3 * i] * ga[0] + dP[3 * i + 1] * ga[1] + dP[3 * i + 2] * ga[2]);
        }
    }
}

DEFSIM__GROUP_MATRIX_OPS(element_matrix, element_apply)

const defsim__term_ops defsim__term_elastic_quadratic = {
    .name = "elastic_quadratic", .flags = DEFSIM__TERM_ELASTIC, .energy_rank = 0,
    .matrix_rank = 0, DEFSIM__TERM_FORCES, DEFSIM__TERM_MATRIX,
    .pairs = defsim__group_pairs, .ranks = defsim__group_ranks};
