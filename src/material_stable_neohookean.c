/* SPDX-License-Identifier: MIT */
/*
 * Stable neo-Hookean (Smith, de Goes, Kim 2018) with its Lame reparameterisation.
 * The scalar law and its table (material.h); compiled again per instruction set (DEFSIM_ISA
 * defined, tet_batch.h) for the batched SIMD law. Conventions: DESIGN.md section 4.
 */
#if !defined(DEFSIM_ISA)

#include "material.h"

#include "element.h"
#include "mat3.h"

#include <math.h>

/* Stable neo-Hookean (Smith, de Goes, Kim 2018), with mu' = 4/3 mu, lambda' = lambda + 5/6 mu,   */
/* alpha = 1 + 3 mu' / (4 lambda') = 1 + mu / lambda', I_C = tr(F^T F):                         */
/* psi = mu'/2 (I_C - 3) + lambda'/2 (J - alpha)^2 - mu'/2 log(I_C + 1).                        */
/* Finite for every finite F (I_C + 1 >= 1). psi(I) = snh_psi_rest(mu, lambda) != 0.     */

static void snh_params(double mu, double lambda, double *mu_p, double *lambda_p, double *alpha)
{
    *mu_p = 4.0 / 3.0 * mu;
    *lambda_p = lambda + 5.0 / 6.0 * mu;
    /* lambda' > 0 whenever mu > 0; alpha -> 1 when both vanish (no energy at all). */
    *alpha = (*lambda_p != 0.0) ? 1.0 + mu / *lambda_p : 1.0;
}

static double snh_psi(double mu, double lambda, const double F[9])
{
    double mp, lp, alpha;
    snh_params(mu, lambda, &mp, &lp, &alpha);
    double ic = defsim__m3_ddot(F, F);
    double d = defsim__m3_det(F) - alpha;
    return 0.5 * mp * (ic - 3.0) + 0.5 * lp * d * d - 0.5 * mp * log(ic + 1.0);
}

/* psi(I) = lambda'/2 (1 - alpha)^2 - mu'/2 log 4: the rest energy that world energies subtract. */
static double snh_psi_rest(double mu, double lambda)
{
    double mp, lp, alpha;
    snh_params(mu, lambda, &mp, &lp, &alpha);
    return 0.5 * lp * (1.0 - alpha) * (1.0 - alpha) - 0.5 * mp * log(4.0);
}

/* P = mu' (1 - 1/(I_C + 1)) F + lambda' (J - alpha) cof(F). */
static double snh_P(double mu, double lambda, const double F[9], double P[9])
{
    double mp, lp, alpha, C[9];
    snh_params(mu, lambda, &mp, &lp, &alpha);
    defsim__m3_cofactor(F, C);
    double ic = defsim__m3_ddot(F, F);
    double d = DEFSIM__M3_DET_COF(F, C) - alpha;
    double c1 = mp * (1.0 - 1.0 / (ic + 1.0));
    double c2 = lp * d;
    for (int i = 0; i < 9; ++i) P[i] = c1 * F[i] + c2 * C[i];
    return 0.5 * mp * (ic - 3.0) + 0.5 * lp * d * d - 0.5 * mp * log(ic + 1.0);
}

DEFSIM__TET_FORCE_KERNEL(forces_snh, snh_P)

/* dP/dmu and dP/dlambda through mu' = 4/3 mu, lambda' = lambda + 5/6 mu, alpha = 1 + mu/lambda':
 * dalpha/dmu = 1/lambda' - 5/6 mu/lambda'^2, dalpha/dlambda = -mu/lambda'^2. */
static void snh_dP_dlame(double mu, double lambda, const double F[9], double Pmu[9],
                         double Plambda[9])
{
    double mp, lp, alpha, C[9];
    snh_params(mu, lambda, &mp, &lp, &alpha);
    defsim__m3_cofactor(F, C);
    const double ic = defsim__m3_ddot(F, F);
    const double d = DEFSIM__M3_DET_COF(F, C) - alpha;
    const double c1 = 4.0 / 3.0 * (1.0 - 1.0 / (ic + 1.0));
    const double da_mu = lp != 0.0 ? 1.0 / lp - 5.0 / 6.0 * mu / (lp * lp) : 0.0;
    const double da_la = lp != 0.0 ? -mu / (lp * lp) : 0.0;
    const double c2mu = 5.0 / 6.0 * d - lp * da_mu;
    const double c2la = d - lp * da_la;
    for (int i = 0; i < 9; ++i) {
        Pmu[i] = c1 * F[i] + c2mu * C[i];
        Plambda[i] = c2la * C[i];
    }
}

/*
 * dP_ij/dF_kl = c1 d_ik d_jl + 2 mu'/(I_C+1)^2 F_ij F_kl + lambda' C_ij C_kl
 *             + lambda' (J - alpha) d2J/dF_ij dF_kl,
 * with d2J/dF_ij dF_kl = eps_ikn eps_jlm F_nm (nonzero only for i != k, j != l).
 */
