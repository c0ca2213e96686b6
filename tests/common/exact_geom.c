/* SPDX-License-Identifier: MIT */
/*
 * Exact predicates (exact_geom.h). An expansion is a sum of doubles whose magnitudes do not
 * overlap, kept in increasing order of magnitude; its sign is the sign of its largest component.
 * Two error-free transformations build everything: two_sum (a + b = s + e exactly) and
 * two_product (a * b = p + e exactly, with fma). Coordinates differences are 2-component
 * expansions, products of three of them 32 components, orient3d a sum of six such products.
 */
#include "exact_geom.h"

#include <math.h>

enum { MAXE = 256 };

static void two_sum(double a, double b, double *s, double *e)
{
    *s = a + b;
    const double bv = *s - a, av = *s - bv;
    *e = (a - av) + (b - bv);
}

/* h = e + b (Shewchuk's Grow-Expansion, zero components dropped). Returns h's length. */
static int grow(const double *e, int n, double b, double *h)
{
    int m = 0;
    double q = b;
    for (int i = 0; i < n; ++i) {
        double s, err;
        two_sum(q, e[i], &s, &err);
        q = s;
        if (err != 0.0) h[m++] = err;
    }
    if (q != 0.0 || m == 0) h[m++] = q;
    return m;
}

/* h = e + f by growing e with each component of f. */
static int add(const double *e, int n, const double *f, int m, double *h)
{
    double t[MAXE];
    int len = n;
    for (int i = 0; i < n; ++i) t[i] = e[i];
    for (int j = 0; j < m; ++j) {
        double u[MAXE];
        len = grow(t, len, f[j], u);
        for (int i = 0; i < len; ++i) t[i] = u[i];
    }
    for (int i = 0; i < len; ++i) h[i] = t[i];
    return len;
}

/* h = e * b: each component times b is exact as p + err (fma); the pieces are summed exactly. */
static int scale(const double *e, int n, double b, double *h)
{
    double acc[MAXE];
    int len = 1;
    acc[0] = 0.0;
    for (int i = 0; i < n; ++i) {
        const double p = e[i] * b, err = fma(e[i], b, -p);
        const double piece[2] = {err, p};
        double u[MAXE];
        len = add(acc, len, piece, 2, u);
        for (int k = 0; k < len; ++k) acc[k] = u[k];
    }
    for (int k = 0; k < len; ++k) h[k] = acc[k];
    return len;
}

static int mul(const double *e, int n, const double *f, int m, double *h)
{
    double acc[MAXE];
    int len = 1;
    acc[0] = 0.0;
    for (int j = 0; j < m; ++j) {
        double t[MAXE], u[MAXE];
        const int lt = scale(e, n, f[j], t);
        len = add(acc, len, t, lt, u);
        for (int k = 0; k < len; ++k) acc[k] = u[k];
    }
    for (int k = 0; k < len; ++k) h[k] = acc[k];
    return len;
}

static int sign_of(const double *e, int n)
{
    for (int i = n - 1; i >= 0; --i)
        if (e[i] != 0.0) return e[i] > 0.0 ? 1 : -1;
    return 0;
}

/* a - b as a 2-component expansion. */
static void diff(double a, double b, double out[2])
{
    double s, e;
    two_sum(a, -b, &s, &e);
    out[0] = e;
    out[1] = s;
}

