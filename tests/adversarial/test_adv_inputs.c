/* SPDX-License-Identifier: MIT */
/*
 * Issue 23's smaller findings, kept (docs/adversarial.md):
 *  - the stable step with penalty contact: a box resting on, or dropped onto, a ground plane stays
 *    stable at 0.9 x defsim_world_stable_step on symplectic_euler, velocity_verlet and (with
 *    friction and damping, which its rule needs) explicit_euler; 2 x the estimate does blow up;
 *  - defsim_world_get_pin_forces reports a failing force callback also when nothing is pinned;
 *  - collider poses beyond the coordinate bound are refused at add and set_pose, and a distance
 *    that overflows fails the step without blaming an SDF;
 *  - radii, half extents, core.substep_safety and tolerances out of their ranges are refused;
 *  - sundials_erk refuses a step it cannot finish within its internal steps at once.
 * Every failed call must leave x, v and t bit-identical.
 */
#include "test_util.h"

#include <float.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#define G 9.81

/* ------------------------------------------------------------------------------------------ */
/* The state before a call, to check that a failed call left it bit-identical */

typedef struct snap {
    double *x, *v, t;
    int32_t n;
} snap;

static snap snap_take(const defsim_world *w)
{
    snap s = {tu_positions(w), tu_velocities(w), defsim_world_time(w),
              defsim_world_vertex_count(w)};
    return s;
}

static void snap_check(const defsim_world *w, snap *s)
{
    double *x = tu_positions(w), *v = tu_velocities(w);
    assert_int_equal(defsim_world_vertex_count(w), s->n);
    assert_memory_equal(x, s->x, 3 * (size_t)s->n * sizeof *x);
    assert_memory_equal(v, s->v, 3 * (size_t)s->n * sizeof *v);
    const double t = defsim_world_time(w);
    assert_memory_equal(&t, &s->t, sizeof t);
    free(x);
    free(v);
    free(s->x);
    free(s->v);
    s->x = s->v = NULL;
}

/* A 2x2x2-cell neo-Hookean box (0.2 m, nu 0.3, 1000 kg/m^3, mass damping alpha) with its bottom
 * at height y0, and a ground plane through the origin with friction mu. */
static defsim_world *box_on_ground(const char *backend, double E, double alpha, double y0,
                                   double mu)
{
    defsim_world *w = tu_world(backend, -G, 1);
    const double lo[3] = {-0.1, y0, -0.1}, hi[3] = {0.1, y0 + 0.2, 0.1};
    defsim_material mat;
    defsim_material_init(&mat, sizeof mat, DEFSIM_MODEL_NEOHOOKEAN);
    mat.youngs_modulus = E;
    mat.poisson_ratio = 0.3;
    mat.density = 1000.0;
    mat.mass_damping = alpha;
    tu_add_box_material(w, 2, 2, 2, lo, hi, &mat);
    defsim_collider_def cd;
    defsim_collider_def_init(&cd, sizeof cd);
    cd.friction = mu;
    TU_OK(defsim_world_add_collider(w, &cd, NULL));
    return w;
}

/* ------------------------------------------------------------------------------------------ */
/* 1. The stable step with penalty contact */

/* Steps `steps` times at `frac` x the stable step estimated at the start; returns the first step
 * that failed or raised the total energy 2 J above its start (the box holds about 8 J of
 * potential energy), or -1 if none did. */
static int run_at(defsim_world *w, double frac, int steps, double *h_out)
{
    double h = 0.0;
    TU_OK(defsim_world_stable_step(w, &h, NULL));
    assert_true(h > 0.0 && isfinite(h));
    h *= frac;
    if (h_out) *h_out = h;
    defsim_energy e0, e;
    TU_OK(defsim_world_energy(w, &e0));
    for (int i = 0; i < steps; ++i) {
        if (defsim_world_step(w, h) != DEFSIM_OK) return i;
        if (defsim_world_energy(w, &e) != DEFSIM_OK || !(e.total <= e0.total + 2.0)) return i;
    }
    return -1;
}

/* The audit's finding (a box resting on the ground tripped the watchdog at step 2,949 at 0.9 x
 * the estimate) and the same box dropped from 1 cm, that is out of contact when the estimate is
 * taken: 0.9 x holds 5,000 steps on the symplectic integrators, and 2 x blows up. */
