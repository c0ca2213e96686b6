/* SPDX-License-Identifier: MIT */
/*
 * Quadratic tets against the continuum (issue 29), by static equilibria. A static solve is
 * two newton_cholmod steps of a long h from rest, each from zero velocity: a step's
 * incremental potential is, up to a constant, the static potential E(x) - f_ext . x plus the
 * mass term 1/(2 h^2) |x - x_n|_M^2, so it lands at x* + O((omega_1 h)^-2) (x_n - x*) with
 * omega_1 the lowest eigenfrequency; two steps take that factor (1e-5 here) to its square.
 * Newton stops at 1e-10 (cantilever) and 1e-8 (Cook's membrane, whose strains of 1e-4 leave
 * the co-rotated energy fewer digits) of the body's size. (A longer h would do it in one step, but the
 * constant h^2 |f_ext|^2_M^-1 / 2 in the potential then drowns the elastic energy in rounding
 * and the line search stalls.)
 *
 *  - The shipped cantilever (3 m x 1 m x 1 m, 12 x 4 x 4 cells, clamped at x = 0, stable
 *    neo-Hookean, E = 1e8 Pa, nu = 0.3, 1000 kg/m^3, its own weight under g = 9.81 m/s^2; the
 *    linear range: the sag is 0.4 % of the length): the top far corner's deflection against the
 *    converged 3D solution REF_CANTILEVER. Quadratic tets within 2 % of it at 12 x 4 x 4 cells,
 *    linear tets about 20 % short.
 *  - The same cantilever at nu = 0.499 against its converged solution REF_CANTILEVER_NU499:
 *    the linear tets lock (84 % short); the quadratic tets are 4.1 % short at 12 x 4 x 4 cells
 *    (issue 29 asks 3 %: not met on this mesh by this element), 2.3 % at 18 x 6 x 6 (within
 *    3 %); the mean-dilatation quadratic tets (volume_averaging, test_quadratic_mixed) are
 *    -0.04 % at 12 x 4 x 4.
 *  - Cook's membrane, 3D thin-plate variant: the tapered panel (0,0), (48,44), (48,60), (0,44)
 *    (Cook 1974) with thickness 1 and traction-free faces, clamped at x = 0 (every vertex
 *    there pinned), a uniform vertical shear traction of total force F on the face x = 48,
 *    E = 1, nu = 1/3, co-rotated; F = 1e-3 keeps the model in its linear range. The reference
 *    REF_COOK = 23.96 is the literature's plane-stress value (Cook, Malkus and Plesha 1989;
 *    Belytschko et al. 2014; Krysl's FinEtools tracks 23.97) of the vertical displacement per
 *    unit force at the MIDDLE of the loaded edge, (48, 52): an independent 2D plane-stress P2
 *    solve (tests/tools/cook_plane_stress.py, numpy only) gives 23.857, 23.926, 23.944 there at
 *    8, 16, 24 elements per side, and 24.815, 25.024, 25.084 at the top right corner (48, 60),
 *    which converges to about 25.17 instead (the number an earlier version of this test took
 *    for a disagreement with the literature). This 3D problem converges to REF_COOK_3D =
 *    23.946 at (48, 52) (mean of its two faces; --long, 16, 24, 32 per side), 0.06 % from
 *    REF_COOK. The mesh: 8 x 8 cells of one hexahedron through the thickness, each split into
 *    6 tets (Kuhn) whose diagonals are the shorter diagonal of each tapered cell (cook()).
 *    Quadratic tets at 8 x 8 elements per side are 0.64 % below REF_COOK and 0.59 % below
 *    REF_COOK_3D: within the 1 % of both (with the longer diagonals they were 1.01 %
 *    below REF_COOK, outside it); 16 x 16 is within 0.5 % of both; linear tets at 8 x 8 are 10 %
 *    below (32 % on the longer diagonals).
 *  - Large deformation: the same cantilever with E = 1e6 Pa (100 times softer) sags 1.186 m, 39 %
 *    of its length, and its far end turns by about 0.6 rad and moves 0.24 m inwards (stable
 *    neo-Hookean, the static solve of three steps). The centre of the far end's sag and
 *    shortening against the quadratic refinements' extrapolation (REF_LARGE_*): quadratic tets at
 *    12 x 4 x 4 are -0.45 % / -0.75 %, linear tets on the same 2,025 vertices (24 x 8 x 8) -5.4 %
 *    / -11.0 %, linear 12 x 4 x 4 -16.7 %.
 *
 * The converged reference of the cantilever comes from quadratic meshes refined independently
 * of the tested one (n = 6, 8, 10: 18 x 6 x 6, 24 x 8 x 8, 30 x 10 x 10 cells) and Richardson
 * extrapolation u(n) = u* + C n^-p with p fitted to the three: `test_tet10_accuracy --long`
 * (ctest long_tet10_refinement, label long) computes it and fails unless it lands within
 * 0.05 % of REF_CANTILEVER, the value the default test uses; the same at nu = 0.499 against
 * REF_CANTILEVER_NU499 (and within 0.1 % of test_volume_averaging's independent reference from
 * the volume-averaged linear tets), and for the large deflection against REF_LARGE_*; it does
 * the same for Cook's membrane (n = 16, 24, 32 per side) against REF_COOK_3D, and checks that
 * within 0.1 % of the literature's REF_COOK. `test_tet10_accuracy --one N NU QUADRATIC` solves and prints one
 * cantilever (3N x N x N cells, Poisson ratio NU, quadratic tets if QUADRATIC is 1).
 */
