/* SPDX-License-Identifier: MIT */
/*
 * The second-order backends (velocity_verlet, newmark, bdf2): a damped spring-mass system
 * against its analytic solution with the observed order, Newmark's energy conservation, the
 * invalidation of Verlet's carried force and of BDF2's history, and Verlet's stability limit
 * with and without auto_substep.
 */
#include "test_util.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define PI 3.14159265358979323846


/* Errors in x and v at T of N steps against x(t) = e^{-ct/2} a (cos wd t + c/(2 wd) sin wd t). */
static void oscillator_error(const char *backend, int N, double *ex, double *ev)
{
    const double m = 0.5, k = 200.0, alpha = 0.8, beta = 2e-3, a = 0.01, T = 1.0;
    const double om2 = k / m, c = alpha + beta * om2, wd = sqrt(om2 - 0.25 * c * c);
    defsim_world *w = tu_oscillator(backend, 1.0, m, k, alpha, beta, a, 1, 0);
    for (int i = 0; i < N; ++i) TU_OK(defsim_world_step(w, T / N));
    double x[6], v[6];
    TU_OK(defsim_world_get_positions(w, x, 2));
    TU_OK(defsim_world_get_velocities(w, v, 2));
    const double e = exp(-0.5 * c * T), cs = cos(wd * T), sn = sin(wd * T);
    const double xe = a * e * (cs + 0.5 * c / wd * sn);
    const double ve = -a * e * (om2 / wd) * sn;
    *ex = fabs(x[3] - 1.0 - xe) / a;
    *ev = fabs(v[3] - ve) / (a * sqrt(om2));
    defsim_world_destroy(w);
}

/* Observed orders in x and v between h = T/400 and T/800 (omega h = 0.05 .. 0.025), with
 * mass and stiffness damping: each between 1.9 and 2.1, and the error itself small. */
static void test_oscillator_orders(void **state)
{
    (void)state;
    const char *names[] = {"velocity_verlet", "newmark", "bdf2"};
    for (int b = 0; b < 3; ++b) {
        if (!tu_available(names[b])) continue;
        double ex[3], ev[3];
        const int N[3] = {200, 400, 800};
        for (int j = 0; j < 3; ++j) oscillator_error(names[b], N[j], &ex[j], &ev[j]);
        const double px = log2(ex[1] / ex[2]), pv = log2(ev[1] / ev[2]);
        printf("%-16s errors x %.3e %.3e %.3e (order %.3f), v %.3e %.3e %.3e (order %.3f)\n",
               names[b], ex[0], ex[1], ex[2], px, ev[0], ev[1], ev[2], pv);
        assert_true(px > 1.9 && px < 2.1);
        assert_true(pv > 1.9 && pv < 2.1);
        assert_true(log2(ex[0] / ex[1]) > 1.8 && log2(ev[0] / ev[1]) > 1.8);
        assert_true(ex[2] < 1e-2 && ev[2] < 1e-2);
    }
}

/* Undamped linear oscillator at omega h = 1 (a sixth of a period per step), 10^4 steps: Newmark
 * conserves 1/2 m v^2 + 1/2 k x^2 to round-off; backward Euler loses nearly all of it. */
static void test_newmark_linear_energy(void **state)
{
    (void)state;
    if (!tu_available("newmark") || !tu_available("newton_cholmod")) skip();
    const double m = 0.5, k = 200.0, h = 1.0 / sqrt(k / m);
    const char *names[2] = {"newmark", "newton_cholmod"};
    double ratio[2], dev[2];
    for (int b = 0; b < 2; ++b) {
        defsim_world *w = tu_oscillator(names[b], 1.0, m, k, 0.0, 0.0, 0.01, 1, 0);
        ratio[b] = tu_energy_run(w, h, 10000, &dev[b]);
        defsim_world_destroy(w);
    }
    printf("omega h = 1, 1e4 steps: newmark max |dE|/E %.2e; newton_cholmod E_end/E_0 %.2e\n",
           dev[0], ratio[1]);
    assert_true(dev[0] < 1e-9);
    assert_true(ratio[1] < 1e-3);
}

