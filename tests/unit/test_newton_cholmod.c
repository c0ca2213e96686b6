/* SPDX-License-Identifier: MIT */
/*
 * newton_cholmod (backends/newton_cholmod): loading on demand, backward Euler against an
 * independent dense Newton solution and against RK4 (order), robustness on stiff and inverted
 * beams, failure and roll-back, projections, factorisation variants, scale invariance of the
 * convergence test, determinism.
 */
#include "test_util.h"

#include <math.h>
#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static const char *NC = "newton_cholmod";

static defsim_world *nc_world(double gy, int threads, double tol, int max_it,
                              defsim_projection proj)
{
    return tu_implicit_world(NC, gy, threads, tol, max_it, proj);
}

static void step_ok(defsim_world *w, double h)
{
    defsim_status st = defsim_world_step(w, h);
    if (st != DEFSIM_OK)
        fail_msg("step: %s (%s)", defsim_status_string(st), defsim_world_last_error(w));
}

static double total_energy(defsim_world *w)
{
    defsim_energy e;
    TU_OK(defsim_world_energy(w, &e));
    return e.total;
}

/* Signed volume of every tet of a box body; returns the smallest one (m^3). */
static double min_tet_volume(defsim_world *w, int nx, int ny, int nz, const double lo[3],
                             const double hi[3])
{
    defsim_mesh m = {.size = sizeof m};
    TU_OK(defsim_mesh_box(lo, hi, nx, ny, nz, &m));
    double *x = tu_positions(w), vmin = INFINITY;
    for (int t = 0; t < m.tet_count; ++t) {
        const int32_t *id = m.tets + 4 * t;
        double a[3], b[3], c[3];
        for (int i = 0; i < 3; ++i) {
            a[i] = x[3 * id[0] + i] - x[3 * id[3] + i];
            b[i] = x[3 * id[1] + i] - x[3 * id[3] + i];
            c[i] = x[3 * id[2] + i] - x[3 * id[3] + i];
        }
        double det = a[0] * (b[1] * c[2] - b[2] * c[1]) - a[1] * (b[0] * c[2] - b[2] * c[0]) +
                     a[2] * (b[0] * c[1] - b[1] * c[0]);
        vmin = fmin(vmin, det / 6.0);
    }
    free(x);
    defsim_mesh_free(&m);
    return vmin;
}

/* ------------------------------------------------------------------------------------------ */
/* Loading: a world with explicit backends maps neither the module nor CHOLMOD (this test runs
 * first in the process); a newton_cholmod world maps both. */

static void test_loaded_on_demand(void **state)
{
    (void)state;
    const double lo[3] = {0, 0, 0}, hi[3] = {1, 1, 1};
    defsim_world *w = tu_world("symplectic_euler", -9.81, 1);
    tu_add_box(w, DEFSIM_MODEL_COROTATED, 2, 1, 1, lo, hi, 1e5, 0.3, 1000);
    for (int i = 0; i < 5; ++i) TU_OK(defsim_world_step(w, 1e-4));
    defsim_world_destroy(w);
    assert_int_equal(tu_mapped("defsim_newton_cholmod.so"), 0);
    assert_int_equal(tu_mapped("libcholmod"), 0);

    w = nc_world(-9.81, 1, 1e-6, 50, DEFSIM_PROJECTION_CLAMP);
    assert_int_equal(tu_mapped("defsim_newton_cholmod.so"), 1);
    tu_add_box(w, DEFSIM_MODEL_COROTATED, 2, 1, 1, lo, hi, 1e5, 0.3, 1000);
    step_ok(w, 1.0 / 60.0);
    assert_int_equal(tu_mapped("libcholmod"), 1);
    defsim_stats s = {.size = sizeof s};
    TU_OK(defsim_world_stats(w, &s));
    assert_true(tu_bstat(w, "newton_iterations") >= 1);
    assert_true(tu_bstat(w, "linear_solves") >= tu_bstat(w, "newton_iterations"));
    assert_true(s.hessian_evals >= tu_bstat(w, "newton_iterations"));
    assert_true(tu_bstat(w, "time_factor") > 0.0 && tu_bstat(w, "time_solve") > 0.0);
    assert_true(s.passes & DEFSIM_PASS_HESSIAN);
    assert_true(s.passes & DEFSIM_PASS_ENERGY);
    defsim_world_destroy(w);
}

/* ------------------------------------------------------------------------------------------ */
/* A spring chain with gravity and a pinned end against backward Euler computed here by dense
 * Newton on the same incremental potential (with implicit Rayleigh damping). */

enum { CH_N = 8, CH_FREE = 3 * (CH_N - 1) };
static const double CH_L = 0.25, CH_K = 400.0, CH_M = 0.05, CH_G = -9.81;

typedef struct chain_ref {
    double x[3 * CH_N], v[3 * CH_N];
    double alpha, beta;
} chain_ref;

/* Adds spring (a, b)'s 3x3 block k ((1 - s) n n^T + s I), s = 1 - l0 / l (clamped at 0 if asked),
 * into the dense free-DOF matrix H with weight c, and its force into f (if not NULL). */