#include "test_util.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

static int long_mode;

static double now_s(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

/* From the --long run (its printout): the cantilever's converged top far corner deflection (m;
 * 12.91581, 12.92728, 12.93361 mm at n = 6, 8, 10, order 1.33, extrapolated 12.952 mm) and
 * Cook's membrane's mid-edge displacement per unit force (23.85395, 23.89101, 23.90781 at 16,
 * 24, 32 per side, order 1.27, extrapolated 23.9457, on the longer diagonals; 23.87996,
 * 23.90574, 23.91765, order 1.22, extrapolated 23.94589 on the shorter ones cook() uses now). */
static const double REF_CANTILEVER = 1.2952e-2;
/* The same cantilever at nu = 0.499, from the --long run: 12.18958, 12.28700, 12.33870 mm at
 * n = 6, 8, 10, order 1.47, extrapolated 12.4714 mm; test_volume_averaging's reference from the
 * volume-averaged linear tets on 24, 36, 48 cells (REF_NU499 there) is 12.4706 mm, 0.01 % off. */
static const double REF_CANTILEVER_NU499 = 1.2471e-2;
static const double REF_NU499_AVERAGED = 1.24706e-2;
/* The large deflection (cantilever_large), from the --long run: sag 1.18292, 1.183897,
 * 1.184427 m (order 1.39, extrapolated 1.185885 m) and shortening 0.2386741, 0.2390004,
 * 0.2391797 m (order 1.34, 0.239694 m) at n = 6, 8, 10 (30 x 10 x 10: 26,901 vertices, 14 min
 * on a busy machine). */
static const double REF_LARGE_SAG = 1.18589;
static const double REF_LARGE_SHORTENING = 0.23969;
static const double REF_COOK = 23.96;
static const double REF_COOK_3D = 23.946;

typedef struct beam_result {
    double deflection;   /* m, downwards positive */
    double corner;       /* Cook's membrane: the top right corner's displacement per unit force */
    int vertices;
    double seconds;
} beam_result;

static void static_solve_steps(defsim_world *w, int32_t nv, double h, int steps)
{
    double *x = malloc(3 * (size_t)nv * sizeof *x), *v = calloc(3 * (size_t)nv, sizeof *v);
    for (int k = 0; k < steps; ++k) {
        const defsim_status st = defsim_world_step(w, h);
        if (st != DEFSIM_OK) fail_msg("static step: %s", defsim_world_last_error(w));
        TU_OK(defsim_world_get_positions(w, x, nv));
        TU_OK(defsim_world_set_state(w, x, v));
    }
    free(x);
    free(v);
}

static void static_solve(defsim_world *w, int32_t nv, double h)
{
    static_solve_steps(w, nv, h, 2);
}

/* The vertex of the mesh nearest p. */
static int32_t nearest(const defsim_mesh *m, const double p[3])
{
    int32_t best = 0;
    double bd = INFINITY;
    for (int32_t i = 0; i < m->vertex_count; ++i) {
        const double *q = m->positions + 3 * (int64_t)i;
        const double d = (q[0] - p[0]) * (q[0] - p[0]) + (q[1] - p[1]) * (q[1] - p[1]) +
                         (q[2] - p[2]) * (q[2] - p[2]);
        if (d < bd) { bd = d; best = i; }
    }
    return best;
}

static void pin_where_x0(defsim_world *w, defsim_body_id id, const defsim_mesh *m)
{
    int32_t *pins = malloc((size_t)m->vertex_count * sizeof *pins), np = 0;
    for (int32_t i = 0; i < m->vertex_count; ++i)
        if (fabs(m->positions[3 * (int64_t)i]) < 1e-12) pins[np++] = i;
    TU_OK(defsim_body_pin(w, id, pins, np));
    free(pins);
}

/* Pins body id's x = 0 face, solves for the static equilibrium (static_solve with step h) and
 * returns the result with the y coordinate of the vertex nearest `corner` in *y. */
static beam_result pin_solve_probe(defsim_world *w, defsim_body_id id, const defsim_mesh *m,
                                   const double corner[3], double h, double *y)
{
    pin_where_x0(w, id, m);
    const int32_t probe = nearest(m, corner);
    const double t0 = now_s();
    static_solve(w, m->vertex_count, h);
    beam_result r = {0};
    r.seconds = now_s() - t0;
    r.vertices = m->vertex_count;
    double *x = malloc(3 * (size_t)m->vertex_count * sizeof *x);
    TU_OK(defsim_world_get_positions(w, x, m->vertex_count));
    *y = x[3 * (int64_t)probe + 1];
    free(x);
    return r;
}

/* The cantilever of n cells per metre (3n x n x n) under its own weight, Poisson ratio nu. */
static beam_result cantilever(int n, int quadratic, double nu)
{
    defsim_world *w = tu_implicit_world("newton_cholmod", -9.81, 1, 1e-10, 50,
                                        DEFSIM_PROJECTION_CLAMP);
    const double lo[3] = {0, 0, 0}, hi[3] = {3, 1, 1};
    defsim_mesh m;
    memset(&m, 0, sizeof m);
    m.size = sizeof m;
    TU_OK(defsim_mesh_box(lo, hi, 3 * n, n, n, &m));
    if (quadratic) TU_OK(defsim_mesh_make_quadratic(&m));
    defsim_body_def bd = test_mesh_body(&m, DEFSIM_MODEL_STABLE_NEOHOOKEAN);
    bd.material.youngs_modulus = 1e8;
    bd.material.poisson_ratio = nu;
    bd.material.density = 1000.0;
    defsim_body_id id;
    TU_OK(defsim_world_add_body(w, &bd, &id));
    const double corner[3] = {3, 1, 1};
    double y;
    beam_result r = pin_solve_probe(w, id, &m, corner, 10.0, &y);
    r.deflection = 1.0 - y;
    defsim_mesh_free(&m);
    defsim_world_destroy(w);
    return r;
}

/* The cantilever of cantilever() 100 times softer (E = 1e6 Pa): a large deflection (the sag is
 * 39 % of the length, the end turns by about 0.6 rad). The centre of the far end's sag
 * (deflection) and its shortening along the beam (corner), in m. Three steps of h = 10 s (the
 * factor per step is 1e-3 here: omega_1 is 10 times lower; 3, 4 and 6 steps agree to 7 digits). */
static beam_result cantilever_large(int n, int quadratic)
{
    defsim_world *w = tu_implicit_world("newton_cholmod", -9.81, 1, 1e-10, 200,
                                        DEFSIM_PROJECTION_CLAMP);
    const double lo[3] = {0, 0, 0}, hi[3] = {3, 1, 1};
    defsim_mesh m;
    memset(&m, 0, sizeof m);
    m.size = sizeof m;
    TU_OK(defsim_mesh_box(lo, hi, 3 * n, n, n, &m));
    if (quadratic) TU_OK(defsim_mesh_make_quadratic(&m));
    defsim_body_def bd = test_mesh_body(&m, DEFSIM_MODEL_STABLE_NEOHOOKEAN);
    bd.material.youngs_modulus = 1e6;
    bd.material.poisson_ratio = 0.3;
    bd.material.density = 1000.0;
    defsim_body_id id;
    TU_OK(defsim_world_add_body(w, &bd, &id));
    pin_where_x0(w, id, &m);
    const double far[3] = {3, 0.5, 0.5};
    const int32_t probe = nearest(&m, far);
    assert_true(fabs(m.positions[3 * (int64_t)probe + 1] - 0.5) < 1e-12);
    const double t0 = now_s();
    static_solve_steps(w, m.vertex_count, 10.0, 3);
    beam_result r = {0};
    r.seconds = now_s() - t0;
    r.vertices = m.vertex_count;
    double *x = malloc(3 * (size_t)m.vertex_count * sizeof *x);
    TU_OK(defsim_world_get_positions(w, x, m.vertex_count));
    r.deflection = 0.5 - x[3 * (int64_t)probe + 1];
    r.corner = 3.0 - x[3 * (int64_t)probe];
    free(x);
    defsim_mesh_free(&m);
    defsim_world_destroy(w);
    return r;
}

/* Cook's membrane with n x n elements in the plane and one through the thickness: the vertical
 * displacement per unit force at the middle of the loaded edge (deflection) and at the top right
 * corner (corner). */
static beam_result cook(int n, int quadratic)
{
    defsim_world *w = tu_implicit_world("newton_cholmod", 0.0, 1, 1e-8, 50,
                                        DEFSIM_PROJECTION_CLAMP);
    const double lo[3] = {0, 0, 0}, hi[3] = {1, 1, 1}, force = 1e-3;
    defsim_mesh m;
    memset(&m, 0, sizeof m);
    m.size = sizeof m;
    TU_OK(defsim_mesh_box(lo, hi, n, n, 1, &m));
    /* The unit square onto the panel, u reversed: x = 48 (1 - u), y = 44 (1 - u) + v (44 - 28
     * (1 - u)) (straight edges, so the tets stay straight). The Kuhn split's diagonals run from
     * (u, v) to (u + 1/n, v + 1/n); reversed, they are the shorter diagonal of each tapered cell
     * (6.0 against 12.1 at the clamped edge for n = 8): -0.64 % at 8 per side instead of -1.01 %
     * along the longer one. The map's Jacobian is negative, so each tet and boundary triangle
     * swaps two nodes to keep its orientation. */
    for (int32_t i = 0; i < m.vertex_count; ++i) {
        double *p = m.positions + 3 * (int64_t)i;
        const double u = 1.0 - p[0], v = p[1];
        p[0] = 48.0 * u;
        p[1] = 44.0 * u + v * (44.0 - 28.0 * u);
    }
    for (int32_t t = 0; t < m.tet_count; ++t) {
        int32_t *tt = m.tets + 4 * (int64_t)t, sw = tt[0];
        tt[0] = tt[1];
        tt[1] = sw;
    }
    for (int32_t t = 0; t < m.triangle_count; ++t) {
        int32_t *tr = m.triangles + 3 * (int64_t)t, sw = tr[0];
        tr[0] = tr[1];
        tr[1] = sw;
    }
    /* The loaded face's triangles before the mesh turns quadratic: each carries F A / A_face,
     * a third at each corner (linear) or at each mid-edge node (quadratic: the corners' shape
     * functions integrate to zero over a triangle). */
    const int32_t nlin = m.vertex_count;
    int32_t *face = NULL, nface = 0;
    face = malloc(3 * (size_t)m.triangle_count * sizeof *face);
    for (int32_t t = 0; t < m.triangle_count; ++t) {
        const int32_t *tr = m.triangles + 3 * (int64_t)t;
        int on = 1;
        for (int k = 0; k < 3; ++k) on &= fabs(m.positions[3 * (int64_t)tr[k]] - 48.0) < 1e-9;
        if (on) memcpy(face + 3 * nface++, tr, 3 * sizeof *tr);
    }
    int32_t *corners = NULL;
    if (quadratic) {
        corners = malloc(4 * (size_t)m.tet_count * sizeof *corners);
        memcpy(corners, m.tets, 4 * (size_t)m.tet_count * sizeof *corners);
        TU_OK(defsim_mesh_make_quadratic(&m));
    }
    double *f = calloc(3 * (size_t)m.vertex_count, sizeof *f);
    double area_total = 0.0;
    for (int32_t t = 0; t < nface; ++t) {
        const double *a = m.positions + 3 * (int64_t)face[3 * t], *b = m.positions + 3 * (int64_t)face[3 * t + 1];
        const double *c = m.positions + 3 * (int64_t)face[3 * t + 2];
        const double e1[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]};
        const double e2[3] = {c[0] - a[0], c[1] - a[1], c[2] - a[2]};
        const double cr[3] = {e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2],
                              e1[0] * e2[1] - e1[1] * e2[0]};
        area_total += 0.5 * sqrt(cr[0] * cr[0] + cr[1] * cr[1] + cr[2] * cr[2]);
    }
    for (int32_t t = 0; t < nface; ++t) {
        const double *a = m.positions + 3 * (int64_t)face[3 * t], *b = m.positions + 3 * (int64_t)face[3 * t + 1];
        const double *c = m.positions + 3 * (int64_t)face[3 * t + 2];
        const double e1[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]};
        const double e2[3] = {c[0] - a[0], c[1] - a[1], c[2] - a[2]};
        const double cr[3] = {e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2],
                              e1[0] * e2[1] - e1[1] * e2[0]};
        const double share = force * 0.5 * sqrt(cr[0] * cr[0] + cr[1] * cr[1] + cr[2] * cr[2]) /
                             area_total / 3.0;
        for (int k = 0; k < 3; ++k) {
            int32_t node = face[3 * t + k];
            if (quadratic) {
                /* the mid-edge node of edge (k, k + 1): the vertex at its middle */
                const double *p = m.positions + 3 * (int64_t)face[3 * t + k];
                const double *q = m.positions + 3 * (int64_t)face[3 * t + (k + 1) % 3];
                const double mid[3] = {0.5 * (p[0] + q[0]), 0.5 * (p[1] + q[1]), 0.5 * (p[2] + q[2])};
                node = nearest(&m, mid);
                assert_true(node >= nlin);
            }
            f[3 * (int64_t)node + 1] += share;
        }
    }
    free(corners);
    defsim_body_def bd = test_mesh_body(&m, DEFSIM_MODEL_COROTATED);
    bd.material.youngs_modulus = 1.0;
    bd.material.poisson_ratio = 1.0 / 3.0;
    bd.material.density = 1.0;
    defsim_body_id id;
    TU_OK(defsim_world_add_body(w, &bd, &id));
    TU_OK(defsim_world_set_external_forces(w, f, m.vertex_count));
    const double corner[3] = {48, 60, 1};
    double y;
    beam_result r = pin_solve_probe(w, id, &m, corner, 1e4, &y);
    r.corner = (y - 60.0) / force;
    /* The middle of the loaded edge, (48, 52), on both faces (n is even: vertices there). */
    double *x = malloc(3 * (size_t)m.vertex_count * sizeof *x);
    TU_OK(defsim_world_get_positions(w, x, m.vertex_count));
    const double mid0[3] = {48, 52, 0}, mid1[3] = {48, 52, 1};
    const int32_t a = nearest(&m, mid0), b = nearest(&m, mid1);
    assert_true(fabs(m.positions[3 * (int64_t)a + 1] - 52.0) < 1e-9);
    assert_true(fabs(m.positions[3 * (int64_t)b + 1] - 52.0) < 1e-9);
    r.deflection = (0.5 * (x[3 * (int64_t)a + 1] + x[3 * (int64_t)b + 1]) - 52.0) / force;
    free(x);
    free(f);
    free(face);
    defsim_mesh_free(&m);
    defsim_world_destroy(w);
    return r;
}