static void test_stable_step_resting(void **state)
{
    (void)state;
    const char *backends[2] = {"symplectic_euler", "velocity_verlet"};
    const double y0s[2] = {0.0, 0.01};
    for (int b = 0; b < 2; ++b)
        for (int k = 0; k < 2; ++k) {
            defsim_world *w = box_on_ground(backends[b], 1e5, 0.0, y0s[k], 0.0);
            double h;
            const int failed = run_at(w, 0.9, 5000, &h);
            printf("  %s, bottom at %g m: 0.9 x the stable step (h = %.4g s): %s %d\n",
                   backends[b], y0s[k], h, failed < 0 ? "held" : "failed at step", failed);
            assert_int_equal(failed, -1);
            defsim_world_destroy(w);
        }
    /* Not absurdly cautious: twice the estimate heats the dropped box within 5,000 steps. */
    for (int b = 0; b < 2; ++b) {
        defsim_world *w = box_on_ground(backends[b], 1e5, 0.0, 0.01, 0.0);
        const int failed = run_at(w, 2.0, 5000, NULL);
        printf("  %s: 2 x the stable step failed at step %d\n", backends[b], failed);
        assert_true(failed >= 0);
        defsim_world_destroy(w);
    }
}

/* explicit_euler's rule needs damping (c / omega^2): mass damping and friction. Dropped from
 * 1 cm, the estimate taken in the air must count the friction of the resting contact to come. */
static void test_stable_step_friction(void **state)
{
    (void)state;
    const char *backends[3] = {"explicit_euler", "symplectic_euler", "velocity_verlet"};
    for (int b = 0; b < 3; ++b)
        for (int k = 0; k < 2; ++k) {
            defsim_world *w = box_on_ground(backends[b], 1e5, 10.0, k ? 0.01 : 0.0, 0.5);
            double h;
            const int failed = run_at(w, 0.9, 5000, &h);
            printf("  %s, mu 0.5, alpha 10, bottom at %g m: 0.9 x the stable step (h = %.4g s): "
                   "%s %d\n", backends[b], k ? 0.01 : 0.0, h,
                   failed < 0 ? "held" : "failed at step", failed);
            assert_int_equal(failed, -1);
            defsim_world_destroy(w);
        }
}

/* ------------------------------------------------------------------------------------------ */
/* 2. get_pin_forces runs the force callback also when nothing is pinned */

static int cb_mode;   /* 0: adds nothing, 1: fails, 2: a NaN force */
static int cb_calls;

static int force_cb(void *user, const double *x, const double *v, double t, int32_t n,
                    double *f)
{
    (void)user; (void)x; (void)v; (void)t; (void)n;
    ++cb_calls;
    if (cb_mode == 2) f[0] += NAN;
    return cb_mode == 1;
}

static void test_pin_forces_unpinned(void **state)
{
    (void)state;
    defsim_world *w = box_on_ground("symplectic_euler", 1e5, 0.0, 0.05, 0.0);
    TU_OK(defsim_world_step(w, 1e-4));   /* a state that is not the rest state */
    const int32_t n = defsim_world_vertex_count(w);
    const size_t bytes = 3 * (size_t)n * sizeof(double);
    double *out = malloc(bytes), *sentinel = malloc(bytes);
    for (int64_t i = 0; i < 3 * (int64_t)n; ++i) sentinel[i] = out[i] = 1234.5 + (double)i;
    TU_OK(defsim_world_set_force_callback(w, force_cb, NULL, NULL));
    for (cb_mode = 1; cb_mode <= 2; ++cb_mode) {
        cb_calls = 0;
        snap s = snap_take(w);
        assert_int_equal(defsim_world_get_pin_forces(w, out, n), DEFSIM_ERR_CALLBACK);
        assert_true(cb_calls >= 1);
        assert_memory_equal(out, sentinel, bytes);   /* out unchanged */
        snap_check(w, &s);
    }
    /* A callback that succeeds: nothing pinned, all zero. */
    cb_mode = 0;
    cb_calls = 0;
    TU_OK(defsim_world_get_pin_forces(w, out, n));
    assert_int_equal(cb_calls, 1);
    for (int64_t i = 0; i < 3 * (int64_t)n; ++i) assert_true(out[i] == 0.0);
    free(out);
    free(sentinel);
    defsim_world_destroy(w);
}

/* ------------------------------------------------------------------------------------------ */
/* 3. Collider poses within the coordinate bound; a distance that overflows blames no SDF */

static int collider_pose(const defsim_world *w, int32_t i, double pos[3])
{
    defsim_collider_def d;
    defsim_collider_def_init(&d, sizeof d);
    if (defsim_world_get_collider(w, i, NULL, &d) != DEFSIM_OK) return 0;
    memcpy(pos, d.position, sizeof d.position);
    return 1;
}

