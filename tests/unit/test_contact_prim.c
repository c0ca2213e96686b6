/* SPDX-License-Identifier: MIT */
/*
 * Primitive distances for contact (src/contact_prim.c): values against brute-force sampling of
 * the primitives, gradients and Hessians against central differences in every region, the
 * mollifier's derivatives, and additive CCD: conservative against a fine independent sampling
 * of the motion and the distance at every coplanarity time (the cubic's roots), and at least as
 * late as ACCD (Li et al. 2021, written here as IPC Toolkit states it) on random and near-contact
 * motions.
 */
#include "contact_prim.h"
#include "test_util.h"

#include <math.h>
#include <string.h>

typedef double (*pair_fn)(const double *x, double *g, double *H, defsim__dtype *type);

static double pt(const double *x, double *g, double *H, defsim__dtype *type)
{
    return defsim__pt_dist2(x, x + 3, x + 6, x + 9, g, H, type);
}

static double ee(const double *x, double *g, double *H, defsim__dtype *type)
{
    return defsim__ee_dist2(x, x + 3, x + 6, x + 9, g, H, type);
}

static double pe(const double *x, double *g, double *H, defsim__dtype *type)
{
    return defsim__pe_dist2(x, x + 3, x + 6, g, H, type);
}

static double eps_x;

static double moll(const double *x, double *g, double *H, defsim__dtype *type)
{
    if (type) *type = DEFSIM__D_EE;
    return defsim__ee_mollifier(x, x + 3, x + 6, x + 9, eps_x, g, H);
}

/* Central differences of f and of its gradient at x (n variables) against g and H; the pair
 * must stay in one region over +-h (checked through its type). Returns the largest relative
 * errors. */
static void fd_check(pair_fn f, const double *x0, int n, double *eg, double *eh)
{
    double x[12], g[12], H[144], gp[12], gm[12], Hs[144];
    defsim__dtype t0, tp, tm;
    memcpy(x, x0, (size_t)n * sizeof *x);
    f(x, g, H, &t0);
    double gscale = 0.0, hscale = 0.0;
    for (int i = 0; i < n; ++i) gscale = fmax(gscale, fabs(g[i]));
    for (int i = 0; i < n * n; ++i) hscale = fmax(hscale, fabs(H[i]));
    *eg = *eh = 0.0;
    const double h = 1e-6;
    for (int i = 0; i < n; ++i) {
        x[i] = x0[i] + h;
        const double fp = f(x, gp, Hs, &tp);
        x[i] = x0[i] - h;
        const double fm = f(x, gm, Hs, &tm);
        x[i] = x0[i];
        assert_int_equal(tp, t0);
        assert_int_equal(tm, t0);
        *eg = fmax(*eg, fabs((fp - fm) / (2 * h) - g[i]) / fmax(gscale, 1e-12));
        for (int j = 0; j < n; ++j)
            *eh = fmax(*eh, fabs((gp[j] - gm[j]) / (2 * h) - H[j * n + i]) / fmax(hscale, 1e-12));
    }
    /* Symmetric Hessian. */
    for (int i = 0; i < n; ++i)
        for (int j = 0; j < n; ++j) assert_true(fabs(H[i * n + j] - H[j * n + i]) <= 1e-12 * hscale);
}

static void random_points(unsigned long long *rng, double *x, int n)
{
    for (int i = 0; i < n; ++i) x[i] = tu_rand(rng);
}

/* Brute force: the smallest squared distance between samples of the two primitives (a point,
 * segment or triangle each, given by 1 to 3 vertices), on a grid of 200 steps per parameter. */