/* Richardson extrapolation of u(n) = u* + C n^-p through three meshes n0 < n1 < n2: p by
 * bisection on the ratio of the differences, then u*. */
static double richardson(const int n[3], const double u[3], double *p_out)
{
    const double target = (u[1] - u[0]) / (u[2] - u[1]);
    double lo = 0.1, hi = 8.0;
    for (int it = 0; it < 200; ++it) {
        const double p = 0.5 * (lo + hi);
        const double r = (pow(n[1], -p) - pow(n[0], -p)) / (pow(n[2], -p) - pow(n[1], -p));
        if (r < target) lo = p;
        else hi = p;
    }
    const double p = 0.5 * (lo + hi);
    const double C = (u[2] - u[1]) / (pow(n[2], -p) - pow(n[1], -p));
    *p_out = p;
    return u[2] - C * pow(n[2], -p);
}

static void test_cantilever(void **state)
{
    (void)state;
    const beam_result q = cantilever(4, 1, 0.3), l = cantilever(4, 0, 0.3);
    const double eq = q.deflection / REF_CANTILEVER - 1.0, el = l.deflection / REF_CANTILEVER - 1.0;
    printf("  cantilever 12 x 4 x 4, reference %.5g mm: quadratic %.5g mm (%+.2f %%, %d vertices, "
           "%.2f s), linear %.5g mm (%+.2f %%, %d vertices, %.2f s)\n", 1e3 * REF_CANTILEVER,
           1e3 * q.deflection, 100.0 * eq, q.vertices, q.seconds, 1e3 * l.deflection, 100.0 * el,
           l.vertices, l.seconds);
    assert_true(fabs(eq) < 0.02);
    assert_true(el < -0.15 && el > -0.25);
    if (!long_mode) return;
    const int n[3] = {6, 8, 10};
    double u[3], p;
    for (int k = 0; k < 3; ++k) {
        const beam_result r = cantilever(n[k], 1, 0.3);
        u[k] = r.deflection;
        printf("  cantilever %d x %d x %d quadratic: %.7g mm (%d vertices, %.2f s)\n", 3 * n[k],
               n[k], n[k], 1e3 * u[k], r.vertices, r.seconds);
    }
    const double ref = richardson(n, u, &p);
    printf("  cantilever extrapolated: %.7g mm (order %.2f); REF_CANTILEVER %.7g mm\n", 1e3 * ref,
           p, 1e3 * REF_CANTILEVER);
    assert_true(fabs(ref / REF_CANTILEVER - 1.0) < 5e-4);
}