static void chain_spring(const double *x, int a, int b, double c, int clamp, double *H, double *f)
{
    double d[3], l = 0.0;
    for (int i = 0; i < 3; ++i) {
        d[i] = x[3 * b + i] - x[3 * a + i];
        l += d[i] * d[i];
    }
    l = sqrt(l);
    double s = 1.0 - CH_L / l;
    if (f)
        for (int i = 0; i < 3; ++i) {
            f[3 * a + i] += CH_K * (l - CH_L) * d[i] / l;
            f[3 * b + i] -= CH_K * (l - CH_L) * d[i] / l;
        }
    if (!H) return;
    if (clamp && s < 0.0) s = 0.0;
    for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j) {
            double kb = c * CH_K * ((1.0 - s) * d[i] * d[j] / (l * l) + (i == j ? s : 0.0));
            int ra = 3 * (a - 1) + i, rb = 3 * (b - 1) + i, ca = 3 * (a - 1) + j,
                cb = 3 * (b - 1) + j;
            if (a > 0) H[ra * CH_FREE + ca] += kb;
            if (b > 0) H[rb * CH_FREE + cb] += kb;
            if (a > 0 && b > 0) {
                H[ra * CH_FREE + cb] -= kb;
                H[rb * CH_FREE + ca] -= kb;
            }
        }
}

/* Solves A x = b (n x n, partial pivoting); A and b are overwritten. */
static void dense_solve(int n, double *A, double *b)
{
    for (int c = 0; c < n; ++c) {
        int p = c;
        for (int r = c + 1; r < n; ++r)
            if (fabs(A[r * n + c]) > fabs(A[p * n + c])) p = r;
        for (int j = 0; j < n; ++j) {
            double t = A[c * n + j];
            A[c * n + j] = A[p * n + j];
            A[p * n + j] = t;
        }
        double t = b[c];
        b[c] = b[p];
        b[p] = t;
        for (int r = c + 1; r < n; ++r) {
            double q = A[r * n + c] / A[c * n + c];
            for (int j = c; j < n; ++j) A[r * n + j] -= q * A[c * n + j];
            b[r] -= q * b[c];
        }
    }
    for (int r = n - 1; r >= 0; --r) {
        double s = b[r];
        for (int j = r + 1; j < n; ++j) s -= A[r * n + j] * b[j];
        b[r] = s / A[r * n + r];
    }
}

/* One backward Euler step of the chain: argmin of g by Newton to |dx| < 1e-14 m. */
static void chain_ref_step(chain_ref *c, double h)
{
    double x0[3 * CH_N], y[3 * CH_N], x[3 * CH_N], B[CH_FREE * CH_FREE] = {0};
    memcpy(x0, c->x, sizeof x0);
    for (int i = 0; i < 3 * CH_N; ++i) y[i] = x0[i] + h * c->v[i];
    memcpy(x, y, sizeof x);
    for (int s = 0; s + 1 < CH_N; ++s) chain_spring(x0, s, s + 1, c->beta, 1, B, NULL);
    int converged = 0;
    for (int it = 0; it < 50 && !converged; ++it) {
        double f[3 * CH_N] = {0}, H[CH_FREE * CH_FREE] = {0}, r[CH_FREE];
        for (int s = 0; s + 1 < CH_N; ++s) chain_spring(x, s, s + 1, 1.0, 0, H, f);
        for (int k = 0; k < CH_FREE; ++k) {
            const int i = k + 3;
            double e = 0.0;
            for (int j = 0; j < CH_FREE; ++j) e += B[k * CH_FREE + j] * (x[j + 3] - x0[j + 3]);
            double grav = (i % 3 == 1) ? CH_M * CH_G : 0.0;
            r[k] = -(CH_M * (x[i] - y[i]) / (h * h) - f[i] - grav +
                     (c->alpha * CH_M * (x[i] - x0[i]) + e) / h);
            H[k * CH_FREE + k] += CH_M / (h * h) + c->alpha * CH_M / h;
            for (int j = 0; j < CH_FREE; ++j) H[k * CH_FREE + j] += B[k * CH_FREE + j] / h;
        }
        dense_solve(CH_FREE, H, r);
        double dmax = 0.0;
        for (int k = 0; k < CH_FREE; ++k) {
            x[k + 3] += r[k];
            dmax = fmax(dmax, fabs(r[k]));
        }
        converged = dmax < 1e-14;
    }
    assert_true(converged);
    for (int i = 0; i < 3 * CH_N; ++i) {
        c->v[i] = (x[i] - x0[i]) / h;
        c->x[i] = x[i];
    }
}

/* The chain: CH_N masses CH_M on a line, scale * CH_L apart, joined by springs of stiffness k
 * with Rayleigh damping alpha, beta; vertex 0 pinned. */
static void add_chain(defsim_world *w, double scale, double k, double alpha, double beta)
{
    double x[3 * CH_N] = {0}, m[CH_N];
    int32_t sp[2 * (CH_N - 1)];
    for (int i = 0; i < CH_N; ++i) {
        x[3 * i] = scale * CH_L * i;
        m[i] = CH_M;
    }
    for (int s = 0; s + 1 < CH_N; ++s) {
        sp[2 * s] = s;
        sp[2 * s + 1] = s + 1;
    }
    defsim_body_def bd;
    defsim_body_def_init(&bd, sizeof bd);
    defsim_material_init(&bd.material, sizeof bd.material, DEFSIM_MODEL_SPRING);
    bd.material.stiffness = k;
    bd.material.mass_damping = alpha;
    bd.material.stiffness_damping = beta;
    bd.rest_positions = x;
    bd.vertex_count = CH_N;
    bd.springs = sp;
    bd.spring_count = CH_N - 1;
    bd.vertex_mass = m;
    defsim_body_id id;
    TU_OK(defsim_world_add_body(w, &bd, &id));
    int32_t pin = 0;
    TU_OK(defsim_body_pin(w, id, &pin, 1));
}

static defsim_world *chain_world(double alpha, double beta, double tol)
{
    defsim_world *w = nc_world(CH_G, 1, tol, 50, DEFSIM_PROJECTION_CLAMP);
    add_chain(w, 1.0, CH_K, alpha, beta);
    return w;
}

