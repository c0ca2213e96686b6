/* SPDX-License-Identifier: MIT */
/*
 * Batched elastic force kernels: one per tet model, vectorised across the elements of a batch
 * (tet_forces.h). This file is compiled once per instruction set; CMake defines DEFSIM_ISA
 * (generic, avx2, avx512) and the matching -m flags, and system.c picks a variant at plan time.
 *
 * The physics is that of material_models.h, rewritten lane-wise: same formulas, same
 * conventions (DESIGN.md section 4). Results differ from the scalar kernels only by rounding:
 * the vector log is fdlibm's algorithm (within 1 ulp of libm), and the FMA-capable variants
 * contract a*b+c (-ffp-contract=fast), so machines with different instruction sets differ in
 * the last bits. On one machine a variant is deterministic, whatever the thread count: every
 * lane's arithmetic depends on its own element only, and the scatter order is the colour order.
 */
#include "tet_forces.h"

#include "simd.h"

#include <stddef.h>
#include <string.h>

#ifndef DEFSIM_ISA
#define DEFSIM_ISA generic
#endif
#define DEFSIM__CAT2(a, b) a##b
#define DEFSIM__CAT(a, b) DEFSIM__CAT2(a, b)
#define DEFSIM__STR2(a) #a
#define DEFSIM__STR(a) DEFSIM__STR2(a)

enum {
    NSUB = DEFSIM__BATCH / DEFSIM_VW,          /* vectors per batch */
    PAR_MIN_BATCHES = 1024 / DEFSIM__BATCH,    /* same threshold as the scalar kernels */
    ROT_MAX_SQUARINGS = 48
};

/* Row r of a batch's data block d, lanes of sub-batch s. */
#define ROW(d, r, s) ((d) + (r) * DEFSIM__BATCH + (s) * DEFSIM_VW)

/* ------------------------------------------------------------------------------------------ */
/* Shared batch machinery: gather, F = Ds Dm^-1, forces h_a = -vol P g_a, scatter.             */

/* The three coordinates of the lanes' vertices id[0 .. VW-1] (on Zen 4, row loads and
 * transposes measured faster than hardware gathers). */
DEFSIM_SIMD_INLINE void gather3(const double *x, const int32_t *id, vd p[3])
{
    const double *rows[DEFSIM_VW];
    for (int l = 0; l < DEFSIM_VW; ++l) rows[l] = x + 3 * (int64_t)id[l];
    v_gather_rows3(rows, p);
}

/* F = Ds Dm^-1 with Ds = [x0 - x3, x1 - x3, x2 - x3] for the lanes of sub-batch s. */
DEFSIM_SIMD_INLINE void batch_deformation(const double *x, const int32_t *id, const double *d,
                                          int s, vd dm[9], vd F[9])
{
    for (int r = 0; r < 9; ++r) dm[r] = v_load(ROW(d, DEFSIM__ROW_DMINV + r, s));
    vd p[4][3], ds[9];
    for (int a = 0; a < 4; ++a) gather3(x, id + a * DEFSIM__BATCH + s * DEFSIM_VW, p[a]);
    for (int i = 0; i < 3; ++i)
        for (int a = 0; a < 3; ++a) ds[3 * i + a] = p[a][i] - p[3][i];
    for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j)
            F[3 * i + j] = ds[3 * i + 0] * dm[0 + j] + ds[3 * i + 1] * dm[3 + j] +
                           ds[3 * i + 2] * dm[6 + j];
}

/* h_a[i] = -vol sum_j P_ij Dminv[a][j], h_3 = -(h_0 + h_1 + h_2), added to the forces of the
 * first nl lanes. Elements of a colour share no vertex, so neither do lanes. */
DEFSIM_SIMD_INLINE void batch_scatter(double *f, const int32_t *id, const vd P[9],
                                      const vd dm[9], vd nvol, int nl)
{
    vd h[4][3];
    for (int a = 0; a < 3; ++a)
        for (int i = 0; i < 3; ++i)
            h[a][i] = nvol * (P[3 * i + 0] * dm[3 * a + 0] + P[3 * i + 1] * dm[3 * a + 1] +
                              P[3 * i + 2] * dm[3 * a + 2]);
    for (int i = 0; i < 3; ++i) h[3][i] = -(h[0][i] + h[1][i] + h[2][i]);
    for (int a = 0; a < 4; ++a) {
        double *rows[DEFSIM_VW];
        for (int l = 0; l < DEFSIM_VW; ++l) rows[l] = f + 3 * (int64_t)id[a * DEFSIM__BATCH + l];
        v_scatter_add_rows3(rows, h[a], nl);
    }
}

