/* SPDX-License-Identifier: MIT */
/*
 * The host's coupling API: held external forces, the force callback (held over implicit steps
 * or with a Jacobian), driven pins, attachments (forces, energies and Hessians against finite
 * differences, the pattern, dampers, hanging bodies), pin forces at static equilibrium, element
 * stress against defsim_material_eval, and every bad-input path leaving the world bit-identical.
 */
#include "test_util.h"

#include "assembly.h"
#include "forces.h"
#include "world.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

static const double LO[3] = {0, 0, 0}, HI[3] = {1.0, 0.25, 0.25};

static defsim_world *world_def(const char *backend, double gy, double tol)
{
    defsim_world_def d;
    defsim_world_def_init(&d, sizeof d);
    d.backend = backend;
    d.gravity[1] = gy;
    d.num_threads = 1;
    defsim_world *w = NULL;
    if (defsim_world_create(&d, &w) != DEFSIM_OK) fail_msg("world_create: %s", defsim_last_error());
    tu_backend_option(w, backend, "tolerance", tol);
    return w;
}

static defsim_body_id add_beam(defsim_world *w, defsim_model model)
{
    return tu_add_box(w, model, 4, 1, 1, LO, HI, 1e5, 0.3, 1000.0);
}

static double *masses(const defsim_world *w)
{
    const int n = defsim_world_vertex_count(w);
    double *m = malloc((size_t)n * sizeof *m);
    TU_OK(defsim_world_get_masses(w, m, n));
    return m;
}

static void momentum(const defsim_world *w, double p[3])
{
    const int n = defsim_world_vertex_count(w);
    double *v = tu_velocities(w), *m = masses(w);
    p[0] = p[1] = p[2] = 0.0;
    for (int i = 0; i < n; ++i)
        for (int k = 0; k < 3; ++k) p[k] += m[i] * v[3 * i + k];
    free(v);
    free(m);
}

/* Two worlds alike, each with one beam (body_k(w, 0)): one to couple, *ref to compare with. */
static defsim_world *twins(const char *backend, double gy, double tol, defsim_model model,
                           defsim_world **ref)
{
    defsim_world *w = world_def(backend, gy, tol);
    *ref = world_def(backend, gy, tol);
    add_beam(w, model);
    add_beam(*ref, model);
    return w;
}

/* The id of the k-th body added to a world where none was removed (ids carry the world's tag). */
static defsim_body_id body_k(const defsim_world *w, int32_t k)
{
    return (defsim_body_id){defsim__world_id_index(w, k), 1};
}

/* An attachment of vertex `vertex` of `body`, stiffness k and damping c, to the origin. */
static defsim_attachment_def attachment(defsim_body_id body, int32_t vertex, double k, double c)
{
    defsim_attachment_def d;
    defsim_attachment_def_init(&d, sizeof d);
    d.body = body;
    d.vertex = vertex;
    d.stiffness = k; d.damping = c;   /* N/m, N s/m */
    return d;
}

/* Random forces, fixed seed: 3 n doubles in [-scale, scale). */
static double *random_forces(int n, double scale, unsigned long long seed)
{
    double *f = malloc(3 * (size_t)n * sizeof *f);
    for (int i = 0; i < 3 * n; ++i) f[i] = scale * tu_rand(&seed);
    return f;
}

/* A beam in a world of the given backend without gravity, with held random forces *f. */
static defsim_world *beam_with_forces(const char *backend, defsim_model model, double scale,
                                      unsigned long long seed, double **f)
{
    defsim_world *w = world_def(backend, 0.0, 1e-6);
    add_beam(w, model);
    const int n = defsim_world_vertex_count(w);
    *f = random_forces(n, scale, seed);
    TU_OK(defsim_world_set_external_forces(w, *f, n));
    return w;
}

/* The world's state as it is now, to compare bit for bit after a failed call. */
typedef struct snapshot {
    double *x, *v, t;
} snapshot;

static snapshot snap(const defsim_world *w)
{
    snapshot s = {tu_positions(w), tu_velocities(w), defsim_world_time(w)};
    return s;
}

static void assert_unchanged(const defsim_world *w, snapshot s)
{
    const int n = defsim_world_vertex_count(w);
    double *x = tu_positions(w), *v = tu_velocities(w);
    assert_memory_equal(x, s.x, 3 * (size_t)n * sizeof *x);
    assert_memory_equal(v, s.v, 3 * (size_t)n * sizeof *v);
    assert_true(defsim_world_time(w) == s.t);
    free(x); free(v); free(s.x); free(s.v);
}

/* ------------------------------------------------------------------------------------------ */
/* External forces */

/* Free particles (no elements), gravity off, constant forces: symplectic Euler's velocity after
 * n steps is n h F / m to rounding, its position sum_k k h^2 F / m. */
static void test_external_particles(void **state)
{
    (void)state;
    defsim_world *w = world_def("symplectic_euler", 0.0, 1e-6);
    const double rest[9] = {0, 0, 0, 1, 0, 0, 0, 2, 0}, m[3] = {0.5, 2.0, 3.0};
    defsim_body_def bd;
    defsim_body_def_init(&bd, sizeof bd);
    defsim_material_init(&bd.material, sizeof bd.material, DEFSIM_MODEL_SPRING);
    bd.rest_positions = rest;
    bd.vertex_count = 3;
    bd.vertex_mass = m;
    TU_OK(defsim_world_add_body(w, &bd, NULL));
    const double F[9] = {1, -2, 3, 0.25, 0, -1, 7, 7, 7};
    TU_OK(defsim_world_set_external_forces(w, F, 3));
    const double h = 1e-2;
    const int n = 100;
    for (int s = 0; s < n; ++s) TU_OK(defsim_world_step(w, h));
    double *v = tu_velocities(w), *x = tu_positions(w);
    for (int i = 0; i < 3; ++i)
        for (int k = 0; k < 3; ++k) {
            const double a = F[3 * i + k] / m[i];
            assert_true(fabs(v[3 * i + k] - n * h * a) <= 1e-13 * fabs(n * h * a) + 1e-300);
            const double xe = rest[3 * i + k] + h * h * a * n * (n + 1) / 2.0;
            assert_true(fabs(x[3 * i + k] - xe) <= 1e-12 * (fabs(xe) + 1.0));
        }
    defsim_stats st = {.size = sizeof st};
    TU_OK(defsim_world_stats(w, &st));
    assert_true(st.passes & DEFSIM_PASS_EXTERNAL_FORCES);
    assert_false(st.passes & DEFSIM_PASS_GRAVITY);
    free(v); free(x);
    defsim_world_destroy(w);
}

/* A deforming body with random forces: momentum grows as t sum F (internal forces cancel), and
 * the energy (kinetic + elastic + the forces' potential -f . x) is that of a conservative
 * system; clearing the forces stops the growth. */