static void chain_case(double alpha, double beta)
{
    const double h = 0.01;
    defsim_world *w = chain_world(alpha, beta, 1e-12);
    chain_ref ref = {.alpha = alpha, .beta = beta};
    TU_OK(defsim_world_get_positions(w, ref.x, CH_N));
    memset(ref.v, 0, sizeof ref.v);
    double ex = 0.0, ev = 0.0, prev = total_energy(w), e0 = prev, travel = 0.0;
    for (int s = 0; s < 200; ++s) {
        step_ok(w, h);
        chain_ref_step(&ref, h);
        double x[3 * CH_N], v[3 * CH_N];
        TU_OK(defsim_world_get_positions(w, x, CH_N));
        TU_OK(defsim_world_get_velocities(w, v, CH_N));
        for (int i = 0; i < 3 * CH_N; ++i) {
            ex = fmax(ex, fabs(x[i] - ref.x[i]));
            ev = fmax(ev, fabs(v[i] - ref.v[i]));
        }
        travel = fmax(travel, fabs(x[3 * (CH_N - 1) + 1]));
        /* Backward Euler, and damping, only dissipate. */
        double e = total_energy(w);
        assert_true(e <= prev + 1e-12 * fabs(e0));
        prev = e;
    }
    printf("spring chain, alpha %.2g, beta %.2g: max |x - x_ref| %.2e m, |v - v_ref| %.2e m/s "
           "over 200 steps (free end fell %.3f m)\n", alpha, beta, ex, ev, travel);
    assert_true(travel > 1.0);   /* the chain swung down: a real test of the nonlinear solve */
    assert_true(ex <= 1e-9);
    assert_true(ev <= 1e-9 / h);
    defsim_world_destroy(w);
}

static void test_chain_vs_dense_newton(void **state)
{
    (void)state;
    chain_case(0.0, 0.0);
}

static void test_chain_rayleigh_damping(void **state)
{
    (void)state;
    chain_case(0.8, 0.02);
}

/* ------------------------------------------------------------------------------------------ */
/* Order in h: an elastic pendulum (one mass on a spring to a pinned anchor, gravity) against
 * RK4 with a tiny step. */

static const double PD_K = 50.0, PD_M = 1.0, PD_L0 = 0.8;

static void pendulum_rhs(const double *s, double *ds)
{
    double l = sqrt(s[0] * s[0] + s[1] * s[1] + s[2] * s[2]);
    double c = -PD_K * (l - PD_L0) / (l * PD_M);
    for (int i = 0; i < 3; ++i) {
        ds[i] = s[3 + i];
        ds[3 + i] = c * s[i] + (i == 1 ? CH_G : 0.0);
    }
}

static void pendulum_rk4(double T, double out[3])
{
    double s[6] = {1.0, 0.0, 0.2, 0.0, 0.0, 0.0};
    const int n = 50000;
    const double h = T / n;
    for (int k = 0; k < n; ++k) {
        double k1[6], k2[6], k3[6], k4[6], t[6];
        pendulum_rhs(s, k1);
        for (int i = 0; i < 6; ++i) t[i] = s[i] + 0.5 * h * k1[i];
        pendulum_rhs(t, k2);
        for (int i = 0; i < 6; ++i) t[i] = s[i] + 0.5 * h * k2[i];
        pendulum_rhs(t, k3);
        for (int i = 0; i < 6; ++i) t[i] = s[i] + h * k3[i];
        pendulum_rhs(t, k4);
        for (int i = 0; i < 6; ++i) s[i] += h / 6.0 * (k1[i] + 2 * k2[i] + 2 * k3[i] + k4[i]);
    }
    memcpy(out, s, 3 * sizeof(double));
}

static double pendulum_error(double T, double h, const double want[3])
{
    defsim_world *w = nc_world(CH_G, 1, 1e-13, 50, DEFSIM_PROJECTION_CLAMP);
    const tu_spring2 o = {.l0 = PD_L0, .x1 = {1.0, 0.0, 0.2}, .m0 = 1.0, .m1 = PD_M, .k = PD_K,
                          .pin_anchor = 1};
    tu_add_spring2(w, &o);
    const int steps = (int)lround(T / h);
    for (int s = 0; s < steps; ++s) step_ok(w, h);
    double got[6];
    TU_OK(defsim_world_get_positions(w, got, 2));
    defsim_world_destroy(w);
    double e = 0.0;
    for (int i = 0; i < 3; ++i) e = fmax(e, fabs(got[3 + i] - want[i]));
    return e;
}

static void test_convergence_order(void **state)
{
    (void)state;
    const double T = 0.5, hs[4] = {0.004, 0.002, 0.001, 0.0005};
    double want[3], e[4];
    pendulum_rk4(T, want);
    for (int k = 0; k < 4; ++k) e[k] = pendulum_error(T, hs[k], want);
    double p1 = log2(e[1] / e[2]), p2 = log2(e[2] / e[3]);
    printf("backward Euler order in h: errors %.3e %.3e %.3e %.3e, orders %.3f %.3f\n", e[0],
           e[1], e[2], e[3], p1, p2);
    assert_true(p1 > 0.85 && p1 < 1.15);
    assert_true(p2 > 0.9 && p2 < 1.1);
}

/* ------------------------------------------------------------------------------------------ */
/* Robustness. */

static const double BEAM_LO[3] = {0, 0, 0}, BEAM_HI[3] = {1.5, 0.5, 0.5};

/* 300 steps of h = 1/30 s; the total energy never grows and the state stays finite. Returns the
 * last total energy. */
