/* SPDX-License-Identifier: MIT */
/*
 * The four tet constitutive models as inline kernels, so that per-material loops inline them.
 *
 * Every function takes the user's Lame parameters mu = E/(2(1+nu)), lambda = E nu/((1+nu)(1-2nu))
 * (the stable neo-Hookean model reparameterises them itself) and a deformation gradient F,
 * row-major (F[3*i+j] = F_ij). For each model:
 *   *_psi   energy density psi(F);
 *   *_P     first Piola-Kirchhoff stress P = dpsi/dF, returns psi as well (no dPdF work);
 *   *_dPdF  dPdF[9*(3*i+j) + (3*k+l)] = dP_ij / dF_kl (symmetric 9 x 9).
 * All four give P(I) = 0 and dPdF(I) = the linear elasticity tensor,
 * dP = mu (dF + dF^T) + lambda tr(dF) I. Conventions: DESIGN.md section 4.
 */
#ifndef DEFSIM_MATERIAL_MODELS_H
#define DEFSIM_MATERIAL_MODELS_H

#include <math.h>

#include "mat3.h"

/* ------------------------------------------------------------------------------------------ */
/* Saint Venant-Kirchhoff: E = (F^T F - I)/2, psi = mu E:E + lambda/2 tr(E)^2.                  */

/* Second Piola-Kirchhoff stress S = 2 mu E + lambda tr(E) I; returns psi. */
static inline double defsim__stvk_S(double mu, double lambda, const double F[9], double S[9])
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

static inline double defsim__stvk_psi(double mu, double lambda, const double F[9])
{
    double S[9];
    return defsim__stvk_S(mu, lambda, F, S);
}

/* P = F S. */
static inline double defsim__stvk_P(double mu, double lambda, const double F[9], double P[9])
{
    double S[9];
    double psi = defsim__stvk_S(mu, lambda, F, S);
    defsim__m3_mul(F, S, P);
    return psi;
}

/* dP_ij/dF_kl = delta_ik S_lj + mu F_il F_kj + mu (F F^T)_ik delta_jl + lambda F_ij F_kl. */
static inline void defsim__stvk_dPdF(double mu, double lambda, const double F[9], double dPdF[81])
{
    double S[9], B[9];
    defsim__stvk_S(mu, lambda, F, S);
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

/* ------------------------------------------------------------------------------------------ */
/* Isotropic energies written in signed singular values: psi = f(s0, s1, s2).                 */

/*
 * dPdF of an isotropic energy from its signed SVD F = U diag(s) V^T, given the gradient g = df/ds
 * and the Hessian h = d2f/ds2 (3 x 3 row-major). In the basis u_a v_b^T the 9 x 9 tensor splits
 * into the 3 x 3 block h on the diagonal modes D_a = u_a v_a^T and, for each pair a < b, two
 * eigenmodes: T = (u_a v_b^T + u_b v_a^T)/sqrt2 with eigenvalue (g_a - g_b)/(s_a - s_b), and
 * Q = (u_a v_b^T - u_b v_a^T)/sqrt2 with eigenvalue (g_a + g_b)/(s_a + s_b). The caller passes
 * those six eigenvalues (it knows closed forms that survive s_a == s_b and s_a + s_b == 0).
 */
static inline void defsim__isotropic_dPdF(const double U[9], const double V[9], const double h[9],
                                          const double ev_sym[3], const double ev_skew[3],
                                          double dPdF[81])
{
    static const int pa[3] = {0, 0, 1}, pb[3] = {1, 2, 2};
    double D[3][9], T[3][9], Q[3][9];
    for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j) {
            int r = 3 * i + j;
            for (int a = 0; a < 3; ++a) D[a][r] = U[3 * i + a] * V[3 * j + a];
            for (int p = 0; p < 3; ++p) {
                double x = U[3 * i + pa[p]] * V[3 * j + pb[p]];
                double y = U[3 * i + pb[p]] * V[3 * j + pa[p]];
                T[p][r] = x + y;
                Q[p][r] = x - y;
            }
        }
    for (int r = 0; r < 9; ++r) {
        /* hD[c] = sum_a D_a[r] h_ac, so the diagonal-mode term of (r, c) is hD . D[.][c]. */
        double hD[3], ts[3], qs[3];
        for (int c = 0; c < 3; ++c)
            hD[c] = D[0][r] * h[c] + D[1][r] * h[3 + c] + D[2][r] * h[6 + c];
        for (int p = 0; p < 3; ++p) {
            ts[p] = 0.5 * ev_sym[p] * T[p][r];
            qs[p] = 0.5 * ev_skew[p] * Q[p][r];
        }
        for (int c = r; c < 9; ++c) {
            double s = hD[0] * D[0][c] + hD[1] * D[1][c] + hD[2] * D[2][c];
            for (int p = 0; p < 3; ++p) s += ts[p] * T[p][c] + qs[p] * Q[p][c];
            dPdF[9 * r + c] = dPdF[9 * c + r] = s;
        }
    }
}

/* s_a + s_b as a denominator, kept at least 1e-6 in magnitude (sign kept, +0 counts as +) so
 * that flat and inverted elements give large but finite stiffness. */