static void test_external_momentum(void **state)
{
    (void)state;
    const char *backends[2] = {"symplectic_euler", "explicit_euler"};
    for (int b = 0; b < 2; ++b) {
        double *f, sum[3] = {0, 0, 0};
        defsim_world *w = beam_with_forces(backends[b], DEFSIM_MODEL_STABLE_NEOHOOKEAN, 0.5, 7, &f);
        const int n = defsim_world_vertex_count(w);
        for (int i = 0; i < n; ++i)
            for (int k = 0; k < 3; ++k) sum[k] += f[3 * i + k];
        const double h = 2e-4;
        const int steps = 500;
        for (int s = 0; s < steps; ++s) TU_OK(defsim_world_step(w, h));
        double p[3];
        momentum(w, p);
        for (int k = 0; k < 3; ++k) assert_true(fabs(p[k] - steps * h * sum[k]) <= 1e-10 * fabs(sum[k]) + 1e-12);
        TU_OK(defsim_world_set_external_forces(w, NULL, 0));
        double p2[3];
        for (int s = 0; s < 10; ++s) TU_OK(defsim_world_step(w, h));
        momentum(w, p2);
        for (int k = 0; k < 3; ++k) assert_true(fabs(p2[k] - p[k]) <= 1e-12 * (fabs(p[k]) + 1e-3));
        free(f);
        defsim_world_destroy(w);
    }
}

/* The potential of held forces is in defsim_energy.gravitational; symplectic Euler keeps the
 * total energy of the (conservative) system within its O(h^2) band. Bad forces are refused. */
static void test_external_energy(void **state)
{
    (void)state;
    double *f;
    defsim_world *w = beam_with_forces("symplectic_euler", DEFSIM_MODEL_COROTATED, 0.2, 3, &f);
    const int n = defsim_world_vertex_count(w);
    double *x = tu_positions(w);
    defsim_energy e0;
    TU_OK(defsim_world_energy(w, &e0));
    double pot = 0.0;
    for (int i = 0; i < 3 * n; ++i) pot -= f[i] * x[i];
    assert_true(fabs(e0.gravitational - pot) <= 1e-14 * fabs(pot));
    double emax = 0.0;
    for (int s = 0; s < 2000; ++s) {
        TU_OK(defsim_world_step(w, 1e-4));
        defsim_energy e;
        TU_OK(defsim_world_energy(w, &e));
        emax = fmax(emax, fabs(e.total - e0.total));
        if (s == 1999) assert_true(e.kinetic > 1e-4);   /* the forces did work */
    }
    defsim_energy e;
    TU_OK(defsim_world_energy(w, &e));
    assert_true(emax <= 2e-2 * e.kinetic);

    /* NaN, infinite or miscounted forces are refused, and the forces held before are kept. */
    double *bad = random_forces(n, 1.0, 6);
    bad[3 * 4 + 1] = NAN;
    assert_int_equal(defsim_world_set_external_forces(w, bad, n), DEFSIM_ERR_INVALID_ARGUMENT);
    bad[3 * 4 + 1] = INFINITY;
    assert_int_equal(defsim_world_set_external_forces(w, bad, n), DEFSIM_ERR_INVALID_ARGUMENT);
    assert_int_equal(defsim_world_set_external_forces(w, f, n - 1), DEFSIM_ERR_INVALID_ARGUMENT);
    assert_int_equal(defsim_world_set_external_forces(NULL, f, n), DEFSIM_ERR_INVALID_ARGUMENT);
    defsim_energy e1;
    TU_OK(defsim_world_energy(w, &e1));
    assert_true(e1.gravitational == e.gravitational);   /* the held forces are the old ones */
    free(f); free(x); free(bad);
    defsim_world_destroy(w);
}

/* Forces are carried per body when bodies are added and removed. */
static void test_external_carried(void **state)
{
    (void)state;
    defsim_world *w = world_def("symplectic_euler", 0.0, 1e-6);
    defsim_body_id a = add_beam(w, DEFSIM_MODEL_STVK);
    const int na = defsim_world_vertex_count(w);
    double *f = random_forces(na, 1.0, 11);
    TU_OK(defsim_world_set_external_forces(w, f, na));
    defsim_body_id b = add_beam(w, DEFSIM_MODEL_STVK);
    TU_OK(defsim_world_remove_body(w, a));
    /* Body b got zero forces: stepping it alone leaves it at rest. */
    TU_OK(defsim_world_step(w, 1e-4));
    double *v = tu_velocities(w);
    for (int i = 0; i < 3 * defsim_body_vertex_count(w, b); ++i) assert_true(v[i] == 0.0);
    free(v);
    defsim_world_destroy(w);

    /* Forces on the second of two bodies follow it when the first is removed. */

    w = world_def("symplectic_euler", 0.0, 1e-6);
    a = add_beam(w, DEFSIM_MODEL_STVK);
    b = add_beam(w, DEFSIM_MODEL_STVK);
    double *f2 = calloc(6 * (size_t)na, sizeof *f2);
    memcpy(f2 + 3 * na, f, 3 * (size_t)na * sizeof *f);   /* forces on b only */
    TU_OK(defsim_world_set_external_forces(w, f2, 2 * na));
    TU_OK(defsim_world_remove_body(w, a));
    defsim_world *ref = world_def("symplectic_euler", 0.0, 1e-6);
    add_beam(ref, DEFSIM_MODEL_STVK);
    TU_OK(defsim_world_set_external_forces(ref, f, na));
    for (int s = 0; s < 20; ++s) {
        TU_OK(defsim_world_step(w, 1e-4));
        TU_OK(defsim_world_step(ref, 1e-4));
    }
    double *x1 = tu_positions(w), *x2 = tu_positions(ref);
    assert_memory_equal(x1, x2, 3 * (size_t)na * sizeof *x1);
    free(x1); free(x2); free(f); free(f2);
    defsim_world_destroy(w);
    defsim_world_destroy(ref);
}

/* All-zero forces cost nothing: the pass does not run, and the trajectory is bit-identical to
 * a world without them. */
static void test_external_zero_skipped(void **state)
{
    (void)state;
    defsim_world *ref, *w = twins("symplectic_euler", -9.81, 1e-6,
                                  DEFSIM_MODEL_STABLE_NEOHOOKEAN, &ref);
    const defsim_body_id b = body_k(w, 0), rb = body_k(ref, 0);
    tu_pin_below(w, b, 0, 0.0);
    tu_pin_below(ref, rb, 0, 0.0);
    const int n = defsim_world_vertex_count(w);
    double *z = calloc(3 * (size_t)n, sizeof *z);
    TU_OK(defsim_world_set_external_forces(w, z, n));
    for (int s = 0; s < 50; ++s) {
        TU_OK(defsim_world_step(w, 1e-4));
        TU_OK(defsim_world_step(ref, 1e-4));
    }
    defsim_stats st = {.size = sizeof st};
    TU_OK(defsim_world_stats(w, &st));
    assert_false(st.passes & (DEFSIM_PASS_EXTERNAL_FORCES | DEFSIM_PASS_FORCE_CALLBACK |
                              DEFSIM_PASS_ATTACHMENTS | DEFSIM_PASS_DRIVEN_PINS));
    double *x1 = tu_positions(w), *x2 = tu_positions(ref);
    assert_memory_equal(x1, x2, 3 * (size_t)n * sizeof *x1);
    free(x1); free(x2); free(z);
    defsim_world_destroy(w);
    defsim_world_destroy(ref);
}

/* ------------------------------------------------------------------------------------------ */
/* The force callback */

typedef struct cb_data {
    const double *f;          /* constant force to add (3 n) */
    double k;                 /* spring to the origin: f = -k x (with f NULL) */
    int calls, jac_calls;
    int fail_at;              /* fail (return 2) at this call (1-based); 0: never */
    int nan_at;               /* write a NaN at this call */
    double t_seen[8];
    defsim_world *w;          /* for the re-entrance test */
    defsim_status reentry;
} cb_data;