/* One kernel per model: LAW(d, s, F, P) computes P for the lanes of sub-batch s. */
#define TET_FORCE_KERNEL(NAME, LAW)                                                           \
    static void NAME(const defsim__group *g, const double *x, double *f, int nthreads)       \
    {                                                                                         \
        (void)nthreads;                                                                       \
        for (int32_t c = 0; c < g->ncolors; ++c) {                                            \
            const int32_t b0 = g->bcolor_ptr[c], b1 = g->bcolor_ptr[c + 1];                   \
            _Pragma("omp parallel for schedule(static) num_threads(nthreads) if(b1 - b0 > PAR_MIN_BATCHES)") \
            for (int32_t b = b0; b < b1; ++b) {                                               \
                const int32_t *id = g->bidx + 4 * DEFSIM__BATCH * (int64_t)b;                 \
                const double *d = g->bdata + DEFSIM__BATCH_ROWS * DEFSIM__BATCH * (int64_t)b; \
                for (int s = 0; s < NSUB && s * DEFSIM_VW < g->blanes[b]; ++s) {              \
                    vd dm[9], F[9], P[9];                                                     \
                    batch_deformation(x, id, d, s, dm, F);                                    \
                    LAW(d, s, F, P);                                                          \
                    batch_scatter(f, id + s * DEFSIM_VW, P, dm,                               \
                                  v_load(ROW(d, DEFSIM__ROW_NVOL, s)),                        \
                                  g->blanes[b] - s * DEFSIM_VW);                              \
                }                                                                             \
            }                                                                                 \
        }                                                                                     \
    }

/* ------------------------------------------------------------------------------------------ */
/* Constitutive laws, lane-wise (formulas: material_models.h).                                */

DEFSIM_SIMD_INLINE void cofactor(const vd A[9], vd C[9])
{
    C[0] = A[4] * A[8] - A[5] * A[7];
    C[1] = A[5] * A[6] - A[3] * A[8];
    C[2] = A[3] * A[7] - A[4] * A[6];
    C[3] = A[2] * A[7] - A[1] * A[8];
    C[4] = A[0] * A[8] - A[2] * A[6];
    C[5] = A[1] * A[6] - A[0] * A[7];
    C[6] = A[1] * A[5] - A[2] * A[4];
    C[7] = A[2] * A[3] - A[0] * A[5];
    C[8] = A[0] * A[4] - A[1] * A[3];
}

/* StVK: E = (F^T F - I)/2, S = 2 mu E + lambda tr(E) I, P = F S. */
DEFSIM_SIMD_INLINE void law_stvk(const double *d, int s, const vd F[9], vd P[9])
{
    const vd mu = v_load(ROW(d, DEFSIM__ROW_P0, s)), la = v_load(ROW(d, DEFSIM__ROW_P1, s));
    vd E[9], S[9];
    for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j)
            E[3 * i + j] = 0.5 * (F[i] * F[j] + F[3 + i] * F[3 + j] + F[6 + i] * F[6 + j]);
    E[0] -= 0.5;
    E[4] -= 0.5;
    E[8] -= 0.5;
    const vd tr = E[0] + E[4] + E[8], mu2 = 2.0 * mu;
    for (int i = 0; i < 9; ++i) S[i] = mu2 * E[i];
    S[0] += la * tr;
    S[4] += la * tr;
    S[8] += la * tr;
    for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j)
            P[3 * i + j] = F[3 * i] * S[j] + F[3 * i + 1] * S[3 + j] + F[3 * i + 2] * S[6 + j];
}

/* Neo-Hookean: P = mu F + (lambda log J - mu)/J cof F; NaN where J <= 0 (as the scalar law). */
DEFSIM_SIMD_INLINE void law_neohookean(const double *d, int s, const vd F[9], vd P[9])
{
    const vd mu = v_load(ROW(d, DEFSIM__ROW_P0, s)), la = v_load(ROW(d, DEFSIM__ROW_P1, s));
    vd C[9];
    cofactor(F, C);
    const vd J = F[0] * C[0] + F[1] * C[1] + F[2] * C[2];
    const vd c = (la * v_log(J) - mu) / J;
    for (int i = 0; i < 9; ++i) P[i] = mu * F[i] + c * C[i];
    const vl bad = ~(J > 0.0);
    if (v_any(bad))
        for (int i = 0; i < 9; ++i) P[i] = v_select(bad, v_set1(NAN), P[i]);
}

/* Stable neo-Hookean: P = mu' (1 - 1/(I_C + 1)) F + lambda' (J - alpha) cof F. */
DEFSIM_SIMD_INLINE void law_snh(const double *d, int s, const vd F[9], vd P[9])
{
    const vd mp = v_load(ROW(d, DEFSIM__ROW_P0, s)), lp = v_load(ROW(d, DEFSIM__ROW_P1, s));
    const vd alpha = v_load(ROW(d, DEFSIM__ROW_P2, s));
    vd C[9];
    cofactor(F, C);
    vd ic = F[0] * F[0];
    for (int i = 1; i < 9; ++i) ic += F[i] * F[i];
    const vd c1 = mp * (1.0 - 1.0 / (ic + 1.0));
    const vd c2 = lp * (F[0] * C[0] + F[1] * C[1] + F[2] * C[2] - alpha);
    for (int i = 0; i < 9; ++i) P[i] = c1 * F[i] + c2 * C[i];
}

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

TET_FORCE_KERNEL(forces_stvk, law_stvk)
TET_FORCE_KERNEL(forces_corotated, law_corotated)
TET_FORCE_KERNEL(forces_neohookean, law_neohookean)
TET_FORCE_KERNEL(forces_snh, law_snh)

/* Rotations of n row-major matrices, VW at a time (the tail padded with F = I). */
static void rotations(int32_t n, const double *F, double *R)
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

const defsim__tet_kernels DEFSIM__CAT(defsim__tet_kernels_, DEFSIM_ISA) = {
    .name = DEFSIM__STR(DEFSIM_ISA),
    .forces = {forces_stvk, forces_corotated, forces_neohookean, forces_snh},
    .rotation = rotations,
};
