/* SPDX-License-Identifier: MIT */
/*
 * Cloth and shells (shell.h; docs/shells.md): the membrane laws on a triangle's 3x2
 * deformation gradient, the discrete-shell hinge with its exact derivatives, and the rest rules
 * (frames, parameters, hinge weights) that body.c and plan.c share.
 */
#include "shell.h"

#include "defsim/defsim.h"
#include "mat3.h"

#include <math.h>
#include <string.h>

static double dot3(const double *a, const double *b)
{
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}

static void cross3(const double *a, const double *b, double *c)
{
    c[0] = a[1] * b[2] - a[2] * b[1];
    c[1] = a[2] * b[0] - a[0] * b[2];
    c[2] = a[0] * b[1] - a[1] * b[0];
}

int defsim__shell_frame(const double *p0, const double *p1, const double *p2,
                        const double warp[3], int need_warp, double dminv[4], double *area,
                        double frame[6])
{
    double d1[3], d2[3], n[3], t1[3], t2[3];
    for (int i = 0; i < 3; ++i) d1[i] = p1[i] - p0[i], d2[i] = p2[i] - p0[i];
    cross3(d1, d2, n);
    const double nn = sqrt(dot3(n, n));
    double l2 = dot3(d1, d1);
    const double l22 = dot3(d2, d2);
    double d3[3] = {d2[0] - d1[0], d2[1] - d1[1], d2[2] - d1[2]};
    if (l22 > l2) l2 = l22;
    if (dot3(d3, d3) > l2) l2 = dot3(d3, d3);
    *area = 0.5 * nn;
    if (!(0.5 * nn > 1e-12 * l2)) return 1;
    for (int i = 0; i < 3; ++i) n[i] /= nn;
    const double wn = sqrt(dot3(warp, warp)), wd = dot3(warp, n);
    for (int i = 0; i < 3; ++i) t1[i] = warp[i] - wd * n[i];
    double tl = sqrt(dot3(t1, t1));
    if (!(tl > 1e-3 * wn)) {
        if (need_warp) return 2;
        memcpy(t1, d1, sizeof t1);
        tl = sqrt(dot3(t1, t1));
    }
    for (int i = 0; i < 3; ++i) t1[i] /= tl;
    cross3(n, t1, t2);
    const double m00 = dot3(d1, t1), m01 = dot3(d2, t1), m10 = dot3(d1, t2), m11 = dot3(d2, t2);
    const double det = m00 * m11 - m01 * m10;
    dminv[0] = m11 / det;
    dminv[1] = -m01 / det;
    dminv[2] = -m10 / det;
    dminv[3] = m00 / det;
    if (frame) memcpy(frame, t1, sizeof t1), memcpy(frame + 3, t2, sizeof t2);
    return 0;
}

int defsim__membrane_params(int32_t model, double E, double nu, double t, double y1, double y2,
                            double g, double nu12, double prm[4])
{
    const double mu = E * t / (2.0 * (1.0 + nu)), la = E * t * nu / (1.0 - nu * nu);
    switch (model) {
    case DEFSIM_SHELL_MEMBRANE_STVK:
        prm[0] = prm[2] = la + 2.0 * mu;
        prm[1] = la;
        prm[3] = mu;
        return DEFSIM__MEMBRANE_STVK;
    case DEFSIM_SHELL_MEMBRANE_NEOHOOKEAN:
        prm[0] = mu;
        prm[1] = la;
        prm[2] = prm[3] = 0.0;
        return DEFSIM__MEMBRANE_NEOHOOKEAN;
    case DEFSIM_SHELL_MEMBRANE_ORTHOTROPIC_STVK: {
        const double den = 1.0 - nu12 * nu12 * y2 / y1;
        prm[0] = y1 / den;
        prm[1] = nu12 * y2 / den;
        prm[2] = y2 / den;
        prm[3] = g;
        return DEFSIM__MEMBRANE_STVK;
    }
    default:
        return -1;
    }
}

/* S = C : E of the StVK law (2x2 symmetric, row-major) for the Green strain E. */
static void stvk_stress(const double prm[4], const double E[4], double S[4])
{
    S[0] = prm[0] * E[0] + prm[1] * E[3];
    S[3] = prm[1] * E[0] + prm[2] * E[3];
    S[1] = S[2] = 2.0 * prm[3] * E[1];
}

