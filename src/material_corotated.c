/* SPDX-License-Identifier: MIT */
/*
 * Co-rotated linear: F = R S from the signed SVD, psi = mu |S - I|^2 + lambda/2 tr(S - I)^2.
 * The scalar law and its table (material.h); compiled again per instruction set (DEFSIM_ISA
 * defined, tet_batch.h) for the batched SIMD law. Conventions: DESIGN.md section 4.
 */
#if !defined(DEFSIM_ISA)

#include "material.h"

#include "element.h"
#include "isotropic.h"
#include "mat3.h"

#include <math.h>

/* Co-rotated linear: F = R S from the signed SVD, psi = mu |S - I|^2 + lambda/2 tr(S - I)^2     */
/* = mu sum (s_i - 1)^2 + lambda/2 (sum s_i - 3)^2.                                            */

static double corotated_psi_sigma(double mu, double lambda, const double s[3])
{
    double d0 = s[0] - 1.0, d1 = s[1] - 1.0, d2 = s[2] - 1.0;
    double tr = d0 + d1 + d2;
    return mu * (d0 * d0 + d1 * d1 + d2 * d2) + 0.5 * lambda * tr * tr;
}

static double corotated_psi(double mu, double lambda, const double F[9])
{
    double U[9], s[3], V[9];
    defsim__svd3(F, U, s, V);
    return corotated_psi_sigma(mu, lambda, s);
}

/* P = R (2 mu (S - I) + lambda tr(S - I) I) = 2 mu (F - R) + lambda tr(S - I) R. */
static double corotated_P(double mu, double lambda, const double F[9], double P[9])
{
    double U[9], s[3], V[9], R[9];
    defsim__svd3(F, U, s, V);
    defsim__m3_mul_nt(U, V, R);
    double tr = s[0] + s[1] + s[2] - 3.0;
    for (int i = 0; i < 9; ++i) P[i] = 2.0 * mu * (F[i] - R[i]) + lambda * tr * R[i];
    return corotated_psi_sigma(mu, lambda, s);
}

DEFSIM__TET_FORCE_KERNEL(forces_corotated, corotated_P)

static void corotated_dPdF(double mu, double lambda, const double F[9], double dPdF[81])
{
    double U[9], s[3], V[9];
    defsim__svd3(F, U, s, V);
    double tr = s[0] + s[1] + s[2] - 3.0;
    double g[3], h[9], ev_sym[3], ev_skew[3];
    for (int a = 0; a < 3; ++a) {
        g[a] = 2.0 * mu * (s[a] - 1.0) + lambda * tr;
        for (int b = 0; b < 3; ++b) h[3 * a + b] = lambda + (a == b ? 2.0 * mu : 0.0);
    }
    static const int pa[3] = {0, 0, 1}, pb[3] = {1, 2, 2};
    for (int p = 0; p < 3; ++p) {
        /* (g_a - g_b)/(s_a - s_b) = 2 mu exactly. */
        ev_sym[p] = 2.0 * mu;
        ev_skew[p] = (g[pa[p]] + g[pb[p]]) / defsim__safe_sum(s[pa[p]], s[pb[p]]);
    }
    defsim__isotropic_dPdF(U, V, h, ev_sym, ev_skew, dPdF);
}

static void corotated_sigma(double mu, double lambda, const double s[3], double h[9],
                            double ev_sym[3], double ev_skew[3])
{
    static const int pa[3] = {0, 0, 1}, pb[3] = {1, 2, 2};
    double tr = s[0] + s[1] + s[2] - 3.0, g[3];
    for (int a = 0; a < 3; ++a) {
        g[a] = 2.0 * mu * (s[a] - 1.0) + lambda * tr;
        for (int b = 0; b < 3; ++b) h[3 * a + b] = lambda + (a == b ? 2.0 * mu : 0.0);
    }
    for (int p = 0; p < 3; ++p) {
        ev_sym[p] = 2.0 * mu;
        ev_skew[p] = (g[pa[p]] + g[pb[p]]) / defsim__safe_sum(s[pa[p]], s[pb[p]]);
    }
}

const defsim__model defsim__model_corotated = {
    .name = "corotated", .id = DEFSIM_MODEL_COROTATED, .pass = DEFSIM_PASS_COROTATED,
    .params = defsim__lame_params, .psi = corotated_psi, .P = corotated_P, .dPdF = corotated_dPdF,
    .sigma = corotated_sigma, .forces = forces_corotated};

#else /* DEFSIM_ISA: the batched law */

