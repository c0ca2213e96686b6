/* SPDX-License-Identifier: MIT */
/*
 * Gradients through runs with contact (issue 25, docs/gradients.md): the tape's backward pass
 * against central finite differences of whole runs on the barrier's differentiable backends
 * (newton_cholmod, newmark; bdf2 in the incline and the cubes): a block sliding down an
 * incline with friction, sliding and sticking (the travel's gradient in the initial speed, the
 * friction coefficient, the density, Young's modulus and the initial positions), a cloth dropped onto a sphere fast enough that
 * CCD cuts its landing step (the initial positions, velocities and mu), and a cube landing on a
 * cube (body contact: the initial state, the top cube's density and E, the bodies' friction);
 * the penalty's backends refused, a moved collider recorded (its poses: test_gradients_poses),
 * bad arguments, and the run (and contact's statistics) going on bit for bit after a backward
 * pass with recomputation.
 */
#include "mesh_body.h"
#include "test_util.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static const char *NC = "newton_cholmod";
static const char *NM = "newmark";
static const char *BD = "bdf2";

enum { INCLINE, CLOTH, CUBES };

/* A run: the scene, its backend, the collider's friction, the start's speed, the steps. */
typedef struct cscene {
    int kind;
    const char *backend;
    double mu;
    double speed;             /* INCLINE: down the slope; CLOTH: downwards (m/s) */
    double h;
    int steps;
    double thick;             /* INCLINE, CUBES: the bodies' contact_thickness (m; 0: none) */
} cscene;

/* What the finite differences move. */
enum { Q_SPEED, Q_X0, Q_V0, Q_MU, Q_RHO, Q_E, Q_BMU, Q_COUNT };
static const char *const qname[Q_COUNT] = {"initial speed", "initial_positions",
                                           "initial_velocities", "collider_friction", "density",
                                           "youngs_modulus", "body_friction"};

#define SLOPE 0.4363323129985824   /* 25 degrees */
#define RHO 1000.0
#define YOUNG 1e5
#define SPHERE_R 0.3

/* The slope's tangent (down is -t) and normal. */
static void slope(double t[3], double n[3])
{
    const double c = cos(SLOPE), s = sin(SLOPE);
    t[0] = c, t[1] = s, t[2] = 0.0;
    n[0] = -s, n[1] = c, n[2] = 0.0;
}

/* The world of sc, moved by e along parameter q (x0, v0: along dir): converged tightly, with
 * the contact stop off (the implicit function theorem differentiates the exact solution). */
