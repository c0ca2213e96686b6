/* SPDX-License-Identifier: MIT */
/*
 * The 10-node tetrahedron (tet10.h). Quadrature: the stiffness rule is the 4-point degree-2
 * rule (positive weights 1/24): P2 displacements give an F linear in xi on straight elements, so
 * the linear-elastic integrands (stress times gradient) are quadratic and integrated exactly; for
 * hyperelastic laws degree 2 = 2p - 2 is what optimal H1 convergence asks of a rule (Ciarlet,
 * Strang's lemma), its 4 x 6 = 24 strain samples equal the element's 30 - 6 non-rigid modes (no
 * spurious zero-energy modes), and its positive weights keep the element Hessian positive
 * semi-definite when each point's dP/dF is projected. The mass needs N_a^2 (degree 4) and the
 * volume of a curved element det(dX/dxi) (degree 3): Walkington's 14-point degree-5 rule, all
 * weights positive.
 */
#include "tet10.h"

#include "mat3.h"
#include "material.h"
#include "system.h"

#include <math.h>
#include <string.h>

const int defsim__tet10_edge[6][2] = {{0, 1}, {1, 2}, {0, 2}, {0, 3}, {1, 3}, {2, 3}};

static double rule2_pts[4 * 4], rule2_w[4], rule5_pts[14 * 4], rule5_w[14];
static int rules_ready;

/* The rules' points from their generators (filled once; idempotent, so a race writes the same
 * values). */
static void rules_init(void)
{
    if (rules_ready) return;
    const double a = (5.0 - sqrt(5.0)) / 20.0;
    for (int q = 0; q < 4; ++q) {
        for (int c = 0; c < 4; ++c) rule2_pts[4 * q + c] = c == q ? 1.0 - 3.0 * a : a;
        rule2_w[q] = 1.0 / 24.0;
    }
    /* Walkington (2000), "Quadrature on simplices of arbitrary dimension": 14 points, degree 5. */
    static const double a1 = 0.0927352503108912264, w1 = 0.0122488405193936582;
    static const double a2 = 0.3108859192633006097, w2 = 0.0187813209530026417;
    static const double b3 = 0.0455037041256496494, w3 = 0.0070910034628469110;
    int q = 0;
    for (int s = 0; s < 2; ++s) {
        const double g = s ? a2 : a1, w = s ? w2 : w1;
        for (int k = 0; k < 4; ++k, ++q) {
            for (int c = 0; c < 4; ++c) rule5_pts[4 * q + c] = c == k ? 1.0 - 3.0 * g : g;
            rule5_w[q] = w;
        }
    }
    for (int e = 0; e < 6; ++e, ++q) {
        const int i = defsim__tet10_edge[e][0], j = defsim__tet10_edge[e][1];
        for (int c = 0; c < 4; ++c) rule5_pts[4 * q + c] = c == i || c == j ? b3 : 0.5 - b3;
        rule5_w[q] = w3;
    }
    rules_ready = 1;
}

int defsim__tet10_rule(int degree, const double **pts, const double **w)
{
    rules_init();
    if (degree == 2) { *pts = rule2_pts; *w = rule2_w; return 4; }
    if (degree == 5) { *pts = rule5_pts; *w = rule5_w; return 14; }
    return 0;
}

void defsim__tet10_shape(const double L[4], double N[10], double dN[10][3])
{
    /* dN/dxi_k = dN/dL_k - dN/dL_3 (xi = L0, L1, L2; L3 dependent). */
    double dL[10][4];
    memset(dL, 0, sizeof dL);
    for (int a = 0; a < 4; ++a) {
        N[a] = L[a] * (2.0 * L[a] - 1.0);
        dL[a][a] = 4.0 * L[a] - 1.0;
    }
    for (int e = 0; e < 6; ++e) {
        const int i = defsim__tet10_edge[e][0], j = defsim__tet10_edge[e][1];
        N[4 + e] = 4.0 * L[i] * L[j];
        dL[4 + e][i] = 4.0 * L[j];
        dL[4 + e][j] = 4.0 * L[i];
    }
    for (int a = 0; a < 10; ++a)
        for (int k = 0; k < 3; ++k) dN[a][k] = dL[a][k] - dL[a][3];
}

