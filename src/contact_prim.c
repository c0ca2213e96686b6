/* SPDX-License-Identifier: MIT */
/*
 * Primitive distances for contact (contact_prim.h). Every distance is one of four formulas of
 * difference vectors of the vertices:
 *   point-point  |d|^2,
 *   point-line   |u x w|^2 / |w|^2              (u = p - e0, w = e1 - e0),
 *   point-plane  ((r . n)^2) / |n|^2, n = c1 x c2 (r = p - t0, c1 = t1 - t0, c2 = t2 - t0),
 *   line-line    the same with r = a0 - b0, c1 = a1 - a0, c2 = b1 - b0.
 * Derivatives use the Jacobians of difference vectors (a +I block and a -I block) and of cross
 * products: D(c1 x c2) = -[c2]x Dc1 + [c1]x Dc2, and for a fixed vector l,
 * D^2 (l . (c1 x c2)) = Dc1^T L Dc2 + (Dc1^T L Dc2)^T with L = -[l]x. Dense 3 x N Jacobians over
 * N <= 12 variables keep this short; the cost is a few thousand flops per pair.
 */
#include "contact_prim.h"

#include <math.h>
#include <string.h>

enum { NMAX = 12 };

typedef struct jac {
    double a[3][NMAX];
} jac;

static double dot3(const double *a, const double *b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }

static void sub3(const double *a, const double *b, double *out)
{
    for (int k = 0; k < 3; ++k) out[k] = a[k] - b[k];
}

static void cross3(const double *a, const double *b, double *out)
{
    out[0] = a[1] * b[2] - a[2] * b[1];
    out[1] = a[2] * b[0] - a[0] * b[2];
    out[2] = a[0] * b[1] - a[1] * b[0];
}

/* The Jacobian of X[i] - X[j] over the packed vertices X (3 per vertex). */
static void jdiff(jac *J, int i, int j)
{
    memset(J, 0, sizeof *J);
    for (int k = 0; k < 3; ++k) {
        J->a[k][3 * i + k] = 1.0;
        J->a[k][3 * j + k] = -1.0;
    }
}

/* out = [v]x J (3 x N) added with factor f. */
static void add_skew_times(jac *out, double f, const double *v, const jac *J, int n)
{
    const double S[3][3] = {{0, -v[2], v[1]}, {v[2], 0, -v[0]}, {-v[1], v[0], 0}};
    for (int r = 0; r < 3; ++r)
        for (int c = 0; c < n; ++c)
            out->a[r][c] += f * (S[r][0] * J->a[0][c] + S[r][1] * J->a[1][c] + S[r][2] * J->a[2][c]);
}

/* g = J^T v (N). */
static void jt_v(const jac *J, const double *v, int n, double *g)
{
    for (int c = 0; c < n; ++c) g[c] = J->a[0][c] * v[0] + J->a[1][c] * v[1] + J->a[2][c] * v[2];
}

/* H += f A^T B (N x N). */
static void add_at_b(double *H, double f, const jac *A, const jac *B, int n)
{
    for (int i = 0; i < n; ++i)
        for (int j = 0; j < n; ++j)
            H[i * n + j] += f * (A->a[0][i] * B->a[0][j] + A->a[1][i] * B->a[1][j] +
                                 A->a[2][i] * B->a[2][j]);
}

/* H += f (A^T L B + B^T L^T A) with L = -[l]x: f times the Hessian of l . (a x b). */
static void add_cross_hessian(double *H, double f, const double *l, const jac *A, const jac *B,
                              int n)
{
    jac LB;
    memset(&LB, 0, sizeof LB);
    add_skew_times(&LB, -1.0, l, B, n);
    add_at_b(H, f, A, &LB, n);
    add_at_b(H, f, &LB, A, n);
}

/* H += f a b^T + f b a^T (a == b allowed: then 2 f a a^T). */
static void add_sym_outer(double *H, double f, const double *a, const double *b, int n)
{
    for (int i = 0; i < n; ++i)
        for (int j = 0; j < n; ++j) H[i * n + j] += f * (a[i] * b[j] + b[i] * a[j]);
}

/* |X[i] - X[j]|^2 */
static double f_pp(const double *X, int n, int i, int j, double *g, double *H)
{
    double d[3];
    sub3(X + 3 * i, X + 3 * j, d);
    if (g || H) {
        jac J;
        jdiff(&J, i, j);
        if (g) {
            jt_v(&J, d, n, g);
            for (int c = 0; c < n; ++c) g[c] *= 2.0;
        }
        if (H) add_at_b(H, 2.0, &J, &J, n);
    }
    return dot3(d, d);
}