static int cb_force(void *user, const double *x, const double *v, double t, int32_t n,
                    double *f)
{
    (void)v;
    cb_data *d = user;
    d->calls++;
    if (d->calls <= 8) d->t_seen[d->calls - 1] = t;
    if (d->w) d->reentry = defsim_world_step(d->w, 1e-3);
    if (d->calls == d->fail_at) return 2;
    for (int i = 0; i < 3 * n; ++i) f[i] += d->f ? d->f[i] : -d->k * x[i];
    if (d->calls == d->nan_at) f[3 * (n - 1)] = NAN;
    return 0;
}

static int cb_jacobian(void *user, const double *x, const double *v, double t, int32_t n,
                       double *blocks)
{
    (void)x; (void)v; (void)t;
    cb_data *d = user;
    d->jac_calls++;
    for (int i = 0; i < n; ++i)
        for (int r = 0; r < 3; ++r)
            for (int c = 0; c < 3; ++c) blocks[9 * i + 3 * r + c] = r == c ? -d->k : 0.0;
    return 0;
}

/* In an explicit backend, a callback adding constant forces gives the trajectory of held
 * external forces bit for bit, and sees the time at the start of each step. */
static void test_callback_explicit(void **state)
{
    (void)state;
    defsim_world *ref, *w = twins("symplectic_euler", 0.0, 1e-6, DEFSIM_MODEL_NEOHOOKEAN, &ref);
    const int n = defsim_world_vertex_count(w);
    double *f = random_forces(n, 0.3, 9);
    cb_data d = {.f = f};
    TU_OK(defsim_world_set_force_callback(w, cb_force, NULL, &d));
    TU_OK(defsim_world_set_external_forces(ref, f, n));
    for (int s = 0; s < 40; ++s) {
        TU_OK(defsim_world_step(w, 1e-4));
        TU_OK(defsim_world_step(ref, 1e-4));
    }
    assert_int_equal(d.calls, 40);
    for (int s = 0; s < 8; ++s) assert_true(fabs(d.t_seen[s] - s * 1e-4) <= 1e-18);
    double *x1 = tu_positions(w), *x2 = tu_positions(ref);
    assert_memory_equal(x1, x2, 3 * (size_t)n * sizeof *x1);
    defsim_stats st = {.size = sizeof st};
    TU_OK(defsim_world_stats(w, &st));
    assert_true(st.passes & DEFSIM_PASS_FORCE_CALLBACK);
    /* Cleared: no more calls. */
    TU_OK(defsim_world_set_force_callback(w, NULL, NULL, NULL));
    TU_OK(defsim_world_step(w, 1e-4));
    assert_int_equal(d.calls, 40);
    free(x1); free(x2); free(f);
    defsim_world_destroy(w);
    defsim_world_destroy(ref);
}

/* The implicit backends of this build (those that fail to load are skipped), and how closely
 * two runs of the same physics summed in another order agree in each: to the Newton tolerance,
 * or to the error control of the adaptive one. */
static const char *const implicit_backends[3] = {"newton_cholmod", "sundials_kinsol",
                                                 "sundials_ida"};
static const double implicit_agree[3] = {1e-6, 1e-6, 1e-4};

/* A force that varies in time, F sin(omega t) on every vertex: the momentum at T is
 * sum F (1 - cos omega T) / omega, and a backend that evaluates forces within its step must hand
 * the callback the time of each evaluation to get it to its order: velocity Verlet (second
 * order: the end of the step for its second force) and sundials_erk (the stage times). */
static int cb_sine(void *user, const double *x, const double *v, double t, int32_t n, double *f)
{
    (void)x; (void)v;
    const double *F = user;
    for (int i = 0; i < 3 * n; ++i) f[i] += F[i] * sin(5.0 * t);
    return 0;
}

static void test_callback_time(void **state)
{
    (void)state;
    const char *backends[2] = {"velocity_verlet", "sundials_erk"};
    for (int b = 0; b < 2; ++b) {
        if (!tu_available(backends[b])) continue;
        defsim_world *w = world_def(backends[b], 0.0, 1e-6);
        add_beam(w, DEFSIM_MODEL_STABLE_NEOHOOKEAN);
        const int n = defsim_world_vertex_count(w);
        double *F = random_forces(n, 1.0, 41), sum[3] = {0, 0, 0}, p[3];
        for (int i = 0; i < 3 * n; ++i) sum[i % 3] += F[i];
        TU_OK(defsim_world_set_force_callback(w, cb_sine, NULL, F));
        const double h = 2e-3;
        for (int s = 0; s < 200; ++s) TU_OK(defsim_world_step(w, h));
        momentum(w, p);
        const double T = defsim_world_time(w), g = (1.0 - cos(5.0 * T)) / 5.0;
        for (int k = 0; k < 3; ++k)
            if (!(fabs(p[k] - sum[k] * g) <= 1e-4 * fabs(sum[k] * g)))
                fail_msg("%s: momentum[%d] %.9g, want %.9g", backends[b], k, p[k], sum[k] * g);
        free(F);
        defsim_world_destroy(w);
    }
}

/* Implicit backends, no Jacobian: the callback is called once per step, at the start, and held:
 * the same trajectory as held external forces set to its value before each step. */
static void test_callback_implicit_held(void **state)
{
    (void)state;
    for (int b = 0; b < 3; ++b) {
        if (!tu_available(implicit_backends[b])) continue;
        defsim_world *ref, *w = twins(implicit_backends[b], 0.0, 1e-10,
                                      DEFSIM_MODEL_STABLE_NEOHOOKEAN, &ref);
        const int n = defsim_world_vertex_count(w);
        cb_data d = {.k = 50.0};
        TU_OK(defsim_world_set_force_callback(w, cb_force, NULL, &d));
        double *f = malloc(3 * (size_t)n * sizeof *f);
        for (int s = 0; s < 10; ++s) {
            double *x = tu_positions(ref);
            for (int i = 0; i < 3 * n; ++i) f[i] = -d.k * x[i];
            TU_OK(defsim_world_set_external_forces(ref, f, n));
            TU_OK(defsim_world_step(w, 1e-2));
            TU_OK(defsim_world_step(ref, 1e-2));
            free(x);
            assert_int_equal(d.calls, s + 1);
            assert_true(fabs(d.t_seen[s < 8 ? s : 7] - (s < 8 ? s : 7) * 1e-2) <= 1e-15);
        }
        double *x1 = tu_positions(w), *x2 = tu_positions(ref);
        if (!(tu_rel_diff(x1, x2, 3 * n, 1.0) <= 1e-9))
            fail_msg("%s: held callback and held forces differ by %.3g", implicit_backends[b],
                     tu_rel_diff(x1, x2, 3 * n, 1.0));
        free(x1); free(x2); free(f);
        defsim_world_destroy(w);
        defsim_world_destroy(ref);
    }
}

/* Implicit backends with a Jacobian: a callback spring to the origin, f = -k x, is the same
 * physics as an attachment of stiffness k to the origin at every vertex, and Newton converges
 * about as fast (the Jacobian enters the matrix, its model the line search): newton_cholmod
 * within 2 iterations; sundials_kinsol (its guess x_n + h v_n + h^2 M^-1 f_applied holds the
 * callback's force but not the attachments') and sundials_ida (adaptive steps) within 50 % + 2. */
