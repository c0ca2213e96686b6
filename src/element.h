/* SPDX-License-Identifier: MIT */
/*
 * Per-element building blocks shared by the physics files and the material files, inlined into
 * their loops: F = Ds Dm^-1, the scatter of P Dm^-T to nodes, node gradients, dP = D : dF, and
 * the scalar force kernel of a tet model.
 */
#ifndef DEFSIM_ELEMENT_H
#define DEFSIM_ELEMENT_H

#include "defsim/backend.h"
#include "mat3.h"
#include "system.h"

#include <math.h>
#include <stdint.h>
#include <string.h>

/* Per-node gradient vectors: dF = sum_a dx_a g_a^T, with g_a = row a of Dm^-1 (a < 3) and
 * g_3 = -(g_0 + g_1 + g_2). */

static inline void tet_gradients(const double *dminv, double g[4][3])
{
    for (int j = 0; j < 3; ++j) {
        g[0][j] = dminv[0 * 3 + j];
        g[1][j] = dminv[1 * 3 + j];
        g[2][j] = dminv[2 * 3 + j];
        g[3][j] = -(g[0][j] + g[1][j] + g[2][j]);
    }
}

/* Attachment e's combination sum_j a_j u[node_j] (u = x or v), minus its world point p when
 * `point` is set: the spring's stretch d (x) or its rate (v). */
static inline void attach_combine(const defsim__attachments *at, int32_t e, const double *u,
                                  int point, double d[3])
{
    const int32_t *nd = at->node + DEFSIM__ATTACH_NODES * (int64_t)e;
    const double *a = at->a + DEFSIM__ATTACH_NODES * (int64_t)e;
    for (int i = 0; i < 3; ++i) d[i] = point ? -at->p[3 * (int64_t)e + i] : 0.0;
    for (int j = 0; j < DEFSIM__ATTACH_NODES; ++j)
        if (nd[j] >= 0)
            for (int i = 0; i < 3; ++i) d[i] += a[j] * u[3 * (int64_t)nd[j] + i];
}

/* F = Ds Dm^-1 with Ds = [x0 - x3, x1 - x3, x2 - x3] (columns). */
static inline void tet_deformation(const double *x, const int32_t *id, const double *dminv,
                                   double F[9])
{
    const double *p3 = x + 3 * (int64_t)id[3];
    double ds[9];
    for (int a = 0; a < 3; ++a) {
        const double *pa = x + 3 * (int64_t)id[a];
        for (int i = 0; i < 3; ++i) ds[3 * i + a] = pa[i] - p3[i];
    }
    for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j)
            F[3 * i + j] = DEFSIM__M3_MUL(ds, dminv, i, j);
}

/* Adds s * P g_a to the force of node a (s = -volume for elastic forces). */
static inline void tet_scatter(double *f, const int32_t *id, const double *dminv,
                               const double P[9], double s)
{
    double h[3][3];   /* h[a][i] = s sum_j P_ij Dminv[a][j] */
    for (int a = 0; a < 3; ++a)
        for (int i = 0; i < 3; ++i)
            h[a][i] = s * DEFSIM__M3_MUL_NT(P, dminv, i, a);
    for (int a = 0; a < 3; ++a) {
        double *fa = f + 3 * (int64_t)id[a];
        fa[0] += h[a][0];
        fa[1] += h[a][1];
        fa[2] += h[a][2];
    }
    double *f3 = f + 3 * (int64_t)id[3];
    f3[0] -= h[0][0] + h[1][0] + h[2][0];
    f3[1] -= h[0][1] + h[1][1] + h[2][1];
    f3[2] -= h[0][2] + h[1][2] + h[2][2];
}

static inline void apply_dpdf(const double D[81], const double dF[9], double dP[9])
{
    for (int r = 0; r < 9; ++r) {
        double s = 0.0;
        for (int c = 0; c < 9; ++c) s += D[9 * r + c] * dF[c];
        dP[r] = s;
    }
}

/* D += c d2(det F)/dF2, the Hessian of J = det F: D[(i j),(k l)] += c eps_ikn eps_jlm F_nm
 * (nonzero only for i != k, j != l). */
static inline void tet_add_det_hessian(const double F[9], double c, double D[81])
{
    for (int i = 0; i < 3; ++i)
        for (int k = 0; k < 3; ++k) {
            if (i == k) continue;
            int n = 3 - i - k;
            double sik = ((k - i + 3) % 3 == 1) ? c : -c;
            for (int j = 0; j < 3; ++j)
                for (int l = 0; l < 3; ++l) {
                    if (j == l) continue;
                    int m = 3 - j - l;
                    double sjl = ((l - j + 3) % 3 == 1) ? sik : -sik;
                    D[9 * (3 * i + j) + 3 * k + l] += sjl * F[3 * n + m];
                }
        }
}

/* The element matrix K[(a c),(b d)] = vol sum_{j,l} g_a[j] D[(c j),(d l)] g_b[l] of a tet (12 x
 * 12, row-major) from a symmetric dP/dF-like D. */
static inline void tet_stiffness(const double *dminv, double vol, const double D[81], double *K)
{
    const int nd = 12;
    double gr[4][3];
    tet_gradients(dminv, gr);
    /* D is symmetric, so K is; and g_3 = -(g_0 + g_1 + g_2) makes node 3's blocks minus sums of
     * the others: only the six blocks a <= b < 3 need the products. */
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
}

/* D := k proj(D) + kd beta clamp(D) (sk = k, sd = kd beta): an element's stiffness with its
 * projection `proj` and its stiffness damping's, which is always clamped. */
static inline void tet_damped_dpdf(double D[81], int proj, double sk, double sd)
{
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
}

/* The scalar force kernel of a tet model over its element group, the law PFUN(mu, lambda, F, P)
 * inlined: the reference the batched kernels are checked against (DEFSIM_SIMD=scalar). */
#define DEFSIM__TET_FORCE_KERNEL(NAME, PFUN)                                                  \
    static void NAME(const defsim__group *g, const double *x, double *f, int nthreads)       \
    {                                                                                         \
        (void)nthreads;                                                                       \
        for (int32_t c = 0; c < g->ncolors; ++c) {                                            \
            const int32_t e0 = g->color_ptr[c], e1 = g->color_ptr[c + 1];                     \
            _Pragma("omp parallel for schedule(static) num_threads(nthreads) if(e1 - e0 > 1024)") \
            for (int32_t e = e0; e < e1; ++e) {                                               \
                const int32_t *id = g->idx + 4 * (int64_t)e;                                  \
                const double *dm = g->dminv + 9 * (int64_t)e;                                 \
                double F[9], P[9];                                                            \
                tet_deformation(x, id, dm, F);                                                \
                (void)PFUN(g->mu[e], g->lambda[e], F, P);                                     \
                tet_scatter(f, id, dm, P, -g->vol[e]);                                        \
            }                                                                                 \
        }                                                                                     \
    }

#endif /* DEFSIM_ELEMENT_H */
