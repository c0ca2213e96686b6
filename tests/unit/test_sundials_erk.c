/* SPDX-License-Identifier: MIT */
/*
 * sundials_erk: damped oscillators against their analytic solutions (error within the
 * per-second contract and falling with the tolerance, observed order at least 4), the stability
 * limit of three tables against independent evaluations of their stability polynomials (reported
 * and used by auto_substep), stability
 * limiting on a stiff beam (few rejected steps, counters by name), history dropped on set_state,
 * and options by name (table choice, bad values refused).
 */
#include "test_util.h"

#include <complex.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* Oscillators (test_util.h) with mass damping only. */
static const tu_osc osc_set[3] = {
    {0.5, 200.0, 0.4, 0.0, 0.1, 0.5, 0},   /* w0 = 20 rad/s */
    {1.0, 50.0, 0.0, 0.0, -0.05, 1.0, 0},  /* undamped, w0 = 7.1 */
    {0.2, 20.0, 0.3, 0.0, 0.2, 0.0, 0},    /* w0 = 10 */
};

static defsim_world *erk_world(double tol)
{
    defsim_world *w = tu_world("sundials_erk", 0.0, 1);
    char v[32];
    snprintf(v, sizeof v, "%.17g", tol);
    TU_OK(defsim_world_set_option(w, "sundials_erk.rtol", v));
    TU_OK(defsim_world_set_option(w, "sundials_erk.atol", v));
    return w;
}

static double stat(defsim_world *w, const char *name)
{
    double v = -1.0;
    TU_OK(defsim_world_stat(w, name, &v));
    return v;
}

/* Error after T = 2 s (40 calls of 0.05 s) in units of T x tol, over three decades; the mean
 * step and the error give the observed order. */
static void test_oscillators(void **state)
{
    (void)state;
    const double tols[4] = {1e-6, 1e-7, 1e-8, 1e-9}, T = 2.0;
    double err[4], hmean[4];
    for (int k = 0; k < 4; ++k) {
        defsim_world *w = erk_world(tols[k]);
        tu_osc os[3];
        memcpy(os, osc_set, sizeof os);
        for (int i = 0; i < 3; ++i) tu_add_oscillator(w, &os[i], 2.0 * i);
        for (int s = 0; s < 40; ++s) TU_OK(defsim_world_step(w, 0.05));
        assert_true(fabs(defsim_world_time(w) - T) < 1e-12);
        double *x = tu_positions(w);
        err[k] = 0.0;
        for (int i = 0; i < 3; ++i) {
            double u, ve;
            tu_osc_exact(&os[i], T, &u, &ve);
            err[k] = fmax(err[k], fabs(x[3 * os[i].vertex] - 1.0 - u));
        }
        free(x);
        const double steps = stat(w, "sundials_erk.internal_steps");
        hmean[k] = T / steps;
        defsim_stats st = {.size = sizeof st};
        TU_OK(defsim_world_stats(w, &st));
        printf("erk oscillators tol %.0e: position error %.3e = %.3g x T tol; internal steps %.0f, "
               "rhs %.0f, rejected %.0f, order %d\n", tols[k], err[k], err[k] / (T * tols[k]),
               steps, stat(w, "sundials_erk.rhs_evals"),
               stat(w, "sundials_erk.error_test_failures"), (int)tu_bstat(w, "order"));
        /* The contract: tolerance per second of simulated time. */
        assert_true(err[k] <= 10.0 * T * tols[k]);
        assert_true(tu_bstat(w, "internal_steps") == (int64_t)steps && tu_bstat(w, "order") == 5);
        assert_true(stat(w, "sundials_erk.order") == 5.0);
        defsim_world_destroy(w);
    }
    for (int k = 0; k + 1 < 4; ++k) assert_true(err[k + 1] < err[k]);
    /* Three decades of tolerance: the error falls in proportion, within a factor of 10. */
    assert_true(err[0] / err[3] >= 100.0 && err[0] / err[3] <= 10000.0);
    /* Observed order between the two tightest tolerances (Dormand-Prince: 5). */
    const double p = log(err[2] / err[3]) / log(hmean[2] / hmean[3]);
    printf("erk observed order %.2f\n", p);
    assert_true(p >= 4.0);
}

