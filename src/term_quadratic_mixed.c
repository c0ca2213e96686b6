/* SPDX-License-Identifier: MIT */
/*
 * The mean-dilatation quadratic tets (quadratic bodies with defsim_body_def.volume_averaging;
 * docs/elements.md): the P2/P0 element of Nagtegaal, Parks and Rice (1974) in energy form,
 * against the locking that displacement-only quadratic tets keep near incompressibility. A model
 * with a split psi(F) = psi_iso(F) + U(J) (material.h) keeps psi_iso at each quadrature point
 * and evaluates U once per element on its mean volume ratio
 *
 *     Jbar = (1/V) sum_q w_q J_q,   V = sum_q w_q,
 *
 * (the element's current volume over its rest volume under the element's own rule), so
 * E_e = sum_q w_q psi_iso(F_q) + V U(Jbar). Where every point has the same F, Jbar = J and E_e
 * is the standard element's energy.
 *
 * Forces: dJbar/dx_a = (1/V) sum_q w_q cof(F_q) G_qa, so f_a = -sum_q w_q (P_iso(F_q) +
 * p cof F_q) G_qa with the element's pressure p = U'(Jbar) (tet10.c's defsim__tet10_mixed).
 *
 * Hessian: sum_q w_q G_q^T (dP_iso/dF(F_q) + p d2J/dF2(F_q)) G_q + V U''(Jbar) b b^T, with
 * b = dJbar/dx over the element's 30 DOFs: element-local, so the pattern is the quadratic tets'
 * own. Each point's 9 x 9 D_q = dP_iso/dF + p d2J/dF2 is indefinite through p d2J/dF2 and is
 * projected by eigen-decomposition under the system's projection (clamp or abs; as the linear
 * volume-averaged tets do, term_nodal_volume.c); the rank-one part is positive semi-definite where
 * U'' >= 0 (stable neo-Hookean: wherever nu >= 0; neo-Hookean: Jbar < e), U'' clamped (abs) under
 * projection. Positive weights keep the sum positive semi-definite; with projection none it is the
 * exact Hessian. Stiffness damping -beta K(x) v uses the clamped K (in this term's forces, as the
 * volume-averaged tets do; the stiffness-damping term skips these groups).
 *
 * Forces and energy by the batched SIMD kernels of tet_forces.c when chosen (core.simd; the
 * models' lane-wise split laws, tet_batch.h's DEFSIM__BATCHED_QMIXED), else by the scalar
 * element kernel; damping and matrices stay scalar. Elements are coloured (scatters without
 * atomics) and energies are blocked sums, so every sum is the same for any thread count.
 */
#include "assembly.h"
#include "element.h"
#include "energy.h"
#include "material.h"
#include "system.h"
#include "term_cache.h"
#include "tet10.h"
#include "tet_forces.h"

#include <math.h>
#include <string.h>

enum { PAR_MIN = 256 };

static const defsim__group *group(const defsim__term *t) { return t->model; }

static int compile(defsim__system *s, defsim__term *out)
{
    return defsim__term_groups(s, DEFSIM__QMIX_GROUP, out);
}

static const double *rest_of(const defsim__group *g, int32_t e)
{
    return g->qrest + DEFSIM__TET10_REST * (int64_t)e;
}

static double element_energy(const defsim__group *g, const double *x, int32_t e)
{
    double F[DEFSIM__TET10_QP][9], P[DEFSIM__TET10_QP][9], u[3];
    return defsim__tet10_mixed(g->law, g->mu[e], g->lambda[e], x, g->idx + 10 * (int64_t)e,
                               rest_of(g, e), F, P, u);
}

/* The batched kernels of this group's model (tet_forces.h's qmforces, qmenergy), or NULL: the
 * scalar ones (core.simd scalar). */
static const defsim__tet_kernels *batched(const defsim__term *t, const defsim__system *s)
{
    const int m = t->index - DEFSIM__QMIX_GROUP;
    return s->tet_kernels && s->tet_kernels->qmforces[m] && s->tet_kernels->qmenergy[m]
               ? s->tet_kernels
               : NULL;
}