static void snh_dPdF(double mu, double lambda, const double F[9], double dPdF[81])
{
    double mp, lp, alpha, C[9];
    snh_params(mu, lambda, &mp, &lp, &alpha);
    defsim__m3_cofactor(F, C);
    double ic = defsim__m3_ddot(F, F);
    double c1 = mp * (1.0 - 1.0 / (ic + 1.0));
    double cF = 2.0 * mp / ((ic + 1.0) * (ic + 1.0));
    double c2 = lp * (DEFSIM__M3_DET_COF(F, C) - alpha);
    for (int r = 0; r < 9; ++r)
        for (int c = r; c < 9; ++c) {
            double h = cF * F[r] * F[c] + lp * C[r] * C[c];
            if (r == c) h += c1;
            dPdF[9 * r + c] = dPdF[9 * c + r] = h;
        }
    tet_add_det_hessian(F, c2, dPdF);
}

static void snh_sigma(double mu, double lambda, const double s[3], double h[9],
                      double ev_sym[3],
                      double ev_skew[3])
{
    static const int pa[3] = {0, 0, 1}, pb[3] = {1, 2, 2};
    double mp, lp, alpha;
    snh_params(mu, lambda, &mp, &lp, &alpha);
    double ic = s[0] * s[0] + s[1] * s[1] + s[2] * s[2];
    double J = s[0] * s[1] * s[2];
    double c1 = mp * (1.0 - 1.0 / (ic + 1.0)), cf = 2.0 * mp / ((ic + 1.0) * (ic + 1.0));
    double c2 = lp * (J - alpha);
    double pr[3] = {s[1] * s[2], s[0] * s[2], s[0] * s[1]};   /* dJ/ds */
    for (int a = 0; a < 3; ++a)
        for (int b = 0; b < 3; ++b)
            h[3 * a + b] = cf * s[a] * s[b] + lp * pr[a] * pr[b] +
                           (a == b ? c1 : c2 * s[3 - a - b]);
    for (int p = 0; p < 3; ++p) {
        double sc = s[3 - pa[p] - pb[p]];
        ev_sym[p] = c1 - c2 * sc;
        ev_skew[p] = c1 + c2 * sc;
    }
}

static void params(double mu, double lambda, double p[3])
{
    snh_params(mu, lambda, &p[0], &p[1], &p[2]);
}

/* The split (material.h): U(J) = lambda/2 (J - alpha)^2 with the user's lambda, and
 * psi_iso = mu'/2 (I_C - 3) - mu'/2 log(I_C + 1) + (lambda' - lambda)/2 (J - alpha)^2, the rest
 * of the law: lambda' - lambda = 5/6 mu stays with each element (or quadrature point), so that
 * psi_iso linearises to mu |eps|^2 with no tr(eps)^2 term, as neo-Hookean's does. With all of
 * lambda' in U, psi_iso's linearised bulk modulus would be 2/3 mu - 5/6 mu = -mu/6: what the
 * averaging takes out of U then leaves a negative stiffness behind (the mean-dilatation
 * quadratic tets sagged 1.5 % too much on the 12 x 4 x 4 cantilever at nu = 0.499 and 1.8 % at
 * 0.3, each point's tangent was indefinite at rest and Newton took twice the iterations:
 * docs/elements.md). P_iso = c1 F + (lambda' - lambda)(J - alpha) cof F,
 * dP_iso/dF = c1 I + 2 mu'/(I_C + 1)^2 F (x) F + (lambda' - lambda)(cof F (x) cof F +
 * (J - alpha) d2J/dF2). */
static double iso_P(double mu, double lambda, const double F[9], double P[9])
{
    double mp, lp, alpha, C[9];
    snh_params(mu, lambda, &mp, &lp, &alpha);
    defsim__m3_cofactor(F, C);
    const double ic = defsim__m3_ddot(F, F), d = DEFSIM__M3_DET_COF(F, C) - alpha;
    const double c1 = mp * (1.0 - 1.0 / (ic + 1.0)), lb = lp - lambda;
    for (int i = 0; i < 9; ++i) P[i] = c1 * F[i] + lb * d * C[i];
    return 0.5 * mp * (ic - 3.0) - 0.5 * mp * log(ic + 1.0) + 0.5 * lb * d * d;
}

static void iso_dPdF(double mu, double lambda, const double F[9], double dPdF[81])
{
    double mp, lp, alpha, C[9];
    snh_params(mu, lambda, &mp, &lp, &alpha);
    defsim__m3_cofactor(F, C);
    const double ic = defsim__m3_ddot(F, F), lb = lp - lambda;
    const double c1 = mp * (1.0 - 1.0 / (ic + 1.0));
    const double cF = 2.0 * mp / ((ic + 1.0) * (ic + 1.0));
    for (int r = 0; r < 9; ++r)
        for (int c = 0; c < 9; ++c)
            dPdF[9 * r + c] = cF * F[r] * F[c] + lb * C[r] * C[c] + (r == c ? c1 : 0.0);
    tet_add_det_hessian(F, lb * (DEFSIM__M3_DET_COF(F, C) - alpha), dPdF);
}