static double sample_d2(const double *a, int na, const double *b, int nb)
{
    const int N = 200;
    double best = INFINITY;
    for (int i = 0; i <= (na > 1 ? N : 0); ++i)
        for (int j = 0; j <= (na > 2 ? N - i : 0); ++j) {
            double pa[3];
            for (int k = 0; k < 3; ++k) {
                pa[k] = a[k];
                if (na > 1) pa[k] += (double)i / N * (a[3 + k] - a[k]);
                if (na > 2) pa[k] += (double)j / N * (a[6 + k] - a[k]);
            }
            for (int u = 0; u <= (nb > 1 ? N : 0); ++u)
                for (int v = 0; v <= (nb > 2 ? N - u : 0); ++v) {
                    double d2 = 0.0;
                    for (int k = 0; k < 3; ++k) {
                        double pb = b[k];
                        if (nb > 1) pb += (double)u / N * (b[3 + k] - b[k]);
                        if (nb > 2) pb += (double)v / N * (b[6 + k] - b[k]);
                        d2 += (pa[k] - pb) * (pa[k] - pb);
                    }
                    best = fmin(best, d2);
                }
        }
    return best;
}

static void test_values_against_sampling(void **state)
{
    (void)state;
    unsigned long long rng = 7;
    for (int trial = 0; trial < 40; ++trial) {
        double x[12];
        random_points(&rng, x, 12);
        /* The sampled minimum is never below the exact one, and close to it: a grid step of
         * 1/200 of edges of length <= 3.5 moves a point by <= 0.0175. */
        const double dpt = sqrt(pt(x, NULL, NULL, NULL)), spt = sqrt(sample_d2(x, 1, x + 3, 3));
        assert_true(spt >= dpt - 1e-12 && spt <= dpt + 0.03);
        const double dee = sqrt(ee(x, NULL, NULL, NULL)), see = sqrt(sample_d2(x, 2, x + 6, 2));
        assert_true(see >= dee - 1e-12 && see <= dee + 0.03);
        const double dpe = sqrt(pe(x, NULL, NULL, NULL)), spe = sqrt(sample_d2(x, 1, x + 3, 2));
        assert_true(spe >= dpe - 1e-12 && spe <= dpe + 0.03);
    }
}

/* Gradients and Hessians in every region: random configurations until each type of each pair
 * has been met at least 5 times, away from region boundaries (the finite differences check the
 * type does not change). */
static void test_derivatives_every_region(void **state)
{
    (void)state;
    struct {
        pair_fn f;
        int n;
        int types;   /* bit mask of the types the pair can have */
    } pairs[] = {{pt, 12, 1 << DEFSIM__D_PP | 1 << DEFSIM__D_PE | 1 << DEFSIM__D_PT},
                 {ee, 12, 1 << DEFSIM__D_PP | 1 << DEFSIM__D_PE | 1 << DEFSIM__D_EE},
                 {pe, 9, 1 << DEFSIM__D_PP | 1 << DEFSIM__D_PE}};
    unsigned long long rng = 11;
    for (int p = 0; p < 3; ++p) {
        int seen[4] = {0, 0, 0, 0};
        double worst_g = 0.0, worst_h = 0.0;
        for (int trial = 0; trial < 20000; ++trial) {
            double x[12];
            random_points(&rng, x, pairs[p].n);
            defsim__dtype t;
            pairs[p].f(x, NULL, NULL, &t);
            /* Keep away from region boundaries: the type must hold at +-1e-4 in every
             * coordinate. */
            int stable = 1;
            for (int i = 0; i < pairs[p].n && stable; ++i)
                for (int sgn = -1; sgn <= 1 && stable; sgn += 2) {
                    double y[12];
                    memcpy(y, x, sizeof y);
                    y[i] += sgn * 1e-4;
                    defsim__dtype ty;
                    pairs[p].f(y, NULL, NULL, &ty);
                    stable = ty == t;
                }
            if (!stable || seen[t] >= 5) continue;
            double eg, eh;
            fd_check(pairs[p].f, x, pairs[p].n, &eg, &eh);
            worst_g = fmax(worst_g, eg);
            worst_h = fmax(worst_h, eh);
            seen[t]++;
        }
        for (int t = 0; t < 4; ++t)
            if (pairs[p].types & (1 << t)) assert_int_equal(seen[t], 5);
        print_message("pair %d: worst relative gradient error %.2e, Hessian %.2e\n", p, worst_g,
                      worst_h);
        assert_true(worst_g < 1e-7);
        assert_true(worst_h < 1e-5);
    }
}