/* |u x w|^2 / |w|^2 with u = X[p] - X[e0], w = X[e1] - X[e0]. */
static double f_pl(const double *X, int n, int p, int e0, int e1, double *g, double *H)
{
    double u[3], w[3], m[3];
    sub3(X + 3 * p, X + 3 * e0, u);
    sub3(X + 3 * e1, X + 3 * e0, w);
    cross3(u, w, m);
    const double a = dot3(m, m), q = dot3(w, w);
    if (!g && !H) return a / q;
    jac Ju, Jw, Dm;
    jdiff(&Ju, p, e0);
    jdiff(&Jw, e1, e0);
    memset(&Dm, 0, sizeof Dm);
    add_skew_times(&Dm, -1.0, w, &Ju, n);
    add_skew_times(&Dm, 1.0, u, &Jw, n);
    double da[NMAX], dq[NMAX];
    jt_v(&Dm, m, n, da);
    jt_v(&Jw, w, n, dq);
    for (int c = 0; c < n; ++c) {
        da[c] *= 2.0;
        dq[c] *= 2.0;
    }
    if (g)
        for (int c = 0; c < n; ++c) g[c] = da[c] / q - a / (q * q) * dq[c];
    if (H) {
        /* d2a = 2 Dm^T Dm + 2 D^2(m . (u x w)) with m fixed; d2q = 2 Jw^T Jw. */
        add_at_b(H, 2.0 / q, &Dm, &Dm, n);
        add_cross_hessian(H, 2.0 / q, m, &Ju, &Jw, n);
        add_sym_outer(H, -1.0 / (q * q), da, dq, n);
        add_sym_outer(H, a / (q * q * q), dq, dq, n);
        add_at_b(H, -2.0 * a / (q * q), &Jw, &Jw, n);
    }
    return a / q;
}

/* (r . n)^2 / |n|^2 with r = X[r0] - X[r1], n = c1 x c2, c1 = X[a0] - X[a1], c2 = X[b0] - X[b1]. */
static double f_plane(const double *X, int n, int r0, int r1, int a0, int a1, int b0, int b1,
                      double *g, double *H)
{
    double r[3], c1[3], c2[3], nv[3];
    sub3(X + 3 * r0, X + 3 * r1, r);
    sub3(X + 3 * a0, X + 3 * a1, c1);
    sub3(X + 3 * b0, X + 3 * b1, c2);
    cross3(c1, c2, nv);
    const double s = dot3(r, nv), q = dot3(nv, nv);
    if (!g && !H) return s * s / q;
    jac Jr, J1, J2, Dn;
    jdiff(&Jr, r0, r1);
    jdiff(&J1, a0, a1);
    jdiff(&J2, b0, b1);
    memset(&Dn, 0, sizeof Dn);
    add_skew_times(&Dn, -1.0, c2, &J1, n);
    add_skew_times(&Dn, 1.0, c1, &J2, n);
    double ds[NMAX], dq[NMAX], t[NMAX];
    jt_v(&Jr, nv, n, ds);
    jt_v(&Dn, r, n, t);
    for (int c = 0; c < n; ++c) ds[c] += t[c];
    jt_v(&Dn, nv, n, dq);
    for (int c = 0; c < n; ++c) dq[c] *= 2.0;
    if (g)
        for (int c = 0; c < n; ++c) g[c] = 2.0 * s / q * ds[c] - s * s / (q * q) * dq[c];
    if (H) {
        /* d2s = Jr^T Dn + Dn^T Jr + D^2(r . (c1 x c2)); d2q = 2 Dn^T Dn + 2 D^2(n . (c1 x c2)). */
        const double fs = 2.0 * s / q, fq = -s * s / (q * q);
        add_sym_outer(H, 1.0 / q, ds, ds, n);
        add_at_b(H, fs, &Jr, &Dn, n);
        add_at_b(H, fs, &Dn, &Jr, n);
        add_cross_hessian(H, fs, r, &J1, &J2, n);
        add_sym_outer(H, -2.0 * s / (q * q), ds, dq, n);
        add_sym_outer(H, s * s / (q * q * q), dq, dq, n);
        add_at_b(H, 2.0 * fq, &Dn, &Dn, n);
        add_cross_hessian(H, 2.0 * fq, nv, &J1, &J2, n);
    }
    return s * s / q;
}