void defsim__tet10_flip(int32_t tet[10])
{
    int32_t t = tet[0]; tet[0] = tet[1]; tet[1] = t;
    t = tet[5]; tet[5] = tet[6]; tet[6] = t;
    t = tet[7]; tet[7] = tet[8]; tet[8] = t;
}

/* J = dX/dxi at barycentric L: J[3 i + k] = sum_a X_a[i] dN_a/dxi_k. */
static void jacobian(const double *pos, const int32_t *tet, const double L[4], double J[9],
                     double N[10], double dN[10][3])
{
    defsim__tet10_shape(L, N, dN);
    memset(J, 0, 9 * sizeof *J);
    for (int a = 0; a < 10; ++a) {
        const double *p = pos + 3 * (int64_t)tet[a];
        for (int i = 0; i < 3; ++i)
            for (int k = 0; k < 3; ++k) J[3 * i + k] += p[i] * dN[a][k];
    }
}

double defsim__tet10_min_jacobian(const double *pos, const int32_t tet[10])
{
    double dm[9];
    const double *p3 = pos + 3 * (int64_t)tet[3];
    for (int a = 0; a < 3; ++a)
        for (int i = 0; i < 3; ++i) dm[3 * i + a] = pos[3 * (int64_t)tet[a] + i] - p3[i];
    const double d0 = defsim__m3_det(dm);
    if (!(d0 > 0.0)) return d0 < 0.0 ? -1.0 : 0.0;
    const double *pts, *w;
    const int nq = defsim__tet10_rule(2, &pts, &w);
    double lo = INFINITY;
    for (int p = 0; p < 4 + 6 + 1 + nq; ++p) {
        double L[4] = {0.0, 0.0, 0.0, 0.0};
        if (p < 4) L[p] = 1.0;
        else if (p < 10) L[defsim__tet10_edge[p - 4][0]] = L[defsim__tet10_edge[p - 4][1]] = 0.5;
        else if (p == 10) L[0] = L[1] = L[2] = L[3] = 0.25;
        else memcpy(L, pts + 4 * (p - 11), sizeof L);
        double J[9], N[10], dN[10][3];
        jacobian(pos, tet, L, J, N, dN);
        const double r = defsim__m3_det(J) / d0;
        if (!(r >= lo)) lo = r;   /* NaN propagates */
    }
    return lo;
}

double defsim__tet10_rest(const double *pos, const int32_t tet[10], double *rest)
{
    const double *pts, *w;
    const int nq = defsim__tet10_rule(2, &pts, &w);
    for (int q = 0; q < nq; ++q) {
        double J[9], Ji[9], N[10], dN[10][3];
        jacobian(pos, tet, pts + 4 * q, J, N, dN);
        const double det = defsim__m3_inverse(J, Ji);
        double *G = rest + DEFSIM__TET10_QSTRIDE * q;
        /* dN_a/dX_j = sum_k dN_a/dxi_k (J^-1)_kj */
        for (int a = 0; a < 10; ++a)
            for (int j = 0; j < 3; ++j)
                G[3 * a + j] = dN[a][0] * Ji[j] + dN[a][1] * Ji[3 + j] + dN[a][2] * Ji[6 + j];
        G[30] = w[q] * det;
    }
    const int n5 = defsim__tet10_rule(5, &pts, &w);
    double vol = 0.0;
    for (int q = 0; q < n5; ++q) {
        double J[9], N[10], dN[10][3];
        jacobian(pos, tet, pts + 4 * q, J, N, dN);
        vol += w[q] * defsim__m3_det(J);
    }
    return vol;
}

void defsim__tet10_mass(const double *pos, const int32_t tet[10], double rho, double *m)
{
    const double *pts, *w;
    const int n5 = defsim__tet10_rule(5, &pts, &w);
    double d[10] = {0}, vol = 0.0, sum = 0.0;
    for (int q = 0; q < n5; ++q) {
        double J[9], N[10], dN[10][3];
        jacobian(pos, tet, pts + 4 * q, J, N, dN);
        const double wd = w[q] * defsim__m3_det(J);
        vol += wd;
        for (int a = 0; a < 10; ++a) d[a] += wd * N[a] * N[a];
    }
    for (int a = 0; a < 10; ++a) sum += d[a];
    for (int a = 0; a < 10; ++a) m[tet[a]] += rho * vol * d[a] / sum;
}