/* Exact values in known configurations. */
static void test_known_distances(void **state)
{
    (void)state;
    defsim__dtype t;
    /* A point 0.3 above the interior of the unit right triangle in z = 0. */
    const double x1[12] = {0.2, 0.2, 0.3, 0, 0, 0, 1, 0, 0, 0, 1, 0};
    assert_true(fabs(pt(x1, NULL, NULL, &t) - 0.09) < 1e-15);
    assert_int_equal(t, DEFSIM__D_PT);
    /* Beyond vertex t1: point-point. */
    const double x2[12] = {2, -1, 0, 0, 0, 0, 1, 0, 0, 0, 1, 0};
    assert_true(fabs(pt(x2, NULL, NULL, &t) - 2.0) < 1e-15);
    assert_int_equal(t, DEFSIM__D_PP);
    /* Crossing edges 0.5 apart: line-line. */
    const double x3[12] = {-1, 0, 0, 1, 0, 0, 0, -1, 0.5, 0, 1, 0.5};
    assert_true(fabs(ee(x3, NULL, NULL, &t) - 0.25) < 1e-15);
    assert_int_equal(t, DEFSIM__D_EE);
    /* Parallel edges 0.4 apart, overlapping: the endpoint candidates give the exact distance. */
    const double x4[12] = {0, 0, 0, 2, 0, 0, 1, 0.4, 0, 3, 0.4, 0};
    assert_true(fabs(ee(x4, NULL, NULL, &t) - 0.16) < 1e-15);
    assert_int_equal(t, DEFSIM__D_PE);
}

static void test_mollifier(void **state)
{
    (void)state;
    /* Nearly parallel edges: c = |ea x eb|^2 below eps. */
    const double x[12] = {0, 0, 0, 1, 0, 0, 0.1, 0.3, 0.05, 1.1, 0.31, 0.06};
    eps_x = defsim__ee_mollifier_eps(x, x + 3, x + 6, x + 9);
    double g[12], H[144];
    const double m = defsim__ee_mollifier(x, x + 3, x + 6, x + 9, eps_x, g, H);
    assert_true(m > 0.0 && m < 1.0);
    double eg, eh;
    fd_check(moll, x, 12, &eg, &eh);
    print_message("mollifier: relative gradient error %.2e, Hessian %.2e (m = %.3f)\n", eg, eh,
                  m);
    assert_true(eg < 1e-7 && eh < 1e-5);
    /* Crossing edges: m = 1 and zero derivatives. */
    const double y[12] = {-1, 0, 0, 1, 0, 0, 0, -1, 0.5, 0, 1, 0.5};
    assert_true(defsim__ee_mollifier(y, y + 3, y + 6, y + 9, eps_x, g, H) == 1.0);
    for (int i = 0; i < 12; ++i) assert_true(g[i] == 0.0);
}

/* The smallest distance over a fine sampling of the motion on [0, t]. */
static double min_along(pair_fn f, const double *x0, const double *dx, double t)
{
    double best = INFINITY;
    for (int i = 0; i <= 20000; ++i) {
        double x[12];
        for (int k = 0; k < 12; ++k) x[k] = x0[k] + t * i / 20000.0 * dx[k];
        best = fmin(best, sqrt(f(x, NULL, NULL, NULL)));
    }
    return best;
}