/* nu = 0.499 (near incompressible; E, load and solve as above): issue 29 asks quadratic tets
 * (or the volume-averaged linear tets of test_volume_averaging) within 3 % of the converged
 * solution at 12 x 4 x 4 cells, and the linear tets' locking shown. Measured: the quadratic tets
 * are 4.1 % short at 12 x 4 x 4 (the 3 % is not met on this mesh; the volume-averaged linear
 * tets are 25 % short), 2.3 % short at 18 x 6 x 6 (--long asserts that one within 3 %); the
 * linear tets lock: 2.05 mm, 84 % short, a fifth of their own sag at nu = 0.3, while the
 * continuum's sag falls by only 3.7 % from nu = 0.3 to 0.499 (REF_CANTILEVER_NU499 /
 * REF_CANTILEVER) and the quadratic tets' by 7 %. */
static void test_cantilever_incompressible(void **state)
{
    (void)state;
    const double nu = 0.499, ref = REF_CANTILEVER_NU499;
    const beam_result q = cantilever(4, 1, nu), l = cantilever(4, 0, nu);
    const beam_result q3 = cantilever(4, 1, 0.3), l3 = cantilever(4, 0, 0.3);
    const double eq = q.deflection / ref - 1.0, el = l.deflection / ref - 1.0;
    printf("  cantilever 12 x 4 x 4, nu 0.499, reference %.5g mm: quadratic %.5g mm (%+.2f %%, "
           "%.2f s), linear %.5g mm (%+.2f %%, %.2f s)\n", 1e3 * ref, 1e3 * q.deflection,
           100.0 * eq, q.seconds, 1e3 * l.deflection, 100.0 * el, l.seconds);
    printf("  sag at nu 0.499 over sag at nu 0.3: continuum %.4f, quadratic %.4f, linear %.4f\n",
           ref / REF_CANTILEVER, q.deflection / q3.deflection, l.deflection / l3.deflection);
    /* quadratic: short by 4.1 %, not within issue 29's 3 % on this mesh (18 x 6 x 6 is, --long) */
    assert_true(eq < 0.0 && eq > -0.045);
    /* linear: locked, far below the continuum and its own sag at nu = 0.3 */
    assert_true(el < -0.75);
    assert_true(l.deflection < 0.25 * l3.deflection);
    assert_true(q.deflection > 5.0 * l.deflection);
    assert_true(q.deflection > 0.9 * q3.deflection);
    /* the two independent references agree */
    assert_true(fabs(ref / REF_NU499_AVERAGED - 1.0) < 1e-3);
    if (!long_mode) return;
    const int n[3] = {6, 8, 10};
    double u[3], p;
    for (int k = 0; k < 3; ++k) {
        const beam_result r = cantilever(n[k], 1, nu);
        u[k] = r.deflection;
        printf("  cantilever %d x %d x %d quadratic, nu 0.499: %.7g mm (%+.2f %%, %d vertices, "
               "%.2f s)\n", 3 * n[k], n[k], n[k], 1e3 * u[k], 100.0 * (u[k] / ref - 1.0),
               r.vertices, r.seconds);
    }
    const double ext = richardson(n, u, &p);
    printf("  cantilever nu 0.499 extrapolated: %.7g mm (order %.2f); REF_CANTILEVER_NU499 %.7g "
           "mm, volume-averaged reference %.7g mm\n", 1e3 * ext, p, 1e3 * ref,
           1e3 * REF_NU499_AVERAGED);
    assert_true(fabs(ext / ref - 1.0) < 5e-4);
    assert_true(fabs(ext / REF_NU499_AVERAGED - 1.0) < 1e-3);
    assert_true(fabs(u[0] / ref - 1.0) < 0.03);   /* 18 x 6 x 6: within issue 29's 3 % */
}