static defsim_world *build(const cscene *sc, int q, double e, const double *dir)
{
    defsim_world *w = tu_implicit_world(sc->backend, -9.81, 1, 1e-13, 200, DEFSIM_PROJECTION_CLAMP);
    assert_true(tu_backend_option(w, sc->backend, "contact_tolerance", 0.0));
    defsim_collider_def cd;
    defsim_collider_def_init(&cd, sizeof cd);
    cd.friction = sc->mu + (q == Q_MU ? e : 0.0);
    double t[3], nrm[3];
    slope(t, nrm);
    double *x, *v;
    int n;
    if (sc->kind == CUBES) {
        /* a 6 cm cube 1e-4 m (half of dhat) above a 10 cm cube whose bottom is pinned, moving
         * down and sideways: it lands and slides under body-body friction */
        TU_OK(defsim_world_set_option(w, "core.body_contact", "true"));
        for (int b = 0; b < 2; ++b) {
            /* with a thickness t, the top cube starts t (two half-thicknesses) higher */
            const double up = b ? sc->thick : 0.0;
            const double lo[3] = {b ? 0.017 : 0.0, b ? 0.1001 + up : 0.0, b ? 0.023 : 0.0};
            const double hi[3] = {b ? 0.077 : 0.1, b ? 0.1601 + up : 0.1, b ? 0.083 : 0.1};
            defsim_mesh m;
            memset(&m, 0, sizeof m);
            m.size = sizeof m;
            TU_OK(defsim_mesh_box(lo, hi, 1, 1, 1, &m));
            defsim_body_def bd = test_mesh_body(&m, DEFSIM_MODEL_STABLE_NEOHOOKEAN);
            bd.material.youngs_modulus = YOUNG * (b && q == Q_E ? 1.0 + e : 1.0);
            bd.material.poisson_ratio = 0.3;
            bd.material.density = RHO * (b && q == Q_RHO ? 1.0 + e : 1.0);
            bd.friction = sc->mu + (q == Q_BMU ? e : 0.0);   /* both bodies */
            bd.contact_thickness = sc->thick;
            defsim_body_id id;
            TU_OK(defsim_world_add_body(w, &bd, &id));
            defsim_mesh_free(&m);
            if (!b) tu_pin_below(w, id, 1, 0.0);
        }
        n = defsim_world_vertex_count(w);
        x = tu_positions(w);
        v = calloc(3 * (size_t)n, sizeof *v);
        uint8_t *pinned = malloc((size_t)n);
        TU_OK(defsim_world_get_pinned(w, pinned, n));
        for (int i = 8; i < n; ++i) {
            v[3 * i] = sc->speed;
            v[3 * i + 1] = -0.2;
            v[3 * i + 2] = 0.1;
        }
        for (int i = 0; dir && i < 3 * n; ++i) {
            if (q == Q_X0) x[i] += e * dir[i];
            if (q == Q_V0 && !pinned[i / 3]) v[i] += e * dir[i];
        }
        free(pinned);
        TU_OK(defsim_world_set_state(w, x, v));
        free(x);
        free(v);
        return w;
    }
    if (sc->kind == INCLINE) {
        /* a 10 cm block, its bottom face on the slope at half the activation distance */
        cd.shape = DEFSIM_SHAPE_PLANE;
        memcpy(cd.normal, nrm, sizeof nrm);
        defsim_material m;
        defsim_material_init(&m, sizeof m, DEFSIM_MODEL_STABLE_NEOHOOKEAN);
        m.youngs_modulus = YOUNG * (1.0 + (q == Q_E ? e : 0.0));
        m.poisson_ratio = 0.3;
        m.density = RHO * (1.0 + (q == Q_RHO ? e : 0.0));
        const double lo[3] = {0, 0, 0}, hi[3] = {0.1, 0.1, 0.1};
        defsim_mesh bm;
        memset(&bm, 0, sizeof bm);
        bm.size = sizeof bm;
        TU_OK(defsim_mesh_box(lo, hi, 1, 1, 1, &bm));
        defsim_body_def bd = test_mesh_body(&bm, m.model);
        bd.material = m;
        bd.contact_thickness = sc->thick;
        TU_OK(defsim_world_add_body(w, &bd, NULL));
        defsim_mesh_free(&bm);
        n = defsim_world_vertex_count(w);
        x = tu_positions(w);
        v = calloc(3 * (size_t)n, sizeof *v);
        /* dhat / 2 (dhat: 1e-3 of the diagonal) beyond the offset t / 2 */
        const double d0 = 0.5e-3 * sqrt(3.0) * 0.1 + 0.5 * sc->thick;
        for (int i = 0; i < n; ++i) {
            const double X = x[3 * i], Y = x[3 * i + 1];
            x[3 * i] = cos(SLOPE) * X - sin(SLOPE) * Y + d0 * nrm[0];
            x[3 * i + 1] = sin(SLOPE) * X + cos(SLOPE) * Y + d0 * nrm[1];
            for (int k = 0; k < 3; ++k) v[3 * i + k] = -(sc->speed + (q == Q_SPEED ? e : 0.0)) * t[k];
        }
    } else {
        /* a 40 cm spring cloth 2 cm above a sphere's top, off centre (centred, the vertex on
         * the top and the symmetry make a tie that finite differences see as a kink), falling */
        cd.shape = DEFSIM_SHAPE_SPHERE;
        cd.radius = SPHERE_R;
        const double o[3] = {-0.13, SPHERE_R + 0.02, -0.17}, u[3] = {0.4, 0, 0}, vv[3] = {0, 0, 0.4};
        tu_add_spring_cloth(w, o, u, vv, 4, 4, 200.0, 0.01);
        n = defsim_world_vertex_count(w);
        x = tu_positions(w);
        v = calloc(3 * (size_t)n, sizeof *v);
        for (int i = 0; i < n; ++i) {
            v[3 * i + 1] = -sc->speed;
            v[3 * i] = 0.2 * x[3 * i + 2];   /* a swirl: the cloth slides as it lands */
        }
    }
    for (int i = 0; dir && i < 3 * n; ++i) {
        if (q == Q_X0) x[i] += e * dir[i];
        if (q == Q_V0) v[i] += e * dir[i];
    }
    TU_OK(defsim_world_set_state(w, x, v));
    free(x);
    free(v);
    defsim_collider_id id;
    TU_OK(defsim_world_add_collider(w, &cd, &id));
    return w;
}

