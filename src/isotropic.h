/* SPDX-License-Identifier: MIT */
/*
 * Isotropic energies written in signed singular values, psi = f(s0, s1, s2): the assembly of
 * dP/dF from its eigen-structure, shared by the models whose dPdF or projection uses it.
 */
#ifndef DEFSIM_ISOTROPIC_H
#define DEFSIM_ISOTROPIC_H

#include <math.h>

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

#endif /* DEFSIM_ISOTROPIC_H */
