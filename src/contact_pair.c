/* SPDX-License-Identifier: MIT */
/*
 * One body-contact constraint's barrier: see contact_pair.h.
 *
 * The Hessian is projected to positive semi-definite by the exact eigenvalue clamp of the whole
 * 3n x 3n matrix, in the smallest subspace that holds its range:
 *   - every distance depends on vertex differences only, so translations are exact null
 *     vectors; an orthonormal basis of their complement (H_k (x) I3 with H the columns of a
 *     Hadamard-like node matrix orthogonal to (1, ..., 1)) turns the clamp of H into the clamp
 *     of a (3m - 3)-square matrix over the m vertices the closest features involve;
 *   - point-point regions (any contact type): the 3 x 3 block of y = x_i - x_j has the
 *     eigenvectors n and the plane orthogonal to it, so the clamp is closed form;
 *   - point-plane (face-vertex interior) and line-line (edge-edge interior, mollifier off)
 *     regions: the signed distance sigma = r . n^ has gradient w (x) n^ (w: the closest points'
 *     node weights) and a Hessian whose range lies in {h_k (x) n^} + {w (x) t : t in the plane}
 *     (moving vertices within the plane leaves n^ fixed, and the normal only turns within the
 *     plane), a 5-dimensional space: its 5 x 5 matrix is built in closed form from the
 *     second-order expansion of sigma and clamped there;
 *   - point-line regions (edge-vertex, and face-vertex or edge-edge pairs closest at an edge's
 *     interior): a 3 x 3 matrix and one eigenvalue, closed form (pl_closed);
 *   - the mollified edge-edge barrier: the Hessian from the distance's and the mollifier's
 *     derivatives, clamped in the 9-dimensional translation-free subspace.
 * Every small clamp uses one symmetric eigensolver: Householder tridiagonalisation and the
 * implicit QR iteration with Wilkinson shifts (Golub and Van Loan, 8.3), for n <= 9. The
 * closed forms are checked against the clamp of the whole matrix in tests/unit/test_contact_pair.c.
 */
#include "contact_pair.h"

#include "defsim/defsim.h"

#include "contact_barrier.h"
#include "contact_prim.h"
#include "mat3.h"

#include <float.h>
#include <math.h>
#include <string.h>

enum { EIG_N = 9 };

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

/* ------------------------------------------------------------------------------------------ */
/* Small symmetric eigenproblems */

/* Replaces the symmetric n x n matrix A by its projection on the positive semi-definite cone
 * (eigenvalues clamped at 0): A = sum over positive lam of lam v v^T. */
static void clamp_psd(int n, double *A)
{
    double W[EIG_N * EIG_N], V[EIG_N * EIG_N], lam[EIG_N];
    /* scaled to entries of at most 1, so that no square in the eigensolver under- or
     * overflows */
    double m = 0.0;
    for (int i = 0; i < n * n; ++i) m = fabs(A[i]) > m ? fabs(A[i]) : m;
    if (!(m > 0.0) || !isfinite(m)) return;
    for (int i = 0; i < n * n; ++i) W[i] = A[i] / m;
    defsim__sym_eig(n, W, lam, V);
    for (int k = 0; k < n; ++k) lam[k] *= m;
    int neg = 0;
    for (int k = 0; k < n; ++k) neg += lam[k] < 0.0;
    if (!neg) return;
    for (int i = 0; i < n; ++i)
        for (int j = i; j < n; ++j) {
            double s = 0.0;
            for (int k = 0; k < n; ++k)
                if (lam[k] > 0.0) s += V[i * n + k] * lam[k] * V[j * n + k];
            A[i * n + j] = A[j * n + i] = s;
        }
}

/* ------------------------------------------------------------------------------------------ */
/* Closed forms */

/* Point-point between vertices i and j of X: the gradient f1 grad d and the clamped Hessian
 * of f(d) (f1 = f', f2 = f'') over y = x_i - x_j, f2 n n^T + max(f1 / d, 0) (I - n n^T), placed
 * as [+B -B; -B +B]. g and H cover nd = 3 (number of vertices) coordinates, zero elsewhere. */