/* BDF2 on an undamped linear oscillator: the energy never rises from one step to the next (the
 * backward-Euler start included) at omega h from 0.1 to 5, and it does decay. */
static void test_bdf2_energy_monotone(void **state)
{
    (void)state;
    if (!tu_available("bdf2")) skip();
    const double m = 0.5, k = 200.0, om = sqrt(k / m);
    const double oh[4] = {0.1, 0.5, 1.0, 5.0};
    for (int j = 0; j < 4; ++j) {
        defsim_world *w = tu_oscillator("bdf2", 1.0, m, k, 0.0, 0.0, 0.01, 1, 0);
        double v0[6] = {0, 0, 0, 0.1, 0, 0};   /* start off the turning point */
        TU_OK(defsim_world_set_state(w, NULL, v0));
        defsim_energy e0, e;
        TU_OK(defsim_world_energy(w, &e0));
        double prev = e0.total;
        for (int i = 0; i < 400; ++i) {
            TU_OK(defsim_world_step(w, oh[j] / om));
            TU_OK(defsim_world_energy(w, &e));
            assert_true(e.total <= prev * (1.0 + 1e-12));
            prev = e.total;
        }
        printf("bdf2, omega h = %.1f: E after 400 steps / E0 = %.3g\n", oh[j], e.total / e0.total);
        assert_true(e.total < e0.total);
        defsim_world_destroy(w);
    }
}

/* --------------------------------------------------------------------------------------- */
/* An undamped soft beam (stable neo-Hookean, 2 m x 0.5 m x 0.5 m, clamped at x = 0) set swinging
 * by an initial velocity, no gravity: total energy over 10 s at h = 1/60 s. */

static defsim_world *swinging_beam(const char *backend)
{
    defsim_world *w = tu_world(backend, 0.0, 1);
    const double lo[3] = {0, 0, 0}, hi[3] = {2, 0.5, 0.5};
    defsim_body_id b = tu_add_box(w, DEFSIM_MODEL_STABLE_NEOHOOKEAN, 4, 1, 1, lo, hi, 1e5, 0.3,
                                  1000);
    tu_pin_below(w, b, 0, 0.0);
    const int n = defsim_world_vertex_count(w);
    double *x = tu_positions(w), *v = calloc(3 * (size_t)n, sizeof *v);
    for (int i = 0; i < n; ++i) v[3 * i + 1] = 0.5 * x[3 * i] * x[3 * i];   /* up to 2 m/s */
    TU_OK(defsim_world_set_state(w, NULL, v));
    free(x);
    free(v);
    return w;
}

static void test_newmark_beam_energy(void **state)
{
    (void)state;
    if (!tu_available("newmark") || !tu_available("newton_cholmod")) skip();
    const char *names[2] = {"newmark", "newton_cholmod"};
    double dev = 0.0, end[2];
    for (int b = 0; b < 2; ++b) {
        defsim_world *w = swinging_beam(names[b]);
        defsim_energy e0, e;
        TU_OK(defsim_world_energy(w, &e0));
        for (int i = 0; i < 600; ++i) {
            TU_OK(defsim_world_step(w, 1.0 / 60.0));
            TU_OK(defsim_world_energy(w, &e));
            if (b == 0) dev = fmax(dev, fabs(e.total - e0.total) / e0.total);
        }
        end[b] = e.total / e0.total;
        defsim_world_destroy(w);
    }
    printf("swinging beam, 10 s at h = 1/60 s: newmark max |dE|/E %.2e, E_end/E_0 %.5f; "
           "newton_cholmod E_end/E_0 %.4f\n", dev, end[0], end[1]);
    assert_true(dev < 0.01);
    assert_true(end[1] < 0.5);
}

/* --------------------------------------------------------------------------------------- */
/* Invalidation of carried state. */

