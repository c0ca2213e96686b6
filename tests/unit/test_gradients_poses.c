/* SPDX-License-Identifier: MIT */
/*
 * Gradients with respect to the colliders' poses over time (issue 25, docs/gradients.md
 * "Collider poses"): `collider_poses` from the tape's backward pass against central finite
 * differences of whole runs (Richardson-extrapolated) on the barrier's differentiable backends
 * (newton_cholmod, newmark, bdf2), along random directions of the translations and of the
 * rotations separately: a block carried and tilted by a ground plane that moves every step
 * (barrier and friction at both ends of each step), a cloth falling onto a sphere that sinks,
 * drifts and spins under it (friction dragged by the spin, with a still ground plane as a
 * second collider), and a block resting on a still plane (its poses are parameters too);
 * checkpoints give the same gradients bit for bit and the run goes on after a backward pass as
 * without it; a collider replaced during the recording still refuses the backward pass, and a
 * wrong count is refused.
 */
#include "test_util.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static const char NC[] = "newton_cholmod", NM[] = "newmark", BD[] = "bdf2";
static const char *const BACKENDS[3] = {NC, NM, BD};

enum { BLOCK, CLOTH };

typedef struct pscene {
    int kind;
    const char *backend;
    int steps;
    double h;
    int still;                /* BLOCK: the plane stays (set_pose never moves it) */
} pscene;

#define SPHERE_R 0.3
#define BLOCK_CELL 0.1

/* The colliders of a scene: BLOCK one plane, CLOTH a sphere and a still plane below it. */
static int ncolliders(const pscene *sc) { return sc->kind == BLOCK ? 1 : 2; }

/* The quaternion (w, x, y, z) of the rotation by |th| about th's direction. */
static void quat_of(const double th[3], double q[4])
{
    const double a = sqrt(th[0] * th[0] + th[1] * th[1] + th[2] * th[2]);
    const double s = a > 0.0 ? sin(0.5 * a) / a : 0.5;
    q[0] = cos(0.5 * a);
    for (int k = 0; k < 3; ++k) q[1 + k] = s * th[k];
}

/* r = a b (Hamilton product), normalised. */
static void quat_mul(const double a[4], const double b[4], double r[4])
{
    double o[4] = {a[0] * b[0] - a[1] * b[1] - a[2] * b[2] - a[3] * b[3],
                   a[0] * b[1] + a[1] * b[0] + a[2] * b[3] - a[3] * b[2],
                   a[0] * b[2] - a[1] * b[3] + a[2] * b[0] + a[3] * b[1],
                   a[0] * b[3] + a[1] * b[2] - a[2] * b[1] + a[3] * b[0]};
    const double n = sqrt(o[0] * o[0] + o[1] * o[1] + o[2] * o[2] + o[3] * o[3]);
    for (int k = 0; k < 4; ++k) r[k] = o[k] / n;
}

/* Collider c's pose at state s, moved by e along dir (6 per collider and state: dp, then the
 * rotation vector dtheta of (I + [dtheta]) R, world frame; NULL: none). BLOCK: the plane slides
 * along x at 0.3 m/s, sinks 20 um per step and tilts 0.5 mrad per step about an axis through the
 * block's middle; CLOTH: the sphere sinks 1 mm and drifts 0.2 mm per step and spins 20 mrad per
 * step about a tilted axis; the plane under it (collider 1) stays. Neither moves towards the
 * body by more than the gap within a step: Newmark's a_n takes the contact force at x_n against
 * the step's end pose (docs/gradients.md), which is infinite past the surface. */
