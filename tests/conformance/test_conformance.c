/* SPDX-License-Identifier: MIT */
/*
 * Conformance suite: every registered backend runs the same scenes and must satisfy the same
 * physical contracts. Run as `test_conformance <backend>` (ctest adds one test per backend in
 * the CMake global property DEFSIM_CONFORMANCE_BACKENDS).
 *
 *  - rest:        a body at rest with no load stays at rest;
 *  - momentum:    a free body under gravity gains exactly M g t of linear momentum (internal
 *                 forces cancel), with mixed tets and springs;
 *  - pins:        pinned vertices keep their positions bit for bit and zero velocity;
 *  - finite:      a violent scene (large random deformation and velocities) stays finite;
 *  - energy:      backends flagged DEFSIM_BACKEND_DISSIPATIVE never increase the total energy
 *                 (kinetic + elastic + gravitational) of a swinging cantilever; those flagged
 *                 DEFSIM_BACKEND_CONSERVATIVE keep it within CONSERVED_BAND of its start (no
 *                 drift, no numerical dissipation);
 *  - determinism: two runs with the same thread count are bit-identical;
 *  - external:    held external forces and a force callback (constant forces, gravity off):
 *                 the momentum grows as t sum F;
 *  - driven:      driven pins land exactly on their targets each step; a body whose clamp and
 *                 free part move with one constant velocity translates exactly (the backend
 *                 sees the pins move within the step); a clamp driven on a circle drags the
 *                 body along;
 *  - attachments: body-to-body attachments are internal forces (momentum M g t, as above, with
 *                 a second box stitched on);
 *                 implicit backends need about as many Newton iterations with them as without;
 *  - callback failure: a failing or NaN callback fails the step with DEFSIM_ERR_CALLBACK and
 *                 leaves the state bit-identical;
 *  - volume averaging: a body of volume-averaged tets steps: clamped it sags, finite, pins
 *                 exact, no energy gain for dissipative backends; free, momentum M g t.
 *
 *
 * Run as `test_conformance <backend> quadratic`, the boxes of every scene are quadratic tets
 * (defsim_mesh_make_quadratic; issue 29) on the same lattice of vertices, and two more cases run
 * (test_checkpoint and test_contact cover them for linear tets):
 *  - contact:     the box dropped on a plane collider comes to lie on it (no vertex below the
 *                 plane by more than 5 mm; linear tets, the same run: 2.1 mm with the explicit
 *                 backends' penalty) and is pushed up by it (its momentum gained less than half
 *                 of M g t);
 *  - checkpoint:  a world saves and loads back, and the loaded world's next steps are
 *                 bit-identical to the original's.
 *
 * The only per-backend choice is the step size: backends flagged DEFSIM_BACKEND_IMPLICIT take
 * h = 1/60 s; the others a step well inside the explicit stability limit of the scene
 * (a tenth of the time a P-wave needs to cross the shortest edge).
 */
#include "test_util.h"

#include "registry.h"
#include "world.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static const char *backend_name;
static uint32_t backend_flags;
static int quadratic;   /* the scenes' boxes are quadratic tets */

/* The scenes' material: E, nu, rho of the tets, stiffness and mass of the springs. */
#define SC_E 2e5
#define SC_NU 0.3
#define SC_RHO 1000.0
#define SC_K 2e3
#define SC_MASS 0.05
#define SC_CELL 0.25   /* edge of a box cell (m); the shortest edge of the mesh */
/* Conservative backends: the largest deviation of the total energy, relative to its scale. */
#define CONSERVED_BAND 1e-2

static double step_size(void)
{
    if (backend_flags & DEFSIM_BACKEND_IMPLICIT) return 1.0 / 60.0;
    const double lambda = SC_E * SC_NU / ((1 + SC_NU) * (1 - 2 * SC_NU));
    const double mu = SC_E / (2 * (1 + SC_NU));
    const double c = sqrt((lambda + 2 * mu) / SC_RHO);
    /* Springs: omega = sqrt(2 k / m) for a link between two free masses. */
    const double omega = sqrt(4.0 * SC_K / SC_MASS);
    double h = (quadratic ? 0.07 : 0.1) * SC_CELL / c;   /* quadratic: stiffer top mode */
    if (0.1 / omega < h) h = 0.1 / omega;
    return h;
}

/* Steps that cover the same simulated time for every backend (about 0.25 s). */
static int step_count(double h)
{
    return (int)ceil(0.25 / h);
}