static void test_callback_implicit_jacobian(void **state)
{
    (void)state;
    const double k = 400.0;
    for (int b = 0; b < 3; ++b) {
        if (!tu_available(implicit_backends[b])) continue;
        defsim_world *ref, *w = twins(implicit_backends[b], -9.81, 1e-8,
                                      DEFSIM_MODEL_STABLE_NEOHOOKEAN, &ref);
        const defsim_body_id rb = body_k(ref, 0);
        const int n = defsim_world_vertex_count(w);
        cb_data d = {.k = k};
        TU_OK(defsim_world_set_force_callback(w, cb_force, cb_jacobian, &d));
        for (int i = 0; i < n; ++i) {
            const defsim_attachment_def ad = attachment(rb, i, k, 0.0);
            TU_OK(defsim_world_add_attachment(ref, &ad, NULL));
        }
        for (int s = 0; s < 10; ++s) {
            TU_OK(defsim_world_step(w, 2e-2));
            TU_OK(defsim_world_step(ref, 2e-2));
        }
        double *x1 = tu_positions(w), *x2 = tu_positions(ref);
        if (!(tu_rel_diff(x1, x2, 3 * n, 1.0) <= implicit_agree[b]))
            fail_msg("%s: callback with Jacobian and attachments differ by %.3g",
                     implicit_backends[b], tu_rel_diff(x1, x2, 3 * n, 1.0));
        defsim_stats s1 = {.size = sizeof s1}, s2 = {.size = sizeof s2};
        TU_OK(defsim_world_stats(w, &s1));
        TU_OK(defsim_world_stats(ref, &s2));
        const int64_t slack = b == 0 ? 2 : 2 + tu_bstat(ref, "newton_iterations") / 2;
        if (!(tu_bstat(w, "newton_iterations") <= tu_bstat(ref, "newton_iterations") + slack))
            fail_msg("%s: %lld Newton iterations with the callback, %lld with attachments",
                     implicit_backends[b], (long long)tu_bstat(w, "newton_iterations"),
                     (long long)tu_bstat(ref, "newton_iterations"));
        assert_true(d.jac_calls >= 10);
        assert_true(d.calls > 10);   /* evaluated at the iterates, not held */
        free(x1); free(x2);
        defsim_world_destroy(w);
        defsim_world_destroy(ref);
    }
}

/* A failing or NaN-returning callback fails the step with DEFSIM_ERR_CALLBACK and leaves the
 * world bit-identical; a callback that calls the world is refused with DEFSIM_ERR_LOCKED. */
static void test_callback_failures(void **state)
{
    (void)state;
    const char *backends[2] = {"symplectic_euler", "newton_cholmod"};
    for (int b = 0; b < 2; ++b) {
        for (int mode = 0; mode < 2; ++mode) {
            defsim_world *w = world_def(backends[b], -9.81, 1e-8);
            defsim_body_id id = add_beam(w, DEFSIM_MODEL_STABLE_NEOHOOKEAN);
            tu_pin_below(w, id, 0, 0.0);
            cb_data d = {.k = 1.0};
            if (mode == 0) d.fail_at = 3; else d.nan_at = 3;
            TU_OK(defsim_world_set_force_callback(w, cb_force, b ? cb_jacobian : NULL, &d));
            defsim_status st = DEFSIM_OK;
            snapshot s = {0};
            int fails = 0;
            for (int k = 0; k < 6 && st == DEFSIM_OK; ++k) {
                s = snap(w);
                st = defsim_world_step(w, 1e-3);
                if (st == DEFSIM_OK) { free(s.x); free(s.v); }
                else fails++;
            }
            assert_int_equal(st, DEFSIM_ERR_CALLBACK);
            assert_int_equal(fails, 1);
            assert_true(strlen(defsim_world_last_error(w)) > 0);
            assert_unchanged(w, s);
            defsim_stats stt = {.size = sizeof stt};
            TU_OK(defsim_world_stats(w, &stt));
            assert_int_equal(stt.failed_steps, 1);
            /* The world stays usable. */
            TU_OK(defsim_world_step(w, 1e-3));
            defsim_world_destroy(w);
        }
    }
    defsim_world *w = world_def("symplectic_euler", -9.81, 1e-8);
    add_beam(w, DEFSIM_MODEL_STVK);
    cb_data d = {.k = 1.0};
    d.w = w;
    TU_OK(defsim_world_set_force_callback(w, cb_force, NULL, &d));
    TU_OK(defsim_world_step(w, 1e-4));
    assert_int_equal(d.reentry, DEFSIM_ERR_LOCKED);
    assert_true(fabs(defsim_world_time(w) - 1e-4) <= 1e-18);
    assert_int_equal(defsim_world_set_force_callback(w, NULL, cb_jacobian, NULL),
                     DEFSIM_ERR_INVALID_ARGUMENT);
    defsim_world_destroy(w);
}

/* ------------------------------------------------------------------------------------------ */
/* Driven pins */

/* Pinned vertices land exactly on their targets at the end of each step, with velocity
 * displacement / h, and stay put (velocity zero) in a step without a target; also when the
 * world splits steps into substeps (auto_substep: the pins pass through points of the line). */
static void test_driven_lands(void **state)
{
    (void)state;
    const char *backends[3] = {"symplectic_euler", "explicit_euler", "symplectic_euler"};
    for (int b = 0; b < 3; ++b) {
        defsim_world_def wd;
        defsim_world_def_init(&wd, sizeof wd);
        wd.backend = backends[b];
        wd.num_threads = 1;
        defsim_world *w = NULL;
        TU_OK(defsim_world_create(&wd, &w));
        TU_OK(defsim_world_set_option_number(w, "core.auto_substep", b == 2));
        defsim_body_id id = add_beam(w, DEFSIM_MODEL_STABLE_NEOHOOKEAN);
        int32_t verts[64];
        double *x = tu_positions(w);
        int nd = 0;
        for (int i = 0; i < defsim_body_vertex_count(w, id); ++i)
            if (x[3 * i] <= 1e-12) verts[nd++] = i;
        double *tgt = malloc(3 * (size_t)nd * sizeof *tgt);
        const double h = b == 2 ? 0.05 : 1e-4;
        for (int s = 0; s < 30; ++s) {
            const double a = 0.01 * (s + 1);
            for (int j = 0; j < nd; ++j) {
                const double *p = x + 3 * verts[j];
                tgt[3 * j] = p[0] + 0.1 * sin(a);
                tgt[3 * j + 1] = p[1] + 0.1 * (1 - cos(a));
                tgt[3 * j + 2] = p[2] + a * a;
            }
            double *before = tu_positions(w);
            TU_OK(defsim_body_set_pin_targets(w, id, verts, nd, tgt));
            TU_OK(defsim_world_step(w, h));
            double *xs = tu_positions(w), *vs = tu_velocities(w);
            for (int j = 0; j < nd; ++j)
                for (int k = 0; k < 3; ++k) {
                    assert_true(xs[3 * verts[j] + k] == tgt[3 * j + k]);
                    const double ve = (tgt[3 * j + k] - before[3 * verts[j] + k]) / h;
                    assert_true(fabs(vs[3 * verts[j] + k] - ve) <= 1e-12 * (fabs(ve) + 1.0));
                }
            free(xs); free(vs); free(before);
        }
        defsim_stats st = {.size = sizeof st};
        TU_OK(defsim_world_stats(w, &st));
        assert_true(st.passes & DEFSIM_PASS_DRIVEN_PINS);
        if (b == 2) assert_true(st.substeps > 3 * st.steps);
        TU_OK(defsim_world_step(w, h));
        TU_OK(defsim_world_stats(w, &st));
        assert_false(st.passes & DEFSIM_PASS_DRIVEN_PINS);
        double *xs = tu_positions(w), *vs = tu_velocities(w);
        for (int j = 0; j < nd; ++j)
            for (int k = 0; k < 3; ++k) {
                assert_true(xs[3 * verts[j] + k] == tgt[3 * j + k]);
                assert_true(vs[3 * verts[j] + k] == 0.0);
            }
        free(xs); free(vs); free(x); free(tgt);
        defsim_world_destroy(w);
    }
}

