/* SPDX-License-Identifier: MIT */
/*
 * A shell strip as a cantilever under its own weight (docs/shells.md), stepped to rest by
 * newton_cholmod with long steps (implicit Euler with h = 100 s: the static problem plus a
 * vanishing proximal term) under the weight as held forces ramped up in load steps, against the elastica solved here independently:
 *   B theta'' = -q (L - s) cos theta, theta(0) = 0, theta'(L) = 0 (B = D W, q = rho_A g W),
 * by shooting on theta'(0) with RK4 (bisection), whose tip deflection over L depends only on
 * alpha = q L^3 / B = rho_A g L^3 / D. The clamp: the strip's first cell [-dx/2, dx/2] is
 * pinned, so that the first hinge, at dx/2, stands for the beam's first segment [0, dx] (a
 * hinge carries the rotation of the segment of length dx around it), and the beam runs from
 * x = 0 to L. Cells are about 8 times longer than wide (docs/shells.md: a free strip on
 * cells long across the bending direction is softer, the diagonal hinges sharing the fold):
 *   - tip deflection within 2 % of the elastica's for alpha = 0.4, 4 and 20 (small to large);
 *   - the tip deflection of the two finest of three meshes within 2 % of each other;
 *   - ASTM D1388 option A: the overhang l at which the tip meets the 41.5 degree line from the
 *     platform's edge (the clamp) gives G = W_a (l/2)^3 (W_a = rho_A g) within 3 % of D.
 */
#include "test_util.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

static const double RHO_A = 0.2, G = 9.81;

/* The elastica in s in [0, 1] (lengths over L): tip (x, y) over L for load alpha; theta'(0)
 * from bisection on theta'(1) = 0. */
static void elastica_rhs(double alpha, double s, const double y[4], double dy[4])
{
    dy[0] = y[1];
    dy[1] = -alpha * (1.0 - s) * cos(y[0]);
    dy[2] = cos(y[0]);
    dy[3] = sin(y[0]);
}

static void elastica_shoot(double alpha, double k, double out[4])
{
    const int n = 2000;
    const double h = 1.0 / n;
    double y[4] = {0.0, k, 0.0, 0.0};
    for (int i = 0; i < n; ++i) {
        const double s = i * h;
        double k1[4], k2[4], k3[4], k4[4], t[4];
        elastica_rhs(alpha, s, y, k1);
        for (int j = 0; j < 4; ++j) t[j] = y[j] + 0.5 * h * k1[j];
        elastica_rhs(alpha, s + 0.5 * h, t, k2);
        for (int j = 0; j < 4; ++j) t[j] = y[j] + 0.5 * h * k2[j];
        elastica_rhs(alpha, s + 0.5 * h, t, k3);
        for (int j = 0; j < 4; ++j) t[j] = y[j] + h * k3[j];
        elastica_rhs(alpha, s + h, t, k4);
        for (int j = 0; j < 4; ++j) y[j] += h / 6.0 * (k1[j] + 2 * k2[j] + 2 * k3[j] + k4[j]);
    }
    memcpy(out, y, sizeof y);
}

/* Tip (x, deflection) over L. */
static void elastica(double alpha, double *x, double *d)
{
    double lo = 0.0, hi = alpha, y[4];
    for (int it = 0; it < 60; ++it) {
        const double m = 0.5 * (lo + hi);
        elastica_shoot(alpha, m, y);
        if (y[1] > 0.0) hi = m;
        else lo = m;
    }
    elastica_shoot(alpha, 0.5 * (lo + hi), y);
    *x = y[2];
    *d = y[3];
}

/* The simulated strip of length L (nx cells past the clamp, ny across) clamped at x = 0 (the
 * cell [-dx/2, dx/2] pinned), at rest under gravity: tip x and deflection (mean over the tip's
 * column), both over L. */