static void pose_at(const pscene *sc, int c, int s, double e, const double *dir, double p[3],
                    double q[4])
{
    double th[3] = {0, 0, 0};
    p[0] = p[1] = p[2] = 0.0;
    if (sc->kind == BLOCK) {
        const int m = sc->still ? 0 : s;
        const double a = 5e-4 * m, ax[3] = {0.3, 0.0, 1.0}, na = sqrt(1.09);
        p[0] = 0.05 + 0.003 * m;
        p[1] = -2e-5 * m;
        p[2] = 0.05;
        for (int k = 0; k < 3; ++k) th[k] = a * ax[k] / na;
    } else if (c == 0) {
        const double a = 0.02 * s, ax[3] = {0.2, 1.0, 0.3}, na = sqrt(1.13);
        p[0] = 2e-4 * s;
        p[1] = -1e-3 * s;
        p[2] = -1e-4 * s;
        for (int k = 0; k < 3; ++k) th[k] = a * ax[k] / na;
    } else {
        p[1] = -0.5;
    }
    quat_of(th, q);
    if (!dir) return;
    const double *d = dir + 6 * ((int64_t)ncolliders(sc) * s + c);
    double dth[3], dq[4], q0[4];
    for (int k = 0; k < 3; ++k) {
        p[k] += e * d[k];
        dth[k] = e * d[3 + k];
    }
    quat_of(dth, dq);
    memcpy(q0, q, sizeof q0);
    quat_mul(dq, q0, q);
}

/* The scene's world (converged tightly, the contact stop off) with its colliders at state 0's
 * poses moved by e along dir. */
static defsim_world *build(const pscene *sc, double e, const double *dir)
{
    defsim_world *w = tu_implicit_world(sc->backend, -9.81, 1, 1e-13, 200, DEFSIM_PROJECTION_CLAMP);
    assert_true(tu_backend_option(w, sc->backend, "contact_tolerance", 0.0));
    double *x, *v;
    int n;
    if (sc->kind == BLOCK) {
        /* a 10 cm block, its bottom face dhat / 2 above the plane */
        const double lo[3] = {0, 0, 0}, hi[3] = {BLOCK_CELL, BLOCK_CELL, BLOCK_CELL};
        tu_add_box(w, DEFSIM_MODEL_STABLE_NEOHOOKEAN, 1, 1, 1, lo, hi, 1e5, 0.3, 1000.0);
        n = defsim_world_vertex_count(w);
        x = tu_positions(w);
        v = calloc(3 * (size_t)n, sizeof *v);
        for (int i = 0; i < n; ++i) x[3 * i + 1] += 0.5e-3 * sqrt(3.0) * BLOCK_CELL;
    } else {
        /* the spring cloth 2 cm above the sphere's top, off centre, falling at 3 m/s */
        const double o[3] = {-0.13, SPHERE_R + 0.02, -0.17}, u[3] = {0.4, 0, 0},
                     vv[3] = {0, 0, 0.4};
        tu_add_spring_cloth(w, o, u, vv, 4, 4, 200.0, 0.01);
        n = defsim_world_vertex_count(w);
        x = tu_positions(w);
        v = calloc(3 * (size_t)n, sizeof *v);
        for (int i = 0; i < n; ++i) v[3 * i + 1] = -3.0;
    }
    TU_OK(defsim_world_set_state(w, x, v));
    free(x);
    free(v);
    for (int c = 0; c < ncolliders(sc); ++c) {
        defsim_collider_def cd;
        defsim_collider_def_init(&cd, sizeof cd);
        cd.shape = sc->kind == CLOTH && c == 0 ? DEFSIM_SHAPE_SPHERE : DEFSIM_SHAPE_PLANE;
        cd.radius = SPHERE_R;
        cd.friction = sc->kind == BLOCK ? 0.5 : c == 0 ? 0.3 : 0.1;
        pose_at(sc, c, 0, e, dir, cd.position, cd.rotation);
        TU_OK(defsim_world_add_collider(w, &cd, NULL));
    }
    return w;
}

/* Steps s0 .. s1 - 1 of the run, moving the colliders to state s + 1's poses before step s. */
static void steps(const pscene *sc, defsim_world *w, int s0, int s1, double e, const double *dir)
{
    for (int s = s0; s < s1; ++s) {
        for (int c = 0; c < ncolliders(sc); ++c) {
            defsim_collider_id id;
            double p[3], q[4];
            TU_OK(defsim_world_get_collider(w, c, &id, NULL));
            pose_at(sc, c, s + 1, e, dir, p, q);
            TU_OK(defsim_collider_set_pose(w, id, p, q));
        }
        const defsim_status st = defsim_world_step(w, sc->h);
        if (st != DEFSIM_OK) fail_msg("step %d: %s", s, defsim_world_last_error(w));
    }
}