#include "tet_batch.h"

enum { ROT_MAX_SQUARINGS = 48 };

/*
 * Rotation of the co-rotated model without an SVD. The rotation R of SO(3) closest to F, the
 * one maximising tr(R^T F), is R = U V^T of the signed SVD (DESIGN.md section 4). With R = R(q)
 * for a unit quaternion q = (w, x, y, z), tr(R^T F) = q^T N q for the symmetric traceless 4x4
 * matrix N below (Horn 1987; Davenport's q-method), so q is N's top eigenvector. In signed
 * singular values s0 >= s1 >= |s2|, N has eigenvalues s0+s1+s2 (top), s0-s1-s2, s1-s0-s2 and
 * s2-s0-s1: the top one is simple unless s1 + s2 = 0, exactly where R is not unique.
 *
 * M = N + c I with c = |F| / sqrt(3) >= -s2 makes the top eigenvalue the largest in magnitude,
 * and repeated squaring (M <- M^2 / tr M^2) drives M to the projector q q^T, squaring the
 * eigenvalue ratio each time. At F = I, M is already that projector; far from degenerate, a
 * handful of squarings suffice. A lane stops one squaring after its defect 1 - |M|_F^2 (for
 * trace 1 and PSD M, about twice the sub-dominant weight) falls below 1e-10, leaving ~1e-21;
 * lanes are frozen independently, so a lane's result never depends on its batch neighbours.
 * Near s1 + s2 = 0 (rotation not unique) the squaring count hits its cap and q is some unit
 * vector of the near-degenerate eigenspace: a maximiser of tr(R^T F) to rounding, possibly not
 * the one the SVD picks. F = 0 gives R = I, as the SVD path does.
 */
enum { S_WW, S_WX, S_WY, S_WZ, S_XX, S_XY, S_XZ, S_YY, S_YZ, S_ZZ };
static const int sym4[4][4] = {{0, 1, 2, 3}, {1, 4, 5, 6}, {2, 5, 7, 8}, {3, 6, 8, 9}};

DEFSIM_SIMD_INLINE void batch_rotation(const vd F[9], vd R[9])
{
    vd fn2 = F[0] * F[0];
    for (int i = 1; i < 9; ++i) fn2 += F[i] * F[i];
    const vd c = v_sqrt(fn2) * 0.57735026918962576451;
    vd M[10];
    M[S_WW] = F[0] + F[4] + F[8] + c;
    M[S_XX] = F[0] - F[4] - F[8] + c;
    M[S_YY] = F[4] - F[0] - F[8] + c;
    M[S_ZZ] = F[8] - F[0] - F[4] + c;
    M[S_WX] = F[7] - F[5];
    M[S_WY] = F[2] - F[6];
    M[S_WZ] = F[3] - F[1];
    M[S_XY] = F[1] + F[3];
    M[S_XZ] = F[2] + F[6];
    M[S_YZ] = F[5] + F[7];
    /* Trace 1 (tr M = 4c), so squares neither overflow nor underflow. */
    const vd inv = 0.25 / c;
    for (int k = 0; k < 10; ++k) M[k] *= inv;
    const vl zero = ~(c > 0.0);   /* F = 0 (or NaN): start from q = (1, 0, 0, 0) */
    if (v_any(zero))
        for (int k = 0; k < 10; ++k) M[k] = v_select(zero, v_set1(k == S_WW ? 1.0 : 0.0), M[k]);

    vl active = (vl){0} - 1, conv = (vl){0};
    for (int it = 0; it < ROT_MAX_SQUARINGS; ++it) {
        vd S[10];
        for (int i = 0; i < 4; ++i)
            for (int j = i; j < 4; ++j)
                S[sym4[i][j]] = M[sym4[i][0]] * M[sym4[0][j]] + M[sym4[i][1]] * M[sym4[1][j]] +
                                M[sym4[i][2]] * M[sym4[2][j]] + M[sym4[i][3]] * M[sym4[3][j]];
        const vd t = 1.0 / (S[S_WW] + S[S_XX] + S[S_YY] + S[S_ZZ]);
        for (int k = 0; k < 10; ++k) M[k] = v_select(active, S[k] * t, M[k]);
        active &= ~conv;   /* converged lanes have had their extra squaring */
        if (!v_any(active)) break;
        const vd fro = M[S_WW] * M[S_WW] + M[S_XX] * M[S_XX] + M[S_YY] * M[S_YY] +
                       M[S_ZZ] * M[S_ZZ] +
                       2.0 * (M[S_WX] * M[S_WX] + M[S_WY] * M[S_WY] + M[S_WZ] * M[S_WZ] +
                              M[S_XY] * M[S_XY] + M[S_XZ] * M[S_XZ] + M[S_YZ] * M[S_YZ]);
        conv = (1.0 - fro) < 1e-10;
    }

    /* q: the column of the largest diagonal entry (its weight in q q^T is >= 1/4). */
    vd q[4], dmax = M[S_WW];
    for (int i = 0; i < 4; ++i) q[i] = M[sym4[i][0]];
    for (int j = 1; j < 4; ++j) {
        const vd dj = M[sym4[j][j]];
        const vl m = dj > dmax;
        dmax = v_select(m, dj, dmax);
        for (int i = 0; i < 4; ++i) q[i] = v_select(m, M[sym4[i][j]], q[i]);
    }
    /* R(q) of the not yet normalised q: divide the quadratic terms by |q|^2. */
    const vd w = q[0], x = q[1], y = q[2], z = q[3];
    const vd s2 = 2.0 / (w * w + x * x + y * y + z * z);
    R[0] = 1.0 - s2 * (y * y + z * z);
    R[1] = s2 * (x * y - w * z);
    R[2] = s2 * (x * z + w * y);
    R[3] = s2 * (x * y + w * z);
    R[4] = 1.0 - s2 * (x * x + z * z);
    R[5] = s2 * (y * z - w * x);
    R[6] = s2 * (x * z - w * y);
    R[7] = s2 * (y * z + w * x);
    R[8] = 1.0 - s2 * (x * x + y * y);
}

