/* SPDX-License-Identifier: MIT */
/*
 * Issue 23, part 2: the watchdog never looks away. Its energy check used to be off in every
 * step in which a collider came, went or moved, and whenever a force callback was set or driven
 * pins moved; the audit's reproducers returned DEFSIM_OK with |v| = 9.8e30 m/s (explicit Euler,
 * h = 1e30 right after adding a plane), 1.5e7 m/s after 691 steps of a far collider moved 1 mm
 * per step, and 1.2e298 m/s (a callback adding 1e300 N). Each path must now fail such a step with
 * DEFSIM_ERR_UNSTABLE and the state exactly as it was, and no successful step may leave a vertex
 * faster than the scene's energy and the work done on it allow. Legitimate scenes on the same
 * paths (a collider pushing a body, a callback spring, a drive, a collider added through a body)
 * run clean.
 *
 * The bound the tests check is their own arithmetic from the state, not the library's: with
 * the body starting at rest at its rest shape (energy 0), a free vertex i after a successful
 * step has m_i |v_i|^2 / 2 <= growth (W_gravity + W_applied) + floor, where W_gravity =
 * sum_j m_j g . (x_j - x_j(0)) and W_applied = sum_j F_j . (x_j - x_j(0)) for a constant applied
 * force F (both path independent), growth = 10 (core.watchdog_energy_growth) and floor = M L g
 * (M the total mass, L the rest diagonal of the scene, g = 9.81 m/s^2; docs/watchdog.md).
 */
#include "test_util.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

static const double G = 9.81, GROWTH = 10.0, PI = 3.14159265358979323846;
/* The unstable runs step at this multiple of the stable step: the energy grows slowly, over
 * tens of steps, as in the audit's run of 691 steps. */
static const double OVER = 1.1;

/* A 1 m box of 2 x 2 x 2 cells on [0, 1]^3 + (0, y0, 0): stable neo-Hookean, E = 1e5 Pa,
 * nu = 0.3, 1000 kg/m^3 (1000 kg), Rayleigh stiffness damping beta (s), in a world with gravity
 * -9.81 m/s^2 along y. */
static defsim_world *box_world_beta(const char *backend, double y0, double beta,
                                    defsim_body_id *out)
{
    defsim_world *w = tu_world(backend, -G, 1);
    defsim_material mat;
    defsim_material_init(&mat, sizeof mat, DEFSIM_MODEL_STABLE_NEOHOOKEAN);
    mat.youngs_modulus = 1e5;
    mat.poisson_ratio = 0.3;
    mat.density = 1000;
    mat.stiffness_damping = beta;
    const double lo[3] = {0, y0, 0}, hi[3] = {1, y0 + 1, 1};
    const defsim_body_id b = tu_add_box_material(w, 2, 2, 2, lo, hi, &mat);
    if (out) *out = b;
    return w;
}

static defsim_world *box_world(const char *backend, double y0, defsim_body_id *out)
{
    return box_world_beta(backend, y0, 0.0, out);
}

static double stable_step(defsim_world *w)
{
    double h = 0.0;
    TU_OK(defsim_world_stable_step(w, &h, NULL));
    assert_true(h > 0.0 && h < 1.0);
    return h;
}

/* Explicit Euler has no stable step on an undamped body: the runs use symplectic Euler's. */
static double symplectic_step(void)
{
    defsim_world *w = box_world("symplectic_euler", 0.0, NULL);
    const double h = stable_step(w);
    defsim_world_destroy(w);
    return h;
}

static double stat(const defsim_world *w, const char *name)
{
    double v = NAN;
    TU_OK(defsim_world_stat(w, name, &v));
    return v;
}

/* What a run is checked against: the start positions, the masses, which vertices are pinned,
 * and an optional constant applied force per vertex (3 n). */
typedef struct budget {
    int n;
    double *x0, *m, floor;
    const uint8_t *pinned;
    const double *force;
} budget;