/* Closest-feature candidates of a point against a segment: PP at an end or PE inside. Returns
 * the squared distance; *which: 0 (end e0), 1 (end e1) or 2 (interior). */
static double point_segment(const double *p, const double *e0, const double *e1, int *which)
{
    double w[3], u[3];
    sub3(e1, e0, w);
    sub3(p, e0, u);
    const double ww = dot3(w, w), t = ww > 0.0 ? dot3(u, w) / ww : 0.0;
    if (t <= 0.0) {
        *which = 0;
        return dot3(u, u);
    }
    if (t >= 1.0) {
        double v[3];
        sub3(p, e1, v);
        *which = 1;
        return dot3(v, v);
    }
    double m[3];
    cross3(u, w, m);
    *which = 2;
    return dot3(m, m) / ww;
}

static void clear(double *g, double *H, int n)
{
    if (g) memset(g, 0, (size_t)n * sizeof *g);
    if (H) memset(H, 0, (size_t)n * (size_t)n * sizeof *H);
}

/* The closest features of p against (t0, t1, t2) in X (p, t0, t1, t2): the formula and the
 * vertices it involves (see defsim__pt_closest); the squared distance for the boundary regions
 * (the interior's is left to the caller, *d2 = -1). */
static int pt_region(const double *X, defsim__dtype *type, int nodes[4], double *d2)
{
    const double *p = X, *t0 = X + 3, *t1 = X + 6, *t2 = X + 9;
    /* Barycentric coordinates of p's projection on the triangle's plane. */
    double e1[3], e2[3], u[3];
    sub3(t1, t0, e1);
    sub3(t2, t0, e2);
    sub3(p, t0, u);
    const double a = dot3(e1, e1), b = dot3(e1, e2), c = dot3(e2, e2);
    const double d = dot3(u, e1), e = dot3(u, e2), det = a * c - b * b;
    if (det > 1e-30 * a * c) {
        const double b1 = (c * d - b * e) / det, b2 = (a * e - b * d) / det;
        if (b1 >= 0.0 && b2 >= 0.0 && b1 + b2 <= 1.0) {
            *type = DEFSIM__D_PT;
            for (int k = 0; k < 4; ++k) nodes[k] = k;
            *d2 = -1.0;
            return 4;
        }
    }
    /* Outside (or a degenerate triangle): the closest point is on the boundary. */
    static const int edge[3][2] = {{1, 2}, {2, 3}, {3, 1}};
    int best = 0, which = 0;
    double dmin = INFINITY;
    for (int k = 0; k < 3; ++k) {
        int w;
        const double dk = point_segment(p, X + 3 * edge[k][0], X + 3 * edge[k][1], &w);
        if (dk < dmin) {
            dmin = dk;
            best = k;
            which = w;
        }
    }
    *d2 = dmin;
    nodes[0] = 0;
    if (which == 2) {
        *type = DEFSIM__D_PE;
        nodes[1] = edge[best][0];
        nodes[2] = edge[best][1];
        return 3;
    }
    *type = DEFSIM__D_PP;
    nodes[1] = edge[best][which];
    return 2;
}

/* Evaluates the formula of a region over the vertices `nodes` of X (n coordinates). */
static double eval_region(const double *X, int n, defsim__dtype type, const int *nodes,
                          double *g, double *H)
{
    switch (type) {
    case DEFSIM__D_PP: return f_pp(X, n, nodes[0], nodes[1], g, H);
    case DEFSIM__D_PE: return f_pl(X, n, nodes[0], nodes[1], nodes[2], g, H);
    case DEFSIM__D_PT: return f_plane(X, n, 0, 1, 2, 1, 3, 1, g, H);
    default: return f_plane(X, n, 0, 2, 1, 0, 3, 2, g, H);
    }
}