static void test_pose_bound(void **state)
{
    (void)state;
    defsim_world *w = box_on_ground("symplectic_euler", 1e5, 0.0, 0.05, 0.0);
    defsim_collider_def cd;
    defsim_collider_def_init(&cd, sizeof cd);
    cd.shape = DEFSIM_SHAPE_SPHERE;
    cd.position[1] = -1.0;
    defsim_collider_id sphere;
    TU_OK(defsim_world_add_collider(w, &cd, &sphere));
    TU_OK(defsim_world_step(w, 1e-4));
    const double q[4] = {1, 0, 0, 0}, far[3] = {0.0, 1e308, 0.0}, beyond[3] = {0.0, 0.0, -2e100};
    /* The audit's pose, and one just beyond the bound: refused, nothing changes. */
    const double *bad[2] = {far, beyond};
    for (int k = 0; k < 2; ++k) {
        snap s = snap_take(w);
        assert_int_equal(defsim_collider_set_pose(w, sphere, bad[k], q),
                         DEFSIM_ERR_INVALID_ARGUMENT);
        snap_check(w, &s);
        defsim_collider_def add = cd;
        memcpy(add.position, bad[k], sizeof add.position);
        assert_int_equal(defsim_world_add_collider(w, &add, NULL), DEFSIM_ERR_INVALID_ARGUMENT);
        assert_int_equal(defsim_world_collider_count(w), 2);
    }
    /* The pose it had is the pose it has: the next step does not move it. */
    double pos[3] = {NAN, NAN, NAN};
    assert_true(collider_pose(w, 1, pos));
    assert_true(pos[0] == 0.0 && pos[1] == -1.0 && pos[2] == 0.0);
    TU_OK(defsim_world_step(w, 1e-4));
    assert_true(collider_pose(w, 1, pos));
    assert_true(pos[0] == 0.0 && pos[1] == -1.0 && pos[2] == 0.0);
    /* At the bound itself: accepted, and the step through the body's region to it succeeds. */
    const double edge[3] = {0.0, 1e100, 0.0};
    TU_OK(defsim_collider_set_pose(w, sphere, edge, q));
    TU_OK(defsim_world_step(w, 1e-4));
    assert_true(collider_pose(w, 1, pos));
    assert_true(pos[1] == 1e100);
    defsim_world_destroy(w);
}

/* A body far beyond the bound (set_state takes any finite state) next to a tilted plane, whose
 * bounds cover everything: the distance overflows. The step fails as UNSTABLE, not as a host
 * callback's failure (there is no SDF), and nothing changes. */
static void test_distance_overflow(void **state)
{
    (void)state;
    defsim_world *w = tu_world("symplectic_euler", -G, 1);
    const double lo[3] = {0, 0, 0}, hi[3] = {0.2, 0.2, 0.2};
    tu_add_box(w, DEFSIM_MODEL_NEOHOOKEAN, 1, 1, 1, lo, hi, 1e5, 0.3, 1000);
    defsim_collider_def cd;
    defsim_collider_def_init(&cd, sizeof cd);
    cd.normal[0] = 1.0;   /* normal (1, 1, 0): no axis-aligned bound */
    TU_OK(defsim_world_add_collider(w, &cd, NULL));
    TU_OK(defsim_world_step(w, 1e-4));
    const int32_t n = defsim_world_vertex_count(w);
    double *x = tu_positions(w), *v = tu_velocities(w);
    for (int32_t i = 0; i < n; ++i) x[3 * i] = x[3 * i + 1] = 1.5e308;
    TU_OK(defsim_world_set_state(w, x, v));
    snap s = snap_take(w);
    assert_int_equal(defsim_world_step(w, 1e-4), DEFSIM_ERR_UNSTABLE);
    snap_check(w, &s);
    s = snap_take(w);
    double h;
    assert_int_equal(defsim_world_stable_step(w, &h, NULL), DEFSIM_ERR_UNSTABLE);
    snap_check(w, &s);
    free(x);
    free(v);
    defsim_world_destroy(w);
}

/* ------------------------------------------------------------------------------------------ */
/* 4. Sizes and option ranges: radii, half extents, core.substep_safety, tolerances */