/* ------------------------------------------------------------------------------------------ */
/* Group-level kernels */

static const double *rest_of(const defsim__group *g, int32_t e)
{
    return g->qrest + DEFSIM__TET10_REST * (int64_t)e;
}

void defsim__tet10_stiffness(const double *rest, const double D[DEFSIM__TET10_QP][81], double c,
                             const double *bv, double *K)
{
    enum { nd = 30 };
    for (int i = 0; i < nd; ++i)
        for (int j = 0; j < nd; ++j) K[i * nd + j] = bv ? c * bv[i] * bv[j] : 0.0;
    for (int q = 0; q < DEFSIM__TET10_QP; ++q) {
        const double *G = rest + DEFSIM__TET10_QSTRIDE * q, *Dq = D[q];
        const double w = G[30];
        for (int b = 0; b < 10; ++b) {
            const double *gb = G + 3 * b;
            double Dg[9][3];   /* Dg[(i,j)][k] = w sum_l D[(i,j),(k,l)] g_b[l] */
            for (int rr = 0; rr < 9; ++rr)
                for (int k = 0; k < 3; ++k)
                    Dg[rr][k] = w * (Dq[9 * rr + 3 * k] * gb[0] + Dq[9 * rr + 3 * k + 1] * gb[1] +
                                     Dq[9 * rr + 3 * k + 2] * gb[2]);
            for (int a = 0; a <= b; ++a) {
                const double *ga = G + 3 * a;
                for (int i = 0; i < 3; ++i)
                    for (int k = 0; k < 3; ++k)
                        K[(3 * a + i) * nd + 3 * b + k] += ga[0] * Dg[3 * i][k] +
                                                           ga[1] * Dg[3 * i + 1][k] +
                                                           ga[2] * Dg[3 * i + 2][k];
            }
        }
    }
    /* D symmetric: the lower blocks mirror the upper ones. */
    for (int b = 0; b < 10; ++b)
        for (int a = 0; a < b; ++a)
            for (int i = 0; i < 3; ++i)
                for (int k = 0; k < 3; ++k)
                    K[(3 * b + k) * nd + 3 * a + i] = K[(3 * a + i) * nd + 3 * b + k];
}

void defsim__tet10_damping_forces(const defsim__group *g, const double *x, const double *v,
                                  double *f, int nthreads)
{
    (void)nthreads;   /* used by OpenMP pragmas only */
    for (int32_t c = 0; c < g->ncolors; ++c) {
        const int32_t e0 = g->color_ptr[c], e1 = g->color_ptr[c + 1];
#pragma omp parallel for schedule(static) num_threads(nthreads) if (e1 - e0 > 128)
        for (int32_t e = e0; e < e1; ++e) {
            if (g->beta[e] == 0.0) continue;
            const int32_t *id = g->idx + 10 * (int64_t)e;
            for (int q = 0; q < DEFSIM__TET10_QP; ++q) {
                const double *G = rest_of(g, e) + DEFSIM__TET10_QSTRIDE * q;
                double F[9], dF[9], D[81], dP[9];
                defsim__tet10_F(x, id, G, F);
                defsim__tet10_F(v, id, G, dF);
                defsim__model_dpdf_projected(g->law, g->mu[e], g->lambda[e], F,
                                             DEFSIM_PROJECTION_CLAMP, D, 0, NULL);
                for (int r = 0; r < 9; ++r) {
                    double sum = 0.0;
                    for (int k = 0; k < 9; ++k) sum += D[9 * r + k] * dF[k];
                    dP[r] = sum;
                }
                defsim__tet10_scatter(f, id, G, dP, -g->beta[e] * G[30]);
            }
        }
    }
}

