/* SPDX-License-Identifier: MIT */
/* The explicit integrators against analytic solutions, conservation, and measured orders. */
#include "test_util.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* A mass m on a spring k to a pinned anchor, displaced by a along x, no gravity. */
static defsim_world *oscillator(const char *backend, double m, double k, double a)
{
    defsim_world *w = tu_world(backend, 0.0, 1);
    const tu_spring2 o = {.l0 = 1, .x1 = {1 + a, 0, 0}, .m0 = 1.0, .m1 = m, .k = k,
                          .pin_anchor = 1};
    tu_add_spring2(w, &o);
    return w;
}

static double displacement(defsim_world *w)
{
    double x[6];
    TU_OK(defsim_world_get_positions(w, x, 2));
    return x[3] - 1.0;
}

/* Period from upward zero crossings of the displacement (linear interpolation). */
static void test_spring_period(void **state)
{
    (void)state;
    const double m = 0.5, k = 200.0, h = 1e-4, T = 2 * 3.14159265358979323846 * sqrt(m / k);
    defsim_world *w = oscillator("symplectic_euler", m, k, 0.01);
    double prev = displacement(w), first = -1, last = -1;
    int crossings = 0;
    for (int i = 1; i <= (int)(10.5 * T / h); ++i) {
        TU_OK(defsim_world_step(w, h));
        double d = displacement(w);
        if (prev < 0 && d >= 0) {
            double t = (i - 1) * h + h * (-prev) / (d - prev);
            if (crossings == 0) first = t;
            last = t;
            ++crossings;
        }
        prev = d;
    }
    assert_true(crossings >= 9);
    double period = (last - first) / (crossings - 1);
    printf("spring period: measured %.8f, 2 pi sqrt(m/k) = %.8f, rel. error %.2e\n", period, T,
           fabs(period - T) / T);
    assert_true(fabs(period - T) < 1e-3 * T);
    defsim_world_destroy(w);
}

/* 1e5 steps: symplectic Euler's energy stays within 1 %; explicit Euler's grows. */
static void test_energy_drift(void **state)
{
    (void)state;
    const double m = 0.5, k = 200.0, h = 2e-4;   /* omega h = 0.004 */
    double dev[2] = {0, 0}, ratio[2] = {0, 0};
    const char *names[2] = {"symplectic_euler", "explicit_euler"};
    for (int b = 0; b < 2; ++b) {
        defsim_world *w = oscillator(names[b], m, k, 0.01);
        defsim_energy e0, e;
        TU_OK(defsim_world_energy(w, &e0));
        for (int i = 0; i < 100000; ++i) {
            TU_OK(defsim_world_step(w, h));
            if (i % 97 == 0 || i == 99999) {
                TU_OK(defsim_world_energy(w, &e));
                dev[b] = fmax(dev[b], fabs(e.total - e0.total) / e0.total);
            }
        }
        ratio[b] = e.total / e0.total;
        defsim_world_destroy(w);
    }
    printf("energy over 1e5 steps (omega h = 0.004): symplectic max deviation %.3f %%, end/start "
           "%.5f; explicit end/start %.3f\n", 100 * dev[0], ratio[0], ratio[1]);
    assert_true(dev[0] < 0.01);
    assert_true(fabs(ratio[0] - 1.0) < 0.01);
    assert_true(ratio[1] > 2.0);   /* (1 + (omega h)^2)^N = e^1.6 ~ 4.95 */
    assert_true(fabs(ratio[1] - exp(100000 * log1p(0.004 * 0.004))) < 0.05 * ratio[1]);
}

/* --------------------------------------------------------------------------------------- */
/* Convergence in h on a nonlinear scene: a soft neo-Hookean cantilever sagging under gravity. */

enum { READ_SYNC = 0, READ_STAGGERED = 1 };

static defsim_world *beam(const char *backend, int32_t *pinned_n)
{
    defsim_world *w = tu_world(backend, -9.81, 1);
    const double lo[3] = {0, 0, 0}, hi[3] = {2, 0.5, 0.5};
    defsim_body_id b = tu_add_box(w, DEFSIM_MODEL_NEOHOOKEAN, 4, 1, 1, lo, hi, 2e4, 0.3, 1000);
    *pinned_n = tu_pin_below(w, b, 0, 0.0);
    return w;
}

/* Acceleration M^-1 (f_elastic + m g) with pinned vertices (x = 0) at zero. */
static void accel(defsim_world *w, const double *x, double *a)
{
    int n = defsim_world_vertex_count(w);
    double *m = malloc((size_t)n * sizeof *m);
    TU_OK(defsim_world_get_masses(w, m, n));
    TU_OK(defsim_world_forces(w, x, a));
    double *x0 = tu_positions(w);
    for (int i = 0; i < n; ++i)
        for (int c = 0; c < 3; ++c) {
            double g = c == 1 ? -9.81 : 0.0;
            a[3 * i + c] = x0[3 * i] <= 1e-12 ? 0.0 : a[3 * i + c] / m[i] + g;
        }
    free(m);
    free(x0);
}