/* Co-rotated: P = 2 mu (F - R) + lambda tr(R^T F - I) R, with tr(R^T F) = s0 + s1 + s2. */
DEFSIM_SIMD_INLINE void law_corotated(const double *d, int s, const vd F[9], vd P[9])
{
    const vd mu = v_load(ROW(d, DEFSIM__ROW_P0, s)), la = v_load(ROW(d, DEFSIM__ROW_P1, s));
    vd R[9];
    batch_rotation(F, R);
    vd tr = R[0] * F[0];
    for (int i = 1; i < 9; ++i) tr += R[i] * F[i];
    const vd mu2 = 2.0 * mu, lt = la * (tr - 3.0);
    for (int i = 0; i < 9; ++i) P[i] = mu2 * (F[i] - R[i]) + lt * R[i];
}

/* psi = mu |S - I|^2 + lambda/2 tr(S - I)^2 with S = R^T F: |S - I|^2 = |F - R|^2 (R is a
 * rotation), tr S = tr(R^T F). */
DEFSIM_SIMD_INLINE vd psi_corotated(const double *d, int s, const vd F[9])
{
    const vd mu = v_load(ROW(d, DEFSIM__ROW_P0, s)), la = v_load(ROW(d, DEFSIM__ROW_P1, s));
    vd R[9];
    batch_rotation(F, R);
    vd tr = R[0] * F[0], dd = (F[0] - R[0]) * (F[0] - R[0]);
    for (int i = 1; i < 9; ++i) {
        tr += R[i] * F[i];
        dd += (F[i] - R[i]) * (F[i] - R[i]);
    }
    const vd t = tr - 3.0;
    return mu * dd + 0.5 * la * t * t;
}

DEFSIM__BATCHED_KERNEL(corotated, law_corotated)
DEFSIM__BATCHED_QKERNEL(corotated, law_corotated)
DEFSIM__BATCHED_QENERGY(corotated, psi_corotated)

/* Rotations of n row-major matrices, VW at a time (the tail padded with F = I). */
void DEFSIM__CAT(defsim__rotations_, DEFSIM_ISA)(int32_t n, const double *F, double *R)
{
    for (int32_t e0 = 0; e0 < n; e0 += DEFSIM_VW) {
        vd Fv[9], Rv[9];
        for (int i = 0; i < 9; ++i) {
            Fv[i] = v_set1(0.0);
            for (int l = 0; l < DEFSIM_VW; ++l)
                Fv[i][l] = e0 + l < n ? F[9 * (int64_t)(e0 + l) + i] : (i % 4 == 0 ? 1.0 : 0.0);
        }
        batch_rotation(Fv, Rv);
        for (int i = 0; i < 9; ++i)
            for (int l = 0; l < DEFSIM_VW && e0 + l < n; ++l) R[9 * (int64_t)(e0 + l) + i] = Rv[i][l];
    }
}

#endif
