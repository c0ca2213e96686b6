/* SPDX-License-Identifier: MIT */
/*
 * sundials_kinsol: backward-Euler trajectories against an independent dense Newton solution, the
 * meaning of the tolerance (a position residual relative to the scene size, the same in metres
 * and millimetres), statistics, failures that leave the state untouched, dissipation, and the
 * conformance checks (rest, momentum, pins).
 */
#include "be_reference.h"
#include "registry.h"
#include "test_util.h"
#include "world.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static defsim_world *kin_world(double tol, int max_iter, double gy, defsim_projection proj)
{
    return tu_implicit_world("sundials_kinsol", gy, 1, tol, max_iter, proj);
}

static defsim_world *cantilever(double tol, int max_iter, defsim_model model, double alpha,
                                double beta, defsim_projection proj, double unit)
{
    return be_cantilever("sundials_kinsol", tol, max_iter, model, alpha, beta, proj, unit);
}

/* Runs `steps` steps of h with the backend and with the dense reference from the same start;
 * returns the largest relative differences of x and v over the run. */
static void compare_with_reference(defsim_world *w, int steps, double h, double *ex, double *ev)
{
    const int n = defsim_world_vertex_count(w);
    double *xr = tu_positions(w), *vr = tu_velocities(w);
    double *x1 = malloc(3 * (size_t)n * sizeof *x1), *v1 = malloc(3 * (size_t)n * sizeof *v1);
    *ex = *ev = 0.0;
    for (int s = 0; s < steps; ++s) {
        be_reference_step(w, xr, vr, h, x1, v1);
        memcpy(xr, x1, 3 * (size_t)n * sizeof *xr);
        memcpy(vr, v1, 3 * (size_t)n * sizeof *vr);
        TU_OK(defsim_world_step(w, h));
        double *x = tu_positions(w), *v = tu_velocities(w);
        *ex = fmax(*ex, tu_rel_diff(x, xr, 3 * n, 1e-300));
        *ev = fmax(*ev, tu_rel_diff(v, vr, 3 * n, 1e-300));
        free(x);
        free(v);
    }
    free(xr); free(vr); free(x1); free(v1);
}

static void test_vs_dense_reference(void **state)
{
    (void)state;
    struct { defsim_model model; double alpha, beta; defsim_projection proj; const char *label; }
    cases[4] = {
        {DEFSIM_MODEL_STABLE_NEOHOOKEAN, 0.0, 0.0, DEFSIM_PROJECTION_CLAMP, "stable NH, undamped"},
        {DEFSIM_MODEL_STABLE_NEOHOOKEAN, 0.5, 0.02, DEFSIM_PROJECTION_CLAMP, "stable NH, Rayleigh"},
        {DEFSIM_MODEL_NEOHOOKEAN, 0.0, 0.0, DEFSIM_PROJECTION_NONE, "NH, exact Hessians"},
        {DEFSIM_MODEL_COROTATED, 0.3, 0.0, DEFSIM_PROJECTION_ABS, "co-rotated, |eig| Hessians"},
    };
    for (int c = 0; c < 4; ++c) {
        defsim_world *w = cantilever(1e-12, 50, cases[c].model, cases[c].alpha, cases[c].beta,
                                     cases[c].proj, 1.0);
        double ex, ev;
        compare_with_reference(w, 15, 0.02, &ex, &ev);
        defsim_stats st = {.size = sizeof st};
        TU_OK(defsim_world_stats(w, &st));
        printf("kinsol vs dense backward Euler (%s): rel. diff x %.2e, v %.2e; Newton %lld in 15 "
               "steps, backtracks %lld\n", cases[c].label, ex, ev,
               (long long)tu_bstat(w, "newton_iterations"), (long long)tu_bstat(w, "line_search_backtracks"));
        assert_true(ex < 1e-10);
        assert_true(ev < 1e-8);
        assert_true(tu_bstat(w, "newton_iterations") >= 15 && tu_bstat(w, "newton_iterations") <= 15 * 8);
        assert_int_equal(tu_bstat(w, "jacobian_evals"), tu_bstat(w, "newton_iterations"));
        assert_int_equal(tu_bstat(w, "linear_solves"), tu_bstat(w, "newton_iterations"));
        assert_true(tu_bstat(w, "residual_evals") > tu_bstat(w, "newton_iterations"));
        assert_int_equal(tu_bstat(w, "convergence_failures"), 0);
        assert_true(tu_bstat(w, "time_factor") > 0.0 && tu_bstat(w, "time_solve") > 0.0);
        defsim_world_destroy(w);
    }
}