/* The loss: INCLINE, the centroid's travel down the slope at the last state; CLOTH, fixed
 * random weights on the last positions and velocities. Weights over the states 0 .. N. */
static void loss_weights(const cscene *sc, int n, double **cx, double **cv)
{
    const size_t n3 = 3 * (size_t)n, all = n3 * (size_t)(sc->steps + 1), last = n3 * (size_t)sc->steps;
    *cx = calloc(all, sizeof **cx);
    *cv = calloc(all, sizeof **cv);
    double t[3], nrm[3];
    slope(t, nrm);
    unsigned long long seed = 5;
    for (size_t i = 0; i < n3; ++i) {
        if (sc->kind == INCLINE) {
            (*cx)[last + i] = -t[i % 3] / n;
        } else if (sc->kind == CUBES) {   /* the top cube's mean height and x */
            (*cx)[last + i] = i >= 24 && i % 3 < 2 ? 1.0 / 8.0 : 0.0;
        } else {
            (*cx)[last + i] = tu_rand(&seed);
            (*cv)[last + i] = 0.01 * tu_rand(&seed);
        }
    }
}

static double run_loss(const cscene *sc, defsim_world *w, const double *cx, const double *cv)
{
    const int n = defsim_world_vertex_count(w), n3 = 3 * n;
    for (int s = 0; s < sc->steps; ++s) {
        const defsim_status st = defsim_world_step(w, sc->h);
        if (st != DEFSIM_OK) fail_msg("step %d: %s", s, defsim_world_last_error(w));
    }
    double *x = tu_positions(w), *v = tu_velocities(w), L = 0.0;
    const double *wx = cx + (size_t)n3 * sc->steps, *wv = cv + (size_t)n3 * sc->steps;
    for (int i = 0; i < n3; ++i) L += wx[i] * x[i] + wv[i] * v[i];
    free(x);
    free(v);
    return L;
}

typedef struct cgrads {
    double *x0, *v0;
    double mu, rho, E, bmu[2];
    double ratio;             /* the backward pass's time over the forward run's */
} cgrads;