static void test_accd(void **state)
{
    (void)state;
    /* A point falling onto a triangle's interior from 1 m at 4 m per unit time: contact at
     * t = 0.25. ACCD stops before, at no less than s = 0.1 of the start distance, and not
     * needlessly early. */
    const double x[12] = {0.2, 0.2, 1.0, 0, 0, 0, 1, 0, 0, 0, 1, 0};
    const double dx[12] = {0, 0, -4.0, 0, 0, 0, 0, 0, 0, 0, 0, 0};
    const double t = defsim__pt_accd(x, dx, 0.1, 1.0, 1000);
    print_message("point onto triangle: toi 0.25, ACCD %.4f\n", t);
    assert_true(t < 0.25 && t >= 0.8 * 0.25 * 0.9);
    /* Moving apart: tmax. */
    const double up[12] = {0, 0, 4.0, 0, 0, 0, 0, 0, 0, 0, 0, 0};
    assert_true(defsim__pt_accd(x, up, 0.1, 1.0, 1000) == 1.0);

    /* Random motions: the pair never touches on [0, t], and if t < 1 it is at least s d0 apart
     * at t (an independent fine sampling, not ACCD's own iterates). */
    unsigned long long rng = 5;
    int stopped = 0;
    for (int trial = 0; trial < 200; ++trial) {
        double y[12], dy[12];
        random_points(&rng, y, 12);
        random_points(&rng, dy, 12);
        for (int k = 0; k < 12; ++k) dy[k] *= 3.0;
        const int is_ee = trial & 1;
        pair_fn f = is_ee ? ee : pt;
        const double d0 = sqrt(f(y, NULL, NULL, NULL));
        const double ty = is_ee ? defsim__ee_accd(y, dy, 0.1, 1.0, 10000)
                                : defsim__pt_accd(y, dy, 0.1, 1.0, 10000);
        assert_true(ty >= 0.0 && ty <= 1.0);
        const double dmin = min_along(f, y, dy, ty);
        assert_true(dmin > 0.0);
        if (ty < 1.0) {
            double z[12];
            for (int k = 0; k < 12; ++k) z[k] = y[k] + ty * dy[k];
            assert_true(sqrt(f(z, NULL, NULL, NULL)) >= 0.1 * d0 * (1 - 1e-12));
            ++stopped;
        }
    }
    print_message("random motions: %d of 200 stopped before t = 1\n", stopped);
    assert_true(stopped > 20);
}

/* The orientation determinant of the four vertices of x + t dx (zero when they are coplanar,
 * which a point-triangle or edge-edge contact requires). */
static double coplanar(const double *x, const double *dx, double t)
{
    double v[4][3];
    for (int a = 0; a < 4; ++a)
        for (int k = 0; k < 3; ++k) v[a][k] = x[3 * a + k] + t * dx[3 * a + k];
    double e[3][3];
    for (int a = 0; a < 3; ++a)
        for (int k = 0; k < 3; ++k) e[a][k] = v[a + 1][k] - v[0][k];
    return e[0][0] * (e[1][1] * e[2][2] - e[1][2] * e[2][1]) -
           e[0][1] * (e[1][0] * e[2][2] - e[1][2] * e[2][0]) +
           e[0][2] * (e[1][0] * e[2][1] - e[1][1] * e[2][0]);
}

/* Every root of the cubic coplanar(t) in [0, t1], to rounding: the interval is split where the
 * determinant's derivative vanishes (a quadratic, from the cubic's coefficients fitted at four
 * times), and each monotone piece with a sign change bisected. Returns how many (<= 3). */