static void volumetric(double mu, double lambda, double J, double u[3])
{
    double mp, lp, alpha;
    snh_params(mu, lambda, &mp, &lp, &alpha);
    u[0] = 0.5 * lambda * (J - alpha) * (J - alpha);
    u[1] = lambda * (J - alpha);
    u[2] = lambda;
}

static const defsim__model_split split = {.P = iso_P, .dPdF = iso_dPdF, .U = volumetric};

const defsim__model defsim__model_stable_neohookean = {
    .name = "stable_neohookean", .id = DEFSIM_MODEL_STABLE_NEOHOOKEAN,
    .pass = DEFSIM_PASS_STABLE_NEOHOOKEAN, .params = params, .psi = snh_psi,
    .psi_rest = snh_psi_rest, .P = snh_P, .dPdF = snh_dPdF, .sigma = snh_sigma,
    .forces = forces_snh, .split = &split, .dP_dlame = snh_dP_dlame};

#else /* DEFSIM_ISA: the batched law */

#include "tet_batch.h"

/* What the lane-wise laws share: C = cof F, I_C = |F|^2, J - alpha. */
DEFSIM_SIMD_INLINE void snh_invariants(const double *d, int s, const vd F[9], vd C[9], vd *ic,
                                       vd *dj)
{
    cofactor(F, C);
    *ic = frob2(F);
    *dj = DEFSIM__M3_DET_COF(F, C) - v_load(ROW(d, DEFSIM__ROW_P2, s));
}

/* Stable neo-Hookean: P = mu' (1 - 1/(I_C + 1)) F + lambda' (J - alpha) cof F. */
DEFSIM_SIMD_INLINE void law_snh(const double *d, int s, const vd F[9], vd P[9])
{
    const vd mp = v_load(ROW(d, DEFSIM__ROW_P0, s)), lp = v_load(ROW(d, DEFSIM__ROW_P1, s));
    vd C[9], ic, dj;
    snh_invariants(d, s, F, C, &ic, &dj);
    const vd c1 = mp * (1.0 - 1.0 / (ic + 1.0));
    const vd c2 = lp * dj;
    for (int i = 0; i < 9; ++i) P[i] = c1 * F[i] + c2 * C[i];
}

/* psi = mu'/2 (I_C - 3) + lambda'/2 (J - alpha)^2 - mu'/2 log(I_C + 1). */
DEFSIM_SIMD_INLINE vd psi_snh(const double *d, int s, const vd F[9])
{
    const vd mp = v_load(ROW(d, DEFSIM__ROW_P0, s)), lp = v_load(ROW(d, DEFSIM__ROW_P1, s));
    vd C[9], ic, dj;
    snh_invariants(d, s, F, C, &ic, &dj);
    return 0.5 * mp * (ic - 3.0) + 0.5 * lp * dj * dj - 0.5 * mp * v_log(ic + 1.0);
}

DEFSIM__BATCHED_KERNEL(stable_neohookean, law_snh)
DEFSIM__BATCHED_QKERNEL(stable_neohookean, law_snh)
DEFSIM__BATCHED_QENERGY(stable_neohookean, psi_snh)

/* The split, lane-wise (the scalar iso_P and volumetric above; lambda, the user's, from the
 * batch's DEFSIM__QROW_LAMBDA row): psi_iso = mu'/2 (I_C - 3) - mu'/2 log(I_C + 1) +
 * (lambda' - lambda)/2 (J - alpha)^2, P_iso = mu' (1 - 1/(I_C + 1)) F + (lambda' - lambda)
 * (J - alpha) cof F; U = lambda/2 (J - alpha)^2, U' = lambda (J - alpha). */
DEFSIM_SIMD_INLINE vd iso_snh(const double *d, int s, const vd F[9], const vd C[9], vd J,
                              vd P[9])
{
    const vd mp = v_load(ROW(d, DEFSIM__ROW_P0, s)), lp = v_load(ROW(d, DEFSIM__ROW_P1, s));
    const vd alpha = v_load(ROW(d, DEFSIM__ROW_P2, s));
    const vd lb = lp - v_load(ROW(d, DEFSIM__QROW_LAMBDA, s)), ic = frob2(F);
    const vd dj = J - alpha, c1 = mp * (1.0 - 1.0 / (ic + 1.0)), c2 = lb * dj;
    for (int i = 0; i < 9; ++i) P[i] = c1 * F[i] + c2 * C[i];
    return 0.5 * mp * (ic - 3.0) - 0.5 * mp * v_log(ic + 1.0) + 0.5 * lb * dj * dj;
}

DEFSIM_SIMD_INLINE void vol_snh(const double *d, int s, vd J, vd u[2])
{
    const vd la = v_load(ROW(d, DEFSIM__QROW_LAMBDA, s));
    const vd dj = J - v_load(ROW(d, DEFSIM__ROW_P2, s));
    u[0] = 0.5 * la * dj * dj;
    u[1] = la * dj;
}

DEFSIM__BATCHED_QMIXED(stable_neohookean, iso_snh, vol_snh)

#endif