/* Records sc's run and runs it backward (interval 1). */
static void tape_grads(const cscene *sc, const double *cx, const double *cv, int n, cgrads *g)
{
    defsim_world *w = build(sc, -1, 0.0, NULL);
    defsim_tape *t = NULL;
    TU_OK(defsim_world_record(w, NULL, &t));
    for (int s = 0; s < sc->steps; ++s) {
        const defsim_status st = defsim_world_step(w, sc->h);
        if (st != DEFSIM_OK) fail_msg("step %d: %s", s, defsim_world_last_error(w));
    }
    g->x0 = malloc(3 * (size_t)n * sizeof *g->x0);
    g->v0 = malloc(3 * (size_t)n * sizeof *g->v0);
    defsim_gradient out[] = {{"initial_positions", g->x0, 3 * (int64_t)n},
                             {"initial_velocities", g->v0, 3 * (int64_t)n},
                             {"collider_friction", &g->mu, 1},
                             {"density", &g->rho, 1},
                             {"youngs_modulus", &g->E, 1}};
    double two[2][2];
    defsim_gradient cube_out[] = {out[0], out[1], {"density", two[0], 2},
                                  {"youngs_modulus", two[1], 2}, {"body_friction", g->bmu, 2}};
    const int32_t nout = sc->kind == INCLINE ? 5 : sc->kind == CUBES ? 5 : 3;
    const defsim_status st = defsim_tape_backward(t, cx, cv, 3 * (int64_t)n * (sc->steps + 1),
                                                  sc->kind == CUBES ? cube_out : out, nout);
    if (st != DEFSIM_OK) fail_msg("backward: %s", defsim_tape_last_error(t));
    if (sc->kind == CUBES) {   /* the top cube's */
        g->rho = two[0][1];
        g->E = two[1][1];
    }
    defsim_tape_stats ts = {.size = sizeof ts};
    TU_OK(defsim_tape_get_stats(t, &ts));
    g->ratio = ts.time_backward / ts.time_forward;
    defsim_tape_destroy(t);
    defsim_world_destroy(w);
}

/* The tape's gradient along q against central differences with steps eps and 2 eps,
 * extrapolated (Richardson: (4 D(eps) - D(2 eps)) / 3, error O(eps^4)), so that the steps can be
 * large against the forward runs' rounding and Newton tolerance. */
static void check(const cscene *sc, const cgrads *g, int q, const double *dir, int n,
                  double eps, const double *cx, const double *cv, double rtol, const char *what)
{
    double an = 0.0;
    if (q == Q_SPEED || q == Q_X0 || q == Q_V0) {
        const double *gg = q == Q_X0 ? g->x0 : g->v0;
        double t[3], nrm[3];
        slope(t, nrm);
        for (int i = 0; i < 3 * n; ++i) an += gg[i] * (q == Q_SPEED ? -t[i % 3] : dir[i]);
    } else {
        an = q == Q_MU ? g->mu : q == Q_BMU ? g->bmu[0] + g->bmu[1]
             : q == Q_RHO ? g->rho * RHO : g->E * YOUNG;
    }
    double L[4];
    for (int k = 0; k < 4; ++k) {
        const double e = (k < 2 ? eps : 2.0 * eps) * (k % 2 ? -1.0 : 1.0);
        defsim_world *w = build(sc, q, e, dir);
        L[k] = run_loss(sc, w, cx, cv);
        defsim_world_destroy(w);
    }
    const double d1 = (L[0] - L[1]) / (2.0 * eps), d2 = (L[2] - L[3]) / (4.0 * eps);
    const double num = (4.0 * d1 - d2) / 3.0;
    const double rel = fabs(an - num) / fmax(fabs(num), 1e-300);
    printf("%s %s d/d(%s): tape %.12e  central differences (step %g) %.12e  relative %.2e\n",
           what, sc->backend, qname[q], an, eps, num, rel);
    if (!(rel <= rtol))
        fail_msg("%s %s: d/d(%s) relative error %.3g > %.3g", what, sc->backend, qname[q], rel,
                 rtol);
}

/* One gradient check: the parameter and the finite differences' step. */
typedef struct qstep {
    int q;
    double eps;
} qstep;

/* Records sc's run of n vertices, runs it backward and checks the gradients qs against central
 * differences (x0, v0 along a random direction from seed), relative 1e-5. */
static void check_all(const cscene *sc, int n, unsigned long long seed, const qstep *qs, int nq,
                      const char *what)
{
    double *cx, *cv;
    loss_weights(sc, n, &cx, &cv);
    cgrads g;
    tape_grads(sc, cx, cv, n, &g);
    printf("%s %s: backward / forward time %.2f\n", what, sc->backend, g.ratio);
    double *dir = calloc(3 * (size_t)n, sizeof *dir);
    for (int i = 0; i < 3 * n; ++i) dir[i] = tu_rand(&seed);
    for (int k = 0; k < nq; ++k) check(sc, &g, qs[k].q, dir, n, qs[k].eps, cx, cv, 1e-5, what);
    free(dir);
    free(g.x0);
    free(g.v0);
    free(cx);
    free(cv);
}

