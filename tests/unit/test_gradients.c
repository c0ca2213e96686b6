/* SPDX-License-Identifier: MIT */
/*
 * Gradients through a run (issue 25, docs/gradients.md): the tape's backward pass against the
 * analytic derivatives of a free fall and against central finite differences of whole runs
 * (the cantilever on a small mesh: E, nu, density, mass and stiffness damping, x0, v0; every
 * tet model; springs), on every differentiable backend; checkpointing against storing every
 * state; bad input (clear statuses, the world unchanged).
 */
#include "test_util.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static const char *NC = "newton_cholmod";
static const char *SE = "symplectic_euler";
static const char *EE = "explicit_euler";
static const char *NM = "newmark";

static int implicit(const char *backend)
{
    return strcmp(backend, NC) == 0 || strcmp(backend, NM) == 0;
}

/* A world of the backend, gravity gy along y, one thread; implicit ones converged tightly (the
 * implicit function theorem differentiates the exact solution of a step). */
static defsim_world *world_for(const char *backend, double gy)
{
    return implicit(backend) ? tu_implicit_world(backend, gy, 1, 1e-13, 60, DEFSIM_PROJECTION_CLAMP)
                             : tu_world(backend, gy, 1);
}

/* A run: backend, material, mesh and steps. */
typedef struct scene {
    const char *backend;
    defsim_model model;
    double E, nu, rho, alpha, beta;
    int nx, ny, nz;
    double len;               /* along x (m); 1 x 1 m across */
    double h;
    int steps;
    int pin;                  /* clamp the face x = 0 */
    double gy;
    double stretch;           /* the start's positions: rest scaled by this (0: 1) */
} scene;

/* The parameters the finite differences move. */
enum { P_E, P_NU, P_RHO, P_ALPHA, P_BETA, P_X0, P_V0, P_COUNT };
static const char *const pname[P_COUNT] = {"youngs_modulus", "poisson_ratio", "density",
                                           "mass_damping", "stiffness_damping",
                                           "initial_positions", "initial_velocities"};

static defsim_world *make(const scene *sc, const double *dp, const double *dx0,
                          const double *dv0, double eps)
{
    defsim_world *w = world_for(sc->backend, sc->gy);
    defsim_material m;
    defsim_material_init(&m, sizeof m, sc->model);
    m.youngs_modulus = sc->E * (1.0 + (dp ? dp[P_E] * eps : 0.0));
    m.poisson_ratio = sc->nu + (dp ? dp[P_NU] * eps : 0.0);
    m.density = sc->rho * (1.0 + (dp ? dp[P_RHO] * eps : 0.0));
    m.mass_damping = sc->alpha + (dp ? dp[P_ALPHA] * eps : 0.0);
    m.stiffness_damping = sc->beta + (dp ? dp[P_BETA] * eps : 0.0);
    const double lo[3] = {0, 0, 0}, hi[3] = {sc->len, 1, 1};
    defsim_body_id b = tu_add_box_material(w, sc->nx, sc->ny, sc->nz, lo, hi, &m);
    if (sc->pin) tu_pin_below(w, b, 0, 0.0);
    /* a start away from rest: a fixed twist of the velocities, and the direction's move */
    const int n = defsim_world_vertex_count(w);
    double *x = tu_positions(w), *v = calloc(3 * (size_t)n, sizeof *v);
    uint8_t *pinned = malloc((size_t)n);
    TU_OK(defsim_world_get_pinned(w, pinned, n));
    const double stretch = sc->stretch > 0.0 ? sc->stretch : 1.0;
    for (int i = 0; i < n; ++i) {
        for (int c = 0; c < 3; ++c) x[3 * i + c] *= stretch;
        if (!pinned[i]) {
            v[3 * i + 1] = 0.3 * x[3 * i] - 0.2 * x[3 * i + 2];
            v[3 * i + 2] = 0.1 * x[3 * i + 1] * x[3 * i];
        }
        for (int c = 0; c < 3; ++c) {
            if (dx0) x[3 * i + c] += eps * dx0[3 * i + c];
            if (dv0 && !pinned[i]) v[3 * i + c] += eps * dv0[3 * i + c];
        }
    }
    TU_OK(defsim_world_set_state(w, x, v));
    free(x);
    free(v);
    free(pinned);
    return w;
}

/* The loss's term of state s: cx_s . x_s + cv_s . v_s with the world's state now. */
static double state_loss(const defsim_world *w, const double *cx, const double *cv, int s)
{
    const int n = defsim_world_vertex_count(w), n3 = 3 * n;
    double *x = malloc((size_t)n3 * sizeof *x), *v = malloc((size_t)n3 * sizeof *v), L = 0.0;
    TU_OK(defsim_world_get_positions(w, x, n));
    TU_OK(defsim_world_get_velocities(w, v, n));
    const double *wx = cx + (size_t)s * n3, *wv = cv + (size_t)s * n3;
    for (int i = 0; i < n3; ++i) L += wx[i] * x[i] + wv[i] * v[i];
    free(x);
    free(v);
    return L;
}

/* L = sum_s cx_s . x_s + cv_s . v_s over the run's states s = 0 .. N. */
static double run_loss(const scene *sc, defsim_world *w, const double *cx, const double *cv)
{
    double L = 0.0;
    for (int s = 0; s <= sc->steps; ++s) {
        if (s > 0) {
            const defsim_status st = defsim_world_step(w, sc->h);
            if (st != DEFSIM_OK) fail_msg("step %d: %s", s, defsim_world_last_error(w));
        }
        L += state_loss(w, cx, cv, s);
    }
    return L;
}

/* The loss's weights: at the middle and last states (positions), last (velocities). */
static void weights(const scene *sc, int n, double **cx, double **cv)
{
    const size_t n3 = 3 * (size_t)n, all = n3 * (size_t)(sc->steps + 1);
    *cx = calloc(all, sizeof **cx);
    *cv = calloc(all, sizeof **cv);
    unsigned long long seed = 7;
    for (size_t i = 0; i < n3; ++i) {
        (*cx)[n3 * (size_t)(sc->steps / 2) + i] = tu_rand(&seed);
        (*cx)[n3 * (size_t)sc->steps + i] = tu_rand(&seed);
        (*cv)[n3 * (size_t)sc->steps + i] = 0.1 * tu_rand(&seed);
    }
}

/* The vertex count of sc's world and its loss's weights (weights). */
static int loss_weights(const scene *sc, double **cx, double **cv)
{
    defsim_world *w = make(sc, NULL, NULL, NULL, 0.0);
    const int n = defsim_world_vertex_count(w);
    defsim_world_destroy(w);
    weights(sc, n, cx, cv);
    return n;
}

typedef struct grads {
    double body[5];           /* E, nu, rho, alpha, beta of the one body */
    double *x0, *v0;
    int n;
} grads;

