/* SPDX-License-Identifier: MIT */
/* The stability watchdog (src/watchdog.c, docs/watchdog.md): garbage states fail the step with
 * the state rolled back, stable runs never trip, the diagnostics by name, and the regressions of
 * issue 17 (finite garbage returned as success). */
#include "test_util.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

/* The cantilever of tests/scenes/cantilever.json: 3 x 1 x 1 m, 12 x 4 x 4 cells, stable
 * neo-Hookean E = 1 MPa, nu = 0.3, 1000 kg/m^3, mass damping 1/s, clamped at x = 0. */
static defsim_world *cantilever(const char *backend, double E)
{
    defsim_world *w = tu_world(backend, -9.81, 1);
    defsim_material mat;
    defsim_material_init(&mat, sizeof mat, DEFSIM_MODEL_STABLE_NEOHOOKEAN);
    mat.youngs_modulus = E;
    mat.poisson_ratio = 0.3;
    mat.density = 1000;
    mat.mass_damping = 1.0;
    const double lo[3] = {0, 0, 0}, hi[3] = {3, 1, 1};
    defsim_body_id b = tu_add_box_material(w, 12, 4, 4, lo, hi, &mat);
    assert_int_equal(tu_pin_below(w, b, 0, 0.0), 25);
    return w;
}

static double max_abs(const double *a, int n)
{
    double m = 0.0;
    for (int i = 0; i < n; ++i) m = fmax(m, fabs(a[i]));
    return m;
}

static double stat(const defsim_world *w, const char *name)
{
    double v = -1.0;
    TU_OK(defsim_world_stat(w, name, &v));
    return v;
}

/* Steps until the first failure (at most n steps); every successful step must leave positions
 * below `bound` (m), and the failed one must leave the state and time exactly as they were.
 * Returns the status of the last call. */
static defsim_status step_until_failure(defsim_world *w, double h, int n, double bound)
{
    const int nv = defsim_world_vertex_count(w);
    double *x = malloc(3 * (size_t)nv * sizeof *x), *v = malloc(3 * (size_t)nv * sizeof *v);
    defsim_status st = DEFSIM_OK;
    for (int s = 0; s < n && st == DEFSIM_OK; ++s) {
        double *x0 = tu_positions(w), *v0 = tu_velocities(w);
        const double t0 = defsim_world_time(w);
        st = defsim_world_step(w, h);
        TU_OK(defsim_world_get_positions(w, x, nv));
        TU_OK(defsim_world_get_velocities(w, v, nv));
        if (st == DEFSIM_OK) {
            assert_true(max_abs(x, 3 * nv) < bound);
        } else {
            assert_memory_equal(x, x0, 3 * (size_t)nv * sizeof *x);
            assert_memory_equal(v, v0, 3 * (size_t)nv * sizeof *v);
            assert_true(defsim_world_time(w) == t0);
        }
        free(x0);
        free(v0);
    }
    free(x);
    free(v);
    return st;
}

/* Issue 17: symplectic Euler on the cantilever at h = 1/60 s returned OK for 60 steps with the
 * tip at 1e104 m. The stable step is about 4e-3 s: the watchdog must fail a step, with the tip
 * never beyond a few metres, and its message's estimate is kept as the stable_step statistic. */
static void test_cantilever_large_step(void **state)
{
    (void)state;
    defsim_world *w = cantilever("symplectic_euler", 1e6);
    assert_int_equal(step_until_failure(w, 1.0 / 60.0, 60, 10.0), DEFSIM_ERR_UNSTABLE);
    assert_true(stat(w, "watchdog_trips") == 1.0);
    const double hs = stat(w, "stable_step");
    assert_true(hs > 1e-3 && hs < 1.0 / 60.0);
    /* The watchdog off: the same run returns the garbage, as before (only non-finite fails). */
    defsim_world_destroy(w);
    w = cantilever("symplectic_euler", 1e6);
    TU_OK(defsim_world_set_option(w, "core.watchdog", "off"));
    defsim_status st = DEFSIM_OK;
    int ok = 0;
    for (int s = 0; s < 60 && st == DEFSIM_OK; ++s, ok += st == DEFSIM_OK) st = defsim_world_step(w, 1.0 / 60.0);
    double *x = tu_positions(w);
    assert_true(max_abs(x, 3 * defsim_world_vertex_count(w)) > 100.0);
    assert_true(stat(w, "watchdog_trips") == 0.0);
    free(x);
    defsim_world_destroy(w);
}