/* The tolerance bounds the position error of a step relative to the scene size. */
static void test_tolerance_is_relative_position(void **state)
{
    (void)state;
    const double tols[3] = {1e-4, 1e-6, 1e-8};
    double errs[3];
    for (int k = 0; k < 3; ++k) {
        defsim_world *w = cantilever(tols[k], 50, DEFSIM_MODEL_STABLE_NEOHOOKEAN, 0.0, 0.0,
                                     DEFSIM_PROJECTION_CLAMP, 1.0);
        const int n = defsim_world_vertex_count(w);
        double *x0 = tu_positions(w), *v0 = tu_velocities(w);
        double *xr = malloc(3 * (size_t)n * sizeof *xr), *vr = malloc(3 * (size_t)n * sizeof *vr);
        be_reference_step(w, x0, v0, 0.05, xr, vr);
        TU_OK(defsim_world_step(w, 0.05));
        double *x = tu_positions(w);
        double e = 0.0;
        for (int i = 0; i < 3 * n; ++i) e = fmax(e, fabs(x[i] - xr[i]));
        errs[k] = e / w->sys.length_scale;
        printf("kinsol tolerance %.0e: position error / L = %.2e\n", tols[k], errs[k]);
        assert_true(errs[k] <= tols[k]);
        free(x0); free(v0); free(xr); free(vr); free(x);
        defsim_world_destroy(w);
    }
}

/* The same scene in metres and in millimetres: the same Newton iterations, the same motion. */
static void test_units_invariance(void **state)
{
    (void)state;
    defsim_world *wm = cantilever(1e-6, 50, DEFSIM_MODEL_STABLE_NEOHOOKEAN, 0.2, 0.01,
                                  DEFSIM_PROJECTION_CLAMP, 1.0);
    defsim_world *wmm = cantilever(1e-6, 50, DEFSIM_MODEL_STABLE_NEOHOOKEAN, 0.2, 0.01,
                                   DEFSIM_PROJECTION_CLAMP, 1000.0);
    const int n = defsim_world_vertex_count(wm);
    defsim_stats a = {.size = sizeof a}, b = {.size = sizeof b};
    for (int s = 0; s < 10; ++s) {
        TU_OK(defsim_world_step(wm, 0.03));
        TU_OK(defsim_world_step(wmm, 0.03));
        TU_OK(defsim_world_stats(wm, &a));
        TU_OK(defsim_world_stats(wmm, &b));
        assert_int_equal(tu_bstat(wm, "newton_iterations"), tu_bstat(wmm, "newton_iterations"));
    }
    double *x = tu_positions(wm), *y = tu_positions(wmm);
    for (int i = 0; i < 3 * n; ++i) y[i] /= 1000.0;
    const double d = tu_rel_diff(y, x, 3 * n, 1.0);
    printf("kinsol metres vs millimetres: %lld Newton iterations each, rel. diff %.2e\n",
           (long long)tu_bstat(wm, "newton_iterations"), d);
    assert_true(d < 1e-5);
    free(x); free(y);
    defsim_world_destroy(wm);
    defsim_world_destroy(wmm);
}

/* One Newton iteration cannot solve a large nonlinear step: DEFSIM_ERR_NOT_CONVERGED, nothing
 * changed, and later steps run as in a fresh world. */