static int coplanar_roots(const double *x, const double *dx, double t1, double *roots)
{
    /* p(t) = c0 + c1 t + c2 t^2 + c3 t^3 from its values at 0, 1/3, 2/3, 1 */
    const double f0 = coplanar(x, dx, 0.0), f1 = coplanar(x, dx, 1.0 / 3.0),
                 f2 = coplanar(x, dx, 2.0 / 3.0), f3 = coplanar(x, dx, 1.0);
    const double c1 = (-11 * f0 + 18 * f1 - 9 * f2 + 2 * f3) / 2.0,
                 c2 = (18 * f0 - 45 * f1 + 36 * f2 - 9 * f3) / 2.0,
                 c3 = (-9 * f0 + 27 * f1 - 27 * f2 + 9 * f3) / 2.0;
    double cut[4] = {0.0, t1, t1, t1};
    int nc = 1;
    /* p'(t) = c1 + 2 c2 t + 3 c3 t^2 */
    const double A = 3 * c3, B = 2 * c2, C = c1;
    if (fabs(A) > 1e-300) {
        const double disc = B * B - 4 * A * C;
        if (disc > 0.0) {
            const double q = -0.5 * (B + copysign(sqrt(disc), B));
            double r1 = q / A, r2 = q != 0.0 ? C / q : r1;
            if (r1 > r2) {
                const double tmp = r1;
                r1 = r2;
                r2 = tmp;
            }
            if (r1 > 0.0 && r1 < t1) cut[nc++] = r1;
            if (r2 > 0.0 && r2 < t1) cut[nc++] = r2;
        }
    } else if (fabs(B) > 1e-300 && -C / B > 0.0 && -C / B < t1) {
        cut[nc++] = -C / B;
    }
    cut[nc++] = t1;
    int n = 0;
    for (int k = 0; k + 1 < nc; ++k) {
        double lo = cut[k], hi = cut[k + 1];
        double flo = coplanar(x, dx, lo), fhi = coplanar(x, dx, hi);
        if (flo == 0.0) {
            roots[n++] = lo;
            continue;
        }
        if ((flo > 0.0) == (fhi > 0.0)) continue;
        for (int it = 0; it < 200 && hi - lo > 1e-15 * (1.0 + hi); ++it) {
            const double mid = 0.5 * (lo + hi), fm = coplanar(x, dx, mid);
            if ((fm > 0.0) == (flo > 0.0)) lo = mid, flo = fm;
            else hi = mid;
        }
        if (n < 3) roots[n++] = 0.5 * (lo + hi);
    }
    return n;
}

/* IPC Toolkit's additive CCD as Li et al. 2021 state it, written here as the reference: the
 * mean displacement removed, lp = the largest displacement of the first primitive plus that of
 * the second, advances of 0.9 d / lp, stop at the advance's start once an advance ends below
 * 0.1 d0. */
static double reference_accd(pair_fn f, int first, const double *x0, const double *dx0)
{
    double dx[12], mean[3] = {0, 0, 0}, x[12];
    for (int a = 0; a < 4; ++a)
        for (int k = 0; k < 3; ++k) mean[k] += 0.25 * dx0[3 * a + k];
    for (int a = 0; a < 4; ++a)
        for (int k = 0; k < 3; ++k) dx[3 * a + k] = dx0[3 * a + k] - mean[k];
    double la = 0.0, lb = 0.0;
    for (int a = 0; a < 4; ++a) {
        const double l = sqrt(dx[3 * a] * dx[3 * a] + dx[3 * a + 1] * dx[3 * a + 1] +
                              dx[3 * a + 2] * dx[3 * a + 2]);
        if (a < first) la = fmax(la, l);
        else lb = fmax(lb, l);
    }
    memcpy(x, x0, sizeof x);
    double d = sqrt(f(x, NULL, NULL, NULL));
    const double gap = 0.1 * d;
    double t = 0.0;
    for (;;) {
        const double tl = 0.9 * d / (la + lb);
        for (int k = 0; k < 12; ++k) x[k] += tl * dx[k];
        d = sqrt(f(x, NULL, NULL, NULL));
        if (t > 0.0 && d < gap) return t;
        t += tl;
        if (t > 1.0) return 1.0;
    }
}

/* Conservative on random and near-contact motions, by two independent checks: a fine sampling
 * of [0, t] and the distance at every time in [0, t] where the four vertices are coplanar (the
 * only times a point-triangle or edge-edge pair can touch). Both must stay above
 * (1 - 0.9) s d0, the least the advances allow; and t at least ACCD's time on most pairs. */
/* A random pair (point-triangle, or edge-edge when is_ee) and its motion: anywhere, moving by up
 * to 3 per unit time, or (near) the pair in z = 0 and z = h (h from 1e-3 to 0.1), closing by up
 * to 0.2 while sliding. */
static void random_motion(unsigned long long *rng, int is_ee, int near, double y[12],
                          double dy[12])
{
    random_points(rng, y, 12);
    random_points(rng, dy, 12);
    if (near) {
        const double h = 1e-3 + 0.099 * (0.5 + 0.5 * tu_rand(rng));
        for (int a = 0; a < 4; ++a) y[3 * a + 2] = (a < (is_ee ? 2 : 1)) ? h : 0.0;
        for (int k = 0; k < 12; ++k) dy[k] *= 0.3;
        const double down = 0.1 * (1.0 + tu_rand(rng));
        for (int a = 0; a < (is_ee ? 2 : 1); ++a) dy[3 * a + 2] = -down;
    } else {
        for (int k = 0; k < 12; ++k) dy[k] *= 3.0;
    }
}