/* The same beam at the scene's own step runs 300 steps (0.25 s) without a trip, for every
 * backend that has a step-size limit and for an implicit one at a large step. */
static void test_no_false_trips(void **state)
{
    (void)state;
    const struct { const char *backend; double h; } runs[] = {
        {"symplectic_euler", 1.0 / 1200}, {"velocity_verlet", 1.0 / 1200},
        {"newton_cholmod", 1.0 / 60}};
    for (size_t r = 0; r < sizeof runs / sizeof runs[0]; ++r) {
        if (!tu_available(runs[r].backend)) continue;
        defsim_world *w = cantilever(runs[r].backend, 1e6);
        const int n = runs[r].h < 0.01 ? 300 : 30;
        for (int s = 0; s < n; ++s) TU_OK(defsim_world_step(w, runs[r].h));
        assert_true(stat(w, "watchdog_trips") == 0.0);
        /* Damped: the energy drift since the reference is a loss, and small against the work
         * gravity did (M g times a sag of centimetres: hundreds of joules). */
        const double drift = stat(w, "energy_drift");
        assert_true(drift <= 1e-6 * 3000 * 9.81 && drift > -3000 * 9.81 * 0.5);
        defsim_world_destroy(w);
    }
}

/* Issue 17: explicit Euler at h = 1e300 returned OK with t = 1e300 and |v| = 9.8e300. */
static void test_explicit_euler_absurd_step(void **state)
{
    (void)state;
    defsim_world *w = cantilever("explicit_euler", 1e6);
    double *x0 = tu_positions(w);
    assert_int_equal(defsim_world_step(w, 1e300), DEFSIM_ERR_UNSTABLE);
    assert_true(defsim_world_time(w) == 0.0);
    double *x = tu_positions(w), *v = tu_velocities(w);
    const int n = 3 * defsim_world_vertex_count(w);
    assert_memory_equal(x, x0, (size_t)n * sizeof *x);
    assert_true(max_abs(v, n) == 0.0);
    free(x0); free(x); free(v);
    defsim_world_destroy(w);
}

/* Issue 17: symplectic Euler with E = 1e12 at h = 1e-3 returned OK with |x| = 1.4e129. */
static void test_stiff_symplectic(void **state)
{
    (void)state;
    defsim_world *w = cantilever("symplectic_euler", 1e12);
    assert_int_equal(step_until_failure(w, 1e-3, 100, 10.0), DEFSIM_ERR_UNSTABLE);
    defsim_world_destroy(w);
}

/* A stiff, nearly incompressible beam (E = 1e8 Pa, nu = 0.499, stable step 4e-5 s) given random
 * velocities of 1 m/s and stepped at h = 0.01 s: the first step moves vertices by a centimetre,
 * which stores 1e3 times the scene's energy as elastic energy while the kinetic energy has not
 * grown yet. The watchdog checks the total energy in such a step and fails it; before, it
 * returned OK and the next step blew up from the garbage. */
static void test_energy_hidden_in_elastic(void **state)
{
    (void)state;
    const char *backends[2] = {"symplectic_euler", "explicit_euler"};
    for (int k = 0; k < 2; ++k) {
        defsim_world *w = tu_world(backends[k], -9.81, 1);
        const double lo[3] = {0, 0, 0}, hi[3] = {1.5, 0.5, 0.5};
        defsim_body_id b = tu_add_box(w, DEFSIM_MODEL_STABLE_NEOHOOKEAN, 6, 2, 2, lo, hi, 1e8,
                                      0.499, 1000);
        const int nv = defsim_world_vertex_count(w);
        double *v = calloc(3 * (size_t)nv, sizeof *v);
        unsigned long long seed = 12345;
        for (int i = 0; i < 3 * nv; ++i) v[i] = tu_rand(&seed);
        TU_OK(defsim_world_set_state(w, NULL, v));
        tu_pin_below(w, b, 0, 0.0);
        defsim_energy e0;
        TU_OK(defsim_world_energy(w, &e0));
        assert_int_equal(step_until_failure(w, 0.01, 5, 10.0), DEFSIM_ERR_UNSTABLE);
        defsim_energy e;
        TU_OK(defsim_world_energy(w, &e));
        /* Whatever steps succeeded hold no more than the start plus what gravity did. */
        assert_true(e.total - e0.total < 100.0);
        free(v);
        defsim_world_destroy(w);
    }
}