static budget budget_start(const defsim_world *w, const uint8_t *pinned, const double *force)
{
    budget b = {.n = defsim_world_vertex_count(w), .pinned = pinned, .force = force};
    b.x0 = tu_positions(w);
    b.m = malloc((size_t)b.n * sizeof *b.m);
    TU_OK(defsim_world_get_masses(w, b.m, b.n));
    double mass = 0.0, lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY,
                                                                         -INFINITY};
    for (int i = 0; i < b.n; ++i) {
        mass += b.m[i];
        for (int k = 0; k < 3; ++k) {
            lo[k] = fmin(lo[k], b.x0[3 * i + k]);
            hi[k] = fmax(hi[k], b.x0[3 * i + k]);
        }
    }
    const double L = sqrt((hi[0] - lo[0]) * (hi[0] - lo[0]) + (hi[1] - lo[1]) * (hi[1] - lo[1]) +
                          (hi[2] - lo[2]) * (hi[2] - lo[2]));
    b.floor = mass * L * G;
    return b;
}

static void budget_end(budget *b)
{
    free(b->x0);
    free(b->m);
}

/* Fails the test if a free vertex of w is faster than the bound of the header allows; returns
 * the largest speed of a free vertex (m/s). */
static double check_speeds(const defsim_world *w, const budget *b)
{
    double *x = tu_positions(w), *v = tu_velocities(w);
    double work = 0.0, vmax = 0.0;
    for (int i = 0; i < b->n; ++i) {
        const double *d0 = b->x0 + 3 * i, *d1 = x + 3 * i;
        work += b->m[i] * -G * (d1[1] - d0[1]);
        if (b->force)
            for (int k = 0; k < 3; ++k) work += b->force[3 * i + k] * (d1[k] - d0[k]);
    }
    const double limit = GROWTH * fmax(work, 0.0) + b->floor;
    for (int i = 0; i < b->n; ++i) {
        if (b->pinned && b->pinned[i]) continue;
        const double *u = v + 3 * i, s2 = u[0] * u[0] + u[1] * u[1] + u[2] * u[2];
        if (!(0.5 * b->m[i] * s2 <= limit))
            fail_msg("vertex %d at %.3g m/s: 0.5 m v^2 = %.3g J over the budget %.3g J", i,
                     sqrt(s2), 0.5 * b->m[i] * s2, limit);
        vmax = fmax(vmax, sqrt(s2));
    }
    free(x);
    free(v);
    return vmax;
}

/* One step that must fail with DEFSIM_ERR_UNSTABLE (`watchdog`: the watchdog's refusal; else
 * the backend's own may come first), leaving state and time bit-identical. */
static void step_refused_by(defsim_world *w, double h, int watchdog)
{
    const int n = defsim_world_vertex_count(w);
    double *x0 = tu_positions(w), *v0 = tu_velocities(w);
    const double t0 = defsim_world_time(w), trips = stat(w, "watchdog_trips");
    const defsim_status st = defsim_world_step(w, h);
    if (st != DEFSIM_ERR_UNSTABLE || (watchdog && stat(w, "watchdog_trips") != trips + 1.0))
        fail_msg("status %d, trips %g: %s", (int)st, stat(w, "watchdog_trips") - trips,
                 defsim_world_last_error(w));
    double *x = tu_positions(w), *v = tu_velocities(w);
    assert_memory_equal(x, x0, 3 * (size_t)n * sizeof *x);
    assert_memory_equal(v, v0, 3 * (size_t)n * sizeof *v);
    assert_true(defsim_world_time(w) == t0);
    free(x0); free(v0); free(x); free(v);
}

static void step_refused(defsim_world *w, double h) { step_refused_by(w, h, 1); }

/* A hook called before each step of run_to_trip (the path under test: move a collider, drive
 * a pin, ...). */
typedef void (*before_fn)(defsim_world *w, int step, void *user);

/* Steps w by h until a step fails (at most n steps): every successful step must respect the
 * budget; the failing one must be refused by the watchdog with the state unchanged. Returns the
 * index of the refused step (n: none was). */
static int run_to_trip(defsim_world *w, double h, int n, const budget *b, before_fn before,
                       void *user)
{
    for (int s = 0; s < n; ++s) {
        if (before) before(w, s, user);
        const int nv = defsim_world_vertex_count(w);
        double *x0 = tu_positions(w), *v0 = tu_velocities(w);
        const double t0 = defsim_world_time(w);
        const defsim_status st = defsim_world_step(w, h);
        if (st == DEFSIM_OK) {
            (void)check_speeds(w, b);
            free(x0); free(v0);
            continue;
        }
        assert_int_equal(st, DEFSIM_ERR_UNSTABLE);
        double *x = tu_positions(w), *v = tu_velocities(w);
        assert_memory_equal(x, x0, 3 * (size_t)nv * sizeof *x);
        assert_memory_equal(v, v0, 3 * (size_t)nv * sizeof *v);
        assert_true(defsim_world_time(w) == t0);
        free(x0); free(v0); free(x); free(v);
        return s;
    }
    return n;
}