/* The run; with cx, cv, its loss cx . x_N + cv . v_N. */
static double run(const pscene *sc, defsim_world *w, double e, const double *dir,
                  const double *cx, const double *cv)
{
    steps(sc, w, 0, sc->steps, e, dir);
    if (!cx) return 0.0;
    const int n3 = 3 * defsim_world_vertex_count(w);
    double *x = tu_positions(w), *v = tu_velocities(w), L = 0.0;
    for (int i = 0; i < n3; ++i) L += cx[i] * x[i] + cv[i] * v[i];
    free(x);
    free(v);
    return L;
}

/* The poses' gradient of the recorded run (interval k), and of x0 (both may be NULL). */
static defsim_status tape_grads(const pscene *sc, int k, const double *cx, const double *cv,
                                double *gpose, double *gx0, double *ratio)
{
    defsim_world *w = build(sc, 0.0, NULL);
    const int n3 = 3 * defsim_world_vertex_count(w);
    defsim_tape_def td;
    defsim_tape_def_init(&td, sizeof td);
    td.interval = k;
    defsim_tape *t = NULL;
    TU_OK(defsim_world_record(w, &td, &t));
    run(sc, w, 0.0, NULL, NULL, NULL);
    const int64_t all = (int64_t)n3 * (sc->steps + 1);
    double *dx = calloc((size_t)all, sizeof *dx), *dv = calloc((size_t)all, sizeof *dv);
    memcpy(dx + all - n3, cx, (size_t)n3 * sizeof *dx);
    memcpy(dv + all - n3, cv, (size_t)n3 * sizeof *dv);
    const defsim_gradient g[2] = {
        {"collider_poses", gpose, 6 * (int64_t)ncolliders(sc) * (sc->steps + 1)},
        {"initial_positions", gx0, n3}};
    const defsim_status st = defsim_tape_backward(t, dx, dv, all, g, gx0 ? 2 : 1);
    if (st != DEFSIM_OK) fail_msg("backward: %s", defsim_tape_last_error(t));
    defsim_tape_stats ts = {.size = sizeof ts};
    TU_OK(defsim_tape_get_stats(t, &ts));
    if (ratio) *ratio = ts.time_backward / ts.time_forward;
    if (k > 1) assert_true(ts.recomputed_steps > 0);
    free(dx);
    free(dv);
    defsim_tape_destroy(t);
    defsim_world_destroy(w);
    return st;
}

/* The loss's random weights on the last state (velocities weighted 0.01). */
static void weights(int n3, double *cx, double *cv)
{
    unsigned long long seed = 7;
    for (int i = 0; i < n3; ++i) {
        cx[i] = tu_rand(&seed);
        cv[i] = 0.01 * tu_rand(&seed);
    }
}

/* One scene on one backend: the tape's collider_poses along a random direction of the
 * translations (step eps_p, m) and one of the rotations (eps_r, rad), each against central
 * differences with steps eps and 2 eps extrapolated (Richardson), relative 1e-5. */