/* Records the run of sc with the given interval and runs it backward for the loss's weights. */
static void tape_grads(const scene *sc, int32_t interval, int64_t max_bytes, const double *cx,
                       const double *cv, grads *g, defsim_tape_stats *ts)
{
    defsim_world *w = make(sc, NULL, NULL, NULL, 0.0);
    const int n = defsim_world_vertex_count(w);
    defsim_tape_def d;
    defsim_tape_def_init(&d, sizeof d);
    d.interval = interval;
    if (max_bytes > 0) d.max_bytes = max_bytes;
    defsim_tape *t = NULL;
    defsim_status st = defsim_world_record(w, &d, &t);
    if (st != DEFSIM_OK) fail_msg("record: %s", defsim_world_last_error(w));
    for (int s = 0; s < sc->steps; ++s) TU_OK(defsim_world_step(w, sc->h));
    g->n = n;
    g->x0 = malloc(3 * (size_t)n * sizeof *g->x0);
    g->v0 = malloc(3 * (size_t)n * sizeof *g->v0);
    defsim_gradient out[P_COUNT];
    for (int k = 0; k < 5; ++k) out[k] = (defsim_gradient){pname[k], &g->body[k], 1};
    out[P_X0] = (defsim_gradient){pname[P_X0], g->x0, 3 * (int64_t)n};
    out[P_V0] = (defsim_gradient){pname[P_V0], g->v0, 3 * (int64_t)n};
    st = defsim_tape_backward(t, cx, cv, 3 * (int64_t)n * (sc->steps + 1), out, P_COUNT);
    if (st != DEFSIM_OK) fail_msg("backward: %s", defsim_tape_last_error(t));
    if (ts) {
        ts->size = sizeof *ts;
        TU_OK(defsim_tape_get_stats(t, ts));
    }
    defsim_tape_destroy(t);
    defsim_world_destroy(w);
}

static void grads_free(grads *g)
{
    free(g->x0);
    free(g->v0);
}

/* Central differences of the loss along parameter p (x0, v0: along dir), step eps. */
static double fd(const scene *sc, int p, const double *dir, double eps, const double *cx,
                 const double *cv)
{
    double L[2];
    for (int k = 0; k < 2; ++k) {
        const double e = k == 0 ? eps : -eps;
        double dp[P_COUNT] = {0};
        if (p < P_X0) dp[p] = 1.0;
        defsim_world *w = make(sc, dp, p == P_X0 ? dir : NULL, p == P_V0 ? dir : NULL, e);
        L[k] = run_loss(sc, w, cx, cv);
        defsim_world_destroy(w);
    }
    return (L[0] - L[1]) / (2.0 * eps);
}

/* The tape's gradient along parameter p against central differences. */
static void check_fd(const scene *sc, const grads *g, const double *cx, const double *cv,
                     const int *which, int nwhich, double rtol, const char *what)
{
    const int n3 = 3 * g->n;
    double *dir = malloc((size_t)n3 * sizeof *dir);
    unsigned long long seed = 99;
    for (int i = 0; i < n3; ++i) dir[i] = tu_rand(&seed);
    for (int q = 0; q < nwhich; ++q) {
        const int p = which[q];
        /* relative steps for E and density (make scales them), absolute for the others */
        const double eps = p == P_E || p == P_RHO ? 1e-5
                           : p == P_NU            ? 1e-6
                           : p == P_ALPHA         ? 1e-5
                           : p == P_BETA          ? 1e-7
                                                  : 1e-6;
        double an;
        if (p < P_X0) {
            an = g->body[p] * (p == P_E ? sc->E : p == P_RHO ? sc->rho : 1.0);
        } else {
            const double *gg = p == P_X0 ? g->x0 : g->v0;
            an = 0.0;
            for (int i = 0; i < n3; ++i) an += gg[i] * dir[i];
        }
        const double num = fd(sc, p, dir, eps, cx, cv);
        const double rel = fabs(an - num) / fmax(fabs(num), 1e-300);
        printf("%s d/d%s: tape %.12e  central differences %.12e  relative %.2e\n", what,
               pname[p], an, num, rel);
        if (!(rel <= rtol))
            fail_msg("%s: d/d%s relative error %.3g > %.3g", what, pname[p], rel, rtol);
    }
    free(dir);
}

/* ------------------------------------------------------------------------------------------ */

/* A free fall (no pins, no deformation): L = sum_i m_i y_i / M at the last state (the centre of
 * mass, which no internal force moves): dL/dx0_y = m_i/M, dL/dv0_y = m_i/M dx_N/dv0 and
 * dL/dalpha = dx_N/dalpha of
 * the scalar recurrence (symplectic Euler: v' = (1 - h a) v + h g, x' = x + h v'; backward
 * Euler: v' = (v + h g)/(1 + h a), x' = x + h v'), differentiated exactly by forward mode
 * here; dL/dE = dL/dnu = 0 (no strain) and dL/drho = 0 (the fall does not depend on mass). */
static void free_fall(const char *backend)
{
    const double a = 0.5, gy = -9.81, h = 0.01, v0y = 0.0;
    const int N = 25;
    scene sc = {backend, DEFSIM_MODEL_COROTATED, 1e5, 0.3, 1000, a, 0.0, 1, 1, 1, 1.0, h, N, 0,
                gy, 0.0};
    defsim_world *w = tu_world(backend, gy, 1);
    if (strcmp(backend, NC) == 0) tu_backend_option(w, backend, "tolerance", 1e-13);
    defsim_material m;
    defsim_material_init(&m, sizeof m, sc.model);
    m.youngs_modulus = sc.E;
    m.poisson_ratio = sc.nu;
    m.density = sc.rho;
    m.mass_damping = a;
    const double lo[3] = {0, 0, 0}, hi[3] = {1, 1, 1};
    tu_add_box_material(w, 1, 1, 1, lo, hi, &m);
    const int n = defsim_world_vertex_count(w);
    defsim_tape *t = NULL;
    TU_OK(defsim_world_record(w, NULL, &t));
    for (int s = 0; s < N; ++s) TU_OK(defsim_world_step(w, h));
    /* L = sum_i m_i y_i / M (the weights are the host's constants) */
    double *dl = calloc(3 * (size_t)n * (N + 1), sizeof *dl);
    double *mass = malloc((size_t)n * sizeof *mass);
    TU_OK(defsim_world_get_masses(w, mass, n));
    double M = 0.0;
    for (int i = 0; i < n; ++i) M += mass[i];
    for (int i = 0; i < n; ++i) dl[3 * (size_t)n * N + 3 * i + 1] = mass[i] / M;
    double *gx = malloc(3 * (size_t)n * sizeof *gx), *gv = malloc(3 * (size_t)n * sizeof *gv);
    double gb[5];
    defsim_gradient out[P_COUNT];
    for (int k = 0; k < 5; ++k) out[k] = (defsim_gradient){pname[k], &gb[k], 1};
    out[P_X0] = (defsim_gradient){pname[P_X0], gx, 3 * (int64_t)n};
    out[P_V0] = (defsim_gradient){pname[P_V0], gv, 3 * (int64_t)n};
    TU_OK(defsim_tape_backward(t, dl, NULL, 3 * (int64_t)n * (N + 1), out, P_COUNT));
    /* the recurrence and its derivatives in v0 and alpha */
    const int se = strcmp(backend, NC) != 0, ee = strcmp(backend, EE) == 0;
    double v = v0y, dv_v0 = 1.0, dx_v0 = 0.0, dv_a = 0.0, dx_a = 0.0;
    for (int s = 0; s < N; ++s) {
        double vn, dvn_v0, dvn_a;
        if (ee) {   /* x moves with the old v */
            dx_v0 += h * dv_v0;
            dx_a += h * dv_a;
        }
        if (se) {
            vn = (1.0 - h * a) * v + h * gy;
            dvn_v0 = (1.0 - h * a) * dv_v0;
            dvn_a = (1.0 - h * a) * dv_a - h * v;
        } else {
            vn = (v + h * gy) / (1.0 + h * a);
            dvn_v0 = dv_v0 / (1.0 + h * a);
            dvn_a = dv_a / (1.0 + h * a) - h * vn / (1.0 + h * a);
        }
        v = vn;
        dv_v0 = dvn_v0;
        dv_a = dvn_a;
        if (!ee) {
            dx_v0 += h * dv_v0;
            dx_a += h * dv_a;
        }
    }
    double ex = 0.0, ev = 0.0, other = 0.0;
    for (int i = 0; i < n; ++i) {
        const double mi = mass[i] / M;
        ex = fmax(ex, fabs(gx[3 * i + 1] - mi) / mi);
        ev = fmax(ev, fabs(gv[3 * i + 1] - mi * dx_v0) / (mi * dx_v0));
        for (int c = 0; c < 3; c += 2)
            other = fmax(other, fmax(fabs(gx[3 * i + c]), fabs(gv[3 * i + c])));
    }
    const double ea = fabs(gb[P_ALPHA] - dx_a) / fabs(dx_a);
    printf("%s free fall: dL/dx0_y = m_i/M to %.2e, dL/dv0_y %.12f (analytic %.12f, rel %.2e), "
           "dL/dalpha %.12f (analytic %.12f, rel %.2e), dL/dE %.2e, dL/dnu %.2e, dL/drho %.2e, "
           "x and z parts %.2e\n",
           backend, ex, gv[1] * M / mass[0], dx_v0, ev, gb[P_ALPHA], dx_a, ea, gb[P_E], gb[P_NU],
           gb[P_RHO], other);
    assert_true(ex < 1e-9);
    assert_true(ev < 1e-9);
    assert_true(ea < 1e-9);
    assert_true(fabs(gb[P_E]) * sc.E < 1e-6 && fabs(gb[P_NU]) < 1e-6);
    assert_true(fabs(gb[P_RHO]) * sc.rho < 1e-6);
    assert_true(other < 1e-9);
    free(dl);
    free(mass);
    free(gx);
    free(gv);
    defsim_tape_destroy(t);
    defsim_world_destroy(w);
}