static inline double defsim__safe_sum(double sa, double sb)
{
    double d = sa + sb;
    if (fabs(d) < 1e-6) d = (d < 0.0) ? -1e-6 : 1e-6;
    return d;
}

/* ------------------------------------------------------------------------------------------ */
/* Co-rotated linear: F = R S from the signed SVD, psi = mu |S - I|^2 + lambda/2 tr(S - I)^2     */
/* = mu sum (s_i - 1)^2 + lambda/2 (sum s_i - 3)^2.                                            */

static inline double defsim__corotated_psi_sigma(double mu, double lambda, const double s[3])
{
    double d0 = s[0] - 1.0, d1 = s[1] - 1.0, d2 = s[2] - 1.0;
    double tr = d0 + d1 + d2;
    return mu * (d0 * d0 + d1 * d1 + d2 * d2) + 0.5 * lambda * tr * tr;
}

static inline double defsim__corotated_psi(double mu, double lambda, const double F[9])
{
    double U[9], s[3], V[9];
    defsim__svd3(F, U, s, V);
    return defsim__corotated_psi_sigma(mu, lambda, s);
}

/* P = R (2 mu (S - I) + lambda tr(S - I) I) = 2 mu (F - R) + lambda tr(S - I) R. */
static inline double defsim__corotated_P(double mu, double lambda, const double F[9], double P[9])
{
    double U[9], s[3], V[9], R[9];
    defsim__svd3(F, U, s, V);
    defsim__m3_mul_nt(U, V, R);
    double tr = s[0] + s[1] + s[2] - 3.0;
    for (int i = 0; i < 9; ++i) P[i] = 2.0 * mu * (F[i] - R[i]) + lambda * tr * R[i];
    return defsim__corotated_psi_sigma(mu, lambda, s);
}

static inline void defsim__corotated_dPdF(double mu, double lambda, const double F[9],
                                          double dPdF[81])
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

/* ------------------------------------------------------------------------------------------ */
/* Neo-Hookean: psi = mu/2 (tr(F^T F) - 3) - mu log J + lambda/2 (log J)^2, J = det F.          */
/* Undefined for J <= 0: psi is +INFINITY and P, dPdF are filled with NAN there.               */

static inline double defsim__neohookean_psi(double mu, double lambda, const double F[9])
{
    double J = defsim__m3_det(F);
    if (!(J > 0.0)) return INFINITY;
    double lj = log(J);
    return 0.5 * mu * (defsim__m3_ddot(F, F) - 3.0) - mu * lj + 0.5 * lambda * lj * lj;
}

/* P = mu (F - F^-T) + lambda log J F^-T. */
static inline double defsim__neohookean_P(double mu, double lambda, const double F[9], double P[9])
{
    double G[9];
    defsim__m3_cofactor(F, G);
    double J = F[0] * G[0] + F[1] * G[1] + F[2] * G[2];
    if (!(J > 0.0)) {
        for (int i = 0; i < 9; ++i) P[i] = NAN;
        return INFINITY;
    }
    double lj = log(J);
    double c = (lambda * lj - mu) / J; /* G = cof F = J F^-T */
    for (int i = 0; i < 9; ++i) P[i] = mu * F[i] + c * G[i];
    return 0.5 * mu * (defsim__m3_ddot(F, F) - 3.0) - mu * lj + 0.5 * lambda * lj * lj;
}