/* Stability polynomials R(z) = sum r_k z^k of three tables. Dormand-Prince 5(4) propagates the
 * 5th-order solution: 1 + z + z^2/2 + z^3/6 + z^4/24 + z^5/120 + z^6/600. Bogacki-Shampine 3(2)
 * and Zonneveld 4(3) propagate explicit 3- and 4-stage solutions of order 3 and 4 (their last
 * stage only feeds the embedding), so R is the Taylor polynomial of exp(z) of that degree. On the
 * imaginary axis |R(iy)| <= 1 holds for Dormand-Prince only up to y = 0.997; the module's limit
 * is where the amplification reaches 1.01. Both are found here by bisection on the closed form;
 * the second must be what defsim_world_stable_step reports times omega_max for an undamped
 * scene. */
typedef struct erk_poly {
    const char *table;
    double r[7];
} erk_poly;

static const erk_poly polys[3] = {
    {"dormand_prince_5", {1, 1, 1.0 / 2, 1.0 / 6, 1.0 / 24, 1.0 / 120, 1.0 / 600}},
    {"bogacki_shampine_3", {1, 1, 1.0 / 2, 1.0 / 6, 0, 0, 0}},
    {"zonneveld_4", {1, 1, 1.0 / 2, 1.0 / 6, 1.0 / 24, 0, 0}},
};

static double poly_amp(const erk_poly *p, double y)
{
    const double complex z = I * y;
    double complex r = 0.0, zk = 1.0;
    for (int k = 0; k < 7; ++k, zk *= z) r += p->r[k] * zk;
    return cabs(r);
}

static double imag_limit(const erk_poly *p, double growth)
{
    double lo = 0.0, hi = 0.0;
    for (double y = 1e-3; y < 10.0; y += 1e-3) {
        if (poly_amp(p, y) > 1.0 + growth) {
            hi = y;
            break;
        }
        lo = y;
    }
    for (int it = 0; it < 60; ++it) {
        const double y = 0.5 * (lo + hi);
        if (poly_amp(p, y) > 1.0 + growth) hi = y;
        else lo = y;
    }
    return lo;
}

/* defsim_world_stable_step reports the limit of the table the option chose, switched on one
 * world; without the option, Dormand-Prince's. */
static void test_stable_step(void **state)
{
    (void)state;
    defsim_world *w = tu_world("sundials_erk", 0.0, 1);
    tu_osc o = osc_set[1];
    tu_add_oscillator(w, &o, 0.0);
    double hw[3];
    for (int k = 0; k < 3; ++k) {
        if (k > 0) TU_OK(defsim_world_set_option(w, "sundials_erk.table", polys[k].table));
        double h = 0.0, omega = 0.0;
        TU_OK(defsim_world_stable_step(w, &h, &omega));
        const double strict = imag_limit(&polys[k], 0.0), y = imag_limit(&polys[k], 1e-2);
        printf("erk %s stable step %.6g s at omega %.6g: h omega = %.6f, closed form %.6f "
               "(|R| <= 1 up to %.6f)\n", polys[k].table, h, omega, h * omega, y, strict);
        assert_true(fabs(omega - sqrt(50.0)) < 1e-3 * sqrt(50.0));
        assert_true(fabs(h * omega - y) < 1e-6 * y);
        hw[k] = h * omega;
    }
    /* The README's table: 0.997 / 1.725, 1.732 / 1.754, 2.828 / 2.832. */
    assert_true(fabs(imag_limit(&polys[0], 0.0) - 0.997) < 1e-3);
    assert_true(fabs(hw[0] - 1.725) < 1e-3 && fabs(hw[1] - 1.754) < 1e-3 &&
                fabs(hw[2] - 2.832) < 1e-3);
    defsim_world_destroy(w);
}

/* core.auto_substep splits an outer step into ceil(h / (safety h_stable)) substeps with the
 * chosen table's h_stable, and re-estimates when the table changes. */