static double energy(const defsim__term *t, const defsim__system *s, defsim__work *wk,
                     const double *x, double total)
{
    const defsim__tet_kernels *k = batched(t, s);
    if (!k) return defsim__group_energy(s, wk, group(t), element_energy, x, total);
    return defsim__group_batched_energy(s, wk, group(t),
                                        k->qmenergy[t->index - DEFSIM__QMIX_GROUP], x, total);
}

/* The coefficient k U'' + kd beta max(U'', 0) of the rank-one part, k's U'' projected by proj
 * (sk = k, sd = kd beta). */
static double dilatation_coef(double upp, int proj, double sk, double sd)
{
    const double pos = upp > 0.0 ? upp : 0.0;
    const double kp = proj == DEFSIM_PROJECTION_CLAMP ? pos
                      : proj == DEFSIM_PROJECTION_ABS ? fabs(upp) : upp;
    return sk * kp + sd * pos;
}

/* What an element's matrices and products need at x: F_q, the tangents D_q = sk D_q^proj +
 * sd D_q^clamp with D_q = dP_iso/dF + p d2J/dF2, b = dJbar/dx (30, the element's node order)
 * and the rank-one coefficient times V. */
typedef struct mixed_lin {
    double D[DEFSIM__TET10_QP][81];
    double b[30];
    double c;
} mixed_lin;

static void linearise_element(const defsim__group *g, const double *x, int32_t e, double sk,
                              double sd, int proj, mixed_lin *L)
{
    const int32_t *id = g->idx + 10 * (int64_t)e;
    const double *r = rest_of(g, e);
    const double mu = g->mu[e], la = g->lambda[e];
    double F[DEFSIM__TET10_QP][9], P[DEFSIM__TET10_QP][9], u[3], V = 0.0;
    (void)defsim__tet10_mixed(g->law, mu, la, x, id, r, F, P, u);
    memset(L->b, 0, sizeof L->b);
    for (int q = 0; q < DEFSIM__TET10_QP; ++q) {
        const double *G = r + DEFSIM__TET10_QSTRIDE * q;
        double C[9];
        V += G[30];
        defsim__m3_cofactor(F[q], C);
        for (int a = 0; a < 10; ++a)
            for (int i = 0; i < 3; ++i)
                L->b[3 * a + i] += G[30] * (C[3 * i] * G[3 * a] + C[3 * i + 1] * G[3 * a + 1] +
                                            C[3 * i + 2] * G[3 * a + 2]);
        g->law->split->dPdF(mu, la, F[q], L->D[q]);
        tet_add_det_hessian(F[q], u[1], L->D[q]);
        tet_damped_dpdf(L->D[q], proj, sk, sd);
    }
    for (int k = 0; k < 30; ++k) L->b[k] /= V;
    L->c = V * dilatation_coef(u[2], proj, sk, sd);
}

/* Element matrix over its ten nodes, 30 x 30: sum_q w_q G_q^T D_q G_q + c b b^T. */
static int element_matrix(const defsim__system *s, const defsim__group *g, const double *x,
                          int32_t e, double sk, double sd, double *K)
{
    mixed_lin L;
    linearise_element(g, x, e, sk, sd, s->projection, &L);
    defsim__tet10_stiffness(rest_of(g, e), (const double (*)[81])L.D, L.c, L.b, K);
    return 1;
}

/* out += (sum_q w_q G_q^T D_q G_q + c b b^T) u for one element without forming its matrix, u =
 * dx on its nodes (pinned rows and columns zero; pinned NULL: none). */