static void vv_closed(const double *X, int nd, int i, int j, double d, double f1, double f2,
                      double *g, double *H)
{
    double n[3];
    for (int k = 0; k < 3; ++k) n[k] = (X[3 * i + k] - X[3 * j + k]) / d;
    if (g) {
        memset(g, 0, (size_t)nd * sizeof *g);
        for (int k = 0; k < 3; ++k) {
            g[3 * i + k] = f1 * n[k];
            g[3 * j + k] = -f1 * n[k];
        }
    }
    if (!H) return;
    memset(H, 0, (size_t)(nd * nd) * sizeof *H);
    const double t = f1 > 0.0 ? f1 / d : 0.0;
    for (int a = 0; a < 3; ++a)
        for (int b = 0; b < 3; ++b) {
            const double v = (f2 - t) * (n[a] * n[b]) + (a == b ? t : 0.0);
            H[(3 * i + a) * nd + 3 * i + b] = H[(3 * j + a) * nd + 3 * j + b] = v;
            H[(3 * i + a) * nd + 3 * j + b] = H[(3 * j + a) * nd + 3 * i + b] = -v;
        }
}

/* Point-line region: vertex p against the line through e0, e1 (indices into X, nd = 3 *
 * number of vertices), distance d, f1 = f'(d), f2 = f''(d). With u = p - e0, w = e1 - e0,
 * L = |w|, beta = u . w / L^2, the closest points' node weights c = (1, beta - 1, -beta),
 * k = (0, -1, 1) (w's), the frame e^ = w / L, n^ (from the line to p), b^ = e^ x n^, and
 * rho = dp - (1 - beta) de0 - beta de1, the expansion of d to second order is
 *   d + rho_n + (rho_b^2 - (d/L)^2 w_n^2 - 2 (d/L) w_n rho_e) / (2d),
 * so the Hessian of f(d) is f1/d |c|^2 on c^ (x) b^ alone, and a 3 x 3 matrix on
 * (h_1 (x) n^, h_2 (x) n^, c^ (x) e^): a 4-dimensional range, clamped there. */
static void pl_closed(const double *X, int nd, const int *nodes, double d, double f1,
                      double f2, double *g, double *H)
{
    const double *p = X + 3 * nodes[0], *e0 = X + 3 * nodes[1], *e1 = X + 3 * nodes[2];
    double u[3], w[3], nh[3], eh[3], bh[3];
    for (int k = 0; k < 3; ++k) u[k] = p[k] - e0[k], w[k] = e1[k] - e0[k];
    const double L2 = defsim__v3_dot(w, w), L = sqrt(L2), beta = defsim__v3_dot(u, w) / L2;
    for (int k = 0; k < 3; ++k) {
        nh[k] = (u[k] - beta * w[k]) / d;
        eh[k] = w[k] / L;
    }
    defsim__v3_cross(eh, nh, bh);
    const double c[3] = {1.0, beta - 1.0, -beta}, kk[3] = {0.0, -1.0, 1.0};
    if (g) {
        memset(g, 0, (size_t)nd * sizeof *g);
        for (int i = 0; i < 3; ++i)
            for (int q = 0; q < 3; ++q) g[3 * nodes[i] + q] = f1 * c[i] * nh[q];
    }
    if (!H) return;
    const double(*h)[4] = defsim__node_basis[3];
    const double cn = sqrt(c[0] * c[0] + c[1] * c[1] + c[2] * c[2]);
    double Cn[3] = {0, 0, 0}, Kn[3] = {0, 0, 0};
    for (int i = 0; i < 3; ++i) {
        Cn[0] += c[i] * h[0][i], Cn[1] += c[i] * h[1][i];
        Kn[0] += kk[i] * h[0][i], Kn[1] += kk[i] * h[1][i];
    }
    const double Ce[3] = {0.0, 0.0, cn};
    double M[9];
    for (int a = 0; a < 3; ++a)
        for (int b = 0; b <= a; ++b)
            M[3 * a + b] = M[3 * b + a] = f2 * Cn[a] * Cn[b] - f1 * d / L2 * Kn[a] * Kn[b] -
                                          f1 / L * (Kn[a] * Ce[b] + Ce[a] * Kn[b]);
    clamp_psd(3, M);
    const double lb = f1 > 0.0 ? f1 * cn * cn / d : 0.0;
    /* Q_i (3 x 4): h_1[i] n^, h_2[i] n^, c^_i e^, c^_i b^ */
    double Q[3][3][4];
    for (int i = 0; i < 3; ++i)
        for (int q = 0; q < 3; ++q) {
            Q[i][q][0] = h[0][i] * nh[q];
            Q[i][q][1] = h[1][i] * nh[q];
            Q[i][q][2] = c[i] / cn * eh[q];
            Q[i][q][3] = c[i] / cn * bh[q];
        }
    memset(H, 0, (size_t)(nd * nd) * sizeof *H);
    for (int i = 0; i < 3; ++i)
        for (int j = i; j < 3; ++j)
            for (int a = 0; a < 3; ++a)
                for (int b = i == j ? a : 0; b < 3; ++b) {
                    double s = lb * Q[i][a][3] * Q[j][b][3];
                    for (int x = 0; x < 3; ++x)
                        for (int y = 0; y < 3; ++y) s += Q[i][a][x] * M[3 * x + y] * Q[j][b][y];
                    H[(3 * nodes[i] + a) * nd + 3 * nodes[j] + b] = s;
                    H[(3 * nodes[j] + b) * nd + 3 * nodes[i] + a] = s;
                }
}