static void test_auto_substep_table(void **state)
{
    (void)state;
    defsim_world *w = erk_world(1e-6);
    TU_OK(defsim_world_set_option(w, "core.auto_substep", "true"));
    tu_osc o = osc_set[1];
    tu_add_oscillator(w, &o, 0.0);
    const double h = 1.97, safety = 0.8, omega = sqrt(50.0);
    double expect[3], taken[3], before = 0.0;
    for (int k = 0; k < 3; ++k) {
        TU_OK(defsim_world_set_option(w, "sundials_erk.table", polys[k].table));
        TU_OK(defsim_world_step(w, h));
        const double hs = imag_limit(&polys[k], 1e-2) / omega;
        expect[k] = ceil(h / (safety * hs));
        taken[k] = stat(w, "substeps") - before;
        before = stat(w, "substeps");
        printf("erk auto_substep, %s: %.0f substeps of %.4g s (limit %.4g s), expected %.0f\n",
               polys[k].table, taken[k], h / taken[k], hs, expect[k]);
        assert_true(taken[k] == expect[k]);
        assert_true(h / taken[k] <= safety * hs);
        assert_true(fabs(stat(w, "stable_step") - hs) < 1e-4 * hs);
    }
    /* h is chosen so that the three counts differ: Dormand-Prince's limit would give 11 each. */
    assert_true(expect[0] == 11.0 && expect[1] == 10.0 && expect[2] == 7.0);
    defsim_world_destroy(w);
}

/* A stiff clamped beam (E = 1e7 Pa) at a loose tolerance for 0.5 s: the steps are set by
 * stability. With the limit on, almost no step is rejected; with it off, ERKStep finds the limit
 * by rejecting steps, many more of them, for about the same number of force evaluations. */
static defsim_world *stiff_beam(int limit)
{
    defsim_world *w = tu_world("sundials_erk", -9.81, 1);
    TU_OK(defsim_world_set_option(w, "sundials_erk.rtol", "1e-2"));
    TU_OK(defsim_world_set_option(w, "sundials_erk.atol", "1e-2"));
    TU_OK(defsim_world_set_option(w, "sundials_erk.stability_limit", limit ? "true" : "false"));
    const double lo[3] = {0, 0, 0}, hi[3] = {2, 0.5, 0.5};
    defsim_body_id b = tu_add_box(w, DEFSIM_MODEL_STABLE_NEOHOOKEAN, 8, 2, 2, lo, hi, 1e7, 0.3,
                                  1000.0);
    assert_true(tu_pin_below(w, b, 0, 0.0) > 0);
    return w;
}

static void test_stability_limiting(void **state)
{
    (void)state;
    double rejected[2], steps[2], limited[2], rhs[2];
    for (int limit = 0; limit < 2; ++limit) {
        defsim_world *w = stiff_beam(limit);
        for (int s = 0; s < 30; ++s) TU_OK(defsim_world_step(w, 1.0 / 60.0));
        steps[limit] = stat(w, "sundials_erk.internal_steps");
        rejected[limit] = stat(w, "sundials_erk.error_test_failures");
        limited[limit] = stat(w, "sundials_erk.stability_limited_steps");
        rhs[limit] = stat(w, "sundials_erk.rhs_evals");
        const double attempts = stat(w, "sundials_erk.step_attempts");
        printf("erk stiff beam, stability limit %s: %.0f steps, %.0f rejected, %.0f limited by "
               "stability, %.0f estimates\n", limit ? "on" : "off", steps[limit], rejected[limit],
               limited[limit], stat(w, "sundials_erk.stability_estimates"));
        assert_true(attempts == steps[limit] + rejected[limit]);
        if (limit) {
            double h = 0.0;
            TU_OK(defsim_world_stable_step(w, &h, NULL));
            /* Most steps sit on the limit, and only a few percent are rejected. */
            assert_true(limited[limit] >= 0.5 * steps[limit]);
            assert_true(rejected[limit] <= 0.05 * steps[limit]);
            assert_true(stat(w, "sundials_erk.stability_estimates") >= 1.0);
            assert_true(steps[limit] >= 0.1 / h);
        } else {
            assert_true(limited[limit] == 0.0);
        }
        defsim_world_destroy(w);
    }
    assert_true(rejected[0] >= 5.0 * (rejected[1] + 1.0));
    /* ... at about the same cost in force evaluations. */
    assert_true(rhs[1] <= 1.15 * rhs[0]);
}

/* set_state drops ERKStep's history: stepping on from a state the host sets gives what a fresh
 * world started there gives (to rounding in the times), while a world that keeps its history
 * takes other internal steps. */