/* The block's centroid and lowest vertex's distance to the slope at the run's end. */
static void incline_state(const cscene *sc, double *travel, double *speed, double *dmin)
{
    defsim_world *w = build(sc, -1, 0.0, NULL);
    const int n = defsim_world_vertex_count(w);
    double *x0 = tu_positions(w);
    for (int s = 0; s < sc->steps; ++s) TU_OK(defsim_world_step(w, sc->h));
    double *x = tu_positions(w), *v = tu_velocities(w), t[3], nrm[3];
    slope(t, nrm);
    *travel = *speed = 0.0;
    *dmin = INFINITY;
    for (int i = 0; i < n; ++i) {
        double d = 0.0;
        for (int k = 0; k < 3; ++k) {
            *travel -= t[k] * (x[3 * i + k] - x0[3 * i + k]) / n;
            *speed -= t[k] * v[3 * i + k] / n;
            d += nrm[k] * x[3 * i + k];
        }
        *dmin = fmin(*dmin, d);
    }
    free(x0);
    free(x);
    free(v);
    defsim_world_destroy(w);
}

/* The block on the slope, sliding (mu 0.2 < tan 25 deg = 0.466: it speeds up) and sticking
 * (mu 0.8: it stops within the run, then rests in friction's smooth stick regime). Steps of the
 * finite differences: 1e-6 m/s, 1e-6 in mu, 1e-6 relative in density and E, 1e-7 m in x0 (a
 * 1/1700 of dhat): the bottom vertices stay within dhat of the slope and the top ones far from
 * it over the whole run, and friction stays in its regime, so that nothing switches within
 * the step; the barrier is twice differentiable at dhat anyway. */
static void incline(const char *backend, double thick)
{
    const double mus[2] = {0.2, 0.8};
    for (int r = 0; r < 2; ++r) {
        const cscene sc = {INCLINE, backend, mus[r], r == 0 ? 0.5 : 0.1, 1e-2, r == 0 ? 12 : 30,
                           thick};
        double travel, speed, dmin;
        incline_state(&sc, &travel, &speed, &dmin);
        const char *what = thick > 0.0 ? (r == 0 ? "incline 2 mm thick (sliding)"
                                                 : "incline 2 mm thick (sticking)")
                           : r == 0 ? "incline (sliding)" : "incline (sticking)";
        printf("%s %s: travel %.6f m, final speed %.3e m/s, lowest vertex %.3e m above the "
               "slope\n", what, backend, travel, speed, dmin);
        /* sliding speeds up from 0.5 m/s; with mu 0.8 backward Euler stops the block (Newmark,
         * which does not dissipate, leaves it moving: the finite differences still hold) */
        if (r == 0) assert_true(speed > 0.6);
        else if (strcmp(backend, NC) == 0) assert_true(fabs(speed) < 1e-3 && travel > 0.0);
        /* the block keeps its half-thickness off the slope, within dhat beyond it */
        assert_true(dmin > 0.5 * thick && dmin < 0.5 * thick + 1e-3 * sqrt(3.0) * 0.1);
        defsim_world *w = build(&sc, -1, 0.0, NULL);
        const int n = defsim_world_vertex_count(w);
        defsim_world_destroy(w);
        const qstep qs[] = {{Q_SPEED, 1e-6}, {Q_MU, 1e-6}, {Q_RHO, 1e-4}, {Q_E, 1e-4},
                            {Q_X0, 1e-7}};
        check_all(&sc, n, 17, qs, 5, what);
    }
}

static void test_incline_newton(void **st)
{
    (void)st;
    incline(NC, 0.0);
}

static void test_incline_newmark(void **st)
{
    (void)st;
    incline(NM, 0.0);
}

/* The same block with a contact thickness of 2 mm (docs/body-contact.md "Thickness"): the
 * barrier, its friction's normal force and their derivatives act on the distance less 1 mm;
 * started dhat / 2 beyond that offset, it slides and sticks as the thin one does, and the same
 * gradients match central differences. */