double defsim__tet10_mixed(const defsim__model *law, double mu, double la, const double *x,
                           const int32_t *id, const double *rest,
                           double F[DEFSIM__TET10_QP][9], double P[DEFSIM__TET10_QP][9],
                           double u[3])
{
    const defsim__model_split *sp = law->split;
    double V = 0.0, jv = 0.0, iso = 0.0;
    for (int q = 0; q < DEFSIM__TET10_QP; ++q) {
        const double *G = rest + DEFSIM__TET10_QSTRIDE * q;
        defsim__tet10_F(x, id, G, F[q]);
        V += G[30];
        jv += G[30] * defsim__m3_det(F[q]);
        iso += G[30] * sp->P(mu, la, F[q], P[q]);
    }
    sp->U(mu, la, jv / V, u);
    for (int q = 0; q < DEFSIM__TET10_QP; ++q) {
        double C[9];
        defsim__m3_cofactor(F[q], C);
        for (int i = 0; i < 9; ++i) P[q][i] += u[1] * C[i];
    }
    double e = iso + V * u[0];
    if (law->psi_rest) e -= V * law->psi_rest(mu, la);
    return e;
}

void defsim__tet10_element_forces(const defsim__group *g, const double *x, int32_t e,
                                  double fl[30])
{
    static const int32_t loc[10] = {0, 1, 2, 3, 4, 5, 6, 7, 8, 9};
    const int32_t *id = g->idx + 10 * (int64_t)e;
    double xl[30], F[DEFSIM__TET10_QP][9], P[DEFSIM__TET10_QP][9], u[3];
    for (int a = 0; a < 10; ++a) memcpy(xl + 3 * a, x + 3 * (int64_t)id[a], 3 * sizeof *xl);
    memset(fl, 0, 30 * sizeof *fl);
    if (g->mixed)
        (void)defsim__tet10_mixed(g->law, g->mu[e], g->lambda[e], xl, loc, rest_of(g, e), F, P, u);
    for (int q = 0; q < DEFSIM__TET10_QP; ++q) {
        const double *G = rest_of(g, e) + DEFSIM__TET10_QSTRIDE * q;
        if (!g->mixed) {
            defsim__tet10_F(xl, loc, G, F[q]);
            (void)g->law->P(g->mu[e], g->lambda[e], F[q], P[q]);
        }
        defsim__tet10_scatter(fl, loc, G, P[q], -G[30]);
    }
}

double defsim__tet10_min_det(const defsim__group *g, const double *x, int32_t e)
{
    const int32_t *id = g->idx + 10 * (int64_t)e;
    double lo = INFINITY;
    for (int q = 0; q < DEFSIM__TET10_QP; ++q) {
        double F[9];
        defsim__tet10_F(x, id, rest_of(g, e) + DEFSIM__TET10_QSTRIDE * q, F);
        const double J = defsim__m3_det(F);
        if (!(J >= lo)) lo = J;
    }
    return lo;
}

void defsim__tet10_stress(const defsim__model *law, double mu, double la, int mixed,
                          const double *x, const int32_t *id, const double *rest, double sigma[9],
                          double *psi)
{
    const double r0 = law->psi_rest ? law->psi_rest(mu, la) : 0.0;
    double wsum = 0.0, e_sum = 0.0, F[DEFSIM__TET10_QP][9], P[DEFSIM__TET10_QP][9], u[3];
    memset(sigma, 0, 9 * sizeof *sigma);
    const double e_mixed = mixed ? defsim__tet10_mixed(law, mu, la, x, id, rest, F, P, u) : 0.0;
    for (int q = 0; q < DEFSIM__TET10_QP; ++q) {
        const double *G = rest + DEFSIM__TET10_QSTRIDE * q;
        double p = INFINITY, J;
        if (mixed) {
            J = defsim__m3_det(F[q]);
            p = e_mixed;
        } else {
            defsim__tet10_F(x, id, G, F[q]);
            J = defsim__m3_det(F[q]);
            if (!(law->needs_positive_det && !(J > 0.0))) p = law->P(mu, la, F[q], P[q]) - r0;
        }
        const int defined = J != 0.0 && isfinite(p);
        const double *Pq = P[q], *Fq = F[q];
        for (int i = 0; i < 3; ++i)
            for (int j = 0; j < 3; ++j)
                sigma[3 * i + j] +=
                    defined ? G[30] * (Pq[3 * i] * Fq[3 * j] + Pq[3 * i + 1] * Fq[3 * j + 1] +
                                       Pq[3 * i + 2] * Fq[3 * j + 2]) / J
                            : NAN;
        wsum += G[30];
        if (!mixed) e_sum += G[30] * p;
    }
    for (int i = 0; i < 9; ++i) sigma[i] /= wsum;
    *psi = mixed ? e_mixed / wsum : e_sum / wsum;
}
