/* SPDX-License-Identifier: MIT */
/*
 * One body-contact constraint's barrier (src/contact_pair.c), for the four contact types in
 * every closest-feature region (and the mollified edge-edge barrier):
 *   - the gradient against central differences of the energy;
 *   - the projected Hessian against the exact eigenvalue clamp of the whole 3n x 3n Hessian,
 *     computed independently: the barrier's Hessian from the distance's derivatives
 *     (contact_prim.c) and the chain rule written here, clamped by cyclic Jacobi (mat3.c) on
 *     the full matrix; agreement to 1e-10 of its norm;
 *   - the same reference Hessian against central differences of the kernel's gradient before
 *     the clamp (the clamp of the differences agrees with the kernel's to 1e-5);
 *   - positive semi-definiteness and the translations in the null space;
 * and all of it again for the barrier with a thickness offset, kappa b(d - xi)
 * (defsim__contact_barrier_offset), whose reference is the same chain rule on d - xi.
 */
#include "contact_barrier.h"
#include "contact_pair.h"
#include "contact_prim.h"
#include "mat3.h"
#include "test_util.h"

#include <math.h>
#include <string.h>

/* The region of a constraint (contact_prim's closest features). */
static int region(int type, const double *X, int nodes[4])
{
    double s;
    defsim__dtype dt = DEFSIM__D_PP;
    if (type == DEFSIM__C_FV) defsim__pt_closest(X, &s, &dt, nodes);
    else if (type == DEFSIM__C_EE) defsim__ee_closest(X, &s, &dt, nodes);
    else if (type == DEFSIM__C_EV) defsim__pe_closest(X, &s, &dt, nodes);
    else nodes[0] = 0, nodes[1] = 1;
    return (int)dt;
}

/* The barrier's Hessian before projection, written independently of the kernel: the chain rule
 * of kappa b(sqrt(s) - xi) (times the mollifier for edge-edge) on the distance's derivatives. */
static void reference_hessian(int type, const double *X, double dh, double xi, double kap,
                              double eps, double *H)
{
    const int nd = 3 * defsim__contact_nodes(type);
    double gs[12], Hs[144];
    const double s = defsim__contact_dist2(type, X, gs, Hs), d = sqrt(s);
    const double b0 = kap * barrier(d - xi, dh), b1 = kap * barrier_d1(d - xi, dh),
                 b2 = kap * barrier_d2(d - xi, dh);
    double gd[12];
    for (int i = 0; i < nd; ++i) gd[i] = gs[i] / (2.0 * d);
    for (int i = 0; i < nd; ++i)
        for (int j = 0; j < nd; ++j)
            H[i * nd + j] =
                b2 * gd[i] * gd[j] + b1 * (Hs[i * nd + j] / (2.0 * d) - gd[i] * gd[j] / d);
    if (type != DEFSIM__C_EE) return;
    double gm[12], Hm[144];
    const double m = defsim__ee_mollifier(X, X + 3, X + 6, X + 9, eps, gm, Hm);
    for (int i = 0; i < 12; ++i)
        for (int j = 0; j < 12; ++j)
            H[i * 12 + j] = m * H[i * 12 + j] + b1 * (gd[i] * gm[j] + gm[i] * gd[j]) +
                            b0 * Hm[i * 12 + j];
}

static double max_abs(const double *a, int n)
{
    double m = 0.0;
    for (int i = 0; i < n; ++i) m = fmax(m, fabs(a[i]));
    return m;
}

typedef struct worst {
    double grad, exact, fd, psd;
    int seen[4];
} worst;