static void test_incline_thick_newton(void **st)
{
    (void)st;
    incline(NC, 2e-3);
}

/* The cloth falls at 3 m/s, 2 cm above the sphere: its first step's inertial predictor
 * x0 + h v0 puts the middle vertices 1 cm inside the sphere, so Newton's updates towards it
 * are cut by CCD (and the start is cut back to x0), yet the converged step keeps them outside;
 * the adjoint ignores the cut and the gradients still match central differences (steps 1e-7
 * m and 1e-4 m/s along random directions, 1e-5 in mu: at 1e-6 the loss differs by about 1e-7,
 * within reach of the forward runs' Newton tolerance, and newmark's estimate moved by 1.4e-5
 * when an experiment changed only the rounding of the PSD projections). */
static void cloth(const char *backend)
{
    const cscene sc = {CLOTH, backend, 0.3, 3.0, 1e-2, 8, 0.0};
    defsim_world *w = build(&sc, -1, 0.0, NULL);
    const int n = defsim_world_vertex_count(w);
    double *x = tu_positions(w), *v = tu_velocities(w);
    int inside = 0;
    for (int i = 0; i < n; ++i) {
        double r2 = 0.0;
        for (int k = 0; k < 3; ++k) r2 += pow(x[3 * i + k] + sc.h * v[3 * i + k], 2);
        inside += r2 < SPHERE_R * SPHERE_R;
    }
    TU_OK(defsim_world_step(w, sc.h));
    double *x1 = tu_positions(w), dmin = INFINITY;
    for (int i = 0; i < n; ++i)
        dmin = fmin(dmin, sqrt(pow(x1[3 * i], 2) + pow(x1[3 * i + 1], 2) + pow(x1[3 * i + 2], 2)) -
                              SPHERE_R);
    printf("cloth %s: the first step's predictor puts %d of %d vertices inside the sphere; the "
           "step ends with the lowest %.3e m above it\n", backend, inside, n, dmin);
    assert_true(inside >= 1 && dmin > 0.0);
    free(x);
    free(v);
    free(x1);
    defsim_world_destroy(w);
    const qstep qs[] = {{Q_X0, 1e-7}, {Q_V0, 1e-4}, {Q_MU, 1e-5}};
    check_all(&sc, n, 23, qs, 3, "cloth on a sphere");
}

static void test_cloth_newton(void **st)
{
    (void)st;
    cloth(NC);
}

static void test_cloth_newmark(void **st)
{
    (void)st;
    cloth(NM);
}

/* Recomputation of contact steps (interval 3) is bit for bit, and the run goes on after a
 * backward pass as if there had been none; bad arguments leave the world as it was. */