/* A small beam under gravity (body 0), clamped at x = 0; bit-identical comparisons. */
static defsim_world *beam(const char *backend, defsim_body_id *id)
{
    defsim_world *w = tu_world(backend, -9.81, 1);
    const double lo[3] = {0, 0, 0}, hi[3] = {2, 0.5, 0.5};
    *id = tu_add_box(w, DEFSIM_MODEL_STABLE_NEOHOOKEAN, 4, 1, 1, lo, hi, 2e4, 0.3, 1000);
    tu_pin_below(w, *id, 0, 0.0);
    return w;
}

/* The beam's rest state with free vertices displaced and set moving (fixed seed). */
static void perturbed(defsim_world *w, double **x, double **v)
{
    const int n = defsim_world_vertex_count(w);
    *x = tu_positions(w);
    *v = tu_velocities(w);
    unsigned long long seed = 7;
    for (int i = 0; i < 3 * n; ++i)
        if ((*x)[i - i % 3] > 0.0) {
            (*x)[i] += 0.02 * tu_rand(&seed);
            (*v)[i] += 0.3 * tu_rand(&seed);
        }
}

static int same_state(defsim_world *a, defsim_world *b)
{
    const int n = defsim_world_vertex_count(a);
    double *xa = tu_positions(a), *xb = tu_positions(b);
    double *va = tu_velocities(a), *vb = tu_velocities(b);
    const size_t bytes = 3 * (size_t)n * sizeof *xa;
    const int same = !memcmp(xa, xb, bytes) && !memcmp(va, vb, bytes);
    free(xa);
    free(xb);
    free(va);
    free(vb);
    return same;
}

/* `backend` carries state from step to step (velocity_verlet its force, bdf2 its history).
 * - set_state: a world that stepped, then set to (x, v) and stepped k times, is bit-identical
 *   to a fresh world set to (x, v) and stepped k times; and, where `carry_shows`, the carry-over
 *   matters: a world that stepped without set_state up to (x', v') differs from a fresh one set
 *   to (x', v'). (Verlet's carried force of an undamped scene is the fresh one bit for bit.)
 * - pins: a world re-pinned after stepping equals a fresh world with the same pins and state. */
static void check_invalidation(const char *backend, double h, int carry_shows)
{
    defsim_body_id ia, ifr, ic;
    defsim_world *a = beam(backend, &ia), *fresh = beam(backend, &ifr);
    double *x, *v;
    perturbed(a, &x, &v);
    TU_OK(defsim_world_set_state(a, x, v));
    for (int i = 0; i < 5; ++i) TU_OK(defsim_world_step(a, h));
    TU_OK(defsim_world_set_state(a, x, v));
    TU_OK(defsim_world_set_state(fresh, x, v));
    for (int i = 0; i < 3; ++i) {
        TU_OK(defsim_world_step(a, h));
        TU_OK(defsim_world_step(fresh, h));
    }
    assert_true(same_state(a, fresh));

    /* Without set_state the carried state is used: continuing differs from restarting. */
    double *x1 = tu_positions(a), *v1 = tu_velocities(a);
    defsim_world *c = beam(backend, &ic);
    TU_OK(defsim_world_set_state(c, x1, v1));
    TU_OK(defsim_world_step(a, h));
    TU_OK(defsim_world_step(c, h));
    if (carry_shows) assert_false(same_state(a, c));
    defsim_world_destroy(c);

    /* Pins: pin the far end of a (which has carried state) and of a fresh world at a's state. */
    double *x2 = tu_positions(a), *v2 = tu_velocities(a);
    const int n = defsim_world_vertex_count(a);
    int32_t far[64];
    int nf = 0;
    for (int i = 0; i < n && nf < 64; ++i)
        if (x2[3 * i] > 1.95) far[nf++] = i;
    assert_true(nf > 0);
    defsim_world *b = beam(backend, &ic);
    TU_OK(defsim_world_set_state(b, x2, v2));
    TU_OK(defsim_body_pin(b, ic, far, nf));
    TU_OK(defsim_body_pin(a, ia, far, nf));
    for (int i = 0; i < 3; ++i) {
        TU_OK(defsim_world_step(a, h));
        TU_OK(defsim_world_step(b, h));
    }
    assert_true(same_state(a, b));
    defsim_world_destroy(b);
    free(x);
    free(v);
    free(x1);
    free(v1);
    free(x2);
    free(v2);
    defsim_world_destroy(a);
    defsim_world_destroy(fresh);
}