int eg_orient3d(const double a[3], const double b[3], const double c[3], const double d[3])
{
    double A[3][2], B[3][2], C[3][2];
    for (int k = 0; k < 3; ++k) {
        diff(a[k], d[k], A[k]);
        diff(b[k], d[k], B[k]);
        diff(c[k], d[k], C[k]);
    }
    /* det = A . (B x C) = sum over cyclic (i, j, k) of A_i (B_j C_k - B_k C_j). */
    double total[MAXE];
    int lt = 1;
    total[0] = 0.0;
    for (int i = 0; i < 3; ++i) {
        const int j = (i + 1) % 3, k = (i + 2) % 3;
        double p[MAXE], q[MAXE], r[MAXE], s[MAXE], u[MAXE];
        const int lp = mul(B[j], 2, C[k], 2, p);
        double nb[2] = {-B[k][0], -B[k][1]};
        const int lq = mul(nb, 2, C[j], 2, q);
        const int lr = add(p, lp, q, lq, r);
        const int ls = mul(A[i], 2, r, lr, s);
        lt = add(total, lt, s, ls, u);
        for (int m = 0; m < lt; ++m) total[m] = u[m];
    }
    return sign_of(total, lt);
}

int eg_orient2d(const double a[3], const double b[3], const double c[3], int i, int j)
{
    double ai[2], aj[2], bi[2], bj[2];
    diff(a[i], c[i], ai);
    diff(a[j], c[j], aj);
    diff(b[i], c[i], bi);
    diff(b[j], c[j], bj);
    double p[MAXE], q[MAXE], r[MAXE];
    const int lp = mul(ai, 2, bj, 2, p);
    const double naj[2] = {-aj[0], -aj[1]};
    const int lq = mul(naj, 2, bi, 2, q);
    const int lr = add(p, lp, q, lq, r);
    return sign_of(r, lr);
}

/* Closed segments ab and cd in the plane (i, j) share a point. */
static int seg_seg_2d(const double *a, const double *b, const double *c, const double *d, int i,
                      int j)
{
    const int o1 = eg_orient2d(a, b, c, i, j), o2 = eg_orient2d(a, b, d, i, j);
    const int o3 = eg_orient2d(c, d, a, i, j), o4 = eg_orient2d(c, d, b, i, j);
    if (o1 * o2 < 0 && o3 * o4 < 0) return 1;
    /* Collinear touching: a point of one on the other (bounding-box test on the line). */
    const double *pts[4][3] = {{a, b, c}, {a, b, d}, {c, d, a}, {c, d, b}};
    const int o[4] = {o1, o2, o3, o4};
    for (int k = 0; k < 4; ++k) {
        if (o[k] != 0) continue;
        const double *p = pts[k][0], *q = pts[k][1], *r = pts[k][2];
        if (fmin(p[i], q[i]) <= r[i] && r[i] <= fmax(p[i], q[i]) && fmin(p[j], q[j]) <= r[j] &&
            r[j] <= fmax(p[j], q[j]))
            return 1;
    }
    return 0;
}

/* Point x in the closed triangle (p, q, r) in the plane (i, j). */
static int point_in_tri_2d(const double *x, const double *p, const double *q, const double *r,
                           int i, int j)
{
    const int a = eg_orient2d(p, q, x, i, j), b = eg_orient2d(q, r, x, i, j),
              c = eg_orient2d(r, p, x, i, j);
    return !((a < 0 || b < 0 || c < 0) && (a > 0 || b > 0 || c > 0));
}

/* Two coplanar triangles: project on a plane where the first is not degenerate. */
static int coplanar_tri_tri(const double *const P[3], const double *const Q[3])
{
    int i = 0, j = 1;
    if (eg_orient2d(P[0], P[1], P[2], 0, 1) == 0) {
        if (eg_orient2d(P[0], P[1], P[2], 1, 2) != 0) {
            i = 1;
            j = 2;
        } else {
            i = 0;
            j = 2;
        }
    }
    for (int a = 0; a < 3; ++a)
        for (int b = 0; b < 3; ++b)
            if (seg_seg_2d(P[a], P[(a + 1) % 3], Q[b], Q[(b + 1) % 3], i, j)) return 1;
    /* No edges cross: one inside the other (a degenerate Q, a segment, has no inside). */
    return point_in_tri_2d(Q[0], P[0], P[1], P[2], i, j) ||
           (eg_orient2d(Q[0], Q[1], Q[2], i, j) != 0 &&
            point_in_tri_2d(P[0], Q[0], Q[1], Q[2], i, j));
}