/* C = F^T F (2x2 row-major) of a 3x2 F. */
static void right_cauchy(const double F[6], double C[4])
{
    DEFSIM__TRI_CAUCHY(F, C);
}

/* out (3x2) = F (3x2) M (2x2). */
static void f_times(const double F[6], const double M[4], double out[6])
{
    DEFSIM__TRI_FTIMES(F, M, out);
}

/* dP/dF (6x6) of P = F S(C): dP = dF S + F dS, dS = dSdC(dC) with dC = dF^T F + F^T dF, column
 * by column of dF = e_k e_l^T (the StVK law and the strain limit's barrier). */
typedef void (*dsdc_fn)(const void *ctx, const double dC[4], double dS[4]);

static void tangent(const double F[6], const double S[4], dsdc_fn dsdc, const void *ctx,
                    double D[36])
{
    for (int k = 0; k < 3; ++k)
        for (int l = 0; l < 2; ++l) {
            double dC[4], dS[4], FdS[6];
            for (int p = 0; p < 2; ++p)
                for (int q = 0; q < 2; ++q)
                    dC[2 * p + q] =
                        (p == l ? F[2 * k + q] : 0.0) + (q == l ? F[2 * k + p] : 0.0);
            dsdc(ctx, dC, dS);
            f_times(F, dS, FdS);
            for (int i = 0; i < 3; ++i)
                for (int j = 0; j < 2; ++j)
                    D[6 * (2 * i + j) + 2 * k + l] = (i == k ? S[2 * l + j] : 0.0) + FdS[2 * i + j];
        }
}

/* StVK: dS = C : dE, dE = dC / 2. */
static void stvk_dsdc(const void *prm, const double dC[4], double dS[4])
{
    const double dE[4] = {0.5 * dC[0], 0.5 * dC[1], 0.5 * dC[2], 0.5 * dC[3]};
    stvk_stress(prm, dE, dS);
}

static double stvk_law(const double prm[4], const double F[6], double P[6], double D[36])
{
    double C[4], E[4], S[4];
    right_cauchy(F, C);
    E[0] = 0.5 * (C[0] - 1.0);
    E[1] = E[2] = 0.5 * C[1];
    E[3] = 0.5 * (C[3] - 1.0);
    stvk_stress(prm, E, S);
    const double psi = 0.5 * (prm[0] * E[0] * E[0] + 2.0 * prm[1] * E[0] * E[3] +
                              prm[2] * E[3] * E[3]) + 2.0 * prm[3] * E[1] * E[1];
    if (P) f_times(F, S, P);
    if (D) tangent(F, S, stvk_dsdc, prm, D);
    return psi;
}

static double neohookean_law(const double prm[4], const double F[6], double P[6], double D[36])
{
    const double mu = prm[0], la = prm[1];
    double C[4];
    right_cauchy(F, C);
    const double detc = C[0] * C[3] - C[1] * C[2];
    if (!(detc > 0.0)) return INFINITY;
    const double lj = 0.5 * log(detc);
    const double Ci[4] = {C[3] / detc, -C[1] / detc, -C[2] / detc, C[0] / detc};
    double FC[6];   /* F C^-1 = d log J / dF */
    f_times(F, Ci, FC);
    const double psi = 0.5 * mu * (C[0] + C[3] - 2.0) - mu * lj + 0.5 * la * lj * lj;
    const double c = la * lj - mu;
    if (P)
        for (int i = 0; i < 6; ++i) P[i] = mu * F[i] + c * FC[i];
    if (D)
        /* dP = mu dF + la (FC : dF) FC + c (dF C^-1 + F dC^-1), dC^-1 = -C^-1 dC C^-1. */
        for (int k = 0; k < 3; ++k)
            for (int l = 0; l < 2; ++l) {
                double dC[4], t[4], dCi[4], FdCi[6];
                for (int p = 0; p < 2; ++p)
                    for (int q = 0; q < 2; ++q)
                        dC[2 * p + q] = (p == l ? F[2 * k + q] : 0.0) + (q == l ? F[2 * k + p] : 0.0);
                for (int p = 0; p < 2; ++p)
                    for (int q = 0; q < 2; ++q)
                        t[2 * p + q] = dC[2 * p] * Ci[q] + dC[2 * p + 1] * Ci[2 + q];
                for (int p = 0; p < 2; ++p)
                    for (int q = 0; q < 2; ++q)
                        dCi[2 * p + q] = -(Ci[2 * p] * t[q] + Ci[2 * p + 1] * t[2 + q]);
                f_times(F, dCi, FdCi);
                const double dlj = FC[2 * k + l];
                for (int i = 0; i < 3; ++i)
                    for (int j = 0; j < 2; ++j)
                        D[6 * (2 * i + j) + 2 * k + l] =
                            (i == k && j == l ? mu : 0.0) + la * dlj * FC[2 * i + j] +
                            c * ((i == k ? Ci[2 * l + j] : 0.0) + FdCi[2 * i + j]);
            }
    return psi;
}