/* All checks on one constraint; returns 0 when it was skipped (too near a region boundary). */
static int check_one(int type, const double *X0, double dh, double xi, double eps, worst *w)
{
    const int n = defsim__contact_nodes(type), nd = 3 * n;
    double X[12], g[12], H[144];
    memcpy(X, X0, (size_t)nd * sizeof *X);
    int nodes[4];
    const int r0 = region(type, X, nodes);
    /* keep away from region boundaries: the region must hold at +-1e-4 in every coordinate */
    for (int i = 0; i < nd; ++i)
        for (int sg = -1; sg <= 1; sg += 2) {
            double Y[12];
            memcpy(Y, X, sizeof Y);
            Y[i] += sg * 1e-4;
            if (region(type, Y, nodes) != r0) return 0;
        }
    const double kap = 3.0;
    const double e = defsim__contact_barrier_offset(type, X, dh, xi, kap, eps, 0, g, H);
    assert_true(e > 0.0 && isfinite(e));
    assert_true(defsim__contact_barrier_offset(type, X, dh, xi, kap, eps, 0, NULL, NULL) == e);
    if (xi == 0.0) {
        /* the offset 0 is the plain barrier, bit for bit */
        double g0[12], H0[144];
        assert_true(defsim__contact_barrier(type, X, dh, kap, eps, g0, H0) == e);
        assert_memory_equal(g0, g, (size_t)nd * sizeof *g);
        assert_memory_equal(H0, H, (size_t)(nd * nd) * sizeof *H);
    }

    /* gradient against central differences of the energy; the Hessian before the clamp
     * against central differences of the gradient */
    /* (with an offset, the barrier's argument d - xi is smaller than d: the step shrinks with
     * it, so that the truncation error h^2 / (3 (d - xi)^2) stays as small as without) */
    const double z = sqrt(defsim__contact_dist2(type, X, NULL, NULL)) - xi;
    const double h = xi > 0.0 ? 1e-6 * fmin(1.0, 2.0 * z) : 1e-6;
    double Hfd[144], gp[12], gm[12];
    double eg = 0.0;
    for (int i = 0; i < nd; ++i) {
        X[i] = X0[i] + h;
        const double ep = defsim__contact_barrier_offset(type, X, dh, xi, kap, eps, 0, gp, NULL);
        X[i] = X0[i] - h;
        const double em = defsim__contact_barrier_offset(type, X, dh, xi, kap, eps, 0, gm, NULL);
        X[i] = X0[i];
        eg = fmax(eg, fabs((ep - em) / (2 * h) - g[i]));
        for (int j = 0; j < nd; ++j) Hfd[j * nd + i] = (gp[j] - gm[j]) / (2 * h);
    }
    w->grad = fmax(w->grad, eg / max_abs(g, nd));

    double Href[144];
    reference_hessian(type, X, dh, xi, kap, eps, Href);
    for (int i = 0; i < nd; ++i)
        for (int j = 0; j < i; ++j)
            Hfd[i * nd + j] = Hfd[j * nd + i] = 0.5 * (Hfd[i * nd + j] + Hfd[j * nd + i]);
    double efd = 0.0;
    for (int i = 0; i < nd * nd; ++i) efd = fmax(efd, fabs(Hfd[i] - Href[i]));
    w->fd = fmax(w->fd, efd / max_abs(Href, nd * nd));

    /* the exact clamp of the whole matrix */
    defsim__project_psd(nd, Href, DEFSIM_PROJECTION_CLAMP);
    double ex = 0.0;
    for (int i = 0; i < nd * nd; ++i) ex = fmax(ex, fabs(H[i] - Href[i]));
    const double scale = max_abs(Href, nd * nd);
    w->exact = fmax(w->exact, ex / scale);

    /* PSD, symmetric, translations in the null space */
    double A[144], lam[12], V[144];
    memcpy(A, H, (size_t)(nd * nd) * sizeof *A);
    defsim__sym_eig(nd, A, lam, V);
    for (int k = 0; k < nd; ++k) w->psd = fmin(w->psd, lam[k] / scale);
    for (int i = 0; i < nd; ++i) {
        for (int j = 0; j < nd; ++j) assert_true(H[i * nd + j] == H[j * nd + i]);
        for (int c = 0; c < 3; ++c)
            if (i % 3 == c) {
                double sum = 0.0;
                for (int a = 0; a < n; ++a) sum += H[i * nd + 3 * a + c];
                assert_true(fabs(sum) <= 1e-11 * scale);
            }
    }
    w->seen[r0]++;
    return 1;
}