static double run_energy_checked(defsim_world *w, int steps, double h, double *first)
{
    const int n = defsim_world_vertex_count(w);
    defsim_energy e0;
    TU_OK(defsim_world_energy(w, &e0));
    const double scale = e0.kinetic + e0.elastic + fabs(e0.gravitational);
    double prev = e0.total;
    *first = e0.total;
    for (int s = 0; s < steps; ++s) {
        step_ok(w, h);
        double e = total_energy(w);
        if (!(e <= prev + 1e-10 * scale))
            fail_msg("step %d raised the energy from %.15g J to %.15g J", s, prev, e);
        prev = e;
    }
    double *x = tu_positions(w), *v = tu_velocities(w);
    for (int i = 0; i < 3 * n; ++i) assert_true(isfinite(x[i]) && isfinite(v[i]));
    free(x);
    free(v);
    return prev;
}

/* E = 10 MPa, nu = 0.45 cantilever, kicked upwards, at h = 1/30 s. */
static void test_stiff_beam(void **state)
{
    (void)state;
    const defsim_model models[2] = {DEFSIM_MODEL_STABLE_NEOHOOKEAN, DEFSIM_MODEL_COROTATED};
    for (int k = 0; k < 2; ++k) {
        defsim_world *w = nc_world(-9.81, 1, 1e-6, 50, DEFSIM_PROJECTION_CLAMP);
        defsim_body_id b = tu_add_box(w, models[k], 6, 2, 2, BEAM_LO, BEAM_HI, 1e7, 0.45, 1000);
        tu_pin_below(w, b, 0, 0.0);
        int n = defsim_world_vertex_count(w);
        double *v = tu_velocities(w), *x = tu_positions(w);
        for (int i = 0; i < n; ++i) v[3 * i + 1] = 3.0 * x[3 * i] / BEAM_HI[0];
        TU_OK(defsim_world_set_state(w, NULL, v));
        double first, last = run_energy_checked(w, 300, 1.0 / 30.0, &first);
        defsim_stats s = {.size = sizeof s};
        TU_OK(defsim_world_stats(w, &s));
        printf("stiff beam (%s): energy %.4g J -> %.4g J, %.2f Newton iterations per step, %lld "
               "backtracks\n", k == 0 ? "stable neo-Hookean" : "co-rotated", first, last,
               (double)tu_bstat(w, "newton_iterations") / 300.0, (long long)tu_bstat(w, "line_search_backtracks"));
        assert_true(last < first);
        assert_int_equal(s.failed_steps, 0);
        free(v);
        free(x);
        defsim_world_destroy(w);
    }
}

/* A stable neo-Hookean beam started inverted and squashed (mirrored in x and compressed to 30 %):
 * it recovers its shape, every tet positively oriented again, without a failed step. */
static void test_inverted_beam(void **state)
{
    (void)state;
    defsim_world *w = nc_world(0.0, 1, 1e-6, 50, DEFSIM_PROJECTION_CLAMP);
    tu_add_box(w, DEFSIM_MODEL_STABLE_NEOHOOKEAN, 6, 2, 2, BEAM_LO, BEAM_HI, 1e6, 0.45, 1000);
    const int n = defsim_world_vertex_count(w);
    double *x = tu_positions(w);
    for (int i = 0; i < n; ++i) {
        x[3 * i] = 0.75 - 0.3 * (x[3 * i] - 0.75);
        x[3 * i + 1] = 0.25 + 0.3 * (x[3 * i + 1] - 0.25);
        x[3 * i + 2] = 0.25 + 0.3 * (x[3 * i + 2] - 0.25);
    }
    TU_OK(defsim_world_set_state(w, x, NULL));
    assert_true(min_tet_volume(w, 6, 2, 2, BEAM_LO, BEAM_HI) < 0.0);
    defsim_energy e0, e1;
    TU_OK(defsim_world_energy(w, &e0));
    double first, last = run_energy_checked(w, 300, 1.0 / 30.0, &first);
    TU_OK(defsim_world_energy(w, &e1));
    double vmin = min_tet_volume(w, 6, 2, 2, BEAM_LO, BEAM_HI);
    printf("inverted beam: elastic energy %.4g J -> %.4g J, smallest tet volume %.3g m^3\n",
           e0.elastic, e1.elastic, vmin);
    assert_true(last < first);
    assert_true(e1.elastic < 1e-3 * e0.elastic);
    /* Rest volume of a tet: (0.25^3) / 6. */
    assert_true(vmin > 0.5 * 0.25 * 0.25 * 0.25 / 6.0);
    free(x);
    defsim_world_destroy(w);
}

/* Plain neo-Hookean has no energy for inverted tets: a beam thrown against its clamp at a large
 * step must be kept out of inversion by the line search, never return NaN. */
static void test_neohookean_line_search(void **state)
{
    (void)state;
    defsim_world *w = nc_world(0.0, 1, 1e-6, 50, DEFSIM_PROJECTION_CLAMP);
    defsim_body_id b = tu_add_box(w, DEFSIM_MODEL_NEOHOOKEAN, 6, 2, 2, BEAM_LO, BEAM_HI, 1e5,
                                  0.3, 1000);
    tu_pin_below(w, b, 0, 0.0);
    int n = defsim_world_vertex_count(w);
    double *v = tu_velocities(w);
    for (int i = 0; i < n; ++i) v[3 * i] = -20.0;
    TU_OK(defsim_world_set_state(w, NULL, v));
    for (int s = 0; s < 20; ++s) {
        step_ok(w, 0.05);
        assert_true(min_tet_volume(w, 6, 2, 2, BEAM_LO, BEAM_HI) > 0.0);
    }
    defsim_stats st = {.size = sizeof st};
    TU_OK(defsim_world_stats(w, &st));
    printf("neo-Hookean slam: %lld Newton iterations, %lld line-search backtracks\n",
           (long long)tu_bstat(w, "newton_iterations"), (long long)tu_bstat(w, "line_search_backtracks"));
    assert_true(tu_bstat(w, "line_search_backtracks") > 0);

    /* A state the model has no energy for (mirrored: every tet inverted) cannot be stepped:
     * NOT_CONVERGED, nothing changes. */
    double *x = tu_positions(w);
    for (int i = 0; i < n; ++i) x[3 * i + 1] = -x[3 * i + 1];
    TU_OK(defsim_world_set_state(w, x, NULL));
    double *xb = tu_positions(w);
    assert_int_equal(defsim_world_step(w, 0.05), DEFSIM_ERR_NOT_CONVERGED);
    double *xa = tu_positions(w);
    assert_memory_equal(xa, xb, 3 * (size_t)n * sizeof *xa);
    free(x);
    free(xa);
    free(xb);
    free(v);
    defsim_world_destroy(w);
}