double defsim__membrane_law(int law, const double prm[4], const double F[6], double P[6],
                            double D[36])
{
    return law == DEFSIM__MEMBRANE_NEOHOOKEAN ? neohookean_law(prm, F, P, D)
                                              : stvk_law(prm, F, P, D);
}

/* A triangle's shape gradients g (F = sum_a x_a g_a^T: g_1, g_2 the rows of Dm^-1,
 * g_0 = -(g_1 + g_2)) and F (3x2) at its vertices X (3x3). */
static void triangle_f(const double m[4], const double X[9], double g[3][2], double F[6])
{
    DEFSIM__TRI_SHAPE(m, g);
#define XA(a, i) X[3 * (a) + (i)]
    DEFSIM__TRI_F(XA, g, F);
#undef XA
}

/* An element's gradient A P g_a and Hessian A g_a^T D g_b (D projected by proj first), where
 * not NULL, from a law's P and dP/dF at its F. */
static void triangle_map(const double g[3][2], double area, const double P[6], double D[36],
                         double grad[9], double H[81], int proj)
{
    if (grad)
        for (int a = 0; a < 3; ++a)
            for (int i = 0; i < 3; ++i)
                grad[3 * a + i] = area * (P[2 * i] * g[a][0] + P[2 * i + 1] * g[a][1]);
    if (H) {
        defsim__project_psd(6, D, proj);
        for (int a = 0; a < 3; ++a)
            for (int i = 0; i < 3; ++i)
                for (int b = 0; b < 3; ++b)
                    for (int k = 0; k < 3; ++k) {
                        double s = 0.0;
                        for (int j = 0; j < 2; ++j)
                            for (int l = 0; l < 2; ++l)
                                s += g[a][j] * D[6 * (2 * i + j) + 2 * k + l] * g[b][l];
                        H[9 * (3 * a + i) + 3 * b + k] = area * s;
                    }
    }
}

double defsim__membrane_element(int law, const double row[DEFSIM__MEMBRANE_WIDTH], double area,
                                const double X[9], double grad[9], double H[81], int proj)
{
    double g[3][2], F[6], P[6], D[36];
    triangle_f(row, X, g, F);
    const double psi = defsim__membrane_law(law, row + 4, F, grad ? P : NULL, H ? D : NULL);
    if (!isfinite(psi)) return INFINITY;
    triangle_map(g, area, P, D, grad, H, proj);
    return area * psi;
}

/* ------------------------------------------------------------------------------------------ */
/* The strain limit */

void defsim__strain_limit_row(int law, const double mrow[DEFSIM__MEMBRANE_WIDTH], double cap,
                              double out[DEFSIM__MEMBRANE_WIDTH])
{
    const double *prm = mrow + 4;
    memcpy(out, mrow, 4 * sizeof *out);
    out[4] = 1.0 + cap;
    out[5] = DEFSIM__STRAIN_LIMIT_BAND * cap;
    out[6] = law == DEFSIM__MEMBRANE_NEOHOOKEAN ? 2.0 * prm[0] + prm[1] : fmax(prm[0], prm[2]);
    out[7] = 0.0;
}

/* The eigenvalues l1 >= l2 of a 2x2 symmetric C and the unit eigenvector v1 of l1 (v2 is its
 * perpendicular (-v1[1], v1[0])). */