/* The closed segment ab meets the closed triangle (p, q, r), not coplanar with it. */
static int seg_tri(const double *a, const double *b, const double *p, const double *q,
                   const double *r)
{
    const int sa = eg_orient3d(p, q, r, a), sb = eg_orient3d(p, q, r, b);
    if (sa * sb > 0 || (sa == 0 && sb == 0)) return 0;
    const int s1 = eg_orient3d(a, b, p, q), s2 = eg_orient3d(a, b, q, r),
              s3 = eg_orient3d(a, b, r, p);
    return !((s1 < 0 || s2 < 0 || s3 < 0) && (s1 > 0 || s2 > 0 || s3 > 0));
}

int eg_tri_tri_intersect(const double p0[3], const double p1[3], const double p2[3],
                         const double q0[3], const double q1[3], const double q2[3])
{
    const double *P[3] = {p0, p1, p2}, *Q[3] = {q0, q1, q2};
    const int s0 = eg_orient3d(p0, p1, p2, q0), s1 = eg_orient3d(p0, p1, p2, q1),
              s2 = eg_orient3d(p0, p1, p2, q2);
    if ((s0 > 0 && s1 > 0 && s2 > 0) || (s0 < 0 && s1 < 0 && s2 < 0)) return 0;
    if (s0 == 0 && s1 == 0 && s2 == 0) return coplanar_tri_tri(P, Q);
    /* Not coplanar: they meet iff an edge of one meets the other (an edge lying in the other's
     * plane is handled by the 2D test of that edge against the triangle). */
    for (int k = 0; k < 3; ++k) {
        const double *a = Q[k], *b = Q[(k + 1) % 3];
        if (eg_orient3d(p0, p1, p2, a) == 0 && eg_orient3d(p0, p1, p2, b) == 0) {
            const double *seg[3] = {a, b, b};
            if (coplanar_tri_tri(P, seg)) return 1;
        } else if (seg_tri(a, b, p0, p1, p2)) {
            return 1;
        }
        const double *c = P[k], *d = P[(k + 1) % 3];
        if (eg_orient3d(q0, q1, q2, c) == 0 && eg_orient3d(q0, q1, q2, d) == 0) {
            const double *seg[3] = {c, d, d};
            if (coplanar_tri_tri(Q, seg)) return 1;
        } else if (seg_tri(c, d, q0, q1, q2)) {
            return 1;
        }
    }
    return 0;
}

int eg_point_in_tet(const double x[3], const double a[3], const double b[3], const double c[3],
                    const double d[3])
{
    const int s = eg_orient3d(a, b, c, d);
    if (s == 0) return 0;
    return eg_orient3d(a, b, c, x) == s && eg_orient3d(a, b, x, d) == s &&
           eg_orient3d(a, x, c, d) == s && eg_orient3d(x, b, c, d) == s;
}

/* ------------------------------------------------------------------------------------------ */
/* Distances (closest points in plain double arithmetic, independent of the library's; moved here
 * from test_body_contact.c so that the thickness tests share them) */

static double dot3(const double *a, const double *b)
{
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}

static void sub3(const double *a, const double *b, double *o)
{
    o[0] = a[0] - b[0], o[1] = a[1] - b[1], o[2] = a[2] - b[2];
}

static void cross3(const double *a, const double *b, double *o)
{
    o[0] = a[1] * b[2] - a[2] * b[1];
    o[1] = a[2] * b[0] - a[0] * b[2];
    o[2] = a[0] * b[1] - a[1] * b[0];
}

/* Squared distance from p to the segment [a, b]. */
static double point_seg_d2(const double *p, const double *a, const double *b)
{
    double ab[3], ap[3];
    sub3(b, a, ab);
    sub3(p, a, ap);
    const double l2 = dot3(ab, ab);
    double t = l2 > 0.0 ? dot3(ap, ab) / l2 : 0.0;
    t = t < 0.0 ? 0.0 : t > 1.0 ? 1.0 : t;
    const double d[3] = {ap[0] - t * ab[0], ap[1] - t * ab[1], ap[2] - t * ab[2]};
    return dot3(d, d);
}