static defsim_collider_id add_plane(defsim_world *w, double y)
{
    defsim_collider_def d;
    defsim_collider_def_init(&d, sizeof d);
    d.position[1] = y;
    defsim_collider_id id;
    TU_OK(defsim_world_add_collider(w, &d, &id));
    return id;
}

/* ------------------------------------------------------------------------------------------ */
/* The reproducers */

/* Explicit Euler at h = 1e30 right after adding a plane under the resting box returned OK with
 * |v| = 9.8e30 m/s (the check was off in the step a collider came). Also the plane touching
 * the box (a vertex within the penalty's reach) and symplectic Euler. */
static void test_plane_added_absurd_step(void **state)
{
    (void)state;
    const char *backends[2] = {"explicit_euler", "symplectic_euler"};
    const double planes[2] = {-0.5, 0.0};
    for (int b = 0; b < 2; ++b)
        for (int p = 0; p < 2; ++p) {
            defsim_world *w = box_world(backends[b], 0.0, NULL);
            TU_OK(defsim_world_step(w, 1e-3));   /* planned, with a reference */
            (void)add_plane(w, planes[p]);
            step_refused(w, 1e30);
            /* The same world still steps at a sound step afterwards (the plane now counted). */
            const budget bg = budget_start(w, NULL, NULL);
            for (int s = 0; s < 20; ++s) TU_OK(defsim_world_step(w, 1e-3));
            (void)check_speeds(w, &bg);
            budget_end((budget *)&bg);
            defsim_world_destroy(w);
        }
}

/* A far collider moved 1 mm per step kept the check off: at 3 times the stable step the box
 * ran 691 steps up to 1.5e7 m/s before the 100x stretch check stopped it. Now it is refused at
 * exactly the step where the same run without a collider is, every step before within budget. */
typedef struct mover {
    defsim_collider_id id;
    double y, dy;
} mover;

static void move_collider(defsim_world *w, int step, void *user)
{
    (void)step;
    mover *m = user;
    m->y += m->dy;
    const double p[3] = {0.0, m->y, 0.0}, q[4] = {1, 0, 0, 0};
    TU_OK(defsim_collider_set_pose(w, m->id, p, q));
}

static void test_far_collider_moving(void **state)
{
    (void)state;
    const char *backends[2] = {"symplectic_euler", "explicit_euler"};
    for (int b = 0; b < 2; ++b) {
        defsim_world *ref = box_world(backends[b], 0.0, NULL);
        const double h = OVER * symplectic_step();
        budget bg = budget_start(ref, NULL, NULL);
        const int n_ref = run_to_trip(ref, h, 2000, &bg, NULL, NULL);
        assert_true(n_ref > 5 && n_ref < 500);
        defsim_world *w = box_world(backends[b], 0.0, NULL);
        mover m = {.id = add_plane(w, -100.0), .y = -100.0, .dy = 1e-3};
        const int n = run_to_trip(w, h, 2000, &bg, move_collider, &m);
        print_message("%s, far plane moved 1 mm per step at h = %.3g s: refused at step %d "
                      "(without the plane: %d)\n", backends[b], h, n, n_ref);
        assert_int_equal(n, n_ref);
        budget_end(&bg);
        defsim_world_destroy(ref);
        defsim_world_destroy(w);
    }
}

/* A collider removed: from under the resting box right before an absurd step, and a far
 * collider added and removed every other step of an unstable run (refused where the run without
 * colliders is). */
typedef struct toggler {
    defsim_collider_id id;
    int live;
} toggler;

static void toggle_collider(defsim_world *w, int step, void *user)
{
    (void)step;
    toggler *t = user;
    if (t->live) TU_OK(defsim_world_remove_collider(w, t->id));
    else t->id = add_plane(w, -100.0);
    t->live = !t->live;
}

