/* SPDX-License-Identifier: MIT */
/*
 * Neo-Hookean: psi = mu/2 (tr(F^T F) - 3) - mu log J + lambda/2 (log J)^2, J = det F.
 * The scalar law and its table (material.h); compiled again per instruction set (DEFSIM_ISA
 * defined, tet_batch.h) for the batched SIMD law. Conventions: DESIGN.md section 4.
 */
#if !defined(DEFSIM_ISA)

#include "material.h"

#include "element.h"
#include "mat3.h"

#include <math.h>

/* Neo-Hookean: psi = mu/2 (tr(F^T F) - 3) - mu log J + lambda/2 (log J)^2, J = det F.          */
/* Undefined for J <= 0: psi is +INFINITY and P, dPdF are filled with NAN there.               */

static double neohookean_psi(double mu, double lambda, const double F[9])
{
    double J = defsim__m3_det(F);
    if (!(J > 0.0)) return INFINITY;
    double lj = log(J);
    return 0.5 * mu * (defsim__m3_ddot(F, F) - 3.0) - mu * lj + 0.5 * lambda * lj * lj;
}

/* G = cof F; returns J = det F from it. */
static double cofactor_det(const double F[9], double G[9])
{
    defsim__m3_cofactor(F, G);
    return DEFSIM__M3_DET_COF(F, G);
}

/* P = mu (F - F^-T) + lambda log J F^-T. */
static double neohookean_P(double mu, double lambda, const double F[9], double P[9])
{
    double G[9];
    const double J = cofactor_det(F, G);
    if (!(J > 0.0)) {
        for (int i = 0; i < 9; ++i) P[i] = NAN;
        return INFINITY;
    }
    double lj = log(J);
    double c = (lambda * lj - mu) / J; /* G = cof F = J F^-T */
    for (int i = 0; i < 9; ++i) P[i] = mu * F[i] + c * G[i];
    return 0.5 * mu * (defsim__m3_ddot(F, F) - 3.0) - mu * lj + 0.5 * lambda * lj * lj;
}

DEFSIM__TET_FORCE_KERNEL(forces_neohookean, neohookean_P)

/* With G = F^-T: dP_ij/dF_kl = mu d_ik d_jl + (mu - lambda log J) G_il G_kj + lambda G_ij G_kl. */
static void neohookean_dPdF(double mu, double lambda, const double F[9], double dPdF[81])
{
    double G[9];
    const double J = cofactor_det(F, G);
    if (!(J > 0.0)) {
        for (int i = 0; i < 81; ++i) dPdF[i] = NAN;
        return;
    }
    for (int i = 0; i < 9; ++i) G[i] /= J;
    double c = mu - lambda * log(J);
    for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j)
            for (int k = 0; k < 3; ++k)
                for (int l = 0; l < 3; ++l) {
                    double h = c * G[3 * i + l] * G[3 * k + j] + lambda * G[3 * i + j] * G[3 * k + l];
                    if (i == k && j == l) h += mu;
                    dPdF[9 * (3 * i + j) + 3 * k + l] = h;
                }
}

static void neohookean_sigma(double mu, double lambda, const double s[3], double h[9],
                             double ev_sym[3], double ev_skew[3])
{
    static const int pa[3] = {0, 0, 1}, pb[3] = {1, 2, 2};
    if (!(s[0] > 0.0 && s[1] > 0.0 && s[2] > 0.0)) {
        for (int i = 0; i < 9; ++i) h[i] = NAN;
        for (int p = 0; p < 3; ++p) ev_sym[p] = ev_skew[p] = NAN;
        return;
    }
    double c = mu - lambda * log(s[0] * s[1] * s[2]);
    for (int a = 0; a < 3; ++a)
        for (int b = 0; b < 3; ++b)
            h[3 * a + b] = lambda / (s[a] * s[b]) + (a == b ? mu + c / (s[a] * s[a]) : 0.0);
    for (int p = 0; p < 3; ++p) {
        double q = s[pa[p]] * s[pb[p]];
        ev_sym[p] = mu + c / q;
        ev_skew[p] = mu - c / q;
    }
}

/* The split (material.h): psi_iso = mu/2 (tr(F^T F) - 3) - mu log J is the law with lambda = 0,
 * U(J) = lambda/2 (log J)^2, U' = lambda log J / J, U'' = lambda (1 - log J) / J^2. */
static double iso_P(double mu, double lambda, const double F[9], double P[9])
{
    (void)lambda;
    return neohookean_P(mu, 0.0, F, P);
}

static void iso_dPdF(double mu, double lambda, const double F[9], double dPdF[81])
{
    (void)lambda;
    neohookean_dPdF(mu, 0.0, F, dPdF);
}