/* The three difference vectors of the plane formula as node weights over the 4 vertices:
 * r, c1, c2 with sigma = r . (c1 x c2) / |c1 x c2|. Point-plane: r = p - t0, c1 = t1 - t0,
 * c2 = t2 - t0; line-line: r = a0 - b0, c1 = a1 - a0, c2 = b1 - b0. */
static const double PLANE_MAP[2][3][4] = {
    {{1, -1, 0, 0}, {0, -1, 1, 0}, {0, -1, 0, 1}},
    {{1, 0, -1, 0}, {-1, 1, 0, 0}, {0, 0, -1, 1}},
};

static double wdot4(const double *a, const double *b)
{
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2] + a[3] * b[3];
}

/* Point-plane (ee = 0) or line-line (ee = 1) region of a 4-vertex constraint with the
 * difference vectors r, c1, c2 (PLANE_MAP), nu = |c1 x c2|, n^ = c1 x c2 / nu and
 * sigma = r . n^: the gradient of f(|sigma|) (f1 = f', f2 = f'' at d = |sigma|) into g (12) and
 * its clamped Hessian into H (144), either NULL.
 *
 * sigma's second-order expansion in the frame (t_a, t_b, n^) with perturbations dr, dc1, dc2
 * (subscript n: along n^, t: in the plane; J v = n^ x v; v = J (dc1_n c2 - dc2_n c1);
 * z = n^ . (dc1_t x c2 + c1 x dc2_t); r_t = r - sigma n^; nu = |c1 x c2|) is
 *   d2 sigma = (2/nu) [dr_t . v + r_t . (dc1_n J dc2_t - dc2_n J dc1_t)]
 *              - (2/nu^2) z (r_t . v) - (sigma/nu^2) |v|^2,
 * so the Hessian has no block within the plane and none along dr_n; in the basis
 * N_k = h_k (x) n^ (k < 3), T_a = w^ (x) t_a, T_b = w^ (x) t_b it is the 5 x 5 matrix below. */
