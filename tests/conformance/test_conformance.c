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
 *  - determinism: two runs with the same thread count are bit-identical.
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
    double h = 0.1 * SC_CELL / c;
    if (0.1 / omega < h) h = 0.1 / omega;
    return h;
}

/* Steps that cover the same simulated time for every backend (about 0.25 s). */
static int step_count(double h)
{
    return (int)ceil(0.25 / h);
}

static defsim_world *make_world(double gy, int threads)
{
    defsim_world_def d;
    defsim_world_def_init(&d, sizeof d);
    d.backend = backend_name;
    d.gravity[1] = gy;
    d.num_threads = threads;
    d.tolerance = 1e-10;
    /* At this tolerance the violent scene needs up to ~80 Newton iterations per step with
     * clamped Hessians (linear convergence) when the integrator does not dissipate it. */
    d.max_iterations = 200;
    defsim_world *w = NULL;
    if (defsim_world_create(&d, &w) != DEFSIM_OK)
        fail_msg("world_create(%s): %s", backend_name, defsim_last_error());
    return w;
}

/* A 4x2x2-cell stable neo-Hookean box on [0,1]x[0,.5]x[0,.5] and, beside it, a spring ladder
 * (a strip of 2 x 4 vertices with rungs and diagonals). Returns the box's id. */
static defsim_body_id add_scene(defsim_world *w)
{
    const double lo[3] = {0, 0, 0}, hi[3] = {4 * SC_CELL, 2 * SC_CELL, 2 * SC_CELL};
    defsim_body_id box = tu_add_box(w, DEFSIM_MODEL_STABLE_NEOHOOKEAN, 4, 2, 2, lo, hi, SC_E,
                                    SC_NU, SC_RHO);
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

static void test_momentum(void **state)
{
    (void)state;
    const double g = -9.81;
    defsim_world *w = make_world(g, 1);
    add_scene(w);
    perturb(w, 0.02, 0.5, 7);
    const int n = defsim_world_vertex_count(w);
    double *m = malloc((size_t)n * sizeof *m), p0[3], p[3], M = 0.0;
    TU_OK(defsim_world_get_masses(w, m, n));
    for (int i = 0; i < n; ++i) M += m[i];
    momentum(w, m, p0);
    const double h = step_size();
    const int steps = step_count(h);
    for (int s = 0; s < steps; ++s) step_ok(w, h);
    momentum(w, m, p);
    const double t = defsim_world_time(w);
    assert_true(fabs(t - steps * h) <= 1e-12 * t);
    const double want[3] = {p0[0], p0[1] + M * g * t, p0[2]};
    /* Scale: the momentum of the initial velocities (0.5 m/s) and of the fall. */
    const double scale = M * (0.5 + fabs(g) * t);
    for (int c = 0; c < 3; ++c)
        if (!(fabs(p[c] - want[c]) <= 1e-8 * scale))
            fail_msg("%s: momentum[%d] = %.12g, want %.12g", backend_name, c, p[c], want[c]);
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

int main(int argc, char **argv)
{
    if (argc != 2) {
        fprintf(stderr, "usage: test_conformance <backend>\n");
        return 2;
    }
    backend_name = argv[1];
    const defsim_backend *b = NULL;
    if (defsim__find_backend(backend_name, &b) != DEFSIM_OK) {
        fprintf(stderr, "backend %s: %s\n", backend_name, defsim_last_error());
        return 1;
    }
    backend_flags = b->flags;
    printf("conformance of %s (flags 0x%x), h = %.6g s\n", backend_name, (unsigned)b->flags,
           step_size());
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_rest),
        cmocka_unit_test(test_momentum),
        cmocka_unit_test(test_pins),
        cmocka_unit_test(test_finite),
        cmocka_unit_test(test_energy),
        cmocka_unit_test(test_determinism),
    };
    return cmocka_run_group_tests_name(backend_name, tests, NULL, NULL);
}