/* bdf2 restarts with one backward-Euler step: without stiffness damping its first step after
 * set_state is bit-identical to newton_cholmod's from the same state. */
static void test_bdf2_first_step_is_backward_euler(void **state)
{
    (void)state;
    if (!tu_available("bdf2") || !tu_available("newton_cholmod")) skip();
    defsim_body_id ia, ib;
    defsim_world *a = beam("bdf2", &ia), *b = beam("newton_cholmod", &ib);
    double *x, *v;
    perturbed(a, &x, &v);
    TU_OK(defsim_world_set_state(a, x, v));
    for (int i = 0; i < 4; ++i) TU_OK(defsim_world_step(a, 1.0 / 60.0));
    TU_OK(defsim_world_set_state(a, x, v));
    TU_OK(defsim_world_set_state(b, x, v));
    TU_OK(defsim_world_step(a, 1.0 / 60.0));
    TU_OK(defsim_world_step(b, 1.0 / 60.0));
    assert_true(same_state(a, b));
    /* The second step is BDF2 proper, no longer backward Euler. */
    TU_OK(defsim_world_step(a, 1.0 / 60.0));
    TU_OK(defsim_world_step(b, 1.0 / 60.0));
    assert_false(same_state(a, b));
    free(x);
    free(v);
    defsim_world_destroy(a);
    defsim_world_destroy(b);
}

static void test_verlet_invalidation(void **state)
{
    (void)state;
    check_invalidation("velocity_verlet", 2e-4, 0);
}

/* One force evaluation per step, plus one after each invalidation. */
static void test_verlet_force_count(void **state)
{
    (void)state;
    defsim_body_id id;
    defsim_world *w = beam("velocity_verlet", &id);
    double *x, *v;
    perturbed(w, &x, &v);
    defsim_stats st = {.size = sizeof st};
    for (int i = 0; i < 10; ++i) TU_OK(defsim_world_step(w, 2e-4));
    TU_OK(defsim_world_stats(w, &st));
    assert_int_equal(st.force_evals, 11);
    TU_OK(defsim_world_set_state(w, x, v));
    free(x);
    free(v);
    for (int i = 0; i < 10; ++i) TU_OK(defsim_world_step(w, 2e-4));
    TU_OK(defsim_world_stats(w, &st));
    assert_int_equal(st.force_evals, 22);
    defsim_world_destroy(w);
}

static void test_bdf2_restart(void **state)
{
    (void)state;
    if (!tu_available("bdf2")) skip();
    check_invalidation("bdf2", 1.0 / 60.0, 1);
}

/* --------------------------------------------------------------------------------------- */
/* Options and counters by name, shared by the three implicit schemes. */

static double option(defsim_world *w, const char *name)
{
    double v = NAN;
    TU_OK(defsim_world_get_option(w, name, &v));
    return v;
}

static double stat(defsim_world *w, const char *name)
{
    double v = NAN;
    TU_OK(defsim_world_stat(w, name, &v));
    return v;
}

/* A beam compressed to 60 % along its axis, one step of h = 1 s: the exact Hessian is
 * indefinite there (projection none needs diagonal shifts; clamp never does). Returns the
 * backend's shifted_factorisations counter. */