/* Driven pins under stiffness damping: the damping of their motion on the free vertices is a
 * term that each backward-Euler backend forms its own way (newton_cholmod: a cross term of its
 * incremental potential; sundials_kinsol: a load -B(x_n) v_pins). Both solve the same equations,
 * so a clamp twisted about the beam's axis gives the same motion in both. */
static void test_driven_damped_implicit(void **state)
{
    (void)state;
    if (!tu_available("sundials_kinsol")) skip();
    double *x[2];
    for (int b = 0; b < 2; ++b) {
        defsim_world_def wd;
        defsim_world_def_init(&wd, sizeof wd);
        wd.backend = implicit_backends[b];
        wd.num_threads = 1;
        defsim_world *w = NULL;
        TU_OK(defsim_world_create(&wd, &w));
        tu_backend_option(w, implicit_backends[b], "tolerance", 1e-10);
        defsim_material mat;
        defsim_material_init(&mat, sizeof mat, DEFSIM_MODEL_STABLE_NEOHOOKEAN);
        mat.youngs_modulus = 1e5;
        mat.stiffness_damping = 0.05;
        defsim_body_id id = tu_add_box_material(w, 4, 1, 1, LO, HI, &mat);
        double *rest = tu_positions(w);
        int32_t cl[8];
        double tgt[24];
        int nc = 0;
        for (int i = 0; i < defsim_world_vertex_count(w); ++i)
            if (rest[3 * i] <= 1e-12) cl[nc++] = i;
        for (int s = 1; s <= 10; ++s) {
            const double a = 0.08 * s, c = cos(a), sn = sin(a);
            for (int j = 0; j < nc; ++j) {
                const double *p = rest + 3 * cl[j];
                const double py = p[1] - 0.125, pz = p[2] - 0.125;
                tgt[3 * j] = p[0];
                tgt[3 * j + 1] = 0.125 + c * py - sn * pz;
                tgt[3 * j + 2] = 0.125 + sn * py + c * pz;
            }
            TU_OK(defsim_body_set_pin_targets(w, id, cl, nc, tgt));
            TU_OK(defsim_world_step(w, 0.02));
        }
        x[b] = tu_positions(w);
        free(rest);
        if (b == 1) {
            const double d = tu_rel_diff(x[0], x[1], 3 * defsim_world_vertex_count(w), 1.0);
            if (!(d <= 1e-7)) fail_msg("newton_cholmod and sundials_kinsol differ by %.3g", d);
        }
        defsim_world_destroy(w);
    }
    free(x[0]); free(x[1]);
}

/* set_pin_targets pins a free vertex; unpinning drops its target; bad input changes nothing. */
static void test_driven_bad_input(void **state)
{
    (void)state;
    defsim_world *w = world_def("symplectic_euler", -9.81, 1e-8);
    defsim_body_id id = add_beam(w, DEFSIM_MODEL_STVK);
    const int32_t v[2] = {0, 3};
    double tgt[6] = {0, 0.1, 0, 0.5, 0.1, 0};
    snapshot s = snap(w);
    tgt[4] = NAN;
    assert_int_equal(defsim_body_set_pin_targets(w, id, v, 2, tgt), DEFSIM_ERR_INVALID_ARGUMENT);
    tgt[4] = 0.1;
    const int32_t vbad[2] = {0, 999};
    assert_int_equal(defsim_body_set_pin_targets(w, id, vbad, 2, tgt),
                     DEFSIM_ERR_INVALID_ARGUMENT);
    assert_int_equal(defsim_body_set_pin_targets(w, id, v, -1, tgt), DEFSIM_ERR_INVALID_ARGUMENT);
    assert_int_equal(defsim_body_set_pin_targets(w, id, v, 2, NULL), DEFSIM_ERR_INVALID_ARGUMENT);
    defsim_body_id stale = {id.index, id.generation + 2};
    assert_int_equal(defsim_body_set_pin_targets(w, stale, v, 2, tgt), DEFSIM_ERR_STALE_ID);
    assert_unchanged(w, s);
    TU_OK(defsim_world_step(w, 1e-4));   /* nothing was pinned by the failed calls */
    double *x = tu_positions(w);
    assert_true(x[1] < 0.0);
    free(x);
    TU_OK(defsim_body_set_pin_targets(w, id, v, 2, tgt));
    TU_OK(defsim_body_unpin(w, id, v + 1, 1));   /* vertex 3 loses its target */
    TU_OK(defsim_world_step(w, 1e-4));
    x = tu_positions(w);
    for (int k = 0; k < 3; ++k) assert_true(x[k] == tgt[k]);
    assert_true(x[3 * 3 + 1] != tgt[4]);
    free(x);
    defsim_world_destroy(w);
}

/* ------------------------------------------------------------------------------------------ */
/* Attachments */

/* Two bodies stitched by attachments: to a world point, body to body through a tet (4 weights)
 * and a triangle (3), vertex to vertex, with dampers. Returns the world. */
static defsim_world *stitched(const char *backend, double gy, defsim_attachment_id ids[4])
{
    defsim_world *w = world_def(backend, gy, 1e-10);
    defsim_body_id a = add_beam(w, DEFSIM_MODEL_STABLE_NEOHOOKEAN);
    const double lo[3] = {0, 0.5, 0}, hi[3] = {1, 0.75, 0.25};
    defsim_body_id b = tu_add_box(w, DEFSIM_MODEL_COROTATED, 4, 1, 1, lo, hi, 1e5, 0.3, 1000.0);
    defsim_attachment_def d = attachment(a, 3, 2e3, 5.0);
    d.target[0] = 0.4; d.target[1] = -0.2; d.target[2] = 0.1;
    TU_OK(defsim_world_add_attachment(w, &d, &ids[0]));
    d.vertex = 7;
    d.target_body = b;
    d.target_vertex_count = 4;
    d.target_vertices[0] = 0; d.target_vertices[1] = 1;
    d.target_vertices[2] = 5; d.target_vertices[3] = 6;
    d.target_weights[0] = 0.1; d.target_weights[1] = 0.2;
    d.target_weights[2] = 0.3; d.target_weights[3] = 0.4;
    TU_OK(defsim_world_add_attachment(w, &d, &ids[1]));
    d.vertex = 9;
    d.damping = 0.0;
    d.target_vertex_count = 3;
    d.target_weights[0] = 0.5; d.target_weights[1] = 0.25; d.target_weights[2] = 0.25;
    TU_OK(defsim_world_add_attachment(w, &d, &ids[2]));
    d.vertex = 2;
    d.target_vertex_count = 1;
    d.target_vertices[0] = 2;
    d.target_weights[0] = 1.0;
    d.damping = 1.0;
    TU_OK(defsim_world_add_attachment(w, &d, &ids[3]));
    return w;
}

