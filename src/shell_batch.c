/* SPDX-License-Identifier: MIT */
/*
 * The shells' batched (SIMD) force kernels (tet_forces.h's table; docs/shells.md), compiled once
 * per instruction set like the tet models' batched laws (CMake defines DEFSIM_ISA): the StVK and
 * neo-Hookean membranes and the hinges, lane-wise over the batches plan.c packs (per colour, so
 * that the lanes' scatters share no vertex). The formulas are shell.c's force paths, in the same
 * order of operations: the generic variant (no FMA) gives the scalar kernels' bits for StVK and
 * the hinges; the neo-Hookean membrane uses the vector log (within 1 ulp of libm), and the FMA
 * variants contract a*b+c, so those differ from the scalar kernels by rounding
 * (tests/unit/test_tet_forces.c: within 1e-12 relative). Collapsed neo-Hookean triangles
 * (det C <= 0, energy +inf) add no force, as in the scalar path. The hinge's atan2 is per lane.
 */
#include "shell.h"
#include "tet_batch.h"

#include <math.h>

/* F = sum_a x_a g_a^T (g_1, g_2 the rows of Dm^-1, g_0 = -(g_1 + g_2)) for sub-batch s. */
DEFSIM_SIMD_INLINE void triangle_f(const double *x, const int32_t *id, const double *d, int s,
                                   vd g[3][2], vd F[6])
{
    vd m[4];
    for (int r = 0; r < 4; ++r) m[r] = v_load(ROW(d, DEFSIM__SROW_DMINV + r, s));
    DEFSIM__TRI_SHAPE(m, g);
    vd p[3][3];
    for (int a = 0; a < 3; ++a) gather3(x, id + a * DEFSIM__BATCH + s * DEFSIM_VW, p[a]);
#define XA(a, i) p[a][i]
    DEFSIM__TRI_F(XA, g, F);
#undef XA
}

/* h_a = -A P g_a added to the first nl lanes' vertices. */
DEFSIM_SIMD_INLINE void triangle_scatter(double *f, const int32_t *id, const vd P[6],
                                         const vd g[3][2], vd narea, int nl)
{
    for (int a = 0; a < 3; ++a) {
        vd h[3];
        for (int i = 0; i < 3; ++i) h[i] = narea * (P[2 * i] * g[a][0] + P[2 * i + 1] * g[a][1]);
        double *rows[DEFSIM_VW];
        for (int l = 0; l < DEFSIM_VW; ++l) rows[l] = f + 3 * (int64_t)id[a * DEFSIM__BATCH + l];
        v_scatter_add_rows3(rows, h, nl);
    }
}

DEFSIM_SIMD_INLINE void f_times(const vd F[6], const vd M[4], vd out[6])
{
    DEFSIM__TRI_FTIMES(F, M, out);
}

DEFSIM_SIMD_INLINE void right_cauchy(const vd F[6], vd C[4])
{
    DEFSIM__TRI_CAUCHY(F, C);
}

/* StVK (isotropic and orthotropic): P = F S, S = C : E. Every lane has a force. */
DEFSIM_SIMD_INLINE vl stvk_p(const double *d, int s, const vd F[6], vd P[6])
{
    vd prm[4], C[4], E[4], S[4];
    for (int r = 0; r < 4; ++r) prm[r] = v_load(ROW(d, DEFSIM__SROW_P + r, s));
    right_cauchy(F, C);
    const vd one = v_set1(1.0), half = v_set1(0.5);
    E[0] = half * (C[0] - one);
    E[1] = E[2] = half * C[1];
    E[3] = half * (C[3] - one);
    S[0] = prm[0] * E[0] + prm[1] * E[3];
    S[3] = prm[1] * E[0] + prm[2] * E[3];
    S[1] = S[2] = v_set1(2.0) * prm[3] * E[1];
    f_times(F, S, P);
    return (vl)(one == one);
}

/* Neo-Hookean: P = mu F + (lambda log J - mu) F C^-1, log J = log(det C)/2; lanes with
 * det C <= 0 (collapsed) are cleared from the returned mask. */
DEFSIM_SIMD_INLINE vl neohookean_p(const double *d, int s, const vd F[6], vd P[6])
{
    const vd mu = v_load(ROW(d, DEFSIM__SROW_P, s)), la = v_load(ROW(d, DEFSIM__SROW_P + 1, s));
    vd C[4];
    right_cauchy(F, C);
    const vd detc = C[0] * C[3] - C[1] * C[2];
    const vl ok = detc > v_set1(0.0);
    const vd dc = v_select(ok, detc, v_set1(1.0));
    const vd lj = v_set1(0.5) * v_log(dc);
    const vd Ci[4] = {C[3] / dc, -C[1] / dc, -C[2] / dc, C[0] / dc};
    vd FC[6];
    f_times(F, Ci, FC);
    const vd c = la * lj - mu;
    for (int i = 0; i < 6; ++i) P[i] = mu * F[i] + c * FC[i];
    return ok;
}