static void test_free_fall_symplectic(void **st)
{
    (void)st;
    free_fall(SE);
}

static void test_free_fall_explicit(void **st)
{
    (void)st;
    free_fall(EE);
}

static void test_free_fall_newton(void **st)
{
    (void)st;
    free_fall(NC);
}

/* The cantilever (tests/scenes/cantilever.json's beam and material, stable neo-Hookean, clamped
 * at x = 0) on a 3 x 1 x 1-cell mesh, with stiffness damping added: every parameter against
 * central differences. */
static void cantilever(const char *backend, double h, int steps)
{
    scene sc = {backend, DEFSIM_MODEL_STABLE_NEOHOOKEAN, 1e6, 0.3, 1000, 1.0, 0.0,
                3, 1, 1, 3.0, h, steps, 1, -9.81, 0.0};
    double *cx, *cv;
    const int n = loss_weights(&sc, &cx, &cv);
    grads g;
    tape_grads(&sc, 1, 0, cx, cv, &g, NULL);
    const int all[] = {P_E, P_NU, P_RHO, P_ALPHA, P_X0, P_V0};
    char what[64];
    snprintf(what, sizeof what, "cantilever %s", backend);
    check_fd(&sc, &g, cx, cv, all, P_COUNT - 1, 1e-5, what);
    grads_free(&g);
    /* stiffness damping's forces -beta K(x) v clamp each K_e to PSD: at rest K_e's rotation
     * modes have eigenvalue 0, where the clamp has a kink, so the damping forces are smooth in
     * x only away from rest. Started stretched by 2 %, every element is under tension (its
     * eigenvalues away from 0) for the run: there every parameter, beta included, is smooth. */
    sc.beta = 2e-3;
    sc.stretch = 1.02;
    free(cx);
    free(cv);
    weights(&sc, n, &cx, &cv);
    tape_grads(&sc, 1, 0, cx, cv, &g, NULL);
    const int damped[] = {P_E, P_NU, P_RHO, P_ALPHA, P_BETA, P_X0, P_V0};
    snprintf(what, sizeof what, "stretched cantilever with beta %s", backend);
    check_fd(&sc, &g, cx, cv, damped, P_COUNT, 1e-5, what);
    grads_free(&g);
    free(cx);
    free(cv);
}

static void test_cantilever_symplectic(void **st)
{
    (void)st;
    cantilever(SE, 2e-3, 40);
}

static void test_cantilever_explicit(void **st)
{
    (void)st;
    cantilever(EE, 1e-3, 30);
}

static void test_cantilever_newmark(void **st)
{
    (void)st;
    cantilever(NM, 1e-2, 12);
}

static void test_cantilever_newton(void **st)
{
    (void)st;
    cantilever(NC, 1e-2, 12);
}

/* Damping rates at zero (their terms are off): dL/dalpha and dL/dbeta still come, against
 * one-sided second-order differences (-3 L(0) + 4 L(e) - L(2e)) / 2e. */
static void test_damping_at_zero(void **st)
{
    (void)st;
    const char *backends[] = {SE, NC};
    for (int b = 0; b < 2; ++b) {
        scene sc = {backends[b], DEFSIM_MODEL_STABLE_NEOHOOKEAN, 1e6, 0.3, 1000, 0.0, 0.0,
                    3, 1, 1, 3.0, b == 0 ? 2e-3 : 1e-2, b == 0 ? 40 : 12, 1, -9.81, 1.02};
        double *cx, *cv;
        loss_weights(&sc, &cx, &cv);
        grads g;
        tape_grads(&sc, 1, 0, cx, cv, &g, NULL);
        for (int q = 0; q < 2; ++q) {
            const int p = q == 0 ? P_ALPHA : P_BETA;
            const double eps = p == P_ALPHA ? 1e-5 : 1e-7;
            double L[3];
            for (int k = 0; k < 3; ++k) {
                double dp[P_COUNT] = {0};
                dp[p] = 1.0;
                defsim_world *wk = make(&sc, dp, NULL, NULL, k * eps);
                L[k] = run_loss(&sc, wk, cx, cv);
                defsim_world_destroy(wk);
            }
            const double num = (-3.0 * L[0] + 4.0 * L[1] - L[2]) / (2.0 * eps);
            const double rel = fabs(g.body[p] - num) / fabs(num);
            printf("%s at zero: d/d%s tape %.12e  one-sided differences %.12e  relative %.2e\n",
                   backends[b], pname[p], g.body[p], num, rel);
            assert_true(rel < 1e-5);
        }
        grads_free(&g);
        free(cx);
        free(cv);
    }
}

/* Per-step held external forces as controls (defsim_world_set_external_forces before every
 * step, zero at some): the gradient "external_forces" against central differences along a
 * random direction of all the steps' forces, on every differentiable backend. */