static void volumetric(double mu, double lambda, double J, double u[3])
{
    (void)mu;
    if (!(J > 0.0)) {
        u[0] = J == J ? INFINITY : NAN;
        u[1] = u[2] = NAN;
        return;
    }
    const double lj = log(J);
    u[0] = 0.5 * lambda * lj * lj;
    u[1] = lambda * lj / J;
    u[2] = lambda * (1.0 - lj) / (J * J);
}

static const defsim__model_split split = {.P = iso_P, .dPdF = iso_dPdF, .U = volumetric};

const defsim__model defsim__model_neohookean = {
    .name = "neohookean", .id = DEFSIM_MODEL_NEOHOOKEAN, .pass = DEFSIM_PASS_NEOHOOKEAN,
    .needs_positive_det = 1, .params = defsim__lame_params, .psi = neohookean_psi,
    .P = neohookean_P, .dPdF = neohookean_dPdF, .sigma = neohookean_sigma,
    .forces = forces_neohookean, .split = &split};

#else /* DEFSIM_ISA: the batched law */

#include "tet_batch.h"

/* Neo-Hookean: P = mu F + (lambda log J - mu)/J cof F; NaN where J <= 0 (as the scalar law). */
DEFSIM_SIMD_INLINE void law_neohookean(const double *d, int s, const vd F[9], vd P[9])
{
    const vd mu = v_load(ROW(d, DEFSIM__ROW_P0, s)), la = v_load(ROW(d, DEFSIM__ROW_P1, s));
    vd C[9];
    cofactor(F, C);
    const vd J = DEFSIM__M3_DET_COF(F, C);
    const vd c = (la * v_log(J) - mu) / J;
    for (int i = 0; i < 9; ++i) P[i] = mu * F[i] + c * C[i];
    const vl bad = ~(J > 0.0);
    if (v_any(bad))
        for (int i = 0; i < 9; ++i) P[i] = v_select(bad, v_set1(NAN), P[i]);
}

/* psi = mu/2 (tr(F^T F) - 3) - mu log J + lambda/2 (log J)^2; +INFINITY where J <= 0 (as the
 * scalar law). */
DEFSIM_SIMD_INLINE vd psi_neohookean(const double *d, int s, const vd F[9])
{
    const vd mu = v_load(ROW(d, DEFSIM__ROW_P0, s)), la = v_load(ROW(d, DEFSIM__ROW_P1, s));
    vd C[9];
    cofactor(F, C);
    const vd J = DEFSIM__M3_DET_COF(F, C);
    const vl bad = ~(J > 0.0);
    const vd lj = v_log(v_select(bad, v_set1(1.0), J));
    const vd psi = 0.5 * mu * (frob2(F) - 3.0) - mu * lj + 0.5 * la * lj * lj;
    return v_select(bad, v_set1(INFINITY), psi);
}

DEFSIM__BATCHED_KERNEL(neohookean, law_neohookean)
DEFSIM__BATCHED_QKERNEL(neohookean, law_neohookean)
DEFSIM__BATCHED_QENERGY(neohookean, psi_neohookean)

/* The split, lane-wise (the scalar iso_P and volumetric above): psi_iso = mu/2 (tr(F^T F) - 3)
 * - mu log J, P_iso = mu F - mu/J cof F (+INFINITY, NaN where J <= 0); U = lambda/2 (log J)^2,
 * U' = lambda log J / J (U = J + INFINITY: +inf, or NaN for a NaN J; U' NaN where J <= 0). */
DEFSIM_SIMD_INLINE vd iso_neohookean(const double *d, int s, const vd F[9], const vd C[9], vd J,
                                     vd P[9])
{
    const vd mu = v_load(ROW(d, DEFSIM__ROW_P0, s));
    const vl bad = ~(J > 0.0);
    const vd c = -mu / J;
    for (int i = 0; i < 9; ++i) P[i] = mu * F[i] + c * C[i];
    const vd psi = 0.5 * mu * (frob2(F) - 3.0) - mu * v_log(v_select(bad, v_set1(1.0), J));
    if (v_any(bad))
        for (int i = 0; i < 9; ++i) P[i] = v_select(bad, v_set1(NAN), P[i]);
    return v_select(bad, v_set1(INFINITY), psi);
}

DEFSIM_SIMD_INLINE void vol_neohookean(const double *d, int s, vd J, vd u[2])
{
    const vd la = v_load(ROW(d, DEFSIM__ROW_P1, s));
    const vl bad = ~(J > 0.0);
    const vd lj = v_log(v_select(bad, v_set1(1.0), J));
    u[0] = v_select(bad, J + INFINITY, 0.5 * la * lj * lj);
    u[1] = v_select(bad, v_set1(NAN), la * lj / J);
}

DEFSIM__BATCHED_QMIXED(neohookean, iso_neohookean, vol_neohookean)

#endif