/* Random constraints of each type, scaled so that the distance (beyond the offset xi, a random
 * 0.2 to 0.9 of the distance when `offset`) is 0.05 to 0.95 of dhat (and on a quarter of them
 * 1e-6, 1e-3 or 0.999 of it), until each region of the type has been checked 40 times. */
static void every_type_and_region(int offset)
{
    static const char *names[4] = {"VV", "EV", "FV", "EE"};
    static const int regions[4] = {1 << DEFSIM__D_PP, 1 << DEFSIM__D_PP | 1 << DEFSIM__D_PE,
                                   1 << DEFSIM__D_PP | 1 << DEFSIM__D_PE | 1 << DEFSIM__D_PT,
                                   1 << DEFSIM__D_PP | 1 << DEFSIM__D_PE | 1 << DEFSIM__D_EE};
    unsigned long long rng = 3;
    for (int type = 0; type < 4; ++type) {
        worst w = {0.0, 0.0, 0.0, 0.0, {0, 0, 0, 0}};
        const int nd = 3 * defsim__contact_nodes(type);
        for (int trial = 0; trial < 200000; ++trial) {
            double X[12];
            for (int i = 0; i < nd; ++i) X[i] = tu_rand(&rng);
            const double dist = sqrt(defsim__contact_dist2(type, X, NULL, NULL));
            const double xi = offset ? (0.2 + 0.7 * tu_rand(&rng)) * dist : 0.0;
            const double d = dist - xi;   /* the barrier's argument */
            /* mostly 0.05 to 0.95 of dhat; one in four at 1e-6, 1e-3 or 0.999 of it */
            static const double extreme[4] = {1e-6, 1e-3, 0.999, 0.5};
            const double dh = (trial & 6) ? d / (0.5 + 0.45 * tu_rand(&rng))
                                          : d / extreme[(trial >> 3) & 3];
            int nodes[4];
            const int r = region(type, X, nodes);
            if (w.seen[r] >= 40) continue;
            /* edge-edge: eps below |ea x eb|^2 (mollifier off) on even trials, above on odd */
            double eps = 0.0;
            if (type == DEFSIM__C_EE) {
                double ea[3], eb[3], c[3];
                for (int k = 0; k < 3; ++k) ea[k] = X[3 + k] - X[k], eb[k] = X[9 + k] - X[6 + k];
                c[0] = ea[1] * eb[2] - ea[2] * eb[1];
                c[1] = ea[2] * eb[0] - ea[0] * eb[2];
                c[2] = ea[0] * eb[1] - ea[1] * eb[0];
                const double cc = c[0] * c[0] + c[1] * c[1] + c[2] * c[2];
                eps = (trial & 1) ? 2.0 * cc : 0.5 * cc;
            }
            check_one(type, X, dh, xi, eps, &w);
        }
        print_message("%s%s: regions seen %d %d %d %d; worst relative gradient error %.2e, "
                      "reference Hessian vs differences %.2e, against the exact clamp %.2e, "
                      "smallest eigenvalue %.2e\n",
                      offset ? "offset " : "", names[type], w.seen[0], w.seen[1], w.seen[2], w.seen[3], w.grad, w.fd,
                      w.exact, w.psd);
        for (int t = 0; t < 4; ++t)
            if (regions[type] & (1 << t)) assert_int_equal(w.seen[t], 40);
        /* far inside dhat b ~ -dhat^2 ln d: the differences' truncation error h^2 b''' / 6 is
         * h^2 / (3 d^2) of b', which the smallest random distances bring to the 1e-6 level */
        assert_true(w.grad < 1e-5);
        assert_true(w.fd < 1e-5);
        assert_true(w.exact < 1e-10);
        assert_true(w.psd > -1e-12);
    }
}

static void test_every_type_and_region(void **state)
{
    (void)state;
    every_type_and_region(0);
}

/* The barrier with a thickness offset: the same checks, with xi a random 0.2 to 0.9 of the
 * distance. */