static void test_external_forces(void **st)
{
    (void)st;
    const char *backends[] = {SE, EE, NC, NM};
    for (int b = 0; b < 4; ++b) {
        scene sc = {backends[b], DEFSIM_MODEL_COROTATED, 2e5, 0.3, 800, 0.5, 0.0, 2, 1, 1, 2.0,
                    b < 2 ? 2e-3 : 1e-2, b < 2 ? 20 : 8, 1, -9.81, 0.0};
        double *cx, *cv;
        const int n = loss_weights(&sc, &cx, &cv), n3 = 3 * n, N = sc.steps;
        double *F = malloc((size_t)N * n3 * sizeof *F), *D = malloc((size_t)N * n3 * sizeof *D);
        double *G = malloc((size_t)N * n3 * sizeof *G), *G3 = malloc((size_t)N * n3 * sizeof *G3);
        unsigned long long seed = 11;
        for (int i = 0; i < N * n3; ++i) {
            F[i] = (i / n3) % 3 == 1 ? 0.0 : 50.0 * tu_rand(&seed);   /* every third step none */
            D[i] = 50.0 * tu_rand(&seed);
        }
        /* passes 0 and 3 record (every state; every 3rd: the recomputation holds the forces) */
        double L[4], an = 0.0;
        for (int pass = 0; pass < 4; ++pass) {
            const double e = pass == 1 ? 1e-3 : pass == 2 ? -1e-3 : 0.0;
            defsim_world *w = make(&sc, NULL, NULL, NULL, 0.0);
            defsim_tape *t = NULL;
            defsim_tape_def td;
            defsim_tape_def_init(&td, sizeof td);
            td.interval = pass == 3 ? 3 : 1;
            if (pass == 0 || pass == 3) TU_OK(defsim_world_record(w, &td, &t));
            double *fj = malloc((size_t)n3 * sizeof *fj);
            L[pass] = 0.0;
            for (int s = 0; s <= N; ++s) {
                if (s > 0) TU_OK(defsim_world_step(w, sc.h));
                L[pass] += state_loss(w, cx, cv, s);
                if (s == N) break;
                const double *Fs = F + (size_t)s * n3, *Ds = D + (size_t)s * n3;
                for (int i = 0; i < n3; ++i) fj[i] = Fs[i] + e * Ds[i];
                TU_OK(defsim_world_set_external_forces(w, fj, n));
            }
            if (t) {
                defsim_gradient out = {"external_forces", pass == 0 ? G : G3, (int64_t)N * n3};
                TU_OK(defsim_tape_backward(t, cx, cv, (int64_t)n3 * (N + 1), &out, 1));
                for (int i = 0; pass == 0 && i < N * n3; ++i) an += G[i] * D[i];
                defsim_tape_destroy(t);
            }
            free(fj);
            defsim_world_destroy(w);
        }
        const double num = (L[1] - L[2]) / 2e-3, rel = fabs(an - num) / fabs(num);
        printf("%s d/dexternal_forces: tape %.12e  central differences %.12e  relative %.2e\n",
               backends[b], an, num, rel);
        assert_true(rel < 1e-5);
        assert_memory_equal(G, G3, (size_t)N * n3 * sizeof *G);
        free(F);
        free(D);
        free(G);
        free(G3);
        free(cx);
        free(cv);
    }
}

/* An attachment of the beam's far end to a world point that moves every step (its targets the
 * controls), with a damper: attachment_stiffness, attachment_damping, attachment_targets and x0
 * against central differences, on every differentiable backend. */
static double attached_run(const scene *sc, const double *cx, const double *cv, double k,
                           double c, const double *P, const double *D, double e,
                           const double *dx0, double ex, double *gk, double *gc, double *gp,
                           double *gx0)
{
    defsim_world *w = make(sc, NULL, dx0, NULL, ex);
    const int n = defsim_world_vertex_count(w), n3 = 3 * n, N = sc->steps;
    defsim_attachment_def ad;
    defsim_attachment_def_init(&ad, sizeof ad);
    TU_OK(defsim_world_body_at(w, 0, &ad.body));
    ad.vertex = n - 1;
    ad.stiffness = k;
    ad.damping = c;
    defsim_attachment_id id;
    TU_OK(defsim_world_add_attachment(w, &ad, &id));
    defsim_tape *t = NULL;
    if (gk) TU_OK(defsim_world_record(w, NULL, &t));
    double L = 0.0;
    for (int s = 0; s <= N; ++s) {
        if (s > 0) TU_OK(defsim_world_step(w, sc->h));
        L += state_loss(w, cx, cv, s);
        if (s == N) break;
        double p[3];
        for (int i = 0; i < 3; ++i) p[i] = P[3 * s + i] + e * D[3 * s + i];
        TU_OK(defsim_attachment_set_target(w, id, p));
    }
    if (t) {
        defsim_gradient out[4] = {{"attachment_stiffness", gk, 1}, {"attachment_damping", gc, 1},
                                  {"attachment_targets", gp, 3 * (int64_t)N},
                                  {"initial_positions", gx0, n3}};
        TU_OK(defsim_tape_backward(t, cx, cv, (int64_t)n3 * (N + 1), out, 4));
        defsim_tape_destroy(t);
    }
    defsim_world_destroy(w);
    return L;
}

static void test_attachments(void **st)
{
    (void)st;
    const char *backends[] = {SE, EE, NC, NM};
    for (int b = 0; b < 4; ++b) {
        scene sc = {backends[b], DEFSIM_MODEL_COROTATED, 2e5, 0.3, 800, 0.5, 0.0, 2, 1, 1, 2.0,
                    b < 2 ? 1e-3 : 1e-2, b < 2 ? 30 : 8, 1, -9.81, 0.0};
        double *cx, *cv;
        const int n = loss_weights(&sc, &cx, &cv), N = sc.steps;
        double P[3 * 64], D[3 * 64], dx0[3 * 64];
        assert_true(N <= 64 && n <= 64);
        unsigned long long seed = 21;
        for (int s = 0; s < N; ++s) {
            P[3 * s] = 2.0 + 0.1 * s * sc.h;   /* the far corner (2, 1, 1), pulled out and up */
            P[3 * s + 1] = 1.0 + 2.0 * s * sc.h;
            P[3 * s + 2] = 1.0;
            for (int i = 0; i < 3; ++i) D[3 * s + i] = tu_rand(&seed);
        }
        for (int i = 0; i < 3 * n; ++i) dx0[i] = tu_rand(&seed);
        const double k = 500.0, c = 20.0;
        double gk, gc, gp[3 * 64], gx0[3 * 64];
        attached_run(&sc, cx, cv, k, c, P, D, 0.0, NULL, 0.0, &gk, &gc, gp, gx0);
        double an[4] = {gk * k, gc * c, 0.0, 0.0};
        for (int i = 0; i < 3 * N; ++i) an[2] += gp[i] * D[i];
        for (int i = 0; i < 3 * n; ++i) an[3] += gx0[i] * dx0[i];
        const char *what[4] = {"attachment_stiffness", "attachment_damping", "attachment_targets",
                               "initial_positions"};
        for (int q = 0; q < 4; ++q) {
            const double e = q < 2 ? 1e-4 : 1e-6;
            double L[2];
            for (int sgn = 0; sgn < 2; ++sgn) {
                const double s = sgn == 0 ? e : -e;
                const double kq = q == 0 ? k * (1 + s) : k, cq = q == 1 ? c * (1 + s) : c;
                L[sgn] = attached_run(&sc, cx, cv, kq, cq, P, D, q == 2 ? s : 0.0,
                                      q == 3 ? dx0 : NULL, q == 3 ? s : 0.0, NULL, NULL, NULL,
                                      NULL);
            }
            const double num = (L[0] - L[1]) / (2.0 * e), rel = fabs(an[q] - num) / fabs(num);
            printf("attached %s d/d%s: tape %.12e  central differences %.12e  relative %.2e\n",
                   backends[b], what[q], an[q], num, rel);
            assert_true(rel < 1e-5);
        }
        free(cx);
        free(cv);
    }
}