static void sym2_eigen(const double C[4], double *l1, double *l2, double v1[2])
{
    const double m = 0.5 * (C[0] + C[3]), h = 0.5 * (C[0] - C[3]);
    const double r = sqrt(h * h + C[1] * C[1]);
    *l1 = m + r;
    *l2 = m - r;
    /* the columns of C - l2 I are parallel to v1: the longer one */
    double a[2] = {C[0] - *l2, C[1]}, b[2] = {C[1], C[3] - *l2};
    const double na = a[0] * a[0] + a[1] * a[1], nb = b[0] * b[0] + b[1] * b[1];
    const double *c = na >= nb ? a : b;
    const double n = sqrt(na >= nb ? na : nb);
    if (n > 0.0) v1[0] = c[0] / n, v1[1] = c[1] / n;
    else v1[0] = 1.0, v1[1] = 0.0;
}

double defsim__membrane_stretch(const double F[6])
{
    double C[4], l1, l2, v[2];
    right_cauchy(F, C);
    sym2_eigen(C, &l1, &l2, v);
    return sqrt(fmax(l1, 0.0));
}

/* One singular value's barrier g(lambda) = kappa b(c - sqrt(lambda)) (lambda = sigma^2) with
 * b(d) = -(d - delta)^2 log(d / delta) on 0 < d < delta: g, g' and g'' in lambda. */
static double limit_g(double c, double delta, double kappa, double lambda, double *g1, double *g2)
{
    const double s = sqrt(lambda), d = c - s, u = d - delta, lg = log(d / delta);
    const double b = -u * u * lg;
    const double b1 = -2.0 * u * lg - u * u / d;
    const double b2 = -2.0 * lg - 4.0 * u / d + u * u / (d * d);
    const double f1 = -kappa * b1, f2 = kappa * b2;   /* d/dsigma, d2/dsigma2 */
    *g1 = f1 / (2.0 * s);
    *g2 = (f2 * s - f1) / (4.0 * s * s * s);
    return kappa * b;
}

/* The barrier's dS = 2 dPsi_C(dC) in C's eigenbasis. */
typedef struct limit_tangent {
    double v1[2], v2[2], h1, h2, dd;
} limit_tangent;

static void limit_dsdc(const void *ctx, const double dC[4], double dS[4])
{
    const limit_tangent *t = ctx;
    const double *v1 = t->v1, *v2 = t->v2;
    const double cv1[2] = {dC[0] * v1[0] + dC[1] * v1[1], dC[2] * v1[0] + dC[3] * v1[1]};
    const double cv2[2] = {dC[0] * v2[0] + dC[1] * v2[1], dC[2] * v2[0] + dC[3] * v2[1]};
    const double a = v1[0] * cv1[0] + v1[1] * cv1[1], b = v2[0] * cv2[0] + v2[1] * cv2[1];
    const double c = v1[0] * cv2[0] + v1[1] * cv2[1];
    for (int p = 0; p < 2; ++p)
        for (int q = 0; q < 2; ++q)
            dS[2 * p + q] = 2.0 * (t->h1 * a * v1[p] * v1[q] + t->h2 * b * v2[p] * v2[q] +
                                   t->dd * c * (v1[p] * v2[q] + v2[p] * v1[q]));
}

double defsim__strain_limit_law(const double prm[3], const double F[6], double P[6],
                                double D[36], int *active)
{
    const double c = prm[0], delta = prm[1], kappa = prm[2];
    double C[4], l[2], v1[2];
    right_cauchy(F, C);
    sym2_eigen(C, &l[0], &l[1], v1);
    *active = 0;
    const double s1 = sqrt(fmax(l[0], 0.0));
    if (!(s1 < c)) return INFINITY;
    double psi = 0.0, g1[2] = {0.0, 0.0}, g2[2] = {0.0, 0.0};
    for (int i = 0; i < 2; ++i)
        if (c - sqrt(fmax(l[i], 0.0)) < delta) {
            psi += limit_g(c, delta, kappa, l[i], &g1[i], &g2[i]);
            *active = 1;
        }
    if (!*active) return 0.0;
    limit_tangent t = {{v1[0], v1[1]}, {-v1[1], v1[0]}, g2[0], g2[1], 0.0};
    /* Psi_C = g'_1 v1 v1^T + g'_2 v2 v2^T, S = 2 Psi_C, P = F S */
    double S[4];
    for (int p = 0; p < 2; ++p)
        for (int q = 0; q < 2; ++q)
            S[2 * p + q] = 2.0 * (g1[0] * t.v1[p] * t.v1[q] + g1[1] * t.v2[p] * t.v2[q]);
    if (P) f_times(F, S, P);
    if (D) {
        /* the divided difference (g'_1 - g'_2) / (l1 - l2), g'' where they (nearly) meet */
        const double dl = l[0] - l[1];
        t.dd = dl > 1e-8 * l[0] ? (g1[0] - g1[1]) / dl : 0.5 * (g2[0] + g2[1]);
        tangent(F, S, limit_dsdc, &t, D);
    }
    return psi;
}