static void test_collider_removed(void **state)
{
    (void)state;
    defsim_world *w = box_world("explicit_euler", 0.0, NULL);
    const defsim_collider_id id = add_plane(w, 0.0);
    for (int s = 0; s < 5; ++s) TU_OK(defsim_world_step(w, 1e-3));
    TU_OK(defsim_world_remove_collider(w, id));
    step_refused(w, 1e30);
    defsim_world_destroy(w);

    defsim_world *ref = box_world("symplectic_euler", 0.0, NULL);
    const double h = OVER * stable_step(ref);
    budget bg = budget_start(ref, NULL, NULL);
    const int n_ref = run_to_trip(ref, h, 2000, &bg, NULL, NULL);
    assert_true(n_ref > 5 && n_ref < 500);
    w = box_world("symplectic_euler", 0.0, NULL);
    toggler t = {.live = 0};
    assert_int_equal(run_to_trip(w, h, 2000, &bg, toggle_collider, &t), n_ref);
    budget_end(&bg);
    defsim_world_destroy(ref);
    defsim_world_destroy(w);
}

/* A force callback adding a finite 1e300 N to every vertex returned OK with |v| = 1.2e298 m/s:
 * refused now in the first step, whatever the backend's kind. */
static int cb_huge(void *user, const double *x, const double *v, double t, int32_t n, double *f)
{
    (void)user; (void)x; (void)v; (void)t;
    for (int i = 0; i < 3 * n; ++i) f[i] += 1e300;
    return 0;
}

static void test_callback_huge_force(void **state)
{
    (void)state;
    const char *backends[4] = {"explicit_euler", "symplectic_euler", "velocity_verlet",
                               "newton_cholmod"};
    for (int b = 0; b < 4; ++b) {
        if (!tu_available(backends[b])) continue;
        defsim_world *w = box_world(backends[b], 0.0, NULL);
        TU_OK(defsim_world_set_force_callback(w, cb_huge, NULL, NULL));
        if (b < 3) {
            /* Euler's two refused by the watchdog; velocity Verlet's own force check may come
             * first (its forces overflow), a refusal all the same. */
            step_refused_by(w, 1e-3, b < 2);
            step_refused_by(w, 1e-3, b < 2);
        } else {
            /* An implicit backend may fail to converge first; never a success. */
            const defsim_status st = defsim_world_step(w, 1e-3);
            assert_true(st == DEFSIM_ERR_UNSTABLE || st == DEFSIM_ERR_NOT_CONVERGED);
            double *v = tu_velocities(w);
            for (int i = 0; i < 3 * defsim_world_vertex_count(w); ++i) assert_true(v[i] == 0.0);
            free(v);
        }
        defsim_world_destroy(w);
    }
}

/* A callback of a moderate constant force at an unstable step: refused where the run with the
 * same force held as external forces is (the callback's work is counted like theirs), every
 * step before within the budget that counts the force's work. */
typedef struct constant_force {
    const double *f;
} constant_force;

static int cb_constant(void *user, const double *x, const double *v, double t, int32_t n,
                       double *f)
{
    (void)x; (void)v; (void)t;
    const constant_force *c = user;
    for (int i = 0; i < 3 * n; ++i) f[i] += c->f[i];
    return 0;
}

static void test_callback_unstable_run(void **state)
{
    (void)state;
    defsim_world *ref = box_world("symplectic_euler", 0.0, NULL);
    const int n = defsim_world_vertex_count(ref);
    double *f = malloc(3 * (size_t)n * sizeof *f);
    for (int i = 0; i < n; ++i) {
        f[3 * i] = 50.0;
        f[3 * i + 1] = 20.0 * (i % 3);
        f[3 * i + 2] = -30.0;
    }
    TU_OK(defsim_world_set_external_forces(ref, f, n));
    const double h = OVER * stable_step(ref);
    budget bg = budget_start(ref, NULL, f);
    const int n_ref = run_to_trip(ref, h, 2000, &bg, NULL, NULL);
    assert_true(n_ref > 5 && n_ref < 500);
    defsim_world *w = box_world("symplectic_euler", 0.0, NULL);
    constant_force c = {f};
    TU_OK(defsim_world_set_force_callback(w, cb_constant, NULL, &c));
    assert_int_equal(run_to_trip(w, h, 2000, &bg, NULL, NULL), n_ref);
    budget_end(&bg);
    free(f);
    defsim_world_destroy(ref);
    defsim_world_destroy(w);
}

