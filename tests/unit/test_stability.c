/* SPDX-License-Identifier: MIT */
/* Stable-step estimates against closed forms and against the measured limit, and automatic
 * substepping. */
#include "test_util.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

/* Mass m on spring k: pinned anchor (one free vertex) or two free masses. */
static defsim_world *oscillator(const char *backend, double m, double k, int pinned,
                                double alpha, int auto_substep)
{
    defsim_world_def d;
    defsim_world_def_init(&d, sizeof d);
    d.backend = backend;
    d.gravity[1] = 0.0;
    d.auto_substep = auto_substep;
    defsim_world *w = NULL;
    TU_OK(defsim_world_create(&d, &w));
    const tu_spring2 o = {.l0 = 1, .x1 = {1.01, 0, 0}, .m0 = m, .m1 = m, .k = k, .alpha = alpha,
                          .pin_anchor = pinned};
    tu_add_spring2(w, &o);
    return w;
}

static void test_closed_forms(void **state)
{
    (void)state;
    const double m = 0.5, k = 200.0;
    double h, om;
    /* One free mass: omega = sqrt(k/m); symplectic Euler limit 2 / omega. */
    defsim_world *w = oscillator("symplectic_euler", m, k, 1, 0.0, 0);
    TU_OK(defsim_world_stable_step(w, &h, &om));
    assert_true(fabs(om - sqrt(k / m)) < 1e-4 * sqrt(k / m));
    assert_true(fabs(h - 2.0 / sqrt(k / m)) < 1e-4 * h);
    defsim_world_destroy(w);
    /* Two free masses: reduced mass m/2, omega = sqrt(2k/m). */
    w = oscillator("symplectic_euler", m, k, 0, 0.0, 0);
    TU_OK(defsim_world_stable_step(w, &h, &om));
    assert_true(fabs(om - sqrt(2 * k / m)) < 1e-4 * om);
    defsim_world_destroy(w);
    /* Damped: h^2 omega^2 + 2 c h = 4. */
    const double alpha = 3.0, w0 = sqrt(k / m);
    w = oscillator("symplectic_euler", m, k, 1, alpha, 0);
    TU_OK(defsim_world_stable_step(w, &h, NULL));
    assert_true(fabs(h * h * w0 * w0 + 2 * alpha * h - 4.0) < 1e-3);
    defsim_world_destroy(w);
    /* Explicit Euler: c / omega^2 with damping, 0 without. */
    w = oscillator("explicit_euler", m, k, 1, alpha, 0);
    TU_OK(defsim_world_stable_step(w, &h, NULL));
    assert_true(fabs(h - alpha / (w0 * w0)) < 1e-3 * h);
    defsim_world_destroy(w);
    w = oscillator("explicit_euler", m, k, 1, 0.0, 0);
    TU_OK(defsim_world_stable_step(w, &h, NULL));
    assert_true(h == 0.0);
    assert_int_equal(defsim_world_stable_step(NULL, &h, NULL), DEFSIM_ERR_INVALID_ARGUMENT);
    defsim_world_destroy(w);
}

/* Runs n steps of size h from a slightly perturbed beam; 1 if the energy stays bounded. */
static int beam_stable(double h, int steps, double *h_pred)
{
    defsim_world *w = tu_world("symplectic_euler", 0.0, 1);
    const double lo[3] = {0, 0, 0}, hi[3] = {2, 0.5, 0.5};
    defsim_body_id b = tu_add_box(w, DEFSIM_MODEL_STABLE_NEOHOOKEAN, 8, 2, 2, lo, hi, 1e6, 0.3, 1000);
    tu_pin_below(w, b, 0, 0.0);
    int n = defsim_world_vertex_count(w);
    double *x = tu_positions(w);
    unsigned long long seed = 4;
    for (int i = 0; i < 3 * n; ++i) x[i] += x[3 * (i / 3)] > 0 ? 1e-4 * tu_rand(&seed) : 0.0;
    TU_OK(defsim_world_set_state(w, x, NULL));
    if (h_pred) TU_OK(defsim_world_stable_step(w, h_pred, NULL));
    defsim_energy e0, e;
    TU_OK(defsim_world_energy(w, &e0));
    int ok = 1;
    for (int i = 0; i < steps && ok; ++i) {
        if (defsim_world_step(w, h) != DEFSIM_OK) ok = 0;
        else if (i % 50 == 0) {
            TU_OK(defsim_world_energy(w, &e));
            if (e.total > 10.0 * e0.total) ok = 0;
        }
    }
    free(x);
    defsim_world_destroy(w);
    return ok;
}

/* The measured limit (bisection on h) lies within a factor of 2 of the prediction. */
static void test_measured_limit(void **state)
{
    (void)state;
    double hp;
    assert_true(beam_stable(1e-6, 10, &hp));
    double lo = hp / 4, hi = hp * 4;
    assert_true(beam_stable(lo, 2000, NULL));
    assert_false(beam_stable(hi, 2000, NULL));
    for (int it = 0; it < 8; ++it) {
        double mid = sqrt(lo * hi);
        if (beam_stable(mid, 2000, NULL)) lo = mid; else hi = mid;
    }
    double measured = sqrt(lo * hi);
    print_message("stable step: predicted %.4g s, measured %.4g s, ratio %.3f\n", hp, measured,
                  measured / hp);
    assert_true(measured > 0.5 * hp && measured < 2.0 * hp);
}

/* auto_substep: a step 20x the stable one succeeds in substeps and tracks a fine run. */
static void test_auto_substep(void **state)
{
    (void)state;
    const double m = 0.5, k = 200.0, w0 = sqrt(k / m);
    const double H = 20 * 2.0 / w0;
    defsim_world *a = oscillator("symplectic_euler", m, k, 1, 0.0, 1);
    defsim_world *b = oscillator("symplectic_euler", m, k, 1, 0.0, 0);
    for (int i = 0; i < 5; ++i) TU_OK(defsim_world_step(a, H));
    defsim_stats s = {.size = sizeof s};
    TU_OK(defsim_world_stats(a, &s));
    assert_true(s.substeps >= 5 * 20);
    assert_true(fabs(s.stable_step - 2.0 / w0) < 1e-3 * s.stable_step);
    /* Without it the same step is unstable, and the state is untouched. */
    double x0[6], x1[6];
    TU_OK(defsim_world_get_positions(b, x0, 2));
    defsim_status st = DEFSIM_OK;
    for (int i = 0; i < 50 && st == DEFSIM_OK; ++i) {
        TU_OK(defsim_world_get_positions(b, x0, 2));
        st = defsim_world_step(b, H);
    }
    assert_int_equal(st, DEFSIM_ERR_UNSTABLE);
    TU_OK(defsim_world_get_positions(b, x1, 2));
    assert_memory_equal(x0, x1, sizeof x0);
    /* Stable is not accurate (omega h = 1.6 per substep), but bounded: symplectic Euler keeps
     * x within 0.01 / sqrt(1 - (omega h / 2)^2) = 0.0167 of rest. */
    double xa[6];
    for (int i = 0; i < 200; ++i) {
        TU_OK(defsim_world_step(a, H));
        TU_OK(defsim_world_get_positions(a, xa, 2));
        assert_true(fabs(xa[3] - 1.0) < 0.0170);
    }
    defsim_world_destroy(a);
    defsim_world_destroy(b);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_closed_forms),
        cmocka_unit_test(test_measured_limit),
        cmocka_unit_test(test_auto_substep),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