/* ------------------------------------------------------------------------------------------ */
/* Failure and roll-back; the world stays usable. */

static void test_not_converged_rolls_back(void **state)
{
    (void)state;
    const double lo[3] = {0, 0, 0}, hi[3] = {1, 1, 1};
    defsim_world *w = nc_world(0.0, 1, 1e-12, 1, DEFSIM_PROJECTION_CLAMP);
    tu_add_box(w, DEFSIM_MODEL_STABLE_NEOHOOKEAN, 2, 2, 2, lo, hi, 1e5, 0.3, 1000);
    const int n = defsim_world_vertex_count(w);
    double *rest = tu_positions(w), *x = tu_positions(w), *v = tu_velocities(w);
    unsigned long long seed = 3;
    for (int i = 0; i < 3 * n; ++i) {
        x[i] += 0.1 * tu_rand(&seed);
        v[i] = tu_rand(&seed);
    }
    TU_OK(defsim_world_set_state(w, x, v));
    double *xb = tu_positions(w), *vb = tu_velocities(w);
    const double t0 = defsim_world_time(w);
    assert_int_equal(defsim_world_step(w, 0.05), DEFSIM_ERR_NOT_CONVERGED);
    assert_true(defsim_world_last_error(w)[0] != '\0');
    double *xa = tu_positions(w), *va = tu_velocities(w);
    assert_memory_equal(xa, xb, 3 * (size_t)n * sizeof *xa);
    assert_memory_equal(va, vb, 3 * (size_t)n * sizeof *va);
    assert_true(defsim_world_time(w) == t0);
    defsim_stats s = {.size = sizeof s};
    TU_OK(defsim_world_stats(w, &s));
    assert_int_equal(s.failed_steps, 1);
    assert_int_equal(tu_bstat(w, "convergence_failures"), 1);
    assert_int_equal(s.steps, 0);

    /* Usable afterwards: a rigid translation is the exact solution of the first iterate
     * (y = x + h v has no strain), so one iteration converges. */
    for (int i = 0; i < 3 * n; ++i) v[i] = (i % 3 == 0) ? 0.5 : -0.25;
    TU_OK(defsim_world_set_state(w, rest, v));
    step_ok(w, 0.05);
    free(xa);
    xa = tu_positions(w);
    for (int i = 0; i < 3 * n; ++i) assert_true(fabs(xa[i] - (rest[i] + 0.05 * v[i])) < 1e-12);
    free(rest); free(x); free(v); free(xb); free(vb); free(xa); free(va);
    defsim_world_destroy(w);
}

/* A world whose every vertex is pinned has no free DOF: steps succeed and nothing moves. */
static void test_all_pinned(void **state)
{
    (void)state;
    const double lo[3] = {0, 0, 0}, hi[3] = {1, 1, 1};
    defsim_world *w = nc_world(-9.81, 1, 1e-6, 50, DEFSIM_PROJECTION_CLAMP);
    defsim_body_id b = tu_add_box(w, DEFSIM_MODEL_COROTATED, 1, 1, 1, lo, hi, 1e5, 0.3, 1000);
    assert_int_equal(tu_pin_below(w, b, 0, 10.0), 8);
    double *x0 = tu_positions(w);
    step_ok(w, 0.1);
    double *x = tu_positions(w);
    assert_memory_equal(x, x0, 24 * sizeof *x);
    free(x0);
    free(x);
    defsim_world_destroy(w);
}

/* ------------------------------------------------------------------------------------------ */
/* One step from a strongly compressed state: the minimiser does not depend on how (or whether)
 * the Hessian is projected, nor on the factorisation and ordering; only the path does. */

static int64_t last_clamped;   /* clamped_iterations of the last one_step_h */

static const char *one_step_backend;   /* NULL: newton_cholmod */

static double *one_step_h(defsim_projection proj, double h, int64_t *iterations)
{
    const double lo[3] = {0, 0, 0}, hi[3] = {1, 0.5, 0.5};
    defsim_world *w = one_step_backend
                          ? tu_implicit_world(one_step_backend, -9.81, 1, 1e-12, 100, proj)
                          : nc_world(-9.81, 1, 1e-12, 100, proj);
    defsim_body_id b = tu_add_box(w, DEFSIM_MODEL_STABLE_NEOHOOKEAN, 4, 2, 2, lo, hi, 1e5, 0.4,
                                  1000);
    tu_pin_below(w, b, 0, 0.0);
    const int n = defsim_world_vertex_count(w);
    double *x = tu_positions(w);
    for (int i = 0; i < n; ++i) x[3 * i] *= 0.6;   /* compressed along the beam to 60 % */
    TU_OK(defsim_world_set_state(w, x, NULL));
    step_ok(w, h);
    free(x);
    x = tu_positions(w);
    defsim_stats s = {.size = sizeof s};
    TU_OK(defsim_world_stats(w, &s));
    if (iterations) *iterations = tu_bstat(w, "newton_iterations");
    last_clamped = tu_bstat(w, "clamped_iterations");
    defsim_world_destroy(w);
    return x;
}