/* The total energy is checked in the steps where an element changed shape by more than 1 % of
 * the smallest element size, not where vertices merely moved that far: the cantilever sagging
 * at its step of 2.8 ms (the tip moves up to 1 cm per step, its elements change by at most
 * 1.8 mm of the 2.5 mm limit) and a box thrown at 50 m/s (5 cm, a fifth of an element, per
 * step) pay the check in a handful of steps of 200. The old trigger (any vertex moving 1 %) checked every
 * step of both, which doubled the explicit step's cost. A step that deforms the elements (the
 * box spun at 50 rad/s: 1.2 cm of relative motion per 0.25 m edge) is checked every time. */
static void test_energy_check_follows_deformation(void **state)
{
    (void)state;
    defsim_stats st = {.size = sizeof st};   /* size first: defsim_world_stats reads it */
    defsim_world *w = cantilever("symplectic_euler", 1e6);
    for (int s = 0; s < 200; ++s) TU_OK(defsim_world_step(w, 2.8e-3));
    TU_OK(defsim_world_stats(w, &st));
    print_message("cantilever evals %lld\n", (long long)st.energy_evals);
    assert_true(st.energy_evals >= 2 && st.energy_evals <= 6);
    defsim_world_destroy(w);

    for (int spin = 0; spin < 2; ++spin) {
        w = tu_world("symplectic_euler", 0.0, 1);
        const double lo[3] = {0, 0, 0}, hi[3] = {1, 1, 1};
        tu_add_box(w, DEFSIM_MODEL_STABLE_NEOHOOKEAN, 4, 4, 4, lo, hi, 1e6, 0.3, 1000);
        const int nv = defsim_world_vertex_count(w);
        double *x = tu_positions(w), *v = calloc(3 * (size_t)nv, sizeof *v);
        for (int i = 0; i < nv; ++i) {
            const double *p = x + 3 * i;
            v[3 * i] = spin ? -50.0 * (p[1] - 0.5) : 50.0;   /* about the box's centre line */
            v[3 * i + 1] = spin ? 50.0 * (p[0] - 0.5) : 0.0;
        }
        TU_OK(defsim_world_set_state(w, NULL, v));
        const int steps = spin ? 20 : 200;
        for (int s = 0; s < steps; ++s) TU_OK(defsim_world_step(w, 1e-3));
        TU_OK(defsim_world_stats(w, &st));
        print_message("spin %d evals %lld\n", spin, (long long)st.energy_evals);
        if (spin) assert_true(st.energy_evals >= steps);
        else assert_true(st.energy_evals >= 2 && st.energy_evals <= 3);
        free(x);
        free(v);
        defsim_world_destroy(w);
    }
}

/* Issue 17: once t = 1e17 s, t + h == t for h = 1 s and time stopped silently. A step that does
 * not advance the clock is refused; one that does is taken. */
static void test_time_that_stops(void **state)
{
    (void)state;
    defsim_world *w = tu_world("symplectic_euler", -9.81, 1);
    TU_OK(defsim_world_step(w, 1e17));   /* no bodies: only the clock moves */
    assert_true(defsim_world_time(w) == 1e17);
    assert_int_equal(defsim_world_step(w, 1.0), DEFSIM_ERR_INVALID_ARGUMENT);
    assert_true(defsim_world_time(w) == 1e17);
    TU_OK(defsim_world_step(w, 64.0));   /* half an ulp of 1e17 is 8: 64 advances it */
    assert_true(defsim_world_time(w) > 1e17);
    defsim_world_destroy(w);
}

/* Issue 17: defsim_world_forces with a NaN in x returned OK. */
static void test_forces_non_finite(void **state)
{
    (void)state;
    defsim_world *w = cantilever("symplectic_euler", 1e6);
    const int n = 3 * defsim_world_vertex_count(w);
    double *x = tu_positions(w), *f = calloc((size_t)n, sizeof *f);
    x[7] = NAN;
    f[0] = 123.0;
    assert_int_equal(defsim_world_forces(w, x, f), DEFSIM_ERR_INVALID_ARGUMENT);
    assert_true(f[0] == 123.0);   /* untouched */
    x[7] = INFINITY;
    assert_int_equal(defsim_world_forces(w, x, f), DEFSIM_ERR_INVALID_ARGUMENT);
    free(x); free(f);
    defsim_world_destroy(w);
}