static defsim_world *make_world_tol(double gy, int threads, double tolerance)
{
    defsim_world_def d;
    defsim_world_def_init(&d, sizeof d);
    d.backend = backend_name;
    d.gravity[1] = gy;
    d.num_threads = threads;
    defsim_world *w = NULL;
    if (defsim_world_create(&d, &w) != DEFSIM_OK)
        fail_msg("world_create(%s): %s", backend_name, defsim_last_error());
    tu_backend_option(w, backend_name, "tolerance", tolerance);
    /* At 1e-10 the violent scene needs up to ~80 Newton iterations per step with clamped
     * Hessians (linear convergence) when the integrator does not dissipate it. */
    tu_backend_option(w, backend_name, "max_iterations", 200);
    return w;
}

static defsim_world *make_world(double gy, int threads)
{
    return make_world_tol(gy, threads, 1e-10);
}

/* A box of nx x ny x nz cells of tets of the scenes' material: linear, or in the quadratic run
 * quadratic tets on half as many cells per axis (where nx, ny, nz are even: the same lattice of
 * vertices, so the scenes keep their sizes, vertex spacing and step), whose corner vertices
 * keep the indices of a linear box of those cells (the mid-edge ones follow). */
static defsim_body_id add_box(defsim_world *w, defsim_model model, int nx, int ny, int nz,
                              const double lo[3], const double hi[3])
{
    if (!quadratic) return tu_add_box(w, model, nx, ny, nz, lo, hi, SC_E, SC_NU, SC_RHO);
    defsim_mesh m;
    memset(&m, 0, sizeof m);
    m.size = sizeof m;
    const int even = nx % 2 == 0 && ny % 2 == 0 && nz % 2 == 0;
    TU_OK(defsim_mesh_box(lo, hi, even ? nx / 2 : nx, even ? ny / 2 : ny, even ? nz / 2 : nz, &m));
    TU_OK(defsim_mesh_make_quadratic(&m));
    defsim_body_def bd = test_mesh_body(&m, model);
    bd.material.youngs_modulus = SC_E;
    bd.material.poisson_ratio = SC_NU;
    bd.material.density = SC_RHO;
    defsim_body_id id;
    TU_OK(defsim_world_add_body(w, &bd, &id));
    defsim_mesh_free(&m);
    return id;
}

/* A 4x2x2-cell stable neo-Hookean box on [0,1]x[0,.5]x[0,.5] and, beside it, a spring ladder
 * (a strip of 2 x 4 vertices with rungs and diagonals). Returns the box's id. */
static defsim_body_id add_scene(defsim_world *w)
{
    const double lo[3] = {0, 0, 0}, hi[3] = {4 * SC_CELL, 2 * SC_CELL, 2 * SC_CELL};
    defsim_body_id box = add_box(w, DEFSIM_MODEL_STABLE_NEOHOOKEAN, 4, 2, 2, lo, hi);
    double sx[3 * 8];
    int32_t sp[2 * 10];
    tu_ladder(1.5, SC_CELL, 0.1, sx, sp);
    defsim_body_def bd;
    defsim_body_def_init(&bd, sizeof bd);
    defsim_material_init(&bd.material, sizeof bd.material, DEFSIM_MODEL_SPRING);
    bd.material.stiffness = SC_K;
    bd.material.vertex_mass = SC_MASS;
    bd.rest_positions = sx;
    bd.vertex_count = 8;
    bd.springs = sp;
    bd.spring_count = 10;
    TU_OK(defsim_world_add_body(w, &bd, NULL));
    return box;
}

static void perturb(defsim_world *w, double dx, double dv, unsigned long long seed)
{
    int n = defsim_world_vertex_count(w);
    double *x = tu_positions(w), *v = tu_velocities(w);
    for (int i = 0; i < 3 * n; ++i) {
        x[i] += dx * tu_rand(&seed);
        v[i] += dv * tu_rand(&seed);
    }
    TU_OK(defsim_world_set_state(w, x, v));
    free(x);
    free(v);
}

static void assert_all_finite(const double *a, int n)
{
    for (int i = 0; i < n; ++i)
        if (!isfinite(a[i])) fail_msg("%s: value %d is not finite", backend_name, i);
}

static void step_ok(defsim_world *w, double h)
{
    defsim_status st = defsim_world_step(w, h);
    if (st != DEFSIM_OK)
        fail_msg("%s: step failed: %s (%s)", backend_name, defsim_status_string(st),
                 defsim_world_last_error(w));
}

/* ------------------------------------------------------------------------------------------ */

static void test_rest(void **state)
{
    (void)state;
    defsim_world *w = make_world(0.0, 1);
    add_scene(w);
    const int n = defsim_world_vertex_count(w);
    double *x0 = tu_positions(w);
    const double h = step_size();
    for (int s = 0; s < step_count(h); ++s) step_ok(w, h);
    double *x = tu_positions(w), *v = tu_velocities(w);
    assert_all_finite(x, 3 * n);
    assert_all_finite(v, 3 * n);
    double dx = 0.0, vmax = 0.0;
    for (int i = 0; i < 3 * n; ++i) {
        dx = fmax(dx, fabs(x[i] - x0[i]));
        vmax = fmax(vmax, fabs(v[i]));
    }
    /* Round-off only: the stress at F = Ds Dm^-1 ~ I is a few ulps of E. */
    if (!(dx <= 1e-10 && vmax <= 1e-8))
        fail_msg("%s: a body at rest moved by %.3g m (speed %.3g m/s)", backend_name, dx, vmax);
    free(x0); free(x); free(v);
    defsim_world_destroy(w);
}