static double compressed_step_shifts(const char *backend, const char *projection)
{
    char name[64];
    defsim_body_id id;
    defsim_world *w = beam(backend, &id);
    snprintf(name, sizeof name, "%s.projection", backend);
    TU_OK(defsim_world_set_option(w, name, projection));
    snprintf(name, sizeof name, "%s.max_iterations", backend);
    TU_OK(defsim_world_set_option(w, name, "200"));
    double *x = tu_positions(w);
    for (int i = 0; i < defsim_world_vertex_count(w); ++i) x[3 * i] *= 0.6;
    TU_OK(defsim_world_set_state(w, x, NULL));
    TU_OK(defsim_world_step(w, 1.0));
    snprintf(name, sizeof name, "%s.shifted_factorisations", backend);
    const double shifts = stat(w, name);
    free(x);
    defsim_world_destroy(w);
    return shifts;
}

static void test_implicit_options(void **state)
{
    (void)state;
    const char *names[] = {"newton_cholmod", "newmark", "bdf2"};
    char name[64];
    for (int b = 0; b < 3; ++b) {
        if (!tu_available(names[b])) skip();
        defsim_body_id id;
        defsim_world *w = beam(names[b], &id);
        snprintf(name, sizeof name, "%s.tolerance", names[b]);
        assert_true(option(w, name) == 1e-6);
        /* One Newton iteration at tolerance 1e-12 cannot converge: a clean failure, state kept;
         * back at 50 iterations the same step succeeds. */
        TU_OK(defsim_world_set_option(w, name, "1e-12"));
        snprintf(name, sizeof name, "%s.max_iterations", names[b]);
        TU_OK(defsim_world_set_option(w, name, "1"));
        double *x0 = tu_positions(w), *x1;
        assert_int_equal(defsim_world_step(w, 1.0 / 60.0), DEFSIM_ERR_NOT_CONVERGED);
        x1 = tu_positions(w);
        assert_memory_equal(x0, x1, 3 * (size_t)defsim_world_vertex_count(w) * sizeof *x0);
        TU_OK(defsim_world_set_option(w, name, "50"));
        TU_OK(defsim_world_step(w, 1.0 / 60.0));
        assert_int_equal(defsim_world_set_option(w, name, "0"), DEFSIM_ERR_INVALID_ARGUMENT);
        snprintf(name, sizeof name, "%s.cholmod_ordering", names[b]);
        TU_OK(defsim_world_set_option(w, name, "metis"));
        assert_true(option(w, name) == 2);
        TU_OK(defsim_world_step(w, 1.0 / 60.0));
        free(x0);
        free(x1);
        defsim_world_destroy(w);

        const double none = compressed_step_shifts(names[b], "none");
        const double clamp = compressed_step_shifts(names[b], "clamp");
        printf("%-15s compressed beam, h = 1 s: shifted factorisations none %g, clamp %g\n",
               names[b], none, clamp);
        assert_true(none > 0.0);
        assert_true(clamp == 0.0);
    }
}

/* The counters of carried state: velocity_verlet.force_restarts and bdf2.restarts count the
 * steps that started without it. */
static void test_restart_counters(void **state)
{
    (void)state;
    const char *names[2] = {"velocity_verlet", "bdf2"};
    const char *counters[2] = {"velocity_verlet.force_restarts", "bdf2.restarts"};
    const double h[2] = {2e-4, 1.0 / 60.0};
    for (int b = 0; b < 2; ++b) {
        if (!tu_available(names[b])) continue;
        defsim_body_id id;
        defsim_world *w = beam(names[b], &id);
        double *x, *v;
        perturbed(w, &x, &v);
        for (int i = 0; i < 4; ++i) TU_OK(defsim_world_step(w, h[b]));
        assert_true(stat(w, counters[b]) == 1.0);
        TU_OK(defsim_world_set_state(w, x, v));
        for (int i = 0; i < 4; ++i) TU_OK(defsim_world_step(w, h[b]));
        assert_true(stat(w, counters[b]) == 2.0);
        const int32_t far = defsim_body_vertex_count(w, id) - 1;
        TU_OK(defsim_body_pin(w, id, &far, 1));
        TU_OK(defsim_world_step(w, h[b]));
        assert_true(stat(w, counters[b]) == 3.0);
        free(x);
        free(v);
        defsim_world_destroy(w);
    }
}