static void test_collider_sizes(void **state)
{
    (void)state;
    defsim_world *w = box_on_ground("symplectic_euler", 1e5, 0.0, 0.05, 0.0);
    TU_OK(defsim_world_step(w, 1e-4));
    const double huge = 1e308, denormal = 1e-310, smallest = 4.9e-324;
    defsim_collider_def sphere, box, capsule;
    defsim_collider_def_init(&sphere, sizeof sphere);
    sphere.shape = DEFSIM_SHAPE_SPHERE;
    sphere.position[1] = -2.0;
    box = capsule = sphere;
    box.shape = DEFSIM_SHAPE_BOX;
    capsule.shape = DEFSIM_SHAPE_CAPSULE;
    const double bad[5] = {huge, 2e100, denormal, smallest, -1.0};
    for (int k = 0; k < 5; ++k) {
        defsim_collider_def d[5] = {sphere, box, box, capsule, capsule};
        d[0].radius = bad[k];
        d[1].half_extents[1] = bad[k];
        d[2].half_extents[0] = d[2].half_extents[1] = d[2].half_extents[2] = bad[k];
        d[3].radius = bad[k];
        d[4].half_height = bad[k];
        for (int j = 0; j < 5; ++j) {
            snap s = snap_take(w);
            assert_int_equal(defsim_world_add_collider(w, &d[j], NULL),
                             DEFSIM_ERR_INVALID_ARGUMENT);
            assert_int_equal(defsim_world_collider_count(w), 1);
            snap_check(w, &s);
        }
    }
    /* A mesh vertex and SDF bounds beyond the coordinate bound. */
    const double tri[9] = {0, 0, 0, 1, 0, 0, 0, 0, 1e200};
    const int32_t idx[3] = {0, 1, 2};
    defsim_collider_def mesh;
    defsim_collider_def_init(&mesh, sizeof mesh);
    mesh.shape = DEFSIM_SHAPE_MESH;
    mesh.vertices = tri;
    mesh.vertex_count = 3;
    mesh.triangles = idx;
    mesh.triangle_count = 1;
    assert_int_equal(defsim_world_add_collider(w, &mesh, NULL), DEFSIM_ERR_INVALID_ARGUMENT);
    /* The limits themselves are sizes: accepted (a capsule of zero half height is a ball). */
    const double ok[2] = {DBL_MIN, 1e100};
    for (int k = 0; k < 2; ++k) {
        defsim_collider_def d[3] = {sphere, box, capsule};
        d[0].radius = ok[k];
        d[1].half_extents[0] = ok[k];
        d[2].radius = ok[k];
        d[2].half_height = 0.0;
        for (int j = 0; j < 3; ++j) {
            d[j].position[1] = -2.0 - ok[k];   /* below the box (the 1e100 ones reach it) */
            defsim_collider_id id;
            TU_OK(defsim_world_add_collider(w, &d[j], &id));
            TU_OK(defsim_world_step(w, 1e-4));
            TU_OK(defsim_world_remove_collider(w, id));
        }
    }
    assert_int_equal(defsim_world_collider_count(w), 1);
    defsim_world_destroy(w);
}

/* An option set out of range leaves its value (and the world) unchanged. */
static void expect_refused(defsim_world *w, const char *name, double value)
{
    double before, after;
    TU_OK(defsim_world_get_option(w, name, &before));
    snap s = snap_take(w);
    assert_int_equal(defsim_world_set_option_number(w, name, value), DEFSIM_ERR_INVALID_ARGUMENT);
    char text[64];
    snprintf(text, sizeof text, "%.17g", value);
    assert_int_equal(defsim_world_set_option(w, name, text), DEFSIM_ERR_INVALID_ARGUMENT);
    TU_OK(defsim_world_get_option(w, name, &after));
    assert_memory_equal(&before, &after, sizeof before);
    snap_check(w, &s);
}

static void test_option_ranges(void **state)
{
    (void)state;
    defsim_world *w = box_on_ground("symplectic_euler", 1e5, 0.0, 0.05, 0.0);
    TU_OK(defsim_world_step(w, 1e-4));
    expect_refused(w, "core.substep_safety", 1e-300);
    expect_refused(w, "core.substep_safety", 0.005);
    TU_OK(defsim_world_set_option_number(w, "core.substep_safety", 0.01));
    defsim_world_destroy(w);
    /* The tolerances of the backends that have them (those built here). */
    const struct { const char *backend, *option; double bad, lowest; } tol[] = {
        {"newton_cholmod", "newton_cholmod.tolerance", 1e-300, 1e-14},
        {"newmark", "newmark.tolerance", 1e-300, 1e-14},
        {"bdf2", "bdf2.tolerance", 1e-300, 1e-14},
        {"sundials_kinsol", "sundials_kinsol.tolerance", 1e-300, 1e-14},
        {"sundials_ida", "sundials_ida.atol", 1e-300, 1e-30},
        {"sundials_erk", "sundials_erk.atol", 1e-300, 1e-30},
    };
    for (size_t i = 0; i < sizeof tol / sizeof *tol; ++i) {
        if (!tu_available(tol[i].backend)) {
            printf("  %s: not available, skipped\n", tol[i].backend);
            continue;
        }
        w = box_on_ground(tol[i].backend, 1e5, 0.0, 0.05, 0.0);
        expect_refused(w, tol[i].option, tol[i].bad);
        expect_refused(w, tol[i].option, 0.5 * tol[i].lowest);
        TU_OK(defsim_world_set_option_number(w, tol[i].option, tol[i].lowest));
        defsim_world_destroy(w);
    }
}