static void momentum(defsim_world *w, const double *m, double p[3])
{
    int n = defsim_world_vertex_count(w);
    double *v = tu_velocities(w);
    p[0] = p[1] = p[2] = 0.0;
    for (int i = 0; i < n; ++i)
        for (int c = 0; c < 3; ++c) p[c] += m[i] * v[3 * i + c];
    free(v);
}

/* The masses (malloc'd), their sum *M and the momentum p0 of a scene about to fall. */
static double *fall_start(defsim_world *w, double *M, double p0[3])
{
    const int n = defsim_world_vertex_count(w);
    double *m = malloc((size_t)n * sizeof *m);
    TU_OK(defsim_world_get_masses(w, m, n));
    *M = 0.0;
    for (int i = 0; i < n; ++i) *M += m[i];
    momentum(w, m, p0);
    return m;
}

/* A free scene falling under g from momentum p0 (initial speeds 0.5 m/s) has momentum
 * p0 + M g t now: internal forces cancel in every backend. */
static void check_fall(defsim_world *w, const double *m, double M, double g, const double p0[3],
                       const char *what)
{
    double p[3];
    momentum(w, m, p);
    const double t = defsim_world_time(w), scale = M * (0.5 + fabs(g) * t);
    const double want[3] = {p0[0], p0[1] + M * g * t, p0[2]};
    for (int c = 0; c < 3; ++c)
        if (!(fabs(p[c] - want[c]) <= 1e-8 * scale))
            fail_msg("%s%s: momentum[%d] = %.12g, want %.12g", backend_name, what, c, p[c],
                     want[c]);
}

static void test_momentum(void **state)
{
    (void)state;
    const double g = -9.81;
    defsim_world *w = make_world(g, 1);
    add_scene(w);
    perturb(w, 0.02, 0.5, 7);
    double p0[3], M, *m = fall_start(w, &M, p0);
    const double h = step_size();
    const int steps = step_count(h);
    for (int s = 0; s < steps; ++s) step_ok(w, h);
    const double t = defsim_world_time(w);
    assert_true(fabs(t - steps * h) <= 1e-12 * t);
    check_fall(w, m, M, g, p0, "");
    free(m);
    defsim_world_destroy(w);
}

static void test_pins(void **state)
{
    (void)state;
    defsim_world *w = make_world(-9.81, 1);
    defsim_body_id box = add_scene(w);
    const int pinned = tu_pin_below(w, box, 0, 0.0);
    assert_int_equal(pinned, 9);
    perturb(w, 0.0, 0.3, 11);   /* pinned vertices get zero velocity from set_state */
    const int n = defsim_world_vertex_count(w);
    const int off = defsim_body_vertex_offset(w, box), nb = defsim_body_vertex_count(w, box);
    double *x0 = tu_positions(w);
    const double h = step_size();
    for (int s = 0; s < step_count(h); ++s) step_ok(w, h);
    double *x = tu_positions(w), *v = tu_velocities(w);
    assert_all_finite(x, 3 * n);
    double moved = 0.0;
    int checked = 0;
    for (int i = 0; i < nb; ++i) {
        const int g = off + i;
        if (x0[3 * g] <= 1e-12) {
            for (int c = 0; c < 3; ++c) {
                assert_true(x[3 * g + c] == x0[3 * g + c]);
                assert_true(v[3 * g + c] == 0.0);
            }
            ++checked;
        } else {
            moved = fmax(moved, fabs(x[3 * g + 1] - x0[3 * g + 1]));
        }
    }
    assert_int_equal(checked, pinned);
    /* The free end did sag: the scene exercised the backend. */
    assert_true(moved > 1e-4);
    free(x0); free(x); free(v);
    defsim_world_destroy(w);
}

static void test_finite(void **state)
{
    (void)state;
    defsim_world *w = make_world(-9.81, 1);
    defsim_body_id box = add_scene(w);
    tu_pin_below(w, box, 0, 0.0);
    perturb(w, 0.05, 3.0, 13);
    const int n = defsim_world_vertex_count(w);
    const double h = step_size();
    for (int s = 0; s < step_count(h); ++s) {
        step_ok(w, h);
        double *x = tu_positions(w), *v = tu_velocities(w);
        assert_all_finite(x, 3 * n);
        assert_all_finite(v, 3 * n);
        free(x); free(v);
        defsim_energy e;
        TU_OK(defsim_world_energy(w, &e));
        assert_true(isfinite(e.total));
    }
    defsim_world_destroy(w);
}