/* Runs to time T with step h; returns positions and synchronous velocities (6n doubles). */
static double *run_to(const char *backend, int read, double T, double h)
{
    int32_t np;
    defsim_world *w = beam(backend, &np);
    int n = defsim_world_vertex_count(w);
    double *a = malloc(3 * (size_t)n * sizeof *a);
    {
        /* Start swinging up (v = 0.5 x along y): from rest the synchronous velocities would be
         * second order by a cancellation that holds only for v_0 = 0 (see README). */
        double *x = tu_positions(w), *v = tu_velocities(w);
        for (int i = 0; i < n; ++i) v[3 * i + 1] = 0.5 * x[3 * i];
        TU_OK(defsim_world_set_state(w, NULL, v));
        free(x);
        free(v);
    }
    if (read == READ_STAGGERED) {
        /* Store v_{-1/2} = v_0 - h/2 a(x_0): symplectic Euler then is leapfrog. */
        double *x = tu_positions(w), *v = tu_velocities(w);
        accel(w, x, a);
        for (int i = 0; i < 3 * n; ++i) v[i] -= 0.5 * h * a[i];
        TU_OK(defsim_world_set_state(w, NULL, v));
        free(x);
        free(v);
    }
    int steps = (int)lround(T / h);
    for (int i = 0; i < steps; ++i) TU_OK(defsim_world_step(w, h));
    double *out = malloc(6 * (size_t)n * sizeof *out);
    double *x = tu_positions(w), *v = tu_velocities(w);
    if (read == READ_STAGGERED) {
        accel(w, x, a);   /* v_N = v_{N-1/2} + h/2 a(x_N) */
        for (int i = 0; i < 3 * n; ++i) v[i] += 0.5 * h * a[i];
    }
    memcpy(out, x, 3 * (size_t)n * sizeof *x);
    memcpy(out + 3 * n, v, 3 * (size_t)n * sizeof *v);
    free(x); free(v); free(a);
    defsim_world_destroy(w);
    return out;
}

static double err_max(const double *a, const double *b, int n)
{
    double e = 0;
    for (int i = 0; i < n; ++i) e = fmax(e, fabs(a[i] - b[i]));
    return e;
}

static void test_convergence_orders(void **state)
{
    (void)state;
    const double T = 0.1;
    const int n3 = 3 * 5 * 2 * 2;
    double *ref = run_to("symplectic_euler", READ_STAGGERED, T, 1e-3 / 256);
    const double hs[4] = {1e-3, 5e-4, 2.5e-4, 1.25e-4};
    struct { const char *backend; int read; const char *label; double lo, hi; } cases[3] = {
        {"explicit_euler", READ_SYNC, "explicit Euler", 0.85, 1.15},
        {"symplectic_euler", READ_SYNC, "symplectic Euler, synchronous (x_n, v_n)", 0.85, 1.15},
        {"symplectic_euler", READ_STAGGERED, "symplectic Euler, staggered (v at half steps)", 1.85, 2.15},
    };
    for (int c = 0; c < 3; ++c) {
        double ex[4], ev[4];
        for (int k = 0; k < 4; ++k) {
            double *r = run_to(cases[c].backend, cases[c].read, T, hs[k]);
            ex[k] = err_max(r, ref, n3);
            ev[k] = err_max(r + n3, ref + n3, n3);
            free(r);
        }
        double px = log2(ex[2] / ex[3]), pv = log2(ev[2] / ev[3]);
        printf("order %-48s x: %.3f (errors %.2e %.2e %.2e %.2e)  v: %.3f\n", cases[c].label,
               px, ex[0], ex[1], ex[2], ex[3], pv);
        assert_true(px > cases[c].lo && px < cases[c].hi);
        assert_true(pv > cases[c].lo && pv < cases[c].hi);
        assert_true(log2(ex[1] / ex[2]) > cases[c].lo - 0.1);
    }
    free(ref);
}

/* A free body under gravity falls with exact free-fall kinematics (internal forces cancel). */
static void test_free_fall_momentum(void **state)
{
    (void)state;
    defsim_world *w = tu_world("symplectic_euler", -9.81, 2);
    tu_check_free_fall(w, "symplectic_euler", -9.81, 2, 500, 1e-4, 1e-10);
    defsim_world_destroy(w);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_spring_period),
        cmocka_unit_test(test_energy_drift),
        cmocka_unit_test(test_convergence_orders),
        cmocka_unit_test(test_free_fall_momentum),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
