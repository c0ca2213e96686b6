/* SPDX-License-Identifier: MIT */
/*
 * Per-element building blocks shared by forces.c, energy.c and assembly.c, inlined into their
 * loops: F = Ds Dm^-1, the scatter of P Dm^-T to nodes, node gradients, dP = D : dF, a spring's
 * 3x3 block, and dP/dF of a tet model (plain or made positive semi-definite).
 */
#ifndef DEFSIM_ELEMENT_H
#define DEFSIM_ELEMENT_H

#include "defsim/backend.h"
#include "mat3.h"
#include "material_models.h"
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
            F[3 * i + j] = ds[3 * i + 0] * dminv[0 + j] + ds[3 * i + 1] * dminv[3 + j] +
                           ds[3 * i + 2] * dminv[6 + j];
}

/* Adds s * P g_a to the force of node a (s = -volume for elastic forces). */
static inline void tet_scatter(double *f, const int32_t *id, const double *dminv,
                               const double P[9], double s)
{
    double h[3][3];   /* h[a][i] = s sum_j P_ij Dminv[a][j] */
    for (int a = 0; a < 3; ++a)
        for (int i = 0; i < 3; ++i)
            h[a][i] = s * (P[3 * i + 0] * dminv[3 * a + 0] + P[3 * i + 1] * dminv[3 * a + 1] +
                           P[3 * i + 2] * dminv[3 * a + 2]);
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

/* dPdF of any tet model (not the hot path). */
static inline void group_dpdf(int model, double mu, double la, const double F[9], double D[81])
{
    switch (model) {
    case DEFSIM_MODEL_STVK: defsim__stvk_dPdF(mu, la, F, D); break;
    case DEFSIM_MODEL_COROTATED: defsim__corotated_dPdF(mu, la, F, D); break;
    case DEFSIM_MODEL_NEOHOOKEAN: defsim__neohookean_dPdF(mu, la, F, D); break;
    default: defsim__snh_dPdF(mu, la, F, D); break;
    }
}

/* dPdF of a tet model made positive semi-definite (mode DEFSIM_PROJECTION_CLAMP or _ABS) from
 * its eigen-structure in signed singular values (material_models.h, *_sigma): the 3 x 3 block h
 * is projected and the six twist / flip eigenvalues clamped, which is the projection of the
 * 9 x 9 tensor without a 9 x 9 eigensolver. D2, if not NULL, receives the projection with mode2
 * from the same decomposition. */
static inline void group_dpdf_projected(int model, double mu, double la, const double F[9], int mode,
                                        double D[81], int mode2, double *D2)
{
    double U[9], V[9], s[3], h[9], es[3], ek[3];
    defsim__svd3(F, U, s, V);
    switch (model) {
    case DEFSIM_MODEL_STVK: defsim__stvk_sigma(mu, la, s, h, es, ek); break;
    case DEFSIM_MODEL_COROTATED: defsim__corotated_sigma(mu, la, s, h, es, ek); break;
    case DEFSIM_MODEL_NEOHOOKEAN: defsim__neohookean_sigma(mu, la, s, h, es, ek); break;
    default: defsim__snh_sigma(mu, la, s, h, es, ek); break;
    }
    const int modes[2] = {mode, mode2};
    double *out[2] = {D, D2};
    for (int k = 0; k < 2; ++k) {
        if (!out[k]) continue;
        double hp[9], esp[3], ekp[3];
        memcpy(hp, h, sizeof hp);
        /* Positive definite (leading minors > 0, Sylvester), the common case: nothing to do. */
        const double m2 = h[0] * h[4] - h[1] * h[3];
        const double m3 = h[0] * (h[4] * h[8] - h[5] * h[7]) - h[1] * (h[3] * h[8] - h[5] * h[6]) +
                          h[2] * (h[3] * h[7] - h[4] * h[6]);
        if (!(h[0] > 0.0 && m2 > 0.0 && m3 > 0.0)) defsim__project_psd(3, hp, modes[k]);
        for (int p = 0; p < 3; ++p) {
            esp[p] = es[p] < 0.0 ? (modes[k] == DEFSIM_PROJECTION_ABS ? -es[p] : 0.0) : es[p];
            ekp[p] = ek[p] < 0.0 ? (modes[k] == DEFSIM_PROJECTION_ABS ? -ek[p] : 0.0) : ek[p];
        }
        defsim__isotropic_dPdF(U, V, hp, esp, ekp, out[k]);
    }
}


/* Spring direction, length and the 3x3 block Kb = k (n n^T + s (I - n n^T)), s = 1 - l0/l,
 * with s projected as the element's Hessian would be (its eigenvalues are k and k s). */
static inline void spring_block(const double *xa, const double *xb, double k, double l0,
                                int projection, double Kb[9])
{
    double d[3] = {xb[0] - xa[0], xb[1] - xa[1], xb[2] - xa[2]};
    double l = sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
    double n[3] = {0, 0, 0};
    double s = 0.0;
    if (l > 0.0) {
        n[0] = d[0] / l; n[1] = d[1] / l; n[2] = d[2] / l;
        s = 1.0 - l0 / l;
    }
    if (projection == DEFSIM_PROJECTION_CLAMP && s < 0.0) s = 0.0;
    if (projection == DEFSIM_PROJECTION_ABS) s = fabs(s);
    for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j)
            Kb[3 * i + j] = k * ((1.0 - s) * n[i] * n[j] + (i == j ? s : 0.0));
}

#endif /* DEFSIM_ELEMENT_H */