static void test_failure_leaves_state(void **state)
{
    (void)state;
    defsim_world *w = cantilever(1e-8, 1, DEFSIM_MODEL_STABLE_NEOHOOKEAN, 0.0, 0.0,
                                 DEFSIM_PROJECTION_CLAMP, 1.0);
    defsim_world *fresh = cantilever(1e-8, 50, DEFSIM_MODEL_STABLE_NEOHOOKEAN, 0.0, 0.0,
                                     DEFSIM_PROJECTION_CLAMP, 1.0);
    const int n = defsim_world_vertex_count(w);
    double *x0 = tu_positions(w), *v0 = tu_velocities(w);
    assert_int_equal(defsim_world_step(w, 0.2), DEFSIM_ERR_NOT_CONVERGED);
    assert_true(strlen(defsim_world_last_error(w)) > 0);
    double *x1 = tu_positions(w), *v1 = tu_velocities(w);
    assert_memory_equal(x0, x1, 3 * (size_t)n * sizeof *x0);
    assert_memory_equal(v0, v1, 3 * (size_t)n * sizeof *v0);
    assert_true(defsim_world_time(w) == 0.0);
    defsim_stats st = {.size = sizeof st};
    TU_OK(defsim_world_stats(w, &st));
    assert_int_equal(st.failed_steps, 1);
    assert_int_equal(tu_bstat(w, "convergence_failures"), 2);   /* from y, then from x_n */
    /* A step short enough to be nearly linear converges in one iteration. */
    TU_OK(defsim_world_step(w, 1e-4));
    TU_OK(defsim_world_step(fresh, 1e-4));
    double *xa = tu_positions(w), *xb = tu_positions(fresh);
    assert_true(tu_rel_diff(xa, xb, 3 * n, 1.0) < 1e-12);
    free(x0); free(v0); free(x1); free(v1); free(xa); free(xb);
    defsim_world_destroy(w);
    defsim_world_destroy(fresh);
}

/* Backward Euler dissipates: without damping the total energy still falls, step after step,
 * even at steps far beyond the explicit limit. */
static void test_dissipation_large_steps(void **state)
{
    (void)state;
    defsim_world *w = kin_world(1e-8, 50, -9.81, DEFSIM_PROJECTION_CLAMP);
    const double lo[3] = {0, 0, 0}, hi[3] = {3, 1, 1};
    defsim_body_id b = tu_add_box(w, DEFSIM_MODEL_STABLE_NEOHOOKEAN, 6, 2, 2, lo, hi, 1e6, 0.3,
                                  1000);
    tu_pin_below(w, b, 0, 0.0);
    defsim_energy e0, e;
    TU_OK(defsim_world_energy(w, &e0));
    double prev = e0.total;
    for (int s = 0; s < 20; ++s) {
        TU_OK(defsim_world_step(w, 0.05));
        TU_OK(defsim_world_energy(w, &e));
        assert_true(e.total <= prev + 1e-9 * fabs(e0.total) + 1e-12);
        prev = e.total;
    }
    printf("kinsol h = 0.05 s on a 1 MPa beam: total energy %.6g J -> %.6g J in 20 steps\n",
           e0.total, e.total);
    assert_true(e.total < e0.total);
    double *x = tu_positions(w);
    const int n = defsim_world_vertex_count(w);
    for (int i = 0; i < 3 * n; ++i) assert_true(isfinite(x[i]));
    free(x);
    defsim_world_destroy(w);
}

/* A neo-Hookean cube hit so hard that the inertial guess x_n + h v_n passes the top through the
 * bottom, where the energy is undefined: the solve starts over from x_n and finds the
 * compressed, uninverted solution. */