static double *one_step(defsim_projection proj, int64_t *iterations)
{
    return one_step_h(proj, 0.02, iterations);
}

static void test_projections_agree(void **state)
{
    (void)state;
    int64_t it[4];
    double *a = one_step(DEFSIM_PROJECTION_CLAMP, &it[0]);
    double *b = one_step(DEFSIM_PROJECTION_ABS, &it[1]);
    double *c = one_step(DEFSIM_PROJECTION_NONE, &it[2]);
    double *d = one_step(DEFSIM_PROJECTION_AUTO, &it[3]);
    const int n = 5 * 3 * 3;
    double dab = 0.0, dac = 0.0, dad = 0.0, moved = 0.0;
    for (int i = 0; i < 3 * n; ++i) {
        dab = fmax(dab, fabs(a[i] - b[i]));
        dac = fmax(dac, fabs(a[i] - c[i]));
        dad = fmax(dad, fabs(a[i] - d[i]));
    }
    double *x0 = malloc(3 * (size_t)n * sizeof *x0);
    {
        const double lo[3] = {0, 0, 0}, hi[3] = {1, 0.5, 0.5};
        defsim_mesh m = {.size = sizeof m};
        TU_OK(defsim_mesh_box(lo, hi, 4, 2, 2, &m));
        for (int i = 0; i < 3 * n; ++i) x0[i] = m.positions[i] * (i % 3 == 0 ? 0.6 : 1.0);
        defsim_mesh_free(&m);
    }
    for (int i = 0; i < 3 * n; ++i) moved = fmax(moved, fabs(a[i] - x0[i]));
    printf("projections: Newton iterations clamp %lld, abs %lld, none %lld, auto %lld; max "
           "differences %.2e, %.2e, %.2e m (step moved %.3f m)\n", (long long)it[0],
           (long long)it[1], (long long)it[2], (long long)it[3], dab, dac, dad, moved);
    assert_true(moved > 1e-2);
    assert_true(dab < 1e-9 && dac < 1e-9 && dad < 1e-9);
    free(a); free(b); free(c); free(d); free(x0);
}

/* The other schemes of the implicit core (newmark, bdf2) have projection auto too: from the
 * compressed beam, the step's minimiser is the clamped one's, in fewer iterations. */
static void test_auto_other_schemes(void **state)
{
    (void)state;
    static const char *const schemes[] = {"newmark", "bdf2"};
    const int n = 5 * 3 * 3;
    for (int k = 0; k < 2; ++k) {
        if (!tu_available(schemes[k])) {
            if (tu_built(schemes[k])) fail_msg("%s is built but not available", schemes[k]);
            continue;
        }
        one_step_backend = schemes[k];
        int64_t it_clamp, it_auto;
        double *a = one_step(DEFSIM_PROJECTION_CLAMP, &it_clamp);
        double *b = one_step(DEFSIM_PROJECTION_AUTO, &it_auto);
        double d = 0.0;
        for (int i = 0; i < 3 * n; ++i) d = fmax(d, fabs(a[i] - b[i]));
        printf("%s: Newton iterations clamp %lld, auto %lld; difference %.2e m\n", schemes[k],
               (long long)it_clamp, (long long)it_auto, d);
        assert_true(d < 1e-9);
        assert_true(it_auto < it_clamp);
        free(a);
        free(b);
    }
    one_step_backend = NULL;
}

/* A rope of 8 springs whose pinned ends are pushed to 80 % of its length, seeded with a small
 * bow: one step buckles it. Returns the positions after the step; iterations, clamped
 * iterations and extrapolations through the pointers. */
static double *buckle_step(defsim_projection proj, double k, double h, int64_t *its,
                           int64_t *clamped, int64_t *extrapolated)
{
    enum { NS = 8, NV = NS + 1 };
    defsim_world *w = nc_world(0.0, 1, 1e-12, 200, proj);
    double rest[3 * NV], x[3 * NV];
    int32_t springs[2 * NS];
    for (int i = 0; i < NV; ++i) {
        rest[3 * i] = (double)i / NS;
        rest[3 * i + 1] = rest[3 * i + 2] = 0.0;
        x[3 * i] = 0.8 * rest[3 * i];
        x[3 * i + 1] = 1e-3 * sin(3.141592653589793 * i / NS);
        x[3 * i + 2] = 0.0;
    }
    for (int i = 0; i < NS; ++i) {
        springs[2 * i] = i;
        springs[2 * i + 1] = i + 1;
    }
    defsim_body_def d;
    defsim_body_def_init(&d, sizeof d);
    defsim_material_init(&d.material, sizeof d.material, DEFSIM_MODEL_SPRING);
    d.material.stiffness = k;
    d.material.vertex_mass = 0.01;
    d.rest_positions = rest;
    d.initial_positions = x;
    d.vertex_count = NV;
    d.springs = springs;
    d.spring_count = NS;
    defsim_body_id b;
    if (defsim_world_add_body(w, &d, &b) != DEFSIM_OK)
        fail_msg("add body: %s", defsim_world_last_error(w));
    const int32_t ends[2] = {0, NS};
    TU_OK(defsim_body_pin(w, b, ends, 2));
    step_ok(w, h);
    double *out = tu_positions(w);
    *its = tu_bstat(w, "newton_iterations");
    *clamped = tu_bstat(w, "clamped_iterations");
    *extrapolated = tu_bstat(w, "extrapolations");
    defsim_world_destroy(w);
    return out;
}