static void strip(double L, int nx, int ny, double D, double *x, double *d)
{
    defsim_world *w = tu_implicit_world("newton_cholmod", 0.0, 1, 1e-8, 50,
                                        DEFSIM_PROJECTION_AUTO);
    const double dx = L / (nx + 0.5);
    /* The width: L / 40, so that the cells are 8 times longer than wide with 8 across at nx = 40
     * (the elastica does not depend on it). */
    const double o[3] = {-0.5 * dx, 0, 0}, u[3] = {L + 0.5 * dx, 0, 0}, v[3] = {0, 0, L / 40};
    defsim_mesh m;
    memset(&m, 0, sizeof m);
    m.size = sizeof m;
    const int nu = nx + 1;
    assert_int_equal(defsim_mesh_cloth(o, u, v, nu, ny, &m), DEFSIM_OK);
    defsim_body_def b;
    defsim_body_def_init(&b, sizeof b);
    b.rest_positions = m.positions;
    b.vertex_count = m.vertex_count;
    b.triangles = m.triangles;
    b.triangle_count = m.triangle_count;
    b.shell_membrane = DEFSIM_SHELL_MEMBRANE_STVK;
    b.shell_youngs_modulus = 1e7;
    b.shell_thickness = 1e-3;
    b.shell_poisson_ratio = 0.3;
    b.shell_areal_density = RHO_A;
    b.shell_bending_rigidity = D;
    defsim_body_id id;
    assert_int_equal(defsim_world_add_body(w, &b, &id), DEFSIM_OK);
    int32_t pins[64], np = 0;
    for (int j = 0; j <= ny; ++j)
        for (int i = 0; i < 2; ++i) pins[np++] = i + (nu + 1) * j;
    assert_int_equal(defsim_body_pin(w, id, pins, np), DEFSIM_OK);
    const int nv = m.vertex_count;
    double *p = malloc(3 * (size_t)nv * sizeof *p), *q = malloc(3 * (size_t)nv * sizeof *q);
    assert_non_null(p);
    assert_non_null(q);
    assert_int_equal(defsim_world_get_positions(w, p, nv), DEFSIM_OK);
    /* The weight m_i g as held forces (masses lumped here as body.c does: rho_A A / 3 per vertex
     * of each triangle), ramped up in load steps, each solved by 100 s steps until one moves
     * nothing (a failed Newton solve leaves the state as it was: the load step is halved). */
    double *fw = calloc(3 * (size_t)nv, sizeof *fw), *fl = malloc(3 * (size_t)nv * sizeof *fl);
    assert_non_null(fw);
    assert_non_null(fl);
    for (int t = 0; t < m.triangle_count; ++t) {
        const int32_t *tv = m.triangles + 3 * t;
        double e1[3], e2[3];
        for (int c = 0; c < 3; ++c) {
            e1[c] = m.positions[3 * tv[1] + c] - m.positions[3 * tv[0] + c];
            e2[c] = m.positions[3 * tv[2] + c] - m.positions[3 * tv[0] + c];
        }
        const double cx = e1[1] * e2[2] - e1[2] * e2[1], cy = e1[2] * e2[0] - e1[0] * e2[2],
                     cz = e1[0] * e2[1] - e1[1] * e2[0];
        const double A = 0.5 * sqrt(cx * cx + cy * cy + cz * cz);
        for (int a = 0; a < 3; ++a) fw[3 * tv[a] + 1] -= RHO_A * A / 3.0 * G;
    }
    double lam = 0.0, dl = 1.0;
    for (int tries = 0; lam < 1.0 && tries < 200; ++tries) {
        const double next = fmin(lam + dl, 1.0);
        for (int i = 0; i < 3 * nv; ++i) fl[i] = next * fw[i];
        assert_int_equal(defsim_world_set_external_forces(w, fl, nv), DEFSIM_OK);
        int ok = 1, still = 0;
        for (int k = 0; k < 20 && ok && !still; ++k) {
            const defsim_status st = defsim_world_step(w, 100.0);
            if (st == DEFSIM_ERR_NOT_CONVERGED) { ok = 0; break; }
            assert_int_equal(st, DEFSIM_OK);
            assert_int_equal(defsim_world_get_positions(w, q, nv), DEFSIM_OK);
            double mv = 0.0;
            for (int i = 0; i < 3 * nv; ++i) mv = fmax(mv, fabs(q[i] - p[i]));
            memcpy(p, q, 3 * (size_t)nv * sizeof *p);
            still = mv < 1e-8 * L;
        }
        if (ok && still) lam = next;
        else dl *= 0.5;
        if (!ok) assert_int_equal(defsim_world_get_positions(w, p, nv), DEFSIM_OK);
    }
    assert_true(lam == 1.0);
    free(fw);
    free(fl);
    *x = *d = 0.0;
    for (int j = 0; j <= ny; ++j) {
        const int t = nu + (nu + 1) * j;
        *x += p[3 * t] / (ny + 1);
        *d -= p[3 * t + 1] / (ny + 1);
    }
    *x /= L;
    *d /= L;
    free(p);
    free(q);
    defsim_mesh_free(&m);
    defsim_world_destroy(w);
}