static void element_apply(const defsim__group *g, const double *x, int32_t e, double sk,
                          double sd, int proj, const uint8_t *pinned, const double *dx,
                          double *out)
{
    const int32_t *id = g->idx + 10 * (int64_t)e;
    const double *r = rest_of(g, e);
    mixed_lin L;
    linearise_element(g, x, e, sk, sd, proj, &L);
    double u[30], o[30], bu = 0.0;
    for (int a = 0; a < 10; ++a)
        for (int i = 0; i < 3; ++i)
            u[3 * a + i] = pinned && pinned[id[a]] ? 0.0 : dx[3 * (int64_t)id[a] + i];
    for (int k = 0; k < 30; ++k) bu += L.b[k] * u[k];
    for (int k = 0; k < 30; ++k) o[k] = L.c * bu * L.b[k];
    for (int q = 0; q < DEFSIM__TET10_QP; ++q) {
        const double *G = r + DEFSIM__TET10_QSTRIDE * q;
        double dF[9], dP[9];
        memset(dF, 0, sizeof dF);
        for (int a = 0; a < 10; ++a)
            for (int i = 0; i < 3; ++i)
                for (int j = 0; j < 3; ++j) dF[3 * i + j] += u[3 * a + i] * G[3 * a + j];
        apply_dpdf(L.D[q], dF, dP);
        for (int a = 0; a < 10; ++a) {
            const double *ga = G + 3 * a;
            for (int i = 0; i < 3; ++i)
                o[3 * a + i] += G[30] * (dP[3 * i] * ga[0] + dP[3 * i + 1] * ga[1] +
                                         dP[3 * i + 2] * ga[2]);
        }
    }
    for (int a = 0; a < 10; ++a) {
        if (pinned && pinned[id[a]]) continue;
        double *p = out + 3 * (int64_t)id[a];
        for (int i = 0; i < 3; ++i) p[i] += o[3 * a + i];
    }
}

static defsim_status forces(const defsim__term *t, const defsim__system *s, const defsim__eval *ev,
                            double *f, uint32_t *used)
{
    const int damp = (ev->which & DEFSIM_FORCE_DAMPING) && ev->v && s->has_stiffness_damping;
    if (!(ev->which & DEFSIM_FORCE_ELASTIC) && !damp) return DEFSIM_OK;
    const defsim__group *g = group(t);
    const double *x = ev->x;
    /* The batched elastic forces first, then (if asked) the damping element by element. */
    const defsim__tet_kernels *k = batched(t, s);
    const int elastic = (ev->which & DEFSIM_FORCE_ELASTIC) && !k;
    if (k && (ev->which & DEFSIM_FORCE_ELASTIC))
        k->qmforces[t->index - DEFSIM__QMIX_GROUP](g, x, f, s->nthreads);
    for (int32_t c = 0; c < g->ncolors && (elastic || damp); ++c) {
        const int32_t e0 = g->color_ptr[c], e1 = g->color_ptr[c + 1];
#pragma omp parallel for schedule(static) num_threads(s->nthreads) if (e1 - e0 > PAR_MIN)
        for (int32_t e = e0; e < e1; ++e) {
            const int32_t *id = g->idx + 10 * (int64_t)e;
            const double *r = rest_of(g, e);
            if (elastic) {
                double F[DEFSIM__TET10_QP][9], P[DEFSIM__TET10_QP][9], u[3];
                (void)defsim__tet10_mixed(g->law, g->mu[e], g->lambda[e], x, id, r, F, P, u);
                for (int q = 0; q < DEFSIM__TET10_QP; ++q) {
                    const double *G = r + DEFSIM__TET10_QSTRIDE * q;
                    defsim__tet10_scatter(f, id, G, P[q], -G[30]);
                }
            }
            /* -beta K v with the clamped K, over every node (a driven pin's velocity counts, and
             * pinned rows are kept for the pin forces) */
            if (damp && g->beta[e] != 0.0)
                element_apply(g, x, e, 0.0, -g->beta[e], DEFSIM_PROJECTION_CLAMP, NULL, ev->v, f);
        }
    }
    if (ev->which & DEFSIM_FORCE_ELASTIC) *used |= g->pass;
    if (damp) *used |= DEFSIM_PASS_STIFFNESS_DAMPING;
    return DEFSIM_OK;
}

DEFSIM__GROUP_MATRIX_OPS(element_matrix, element_apply)

const defsim__term_ops defsim__term_quadratic_mixed = {
    .name = "quadratic_mixed", .flags = DEFSIM__TERM_ELASTIC, .energy_rank = 0,
    .matrix_rank = 0, DEFSIM__TERM_FORCES, DEFSIM__TERM_MATRIX,
    .pairs = defsim__group_pairs, .ranks = defsim__group_ranks};