/* The closest features of segments (a0, a1) and (b0, b1) in X: as pt_region. */
static int ee_region(const double *X, defsim__dtype *type, int nodes[4], double *d2)
{
    const double *a0 = X, *a1 = X + 3, *b0 = X + 6, *b1 = X + 9;
    double ea[3], eb[3], r[3], n[3];
    sub3(a1, a0, ea);
    sub3(b1, b0, eb);
    sub3(a0, b0, r);
    cross3(ea, eb, n);
    const double aa = dot3(ea, ea), bb = dot3(eb, eb), ab = dot3(ea, eb);
    const double nn = dot3(n, n);
    if (nn > 1e-20 * aa * bb) {
        /* Closest points of the two lines: a0 + s ea and b0 + t eb. */
        const double ra = dot3(r, ea), rb = dot3(r, eb), det = aa * bb - ab * ab;
        const double s = (ab * rb - bb * ra) / det, t = (aa * rb - ab * ra) / det;
        if (s > 0.0 && s < 1.0 && t > 0.0 && t < 1.0) {
            *type = DEFSIM__D_EE;
            for (int k = 0; k < 4; ++k) nodes[k] = k;
            *d2 = -1.0;
            return 4;
        }
    }
    /* On the boundary of the parameter square: an end against the other segment. */
    static const int cand[4][3] = {{0, 2, 3}, {1, 2, 3}, {2, 0, 1}, {3, 0, 1}};
    int best = 0, which = 0;
    double dmin = INFINITY;
    for (int k = 0; k < 4; ++k) {
        int w;
        const double dk =
            point_segment(X + 3 * cand[k][0], X + 3 * cand[k][1], X + 3 * cand[k][2], &w);
        if (dk < dmin) {
            dmin = dk;
            best = k;
            which = w;
        }
    }
    *d2 = dmin;
    nodes[0] = cand[best][0];
    if (which == 2) {
        *type = DEFSIM__D_PE;
        nodes[1] = cand[best][1];
        nodes[2] = cand[best][2];
        return 3;
    }
    *type = DEFSIM__D_PP;
    nodes[1] = cand[best][1 + which];
    return 2;
}

/* A region function of packed vertices (pt_region and ee_region of four, pe_region of three). */
typedef int (*region_fn)(const double *X, defsim__dtype *type, int nodes[4], double *d2);

/* The closest features of four packed vertices by `region`, with the interior's distance. */
static int closest4(region_fn region, const double *x, double *d2, defsim__dtype *type,
                    int nodes[4])
{
    const int m = region(x, type, nodes, d2);
    if (*d2 < 0.0) *d2 = eval_region(x, 12, *type, nodes, NULL, NULL);
    return m;
}

/* The squared distance of the n / 3 packed vertices X (and its derivatives) by `region`. */
static double dist2_packed(region_fn region, const double *X, int n, double *g, double *H,
                           defsim__dtype *type)
{
    clear(g, H, n);
    defsim__dtype tt;
    if (!type) type = &tt;
    int nodes[4];
    double d2;
    region(X, type, nodes, &d2);
    if (d2 >= 0.0 && !g && !H) return d2;
    return eval_region(X, n, *type, nodes, g, H);
}

/* The squared distance of four vertices (and its derivatives) by `region`. */
static double dist2_4(region_fn region, const double *v0, const double *v1, const double *v2,
                      const double *v3, double *g, double *H, defsim__dtype *type)
{
    double X[12];
    memcpy(X, v0, 3 * sizeof *X);
    memcpy(X + 3, v1, 3 * sizeof *X);
    memcpy(X + 6, v2, 3 * sizeof *X);
    memcpy(X + 9, v3, 3 * sizeof *X);
    return dist2_packed(region, X, 12, g, H, type);
}

int defsim__pt_closest(const double x[12], double *d2, defsim__dtype *type, int nodes[4])
{
    return closest4(pt_region, x, d2, type, nodes);
}

double defsim__pt_dist2(const double p[3], const double t0[3], const double t1[3],
                        const double t2[3], double g[12], double H[144], defsim__dtype *type)
{
    return dist2_4(pt_region, p, t0, t1, t2, g, H, type);
}

int defsim__ee_closest(const double x[12], double *d2, defsim__dtype *type, int nodes[4])
{
    return closest4(ee_region, x, d2, type, nodes);
}

double defsim__ee_dist2(const double a0[3], const double a1[3], const double b0[3],
                        const double b1[3], double g[12], double H[144], defsim__dtype *type)
{
    return dist2_4(ee_region, a0, a1, b0, b1, g, H, type);
}

/* The closest features of p and segment (e0, e1) in X (p, e0, e1), as pt_region (the distance
 * always set). */
static int pe_region(const double *X, defsim__dtype *type, int nodes[4], double *d2)
{
    int which;
    *d2 = point_segment(X, X + 3, X + 6, &which);
    nodes[0] = 0;
    if (which == 2) {
        *type = DEFSIM__D_PE;
        nodes[1] = 1;
        nodes[2] = 2;
        return 3;
    }
    *type = DEFSIM__D_PP;
    nodes[1] = 1 + which;
    return 2;
}

int defsim__pe_closest(const double x[9], double *d2, defsim__dtype *type, int nodes[4])
{
    return pe_region(x, type, nodes, d2);
}