static void check_scene(const pscene *sc, double eps_p, double eps_r, const char *what)
{
    defsim_world *w0 = build(sc, 0.0, NULL);
    const int n3 = 3 * defsim_world_vertex_count(w0);
    defsim_world_destroy(w0);
    const int np = 6 * ncolliders(sc) * (sc->steps + 1);
    double *cx = malloc((size_t)n3 * sizeof *cx), *cv = malloc((size_t)n3 * sizeof *cv);
    double *g = malloc((size_t)np * sizeof *g), *dir = malloc((size_t)np * sizeof *dir), ratio;
    weights(n3, cx, cv);
    tape_grads(sc, 1, cx, cv, g, NULL, &ratio);
    printf("%s %s: backward / forward time %.2f\n", what, sc->backend, ratio);
    unsigned long long seed = 11;
    for (int part = 0; part < 2; ++part) {   /* translations, then rotations */
        double an = 0.0, nrm = 0.0;
        for (int i = 0; i < np; ++i) {
            dir[i] = (i % 6 < 3) == (part == 0) ? tu_rand(&seed) : 0.0;
            an += g[i] * dir[i];
            nrm += fabs(g[i] * dir[i]);
        }
        const double eps = part == 0 ? eps_p : eps_r;
        double L[4];
        for (int k = 0; k < 4; ++k) {
            const double e = (k < 2 ? eps : 2.0 * eps) * (k % 2 ? -1.0 : 1.0);
            defsim_world *w = build(sc, e, dir);
            L[k] = run(sc, w, e, dir, cx, cv);
            defsim_world_destroy(w);
        }
        const double d1 = (L[0] - L[1]) / (2.0 * eps), d2 = (L[2] - L[3]) / (4.0 * eps);
        const double num = (4.0 * d1 - d2) / 3.0;
        const double rel = fabs(an - num) / fmax(fabs(num), 1e-300);
        printf("%s %s d/d(collider_poses, %s): tape %.12e  central differences (step %g) %.12e  "
               "relative %.2e (sum of |terms| %.3e)\n",
               what, sc->backend, part == 0 ? "translations" : "rotations", an, eps, num, rel,
               nrm);
        /* the gradient is not trivially small: its terms do not cancel to nothing */
        assert_true(fabs(num) > 1e-3 * nrm);
        if (!(rel <= 1e-5))
            fail_msg("%s %s: collider_poses (%s) relative error %.3g > 1e-5", what, sc->backend,
                     part == 0 ? "translations" : "rotations", rel);
    }
    free(cx);
    free(cv);
    free(g);
    free(dir);
}

/* The block on the moving plane: dragged along by friction (mu 0.5) from rest, sinking and tilted,
 * 12 steps of 10 ms; steps 1e-8 m and 1e-7 rad (the plane's origin is under the block's middle,
 * so a rotation moves the block's bottom by at most 1e-8 m, 1/17000 of dhat: on Newmark, steps
 * ten times larger leave 1e-5 of the gradient in the extrapolation's error, those of 1e-6 m 2e-2,
 * from the curvature of friction's stick regime, while the tape's gradient agrees with steps
 * of 1e-8 m to 9e-10). The block must
 * end carried along near the plane's speed (Newmark, which does not dissipate, overshoots it in
 * friction's stick regime: 0.37 m/s). */
static void block(const char *backend)
{
    const pscene sc = {BLOCK, backend, 12, 1e-2, 0};
    defsim_world *w = build(&sc, 0.0, NULL);
    const int n = defsim_world_vertex_count(w);
    run(&sc, w, 0.0, NULL, NULL, NULL);
    double *v = tu_velocities(w), vx = 0.0;
    for (int i = 0; i < n; ++i) vx += v[3 * i] / n;
    printf("block on a moving plane %s: carried at %.4f m/s (the plane: 0.3 m/s), %.0f contact "
           "pairs\n", backend, vx, tu_stat(w, "contact.active"));
    assert_true(vx > 0.1 && vx < 0.5);
    free(v);
    defsim_world_destroy(w);
    check_scene(&sc, 1e-8, 1e-7, "block on a moving plane");
}

/* The cloth falling at 3 m/s onto the rising, drifting and spinning sphere (mu 0.3; the still
 * plane below, the second collider, is out of reach: its gradient is 0), 8 steps of 10 ms;
 * steps 1e-7 m and 3e-7 rad (1e-7 m at the sphere's surface). */
static void cloth(const char *backend)
{
    const pscene sc = {CLOTH, backend, 8, 1e-2, 0};
    check_scene(&sc, 1e-7, 3e-7, "cloth on a moving sphere");
}