static void leaves_run(const cscene sc)
{
    defsim_world *w = build(&sc, -1, 0.0, NULL), *ref = build(&sc, -1, 0.0, NULL);
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
    double *cx, *cv;
    loss_weights(&sc, n, &cx, &cv);
    const int64_t cnt = (int64_t)n3 * (sc.steps + 1);
    static const char *const cstats[] = {"contact.pairs", "contact.active", "contact.min_distance",
                                         "contact.body_candidates", "contact.body_active",
                                         "contact.body_min_distance"};
    double before[6];
    for (int k = 0; k < 6; ++k) before[k] = tu_stat(w, cstats[k]);
    double mu[2] = {0.0, 0.0}, mu3 = 0.0;
    /* a friction gradient of the wrong size, a loss gradient of the wrong size, NaN */
    const char *mu_name = sc.kind == INCLINE ? "collider_friction" : "body_friction";
    defsim_gradient bad = {mu_name, mu, sc.kind == INCLINE ? 2 : 3};
    assert_int_equal(defsim_tape_backward(t, cx, cv, cnt, &bad, 1), DEFSIM_ERR_INVALID_ARGUMENT);
    double mu2[2] = {0.0, 0.0};
    defsim_gradient good = {mu_name, sc.kind == INCLINE ? &mu3 : mu2, sc.kind == INCLINE ? 1 : 2};
    assert_int_equal(defsim_tape_backward(t, cx, cv, cnt - 1, &good, 1),
                     DEFSIM_ERR_INVALID_ARGUMENT);
    cx[5] = NAN;
    assert_int_equal(defsim_tape_backward(t, cx, cv, cnt, &good, 1), DEFSIM_ERR_INVALID_ARGUMENT);
    cx[5] = 0.0;
    TU_OK(defsim_tape_backward(t, cx, cv, cnt, &good, 1));
    defsim_tape_stats ts = {.size = sizeof ts};
    TU_OK(defsim_tape_get_stats(t, &ts));
    if (sc.kind == CUBES) mu3 = mu2[1];
    for (int k = 0; k < 6; ++k)   /* contact's statistics as they were */
        assert_true(tu_stat(w, cstats[k]) == before[k] ||
                    (isnan(before[k]) && isnan(tu_stat(w, cstats[k]))));
    assert_true(ts.recomputed_steps == 9 && mu3 != 0.0);
    assert_true(defsim_world_time(w) == defsim_world_time(ref));
    for (int s = 0; s < 5; ++s) {
        TU_OK(defsim_world_step(w, sc.h));
        TU_OK(defsim_world_step(ref, sc.h));
    }
    double *x = tu_positions(w), *xr = tu_positions(ref);
    assert_memory_equal(x, xr, (size_t)n3 * sizeof *x);
    printf("%s %s: dL/dmu %.6e; after a backward pass (%lld steps recomputed) the run goes on "
           "bit for bit\n", sc.kind == INCLINE ? "incline" : "cubes", sc.backend, mu3,
           (long long)ts.recomputed_steps);
    free(x);
    free(xr);
    free(cx);
    free(cv);
    defsim_tape_destroy(t);
    defsim_world_destroy(w);
    defsim_world_destroy(ref);
}

static void test_contact_backward_leaves_run(void **st)
{
    (void)st;
    leaves_run((cscene){INCLINE, NC, 0.2, 0.5, 1e-2, 9, 0.0});
    leaves_run((cscene){CUBES, NC, 0.5, 0.1, 1e-2, 9, 0.0});
}

/* The penalty's backends are refused; a collider moved during the recording (set_pose) is
 * recorded, its poses differentiated (test_gradients_poses checks them). */
static void test_contact_unsupported(void **st)
{
    (void)st;
    cscene sc = {INCLINE, NC, 0.2, 0.5, 1e-2, 2, 0.0};
    defsim_world *w = build(&sc, -1, 0.0, NULL);
    defsim_tape *t = NULL;
    TU_OK(defsim_world_record(w, NULL, &t));
    TU_OK(defsim_world_step(w, sc.h));
    defsim_collider_id id;
    TU_OK(defsim_world_get_collider(w, 0, &id, NULL));
    const double p[3] = {0.0, -1e-3, 0.0}, q[4] = {1, 0, 0, 0};
    TU_OK(defsim_collider_set_pose(w, id, p, q));
    TU_OK(defsim_world_step(w, sc.h));
    double gp[3 * 6];
    const defsim_gradient g = {"collider_poses", gp, 3 * 6};
    TU_OK(defsim_tape_backward(t, NULL, NULL, 0, &g, 1));
    defsim_tape_stats ts = {.size = sizeof ts};
    TU_OK(defsim_tape_get_stats(t, &ts));
    assert_true(ts.steps == 2);
    defsim_tape_destroy(t);
    defsim_world_destroy(w);
    /* symplectic Euler and velocity Verlet: contact is the penalty */
    const char *const penalty[2] = {"symplectic_euler", "velocity_verlet"};
    for (int b = 0; b < 2; ++b) {
        defsim_world *e = tu_world(penalty[b], -9.81, 1);
        const double lo[3] = {0, 0.1, 0}, hi[3] = {0.1, 0.2, 0.1};
        tu_add_box(e, DEFSIM_MODEL_COROTATED, 1, 1, 1, lo, hi, 1e5, 0.3, 1000);
        defsim_collider_def cd;
        defsim_collider_def_init(&cd, sizeof cd);
        TU_OK(defsim_world_add_collider(e, &cd, &id));
        assert_int_equal(defsim_world_record(e, NULL, &t), DEFSIM_ERR_UNSUPPORTED);
        printf("  %s\n", defsim_world_last_error(e));
        assert_non_null(strstr(defsim_world_last_error(e), "penalty"));
        assert_non_null(strstr(defsim_world_last_error(e), penalty[b]));
        TU_OK(defsim_world_step(e, 1e-4));
        defsim_world_destroy(e);
    }
}