/* ------------------------------------------------------------------------------------------ */
/* 5. sundials_erk: the work of one call, and how a host interrupts a long one */

static double now_s(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

static double stat_of(const defsim_world *w, const char *name)
{
    double v = NAN;
    TU_OK(defsim_world_stat(w, name, &v));
    return v;
}

static long stop_after, stop_calls;

static int stopping_cb(void *user, const double *x, const double *v, double t, int32_t n,
                       double *f)
{
    (void)user; (void)x; (void)v; (void)t; (void)n; (void)f;
    return ++stop_calls >= stop_after;   /* the host's "stop" flag, raised after stop_after */
}

static defsim_world *erk_box(void)
{
    defsim_world *w = tu_world("sundials_erk", -G, 1);
    const double lo[3] = {0, 0, 0}, hi[3] = {0.2, 0.2, 0.2};
    tu_add_box(w, DEFSIM_MODEL_NEOHOOKEAN, 2, 2, 2, lo, hi, 1e5, 0.3, 1000);
    TU_OK(defsim_world_step(w, 1e-3));
    return w;
}

static void test_erk_work(void **state)
{
    (void)state;
    if (!tu_available("sundials_erk")) {
        printf("  sundials_erk: not available, skipped\n");
        return;
    }
    /* h = 1000 s needs about 226,000 internal steps at the stability limit, more than the
     * 100,000 a call may take: refused before any (it took 12 s and 100,000 steps). */
    defsim_world *w = erk_box();
    const double steps0 = stat_of(w, "sundials_erk.internal_steps");
    snap s = snap_take(w);
    double t0 = now_s();
    assert_int_equal(defsim_world_step(w, 1000.0), DEFSIM_ERR_NOT_CONVERGED);
    const double took = now_s() - t0;
    printf("  h = 1000 s: refused in %.3f s\n", took);
    assert_true(took < 5.0);
    assert_true(stat_of(w, "sundials_erk.internal_steps") == steps0);
    snap_check(w, &s);
    TU_OK(defsim_world_step(w, 1e-3));   /* the world goes on */
    /* A smaller max_internal_steps lowers the step that is refused at once. */
    TU_OK(defsim_world_set_option_number(w, "sundials_erk.max_internal_steps", 1000));
    s = snap_take(w);
    assert_int_equal(defsim_world_step(w, 10.0), DEFSIM_ERR_NOT_CONVERGED);
    snap_check(w, &s);
    TU_OK(defsim_world_step(w, 1e-2));   /* about 2 internal steps: allowed */
    defsim_world_destroy(w);

    /* A call that would run for seconds (h = 100 s: about 32,000 internal steps): the host stops
     * it from its force callback, which explicit backends call at every force evaluation. */
    w = erk_box();
    stop_after = 500;
    stop_calls = 0;
    TU_OK(defsim_world_set_force_callback(w, stopping_cb, NULL, NULL));
    s = snap_take(w);
    t0 = now_s();
    assert_int_equal(defsim_world_step(w, 100.0), DEFSIM_ERR_CALLBACK);
    printf("  h = 100 s, stopped by the callback after %ld calls in %.3f s\n", stop_calls,
           now_s() - t0);
    assert_int_equal(stop_calls, stop_after);   /* no force evaluation after the stop */
    snap_check(w, &s);
    defsim_world_destroy(w);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_stable_step_resting),
        cmocka_unit_test(test_stable_step_friction),
        cmocka_unit_test(test_pin_forces_unpinned),
        cmocka_unit_test(test_pose_bound),
        cmocka_unit_test(test_distance_overflow),
        cmocka_unit_test(test_collider_sizes),
        cmocka_unit_test(test_option_ranges),
        cmocka_unit_test(test_erk_work),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