/* Forces of the attachments are -dE/dx (central differences of the elastic energy) and their
 * Hessians are exact: the matrix-free product and the assembled pattern (which couples both
 * bodies) agree with finite differences of the forces. */
static void test_attachment_derivatives(void **state)
{
    (void)state;
    defsim_attachment_id ids[4];
    defsim_world *w = stitched("newton_cholmod", 0.0, ids);
    const int n = defsim_world_vertex_count(w);
    double *x = tu_positions(w);
    unsigned long long seed = 17;
    for (int i = 0; i < 3 * n; ++i) x[i] += 0.05 * tu_rand(&seed);
    TU_OK(defsim_world_set_state(w, x, NULL));
    TU_OK(defsim__world_plan(w));
    const defsim__system *s = &w->sys;
    assert_int_equal(s->att.n, 4);
    double *f = malloc(3 * (size_t)n * sizeof *f), *fp = malloc(3 * (size_t)n * sizeof *fp);
    double *fm = malloc(3 * (size_t)n * sizeof *fm), *dx = malloc(3 * (size_t)n * sizeof *dx);
    double *Adx = malloc(3 * (size_t)n * sizeof *Adx), *xp = malloc(3 * (size_t)n * sizeof *xp);
    TU_OK(defsim_world_forces(w, x, f));
    /* Force against the energy: the attached vertices of the first body and their targets. */
    const int probe[5] = {3, 7, 9, 2, 20 + 6};
    const double eps = 1e-6;
    for (int p = 0; p < 5; ++p)
        for (int k = 0; k < 3; ++k) {
            const int i = 3 * probe[p] + k;
            memcpy(xp, x, 3 * (size_t)n * sizeof *x);
            defsim_energy ep, em;
            xp[i] = x[i] + eps;
            TU_OK(defsim_world_set_state(w, xp, NULL));
            TU_OK(defsim_world_energy(w, &ep));
            xp[i] = x[i] - eps;
            TU_OK(defsim_world_set_state(w, xp, NULL));
            TU_OK(defsim_world_energy(w, &em));
            const double fd = -(ep.elastic - em.elastic) / (2 * eps);
            assert_true(fabs(fd - f[i]) <= 1e-6 * (fabs(f[i]) + 1.0));
        }
    TU_OK(defsim_world_set_state(w, x, NULL));
    /* Hessian: the attachments' part alone (elastic bodies too: the product is exact with
     * projection NONE). */
    for (int i = 0; i < 3 * n; ++i) dx[i] = tu_rand(&seed);
    const defsim_matrix_coeffs c = {1.0, 0.0, 0.0, 0.0};
    defsim__matrix_apply(s, x, &c, DEFSIM_PROJECTION_NONE, dx, Adx);
    for (int i = 0; i < 3 * n; ++i) { xp[i] = x[i] + eps * dx[i]; }
    defsim__forces(s, xp, NULL, DEFSIM_FORCE_ELASTIC | DEFSIM__FORCE_KEEP_PINNED, fp, NULL);
    for (int i = 0; i < 3 * n; ++i) { xp[i] = x[i] - eps * dx[i]; }
    defsim__forces(s, xp, NULL, DEFSIM_FORCE_ELASTIC | DEFSIM__FORCE_KEEP_PINNED, fm, NULL);
    double num = 0.0, den = 0.0;
    for (int i = 0; i < 3 * n; ++i) {
        const double fd = -(fp[i] - fm[i]) / (2 * eps);
        num = fmax(num, fabs(fd - Adx[i]));
        den = fmax(den, fabs(Adx[i]));
    }
    assert_true(num <= 1e-5 * den);
    /* The assembled matrix (FULL pattern, the world's clamped projection) times dx equals the
     * matrix-free product with the same projection: the pattern holds every coupling. */
    defsim_csc pat;
    TU_OK(defsim__pattern_build(&w->sys));
    TU_OK(defsim__matrix_pattern(s, DEFSIM_TRIANGLE_FULL, &pat));
    double *val = malloc((size_t)pat.nnz * sizeof *val);
    TU_OK(defsim__matrix_values(s, x, &c, DEFSIM_TRIANGLE_FULL, val, NULL));
    defsim__matrix_apply(s, x, &c, s->projection, dx, Adx);
    double *y = calloc((size_t)pat.n, sizeof *y);
    for (int64_t j = 0; j < pat.n; ++j)
        for (int64_t q = pat.col_ptr[j]; q < pat.col_ptr[j + 1]; ++q)
            y[pat.row_idx[q]] += val[q] * dx[s->free_dofs[j]];
    double err = 0.0, ref = 0.0;
    for (int64_t j = 0; j < pat.n; ++j) {
        err = fmax(err, fabs(y[j] - Adx[s->free_dofs[j]]));
        ref = fmax(ref, fabs(Adx[s->free_dofs[j]]));
    }
    assert_true(err <= 1e-12 * ref);
    /* The damping matrix B of the attachments (kd) against the damping force. */
    const defsim_matrix_coeffs cd = {0.0, 1.0, 0.0, 0.0};
    defsim__matrix_apply(s, x, &cd, s->projection, dx, Adx);
    defsim__forces(s, x, dx, DEFSIM_FORCE_DAMPING | DEFSIM__FORCE_KEEP_PINNED, fp, NULL);
    for (int i = 0; i < 3 * n; ++i) assert_true(fabs(Adx[i] + fp[i]) <= 1e-12 * (fabs(fp[i]) + 1));
    free(f); free(fp); free(fm); free(dx); free(Adx); free(xp); free(x); free(val); free(y);
    defsim_world_destroy(w);
}

/* Attachments between bodies are internal forces: with dampers, momentum is conserved; the
 * force read back is -k d - c dv on the vertex. */
static void test_attachment_momentum(void **state)
{
    (void)state;
    defsim_attachment_id ids[4];
    defsim_world *w = stitched("symplectic_euler", 0.0, ids);
    TU_OK(defsim_world_remove_attachment(w, ids[0]));   /* the world point is external */
    assert_int_equal(defsim_world_remove_attachment(w, ids[0]), DEFSIM_ERR_STALE_ID);
    const int n = defsim_world_vertex_count(w);
    double *v = random_forces(n, 0.3, 23), p0[3], p1[3];
    TU_OK(defsim_world_set_state(w, NULL, v));
    momentum(w, p0);
    for (int s = 0; s < 300; ++s) TU_OK(defsim_world_step(w, 2e-4));
    momentum(w, p1);
    for (int k = 0; k < 3; ++k) assert_true(fabs(p1[k] - p0[k]) <= 1e-12);
    /* Vertex-to-vertex attachment (ids[3]): body a vertex 2 to body b vertex 2 (offset 20). */
    double f[3], *x = tu_positions(w), *vv = tu_velocities(w);
    TU_OK(defsim_world_get_attachment_force(w, ids[3], f));
    for (int k = 0; k < 3; ++k) {
        const double e = -2e3 * (x[3 * 2 + k] - x[3 * 22 + k]) - 1.0 * (vv[3 * 2 + k] - vv[3 * 22 + k]);
        assert_true(fabs(f[k] - e) <= 1e-12 * (fabs(e) + 1.0));
    }
    free(v); free(x); free(vv);
    defsim_world_destroy(w);
}