static void test_elastica(void **state)
{
    (void)state;
    const double L = 0.2, alphas[3] = {0.4, 4.0, 20.0};
    for (int k = 0; k < 3; ++k) {
        const double D = RHO_A * G * L * L * L / alphas[k];
        double ex, ed, sx, sd;
        elastica(alphas[k], &ex, &ed);
        strip(L, 40, 8, D, &sx, &sd);
        print_message("alpha %5.1f: tip deflection / L simulated %.5f, elastica %.5f (%+.2f %%); "
                      "small-deflection alpha/8 = %.5f\n", alphas[k], sd, ed,
                      100 * (sd - ed) / ed, alphas[k] / 8);
        assert_true(fabs(sd - ed) < 0.02 * ed);
    }
}

static void test_refinement(void **state)
{
    (void)state;
    const double L = 0.2, D = RHO_A * G * L * L * L / 4.0;
    double d[3], x;
    const int n[3] = {10, 20, 40};
    for (int k = 0; k < 3; ++k) strip(L, n[k], n[k] / 5, D, &x, &d[k]);
    print_message("alpha 4: tip deflection / L with %d, %d, %d cells: %.5f %.5f %.5f "
                  "(finest two %+.3f %%)\n", n[0], n[1], n[2], d[0], d[1], d[2],
                  100 * (d[2] - d[1]) / d[2]);
    assert_true(fabs(d[2] - d[1]) < 0.02 * d[2]);
    assert_true(fabs(d[2] - d[1]) < fabs(d[1] - d[0]));   /* converging */
}

/* ASTM D1388 option A: the overhang at which the tip's chord from the edge is 41.5 degrees
 * below horizontal, by the secant method on the simulated angle. */
static void test_d1388(void **state)
{
    (void)state;
    const double D = 2e-5;   /* N m, a light fabric's: bending length (D / W_a)^(1/3) = 2.2 cm */
    const double target = 41.5 * 3.14159265358979323846 / 180.0;
    double l[2] = {0.035, 0.05}, f[2];
    for (int k = 0; k < 2; ++k) {
        double x, d;
        strip(l[k], 40, 8, D, &x, &d);
        f[k] = atan2(d, x) - target;
    }
    double lc = l[1];
    for (int it = 0; it < 8 && fabs(f[1]) > 1e-5; ++it) {
        lc = l[1] - f[1] * (l[1] - l[0]) / (f[1] - f[0]);
        double x, d;
        strip(lc, 40, 8, D, &x, &d);
        l[0] = l[1]; f[0] = f[1];
        l[1] = lc; f[1] = atan2(d, x) - target;
    }
    const double c = 0.5 * lc, Gm = RHO_A * G * c * c * c;
    print_message("D1388: overhang %.4f m, bending length %.4f m, G = W c^3 = %.4e N m "
                  "(put in %.4e: %+.2f %%)\n", lc, c, Gm, D, 100 * (Gm - D) / D);
    assert_true(fabs(f[1]) < 1e-4);
    assert_true(fabs(Gm - D) < 0.03 * D);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_elastica),
        cmocka_unit_test(test_refinement),
        cmocka_unit_test(test_d1388),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