static void test_inverting_guess(void **state)
{
    (void)state;
    defsim_world *w = kin_world(1e-8, 50, 0.0, DEFSIM_PROJECTION_CLAMP);
    const double lo[3] = {0, 0, 0}, hi[3] = {1, 1, 1};
    defsim_body_id b = tu_add_box(w, DEFSIM_MODEL_NEOHOOKEAN, 1, 1, 1, lo, hi, 1e5, 0.3, 1000);
    tu_pin_below(w, b, 1, 0.0);
    const int n = defsim_world_vertex_count(w);
    double *x = tu_positions(w), *v = tu_velocities(w);
    for (int i = 0; i < n; ++i)
        if (x[3 * i + 1] > 0.5) v[3 * i + 1] = -30.0;
    TU_OK(defsim_world_set_state(w, NULL, v));
    defsim_energy e0, e1;
    TU_OK(defsim_world_energy(w, &e0));
    TU_OK(defsim_world_step(w, 0.1));   /* x_n + h v_n puts the top at y = -2 */
    TU_OK(defsim_world_energy(w, &e1));
    free(x);
    x = tu_positions(w);
    for (int i = 0; i < n; ++i)
        if (fabs(x[3 * i + 1]) > 1e-12) assert_true(x[3 * i + 1] > 0.0 && x[3 * i + 1] < 1.0);
    printf("kinsol neo-Hookean cube from an inverted guess: energy %.4g J -> %.4g J\n", e0.total,
           e1.total);
    assert_true(isfinite(e1.total) && e1.total < e0.total);
    free(x); free(v);
    defsim_world_destroy(w);
}

/* ---------------------------------------------------------------------------------------- */
/* Conformance: rest, momentum, pins. */

static void test_rest_stays_at_rest(void **state)
{
    (void)state;
    defsim_world *w = kin_world(1e-8, 50, 0.0, DEFSIM_PROJECTION_CLAMP);
    const double lo[3] = {0, 0, 0}, hi[3] = {1, 1, 1};
    tu_add_box(w, DEFSIM_MODEL_STABLE_NEOHOOKEAN, 2, 2, 2, lo, hi, 1e5, 0.3, 1000);
    const int n = defsim_world_vertex_count(w);
    double *x0 = tu_positions(w);
    for (int s = 0; s < 5; ++s) TU_OK(defsim_world_step(w, 0.05));
    double *x = tu_positions(w), *v = tu_velocities(w);
    for (int i = 0; i < 3 * n; ++i) {
        assert_true(x[i] == x0[i]);
        assert_true(v[i] == 0.0);
    }
    free(x0); free(x); free(v);
    defsim_world_destroy(w);
}

static void test_free_body_momentum(void **state)
{
    (void)state;
    defsim_world *w = kin_world(1e-8, 50, -9.81, DEFSIM_PROJECTION_CLAMP);
    tu_check_free_fall(w, "kinsol", -9.81, 11, 10, 0.02, 1e-9);
    defsim_world_destroy(w);
}

static void test_pinned_fixed(void **state)
{
    (void)state;
    defsim_world *w = cantilever(1e-6, 50, DEFSIM_MODEL_STABLE_NEOHOOKEAN, 0.0, 0.0,
                                 DEFSIM_PROJECTION_CLAMP, 1.0);
    tu_check_clamped_end(w, 10, 0.05, 4);
    defsim_world_destroy(w);
}

static void test_flags(void **state)
{
    (void)state;
    defsim_world *w = kin_world(1e-6, 50, 0.0, DEFSIM_PROJECTION_CLAMP);   /* loads the module */
    defsim_world_destroy(w);
    const defsim_backend *b = NULL;
    TU_OK(defsim__find_backend("sundials_kinsol", &b));
    assert_true(b->flags & DEFSIM_BACKEND_NEEDS_MATRIX);
    assert_true(b->flags & DEFSIM_BACKEND_IMPLICIT);
    assert_true(b->flags & DEFSIM_BACKEND_DISSIPATIVE);
    assert_false(b->flags & DEFSIM_BACKEND_ADAPTIVE);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_flags),
        cmocka_unit_test(test_vs_dense_reference),
        cmocka_unit_test(test_tolerance_is_relative_position),
        cmocka_unit_test(test_units_invariance),
        cmocka_unit_test(test_failure_leaves_state),
        cmocka_unit_test(test_dissipation_large_steps),
        cmocka_unit_test(test_inverting_guess),
        cmocka_unit_test(test_rest_stays_at_rest),
        cmocka_unit_test(test_free_body_momentum),
        cmocka_unit_test(test_pinned_fixed),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