static void test_energy(void **state)
{
    (void)state;
    const int conservative = (backend_flags & DEFSIM_BACKEND_CONSERVATIVE) != 0;
    if (!(backend_flags & DEFSIM_BACKEND_DISSIPATIVE) && !conservative) {
        printf("%s is flagged neither dissipative nor conservative: energy check skipped\n",
               backend_name);
        skip();
    }
    defsim_world *w = make_world(-9.81, 1);
    defsim_body_id box = add_scene(w);
    tu_pin_below(w, box, 0, 0.0);
    perturb(w, 0.01, 0.5, 17);
    defsim_energy e0, e;
    TU_OK(defsim_world_energy(w, &e0));
    const double scale = e0.kinetic + e0.elastic + fabs(e0.gravitational);
    double prev = e0.total, band = 0.0;
    const double h = step_size();
    for (int s = 0; s < step_count(h); ++s) {
        step_ok(w, h);
        TU_OK(defsim_world_energy(w, &e));
        band = fmax(band, fabs(e.total - e0.total) / scale);
        if (conservative) continue;
        if (!(e.total <= prev + 1e-9 * scale))
            fail_msg("%s: step %d raised the total energy from %.12g J to %.12g J", backend_name,
                     s, prev, e.total);
        prev = e.total;
    }
    printf("%s: largest energy deviation %.3g of the energy scale\n", backend_name, band);
    if (conservative) {
        if (!(band <= CONSERVED_BAND))
            fail_msg("%s: the energy left a band of %g of its scale (%.3g)", backend_name,
                     CONSERVED_BAND, band);
    } else {
        /* It did dissipate (the swinging strip loses energy to the integrator or damping). */
        assert_true(e.total < e0.total);
    }
    defsim_world_destroy(w);
}

static double *determinism_run(void)
{
    defsim_world *w = make_world(-9.81, 2);
    defsim_body_id box = add_scene(w);
    tu_pin_below(w, box, 0, 0.0);
    perturb(w, 0.02, 1.0, 19);
    const double h = step_size();
    for (int s = 0; s < step_count(h); ++s) step_ok(w, h);
    const int n = defsim_world_vertex_count(w);
    double *out = malloc(6 * (size_t)n * sizeof *out);
    TU_OK(defsim_world_get_positions(w, out, n));
    TU_OK(defsim_world_get_velocities(w, out + 3 * n, n));
    defsim_world_destroy(w);
    return out;
}

static void test_determinism(void **state)
{
    (void)state;
    double *a = determinism_run(), *b = determinism_run();
    defsim_world *w = make_world(0.0, 1);
    add_scene(w);
    const int n = defsim_world_vertex_count(w);
    defsim_world_destroy(w);
    assert_memory_equal(a, b, 6 * (size_t)n * sizeof *a);
    free(a);
    free(b);
}

/* ------------------------------------------------------------------------------------------ */
/* The host's coupling terms */

/* Their checks are exact whatever the nonlinear tolerance (momentum) or need no tight one; a
 * clamped Newton converges only linearly on compressed springs, so 1e-10 costs many iterations. */
#define COUPLING_TOL 1e-8

static int cb_add(void *user, const double *x, const double *v, double t, int32_t n, double *f)
{
    (void)x; (void)v; (void)t;
    const double *F = user;
    for (int i = 0; i < 3 * n; ++i) f[i] += F[i];
    return 0;
}

static void test_external(void **state)
{
    (void)state;
    for (int use_callback = 0; use_callback < 2; ++use_callback) {
        defsim_world *w = make_world_tol(0.0, 1, COUPLING_TOL);
        add_scene(w);
        perturb(w, 0.02, 0.0, 23);
        const int n = defsim_world_vertex_count(w);
        double *m = malloc((size_t)n * sizeof *m), *F = malloc(3 * (size_t)n * sizeof *F);
        double p0[3], p[3], sum[3] = {0, 0, 0};
        unsigned long long seed = 29;
        TU_OK(defsim_world_get_masses(w, m, n));
        for (int i = 0; i < 3 * n; ++i) {
            F[i] = 2.0 * tu_rand(&seed);
            sum[i % 3] += F[i];
        }
        if (use_callback) TU_OK(defsim_world_set_force_callback(w, cb_add, NULL, F));
        else TU_OK(defsim_world_set_external_forces(w, F, n));
        momentum(w, m, p0);
        const double h = step_size();
        const int steps = step_count(h);
        for (int s = 0; s < steps; ++s) step_ok(w, h);
        momentum(w, m, p);
        const double t = defsim_world_time(w);
        double scale = 0.0;
        for (int c = 0; c < 3; ++c) scale = fmax(scale, fabs(sum[c]) * t);
        for (int c = 0; c < 3; ++c)
            if (!(fabs(p[c] - p0[c] - t * sum[c]) <= 1e-8 * scale))
                fail_msg("%s (%s): momentum[%d] grew by %.12g, want %.12g", backend_name,
                         use_callback ? "callback" : "external forces", c, p[c] - p0[c],
                         t * sum[c]);
        free(m); free(F);
        defsim_world_destroy(w);
    }
}