static void test_cook(void **state)
{
    (void)state;
    const beam_result q = cook(8, 1), l = cook(8, 0), q16 = cook(16, 1);
    const double eq = q.deflection / REF_COOK - 1.0, el = l.deflection / REF_COOK - 1.0;
    const double e16 = q16.deflection / REF_COOK - 1.0, e3 = q.deflection / REF_COOK_3D - 1.0;
    printf("  Cook's membrane at (48, 52), reference %.5g (this 3D problem converged: %.5g): "
           "8 x 8 quadratic %.5g (%+.2f %%, %+.2f %% of the 3D one; %d vertices, %.2f s), linear "
           "%.5g (%+.2f %%, %.2f s); 16 x 16 quadratic %.5g (%+.2f %%, %.2f s); top right corner "
           "(48, 60): %.5g, %.5g, %.5g\n", REF_COOK, REF_COOK_3D, q.deflection, 100.0 * eq,
           100.0 * e3, q.vertices, q.seconds, l.deflection, 100.0 * el, l.seconds, q16.deflection,
           100.0 * e16, q16.seconds, q.corner, l.corner, q16.corner);
    assert_true(e3 < 0.0 && e3 > -0.01);   /* within 1 % of the converged 3D solution */
    assert_true(eq < 0.0 && eq > -0.01);   /* and of the literature's 23.96 (-0.64 %) */
    assert_true(fabs(e16) < 0.005);
    assert_true(el < -0.05);               /* linear tets: 10 % short */
    /* The corner converges elsewhere (about 25.1): it is not the literature's point. */
    assert_true(q16.corner > 24.8);
    if (!long_mode) return;
    const int n[3] = {16, 24, 32};
    double u[3], p;
    for (int k = 0; k < 3; ++k) {
        const beam_result r = cook(n[k], 1);
        u[k] = r.deflection;
        printf("  Cook's membrane %d x %d quadratic: mid-edge %.7g, corner %.7g (%d vertices, "
               "%.2f s)\n", n[k], n[k], u[k], r.corner, r.vertices, r.seconds);
    }
    const double ref = richardson(n, u, &p);
    printf("  Cook's membrane extrapolated: %.7g (order %.2f); REF_COOK_3D %.5g, literature "
           "%.4g\n", ref, p, REF_COOK_3D, REF_COOK);
    assert_true(fabs(ref / REF_COOK_3D - 1.0) < 5e-4);
    assert_true(fabs(ref / REF_COOK - 1.0) < 1e-3);
}