static void test_set_state_resets(void **state)
{
    (void)state;
    const double tol = 1e-4;
    defsim_world *a = erk_world(tol), *b = erk_world(tol), *c = erk_world(tol);
    tu_osc oa = osc_set[0], ob = osc_set[0], oc = osc_set[0];
    tu_add_oscillator(a, &oa, 0.0);
    tu_add_oscillator(b, &ob, 0.0);
    for (int s = 0; s < 7; ++s) TU_OK(defsim_world_step(a, 0.05));
    for (int s = 0; s < 7; ++s) TU_OK(defsim_world_step(b, 0.05));
    double *x = tu_positions(a), *v = tu_velocities(a);
    /* c: a fresh world whose initial state is a's. */
    oc.u0 = x[3 * oa.vertex] - 1.0;
    oc.v0 = v[3 * oa.vertex];
    tu_add_oscillator(c, &oc, 0.0);
    /* The same state again, through a different one: only the history goes (setting the
     * same bits alone changes nothing). */
    x[3 * oa.vertex] += 1.0;
    TU_OK(defsim_world_set_state(a, x, v));
    x[3 * oa.vertex] -= 1.0;
    TU_OK(defsim_world_set_state(a, x, v));
    const double before = stat(a, "sundials_erk.internal_steps");
    for (int s = 0; s < 7; ++s) {
        TU_OK(defsim_world_step(a, 0.05));
        TU_OK(defsim_world_step(b, 0.05));
        TU_OK(defsim_world_step(c, 0.05));
    }
    double *xa = tu_positions(a), *xb = tu_positions(b), *xc = tu_positions(c);
    const double da = fabs(xa[3 * oa.vertex] - xc[3 * oc.vertex]);
    const double db = fabs(xb[3 * ob.vertex] - xc[3 * oc.vertex]);
    printf("erk after set_state: |a - fresh| %.3e, |kept history - fresh| %.3e; steps after "
           "reset %.0f, fresh %.0f\n", da, db, stat(a, "sundials_erk.internal_steps") - before,
           stat(c, "sundials_erk.internal_steps"));
    assert_true(stat(a, "sundials_erk.internal_steps") - before ==
                stat(c, "sundials_erk.internal_steps"));
    assert_true(da <= 1e-12);
    assert_true(db > 100.0 * da && db > 1e-12);
    free(x); free(v); free(xa); free(xb); free(xc);
    defsim_world_destroy(a);
    defsim_world_destroy(b);
    defsim_world_destroy(c);
}

/* Every table of the option runs with its own order; bad values are refused and leave the
 * option as it was. */
static void test_tables(void **state)
{
    (void)state;
    static const char *tables[] = {"dormand_prince_5", "bogacki_shampine_3", "zonneveld_4",
                                   "cash_karp_5", "verner_6", "fehlberg_8"};
    static const int orders[] = {5, 3, 4, 5, 6, 8};
    for (int k = 0; k < 6; ++k) {
        defsim_world *w = erk_world(1e-6);
        TU_OK(defsim_world_set_option(w, "sundials_erk.table", tables[k]));
        tu_osc o = osc_set[1];
        tu_add_oscillator(w, &o, 0.0);
        for (int s = 0; s < 10; ++s) TU_OK(defsim_world_step(w, 0.05));
        double u, ve;
        tu_osc_exact(&o, 0.5, &u, &ve);
        double *x = tu_positions(w);
        const double e = fabs(x[3 * o.vertex] - 1.0 - u);
        free(x);
        printf("erk table %s: order %.0f, error %.2e, %.0f steps\n", tables[k],
               stat(w, "sundials_erk.order"), e, stat(w, "sundials_erk.internal_steps"));
        assert_true(stat(w, "sundials_erk.order") == orders[k]);
        assert_true(e <= 10.0 * 0.5 * 1e-6);
        defsim_world_destroy(w);
    }
    defsim_world *w = erk_world(1e-6);
    double v = -1.0;
    assert_int_equal(defsim_world_set_option(w, "sundials_erk.table", "heun_euler_2"),
                     DEFSIM_ERR_INVALID_ARGUMENT);
    assert_int_equal(defsim_world_set_option(w, "sundials_erk.rtol", "0"),
                     DEFSIM_ERR_INVALID_ARGUMENT);
    TU_OK(defsim_world_get_option(w, "sundials_erk.table", &v));
    assert_true(v == 0.0);
    defsim_world_destroy(w);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_oscillators),
        cmocka_unit_test(test_stable_step),
        cmocka_unit_test(test_auto_substep_table),
        cmocka_unit_test(test_stability_limiting),
        cmocka_unit_test(test_set_state_resets),
        cmocka_unit_test(test_tables),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