/* With G = F^-T: dP_ij/dF_kl = mu d_ik d_jl + (mu - lambda log J) G_il G_kj + lambda G_ij G_kl. */
static inline void defsim__neohookean_dPdF(double mu, double lambda, const double F[9],
                                           double dPdF[81])
{
    double G[9];
    defsim__m3_cofactor(F, G);
    double J = F[0] * G[0] + F[1] * G[1] + F[2] * G[2];
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

/* ------------------------------------------------------------------------------------------ */
/* Stable neo-Hookean (Smith, de Goes, Kim 2018), with mu' = 4/3 mu, lambda' = lambda + 5/6 mu,   */
/* alpha = 1 + 3 mu' / (4 lambda') = 1 + mu / lambda', I_C = tr(F^T F):                         */
/* psi = mu'/2 (I_C - 3) + lambda'/2 (J - alpha)^2 - mu'/2 log(I_C + 1).                        */
/* Finite for every finite F (I_C + 1 >= 1). psi(I) = defsim__snh_psi_rest(mu, lambda) != 0.     */

static inline void defsim__snh_params(double mu, double lambda, double *mu_p, double *lambda_p,
                                      double *alpha)
{
    *mu_p = 4.0 / 3.0 * mu;
    *lambda_p = lambda + 5.0 / 6.0 * mu;
    /* lambda' > 0 whenever mu > 0; alpha -> 1 when both vanish (no energy at all). */
    *alpha = (*lambda_p != 0.0) ? 1.0 + mu / *lambda_p : 1.0;
}

static inline double defsim__snh_psi(double mu, double lambda, const double F[9])
{
    double mp, lp, alpha;
    defsim__snh_params(mu, lambda, &mp, &lp, &alpha);
    double ic = defsim__m3_ddot(F, F);
    double d = defsim__m3_det(F) - alpha;
    return 0.5 * mp * (ic - 3.0) + 0.5 * lp * d * d - 0.5 * mp * log(ic + 1.0);
}

/* psi(I) = lambda'/2 (1 - alpha)^2 - mu'/2 log 4: the rest energy that world energies subtract. */
static inline double defsim__snh_psi_rest(double mu, double lambda)
{
    double mp, lp, alpha;
    defsim__snh_params(mu, lambda, &mp, &lp, &alpha);
    return 0.5 * lp * (1.0 - alpha) * (1.0 - alpha) - 0.5 * mp * log(4.0);
}

/* P = mu' (1 - 1/(I_C + 1)) F + lambda' (J - alpha) cof(F). */
static inline double defsim__snh_P(double mu, double lambda, const double F[9], double P[9])
{
    double mp, lp, alpha, C[9];
    defsim__snh_params(mu, lambda, &mp, &lp, &alpha);
    defsim__m3_cofactor(F, C);
    double ic = defsim__m3_ddot(F, F);
    double d = F[0] * C[0] + F[1] * C[1] + F[2] * C[2] - alpha;
    double c1 = mp * (1.0 - 1.0 / (ic + 1.0));
    double c2 = lp * d;
    for (int i = 0; i < 9; ++i) P[i] = c1 * F[i] + c2 * C[i];
    return 0.5 * mp * (ic - 3.0) + 0.5 * lp * d * d - 0.5 * mp * log(ic + 1.0);
}

/*
 * dP_ij/dF_kl = c1 d_ik d_jl + 2 mu'/(I_C+1)^2 F_ij F_kl + lambda' C_ij C_kl
 *             + lambda' (J - alpha) d2J/dF_ij dF_kl,
 * with d2J/dF_ij dF_kl = eps_ikn eps_jlm F_nm (nonzero only for i != k, j != l).
 */
static inline void defsim__snh_dPdF(double mu, double lambda, const double F[9], double dPdF[81])
{
    double mp, lp, alpha, C[9];
    defsim__snh_params(mu, lambda, &mp, &lp, &alpha);
    defsim__m3_cofactor(F, C);
    double ic = defsim__m3_ddot(F, F);
    double c1 = mp * (1.0 - 1.0 / (ic + 1.0));
    double cF = 2.0 * mp / ((ic + 1.0) * (ic + 1.0));
    double c2 = lp * (F[0] * C[0] + F[1] * C[1] + F[2] * C[2] - alpha);
    for (int r = 0; r < 9; ++r)
        for (int c = r; c < 9; ++c) {
            double h = cF * F[r] * F[c] + lp * C[r] * C[c];
            if (r == c) h += c1;
            dPdF[9 * r + c] = dPdF[9 * c + r] = h;
        }
    for (int i = 0; i < 3; ++i)
        for (int k = 0; k < 3; ++k) {
            if (i == k) continue;
            int n = 3 - i - k;
            double sik = ((k - i + 3) % 3 == 1) ? c2 : -c2;
            for (int j = 0; j < 3; ++j)
                for (int l = 0; l < 3; ++l) {
                    if (j == l) continue;
                    int m = 3 - j - l;
                    double sjl = ((l - j + 3) % 3 == 1) ? sik : -sik;
                    dPdF[9 * (3 * i + j) + 3 * k + l] += sjl * F[3 * n + m];
                }
        }
}

/* ------------------------------------------------------------------------------------------ */
/* dPdF in signed singular values, for the analytic PSD projection of element Hessians.       */
/* Every model above is isotropic: psi = f(s) in the signed singular values s of F. For each,   */
/* *_sigma gives the Hessian h = d2f/ds2 (3 x 3 row-major) and the eigenvalues of the twist and */
/* flip modes of defsim__isotropic_dPdF for the pairs (0,1), (0,2), (1,2):                    */
/* ev_sym = (g_a - g_b)/(s_a - s_b) and ev_skew = (g_a + g_b)/(s_a + s_b), g = df/ds, in closed */
/* forms that need no such division where one exists. With these, dPdF's eigenvalues are those */
/* of h and the six ev, so clamping them projects dPdF without a 9 x 9 eigensolver.             */

static inline void defsim__stvk_sigma(double mu, double lambda, const double s[3], double h[9],
                                      double ev_sym[3], double ev_skew[3])
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

static inline void defsim__corotated_sigma(double mu, double lambda, const double s[3],
                                           double h[9], double ev_sym[3], double ev_skew[3])
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

/* Undefined (NAN) unless every s > 0. */
static inline void defsim__neohookean_sigma(double mu, double lambda, const double s[3],
                                            double h[9], double ev_sym[3], double ev_skew[3])
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

static inline void defsim__snh_sigma(double mu, double lambda, const double s[3], double h[9],
                                     double ev_sym[3], double ev_skew[3])
{
    static const int pa[3] = {0, 0, 1}, pb[3] = {1, 2, 2};
    double mp, lp, alpha;
    defsim__snh_params(mu, lambda, &mp, &lp, &alpha);
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

#endif /* DEFSIM_MATERIAL_MODELS_H */