static void test_offset_every_type_and_region(void **state)
{
    (void)state;
    every_type_and_region(1);
}

/* The offset's band: nothing at d >= xi + dhat (0.3 with xi 0.1, dhat 0.15), +inf at d <= xi (and at 0), and at
 * xi < d < xi + dhat the plain barrier of d - xi: a point-point pair at 0.3 with xi 0.1 and
 * dhat 0.5 has kappa b(0.2), gradient kappa b'(0.2) n and H = kappa b''(0.2) on n. */
static void test_offset_band(void **state)
{
    (void)state;
    const double X[6] = {0, 0, 0.3, 0, 0, 0};
    double g[6], H[36];
    assert_true(defsim__contact_barrier_offset(DEFSIM__C_VV, X, 0.15, 0.1, 1.0, 0.0, 0, g, H) == 0.0);
    assert_true(defsim__contact_barrier_offset(DEFSIM__C_VV, X, 0.21, 0.1, 1.0, 0.0, 0, g, H) > 0.0);
    assert_true(isinf(defsim__contact_barrier_offset(DEFSIM__C_VV, X, 0.2, 0.3, 1.0, 0.0, 0, g, H)));
    assert_true(isinf(defsim__contact_barrier_offset(DEFSIM__C_VV, X, 0.2, 0.35, 1.0, 0.0, 0, g, H)));
    const double e = defsim__contact_barrier_offset(DEFSIM__C_VV, X, 0.5, 0.1, 2.0, 0.0, 0, g, H);
    assert_true(fabs(e - 2.0 * barrier(0.2, 0.5)) < 1e-15);
    const double b2 = 2.0 * barrier_d2(0.2, 0.5);
    for (int i = 0; i < 6; ++i)
        for (int j = 0; j < 6; ++j) {
            const double want = (i % 3 == 2 && j % 3 == 2) ? ((i < 3) == (j < 3) ? b2 : -b2) : 0.0;
            assert_true(fabs(H[i * 6 + j] - want) <= 1e-14 * b2);
        }
    assert_true(fabs(g[2] - 2.0 * barrier_d1(0.2, 0.5)) < 1e-14 * fabs(g[2]));
}

/* Outside dhat nothing; at distance zero +inf; point-point in closed form against its
 * analytic eigenvalues: kappa b'' (twice, along +-n) and 0 elsewhere. */
static void test_limits_and_vv(void **state)
{
    (void)state;
    const double X[6] = {0, 0, 0.3, 0, 0, 0};
    double g[6], H[36];
    assert_true(defsim__contact_barrier(DEFSIM__C_VV, X, 0.2, 1.0, 0.0, g, H) == 0.0);
    const double Z[6] = {1, 2, 3, 1, 2, 3};
    assert_true(isinf(defsim__contact_barrier(DEFSIM__C_VV, Z, 0.2, 1.0, 0.0, g, H)));
    const double e = defsim__contact_barrier(DEFSIM__C_VV, X, 0.5, 2.0, 0.0, g, H);
    assert_true(fabs(e - 2.0 * barrier(0.3, 0.5)) < 1e-15);
    const double b2 = 2.0 * barrier_d2(0.3, 0.5);
    /* H = b2 [n n^T, -n n^T; -n n^T, n n^T] with n = e_z */
    for (int i = 0; i < 6; ++i)
        for (int j = 0; j < 6; ++j) {
            const double want = (i % 3 == 2 && j % 3 == 2) ? ((i < 3) == (j < 3) ? b2 : -b2) : 0.0;
            assert_true(fabs(H[i * 6 + j] - want) <= 1e-14 * b2);
        }
    assert_true(fabs(g[2] - 2.0 * barrier_d1(0.3, 0.5)) < 1e-14 * fabs(g[2]));
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_every_type_and_region),
        cmocka_unit_test(test_offset_every_type_and_region),
        cmocka_unit_test(test_offset_band),
        cmocka_unit_test(test_limits_and_vv),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