/* The box's clamp (x = 0) in world vertex ids; returns the count. */
static int clamp_vertices(defsim_world *w, defsim_body_id box, int32_t *local)
{
    const int nb = defsim_body_vertex_count(w, box), off = defsim_body_vertex_offset(w, box);
    double *x = tu_positions(w);
    int k = 0;
    for (int i = 0; i < nb; ++i)
        if (x[3 * (off + i)] <= 1e-12) local[k++] = i;
    free(x);
    return k;
}

static void test_driven(void **state)
{
    (void)state;
    /* A moving frame: clamp driven with velocity u, everything else starting with u, no
     * gravity. The exact motion is a rigid translation x0 + u t. */
    const double u[3] = {0.3, -0.2, 0.1};
    defsim_world *w = make_world_tol(0.0, 1, COUPLING_TOL);
    defsim_body_id box = add_scene(w);
    int32_t cl[64];
    const int nc = clamp_vertices(w, box, cl);
    const int n = defsim_world_vertex_count(w), off = defsim_body_vertex_offset(w, box);
    double *x0 = tu_positions(w), *v = tu_velocities(w), *tgt = malloc(3 * (size_t)nc * sizeof *tgt);
    for (int i = 0; i < n; ++i)
        for (int c = 0; c < 3; ++c) v[3 * i + c] = u[c];
    TU_OK(defsim_world_set_state(w, NULL, v));
    const double h = step_size();
    const int steps = step_count(h);
    double err = 0.0;
    for (int s = 1; s <= steps; ++s) {
        for (int j = 0; j < nc; ++j)
            for (int c = 0; c < 3; ++c) tgt[3 * j + c] = x0[3 * (off + cl[j]) + c] + u[c] * s * h;
        TU_OK(defsim_body_set_pin_targets(w, box, cl, nc, tgt));
        step_ok(w, h);
        double *x = tu_positions(w);
        for (int j = 0; j < nc; ++j)
            for (int c = 0; c < 3; ++c)
                if (x[3 * (off + cl[j]) + c] != tgt[3 * j + c])
                    fail_msg("%s: driven vertex %d missed its target at step %d by %.3g m",
                             backend_name, cl[j], s, x[3 * (off + cl[j]) + c] - tgt[3 * j + c]);
        for (int i = 0; i < n; ++i)
            for (int c = 0; c < 3; ++c)
                err = fmax(err, fabs(x[3 * i + c] - (x0[3 * i + c] + u[c] * s * h)));
        free(x);
    }
    const double disp = 0.3 * steps * h;
    if (!(err <= 1e-8 * disp))
        fail_msg("%s: a translating frame deviated from x0 + u t by %.3g m (of %.3g m)",
                 backend_name, err, disp);
    defsim_world_destroy(w);

    /* A clamp driven on a quarter circle of radius R in the y-z plane (period 4 s, well below
     * the beam's first bending mode): the body's centre follows the clamp. */
    w = make_world_tol(0.0, 1, COUPLING_TOL);
    box = add_scene(w);
    const double R = 0.1, om = 2.0 * 3.14159265358979323846 / 4.0;
    const int nb = defsim_body_vertex_count(w, box);
    const int qsteps = (int)ceil(1.0 / h);
    double *xs = NULL;
    for (int s = 1; s <= qsteps; ++s) {
        const double t = s * h;
        for (int j = 0; j < nc; ++j) {
            const double *p = x0 + 3 * (off + cl[j]);
            tgt[3 * j] = p[0];
            tgt[3 * j + 1] = p[1] + R * (1.0 - cos(om * t));
            tgt[3 * j + 2] = p[2] + R * sin(om * t);
        }
        TU_OK(defsim_body_set_pin_targets(w, box, cl, nc, tgt));
        step_ok(w, h);
    }
    xs = tu_positions(w);
    assert_all_finite(xs, 3 * n);
    const double t = qsteps * h, want[2] = {R * (1.0 - cos(om * t)), R * sin(om * t)};
    double c[2] = {0, 0};
    for (int i = 0; i < nb; ++i)
        for (int k = 0; k < 2; ++k) c[k] += (xs[3 * (off + i) + 1 + k] - x0[3 * (off + i) + 1 + k]) / nb;
    const double dist = hypot(c[0] - want[0], c[1] - want[1]), arc = hypot(want[0], want[1]);
    if (!(dist <= 0.25 * arc))
        fail_msg("%s: the body's centre is %.3g m from the clamp's displacement (%.3g m)",
                 backend_name, dist, arc);
    free(xs); free(x0); free(v); free(tgt);
    defsim_world_destroy(w);
}

