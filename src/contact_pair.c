/* SPDX-License-Identifier: MIT */
/*
 * One body-contact constraint's barrier: see contact_pair.h.
 */
#include "contact_pair.h"

#include "contact_barrier.h"
#include "contact_prim.h"
#include "mat3.h"

#include "defsim/defsim.h"

#include <math.h>

double defsim__contact_dist2(int type, const double *X, double *g, double *H)
{
    switch (type) {
    case DEFSIM__C_FV: return defsim__pt_dist2(X, X + 3, X + 6, X + 9, g, H, NULL);
    case DEFSIM__C_EE: return defsim__ee_dist2(X, X + 3, X + 6, X + 9, g, H, NULL);
    case DEFSIM__C_EV: return defsim__pe_dist2(X, X + 3, X + 6, g, H, NULL);
    default: {
        double s = 0.0;
        for (int k = 0; k < 3; ++k) {
            const double r = X[k] - X[3 + k];
            s += r * r;
            if (g) {
                g[k] = 2.0 * r;
                g[3 + k] = -2.0 * r;
            }
        }
        if (H)
            for (int i = 0; i < 6; ++i)
                for (int j = 0; j < 6; ++j)
                    H[6 * i + j] = (i % 3 == j % 3) ? ((i < 3) == (j < 3) ? 2.0 : -2.0) : 0.0;
        return s;
    }
    }
}

/* Makes the Hessian H (3n x 3n) of a function of the n vertices that only their differences
 * enter (every distance here) positive semi-definite: in the coordinates y_i = x_i - x_0
 * (i >= 1) it is T^T B T with B its (3n - 3)-square lower block; B is projected (clamped
 * eigenvalues) and mapped back. A smaller eigenproblem than the full one (9 instead of 12), and
 * translations stay in the null space exactly. */
static void project_relative(int n, double *H)
{
    const int nd = 3 * n, r = nd - 3;
    double B[81];
    for (int i = 0; i < r; ++i)
        for (int j = 0; j < r; ++j) B[i * r + j] = H[(3 + i) * nd + 3 + j];
    defsim__project_psd(r, B, DEFSIM_PROJECTION_CLAMP);
    /* column sums per row (the x_0 column block of B T) */
    double c[81][3];
    for (int i = 0; i < r; ++i)
        for (int k = 0; k < 3; ++k) {
            double sum = 0.0;
            for (int b = 0; b < n - 1; ++b) sum += B[i * r + 3 * b + k];
            c[i][k] = sum;
        }
    for (int i = 0; i < r; ++i)
        for (int j = 0; j < r; ++j) H[(3 + i) * nd + 3 + j] = B[i * r + j];
    for (int i = 0; i < r; ++i)
        for (int k = 0; k < 3; ++k) H[(3 + i) * nd + k] = H[k * nd + 3 + i] = -c[i][k];
    for (int k = 0; k < 3; ++k)
        for (int l = 0; l < 3; ++l) {
            double sum = 0.0;
            for (int a = 0; a < n - 1; ++a) sum += c[3 * a + k][l];
            H[k * nd + l] = sum;
        }
}

double defsim__contact_barrier(int type, const double *X, double dh, double kap,
                               double eps_moll, double *g, double *H)
{
    const int m = defsim__contact_nodes(type);
    const int nd = 3 * m;
    double gs[12], Hs[144];
    /* the derivatives only for pairs within dhat (most candidates are not) */
    double s = defsim__contact_dist2(type, X, NULL, NULL);
    if (!(s < dh * dh)) return 0.0;
    if (!(s > 0.0)) return INFINITY;
    if (g || H) s = defsim__contact_dist2(type, X, gs, H ? Hs : NULL);
    const double d = sqrt(s);
    const double e = kap * barrier(d, dh);
    double gd[12];
    const double b1 = kap * barrier_d1(d, dh);
    for (int i = 0; i < nd && (g || H); ++i) gd[i] = gs[i] / (2.0 * d);
    if (H) {
        /* d = sqrt(s): Hd = Hs / (2d) - gs gs^T / (4 d^3) */
        const double b2 = kap * barrier_d2(d, dh);
        for (int i = 0; i < nd; ++i)
            for (int j = 0; j < nd; ++j)
                H[i * nd + j] = b2 * gd[i] * gd[j] +
                                b1 * (Hs[i * nd + j] / (2.0 * d) - gd[i] * gd[j] / d);
    }
    if (g)
        for (int i = 0; i < nd; ++i) g[i] = b1 * gd[i];
    double out = e;
    if (type == DEFSIM__C_EE) {
        double gm[12], Hm[144];
        const double mo = defsim__ee_mollifier(X, X + 3, X + 6, X + 9, eps_moll,
                                               g || H ? gm : NULL, H ? Hm : NULL);
        if (mo < 1.0) {
            if (H)
                for (int i = 0; i < 12; ++i)
                    for (int j = 0; j < 12; ++j)
                        H[i * 12 + j] = mo * H[i * 12 + j] + b1 * gd[i] * gm[j] +
                                        gm[i] * b1 * gd[j] + e * Hm[i * 12 + j];
            if (g)
                for (int i = 0; i < 12; ++i) g[i] = mo * g[i] + e * gm[i];
            out = mo * e;
        }
    }
    if (H) project_relative(m, H);
    return out;
}