/* Driven pins: the box's bottom face pinned and driven 1 mm per step along x at 3 times the
 * stable step. The check was off in every drive step (the run went on until the stretch check);
 * now it is refused within the steps the undriven run needs plus a few, every step before within
 * the budget (the drive's own work is tiny: 1 mm per step against the box's elastic forces). */
typedef struct driver {
    defsim_body_id body;
    int32_t verts[9];
    double x[27];
    int n;
    double dx;
} driver;

static void drive_pins(defsim_world *w, int step, void *user)
{
    (void)step;
    driver *d = user;
    for (int i = 0; i < d->n; ++i) d->x[3 * i] += d->dx;
    TU_OK(defsim_body_set_pin_targets(w, d->body, d->verts, d->n, d->x));
}

static driver bottom_face(defsim_world *w, defsim_body_id b, uint8_t *pinned)
{
    driver d = {.body = b, .dx = 1e-3};
    double *x = tu_positions(w);
    const int n = defsim_world_vertex_count(w);
    for (int i = 0; i < n; ++i)
        if (x[3 * i + 1] <= 1e-12) {
            d.verts[d.n] = i;
            memcpy(d.x + 3 * d.n, x + 3 * i, 3 * sizeof *x);
            pinned[i] = 1;
            d.n++;
        }
    assert_int_equal(d.n, 9);
    TU_OK(defsim_body_pin(w, b, d.verts, d.n));
    free(x);
    return d;
}

static void test_drive_unstable_run(void **state)
{
    (void)state;
    defsim_body_id rb, b;
    defsim_world *ref = box_world("symplectic_euler", 0.0, &rb);
    uint8_t pinned[27] = {0};
    (void)bottom_face(ref, rb, pinned);
    const double h = OVER * stable_step(ref);
    budget bg = budget_start(ref, pinned, NULL);
    const int n_ref = run_to_trip(ref, h, 2000, &bg, NULL, NULL);
    assert_true(n_ref > 5 && n_ref < 500);
    defsim_world *w = box_world("symplectic_euler", 0.0, &b);
    driver d = bottom_face(w, b, pinned);
    const int n = run_to_trip(w, h, 2000, &bg, drive_pins, &d);
    print_message("drive 1 mm per step at h = %.3g s: refused at step %d (undriven: %d)\n", h,
                  n, n_ref);
    assert_true(n <= n_ref + 5);
    budget_end(&bg);
    /* And an absurd step with a drive: refused. */
    defsim_world_destroy(w);
    w = box_world("explicit_euler", 0.0, &b);
    d = bottom_face(w, b, pinned);
    TU_OK(defsim_world_step(w, 1e-3));
    drive_pins(w, 0, &d);
    step_refused(w, 1e30);
    defsim_world_destroy(ref);
    defsim_world_destroy(w);
}

/* ------------------------------------------------------------------------------------------ */
/* No false trips on the same paths */

static double kinetic(const defsim_world *w)
{
    defsim_energy e;
    TU_OK(defsim_world_energy(w, &e));
    return e.kinetic;
}

/* A plane under the box rising at 0.2 m/s lifts it, and one rising at 10 m/s bats it up
 * (penalty contact, symplectic Euler at half the stable step with contact, and at 1/60 s with
 * core.auto_substep; barrier contact with newton_cholmod): no trip, the reference kept (energy_drift defined), the box lifted. At
 * 10 m/s the box's kinetic energy goes well past the floor of the bound: without the plane's
 * work in the budget the check would refuse these steps. */