/* The vertex of body b at rest position (x, y, z). */
static int32_t vertex_at(defsim_world *w, defsim_body_id b, double x, double y, double z)
{
    const int off = defsim_body_vertex_offset(w, b), nb = defsim_body_vertex_count(w, b);
    double *p = tu_positions(w);
    int32_t found = -1;
    for (int i = 0; i < nb && found < 0; ++i) {
        const double *q = p + 3 * (off + i);
        if (fabs(q[0] - x) + fabs(q[1] - y) + fabs(q[2] - z) < 1e-12) found = i;
    }
    free(p);
    if (found < 0) fail_msg("no vertex at (%g, %g, %g)", x, y, z);
    return found;
}

/* A second box, one cell on [1, 1.5] x [0, .5] x [0, .5], stitched to the scene's box at their
 * common face (stitch = 1): each vertex of its face to a point of the box near its twin (a vertex, an edge,
 * a triangle, a tet's four vertices), with dampers. */
static void attach_scene(defsim_world *w, defsim_body_id box, int stitch)
{
    const double lo[3] = {4 * SC_CELL, 0, 0}, hi[3] = {6 * SC_CELL, 2 * SC_CELL, 2 * SC_CELL};
    defsim_body_id b = add_box(w, DEFSIM_MODEL_COROTATED, 1, 1, 1, lo, hi);
    if (!stitch) return;
#define BOX_V(j, k) vertex_at(w, box, 4 * SC_CELL, (j) * SC_CELL, (k) * SC_CELL)
    for (int k = 0; k < 2; ++k)
        for (int j = 0; j < 2; ++j) {
            defsim_attachment_def d;
            defsim_attachment_def_init(&d, sizeof d);
            d.body = b;
            d.vertex = 2 * (j + 2 * k);
            d.stiffness = 2e3;
            d.damping = 2.0;
            d.target_body = box;
            d.target_vertex_count = 1 + j + 2 * k;
            const int32_t near[4] = {BOX_V(2 * j, 2 * k), BOX_V(1, 2 * k), BOX_V(2 * j, 1),
                                     BOX_V(1, 1)};
            for (int q = 0; q < d.target_vertex_count; ++q) {
                d.target_vertices[q] = near[q];
                d.target_weights[q] = q == 0 ? 1.0 - 0.05 * (d.target_vertex_count - 1) : 0.05;
            }
            TU_OK(defsim_world_add_attachment(w, &d, NULL));
        }
#undef BOX_V
}

static void test_attachments(void **state)
{
    (void)state;
    const double g = -9.81;
    int64_t iters[2] = {0, 0};
    for (int with = 0; with < 2; ++with) {
        defsim_world *w = make_world_tol(g, 1, COUPLING_TOL);
        defsim_body_id box = add_scene(w);
        attach_scene(w, box, with);
        perturb(w, 0.02, 0.5, 31);
        double p0[3], M, *m = fall_start(w, &M, p0);
        const double h = step_size();
        for (int s = 0; s < step_count(h); ++s) step_ok(w, h);
        check_fall(w, m, M, g, p0, with ? " (attachments)" : "");
        defsim_stats st = {.size = sizeof st};
        TU_OK(defsim_world_stats(w, &st));
        if (with) assert_true(st.passes & DEFSIM_PASS_ATTACHMENTS);
        iters[with] = tu_bstat(w, "newton_iterations");
        free(m);
        defsim_world_destroy(w);
    }
    if (!(iters[1] <= 1.5 * (double)iters[0] + 2))
        fail_msg("%s: %lld nonlinear iterations with attachments, %lld without", backend_name,
                 (long long)iters[1], (long long)iters[0]);
}

typedef struct failing {
    int calls, fail_at, nan_at;
} failing;

static int cb_failing(void *user, const double *x, const double *v, double t, int32_t n,
                      double *f)
{
    (void)x; (void)v; (void)t;
    failing *d = user;
    d->calls++;
    if (d->calls == d->fail_at) return -1;
    if (d->calls == d->nan_at) f[n / 2] = NAN;
    return 0;
}