/* A still plane is a parameter too (the gradient of moving it from rest): the block resting on
 * it for 10 steps; the perturbed runs move the plane a little in every step. */
static void test_still_plane(void **st)
{
    (void)st;
    const pscene sc = {BLOCK, NC, 10, 1e-2, 1};
    check_scene(&sc, 1e-8, 1e-7, "block on a still plane");
}

/* The cases' state: the backend's name. */
static void test_block(void **st) { block((const char *)*st); }

static void test_cloth(void **st) { cloth((const char *)*st); }

/* Checkpoints every 3rd state (and the automatic interval, which stores all here) give the
 * gradients of storing every state bit for bit: the recomputed steps hold the recorded poses
 * again. On each backend, the block's run. */
static void test_checkpoints(void **st)
{
    (void)st;
    for (int b = 0; b < 3; ++b) {
        const pscene sc = {BLOCK, BACKENDS[b], 10, 1e-2, 0};
        defsim_world *w = build(&sc, 0.0, NULL);
        const int n3 = 3 * defsim_world_vertex_count(w);
        defsim_world_destroy(w);
        const int np = 6 * (sc.steps + 1);
        double *cx = malloc((size_t)n3 * sizeof *cx), *cv = malloc((size_t)n3 * sizeof *cv);
        double *g1 = malloc((size_t)np * sizeof *g1), *g3 = malloc((size_t)np * sizeof *g3);
        double *x1 = malloc((size_t)n3 * sizeof *x1), *x3 = malloc((size_t)n3 * sizeof *x3);
        weights(n3, cx, cv);
        tape_grads(&sc, 1, cx, cv, g1, x1, NULL);
        tape_grads(&sc, 3, cx, cv, g3, x3, NULL);
        assert_memory_equal(g1, g3, (size_t)np * sizeof *g1);
        assert_memory_equal(x1, x3, (size_t)n3 * sizeof *x1);
        double gmax = 0.0;
        for (int i = 0; i < np; ++i) gmax = fmax(gmax, fabs(g1[i]));
        assert_true(gmax > 0.0);
        printf("checkpoints %s: interval 3 gives interval 1's collider_poses bit for bit (largest "
               "|component| %.3e)\n", BACKENDS[b], gmax);
        free(cx);
        free(cv);
        free(g1);
        free(g3);
        free(x1);
        free(x3);
    }
}

/* After a backward pass that recomputed steps (interval 3), the world's colliders are where the
 * run left them and the run goes on bit for bit, the colliders moving on, as in a world that
 * had no backward pass. */
static void test_backward_leaves_run(void **st)
{
    (void)st;
    const pscene sc = {CLOTH, BD, 7, 1e-2, 0};
    defsim_world *w = build(&sc, 0.0, NULL), *ref = build(&sc, 0.0, NULL);
    const int n3 = 3 * defsim_world_vertex_count(w);
    defsim_tape_def td;
    defsim_tape_def_init(&td, sizeof td);
    td.interval = 3;
    defsim_tape *t = NULL;
    TU_OK(defsim_world_record(w, &td, &t));
    run(&sc, w, 0.0, NULL, NULL, NULL);
    run(&sc, ref, 0.0, NULL, NULL, NULL);
    double *dx = calloc((size_t)n3 * 8, sizeof *dx), g[8 * 2 * 6];
    for (int i = 0; i < n3; ++i) dx[7 * n3 + i] = 1.0;
    const defsim_gradient gr = {"collider_poses", g, 8 * 2 * 6};
    TU_OK(defsim_tape_backward(t, dx, NULL, (int64_t)n3 * 8, &gr, 1));
    defsim_tape_stats ts = {.size = sizeof ts};
    TU_OK(defsim_tape_get_stats(t, &ts));
    assert_true(ts.recomputed_steps == 6);
    defsim_collider_def a, b;
    a.size = b.size = sizeof a;
    TU_OK(defsim_world_get_collider(w, 0, NULL, &a));
    TU_OK(defsim_world_get_collider(ref, 0, NULL, &b));
    assert_memory_equal(a.position, b.position, sizeof a.position);
    assert_memory_equal(a.rotation, b.rotation, sizeof a.rotation);
    steps(&sc, w, sc.steps, sc.steps + 4, 0.0, NULL);
    steps(&sc, ref, sc.steps, sc.steps + 4, 0.0, NULL);
    double *x = tu_positions(w), *xr = tu_positions(ref);
    assert_memory_equal(x, xr, (size_t)n3 * sizeof *x);
    printf("cloth on a moving sphere bdf2: after a backward pass (%lld steps recomputed) the run "
           "goes on bit for bit\n", (long long)ts.recomputed_steps);
    free(x);
    free(xr);
    free(dx);
    defsim_tape_destroy(t);
    defsim_world_destroy(w);
    defsim_world_destroy(ref);
}