static void test_moving_collider_lifts(void **state)
{
    (void)state;
    const char *backends[3] = {"symplectic_euler", "newton_cholmod", "symplectic_euler"};
    const double speeds[2] = {0.2, 10.0}, durations[2] = {0.5, 0.3};
    for (int b = 0; b < 3; ++b)
        for (int k = 0; k < 2; ++k) {
            if (!tu_available(backends[b])) continue;
            defsim_world *w = box_world(backends[b], 0.02, NULL);
            mover m = {.id = add_plane(w, 0.0), .y = 0.0, .dy = 0.0};
            /* the third: auto_substep, the plane moving in substeps of a 1/60 s step */
            if (b == 2) TU_OK(defsim_world_set_option(w, "core.auto_substep", "on"));
            const double h = b == 0 ? 0.5 * stable_step(w) : b == 1 ? 1e-2 : 1.0 / 60.0;
            const int steps = (int)ceil(durations[k] / h);
            budget bg = budget_start(w, NULL, NULL);
            double kmax = 0.0;
            m.dy = speeds[k] * h;
            for (int s = 0; s < steps; ++s) {
                move_collider(w, s, &m);
                TU_OK(defsim_world_step(w, h));
                kmax = fmax(kmax, kinetic(w));
            }
            assert_true(stat(w, "watchdog_trips") == 0.0);
            assert_false(isnan(stat(w, "energy_drift")));
            double *x = tu_positions(w), ymin = INFINITY;
            for (int i = 0; i < defsim_world_vertex_count(w); ++i)
                ymin = fmin(ymin, x[3 * i + 1]);
            /* the plane rose by 0.1 m or 3 m; the box started 0.02 m above */
            assert_true(ymin > (k == 0 ? 0.05 : 2.5));
            if (k == 1) {
                print_message("%s: plane at 10 m/s: kinetic energy up to %.3g J, floor %.3g J\n",
                              backends[b], kmax, bg.floor);
                assert_true(kmax > 2.0 * bg.floor);
            }
            free(x);
            budget_end(&bg);
            defsim_world_destroy(w);
        }
}

/* A callback spring pulling every vertex towards a point 0.3 m away (f = -k (x - p)), with
 * gravity: the box swings for 1 s, no trip, reference kept; k = 2000 N/m at half the stable
 * step, and k = 2e5 N/m at 1 ms (the explicit backends), whose swing's kinetic energy goes well
 * past the floor of the bound: without the callback's work the check would refuse it. */
typedef struct anchor {
    double k, p[3];
} anchor;

static int cb_anchor(void *user, const double *x, const double *v, double t, int32_t n,
                     double *f)
{
    (void)v; (void)t;
    const anchor *a = user;
    for (int i = 0; i < n; ++i)
        for (int k = 0; k < 3; ++k) f[3 * i + k] -= a->k * (x[3 * i + k] - a->p[k]);
    return 0;
}

static void test_callback_spring_clean(void **state)
{
    (void)state;
    const char *backends[5] = {"symplectic_euler", "velocity_verlet", "newton_cholmod",
                               "symplectic_euler", "velocity_verlet"};
    for (int b = 0; b < 5; ++b) {
        if (!tu_available(backends[b])) continue;
        defsim_world *w = box_world(backends[b], 0.0, NULL);
        anchor a = {.k = b < 3 ? 2000.0 : 2e5, .p = {0.8, 0.5, 0.5}};
        TU_OK(defsim_world_set_force_callback(w, cb_anchor, NULL, &a));
        const double h = b < 2 ? 0.5 * stable_step(w) : b == 2 ? 1e-2 : 1e-3;
        const int steps = (int)ceil(1.0 / h);
        budget bg = budget_start(w, NULL, NULL);
        double kmax = 0.0;
        for (int s = 0; s < steps; ++s) {
            TU_OK(defsim_world_step(w, h));
            kmax = fmax(kmax, kinetic(w));
        }
        assert_true(stat(w, "watchdog_trips") == 0.0);
        assert_false(isnan(stat(w, "energy_drift")));
        if (b >= 3) {
            print_message("%s: callback spring of 2e5 N/m: kinetic energy up to %.3g J, floor "
                          "%.3g J\n", backends[b], kmax, bg.floor);
            assert_true(kmax > 2.0 * bg.floor);
        }
        budget_end(&bg);
        defsim_world_destroy(w);
    }
}

/* The bottom face driven on a circle of radius 5 cm once per second: no trip, reference kept;
 * also with stiffness damping (its forces across the pins count in the drive's work); and
 * driven along x at x = 5 t^2 (to 10 m/s in 1 s), whose kinetic energy goes well past the
 * floor of the bound: without the pins' work the check would refuse it. */