/* The large deflection (cantilever_large): the far end's sag and shortening per element type
 * and mesh against the quadratic refinements' extrapolation (REF_LARGE_*). */
static void test_cantilever_large(void **state)
{
    (void)state;
    const struct { int n, quadratic; } mesh[] = {{2, 1}, {4, 1}, {4, 0}, {8, 0}};
    beam_result r[4];
    for (int k = 0; k < 4; ++k) {
        r[k] = cantilever_large(mesh[k].n, mesh[k].quadratic);
        printf("  large deflection, %2d x %d x %d %-9s (%5d vertices): sag %.6f m (%+.2f %%), "
               "shortening %.6f m (%+.2f %%), %.2f s\n", 3 * mesh[k].n, mesh[k].n, mesh[k].n,
               mesh[k].quadratic ? "quadratic" : "linear", r[k].vertices, r[k].deflection,
               100.0 * (r[k].deflection / REF_LARGE_SAG - 1.0), r[k].corner,
               100.0 * (r[k].corner / REF_LARGE_SHORTENING - 1.0), r[k].seconds);
    }
    const double sag_q4 = r[1].deflection / REF_LARGE_SAG - 1.0;
    const double short_q4 = r[1].corner / REF_LARGE_SHORTENING - 1.0;
    const double sag_l8 = r[3].deflection / REF_LARGE_SAG - 1.0;
    /* 12 x 4 x 4 quadratic and 24 x 8 x 8 linear have the same 2,025 vertices. */
    assert_int_equal(r[1].vertices, r[3].vertices);
    assert_true(fabs(sag_q4) < 0.005 && fabs(short_q4) < 0.01);
    assert_true(sag_l8 < -0.03 && fabs(sag_l8) > 10.0 * fabs(sag_q4));
    assert_true(r[2].deflection / REF_LARGE_SAG - 1.0 < -0.1);   /* 12 x 4 x 4 linear */
    /* Large: the sag is 39 % of the length and the end moves 8 % of it inwards. */
    assert_true(REF_LARGE_SAG > 0.35 * 3.0 && REF_LARGE_SHORTENING > 0.07 * 3.0);
    if (!long_mode) return;
    const int n[3] = {6, 8, 10};
    double us[3], ux[3], ps, px;
    for (int k = 0; k < 3; ++k) {
        const beam_result q = cantilever_large(n[k], 1);
        us[k] = q.deflection;
        ux[k] = q.corner;
        printf("  large deflection %d x %d x %d quadratic: sag %.7f m, shortening %.7f m (%d "
               "vertices, %.2f s)\n", 3 * n[k], n[k], n[k], us[k], ux[k], q.vertices, q.seconds);
    }
    const double s_ext = richardson(n, us, &ps), x_ext = richardson(n, ux, &px);
    printf("  large deflection extrapolated: sag %.7f m (order %.2f), shortening %.7f m (order "
           "%.2f); REF_LARGE_SAG %.7f, REF_LARGE_SHORTENING %.7f\n", s_ext, ps, x_ext, px,
           REF_LARGE_SAG, REF_LARGE_SHORTENING);
    assert_true(fabs(s_ext / REF_LARGE_SAG - 1.0) < 2e-4);
    assert_true(fabs(x_ext / REF_LARGE_SHORTENING - 1.0) < 5e-4);
}