double defsim__pe_dist2(const double p[3], const double e0[3], const double e1[3], double g[9],
                        double H[81], defsim__dtype *type)
{
    double X[9];
    memcpy(X, p, 3 * sizeof *X);
    memcpy(X + 3, e0, 3 * sizeof *X);
    memcpy(X + 6, e1, 3 * sizeof *X);
    return dist2_packed(pe_region, X, 9, g, H, type);
}

int defsim__triangle_closest(const double p[3], const double a[3], const double b[3],
                             const double c[3], double w[3])
{
    double ab[3], ac[3], ap[3], bp[3], cp[3];
    sub3(b, a, ab);
    sub3(c, a, ac);
    sub3(p, a, ap);
    sub3(p, b, bp);
    sub3(p, c, cp);
    const double d1 = dot3(ab, ap), d2 = dot3(ac, ap), d3 = dot3(ab, bp), d4 = dot3(ac, bp);
    const double d5 = dot3(ab, cp), d6 = dot3(ac, cp);
    const double va = d3 * d6 - d5 * d4, vb = d5 * d2 - d1 * d6, vc = d1 * d4 - d3 * d2;
    double u = 0.0, v = 0.0, t = 0.0;   /* weights of a, b, c */
    int r;
    if (d1 <= 0.0 && d2 <= 0.0) r = 0, u = 1.0;
    else if (d3 >= 0.0 && d4 <= d3) r = 1, v = 1.0;
    else if (vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0) r = 3, v = d1 / (d1 - d3), u = 1.0 - v;
    else if (d6 >= 0.0 && d5 <= d6) r = 2, t = 1.0;
    else if (vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0) r = 5, t = d2 / (d2 - d6), u = 1.0 - t;
    else if (va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0) {
        r = 4;
        t = (d4 - d3) / ((d4 - d3) + (d5 - d6));
        v = 1.0 - t;
    } else {
        r = 6;
        const double den = 1.0 / (va + vb + vc);
        v = vb * den, t = vc * den, u = 1.0 - v - t;
    }
    w[0] = u, w[1] = v, w[2] = t;
    return r;
}

double defsim__ee_mollifier_eps(const double a0[3], const double a1[3], const double b0[3],
                                const double b1[3])
{
    double ea[3], eb[3];
    sub3(a1, a0, ea);
    sub3(b1, b0, eb);
    return 1e-3 * dot3(ea, ea) * dot3(eb, eb);
}

double defsim__ee_mollifier(const double a0[3], const double a1[3], const double b0[3],
                            const double b1[3], double eps, double g[12], double H[144])
{
    clear(g, H, 12);
    double ea[3], eb[3], v[3];
    sub3(a1, a0, ea);
    sub3(b1, b0, eb);
    cross3(ea, eb, v);
    const double c = dot3(v, v);
    if (!(c < eps)) return 1.0;
    const double x = c / eps, m = (2.0 - x) * x;
    if (!g && !H) return m;
    const double m1 = 2.0 / eps * (1.0 - x), m2 = -2.0 / (eps * eps);
    jac Ja, Jb, Dv;
    jdiff(&Ja, 1, 0);
    jdiff(&Jb, 3, 2);
    memset(&Dv, 0, sizeof Dv);
    add_skew_times(&Dv, -1.0, eb, &Ja, 12);
    add_skew_times(&Dv, 1.0, ea, &Jb, 12);
    double dc[12];
    jt_v(&Dv, v, 12, dc);
    for (int k = 0; k < 12; ++k) dc[k] *= 2.0;
    if (g)
        for (int k = 0; k < 12; ++k) g[k] = m1 * dc[k];
    if (H) {
        add_sym_outer(H, 0.5 * m2, dc, dc, 12);
        add_at_b(H, 2.0 * m1, &Dv, &Dv, 12);
        add_cross_hessian(H, 2.0 * m1, v, &Ja, &Jb, 12);
    }
    return m;
}

/* ------------------------------------------------------------------------------------------ */
/* Additive CCD */

/* The squared distance of a packed pair for CCD (no derivatives, no copy). */
static double ccd_dist2(defsim__ccd_pair pair, const double *x)
{
    defsim__dtype type;
    int nodes[4];
    double d2;
    if (pair == DEFSIM__CCD_PE) return point_segment(x, x + 3, x + 6, &nodes[0]);
    if (pair == DEFSIM__CCD_PT) closest4(pt_region, x, &d2, &type, nodes);
    else closest4(ee_region, x, &d2, &type, nodes);
    return d2;
}