/* A cube landing on a cube (body contact: the barrier between the bodies' boundary triangles,
 * point-triangle and edge-edge pairs, with friction mu 0.5 from both bodies). The loss is the
 * top cube's mean height plus its mean x after the run; its gradient in the initial positions
 * and velocities (random directions; steps 1e-8 m and 1e-6 m/s), the top cube's density and
 * Young's modulus (1e-4 relative) and the friction of both bodies moved together (1e-6). */
static void cubes(const char *backend, double thick)
{
    const cscene sc = {CUBES, backend, 0.5, 0.1, 1e-2, 10, thick};
    defsim_world *w = build(&sc, -1, 0.0, NULL);
    const int n = defsim_world_vertex_count(w);
    for (int s = 0; s < sc.steps; ++s) TU_OK(defsim_world_step(w, sc.h));
    double *x = tu_positions(w), *v = tu_velocities(w), vx = 0.0;
    for (int i = 8; i < n; ++i) vx += v[3 * i] / (n - 8);
    const double dmin = tu_stat(w, "contact.body_min_distance");
    printf("cubes %s: %.0f candidate pairs at the end, the closest %.3e m apart (dhat 2.1e-4); "
           "the top cube moves sideways at %.4f m/s (from 0.1)\n", backend,
           tu_stat(w, "contact.body_candidates"), dmin, vx);
    assert_true(dmin > 0.0 && vx < 0.1);   /* dmin: beyond the offset t */
    free(x);
    free(v);
    defsim_world_destroy(w);
    const qstep qs[] = {{Q_V0, 1e-6}, {Q_X0, 1e-8}, {Q_RHO, 1e-4}, {Q_E, 1e-4}, {Q_BMU, 1e-4}};
    check_all(&sc, n, 31, qs, 5,
              thick > 0.0 ? "cube on a cube, 1 mm thick" : "cube on a cube");
}

static void test_cubes_newton(void **st)
{
    (void)st;
    cubes(NC, 0.0);
}

/* The cubes with a contact thickness of 1 mm each (the pair's offset 1 mm: the top cube starts
 * 1 mm higher): body contact's barrier and lagged friction on d - xi, the same gradients. */
static void test_cubes_thick_newton(void **st)
{
    (void)st;
    cubes(NC, 1e-3);
}

static void test_cubes_newmark(void **st)
{
    (void)st;
    cubes(NM, 0.0);
}

/* BDF2 (its barrier and lagged friction through ic_adjoint, its history through bdf2_adjoint):
 * the cube on a cube and the sliding and sticking block, against central differences too. */
static void test_contact_bdf2(void **st)
{
    (void)st;
    incline(BD, 0.0);
    cubes(BD, 0.0);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_contact_unsupported),
        cmocka_unit_test(test_contact_backward_leaves_run),
        cmocka_unit_test(test_incline_newton),
        cmocka_unit_test(test_incline_newmark),
        cmocka_unit_test(test_incline_thick_newton),
        cmocka_unit_test(test_cloth_newton),
        cmocka_unit_test(test_cloth_newmark),
        cmocka_unit_test(test_cubes_newton),
        cmocka_unit_test(test_cubes_newmark),
        cmocka_unit_test(test_contact_bdf2),
        cmocka_unit_test(test_cubes_thick_newton),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