/* Poses are followed, the colliders themselves are not: a collider replaced during the
 * recording by one of another friction (its slot reused) stops it, and the backward pass says
 * so; a wrong count of collider_poses is refused; the world is left as it was. */
static void test_refused(void **st)
{
    (void)st;
    const pscene sc = {BLOCK, BACKENDS[0], 3, 1e-2, 0};
    defsim_world *w = build(&sc, 0.0, NULL);
    const int n3 = 3 * defsim_world_vertex_count(w);
    defsim_tape *t = NULL;
    TU_OK(defsim_world_record(w, NULL, &t));
    run(&sc, w, 0.0, NULL, NULL, NULL);
    double g[6 * 4], bad[6 * 3];
    defsim_gradient gr = {"collider_poses", g, 6 * 4};
    TU_OK(defsim_tape_backward(t, NULL, NULL, 0, &gr, 1));
    defsim_gradient wrong = {"collider_poses", bad, 6 * 3};
    assert_int_equal(defsim_tape_backward(t, NULL, NULL, 0, &wrong, 1),
                     DEFSIM_ERR_INVALID_ARGUMENT);
    printf("  %s\n", defsim_tape_last_error(t));
    assert_non_null(strstr(defsim_tape_last_error(t), "collider_poses"));
    /* the same plane with another friction, in the same slot */
    defsim_collider_id id;
    defsim_collider_def cd;
    cd.size = sizeof cd;
    TU_OK(defsim_world_get_collider(w, 0, &id, &cd));
    TU_OK(defsim_world_remove_collider(w, id));
    cd.friction = 0.2;
    TU_OK(defsim_world_add_collider(w, &cd, NULL));
    TU_OK(defsim_world_step(w, sc.h));
    double *x = tu_positions(w);
    assert_int_equal(defsim_tape_backward(t, NULL, NULL, 0, &gr, 1), DEFSIM_ERR_INVALID_ARGUMENT);
    printf("  %s\n", defsim_tape_last_error(t));
    assert_non_null(strstr(defsim_tape_last_error(t), "collider"));
    assert_non_null(strstr(defsim_tape_last_error(t), "replaced"));
    double *x2 = tu_positions(w);   /* the world as it was */
    assert_memory_equal(x, x2, (size_t)n3 * sizeof *x);
    free(x);
    free(x2);
    defsim_tape_destroy(t);
    defsim_world_destroy(w);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_refused),
        {.name = "test_block_newton", .test_func = test_block, .initial_state = (void *)NC},
        {.name = "test_block_newmark", .test_func = test_block, .initial_state = (void *)NM},
        {.name = "test_block_bdf2", .test_func = test_block, .initial_state = (void *)BD},
        {.name = "test_cloth_newton", .test_func = test_cloth, .initial_state = (void *)NC},
        {.name = "test_cloth_newmark", .test_func = test_cloth, .initial_state = (void *)NM},
        {.name = "test_cloth_bdf2", .test_func = test_cloth, .initial_state = (void *)BD},
        cmocka_unit_test(test_still_plane),
        cmocka_unit_test(test_checkpoints),
        cmocka_unit_test(test_backward_leaves_run),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