/* A free cube hung from the clamped beam by an attachment to a point between two of the beam's
 * vertices (a body-element target: both bodies feel it): x0, attachment stiffness and damping
 * against central differences on symplectic Euler and newton_cholmod. */
static double hung_run(const char *backend, double h, int N, const double *dir, double e, int p,
                       const double *cx, double *g, int *nout)
{
    defsim_world *w = world_for(backend, -9.81);
    const double lo[3] = {0, 0, 0}, hi[3] = {2, 1, 1};
    const double clo[3] = {1.2, -1.5, 0}, chi[3] = {2, -0.7, 0.8};
    defsim_body_id beam = tu_add_box(w, DEFSIM_MODEL_COROTATED, 2, 1, 1, lo, hi, 2e5, 0.3, 800);
    defsim_body_id cube = tu_add_box(w, DEFSIM_MODEL_COROTATED, 1, 1, 1, clo, chi, 1e5, 0.3, 500);
    tu_pin_below(w, beam, 0, 0.0);
    const int n = defsim_world_vertex_count(w), n3 = 3 * n;
    if (nout) *nout = n;
    defsim_attachment_def ad;
    defsim_attachment_def_init(&ad, sizeof ad);
    ad.body = cube;
    ad.vertex = defsim_body_vertex_count(w, cube) - 1;
    ad.stiffness = 300.0 * (1.0 + (p == 1 ? e : 0.0));
    ad.damping = 50.0 * (1.0 + (p == 2 ? e : 0.0));
    ad.target_body = beam;
    ad.target_vertex_count = 2;
    ad.target_vertices[0] = defsim_body_vertex_count(w, beam) - 1;
    ad.target_vertices[1] = defsim_body_vertex_count(w, beam) - 2;
    ad.target_weights[0] = ad.target_weights[1] = 0.5;
    TU_OK(defsim_world_add_attachment(w, &ad, NULL));
    double *x = tu_positions(w);
    for (int i = 0; p == 0 && dir && i < n3; ++i) x[i] += e * dir[i];
    TU_OK(defsim_world_set_state(w, x, NULL));
    free(x);
    if (!cx) {
        defsim_world_destroy(w);
        return 0.0;
    }
    double *cv = calloc((size_t)n3 * (N + 1), sizeof *cv);
    defsim_tape *t = NULL;
    if (g) TU_OK(defsim_world_record(w, NULL, &t));
    double L = state_loss(w, cx, cv, 0);
    for (int s = 1; s <= N; ++s) {
        TU_OK(defsim_world_step(w, h));
        L += state_loss(w, cx, cv, s);
    }
    if (t) {
        defsim_gradient out[3] = {{"initial_positions", g, n3},
                                  {"attachment_stiffness", g + n3, 1},
                                  {"attachment_damping", g + n3 + 1, 1}};
        TU_OK(defsim_tape_backward(t, cx, cv, (int64_t)n3 * (N + 1), out, 3));
        defsim_tape_destroy(t);
    }
    free(cv);
    defsim_world_destroy(w);
    return L;
}

static void test_body_attachment(void **st)
{
    (void)st;
    const char *backends[] = {SE, NC};
    for (int b = 0; b < 2; ++b) {
        const double h = b == 0 ? 1e-3 : 1e-2;
        const int N = b == 0 ? 40 : 10;
        int n;
        hung_run(backends[b], h, N, NULL, 0.0, -1, NULL, NULL, &n);
        const int n3 = 3 * n;
        double *cx = calloc((size_t)n3 * (N + 1), sizeof *cx);
        double *dir = malloc((size_t)n3 * sizeof *dir);
        double *g = malloc((size_t)(n3 + 2) * sizeof *g);
        unsigned long long seed = 5;
        for (int i = 0; i < n3; ++i) {
            cx[(size_t)n3 * N + i] = tu_rand(&seed);
            dir[i] = tu_rand(&seed);
        }
        hung_run(backends[b], h, N, NULL, 0.0, -1, cx, g, NULL);
        double an[3] = {0.0, g[n3] * 300.0, g[n3 + 1] * 50.0};
        for (int i = 0; i < n3; ++i) an[0] += g[i] * dir[i];
        const char *what[3] = {"initial_positions", "attachment_stiffness", "attachment_damping"};
        for (int p = 0; p < 3; ++p) {
            const double e = p == 0 ? 1e-6 : 1e-4;
            const double num = (hung_run(backends[b], h, N, dir, e, p, cx, NULL, NULL) -
                                hung_run(backends[b], h, N, dir, -e, p, cx, NULL, NULL)) / (2 * e);
            const double rel = fabs(an[p] - num) / fabs(num);
            printf("body attachment %s d/d%s: tape %.12e  central differences %.12e  "
                   "relative %.2e\n", backends[b], what[p], an[p], num, rel);
            assert_true(rel < 1e-5);
        }
        free(cx);
        free(dir);
        free(g);
    }
}

/* Every tet model: E, nu, x0 through a few steps of a bent cube with damping. */
static void test_models(void **st)
{
    (void)st;
    const defsim_model models[] = {DEFSIM_MODEL_STVK, DEFSIM_MODEL_COROTATED,
                                   DEFSIM_MODEL_NEOHOOKEAN, DEFSIM_MODEL_STABLE_NEOHOOKEAN};
    const char *backends[] = {SE, NC};
    for (int b = 0; b < 2; ++b)
        for (int k = 0; k < 4; ++k) {
            scene sc = {backends[b], models[k], 2e5, 0.35, 800, 0.5, 1e-3, 2, 1, 1, 2.0,
                        b == 0 ? 2e-3 : 1e-2, b == 0 ? 20 : 6, 1, -9.81, 1.02};
            double *cx, *cv;
            loss_weights(&sc, &cx, &cv);
            grads g;
            tape_grads(&sc, 1, 0, cx, cv, &g, NULL);
            const int which[] = {P_E, P_NU, P_BETA, P_X0};
            char what[64];
            snprintf(what, sizeof what, "model %d %s", (int)models[k], backends[b]);
            check_fd(&sc, &g, cx, cv, which, 4, 1e-5, what);
            grads_free(&g);
            free(cx);
            free(cv);
        }
}

/* Checkpointing (every 4th state, and automatic with a budget that forces thinning) gives the
 * gradients of storing every state, bit for bit, and recomputes what it should. */