static void test_accd_conservative_and_tight(void **state)
{
    (void)state;
    unsigned long long rng = 17;
    int stopped = 0, smaller = 0, compared = 0, roots_checked = 0;
    double worst = INFINITY, ratio_sum_log = 0.0;
    for (int trial = 0; trial < 3000; ++trial) {
        const int is_ee = trial & 1, near = (trial >> 1) & 1;
        pair_fn f = is_ee ? ee : pt;
        double y[12], dy[12];
        random_motion(&rng, is_ee, near, y, dy);
        const double d0 = sqrt(f(y, NULL, NULL, NULL));
        const double s = 0.1;
        const double t = is_ee ? defsim__ee_accd(y, dy, s, 1.0, 1000000)
                               : defsim__pt_accd(y, dy, s, 1.0, 1000000);
        assert_true(t >= 0.0 && t <= 1.0);
        double dmin = min_along(f, y, dy, t);
        double roots[3];
        const int nr = coplanar_roots(y, dy, t, roots);
        for (int r = 0; r < nr; ++r) {
            double z[12];
            for (int k = 0; k < 12; ++k) z[k] = y[k] + roots[r] * dy[k];
            dmin = fmin(dmin, sqrt(f(z, NULL, NULL, NULL)));
            ++roots_checked;
        }
        worst = fmin(worst, dmin / d0);
        assert_true(dmin >= 0.1 * s * d0 * (1.0 - 1e-9));
        if (t < 1.0) {
            double z[12];
            for (int k = 0; k < 12; ++k) z[k] = y[k] + t * dy[k];
            assert_true(sqrt(f(z, NULL, NULL, NULL)) >= s * d0 * (1.0 - 1e-12));
            ++stopped;
        }
        const double tr = reference_accd(f, is_ee ? 2 : 1, y, dy);
        if (tr < 1.0) {
            ++compared;
            smaller += t < tr;
            ratio_sum_log += log(t / tr);
        }
    }
    print_message("3000 motions: %d stopped before t = 1, %d coplanar times checked, smallest "
                  "distance over [0, t] %.3f of the start; against ACCD on %d: smaller on %d, "
                  "geometric mean of ours / ACCD %.4f\n",
                  stopped, roots_checked, worst, compared, smaller,
                  exp(ratio_sum_log / (compared ? compared : 1)));
    assert_true(stopped > 300 && roots_checked > 100);
    assert_true(smaller <= compared / 100);
    assert_true(ratio_sum_log > 0.0);
}

/* CCD with a minimum separation (the contact thickness, defsim__accd_offset): a point falling
 * at 4 m per unit time from 1 m onto a triangle with xi = 0.5 reaches the offset surface at
 * t = 0.125 and stops before it, at least s (d0 - xi) beyond it; on 3000 random and closing
 * motions with xi a random 0.2 to 0.9 of the start distance, the distance sampled finely over
 * [0, t] (independently of the CCD's iterates) stays above xi, and where it stops it is at
 * least xi + s (d0 - xi); with xi = 0 the result is defsim__accd's, bit for bit. */