/* A membrane kernel over its group's batches. */
#define MEMBRANE_KERNEL(name, LAW)                                                            \
    void DEFSIM__CAT(defsim__batched_membrane_##name##_, DEFSIM_ISA)(                         \
        const defsim__group *g, const double *x, double *f, int nthreads)                     \
    {                                                                                         \
        (void)nthreads;                                                                       \
        DEFSIM__BATCH_LOOP(g, {                                                               \
            vd gs[3][2], F[6], P[6];                                                          \
            triangle_f(x, id, d, s, gs, F);                                                   \
            const vl ok = LAW(d, s, F, P);                                                    \
            for (int i = 0; i < 6; ++i) P[i] = v_select(ok, P[i], v_set1(0.0));              \
            triangle_scatter(f, id + s * DEFSIM_VW, P, gs,                                    \
                             v_load(ROW(d, DEFSIM__SROW_NAREA, s)), nl);                      \
        })                                                                                    \
    }

MEMBRANE_KERNEL(stvk, stvk_p)
MEMBRANE_KERNEL(neohookean, neohookean_p)

/* ------------------------------------------------------------------------------------------ */
/* The hinges: shell.c's gradient of theta = atan2(y, x) over u = (e, a, b), lane-wise. */

DEFSIM_SIMD_INLINE vd dot3(const vd a[3], const vd b[3])
{
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}

DEFSIM_SIMD_INLINE void cross3(const vd a[3], const vd b[3], vd c[3])
{
    c[0] = a[1] * b[2] - a[2] * b[1];
    c[1] = a[2] * b[0] - a[0] * b[2];
    c[2] = a[0] * b[1] - a[1] * b[0];
}

/* The hinge's force h_A = -w delta dtheta/dx_A (A = 0 .. 3) for sub-batch s. */
DEFSIM_SIMD_INLINE void hinge_force(const double *x, const int32_t *id, const double *d, int s,
                                    vd h[4][3])
{
    vd X[4][3], e[3], a[3], b[3], axb[3], bxe[3], exa[3];
    for (int A = 0; A < 4; ++A) gather3(x, id + A * DEFSIM__BATCH + s * DEFSIM_VW, X[A]);
    for (int i = 0; i < 3; ++i) {
        e[i] = X[1][i] - X[0][i];
        a[i] = X[2][i] - X[0][i];
        b[i] = X[3][i] - X[0][i];
    }
    cross3(a, b, axb);
    cross3(b, e, bxe);
    cross3(e, a, exa);
    const vd sq = dot3(e, e), L = v_sqrt(sq), tau = dot3(e, axb);
    const vd p = dot3(e, a), q = dot3(e, b), r = dot3(a, b);
    const vd y = -L * tau, xx = p * q - sq * r;
    /* theta and delta = theta - theta0 wrapped into (-pi, pi], per lane */
    const vd th0 = v_load(ROW(d, DEFSIM__SROW_THETA0, s));
    vd delta;
    const double pi = 3.14159265358979323846;
    for (int l = 0; l < DEFSIM_VW; ++l) {
        double dl = atan2(y[l], xx[l]) - th0[l];
        if (dl > pi) dl -= 2.0 * pi;
        else if (dl <= -pi) dl += 2.0 * pi;
        delta[l] = dl;
    }
    /* the gradients of y and x over e, a, b (shell.c's, without its zero terms) */
    vd gy[3][3], gx[3][3];
    const vd two = v_set1(2.0);
    for (int i = 0; i < 3; ++i) {
        gy[0][i] = -(tau * (e[i] / L) + L * axb[i]);
        gy[1][i] = -(L * bxe[i]);
        gy[2][i] = -(L * exa[i]);
        gx[0][i] = q * a[i] + p * b[i] - r * (two * e[i]);
        gx[1][i] = q * e[i] - sq * b[i];
        gx[2][i] = p * e[i] - sq * a[i];
    }
    const vd r2 = xx * xx + y * y;
    const vd nwd = -(v_load(ROW(d, DEFSIM__SROW_W, s)) * delta);
    vd gth[3][3];
    for (int u = 0; u < 3; ++u)
        for (int i = 0; i < 3; ++i) gth[u][i] = (xx * gy[u][i] - y * gx[u][i]) / r2;
    for (int i = 0; i < 3; ++i) {
        h[1][i] = nwd * gth[0][i];
        h[2][i] = nwd * gth[1][i];
        h[3][i] = nwd * gth[2][i];
        h[0][i] = nwd * -(gth[0][i] + gth[1][i] + gth[2][i]);
    }
}

void DEFSIM__CAT(defsim__batched_hinge_, DEFSIM_ISA)(const defsim__group *g, const double *x,
                                                    double *f, int nthreads)
{
    (void)nthreads;
    DEFSIM__BATCH_LOOP(g, {
        vd h[4][3];
        hinge_force(x, id, d, s, h);
        const int32_t *ids = id + s * DEFSIM_VW;
        for (int A = 0; A < 4; ++A) {
            double *rows[DEFSIM_VW];
            for (int l = 0; l < DEFSIM_VW; ++l)
                rows[l] = f + 3 * (int64_t)ids[A * DEFSIM__BATCH + l];
            v_scatter_add_rows3(rows, h[A], nl);
        }
    })
}