static void test_callback_failure(void **state)
{
    (void)state;
    for (int mode = 0; mode < 2; ++mode) {
        defsim_world *w = make_world_tol(-9.81, 1, COUPLING_TOL);
        defsim_body_id box = add_scene(w);
        tu_pin_below(w, box, 0, 0.0);
        failing d = {0, mode == 0 ? 4 : 0, mode == 1 ? 4 : 0};
        TU_OK(defsim_world_set_force_callback(w, cb_failing, NULL, &d));
        const int n = defsim_world_vertex_count(w);
        const double h = step_size();
        defsim_status st = DEFSIM_OK;
        for (int s = 0; s < 8 && st == DEFSIM_OK; ++s) {
            double *x = tu_positions(w), *v = tu_velocities(w), t = defsim_world_time(w);
            st = defsim_world_step(w, h);
            if (st != DEFSIM_OK) {
                double *x2 = tu_positions(w), *v2 = tu_velocities(w);
                assert_memory_equal(x, x2, 3 * (size_t)n * sizeof *x);
                assert_memory_equal(v, v2, 3 * (size_t)n * sizeof *v);
                assert_true(defsim_world_time(w) == t);
                free(x2); free(v2);
            }
            free(x); free(v);
        }
        if (st != DEFSIM_ERR_CALLBACK)
            fail_msg("%s: a %s callback gave status %s", backend_name,
                     mode ? "NaN" : "failing", defsim_status_string(st));
        step_ok(w, h);   /* usable afterwards */
        defsim_world_destroy(w);
    }
}

/* A volume-averaged stable neo-Hookean box (defsim_body_def.volume_averaging; the scenes' box
 * otherwise): clamped, it sags and stays finite with its pins exact, and dissipative backends
 * do not raise its energy; free, its momentum grows as M g t (its internal forces cancel). The
 * step is the scenes' (the averaged element is no stiffer than the standard one). */
static defsim_body_id add_averaged(defsim_world *w)
{
    const double lo[3] = {0, 0, 0}, hi[3] = {4 * SC_CELL, 2 * SC_CELL, 2 * SC_CELL};
    defsim_mesh m;
    memset(&m, 0, sizeof m);
    m.size = sizeof m;
    TU_OK(defsim_mesh_box(lo, hi, 4, 2, 2, &m));
    defsim_body_def bd = test_mesh_body(&m, DEFSIM_MODEL_STABLE_NEOHOOKEAN);
    bd.material.youngs_modulus = SC_E;
    bd.material.poisson_ratio = SC_NU;
    bd.material.density = SC_RHO;
    bd.volume_averaging = 1;
    defsim_body_id id;
    if (defsim_world_add_body(w, &bd, &id) != DEFSIM_OK)
        fail_msg("add_body: %s", defsim_world_last_error(w));
    defsim_mesh_free(&m);
    return id;
}

static void test_volume_averaging(void **state)
{
    (void)state;
    const int dissipative = (backend_flags & DEFSIM_BACKEND_DISSIPATIVE) != 0;
    defsim_world *w = make_world(-9.81, 1);
    const defsim_body_id box = add_averaged(w);
    tu_pin_below(w, box, 0, 0.0);
    perturb(w, 0.0, 0.3, 23);
    const int n = defsim_world_vertex_count(w);
    double *x0 = tu_positions(w);
    defsim_energy e0, e;
    TU_OK(defsim_world_energy(w, &e0));
    const double scale = e0.kinetic + e0.elastic + fabs(e0.gravitational);
    double prev = e0.total;
    const double h = step_size();
    for (int s = 0; s < step_count(h); ++s) {
        step_ok(w, h);
        TU_OK(defsim_world_energy(w, &e));
        if (dissipative && !(e.total <= prev + 1e-9 * scale))
            fail_msg("%s: step %d raised the averaged box's energy from %.12g J to %.12g J",
                     backend_name, s, prev, e.total);
        prev = e.total;
    }
    double *x = tu_positions(w), *v = tu_velocities(w), moved = 0.0;
    assert_all_finite(x, 3 * n);
    assert_all_finite(v, 3 * n);
    for (int i = 0; i < n; ++i) {
        if (x0[3 * i] <= 1e-12) {
            for (int c = 0; c < 3; ++c) assert_true(x[3 * i + c] == x0[3 * i + c]);
        } else {
            moved = fmax(moved, fabs(x[3 * i + 1] - x0[3 * i + 1]));
        }
    }
    printf("%s: averaged box sagged %.4g m, energy %.6g J -> %.6g J\n", backend_name, moved,
           e0.total, e.total);
    assert_true(moved > 1e-4);
    free(x0); free(x); free(v);
    defsim_world_destroy(w);

    w = make_world(-9.81, 1);
    add_averaged(w);
    perturb(w, 0.02, 0.5, 29);
    double p0[3], M, *m = fall_start(w, &M, p0);
    for (int s = 0; s < step_count(h); ++s) step_ok(w, h);
    check_fall(w, m, M, -9.81, p0, " (averaged box)");
    free(m);
    defsim_world_destroy(w);
}