static void test_checkpoints(void **st)
{
    (void)st;
    const char *backends[] = {SE, NC, NM};
    for (int b = 0; b < 3; ++b) {
        scene sc = {backends[b], DEFSIM_MODEL_STABLE_NEOHOOKEAN, 1e6, 0.3, 1000, 1.0, 2e-3,
                    3, 1, 1, 3.0, b == 0 ? 2e-3 : 1e-2, 21, 1, -9.81, 0.0};
        double *cx, *cv;
        const int n = loss_weights(&sc, &cx, &cv);
        grads g1, g4, ga;
        defsim_tape_stats s1, s4, sa;
        tape_grads(&sc, 1, 0, cx, cv, &g1, &s1);
        tape_grads(&sc, 4, 0, cx, cv, &g4, &s4);
        /* room for 3 states: thinned to every 8th, then 16th */
        tape_grads(&sc, 0, 3 * 6 * 8 * (int64_t)n, cx, cv, &ga, &sa);
        printf("%s checkpoints: interval 1: %lld states, %lld bytes, %lld recomputed; "
               "interval 4: %lld states, %lld bytes, %lld recomputed; automatic: interval %d, "
               "%lld states, %lld recomputed\n",
               backends[b], (long long)s1.stored_states, (long long)s1.bytes,
               (long long)s1.recomputed_steps, (long long)s4.stored_states, (long long)s4.bytes,
               (long long)s4.recomputed_steps, (int)sa.interval, (long long)sa.stored_states,
               (long long)sa.recomputed_steps);
        assert_int_equal(s1.recomputed_steps, 0);
        assert_int_equal(s1.stored_states, 22 + 1);
        assert_int_equal(s4.stored_states, 6 + 1);            /* 0, 4, ..., 20 and the last */
        assert_int_equal(s4.recomputed_steps, 5 * 4);          /* the segments of 4 steps */
        assert_true(sa.interval >= 8);
        assert_true(sa.recomputed_steps > 0);
        assert_memory_equal(g1.body, g4.body, sizeof g1.body);
        assert_memory_equal(g1.body, ga.body, sizeof g1.body);
        assert_memory_equal(g1.x0, g4.x0, 3 * (size_t)n * sizeof(double));
        assert_memory_equal(g1.v0, ga.v0, 3 * (size_t)n * sizeof(double));
        grads_free(&g1);
        grads_free(&g4);
        grads_free(&ga);
        free(cx);
        free(cv);
    }
}

/* Springs (a pinned ladder swinging under gravity, with Rayleigh damping): x0, v0, alpha and
 * beta against central differences. */
static void test_springs(void **st)
{
    (void)st;
    const char *backends[] = {SE, NC};
    for (int b = 0; b < 2; ++b) {
        double x[24];
        int32_t springs[20];
        tu_ladder(0.0, 0.25, 0.05, x, springs);
        const int nstep = b == 0 ? 60 : 10;
        const double h = b == 0 ? 1e-3 : 1e-2;
        double L[2], an[3];
        unsigned long long seed = 3;
        double dir[24];
        for (int i = 0; i < 24; ++i) dir[i] = tu_rand(&seed);
        double *wx = calloc(24 * (size_t)(nstep + 1), sizeof *wx);
        double *wv = calloc(24 * (size_t)(nstep + 1), sizeof *wv);
        for (int i = 0; i < 24; ++i) {
            wx[24 * (size_t)nstep + i] = tu_rand(&seed);
            wv[24 * (size_t)nstep + i] = 0.1 * tu_rand(&seed);
        }
        /* 0: tape; then central differences along x0, v0 (dir) and beta */
        for (int pass = 0; pass < 7; ++pass) {
            const int p = pass == 0 ? -1 : (pass - 1) / 2;   /* 0 x0, 1 v0, 2 beta */
            const double eps = p == 2 ? 1e-7 : 1e-6, e = pass == 0 ? 0.0 : (pass % 2 ? eps : -eps);
            defsim_world *w = world_for(backends[b], -9.81);
            defsim_body_def bd;
            defsim_body_def_init(&bd, sizeof bd);
            bd.rest_positions = x;
            bd.vertex_count = 8;
            bd.springs = springs;
            bd.spring_count = 10;
            defsim_material_init(&bd.material, sizeof bd.material, DEFSIM_MODEL_SPRING);
            bd.material.stiffness = 400.0;
            bd.material.vertex_mass = 0.05;
            bd.material.mass_damping = 0.3;
            bd.material.stiffness_damping = 2e-3 + (p == 2 ? e : 0.0);
            defsim_body_id id;
            TU_OK(defsim_world_add_body(w, &bd, &id));
            const int32_t pins[2] = {0, 1};
            TU_OK(defsim_body_pin(w, id, pins, 2));
            double x0[24], v0[24] = {0};
            memcpy(x0, x, sizeof x0);
            for (int i = 0; i < 8; ++i) {
                x0[3 * i + 1] -= 0.05 * i * i * 0.25;   /* a bend: the springs start stretched */
                if (i >= 2) v0[3 * i + 2] = 0.2 * i;
            }
            for (int i = 2 * 3; i < 24; ++i) {
                if (p == 0) x0[i] += e * dir[i];
                if (p == 1) v0[i] += e * dir[i];
            }
            TU_OK(defsim_world_set_state(w, x0, v0));
            defsim_tape *t = NULL;
            if (pass == 0) TU_OK(defsim_world_record(w, NULL, &t));
            double Lp = 0.0, xs[24], vs[24];
            for (int s = 0; s < nstep; ++s) TU_OK(defsim_world_step(w, h));
            TU_OK(defsim_world_get_positions(w, xs, 8));
            TU_OK(defsim_world_get_velocities(w, vs, 8));
            const double *ax = wx + 24 * (size_t)nstep, *av = wv + 24 * (size_t)nstep;
            for (int i = 0; i < 24; ++i) Lp += ax[i] * xs[i] + av[i] * vs[i];
            if (pass == 0) {
                double gx[24], gv[24], gbeta;
                defsim_gradient out[3] = {{"initial_positions", gx, 24},
                                          {"initial_velocities", gv, 24},
                                          {"stiffness_damping", &gbeta, 1}};
                TU_OK(defsim_tape_backward(t, wx, wv, 24 * (int64_t)(nstep + 1), out, 3));
                an[0] = an[1] = 0.0;
                for (int i = 6; i < 24; ++i) {
                    an[0] += gx[i] * dir[i];
                    an[1] += gv[i] * dir[i];
                }
                an[2] = gbeta;
                defsim_tape_destroy(t);
            } else {
                L[pass % 2 ? 0 : 1] = Lp;
                if (pass % 2 == 0) {
                    const double num = (L[0] - L[1]) / (2.0 * eps);
                    const double rel = fabs(num - an[p]) / fabs(num);
                    printf("springs %s d/d%s: tape %.12e  central differences %.12e  "
                           "relative %.2e\n",
                           backends[b], p == 0 ? "x0" : p == 1 ? "v0" : "beta", an[p], num, rel);
                    assert_true(rel < 1e-5);
                }
            }
            defsim_world_destroy(w);
        }
        free(wx);
        free(wv);
    }
}

/* Bad input: clear statuses, the world unchanged (state, time, statistics), and the run after a
 * successful backward pass the same, bit for bit, as without it. */