/* A body hanging from world-point attachments, settled: the attachment forces sum to its
 * weight (1e-6 relative); a clamped cantilever settled likewise: the pin forces sum to its
 * weight. */
static void test_static_equilibrium(void **state)
{
    (void)state;
    for (int which = 0; which < 2; ++which) {
        defsim_world *w = world_def("newton_cholmod", -9.81, 1e-12);
        defsim_body_id id = add_beam(w, DEFSIM_MODEL_STABLE_NEOHOOKEAN);
        const int n = defsim_world_vertex_count(w);
        double *x = tu_positions(w);
        defsim_attachment_id att[64];
        int na = 0;
        if (which == 0) {
            tu_pin_below(w, id, 0, 0.0);
        } else {
            for (int i = 0; i < n; ++i)
                if (x[3 * i + 1] >= HI[1] - 1e-12) {
                    defsim_attachment_def ad = attachment(id, i, 5e3, 2.0);
                    memcpy(ad.target, x + 3 * i, sizeof ad.target);
                    TU_OK(defsim_world_add_attachment(w, &ad, &att[na++]));
                }
        }
        /* Implicit Euler's own dissipation settles it (each mode loses a factor
         * 1/sqrt(1 + h^2 omega^2) per step). */
        for (int s = 0; s < 800; ++s) TU_OK(defsim_world_step(w, 0.1));
        double *mass = masses(w), weight = 0.0;
        for (int i = 0; i < n; ++i) weight += mass[i] * 9.81;
        double sum[3] = {0, 0, 0};
        if (which == 0) {
            double *r = malloc(3 * (size_t)n * sizeof *r);
            TU_OK(defsim_world_get_pin_forces(w, r, n));
            for (int i = 0; i < n; ++i)
                for (int k = 0; k < 3; ++k) sum[k] += r[3 * i + k];
            free(r);
        } else {
            for (int a = 0; a < na; ++a) {
                double f[3];
                TU_OK(defsim_world_get_attachment_force(w, att[a], f));
                for (int k = 0; k < 3; ++k) sum[k] += f[k];
            }
        }
        assert_true(fabs(sum[1] - weight) <= 1e-6 * weight);
        assert_true(fabs(sum[0]) <= 1e-6 * weight && fabs(sum[2]) <= 1e-6 * weight);
        free(mass); free(x);
        defsim_world_destroy(w);
    }
}

/* Pin forces: zero on free vertices, -f on pinned ones, including the callback's force. */
static void test_pin_forces_definition(void **state)
{
    (void)state;
    defsim_world *w = world_def("symplectic_euler", -9.81, 1e-8);
    defsim_body_id id = add_beam(w, DEFSIM_MODEL_STVK);
    tu_pin_below(w, id, 0, 0.0);
    const int n = defsim_world_vertex_count(w);
    double *f = random_forces(n, 1.0, 31);
    cb_data d = {.f = f};
    TU_OK(defsim_world_set_force_callback(w, cb_force, NULL, &d));
    for (int s = 0; s < 20; ++s) TU_OK(defsim_world_step(w, 1e-4));
    double *r = malloc(3 * (size_t)n * sizeof *r), *fe = malloc(3 * (size_t)n * sizeof *fe);
    double *x = tu_positions(w), *m = masses(w);
    TU_OK(defsim_world_get_pin_forces(w, r, n));
    TU_OK(defsim_world_forces(w, NULL, fe));
    for (int i = 0; i < n; ++i)
        for (int k = 0; k < 3; ++k) {
            const double e = x[3 * i] <= 1e-12
                                 ? -(fe[3 * i + k] + f[3 * i + k] + (k == 1 ? -9.81 * m[i] : 0.0))
                                 : 0.0;
            assert_true(fabs(r[3 * i + k] - e) <= 1e-10 * (fabs(e) + 1.0));
        }
    d.fail_at = d.calls + 1;
    assert_int_equal(defsim_world_get_pin_forces(w, r, n), DEFSIM_ERR_CALLBACK);
    assert_int_equal(defsim_world_get_pin_forces(w, r, n - 1), DEFSIM_ERR_INVALID_ARGUMENT);
    free(f); free(r); free(fe); free(x); free(m);
    defsim_world_destroy(w);
}

/* The stable-step estimate sees attachments: a stiff spring raises omega_max, a strong damper
 * shortens symplectic Euler's stable step (h^2 w^2 + 2 c h = 4). */
static void test_attachment_stable_step(void **state)
{
    (void)state;
    defsim_world *w = world_def("symplectic_euler", -9.81, 1e-6);
    defsim_body_id b = add_beam(w, DEFSIM_MODEL_STVK);
    double h0, om0, h1, om1, h2, om2;
    TU_OK(defsim_world_stable_step(w, &h0, &om0));
    defsim_attachment_def d = attachment(b, 0, 1.0, 1e4);
    defsim_attachment_id id;
    TU_OK(defsim_world_add_attachment(w, &d, &id));
    TU_OK(defsim_world_stable_step(w, &h1, &om1));
    assert_true(fabs(om1 - om0) <= 1e-3 * om0 && h1 < 0.5 * h0);
    TU_OK(defsim_world_remove_attachment(w, id));
    d.stiffness = 1e9;
    d.damping = 0.0;
    TU_OK(defsim_world_add_attachment(w, &d, NULL));
    TU_OK(defsim_world_stable_step(w, &h2, &om2));
    assert_true(om2 > 2.0 * om0 && h2 < 0.5 * h0);
    defsim_world_destroy(w);
}

/* Ids: removed attachments and those of removed bodies are stale; bad definitions are refused
 * and change nothing; set_target moves a world point without re-planning. */