static void test_drive_clean(void **state)
{
    (void)state;
    const char *backends[4] = {"symplectic_euler", "newton_cholmod", "symplectic_euler",
                               "symplectic_euler"};
    const double beta[4] = {0.0, 0.0, 5e-3, 0.0};
    for (int b = 0; b < 4; ++b) {
        if (!tu_available(backends[b])) continue;
        defsim_body_id id;
        defsim_world *w = box_world_beta(backends[b], 0.0, beta[b], &id);
        uint8_t pinned[27] = {0};
        driver d = bottom_face(w, id, pinned);
        double base[27];
        memcpy(base, d.x, sizeof base);
        const double h = b != 1 ? 0.5 * stable_step(w) : 1e-2;
        const int steps = (int)ceil(1.0 / h);
        budget bg = budget_start(w, pinned, NULL);
        double kmax = 0.0;
        for (int s = 0; s < steps; ++s) {
            const double t = (s + 1) * h;
            const double ox = b < 3 ? 0.05 * (cos(2 * PI * t) - 1.0) : 5.0 * t * t,
                         oz = b < 3 ? 0.05 * sin(2 * PI * t) : 0.0;
            for (int i = 0; i < d.n; ++i) {
                d.x[3 * i] = base[3 * i] + ox;
                d.x[3 * i + 2] = base[3 * i + 2] + oz;
            }
            TU_OK(defsim_body_set_pin_targets(w, id, d.verts, d.n, d.x));
            TU_OK(defsim_world_step(w, h));
            kmax = fmax(kmax, kinetic(w));
        }
        assert_true(stat(w, "watchdog_trips") == 0.0);
        assert_false(isnan(stat(w, "energy_drift")));
        if (b == 3) {
            print_message("drive to 10 m/s: kinetic energy up to %.3g J, floor %.3g J\n", kmax,
                          bg.floor);
            assert_true(kmax > 2.0 * bg.floor);
        }
        budget_end(&bg);
        defsim_world_destroy(w);
    }
}

/* A plane added through the resting box (its bottom layer 5 cm inside, then half the box
 * inside): the penalty pushes the box out with the energy it stored, which the watchdog counts
 * as work put in by the host; then the plane removed and the box falls: no trip in 0.5 s of
 * either. Half the box inside stores and releases well past the floor of the bound: without
 * the added plane's energy in the budget the check would refuse it. */
static void test_collider_added_inside_clean(void **state)
{
    (void)state;
    const double depth[2] = {0.05, 0.5};
    for (int k = 0; k < 2; ++k) {
        defsim_world *w = box_world("symplectic_euler", 0.0, NULL);
        TU_OK(defsim_world_step(w, 1e-4));
        budget bg = budget_start(w, NULL, NULL);
        const defsim_collider_id id = add_plane(w, depth[k]);
        const double h = 0.5 * stable_step(w);
        const int steps = (int)ceil(0.5 / h);
        double kmax = 0.0;
        for (int s = 0; s < steps; ++s) {
            TU_OK(defsim_world_step(w, h));
            kmax = fmax(kmax, kinetic(w));
        }
        double *x = tu_positions(w), ymin = INFINITY;
        for (int i = 0; i < defsim_world_vertex_count(w); ++i) ymin = fmin(ymin, x[3 * i + 1]);
        assert_true(ymin > 0.0);   /* pushed up out of its start */
        free(x);
        TU_OK(defsim_world_remove_collider(w, id));
        for (int s = 0; s < steps; ++s) TU_OK(defsim_world_step(w, h));
        assert_true(stat(w, "watchdog_trips") == 0.0);
        assert_false(isnan(stat(w, "energy_drift")));
        if (k == 1) {
            print_message("plane added through half the box: kinetic energy up to %.3g J, "
                          "floor %.3g J\n", kmax, bg.floor);
            assert_true(kmax > 2.0 * bg.floor);
        }
        budget_end(&bg);
        defsim_world_destroy(w);
    }
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_plane_added_absurd_step),
        cmocka_unit_test(test_far_collider_moving),
        cmocka_unit_test(test_collider_removed),
        cmocka_unit_test(test_callback_huge_force),
        cmocka_unit_test(test_callback_unstable_run),
        cmocka_unit_test(test_drive_unstable_run),
        cmocka_unit_test(test_moving_collider_lifts),
        cmocka_unit_test(test_callback_spring_clean),
        cmocka_unit_test(test_drive_clean),
        cmocka_unit_test(test_collider_added_inside_clean),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