static void plane_closed(int ee, double sig, double nu, const double nh[3],
                         const double r[3], const double c1[3], const double c2[3], double f1,
                         double f2, double *g, double *H)
{
    const double(*map)[4] = PLANE_MAP[ee];
    const double sg = sig > 0.0 ? 1.0 : -1.0;
    /* barycentric weights of the closest point: r_t = beta1 c1 + beta2 c2 */
    double m[3], rt[3];
    defsim__v3_cross(r, c2, m);
    const double beta1 = defsim__v3_dot(m, nh) / nu;
    defsim__v3_cross(c1, r, m);
    const double beta2 = defsim__v3_dot(m, nh) / nu;
    for (int k = 0; k < 3; ++k) rt[k] = r[k] - sig * nh[k];
    double w[4];
    for (int i = 0; i < 4; ++i) w[i] = map[0][i] - beta1 * map[1][i] - beta2 * map[2][i];
    if (g)
        for (int i = 0; i < 4; ++i)
            for (int k = 0; k < 3; ++k) g[3 * i + k] = f1 * sg * w[i] * nh[k];
    if (!H) return;
    const double W = sqrt(wdot4(w, w));
    double wh[4];
    for (int i = 0; i < 4; ++i) wh[i] = w[i] / W;
    /* in-plane frame */
    double ta[3], tb[3];
    const double l1 = sqrt(defsim__v3_dot(c1, c1));
    for (int k = 0; k < 3; ++k) ta[k] = c1[k] / l1;
    defsim__v3_cross(nh, ta, tb);
    const double *h[3] = {defsim__node_basis[4][0], defsim__node_basis[4][1],
                          defsim__node_basis[4][2]};
    double v[3][3], rv[3], G[3];
    for (int k = 0; k < 3; ++k) {
        const double m1 = wdot4(map[1], h[k]), m2 = wdot4(map[2], h[k]);
        double u[3];
        for (int c = 0; c < 3; ++c) u[c] = m1 * c2[c] - m2 * c1[c];
        defsim__v3_cross(nh, u, v[k]);
        rv[k] = -nu * (beta1 * m1 + beta2 * m2);
        G[k] = wdot4(w, h[k]);
    }
    /* in-plane directions: weights of w^ on r, c1, c2 */
    const double ar = wdot4(map[0], wh), a1 = wdot4(map[1], wh), a2 = wdot4(map[2], wh);
    double jr[3];
    defsim__v3_cross(nh, rt, jr);
    const double *t[2] = {ta, tb};
    double z[2], tj[2];
    for (int a = 0; a < 2; ++a) {
        double q1[3], q2[3];
        defsim__v3_cross(t[a], c2, q1);
        defsim__v3_cross(c1, t[a], q2);
        z[a] = a1 * defsim__v3_dot(nh, q1) + a2 * defsim__v3_dot(nh, q2);
        tj[a] = defsim__v3_dot(t[a], jr);
    }
    /* M = f2 G G^T + f1 sg K over (N_0, N_1, N_2, T_a, T_b) */
    double M[25];
    const double ks = f1 * sg;
    for (int k = 0; k < 3; ++k) {
        for (int l = 0; l <= k; ++l)
            M[5 * k + l] = M[5 * l + k] =
                f2 * G[k] * G[l] - ks * sig / (nu * nu) * defsim__v3_dot(v[k], v[l]);
        const double m1 = wdot4(map[1], h[k]), m2 = wdot4(map[2], h[k]);
        for (int a = 0; a < 2; ++a) {
            const double kt = (ar * defsim__v3_dot(t[a], v[k]) - (m1 * a2 - m2 * a1) * tj[a]) / nu -
                              z[a] * rv[k] / (nu * nu);
            M[5 * k + 3 + a] = M[5 * (3 + a) + k] = ks * kt;
        }
    }
    M[18] = M[19] = M[23] = M[24] = 0.0;
    clamp_psd(5, M);
    /* H = Q M Q^T with Q_i (3 x 5) the rows of node i */
    double Q[4][3][5], Z[4][3][5];
    for (int i = 0; i < 4; ++i)
        for (int c = 0; c < 3; ++c) {
            for (int k = 0; k < 3; ++k) Q[i][c][k] = h[k][i] * nh[c];
            Q[i][c][3] = wh[i] * ta[c];
            Q[i][c][4] = wh[i] * tb[c];
        }
    for (int i = 0; i < 4; ++i)
        for (int c = 0; c < 3; ++c)
            for (int q = 0; q < 5; ++q) {
                double s = 0.0;
                for (int p = 0; p < 5; ++p) s += Q[i][c][p] * M[5 * p + q];
                Z[i][c][q] = s;
            }
    for (int i = 0; i < 4; ++i)
        for (int j = i; j < 4; ++j)
            for (int a = 0; a < 3; ++a)
                for (int b = i == j ? a : 0; b < 3; ++b) {
                    double s = 0.0;
                    for (int q = 0; q < 5; ++q) s += Z[i][a][q] * Q[j][b][q];
                    H[(3 * i + a) * 12 + 3 * j + b] = H[(3 * j + b) * 12 + 3 * i + a] = s;
                }
}

/* ------------------------------------------------------------------------------------------ */

/* The closest features of the constraint (see defsim__pt_closest); VV: both vertices. */
static int closest(int type, const double *X, double *s, defsim__dtype *dt, int nodes[4])
{
    switch (type) {
    case DEFSIM__C_FV: return defsim__pt_closest(X, s, dt, nodes);
    case DEFSIM__C_EE: return defsim__ee_closest(X, s, dt, nodes);
    case DEFSIM__C_EV: return defsim__pe_closest(X, s, dt, nodes);
    default:
        *s = defsim__contact_dist2(type, X, NULL, NULL);
        *dt = DEFSIM__D_PP;
        nodes[0] = 0;
        nodes[1] = 1;
        return 2;
    }
}

double defsim__contact_barrier(int type, const double *X, double dh, double kap,
                               double eps_moll, double *g, double *H)
{
    return defsim__contact_barrier_offset(type, X, dh, 0.0, kap, eps_moll, 0, g, H);
}