/* Projection auto's extrapolation (implicit_core README, line search): at h = 0.1 s the
 * rope's exact Hessian is indefinite until it has bowed out, and the clamped model sees only
 * inertia across it, so its full steps find less curvature than it predicts. Measured: clamp 53
 * iterations, auto before the extrapolation 30 (24 of them clamped), auto now 23 (17 clamped,
 * 9 extrapolated); the same minimiser, to 1e-12 m, the rope bowed out by 4.25 cm. */
static void test_auto_extrapolates(void **state)
{
    (void)state;
    int64_t it[2], cl[2], ex[2];
    double *xc = buckle_step(DEFSIM_PROJECTION_CLAMP, 10.0, 0.1, &it[0], &cl[0], &ex[0]);
    double *xa = buckle_step(DEFSIM_PROJECTION_AUTO, 10.0, 0.1, &it[1], &cl[1], &ex[1]);
    double d = 0.0, bow = 0.0;
    for (int i = 0; i < 27; ++i) d = fmax(d, fabs(xc[i] - xa[i]));
    for (int i = 0; i < 9; ++i) bow = fmax(bow, fabs(xa[3 * i + 1]));
    printf("buckling rope: clamp %lld iterations; auto %lld (%lld clamped, %lld extrapolated); "
           "difference %.2e m, bow %.4f m\n", (long long)it[0], (long long)it[1],
           (long long)cl[1], (long long)ex[1], d, bow);
    assert_true(bow > 0.04 && bow < 0.05);   /* buckled: from 1 mm to 4.25 cm */
    assert_true(d < 1e-9);
    assert_int_equal(ex[0], 0);               /* clamp never extrapolates */
    assert_true(ex[1] > 0);
    assert_true(it[1] <= 24);                 /* 30 before the extrapolation */
    assert_true(it[0] >= 50);
    free(xc);
    free(xa);
}

/* At h = 1 s the exact (PROJECTION_NONE) Hessian of the compressed beam is indefinite even
 * with M / h^2: the solver shifts its diagonal until the factorisation is positive definite
 * (CHOLMOD reports NOT_POSDEF in supernodal mode; in simplicial LDL' mode a pivot is <= 0), and
 * still reaches the minimiser that the projected Hessians reach. */
static void test_indefinite_exact_hessian(void **state)
{
    (void)state;
    const char *factor[2] = {"supernodal", "simplicial"};
    const int n = 5 * 3 * 3;
    for (int f = 0; f < 2; ++f) {
        setenv("DEFSIM_CHOLMOD_FACTOR", factor[f], 1);
        int64_t it_none, it_clamp, it_auto;
        double *a = one_step_h(DEFSIM_PROJECTION_NONE, 1.0, &it_none);
        double *b = one_step_h(DEFSIM_PROJECTION_CLAMP, 1.0, &it_clamp);
        double *c = one_step_h(DEFSIM_PROJECTION_AUTO, 1.0, &it_auto);
        double d = 0.0, dc = 0.0;
        for (int i = 0; i < 3 * n; ++i) {
            d = fmax(d, fabs(a[i] - b[i]));
            dc = fmax(dc, fabs(c[i] - b[i]));
        }
        printf("h = 1 s, %s: Newton iterations none %lld, clamp %lld, auto %lld (%lld of them "
               "clamped); differences %.2e, %.2e m\n", factor[f], (long long)it_none,
               (long long)it_clamp, (long long)it_auto, (long long)last_clamped, d, dc);
        assert_true(d < 1e-9 && dc < 1e-9);
        /* auto met the indefinite exact matrix and used the clamped one there */
        assert_true(last_clamped > 0 && last_clamped < it_auto);
        free(a);
        free(b);
        free(c);
    }
    unsetenv("DEFSIM_CHOLMOD_FACTOR");
}

static void test_factorisations_agree(void **state)
{
    (void)state;
    const char *factor[3] = {"supernodal", "simplicial", "auto"};
    const char *order[3] = {"amd", "metis", "best"};
    double *ref = one_step(DEFSIM_PROJECTION_CLAMP, NULL);
    const int n = 5 * 3 * 3;
    for (int f = 0; f < 3; ++f)
        for (int o = 0; o < 3; ++o) {
            setenv("DEFSIM_CHOLMOD_FACTOR", factor[f], 1);
            setenv("DEFSIM_CHOLMOD_ORDERING", order[o], 1);
            double *x = one_step(DEFSIM_PROJECTION_CLAMP, NULL);
            double d = 0.0;
            for (int i = 0; i < 3 * n; ++i) d = fmax(d, fabs(x[i] - ref[i]));
            assert_true(d < 1e-9);
            free(x);
        }
    unsetenv("DEFSIM_CHOLMOD_FACTOR");
    unsetenv("DEFSIM_CHOLMOD_ORDERING");
    free(ref);
}

/* ------------------------------------------------------------------------------------------ */
/* The convergence test is scale-free: the chain in units 1024x larger (positions, gravity), or
 * run 8x slower (h x 8, k and g / 64), takes the same Newton iterations and gives the same
 * trajectory bit for bit (powers of two scale exactly in floating point). */