/* Squared distance from p to the triangle (a, b, c): the plane's distance when p projects inside
 * (all three edge normals agree), otherwise the nearest edge. */
static double point_tri_d2(const double *p, const double *a, const double *b, const double *c)
{
    double e0[3], e1[3], n[3];
    sub3(b, a, e0);
    sub3(c, a, e1);
    cross3(e0, e1, n);
    const double n2 = dot3(n, n);
    if (n2 > 0.0) {
        const double *v[3] = {a, b, c};
        int inside = 1;
        for (int k = 0; k < 3 && inside; ++k) {
            double e[3], q[3], s[3];
            sub3(v[(k + 1) % 3], v[k], e);
            sub3(p, v[k], q);
            cross3(e, q, s);
            inside = dot3(s, n) >= 0.0;
        }
        if (inside) {
            double ap[3];
            sub3(p, a, ap);
            const double h = dot3(ap, n);
            return h * h / n2;
        }
    }
    return fmin(point_seg_d2(p, a, b), fmin(point_seg_d2(p, b, c), point_seg_d2(p, c, a)));
}

/* Squared distance between the segments [p0, p1] and [q0, q1]: the minimum lies either at the
 * interior critical point of |p(s) - q(t)|^2 (when it exists within both segments) or on the
 * boundary, where one end point meets the other segment. */
static double seg_seg_d2(const double *p0, const double *p1, const double *q0, const double *q1)
{
    double best = fmin(fmin(point_seg_d2(p0, q0, q1), point_seg_d2(p1, q0, q1)),
                       fmin(point_seg_d2(q0, p0, p1), point_seg_d2(q1, p0, p1)));
    double d1[3], d2[3], r[3];
    sub3(p1, p0, d1);
    sub3(q1, q0, d2);
    sub3(p0, q0, r);
    const double a = dot3(d1, d1), b = dot3(d1, d2), c = dot3(d2, d2);
    const double d = dot3(d1, r), e = dot3(d2, r), den = a * c - b * b;
    if (den > 1e-12 * a * c) {
        const double s = (b * e - c * d) / den, t = (a * e - b * d) / den;
        if (s > 0.0 && s < 1.0 && t > 0.0 && t < 1.0) {
            double g[3];
            for (int k = 0; k < 3; ++k) g[k] = r[k] + s * d1[k] - t * d2[k];
            best = fmin(best, dot3(g, g));
        }
    }
    return best;
}

double eg_point_tri_distance(const double x[3], const double a[3], const double b[3],
                             const double c[3])
{
    return sqrt(point_tri_d2(x, a, b, c));
}

double eg_tri_tri_gap(const double p0[3], const double p1[3], const double p2[3],
                      const double q0[3], const double q1[3], const double q2[3])
{
    const double *P[3] = {p0, p1, p2}, *Q[3] = {q0, q1, q2};
    double d2 = INFINITY;
    for (int i = 0; i < 3; ++i) {
        d2 = fmin(d2, point_tri_d2(P[i], q0, q1, q2));
        d2 = fmin(d2, point_tri_d2(Q[i], p0, p1, p2));
        for (int j = 0; j < 3; ++j)
            d2 = fmin(d2, seg_seg_d2(P[i], P[(i + 1) % 3], Q[j], Q[(j + 1) % 3]));
    }
    return sqrt(d2);
}

double eg_tri_tri_distance(const double p0[3], const double p1[3], const double p2[3],
                           const double q0[3], const double q1[3], const double q2[3])
{
    if (eg_tri_tri_intersect(p0, p1, p2, q0, q1, q2)) return 0.0;
    return eg_tri_tri_gap(p0, p1, p2, q0, q1, q2);
}