static void test_bad_input(void **st)
{
    (void)st;
    scene sc = {SE, DEFSIM_MODEL_COROTATED, 1e5, 0.3, 1000, 0.2, 0.0, 2, 1, 1, 2.0, 2e-3, 10, 1,
                -9.81, 0.0};
    defsim_world *w = make(&sc, NULL, NULL, NULL, 0.0);
    defsim_world *ref = make(&sc, NULL, NULL, NULL, 0.0);
    const int n = defsim_world_vertex_count(w), n3 = 3 * n;
    defsim_tape *t = NULL;
    assert_int_equal(defsim_tape_backward(NULL, NULL, NULL, 0, NULL, 0),
                     DEFSIM_ERR_INVALID_ARGUMENT);
    assert_int_equal(defsim_world_record(w, NULL, NULL), DEFSIM_ERR_INVALID_ARGUMENT);
    TU_OK(defsim_world_record(w, NULL, &t));
    defsim_tape *t2 = NULL;
    assert_int_equal(defsim_world_record(w, NULL, &t2), DEFSIM_ERR_INVALID_ARGUMENT);
    assert_null(t2);
    for (int s = 0; s < sc.steps; ++s) {
        TU_OK(defsim_world_step(w, sc.h));
        TU_OK(defsim_world_step(ref, sc.h));
    }
    double *x = tu_positions(w), *dl = calloc((size_t)n3 * (sc.steps + 1), sizeof *dl);
    defsim_stats s0 = {.size = sizeof s0}, s1 = {.size = sizeof s1};
    TU_OK(defsim_world_stats(w, &s0));
    const double t0 = defsim_world_time(w);
    double gE = 0.0, gx[3 * 64];
    assert_true(n <= 64);
    defsim_gradient ok = {"youngs_modulus", &gE, 1};
    /* wrong size */
    assert_int_equal(defsim_tape_backward(t, dl, NULL, (int64_t)n3 * sc.steps, &ok, 1),
                     DEFSIM_ERR_INVALID_ARGUMENT);
    /* NaN in dL/dx */
    dl[n3 * 3 + 5] = NAN;
    assert_int_equal(defsim_tape_backward(t, dl, NULL, (int64_t)n3 * (sc.steps + 1), &ok, 1),
                     DEFSIM_ERR_INVALID_ARGUMENT);
    dl[n3 * 3 + 5] = 0.0;
    /* unknown name, wrong count */
    defsim_gradient bad = {"youngs", &gE, 1}, badn = {"initial_positions", gx, n3 - 1};
    assert_int_equal(defsim_tape_backward(t, dl, NULL, (int64_t)n3 * (sc.steps + 1), &bad, 1),
                     DEFSIM_ERR_INVALID_ARGUMENT);
    assert_int_equal(defsim_tape_backward(t, dl, NULL, (int64_t)n3 * (sc.steps + 1), &badn, 1),
                     DEFSIM_ERR_INVALID_ARGUMENT);
    double *x1 = tu_positions(w);
    assert_memory_equal(x, x1, (size_t)n3 * sizeof *x);
    free(x1);
    /* a successful pass (every 3rd state stored would recompute: this one stores all) leaves
     * the world as it was, and the run goes on bit for bit */
    for (int i = 0; i < n3; ++i) dl[(size_t)n3 * sc.steps + i] = 1.0;
    TU_OK(defsim_tape_backward(t, dl, NULL, (int64_t)n3 * (sc.steps + 1), &ok, 1));
    assert_true(gE != 0.0);
    TU_OK(defsim_world_stats(w, &s1));
    assert_int_equal(s0.steps, s1.steps);
    assert_true(defsim_world_time(w) == t0);
    x1 = tu_positions(w);
    assert_memory_equal(x, x1, (size_t)n3 * sizeof *x);
    free(x1);
    for (int s = 0; s < 5; ++s) {
        TU_OK(defsim_world_step(w, sc.h));
        TU_OK(defsim_world_step(ref, sc.h));
    }
    x1 = tu_positions(w);
    double *xr = tu_positions(ref);
    assert_memory_equal(xr, x1, (size_t)n3 * sizeof *x);
    free(x1);
    free(xr);
    /* the state set between recorded steps: the recording cannot follow */
    TU_OK(defsim_world_set_state(w, x, NULL));
    TU_OK(defsim_world_step(w, sc.h));
    const int64_t cnt = (int64_t)n3 * (sc.steps + 5 + 2);
    double *dl2 = calloc((size_t)cnt, sizeof *dl2);
    assert_int_equal(defsim_tape_backward(t, dl2, NULL, cnt, &ok, 1), DEFSIM_ERR_INVALID_ARGUMENT);
    printf("state set between steps: %s\n", defsim_tape_last_error(t));
    free(dl2);
    /* a world destroyed before its tape */
    defsim_world_destroy(w);
    assert_int_equal(defsim_tape_backward(t, NULL, NULL, 0, NULL, 0), DEFSIM_ERR_INVALID_ARGUMENT);
    defsim_tape_stats ts = {.size = sizeof ts};
    TU_OK(defsim_tape_get_stats(t, &ts));
    assert_int_equal(ts.steps, sc.steps + 5);
    defsim_tape_destroy(t);
    defsim_world_destroy(ref);
    free(x);
    free(dl);
}

static int zero_force(void *user, const double *x, const double *v, double t, int32_t n,
                      double *f)
{
    (void)user; (void)x; (void)v; (void)t; (void)n; (void)f;
    return 0;
}

/* On the implicit backends, with checkpoints (interval 3: steps recomputed), a backward pass
 * leaves the state, time, statistics and backend counters as they were, and the run goes on
 * bit for bit as a run without it. */
static void test_backward_leaves_run(void **st)
{
    (void)st;
    const char *backends[] = {NC, NM};
    for (int b = 0; b < 2; ++b) {
        scene sc = {backends[b], DEFSIM_MODEL_STABLE_NEOHOOKEAN, 1e6, 0.3, 1000, 1.0, 2e-3,
                    3, 1, 1, 3.0, 1e-2, 9, 1, -9.81, 0.0};
        defsim_world *w = make(&sc, NULL, NULL, NULL, 0.0);
        defsim_world *ref = make(&sc, NULL, NULL, NULL, 0.0);
        const int n = defsim_world_vertex_count(w), n3 = 3 * n;
        defsim_tape_def td;
        defsim_tape_def_init(&td, sizeof td);
        td.interval = 3;
        defsim_tape *t = NULL;
        TU_OK(defsim_world_record(w, &td, &t));
        for (int s = 0; s < sc.steps; ++s) {
            TU_OK(defsim_world_step(w, sc.h));
            TU_OK(defsim_world_step(ref, sc.h));
        }
        const double it0 = tu_bstat(w, "newton_iterations");
        defsim_stats s0 = {.size = sizeof s0}, s1 = {.size = sizeof s1};
        TU_OK(defsim_world_stats(w, &s0));
        double *dl = calloc((size_t)n3 * (sc.steps + 1), sizeof *dl), gE = 0.0;
        for (int i = 0; i < n3; ++i) dl[(size_t)n3 * sc.steps + i] = 1.0;
        defsim_gradient g = {"youngs_modulus", &gE, 1};
        TU_OK(defsim_tape_backward(t, dl, NULL, (int64_t)n3 * (sc.steps + 1), &g, 1));
        defsim_tape_stats ts = {.size = sizeof ts};
        TU_OK(defsim_tape_get_stats(t, &ts));
        assert_true(ts.recomputed_steps == 9 && gE != 0.0);
        TU_OK(defsim_world_stats(w, &s1));
        assert_int_equal(s0.steps, s1.steps);
        assert_true(s0.time_step == s1.time_step && s0.force_evals == s1.force_evals);
        assert_true(tu_bstat(w, "newton_iterations") == it0);
        assert_true(defsim_world_time(w) == defsim_world_time(ref));
        for (int s = 0; s < 5; ++s) {
            TU_OK(defsim_world_step(w, sc.h));
            TU_OK(defsim_world_step(ref, sc.h));
        }
        double *x = tu_positions(w), *xr = tu_positions(ref);
        assert_memory_equal(x, xr, (size_t)n3 * sizeof *x);
        printf("%s: after a backward pass (%lld steps recomputed) the run goes on bit for bit\n",
               backends[b], (long long)ts.recomputed_steps);
        free(x);
        free(xr);
        free(dl);
        defsim_tape_destroy(t);
        defsim_world_destroy(w);
        defsim_world_destroy(ref);
    }
}