double defsim__strain_limit_element(const double row[DEFSIM__MEMBRANE_WIDTH], double area,
                                    const double X[9], double grad[9], double H[81], int proj,
                                    int *active)
{
    double g[3][2], F[6], P[6], D[36];
    triangle_f(row, X, g, F);
    const double psi = defsim__strain_limit_law(row + 4, F, grad ? P : NULL, H ? D : NULL,
                                                active);
    if (!isfinite(psi)) return INFINITY;
    if (*active) triangle_map(g, area, P, D, grad, H, proj);
    return area * psi;
}

double defsim__strain_limit_step(const double row[DEFSIM__MEMBRANE_WIDTH], const double X[9],
                                 const double dX[9])
{
    /* sigma_max(F0 + a dF) is a norm of an affine function of a, convex in a: below the cap at
     * a = 0 and at a = 1 it is below it all the way; otherwise it crosses once, at r (found by
     * bisection), and every a < r is below it. */
    double g[3][2], F0[6], dF[6];
    const double c = row[4];
    triangle_f(row, X, g, F0);
    triangle_f(row, dX, g, dF);
    double F[6];
    for (int i = 0; i < 6; ++i) F[i] = F0[i] + dF[i];
    if (defsim__membrane_stretch(F) < c) return 1.0;
    if (!(defsim__membrane_stretch(F0) < c)) return 0.0;
    double lo = 0.0, hi = 1.0;
    for (int it = 0; it < 60 && hi - lo > 1e-15; ++it) {
        const double mid = 0.5 * (lo + hi);
        for (int i = 0; i < 6; ++i) F[i] = F0[i] + mid * dF[i];
        if (defsim__membrane_stretch(F) < c) lo = mid;
        else hi = mid;
    }
    return DEFSIM__STRAIN_LIMIT_STEP * lo;
}

/* ------------------------------------------------------------------------------------------ */
/* The hinge */

/* A hinge's edge e = x1 - x0 and wings a = x2 - x0, b = x3 - x0. */
static void hinge_vectors(const double X[12], double e[3], double a[3], double b[3])
{
    for (int i = 0; i < 3; ++i) {
        e[i] = X[3 + i] - X[i];
        a[i] = X[6 + i] - X[i];
        b[i] = X[9 + i] - X[i];
    }
}