int main(int argc, char **argv)
{
    long_mode = argc > 1 && strcmp(argv[1], "--long") == 0;
    if (argc > 4 && strcmp(argv[1], "--one") == 0) {   /* --one N NU QUADRATIC: one cantilever */
        const int n = atoi(argv[2]), quad = atoi(argv[4]);
        const double nu = atof(argv[3]);
        const beam_result r = cantilever(n, quad, nu);
        printf("  cantilever %d x %d x %d %s nu %g: %.7g mm (%d vertices, %.2f s)\n", 3 * n, n, n,
               quad ? "quadratic" : "linear", nu, 1e3 * r.deflection, r.vertices, r.seconds);
        return 0;
    }
    if (argc > 3 && strcmp(argv[1], "--large") == 0) {   /* --large N QUADRATIC */
        const int n = atoi(argv[2]), quad = atoi(argv[3]);
        const beam_result r = cantilever_large(n, quad);
        printf("  large cantilever %d x %d x %d %s: sag %.7g m, shortening %.7g m (%d vertices, "
               "%.2f s)\n", 3 * n, n, n, quad ? "quadratic" : "linear", r.deflection, r.corner,
               r.vertices, r.seconds);
        return 0;
    }
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_cantilever),
        cmocka_unit_test(test_cantilever_incompressible),
        cmocka_unit_test(test_cook),
        cmocka_unit_test(test_cantilever_large),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