/* A unit neo-Hookean cube (5 vertices... a 1-cell box, 6 tets) whose vertex 0 is pushed through
 * the opposite face: inverted elements. */
static defsim_world *inverted_neohookean(const char *backend, defsim_model model)
{
    defsim_world *w = tu_world(backend, 0.0, 1);
    const double lo[3] = {0, 0, 0}, hi[3] = {1, 1, 1};
    tu_add_box(w, model, 1, 1, 1, lo, hi, 1e5, 0.3, 1000);
    return w;
}

/* Issue 17: the energy of an inverted neo-Hookean body was +inf with DEFSIM_OK. Now
 * DEFSIM_ERR_UNSTABLE, with the energies still filled in (elastic +inf); the diagnostics count
 * the inverted tets and give the smallest J. */
static void test_inverted_energy_and_diagnostics(void **state)
{
    (void)state;
    defsim_world *w = inverted_neohookean("symplectic_euler", DEFSIM_MODEL_NEOHOOKEAN);
    defsim_energy e;
    TU_OK(defsim_world_energy(w, &e));
    assert_true(e.elastic == 0.0);
    TU_OK(defsim_world_step(w, 1e-4));
    assert_true(stat(w, "min_volume_ratio") == 1.0);   /* at rest, exactly */
    assert_true(stat(w, "inverted_elements") == 0.0);
    double *x = tu_positions(w);
    const int nv = defsim_world_vertex_count(w);
    for (int i = 0; i < nv; ++i)
        if (x[3 * i] == 0 && x[3 * i + 1] == 0 && x[3 * i + 2] == 0) x[3 * i] = 2.0;   /* through */
    TU_OK(defsim_world_set_state(w, x, NULL));
    assert_int_equal(defsim_world_energy(w, &e), DEFSIM_ERR_UNSTABLE);
    assert_true(isinf(e.elastic) && e.elastic > 0 && isinf(e.total));
    const double bad = stat(w, "inverted_elements");
    assert_true(bad >= 1.0 && bad <= 6.0);
    assert_true(stat(w, "min_volume_ratio") < 0.0);
    /* The same state in a model that may invert has a finite energy. (The diagnostics read a
     * planned world: the step plans it.) */
    defsim_world_destroy(w);
    w = inverted_neohookean("symplectic_euler", DEFSIM_MODEL_STVK);
    TU_OK(defsim_world_step(w, 1e-4));
    TU_OK(defsim_world_set_state(w, x, NULL));
    TU_OK(defsim_world_energy(w, &e));
    assert_true(isfinite(e.elastic) && e.elastic > 0);
    assert_true(stat(w, "inverted_elements") == bad);
    free(x);
    defsim_world_destroy(w);
}

/* A neo-Hookean cube hit hard enough to invert within one step: the step that inverts fails
 * (before, it returned OK and the next one failed on non-finite forces, from the inverted
 * state). */
static void test_inverting_step_fails(void **state)
{
    (void)state;
    defsim_world *w = inverted_neohookean("symplectic_euler", DEFSIM_MODEL_NEOHOOKEAN);
    const int nv = defsim_world_vertex_count(w);
    double *v = calloc(3 * (size_t)nv, sizeof *v), *x = tu_positions(w);
    for (int i = 0; i < nv; ++i)
        if (x[3 * i] == 0 && x[3 * i + 1] == 0 && x[3 * i + 2] == 0) v[3 * i] = 3000.0;
    TU_OK(defsim_world_set_state(w, NULL, v));
    /* The kinetic energy is the host's: the energy bound allows it; the inversion does not. */
    TU_OK(defsim_world_set_option(w, "core.watchdog_energy_growth", "1e6"));
    assert_int_equal(defsim_world_step(w, 1e-3), DEFSIM_ERR_UNSTABLE);
    assert_true(stat(w, "inverted_elements") == 0.0);
    assert_true(stat(w, "watchdog_trips") == 1.0);
    free(v); free(x);
    defsim_world_destroy(w);
}