static void test_accd_offset(void **state)
{
    (void)state;
    const double x[12] = {0.2, 0.2, 1.0, 0, 0, 0, 1, 0, 0, 0, 1, 0};
    const double dx[12] = {0, 0, -4.0, 0, 0, 0, 0, 0, 0, 0, 0, 0};
    const double lp0 = defsim__ccd_speed(DEFSIM__CCD_PT, dx);
    const double t0 = defsim__accd_offset(DEFSIM__CCD_PT, x, dx, 0.5, 0.5, lp0, 0.1, 1.0, 1000);
    print_message("point onto triangle with xi 0.5: reaches the offset at 0.125, CCD %.4f\n", t0);
    assert_true(t0 < 0.125 && t0 >= 0.8 * 0.125 * 0.9);
    assert_true(1.0 - 4.0 * t0 >= 0.5 + 0.1 * 0.5 * (1 - 1e-12));
    unsigned long long rng = 23;
    int stopped = 0;
    double worst = INFINITY;
    for (int trial = 0; trial < 3000; ++trial) {
        const int is_ee = trial & 1, near = (trial >> 1) & 1;
        pair_fn f = is_ee ? ee : pt;
        const defsim__ccd_pair kind = is_ee ? DEFSIM__CCD_EE : DEFSIM__CCD_PT;
        double y[12], dy[12];
        random_motion(&rng, is_ee, near, y, dy);
        const double dist = sqrt(f(y, NULL, NULL, NULL));
        const double lp = defsim__ccd_speed(kind, dy);
        const double s = 0.1;
        if (trial < 200) {
            const double a = defsim__accd(kind, y, dy, dist, lp, s, 1.0, 100000);
            const double b = defsim__accd_offset(kind, y, dy, dist, 0.0, lp, s, 1.0, 100000);
            assert_memory_equal(&a, &b, sizeof a);
        }
        const double xi = (0.2 + 0.7 * tu_rand(&rng)) * dist, d0 = dist - xi;
        const double t = defsim__accd_offset(kind, y, dy, d0, xi, lp, s, 1.0, 1000000);
        assert_true(t >= 0.0 && t <= 1.0);
        const double dmin = min_along(f, y, dy, t) - xi;
        worst = fmin(worst, dmin / d0);
        assert_true(dmin > 0.0);
        if (t < 1.0) {
            double z[12];
            for (int k = 0; k < 12; ++k) z[k] = y[k] + t * dy[k];
            assert_true(sqrt(f(z, NULL, NULL, NULL)) - xi >= s * d0 * (1.0 - 1e-9));
            ++stopped;
        }
    }
    print_message("3000 motions with an offset: %d stopped before t = 1; smallest distance "
                  "beyond the offset over [0, t] %.3f of the start's\n", stopped, worst);
    assert_true(stopped > 300);
}

/* Point-edge CCD (ropes): a point swept through a segment's interior stops short of it; the
 * distance over [0, t] stays above (1 - 0.9) s d0 on random motions (fine sampling). */
static void test_pe_accd(void **state)
{
    (void)state;
    const double x[9] = {0.5, 1.0, 0.0, 0, 0, 0, 1, 0, 0};
    const double dx[9] = {0, -2.0, 0, 0, 0, 0, 0, 0, 0};
    const double t = defsim__pe_accd(x, dx, 0.1, 1.0, 100000);
    /* distance 1 - 2t reaches 0.1 at t = 0.45 */
    assert_true(t <= 0.45 && t > 0.45 - 1e-3);
    unsigned long long rng = 23;
    for (int trial = 0; trial < 500; ++trial) {
        double y[12] = {0}, dy[12] = {0};
        random_points(&rng, y, 9);
        random_points(&rng, dy, 9);
        for (int k = 0; k < 9; ++k) dy[k] *= 3.0;
        const double d0 = sqrt(pe(y, NULL, NULL, NULL));
        const double ty = defsim__pe_accd(y, dy, 0.1, 1.0, 1000000);
        double best = INFINITY;
        for (int i = 0; i <= 20000; ++i) {
            double z[9];
            for (int k = 0; k < 9; ++k) z[k] = y[k] + ty * i / 20000.0 * dy[k];
            best = fmin(best, sqrt(pe(z, NULL, NULL, NULL)));
        }
        assert_true(best >= 0.01 * d0 * (1.0 - 1e-9));
    }
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_values_against_sampling),
        cmocka_unit_test(test_derivatives_every_region),
        cmocka_unit_test(test_known_distances),
        cmocka_unit_test(test_mollifier),
        cmocka_unit_test(test_accd),
        cmocka_unit_test(test_accd_conservative_and_tight),
        cmocka_unit_test(test_accd_offset),
        cmocka_unit_test(test_pe_accd),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