static void test_attachment_bad_input(void **state)
{
    (void)state;
    defsim_attachment_id ids[4];
    defsim_world *w = stitched("symplectic_euler", -9.81, ids);
    defsim_body_id a = body_k(w, 0), b = body_k(w, 1);
    snapshot s = snap(w);
    defsim_attachment_def d = attachment(a, 1, -1.0, 0.0);
    assert_int_equal(defsim_world_add_attachment(w, &d, NULL), DEFSIM_ERR_INVALID_ARGUMENT);
    d.stiffness = 10.0;
    d.damping = NAN;
    assert_int_equal(defsim_world_add_attachment(w, &d, NULL), DEFSIM_ERR_INVALID_ARGUMENT);
    d.damping = 0.0;
    d.target[1] = NAN;
    assert_int_equal(defsim_world_add_attachment(w, &d, NULL), DEFSIM_ERR_INVALID_ARGUMENT);
    d.target[1] = 0.0;
    d.vertex = 1000;
    assert_int_equal(defsim_world_add_attachment(w, &d, NULL), DEFSIM_ERR_INVALID_ARGUMENT);
    d.vertex = 1;
    d.target_body = b;
    d.target_vertex_count = 2;
    d.target_weights[0] = 0.5;
    d.target_weights[1] = 0.6;
    assert_int_equal(defsim_world_add_attachment(w, &d, NULL), DEFSIM_ERR_INVALID_ARGUMENT);
    d.target_weights[1] = 0.5;
    d.target_vertex_count = 5;
    assert_int_equal(defsim_world_add_attachment(w, &d, NULL), DEFSIM_ERR_INVALID_ARGUMENT);
    d.target_vertex_count = 2;
    d.target_vertices[1] = -1;
    assert_int_equal(defsim_world_add_attachment(w, &d, NULL), DEFSIM_ERR_INVALID_ARGUMENT);
    d.target_vertices[1] = 0;
    d.target_body.generation = 2;
    assert_int_equal(defsim_world_add_attachment(w, &d, NULL), DEFSIM_ERR_STALE_ID);
    const double nan3[3] = {0, NAN, 0};
    assert_int_equal(defsim_attachment_set_target(w, ids[0], nan3), DEFSIM_ERR_INVALID_ARGUMENT);
    defsim_attachment_id bogus = {99, 1};
    double f[3];
    assert_int_equal(defsim_world_get_attachment_force(w, bogus, f), DEFSIM_ERR_STALE_ID);
    assert_unchanged(w, s);
    TU_OK(defsim_world_step(w, 1e-4));
    /* set_target: the world point moves, the force follows at once. */
    const double p[3] = {2.0, 1.0, -1.0};
    TU_OK(defsim_attachment_set_target(w, ids[0], p));
    double *x = tu_positions(w), *v = tu_velocities(w);
    TU_OK(defsim_world_get_attachment_force(w, ids[0], f));
    for (int k = 0; k < 3; ++k)
        assert_true(fabs(f[k] - (-2e3 * (x[9 + k] - p[k]) - 5.0 * v[9 + k])) <= 1e-9);
    free(x); free(v);
    /* Removing body b removes the attachments that reach it; ids[0] (to a world point) stays,
     * and a freed slot is reused with a new generation. */
    TU_OK(defsim_world_remove_body(w, b));
    for (int i = 1; i < 4; ++i)
        assert_int_equal(defsim_world_get_attachment_force(w, ids[i], f), DEFSIM_ERR_STALE_ID);
    TU_OK(defsim_world_get_attachment_force(w, ids[0], f));
    d = attachment(a, 0, 1e3, 0.0);
    defsim_attachment_id id2;
    TU_OK(defsim_world_add_attachment(w, &d, &id2));
    assert_true(id2.index == ids[1].index && id2.generation != ids[1].generation);
    TU_OK(defsim_world_step(w, 1e-4));
    defsim_world_destroy(w);
}

/* ------------------------------------------------------------------------------------------ */
/* Element stress */

/* A uniformly deformed tet: sigma = P F^T / J of defsim_material_eval for every model, von
 * Mises and energy density to match; all zero at rest. */
static void test_element_stress(void **state)
{
    (void)state;
    const double X[12] = {0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1};
    const int32_t T[4] = {1, 2, 3, 0};
    const double F[9] = {1.1, 0.05, -0.02, 0.03, 0.95, 0.04, -0.01, 0.02, 1.05};
    const defsim_model models[4] = {DEFSIM_MODEL_STVK, DEFSIM_MODEL_COROTATED,
                                    DEFSIM_MODEL_NEOHOOKEAN, DEFSIM_MODEL_STABLE_NEOHOOKEAN};
    for (int mi = 0; mi < 4; ++mi) {
        defsim_world *w = world_def("symplectic_euler", 0.0, 1e-6);
        defsim_body_def bd;
        defsim_body_def_init(&bd, sizeof bd);
        defsim_material_init(&bd.material, sizeof bd.material, models[mi]);
        bd.material.youngs_modulus = 3e6;
        bd.material.poisson_ratio = 0.35;
        bd.rest_positions = X;
        bd.vertex_count = 4;
        bd.tets = T;
        bd.tet_count = 1;
        defsim_body_id id;
        TU_OK(defsim_world_add_body(w, &bd, &id));
        double sig[9], vm, psi;
        TU_OK(defsim_body_element_stress(w, id, sig, &vm, &psi, 1));
        for (int i = 0; i < 9; ++i) assert_true(fabs(sig[i]) <= 1e-9 * 3e6);
        assert_true(vm <= 1e-9 * 3e6 && fabs(psi) <= 1e-9 * 3e6);
        double x[12];
        for (int a = 0; a < 4; ++a)
            for (int i = 0; i < 3; ++i)
                x[3 * a + i] = F[3 * i] * X[3 * a] + F[3 * i + 1] * X[3 * a + 1] +
                               F[3 * i + 2] * X[3 * a + 2] + 0.3 * i;
        TU_OK(defsim_world_set_state(w, x, NULL));
        TU_OK(defsim_body_element_stress(w, id, sig, &vm, &psi, 1));
        double P[9], psi_e, psi0;
        const double I[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1};
        TU_OK(defsim_material_eval(&bd.material, F, &psi_e, P, NULL));
        TU_OK(defsim_material_eval(&bd.material, I, &psi0, NULL, NULL));
        const double J = F[0] * (F[4] * F[8] - F[5] * F[7]) - F[1] * (F[3] * F[8] - F[5] * F[6]) +
                         F[2] * (F[3] * F[7] - F[4] * F[6]);
        double se[9], scale = 0.0;
        for (int i = 0; i < 3; ++i)
            for (int j = 0; j < 3; ++j) {
                se[3 * i + j] = (P[3 * i] * F[3 * j] + P[3 * i + 1] * F[3 * j + 1] +
                                 P[3 * i + 2] * F[3 * j + 2]) / J;
                scale = fmax(scale, fabs(se[3 * i + j]));
            }
        assert_true(scale > 1e4);
        for (int i = 0; i < 9; ++i) assert_true(fabs(sig[i] - se[i]) <= 1e-10 * scale);
        /* von Mises in the engineering form (sigma is symmetric). */
        const double d01 = se[0] - se[4], d12 = se[4] - se[8], d20 = se[8] - se[0];
        const double vme = sqrt(0.5 * (d01 * d01 + d12 * d12 + d20 * d20) +
                                3.0 * (se[1] * se[1] + se[5] * se[5] + se[2] * se[2]));
        assert_true(fabs(vm - vme) <= 1e-9 * scale);
        assert_true(fabs(psi - (psi_e - psi0)) <= 1e-10 * fabs(psi_e - psi0));
        assert_int_equal(defsim_body_element_stress(w, id, sig, NULL, NULL, 2),
                         DEFSIM_ERR_INVALID_ARGUMENT);
        defsim_body_id stale = {id.index, 2};
        assert_int_equal(defsim_body_element_stress(w, stale, sig, NULL, NULL, 1),
                         DEFSIM_ERR_STALE_ID);
        defsim_world_destroy(w);
    }
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_external_particles),
        cmocka_unit_test(test_external_momentum),
        cmocka_unit_test(test_external_energy),
        cmocka_unit_test(test_external_carried),
        cmocka_unit_test(test_external_zero_skipped),
        cmocka_unit_test(test_callback_explicit),
        cmocka_unit_test(test_callback_time),
        cmocka_unit_test(test_callback_implicit_held),
        cmocka_unit_test(test_callback_implicit_jacobian),
        cmocka_unit_test(test_callback_failures),
        cmocka_unit_test(test_driven_lands),
        cmocka_unit_test(test_driven_damped_implicit),
        cmocka_unit_test(test_driven_bad_input),
        cmocka_unit_test(test_attachment_derivatives),
        cmocka_unit_test(test_attachment_momentum),
        cmocka_unit_test(test_static_equilibrium),
        cmocka_unit_test(test_pin_forces_definition),
        cmocka_unit_test(test_attachment_stable_step),
        cmocka_unit_test(test_attachment_bad_input),
        cmocka_unit_test(test_element_stress),
    };
    return tu_exit(cmocka_run_group_tests(tests, NULL, NULL));
}