double defsim__ccd_speed(defsim__ccd_pair pair, const double dx[12])
{
    const int first = pair == DEFSIM__CCD_EE ? 2 : 1;
    double lp = 0.0;
    for (int a = 0; a < first; ++a)
        for (int b = first; b < 4; ++b) {
            double r[3];
            sub3(dx + 3 * a, dx + 3 * b, r);
            const double l = dot3(r, r);
            lp = l > lp ? l : lp;
        }
    return sqrt(lp);
}

/* Conservative advancement of the distance d(t) of the pair x0 + t dx0 (t in [0, tmax]), one
 * loop for the three kinds of pair.
 *
 * The closest points move with a relative velocity that is a convex combination of the vertex
 * differences dx_a - dx_b (a on the first primitive, b on the second), so d is Lipschitz with
 * constant lp = max |dx_a - dx_b| (defsim__ccd_speed): no larger than ACCD's bound (the largest
 * displacement on each side after removing the mean, whose sum bounds every |dx_a - dx_b|). Each
 * advance is ETA d / lp, over which d stays above (1 - ETA) d > 0. When an advance ends below
 * the gap s d(0), the crossing inside that advance (which is collision-free as a whole) is
 * bracketed and halved REFINE times, and the last time found at or above the gap is returned:
 * the result is then within 2^-REFINE of one advance of where d first reaches the gap at a
 * checked time, where ACCD stops one whole advance short of it. */
enum { REFINE = 12 };
#define ETA 0.9

double defsim__accd(defsim__ccd_pair pair, const double x0[12], const double dx[12], double d0,
                    double lp, double s, double tmax, int max_iterations)
{
    return defsim__accd_offset(pair, x0, dx, d0, 0.0, lp, s, tmax, max_iterations);
}

double defsim__accd_offset(defsim__ccd_pair pair, const double x0[12], const double dx[12],
                           double d0, double xi, double lp, double s, double tmax,
                           int max_iterations)
{
    if (!(lp > 0.0)) return tmax;
    if (!(d0 > 0.0)) return 0.0;
    double x[12];
    double d = d0;
    const double gap = s * d;
    double t = 0.0;
    for (int it = 0; it < max_iterations; ++it) {
        const double tl = ETA * d / lp;
        if (t + tl >= tmax) return tmax;
        for (int k = 0; k < 12; ++k) x[k] = x0[k] + (t + tl) * dx[k];
        const double dn = sqrt(ccd_dist2(pair, x)) - xi;
        if (dn < gap) {
            /* d(t) >= gap > d(t + tl): bisect, keeping lo at or above the gap */
            double lo = t, hi = t + tl;
            for (int r = 0; r < REFINE; ++r) {
                const double mid = 0.5 * (lo + hi);
                for (int k = 0; k < 12; ++k) x[k] = x0[k] + mid * dx[k];
                if (sqrt(ccd_dist2(pair, x)) - xi >= gap) lo = mid;
                else hi = mid;
            }
            return lo;
        }
        t += tl;
        d = dn;
    }
    return t;
}

static double accd_of(defsim__ccd_pair pair, const double x[12], const double dx[12], double s,
                      double tmax, int max_iterations)
{
    const double lp = defsim__ccd_speed(pair, dx);
    if (!(lp > 0.0)) return tmax;
    return defsim__accd(pair, x, dx, sqrt(ccd_dist2(pair, x)), lp, s, tmax, max_iterations);
}

double defsim__pt_accd(const double x[12], const double dx[12], double s, double tmax,
                       int max_iterations)
{
    return accd_of(DEFSIM__CCD_PT, x, dx, s, tmax, max_iterations);
}

double defsim__ee_accd(const double x[12], const double dx[12], double s, double tmax,
                       int max_iterations)
{
    return accd_of(DEFSIM__CCD_EE, x, dx, s, tmax, max_iterations);
}

double defsim__pe_accd(const double x[9], const double dx[9], double s, double tmax,
                       int max_iterations)
{
    /* The edge's end repeated as a fourth vertex: it moves with the edge, so the bound on the
     * relative motion is unchanged. */
    double x4[12], d4[12];
    memcpy(x4, x, 9 * sizeof *x);
    memcpy(d4, dx, 9 * sizeof *dx);
    memcpy(x4 + 9, x + 6, 3 * sizeof *x);
    memcpy(d4 + 9, dx + 6, 3 * sizeof *dx);
    return accd_of(DEFSIM__CCD_PE, x4, d4, s, tmax, max_iterations);
}