double defsim__contact_barrier_offset(int type, const double *X, double dh, double xi,
                                      double kap, double eps_moll, int exact, double *g,
                                      double *H)
{
    const int m = defsim__contact_nodes(type);
    const int nd = 3 * m;
    /* the derivatives only for pairs within the band (most candidates are not); the exact
     * Hessian takes the distance's derivatives for every type, the projected one the closest
     * features' closed forms */
    defsim__dtype dt = DEFSIM__D_PP;
    int nodes[4];
    double s, gs[12], Hs[144];
    if (exact)
        s = defsim__contact_dist2(type, X, gs, H ? Hs : NULL);
    else
        closest(type, X, &s, &dt, nodes);
    const double reach = xi + dh;   /* dh itself at xi = 0 */
    if (!(s < reach * reach)) return 0.0;
    if (!(s > 0.0)) return INFINITY;
    const double d = sqrt(s);
    if (!(d > xi)) return INFINITY;
    /* the barrier on the distance beyond the offset; the geometry below keeps d itself */
    const double z = d - xi;
    const double e = kap * barrier(z, dh);
    if (!g && !H) {
        if (type == DEFSIM__C_EE)
            return e * defsim__ee_mollifier(X, X + 3, X + 6, X + 9, eps_moll, NULL, NULL);
        return e;
    }
    const double b1 = kap * barrier_d1(z, dh), b2 = kap * barrier_d2(z, dh);
    if (!exact) {
        const int moll = type == DEFSIM__C_EE &&
                         defsim__ee_mollifier(X, X + 3, X + 6, X + 9, eps_moll, NULL, NULL) < 1.0;
        if (!moll && dt == DEFSIM__D_PP) {
            vv_closed(X, nd, nodes[0], nodes[1], d, b1, b2, g, H);
            return e;
        }
        if (!moll && (dt == DEFSIM__D_PT || dt == DEFSIM__D_EE)) {
            const int ee = dt == DEFSIM__D_EE;
            const double(*map)[4] = PLANE_MAP[ee];
            double r[3], c1[3], c2[3], n[3], nh[3];
            for (int k = 0; k < 3; ++k) {
                double v[3] = {0, 0, 0};
                for (int i = 0; i < 4; ++i)
                    for (int q = 0; q < 3; ++q) v[q] += map[k][i] * X[3 * i + q];
                memcpy(k == 0 ? r : k == 1 ? c1 : c2, v, sizeof v);
            }
            defsim__v3_cross(c1, c2, n);
            const double nu = sqrt(defsim__v3_dot(n, n));
            for (int k = 0; k < 3; ++k) nh[k] = n[k] / nu;
            const double sig = defsim__v3_dot(r, nh);
            plane_closed(ee, sig, nu, nh, r, c1, c2, b1, b2, g, H);
            return e;
        }
        if (!moll && dt == DEFSIM__D_PE) {
            pl_closed(X, nd, nodes, d, b1, b2, g, H);
            return e;
        }
        /* the mollified edge-edge barrier: the chain rule below, then clamped */
        defsim__contact_dist2(type, X, gs, H ? Hs : NULL);
    }
    /* m kappa b(d - xi) (m = 1 but for edge-edge): its Hessian from the distance's and the
     * mollifier's derivatives; projected, clamped in the 9-dimensional translation-free
     * subspace (only the mollified edge-edge barrier comes here). */
    double gd[12], gm[12] = {0}, Hm[144] = {0};
    const double mo = type == DEFSIM__C_EE
                          ? defsim__ee_mollifier(X, X + 3, X + 6, X + 9, eps_moll, gm, H ? Hm : NULL)
                          : 1.0;
    for (int i = 0; i < nd; ++i) gd[i] = gs[i] / (2.0 * d);
    if (g)
        for (int i = 0; i < nd; ++i) g[i] = mo * (b1 * gd[i]) + e * gm[i];
    if (H) {
        /* d = sqrt(s): Hd = Hs / (2d) - gs gs^T / (4 d^3) */
        for (int i = 0; i < nd; ++i)
            for (int j = 0; j < nd; ++j) {
                const double hd = Hs[i * nd + j] / (2.0 * d) - gd[i] * gd[j] / d;
                H[i * nd + j] = mo * (b2 * gd[i] * gd[j] + b1 * hd) + b1 * gd[i] * gm[j] +
                                gm[i] * b1 * gd[j] + e * Hm[i * nd + j];
            }
        static const int all[4] = {0, 1, 2, 3};
        if (!exact) defsim__project_psd_nodes(12, H, 4, all, DEFSIM_PROJECTION_CLAMP);
    }
    return mo * e;
}