/* Derivatives over u = (e, a, b) in R^9. */
double defsim__hinge_angle(const double X[12], double gout[12], double Hout[144])
{
    double e[3], a[3], b[3], axb[3], bxe[3], exa[3];
    hinge_vectors(X, e, a, b);
    cross3(a, b, axb);
    cross3(b, e, bxe);
    cross3(e, a, exa);
    const double s = dot3(e, e), L = sqrt(s), tau = dot3(e, axb);
    const double p = dot3(e, a), q = dot3(e, b), r = dot3(a, b);
    const double y = -L * tau, x = p * q - s * r;
    const double theta = atan2(y, x);
    if (!gout && !Hout) return theta;

    /* Gradients over u: tau, L, p, q, s, r. */
    double gt[9], gL[9] = {0}, gp[9] = {0}, gq[9] = {0}, gs[9] = {0}, gr[9] = {0};
    for (int i = 0; i < 3; ++i) {
        gt[i] = axb[i]; gt[3 + i] = bxe[i]; gt[6 + i] = exa[i];
        gL[i] = e[i] / L;
        gp[i] = a[i]; gp[3 + i] = e[i];
        gq[i] = b[i]; gq[6 + i] = e[i];
        gs[i] = 2.0 * e[i];
        gr[3 + i] = b[i]; gr[6 + i] = a[i];
    }
    double gy[9], gx[9];
    for (int i = 0; i < 9; ++i) {
        gy[i] = -(tau * gL[i] + L * gt[i]);
        gx[i] = q * gp[i] + p * gq[i] - r * gs[i] - s * gr[i];
    }
    const double r2 = x * x + y * y;
    double gth[9];
    for (int i = 0; i < 9; ++i) gth[i] = (x * gy[i] - y * gx[i]) / r2;
    /* d/dX of u: e = x1 - x0, a = x2 - x0, b = x3 - x0. */
    if (gout) {
        for (int i = 0; i < 3; ++i) {
            gout[3 + i] = gth[i];
            gout[6 + i] = gth[3 + i];
            gout[9 + i] = gth[6 + i];
            gout[i] = -(gth[i] + gth[3 + i] + gth[6 + i]);
        }
    }
    if (!Hout) return theta;

    /* Hessians over u. tau = e . (a x b): d2/de_i da_j = eps_ijk b_k, d2/da_j db_k =
     * eps_ijk e_i, d2/de_i db_k = eps_ijk a_j. */
    double Ht[81] = {0}, HL[81] = {0}, Hx[81], Hy[81], Hth[81];
    static const int eps[3][3][3] = {{{0, 0, 0}, {0, 0, 1}, {0, -1, 0}},
                                     {{0, 0, -1}, {0, 0, 0}, {1, 0, 0}},
                                     {{0, 1, 0}, {-1, 0, 0}, {0, 0, 0}}};
    for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j)
            for (int k = 0; k < 3; ++k) {
                const double v = eps[i][j][k];
                if (v == 0.0) continue;
                Ht[9 * i + 3 + j] += v * b[k]; Ht[9 * (3 + j) + i] += v * b[k];
                Ht[9 * (3 + j) + 6 + k] += v * e[i]; Ht[9 * (6 + k) + 3 + j] += v * e[i];
                Ht[9 * i + 6 + k] += v * a[j]; Ht[9 * (6 + k) + i] += v * a[j];
            }
    for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j) HL[9 * i + j] = ((i == j ? 1.0 : 0.0) - e[i] * e[j] / s) / L;
    for (int i = 0; i < 9; ++i)
        for (int j = 0; j < 9; ++j) {
            const int ij = 9 * i + j;
            Hy[ij] = -(tau * HL[ij] + gL[i] * gt[j] + gt[i] * gL[j] + L * Ht[ij]);
            /* x = p q - s r: the Hessians of p, q (e-a, e-b blocks of I), s (2I on e-e), r (a-b). */
            const int bi = i / 3, bj = j / 3, same = i % 3 == j % 3;
            double hp = same && ((bi == 0 && bj == 1) || (bi == 1 && bj == 0)) ? 1.0 : 0.0;
            double hq = same && ((bi == 0 && bj == 2) || (bi == 2 && bj == 0)) ? 1.0 : 0.0;
            double hs = same && bi == 0 && bj == 0 ? 2.0 : 0.0;
            double hr = same && ((bi == 1 && bj == 2) || (bi == 2 && bj == 1)) ? 1.0 : 0.0;
            Hx[ij] = gp[i] * gq[j] + gq[i] * gp[j] + q * hp + p * hq - gr[i] * gs[j] -
                     gs[i] * gr[j] - r * hs - s * hr;
        }
    /* theta = atan2(y, x): H = (x Hy - y Hx + gx gy^T - gy gx^T) / r2
     *                          - (x gy - y gx)(2 x gx + 2 y gy)^T / r2^2, symmetrised. */
    for (int i = 0; i < 9; ++i)
        for (int j = 0; j < 9; ++j) {
            const double h1 = (x * Hy[9 * i + j] - y * Hx[9 * i + j]) / r2;
            const double hij = -gth[i] * 2.0 * (x * gx[j] + y * gy[j]) / r2;
            const double hji = -gth[j] * 2.0 * (x * gx[i] + y * gy[i]) / r2;
            Hth[9 * i + j] = h1 + 0.5 * (hij + hji);
        }
    /* To X: H_X = J^T H_u J with J = [[-I, I, 0, 0], [-I, 0, I, 0], [-I, 0, 0, I]]: block (A, B)
     * of H_X (A, B = 0..3, each 3 x 3) is Hth's block (A - 1, B - 1) for A, B >= 1, minus the sum
     * of Hth's blocks over the index that is 0, and the sum of all nine blocks for A = B = 0
     * (summed in the same order as the full product, so the figures are those of J^T H J). */
    for (int i = 0; i < 3; ++i)
        for (int k = 0; k < 3; ++k) {
            double v00 = 0.0;
            for (int ua = 0; ua < 3; ++ua)
                for (int ub = 0; ub < 3; ++ub) v00 += Hth[9 * (3 * ua + i) + 3 * ub + k];
            Hout[12 * i + k] = v00;
            for (int B = 1; B < 4; ++B) {
                double row = 0.0, col = 0.0;
                for (int u = 0; u < 3; ++u) {
                    row += -Hth[9 * (3 * u + i) + 3 * (B - 1) + k];
                    col += -Hth[9 * (3 * (B - 1) + i) + 3 * u + k];
                }
                Hout[12 * i + 3 * B + k] = row;
                Hout[12 * (3 * B + i) + k] = col;
                for (int A = 1; A < 4; ++A)
                    Hout[12 * (3 * A + i) + 3 * B + k] = Hth[9 * (3 * (A - 1) + i) + 3 * (B - 1) + k];
            }
        }
    return theta;
}