/* --------------------------------------------------------------------------------------- */
/* Velocity Verlet's stability limit: 2 / (c + sqrt(c^2 + omega^2)). */

/* Energy after `steps` steps of h, relative to the start (inf if the step failed). */
static double energy_ratio(double alpha, double beta, double h, int steps, int auto_substep)
{
    const double m = 0.5, k = 200.0;
    defsim_world *w =
        tu_oscillator("velocity_verlet", 1.0, m, k, alpha, beta, 0.01, 1, auto_substep);
    defsim_energy e0, e;
    TU_OK(defsim_world_energy(w, &e0));
    for (int i = 0; i < steps; ++i)
        if (defsim_world_step(w, h) != DEFSIM_OK) {
            defsim_world_destroy(w);
            return INFINITY;
        }
    TU_OK(defsim_world_energy(w, &e));
    defsim_world_destroy(w);
    return e.total / e0.total;
}

static void test_verlet_stable_step(void **state)
{
    (void)state;
    const double m = 0.5, k = 200.0, om = sqrt(k / m);
    const double damping[3][2] = {{0.0, 0.0}, {4.0, 0.0}, {1.0, 2e-3}};
    for (int d = 0; d < 3; ++d) {
        const double alpha = damping[d][0], beta = damping[d][1], c = alpha + beta * om * om;
        defsim_world *w = tu_oscillator("velocity_verlet", 1.0, m, k, alpha, beta, 0.01, 1, 0);
        double hs, omega;
        TU_OK(defsim_world_stable_step(w, &hs, &omega));
        defsim_world_destroy(w);
        const double want = 2.0 / (c + sqrt(c * c + om * om));
        printf("c = %.2f 1/s: stable step %.6f s (want %.6f), omega %.4f\n", c, hs, want, omega);
        assert_true(fabs(omega - om) < 1e-6 * om);
        assert_true(fabs(hs - want) < 1e-6 * want);
        /* Just below the limit the energy stays bounded; just above it grows (until the spring
         * is stretched past its anchor and the nonlinearity takes over). */
        const double below = energy_ratio(alpha, beta, 0.99 * want, 4000, 0);
        const double above = energy_ratio(alpha, beta, 1.02 * want, 4000, 0);
        printf("  h = 0.99 limit: E/E0 %.3g; 1.02 limit: %.3g\n", below, above);
        assert_true(below < 2.0);
        assert_true(above > 1e3);
    }
    /* auto_substep: 1.5 times the limit is split into two substeps (omega h = 1.5) that keep the
     * energy within leapfrog's bounded oscillation, a factor 1 - (omega h)^2/4 = 0.44 either way
     * of the start; off, it blows up. */
    const double h = 1.5 * 2.0 / om;
    const double on = energy_ratio(0.0, 0.0, h, 2000, 1), off = energy_ratio(0.0, 0.0, h, 2000, 0);
    printf("h = 1.5 x 2/omega: auto_substep on E/E0 %.4f, off %.3g\n", on, off);
    assert_true(on > 0.4 && on < 2.5);
    assert_true(off > 1e6);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_oscillator_orders),
        cmocka_unit_test(test_newmark_linear_energy),
        cmocka_unit_test(test_newmark_beam_energy),
        cmocka_unit_test(test_bdf2_energy_monotone),
        cmocka_unit_test(test_verlet_invalidation),
        cmocka_unit_test(test_verlet_force_count),
        cmocka_unit_test(test_bdf2_restart),
        cmocka_unit_test(test_bdf2_first_step_is_backward_euler),
        cmocka_unit_test(test_verlet_stable_step),
        cmocka_unit_test(test_implicit_options),
        cmocka_unit_test(test_restart_counters),
    };
    return tu_exit(cmocka_run_group_tests(tests, NULL, NULL));
}