/* Issue 17: defsim_material_eval at |F| ~ 1e120 .. 1e200 returned inf / NaN with DEFSIM_OK (and
 * neo-Hookean blamed det F <= 0 where det F overflowed). Now a call either succeeds with finite
 * outputs (co-rotated's energy grows only like |F|^2 and stays finite to 1e150) or reports the
 * overflow; at 1e200 every model overflows. Moderate F still evaluates. */
static void test_material_eval_overflow(void **state)
{
    (void)state;
    const defsim_model models[] = {DEFSIM_MODEL_STVK, DEFSIM_MODEL_COROTATED,
                                   DEFSIM_MODEL_NEOHOOKEAN, DEFSIM_MODEL_STABLE_NEOHOOKEAN};
    for (int m = 0; m < 4; ++m) {
        defsim_material mat;
        defsim_material_init(&mat, sizeof mat, models[m]);
        for (double s = 1e120; s <= 1e200; s *= 1e10) {
            const double F[9] = {s, 0.3 * s, 0, 0.1 * s, s, 0, 0, 0.2 * s, s};
            double psi, P[9], D[81];
            const defsim_status st = defsim_material_eval(&mat, F, &psi, P, D);
            if (st == DEFSIM_OK) {
                int finite = isfinite(psi);
                for (int i = 0; i < 9; ++i) finite &= isfinite(P[i]) != 0;
                for (int i = 0; i < 81; ++i) finite &= isfinite(D[i]) != 0;
                assert_true(finite && s < 1e200);
            } else {
                assert_int_equal(st, DEFSIM_ERR_UNSTABLE);
            }
        }
        const double F[9] = {1.2, 0.1, 0, 0, 0.9, 0, 0, 0.05, 1.1};
        double psi, P[9], D[81];
        TU_OK(defsim_material_eval(&mat, F, &psi, P, D));
        assert_true(isfinite(psi));
    }
}

/* Issue 17: newton_cholmod at h = 4.9e-324 blamed "an inverted neo-Hookean element?". 1/h^2
 * overflows: the step is refused as an invalid argument, the state unchanged. */
static void test_newton_tiny_step(void **state)
{
    (void)state;
    if (!tu_available("newton_cholmod")) skip();
    defsim_world *w = cantilever("newton_cholmod", 1e6);
    double *x0 = tu_positions(w);
    assert_int_equal(defsim_world_step(w, 4.9e-324), DEFSIM_ERR_INVALID_ARGUMENT);
    double *x = tu_positions(w);
    assert_memory_equal(x, x0, 3 * (size_t)defsim_world_vertex_count(w) * sizeof *x);
    /* A small but representable step works, and the residual of its last Newton iteration is
     * kept (N), below what the solver's tolerance allows for a step that converged. */
    TU_OK(defsim_world_step(w, 1e-3));
    const double r = stat(w, "newton_cholmod.nonlinear_residual");
    assert_true(r > 0.0 && isfinite(r));
    free(x0); free(x);
    defsim_world_destroy(w);
}

/* Work by the host is part of the budget: a weightless oscillator pulled by a held external
 * force far beyond the energy it started with, and an attachment target dragged 50 m in steps,
 * never trip; the energy drift stays at the integrator's error. */
static void test_host_work_is_budgeted(void **state)
{
    (void)state;
    defsim_world *w = tu_oscillator("symplectic_euler", 1.0, 1.0, 100.0, 0.0, 0.0, 0.0, 1, 0);
    const int nv = defsim_world_vertex_count(w);
    double *f = calloc(3 * (size_t)nv, sizeof *f);
    for (int s = 0; s < 2000; ++s) {
        f[3] = 500.0 * (s < 1000 ? 1.0 : -1.0);   /* 500 N along x, then reversed */
        TU_OK(defsim_world_set_external_forces(w, f, nv));
        TU_OK(defsim_world_step(w, 1e-3));
    }
    assert_true(stat(w, "watchdog_trips") == 0.0);
    /* Symplectic Euler's energy error at h omega = 0.01 is about 1 % of the energy (~1e3 J). */
    assert_true(fabs(stat(w, "energy_drift")) < 50.0);
    free(f);
    defsim_world_destroy(w);

    w = tu_world("symplectic_euler", 0.0, 1);
    const double lo[3] = {0, 0, 0}, hi[3] = {1, 0.2, 0.2};
    defsim_body_id b = tu_add_box(w, DEFSIM_MODEL_COROTATED, 4, 1, 1, lo, hi, 1e5, 0.3, 100);
    defsim_attachment_def ad;
    defsim_attachment_def_init(&ad, sizeof ad);
    ad.body = b;
    ad.vertex = 0;
    ad.stiffness = 1e3;
    ad.damping = 10.0;
    defsim_attachment_id a;
    TU_OK(defsim_world_add_attachment(w, &ad, &a));
    double hs;
    TU_OK(defsim_world_stable_step(w, &hs, NULL));
    for (int s = 0; s < 3000; ++s) {
        const double p[3] = {50.0 * s / 3000.0, 0, 0};
        TU_OK(defsim_attachment_set_target(w, a, p));
        TU_OK(defsim_world_step(w, 0.5 * hs));
    }
    assert_true(stat(w, "watchdog_trips") == 0.0);
    defsim_world_destroy(w);
}