double defsim__hinge_delta(double theta, double theta0)
{
    const double pi = 3.14159265358979323846;
    double d = theta - theta0;
    if (d > pi) d -= 2.0 * pi;
    else if (d <= -pi) d += 2.0 * pi;
    return d;
}

double defsim__hinge_element(double w, double theta0, const double X[12], double grad[12],
                             double H[144], int proj)
{
    double g[12];
    const double th = defsim__hinge_angle(X, (grad || H) ? g : NULL, H);
    const double d = defsim__hinge_delta(th, theta0);
    if (grad)
        for (int i = 0; i < 12; ++i) grad[i] = w * d * g[i];
    if (H) {
        for (int i = 0; i < 12; ++i)
            for (int j = 0; j < 12; ++j) H[12 * i + j] = w * (g[i] * g[j] + d * H[12 * i + j]);
        /* the angle does not change when the four vertices translate */
        static const int all[4] = {0, 1, 2, 3};
        defsim__project_psd_nodes(12, H, 4, all, proj);
    }
    return 0.5 * w * d * d;
}

int defsim__hinge_rest(const double X[12], const double warp[3], double d_warp, double d_weft,
                       double *w, double *theta0)
{
    double e[3], a[3], b[3], n1[3], n2[3];
    hinge_vectors(X, e, a, b);
    cross3(e, a, n1);
    cross3(b, e, n2);
    const double A1 = 0.5 * sqrt(dot3(n1, n1)), A2 = 0.5 * sqrt(dot3(n2, n2)), s = dot3(e, e);
    if (!(A1 > 1e-12 * s) || !(A2 > 1e-12 * s)) return 1;
    double D = d_warp;
    if (d_weft != d_warp) {
        /* The bending direction: across the edge in the hinge's mean rest plane. */
        double n[3], c[3], wp[3];
        for (int i = 0; i < 3; ++i) n[i] = n1[i] / (2.0 * A1) + n2[i] / (2.0 * A2);
        const double nl = sqrt(dot3(n, n));
        if (!(nl > 1e-6)) return 1;   /* folded flat at rest: no plane */
        for (int i = 0; i < 3; ++i) n[i] /= nl;
        const double wd = dot3(warp, n), wn = sqrt(dot3(warp, warp));
        for (int i = 0; i < 3; ++i) wp[i] = warp[i] - wd * n[i];
        const double wl = sqrt(dot3(wp, wp));
        if (!(wl > 1e-3 * wn)) return 2;
        cross3(n, e, c);
        const double c2 = dot3(c, wp) * dot3(c, wp) / (dot3(c, c) * wl * wl);
        D = d_warp * c2 + d_weft * (1.0 - c2);
    }
    *w = D * s / (A1 + A2);
    *theta0 = defsim__hinge_angle(X, NULL, NULL);
    return 0;
}