static void scaled_chain(double c, double s, int steps, double *x_out, int64_t *iters)
{
    defsim_world_def d;
    defsim_world_def_init(&d, sizeof d);
    d.backend = NC;
    d.gravity[1] = CH_G * c / (s * s);
    d.num_threads = 1;
    defsim_world *w = NULL;
    TU_OK(defsim_world_create(&d, &w));
    tu_backend_option(w, NC, "tolerance", 1e-8);
    add_chain(w, c, CH_K / (s * s), 0.0, 0.0);
    for (int k = 0; k < steps; ++k) step_ok(w, 0.01 * s);
    TU_OK(defsim_world_get_positions(w, x_out, CH_N));
    defsim_stats st = {.size = sizeof st};
    TU_OK(defsim_world_stats(w, &st));
    *iters = tu_bstat(w, "newton_iterations");
    defsim_world_destroy(w);
}

static void test_scale_free(void **state)
{
    (void)state;
    double a[3 * CH_N], b[3 * CH_N], c[3 * CH_N];
    int64_t ia, ib, ic;
    scaled_chain(1.0, 1.0, 60, a, &ia);
    scaled_chain(1024.0, 1.0, 60, b, &ib);
    scaled_chain(1.0, 8.0, 60, c, &ic);
    printf("scale-free: Newton iterations %lld (m, s), %lld (x1024 length), %lld (x8 time)\n",
           (long long)ia, (long long)ib, (long long)ic);
    assert_true(ia > 60);
    assert_int_equal(ia, ib);
    assert_int_equal(ia, ic);
    for (int i = 0; i < 3 * CH_N; ++i) {
        assert_true(b[i] == 1024.0 * a[i]);
        assert_true(c[i] == a[i]);
    }
}

/* ------------------------------------------------------------------------------------------ */
/* Determinism: the same run twice with 2 threads (coloured assembly, CHOLMOD, BLAS) is
 * bit-identical. */

static double *determinism_run(void)
{
    defsim_world *w = nc_world(-9.81, 2, 1e-8, 50, DEFSIM_PROJECTION_CLAMP);
    const double hi[3] = {3, 1, 1}, lo[3] = {0, 0, 0};
    defsim_body_id b = tu_add_box(w, DEFSIM_MODEL_STABLE_NEOHOOKEAN, 12, 4, 4, lo, hi, 1e6, 0.3,
                                  1000);
    tu_pin_below(w, b, 0, 0.0);
    for (int s = 0; s < 5; ++s) step_ok(w, 1.0 / 60.0);
    double *x = tu_positions(w);
    defsim_world_destroy(w);
    return x;
}

static void test_determinism(void **state)
{
    (void)state;
    double *a = determinism_run(), *b = determinism_run();
    assert_memory_equal(a, b, 3 * 13 * 5 * 5 * sizeof *a);
    free(a);
    free(b);
}

/* Worlds stepped concurrently from several threads, with different thread counts (so that the
 * process-wide BLAS thread count is contended) and concurrent symbolic analyses, give exactly
 * what each gives alone. */
typedef struct concurrent_job {
    int threads;
    double *x;
} concurrent_job;

static double *concurrent_run(int threads)
{
    defsim_world *w = nc_world(-9.81, threads, 1e-8, 50, DEFSIM_PROJECTION_CLAMP);
    const double hi[3] = {2, 0.5, 0.5}, lo[3] = {0, 0, 0};
    defsim_body_id b = tu_add_box(w, DEFSIM_MODEL_STABLE_NEOHOOKEAN, 8, 2, 2, lo, hi, 1e6, 0.3,
                                  1000);
    tu_pin_below(w, b, 0, 0.0);
    for (int s = 0; s < 8; ++s)
        if (defsim_world_step(w, 1.0 / 60.0) != DEFSIM_OK) {
            defsim_world_destroy(w);
            return NULL;
        }
    double *x = tu_positions(w);
    defsim_world_destroy(w);
    return x;
}

static void *concurrent_thread(void *arg)
{
    concurrent_job *job = arg;
    job->x = concurrent_run(job->threads);
    return NULL;
}

static void test_concurrent_worlds(void **state)
{
    (void)state;
    enum { JOBS = 4 };
    const int n = 9 * 3 * 3;
    double *serial[2] = {concurrent_run(1), concurrent_run(2)};
    assert_non_null(serial[0]);
    assert_non_null(serial[1]);
    concurrent_job jobs[JOBS];
    pthread_t tid[JOBS];
    for (int k = 0; k < JOBS; ++k) {
        jobs[k].threads = 1 + k % 2;
        jobs[k].x = NULL;
        assert_int_equal(pthread_create(&tid[k], NULL, concurrent_thread, &jobs[k]), 0);
    }
    for (int k = 0; k < JOBS; ++k) assert_int_equal(pthread_join(tid[k], NULL), 0);
    for (int k = 0; k < JOBS; ++k) {
        assert_non_null(jobs[k].x);
        assert_memory_equal(jobs[k].x, serial[k % 2], 3 * (size_t)n * sizeof(double));
        free(jobs[k].x);
    }
    free(serial[0]);
    free(serial[1]);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_loaded_on_demand),
        cmocka_unit_test(test_chain_vs_dense_newton),
        cmocka_unit_test(test_chain_rayleigh_damping),
        cmocka_unit_test(test_convergence_order),
        cmocka_unit_test(test_stiff_beam),
        cmocka_unit_test(test_inverted_beam),
        cmocka_unit_test(test_neohookean_line_search),
        cmocka_unit_test(test_not_converged_rolls_back),
        cmocka_unit_test(test_all_pinned),
        cmocka_unit_test(test_projections_agree),
        cmocka_unit_test(test_auto_other_schemes),
        cmocka_unit_test(test_auto_extrapolates),
        cmocka_unit_test(test_indefinite_exact_hessian),
        cmocka_unit_test(test_factorisations_agree),
        cmocka_unit_test(test_scale_free),
        cmocka_unit_test(test_determinism),
        cmocka_unit_test(test_concurrent_worlds),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
