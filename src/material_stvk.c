/* SPDX-License-Identifier: MIT */
/*
 * Saint Venant-Kirchhoff: E = (F^T F - I)/2, psi = mu E:E + lambda/2 tr(E)^2.
 * The scalar law and its table (material.h); compiled again per instruction set (DEFSIM_ISA
 * defined, tet_batch.h) for the batched SIMD law. Conventions: DESIGN.md section 4.
 */
#if !defined(DEFSIM_ISA)

#include "material.h"

#include "element.h"
#include "mat3.h"

#include <math.h>

/* Second Piola-Kirchhoff stress S = 2 mu E + lambda tr(E) I; returns psi. */
static double stvk_S(double mu, double lambda, const double F[9], double S[9])
{
    double E[9];
    defsim__m3_mul_tn(F, F, E);
    for (int i = 0; i < 9; ++i) E[i] *= 0.5;
    E[0] -= 0.5;
    E[4] -= 0.5;
    E[8] -= 0.5;
    double tr = E[0] + E[4] + E[8];
    for (int i = 0; i < 9; ++i) S[i] = 2.0 * mu * E[i];
    S[0] += lambda * tr;
    S[4] += lambda * tr;
    S[8] += lambda * tr;
    return mu * defsim__m3_ddot(E, E) + 0.5 * lambda * tr * tr;
}

static double stvk_psi(double mu, double lambda, const double F[9])
{
    double S[9];
    return stvk_S(mu, lambda, F, S);
}

/* P = F S. */
static double stvk_P(double mu, double lambda, const double F[9], double P[9])
{
    double S[9];
    double psi = stvk_S(mu, lambda, F, S);
    defsim__m3_mul(F, S, P);
    return psi;
}

DEFSIM__TET_FORCE_KERNEL(forces_stvk, stvk_P)

/* dP_ij/dF_kl = delta_ik S_lj + mu F_il F_kj + mu (F F^T)_ik delta_jl + lambda F_ij F_kl. */
static void stvk_dPdF(double mu, double lambda, const double F[9], double dPdF[81])
{
    double S[9], B[9];
    stvk_S(mu, lambda, F, S);
    defsim__m3_mul_nt(F, F, B);
    for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j)
            for (int k = 0; k < 3; ++k)
                for (int l = 0; l < 3; ++l) {
                    double h = mu * F[3 * i + l] * F[3 * k + j] + lambda * F[3 * i + j] * F[3 * k + l];
                    if (i == k) h += S[3 * l + j];
                    if (j == l) h += mu * B[3 * i + k];
                    dPdF[9 * (3 * i + j) + 3 * k + l] = h;
                }
}

static void stvk_sigma(double mu, double lambda, const double s[3], double h[9],
                       double ev_sym[3],
                       double ev_skew[3])
{
    static const int pa[3] = {0, 0, 1}, pb[3] = {1, 2, 2};
    double tr = 0.5 * (s[0] * s[0] + s[1] * s[1] + s[2] * s[2] - 3.0);
    for (int a = 0; a < 3; ++a)
        for (int b = 0; b < 3; ++b)
            h[3 * a + b] = lambda * s[a] * s[b] +
                           (a == b ? mu * (3.0 * s[a] * s[a] - 1.0) + lambda * tr : 0.0);
    for (int p = 0; p < 3; ++p) {
        double x = s[pa[p]], y = s[pb[p]];
        ev_sym[p] = mu * (x * x + x * y + y * y - 1.0) + lambda * tr;
        ev_skew[p] = mu * (x * x - x * y + y * y - 1.0) + lambda * tr;
    }
}

const defsim__model defsim__model_stvk = {
    .name = "stvk", .id = DEFSIM_MODEL_STVK, .pass = DEFSIM_PASS_STVK,
    .params = defsim__lame_params, .psi = stvk_psi, .P = stvk_P, .dPdF = stvk_dPdF,
    .sigma = stvk_sigma, .forces = forces_stvk};

#else /* DEFSIM_ISA: the batched law */

#include "tet_batch.h"

/* E = (F^T F - I)/2. */
DEFSIM_SIMD_INLINE void green_strain(const vd F[9], vd E[9])
{
    for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j)
            E[3 * i + j] = 0.5 * DEFSIM__M3_MUL_TN(F, F, i, j);
    E[0] -= 0.5;
    E[4] -= 0.5;
    E[8] -= 0.5;
}

/* StVK: E = (F^T F - I)/2, S = 2 mu E + lambda tr(E) I, P = F S. */
DEFSIM_SIMD_INLINE void law_stvk(const double *d, int s, const vd F[9], vd P[9])
{
    const vd mu = v_load(ROW(d, DEFSIM__ROW_P0, s)), la = v_load(ROW(d, DEFSIM__ROW_P1, s));
    vd E[9], S[9];
    green_strain(F, E);
    const vd tr = E[0] + E[4] + E[8], mu2 = 2.0 * mu;
    for (int i = 0; i < 9; ++i) S[i] = mu2 * E[i];
    S[0] += la * tr;
    S[4] += la * tr;
    S[8] += la * tr;
    for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j)
            P[3 * i + j] = DEFSIM__M3_MUL(F, S, i, j);
}

/* psi = mu E:E + lambda/2 tr(E)^2. */
DEFSIM_SIMD_INLINE vd psi_stvk(const double *d, int s, const vd F[9])
{
    const vd mu = v_load(ROW(d, DEFSIM__ROW_P0, s)), la = v_load(ROW(d, DEFSIM__ROW_P1, s));
    vd E[9];
    green_strain(F, E);
    const vd tr = E[0] + E[4] + E[8];
    return mu * frob2(E) + 0.5 * la * tr * tr;
}

DEFSIM__BATCHED_KERNEL(stvk, law_stvk)
DEFSIM__BATCHED_QKERNEL(stvk, law_stvk)
DEFSIM__BATCHED_QENERGY(stvk, psi_stvk)

#endif