/* The box dropped from 2 cm onto the plane y = 0 (a plane collider): after 0.25 s no vertex is
 * below the plane by more than 5 mm (1 % of the box's height: the explicit backends' penalty
 * lets the 250 kg box sink about 2 mm, the barrier of the implicit ones none) and the plane
 * has pushed it up. */
static void test_contact(void **state)
{
    (void)state;
    const double g = -9.81;
    defsim_world *w = make_world(g, 1);
    const double lo[3] = {0, 0.02, 0}, hi[3] = {4 * SC_CELL, 0.02 + 2 * SC_CELL, 2 * SC_CELL};
    add_box(w, DEFSIM_MODEL_STABLE_NEOHOOKEAN, 4, 2, 2, lo, hi);
    defsim_collider_def cd;
    defsim_collider_def_init(&cd, sizeof cd);
    TU_OK(defsim_world_add_collider(w, &cd, NULL));
    double p0[3], M, *m = fall_start(w, &M, p0);
    const double h = step_size();
    for (int s = 0; s < step_count(h); ++s) step_ok(w, h);
    const int n = defsim_world_vertex_count(w);
    double *x = tu_positions(w), lowest = INFINITY, p[3];
    for (int i = 0; i < n; ++i) lowest = fmin(lowest, x[3 * i + 1]);
    momentum(w, m, p);
    const double t = defsim_world_time(w);
    printf("%s: lowest vertex at %.3g m after %.3g s; momentum %.4g of M g t %.4g kg m/s\n",
           backend_name, lowest, t, p[1], M * g * t);
    assert_true(lowest > -5e-3);
    assert_true(p[1] > 0.5 * M * g * t);
    free(x);
    free(m);
    defsim_world_destroy(w);
}

/* Save a world with the scene mid-run, load it, and step both: bit-identical. */
static void test_checkpoint(void **state)
{
    (void)state;
    defsim_world *w = make_world(-9.81, 1);
    defsim_body_id box = add_scene(w);
    tu_pin_below(w, box, 0, 0.0);
    perturb(w, 0.01, 0.3, 41);
    const double h = step_size();
    for (int s = 0; s < 5; ++s) step_ok(w, h);
    void *buf = NULL;
    size_t size = 0;
    TU_OK(defsim_world_save_buffer(w, &buf, &size));
    defsim_world *w2 = NULL;
    if (defsim_world_load_buffer(buf, size, NULL, NULL, &w2) != DEFSIM_OK)
        fail_msg("%s: load: %s", backend_name, defsim_last_error());
    defsim_buffer_free(buf);
    for (int s = 0; s < 5; ++s) {
        step_ok(w, h);
        step_ok(w2, h);
    }
    const int n = defsim_world_vertex_count(w);
    double *x = tu_positions(w), *x2 = tu_positions(w2);
    assert_int_equal(defsim_world_vertex_count(w2), n);
    assert_memory_equal(x, x2, 3 * (size_t)n * sizeof *x);
    free(x);
    free(x2);
    defsim_world_destroy(w);
    defsim_world_destroy(w2);
}

int main(int argc, char **argv)
{
    if (argc < 2 || argc > 3 || (argc == 3 && strcmp(argv[2], "quadratic") != 0)) {
        fprintf(stderr, "usage: test_conformance <backend> [quadratic]\n");
        return 2;
    }
    backend_name = argv[1];
    quadratic = argc == 3;
    const defsim_backend *b = NULL;
    if (defsim__find_backend(backend_name, &b) != DEFSIM_OK) {
        fprintf(stderr, "backend %s: %s\n", backend_name, defsim_last_error());
        return 1;
    }
    backend_flags = b->flags;
    printf("conformance of %s (flags 0x%x)%s, h = %.6g s\n", backend_name, (unsigned)b->flags,
           quadratic ? " on quadratic tets" : "", step_size());
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_rest),
        cmocka_unit_test(test_momentum),
        cmocka_unit_test(test_pins),
        cmocka_unit_test(test_finite),
        cmocka_unit_test(test_energy),
        cmocka_unit_test(test_determinism),
        cmocka_unit_test(test_external),
        cmocka_unit_test(test_driven),
        cmocka_unit_test(test_attachments),
        cmocka_unit_test(test_callback_failure),
    };
    /* linear tets only: the averaged element is refused for quadratic ones */
    const struct CMUnitTest linear_tests[] = {
        cmocka_unit_test(test_volume_averaging),
    };
    const struct CMUnitTest quad_tests[] = {
        cmocka_unit_test(test_contact),
        cmocka_unit_test(test_checkpoint),
    };
    int failed = cmocka_run_group_tests_name(backend_name, tests, NULL, NULL);
    if (quadratic) failed += cmocka_run_group_tests_name("quadratic", quad_tests, NULL, NULL);
    else failed += cmocka_run_group_tests_name("linear", linear_tests, NULL, NULL);
    return failed;
}