/* Thresholds are options with documented defaults and ranges. */
static void test_options(void **state)
{
    (void)state;
    defsim_world *w = tu_world("symplectic_euler", -9.81, 1);
    double v;
    TU_OK(defsim_world_get_option(w, "core.watchdog", &v));
    assert_true(v == 1.0);
    TU_OK(defsim_world_get_option(w, "core.watchdog_energy_growth", &v));
    assert_true(v == 10.0);
    TU_OK(defsim_world_get_option(w, "core.watchdog_max_stretch", &v));
    assert_true(v == 100.0);
    assert_int_equal(defsim_world_set_option(w, "core.watchdog_energy_growth", "0.5"),
                     DEFSIM_ERR_INVALID_ARGUMENT);
    assert_int_equal(defsim_world_set_option_number(w, "core.watchdog_max_stretch", NAN),
                     DEFSIM_ERR_INVALID_ARGUMENT);
    defsim_world_destroy(w);
}

/* A body stretched beyond core.watchdog_max_stretch times its rest size fails the step, even
 * when the energy bound is switched off in effect. */
static void test_stretch_bound(void **state)
{
    (void)state;
    defsim_world *w = tu_world("symplectic_euler", 0.0, 1);
    const double lo[3] = {0, 0, 0}, hi[3] = {1, 1, 1};
    tu_add_box(w, DEFSIM_MODEL_STVK, 1, 1, 1, lo, hi, 1e3, 0.3, 1000);
    const int nv = defsim_world_vertex_count(w);
    double *v = calloc(3 * (size_t)nv, sizeof *v);
    v[0] = 100.0;   /* vertex 0 flies off at 100 m/s: 1 m after 10 ms */
    TU_OK(defsim_world_set_state(w, NULL, v));
    TU_OK(defsim_world_set_option(w, "core.watchdog_energy_growth", "1e300"));
    TU_OK(defsim_world_set_option(w, "core.watchdog_max_stretch", "3"));
    /* Rest diagonal sqrt(3) m: the body may span 5.2 m. */
    defsim_status st = DEFSIM_OK;
    int steps = 0;
    while (st == DEFSIM_OK && steps < 1000) {
        st = defsim_world_step(w, 1e-3);
        steps += st == DEFSIM_OK;
    }
    assert_int_equal(st, DEFSIM_ERR_UNSTABLE);
    double *x = tu_positions(w);
    assert_true(x[0] < 3.0 * sqrt(3.0) && x[0] > 3.0);
    free(v); free(x);
    defsim_world_destroy(w);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_cantilever_large_step),
        cmocka_unit_test(test_no_false_trips),
        cmocka_unit_test(test_explicit_euler_absurd_step),
        cmocka_unit_test(test_stiff_symplectic),
        cmocka_unit_test(test_energy_hidden_in_elastic),
        cmocka_unit_test(test_energy_check_follows_deformation),
        cmocka_unit_test(test_time_that_stops),
        cmocka_unit_test(test_forces_non_finite),
        cmocka_unit_test(test_inverted_energy_and_diagnostics),
        cmocka_unit_test(test_inverting_step_fails),
        cmocka_unit_test(test_material_eval_overflow),
        cmocka_unit_test(test_newton_tiny_step),
        cmocka_unit_test(test_host_work_is_budgeted),
        cmocka_unit_test(test_options),
        cmocka_unit_test(test_stretch_bound),
    };
    return tu_exit(cmocka_run_group_tests(tests, NULL, NULL));
}