/* A backend without an adjoint, and terms not differentiated yet: DEFSIM_ERR_UNSUPPORTED when
 * recording begins, the world unchanged. */
static void test_unsupported(void **st)
{
    (void)st;
    const char *nondiff[] = {"velocity_verlet", "bdf2"};
    for (int b = 0; b < 2; ++b) {
        scene sc = {nondiff[b], DEFSIM_MODEL_COROTATED, 1e5, 0.3, 1000, 0.0, 0.0, 1, 1, 1, 1.0,
                    1e-3, 1, 1, -9.81, 0.0};
        defsim_world *w = make(&sc, NULL, NULL, NULL, 0.0);
        defsim_tape *t = NULL;
        assert_int_equal(defsim_world_record(w, NULL, &t), DEFSIM_ERR_UNSUPPORTED);
        assert_null(t);
        assert_non_null(strstr(defsim_world_last_error(w), nondiff[b]));
        TU_OK(defsim_world_step(w, 1e-3));
        defsim_world_destroy(w);
    }
    /* collider contact, the force callback */
    scene sc = {SE, DEFSIM_MODEL_COROTATED, 1e5, 0.3, 1000, 0.0, 0.0, 1, 1, 1, 1.0, 1e-3, 1, 0,
                -9.81, 0.0};
    defsim_world *w = make(&sc, NULL, NULL, NULL, 0.0);
    defsim_collider_def cd;
    defsim_collider_def_init(&cd, sizeof cd);
    cd.shape = DEFSIM_SHAPE_PLANE;
    cd.normal[0] = 0.0;
    cd.normal[1] = 1.0;
    cd.normal[2] = 0.0;
    cd.position[1] = -1.0;
    defsim_collider_id cid;
    TU_OK(defsim_world_add_collider(w, &cd, &cid));
    defsim_tape *t = NULL;
    assert_int_equal(defsim_world_record(w, NULL, &t), DEFSIM_ERR_UNSUPPORTED);
    assert_non_null(strstr(defsim_world_last_error(w), "collider"));
    TU_OK(defsim_world_remove_collider(w, cid));
    /* the force callback */
    TU_OK(defsim_world_set_force_callback(w, zero_force, NULL, NULL));
    assert_int_equal(defsim_world_record(w, NULL, &t), DEFSIM_ERR_UNSUPPORTED);
    assert_non_null(strstr(defsim_world_last_error(w), "callback"));
    TU_OK(defsim_world_set_force_callback(w, NULL, NULL, NULL));
    TU_OK(defsim_world_record(w, NULL, &t));
    /* a collider added during the recording: the backward pass refuses, and a step taken with
     * it stops the recording */
    TU_OK(defsim_world_step(w, 1e-3));
    TU_OK(defsim_world_add_collider(w, &cd, &cid));
    const int64_t cnt = 2 * 3 * (int64_t)defsim_world_vertex_count(w);
    assert_int_equal(defsim_tape_backward(t, NULL, NULL, cnt, NULL, 0), DEFSIM_ERR_UNSUPPORTED);
    TU_OK(defsim_world_step(w, 1e-3));
    TU_OK(defsim_world_remove_collider(w, cid));
    assert_int_equal(defsim_tape_backward(t, NULL, NULL, cnt + cnt / 2, NULL, 0),
                     DEFSIM_ERR_INVALID_ARGUMENT);
    assert_non_null(strstr(defsim_tape_last_error(t), "collider"));
    defsim_tape_destroy(t);
    defsim_world_destroy(w);
}

/* Element kinds without a vector-Jacobian product (quadratic tets, volume-averaged tets, the
 * mean-dilatation quadratic tets): the recording is refused naming the term, and the world
 * steps on. */
static void test_unsupported_elements(void **st)
{
    (void)st;
    const char *term[3] = {"elastic_quadratic", "nodal_volume", "quadratic_mixed"};
    for (int k = 0; k < 3; ++k) {
        defsim_world *w = tu_world(SE, -9.81, 1);
        const double lo[3] = {0, 0, 0}, hi[3] = {0.2, 0.1, 0.1};
        defsim_mesh m;
        memset(&m, 0, sizeof m);
        m.size = sizeof m;
        TU_OK(defsim_mesh_box(lo, hi, 2, 1, 1, &m));
        if (k != 1) TU_OK(defsim_mesh_make_quadratic(&m));
        defsim_body_def bd = test_mesh_body(&m, DEFSIM_MODEL_NEOHOOKEAN);
        bd.material.youngs_modulus = 1e5;
        bd.volume_averaging = k > 0;
        TU_OK(defsim_world_add_body(w, &bd, NULL));
        defsim_mesh_free(&m);
        defsim_tape *t = NULL;
        assert_int_equal(defsim_world_record(w, NULL, &t), DEFSIM_ERR_UNSUPPORTED);
        assert_null(t);
        printf("  %s\n", defsim_world_last_error(w));
        assert_non_null(strstr(defsim_world_last_error(w), term[k]));
        TU_OK(defsim_world_step(w, 1e-4));
        defsim_world_destroy(w);
    }
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_free_fall_symplectic),
        cmocka_unit_test(test_unsupported_elements),
        cmocka_unit_test(test_free_fall_explicit),
        cmocka_unit_test(test_free_fall_newton),
        cmocka_unit_test(test_cantilever_symplectic),
        cmocka_unit_test(test_cantilever_explicit),
        cmocka_unit_test(test_cantilever_newton),
        cmocka_unit_test(test_cantilever_newmark),
        cmocka_unit_test(test_damping_at_zero),
        cmocka_unit_test(test_external_forces),
        cmocka_unit_test(test_attachments),
        cmocka_unit_test(test_body_attachment),
        cmocka_unit_test(test_models),
        cmocka_unit_test(test_checkpoints),
        cmocka_unit_test(test_springs),
        cmocka_unit_test(test_backward_leaves_run),
        cmocka_unit_test(test_bad_input),
        cmocka_unit_test(test_unsupported),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
