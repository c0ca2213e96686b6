/* SPDX-License-Identifier: MIT */
/*
 * Checkpoints bit-exact with colliders (issue 23): every scene kind (colliders still, moving,
 * stopped after moving, under auto_substep, an SDF installed again after the load; friction;
 * attachments, driven pins, held forces and a force callback beside a frictional collider; body
 * contact) on all nine backends
 * (docs/checkpoints.md "What continues bit for bit" has the matrix and sundials_erk's one
 * exception). A run is saved after N steps with the next step's collider pose and pin target
 * pending, loaded into a new world (the force callback installed again), and both step M more:
 * positions, velocities and the clock must have the same bits, and so must a world loaded from
 * the loaded world's own checkpoint. Saved early and mid-run; with --long (long_adv_ckpt)
 * late, and after every 5th step of a run. Each scene is checked to do
 * what it claims (contact forces, forces along the ground, body contact pairs), so that no case
 * passes by having nothing to continue.
 *
 * What it caught: the penalty frequency computed again at the load (every penalty backend),
 * friction's matrix-block velocities (sundials_kinsol), sundials_erk's replay without the
 * colliders (a failed load) and its miss by a still, rotated collider's roundoff velocity,
 * newmark reading a freed pattern after loading body contact.
 */
#include "test_util.h"

#include "checkpoint.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

enum { K_STILL, K_FRICTION, K_MOVING, K_STOPPED, K_SUBSTEP, K_COUPLED, K_SDF, K_BODY, K_COUNT };
static const char *const kind_name[K_COUNT] = {"still",   "friction", "moving", "stopped",
                                               "substep", "coupled",  "sdf",    "body"};

/* K_STOPPED: the sphere moves in steps 1 .. stop_after (the last step before the save), then
 * stays where it is, so that the steps after the load continue a history (no reset for a
 * moving collider) that began while it moved. */
static int stop_after = 0;

/* All nine backends. */
static const char *const backends[] = {"symplectic_euler", "explicit_euler", "velocity_verlet",
                                       "newton_cholmod",   "newmark",        "bdf2",
                                       "sundials_ida",     "sundials_kinsol", "sundials_erk"};
enum { NB = sizeof backends / sizeof backends[0] };

static const double H = 5e-4;

/* K_SUBSTEP takes 8 times longer steps with core.auto_substep on (several substeps per step on
 * the backends with a stable-step estimate; one step on the others). */
static double step_of(int kind) { return kind == K_SUBSTEP ? 8.0 * H : H; }

/* The force callback: a drag and a time-varying push along z on every vertex, with its
 * constants behind `user` (which the loaded world must be given again). */
typedef struct wind {
    double drag, push;
} wind;

static int wind_force(void *user, const double *x, const double *v, double t, int32_t n,
                      double *f)
{
    const wind *p = user;
    for (int32_t i = 0; i < n; ++i) {
        for (int k = 0; k < 3; ++k) f[3 * i + k] -= p->drag * v[3 * i + k];
        f[3 * i + 2] += p->push * sin(40.0 * t + x[3 * i]);
    }
    return 0;
}

static wind the_wind = {0.05, 0.02};

/* K_SDF's ground: the half-space y < 0 as the host's signed distance (local frame). */
static double ground_sdf(void *user, const double p[3], double grad[3])
{
    (void)user;
    grad[0] = 0.0;
    grad[1] = 1.0;
    grad[2] = 0.0;
    return p[1];
}

static int is_ccd(const char *backend)
{
    return strcmp(backend, "newton_cholmod") == 0 || strcmp(backend, "newmark") == 0 ||
           strcmp(backend, "bdf2") == 0;
}

/* A soft stable neo-Hookean cube (2 cells a side, 0.2 m; body friction the default 0.5) at
 * height y0 with Rayleigh stiffness damping (explicit_euler needs it to stay bounded at H). */
static defsim_body_id add_cube(defsim_world *w, double x0, double y0)
{
    defsim_material m;
    defsim_material_init(&m, sizeof m, DEFSIM_MODEL_STABLE_NEOHOOKEAN);
    m.youngs_modulus = 1e5;
    m.poisson_ratio = 0.3;
    m.density = 1000.0;
    m.stiffness_damping = 2e-3;
    const double lo[3] = {x0, y0, 0.0}, hi[3] = {x0 + 0.2, y0 + 0.2, 0.2};
    return tu_add_box_material(w, 2, 2, 2, lo, hi, &m);
}

static defsim_collider_id add_plane(defsim_world *w, double friction)
{
    defsim_collider_def cd;
    defsim_collider_def_init(&cd, sizeof cd);
    cd.friction = friction;
    defsim_collider_id id;
    TU_OK(defsim_world_add_collider(w, &cd, &id));
    return id;
}

/* Adds vx to every vertex's x velocity. */
static void slide(defsim_world *w, double vx)
{
    const int32_t n = defsim_world_vertex_count(w);
    double *x = tu_positions(w), *v = tu_velocities(w);
    for (int32_t i = 0; i < n; ++i) v[3 * i] += vx;
    TU_OK(defsim_world_set_state(w, x, v));
    free(x);
    free(v);
}

/* The scene of `kind` on `backend`, or NULL where it does not apply (body contact needs a
 * backend with CCD) or the backend is not in this build. */
static defsim_world *scene(const char *backend, int kind)
{
    /* sundials_erk under auto_substep: each substep is an ERK solve of many internal steps
     * against the stiff penalty, 10 s here; its history across substeps is what the other
     * kinds test. */
    if (!tu_available(backend) || (kind == K_BODY && !is_ccd(backend)) ||
        (kind == K_SUBSTEP && strcmp(backend, "sundials_erk") == 0))
        return NULL;
    defsim_world *w = tu_world(backend, -9.81, 1);
    switch (kind) {
    case K_STILL:   /* a cube falling onto a still, frictionless ground, and a still sphere */
        add_cube(w, 0.0, 0.0002);
        add_plane(w, 0.0);
        {
            defsim_collider_def cd;
            defsim_collider_def_init(&cd, sizeof cd);
            cd.shape = DEFSIM_SHAPE_SPHERE;
            cd.radius = 0.1;
            cd.position[0] = 0.1;
            cd.position[1] = 0.3;
            cd.position[2] = 0.1;
            TU_OK(defsim_world_add_collider(w, &cd, NULL));
        }
        break;
    case K_FRICTION:   /* a cube sliding on a frictional ground */
        add_cube(w, 0.0, 0.0001);
        add_plane(w, 0.6);
        slide(w, 0.5);
        break;
    case K_MOVING:
    case K_STOPPED:
    case K_SUBSTEP: {   /* a frictional sphere touching a cube's side, sliding along it and
                          turning (a collider that overruns a vertex's gap in one step is
                          another matter: newmark refuses such steps) */
        add_cube(w, 0.0, 0.0001);
        add_plane(w, 0.3);
        defsim_collider_def cd;
        defsim_collider_def_init(&cd, sizeof cd);
        cd.shape = DEFSIM_SHAPE_SPHERE;
        cd.radius = 0.1;
        cd.position[0] = -0.1001;
        cd.position[1] = 0.1;
        cd.position[2] = 0.1;
        cd.friction = 0.4;
        TU_OK(defsim_world_add_collider(w, &cd, NULL));
        if (kind == K_SUBSTEP) TU_OK(defsim_world_set_option(w, "core.auto_substep", "true"));
        break;
    }
    case K_COUPLED: {   /* attachments, a driven pin, the callback, held forces; friction */
        const defsim_body_id cube = add_cube(w, 0.0, 0.0001);
        add_plane(w, 0.5);
        double x[24];
        int32_t springs[20];
        tu_ladder(0.3, 0.1, 0.05, x, springs);
        for (int i = 0; i < 8; ++i) x[3 * i + 1] += 0.05;
        defsim_body_def bd;
        defsim_body_def_init(&bd, sizeof bd);
        defsim_material_init(&bd.material, sizeof bd.material, DEFSIM_MODEL_SPRING);
        bd.material.stiffness = 300.0;
        bd.material.vertex_mass = 0.02;
        bd.material.mass_damping = 0.5;
        bd.rest_positions = x;
        bd.vertex_count = 8;
        bd.springs = springs;
        bd.spring_count = 10;
        defsim_body_id ladder;
        TU_OK(defsim_world_add_body(w, &bd, &ladder));
        defsim_attachment_def ad;
        defsim_attachment_def_init(&ad, sizeof ad);
        ad.body = ladder;
        ad.vertex = 0;
        ad.stiffness = 400.0;
        ad.damping = 0.5;
        ad.target_body = cube;
        ad.target_vertex_count = 2;
        ad.target_vertices[0] = 2;    /* on the cube's x = 0.2 face */
        ad.target_vertices[1] = 8;
        ad.target_weights[0] = 0.5;
        ad.target_weights[1] = 0.5;
        TU_OK(defsim_world_add_attachment(w, &ad, NULL));
        defsim_attachment_def_init(&ad, sizeof ad);
        ad.body = ladder;
        ad.vertex = 5;
        ad.stiffness = 200.0;
        ad.target[0] = 0.6;
        ad.target[1] = 0.3;
        TU_OK(defsim_world_add_attachment(w, &ad, NULL));
        const int32_t nv = defsim_world_vertex_count(w);
        double *f = calloc(3 * (size_t)nv, sizeof *f);
        assert_non_null(f);
        for (int32_t i = nv - 8; i < nv; ++i) f[3 * i + 2] = 0.05 * (i % 3);
        TU_OK(defsim_world_set_external_forces(w, f, nv));
        free(f);
        TU_OK(defsim_world_set_force_callback(w, wind_force, NULL, &the_wind));
        slide(w, 0.2);
        break;
    }
    case K_SDF: {   /* a cube sliding on a tilted frictional ground given by the host's SDF */
        add_cube(w, 0.0, 0.0001);
        defsim_collider_def cd;
        defsim_collider_def_init(&cd, sizeof cd);
        cd.shape = DEFSIM_SHAPE_SDF;
        cd.sdf = ground_sdf;
        cd.friction = 0.5;
        const double a = 0.05;   /* about z: the ground slopes down along +x */
        cd.rotation[0] = cos(a / 2);
        cd.rotation[3] = -sin(a / 2);
        TU_OK(defsim_world_add_collider(w, &cd, NULL));
        slide(w, 0.2);
        break;
    }
    case K_BODY:   /* a cube falling onto another on a frictional ground: body contact */
        add_cube(w, 0.0, 0.0001);
        add_cube(w, 0.05, 0.2008);
        add_plane(w, 0.5);
        TU_OK(defsim_world_set_option(w, "core.body_contact", "true"));
        break;
    }
    return w;
}

/* What happens before step k (1-based) of a scene: the moving sphere gets its pose at the end of
 * step k; the ladder's last vertex its target. */
static void prepare(defsim_world *w, int kind, int k)
{
    if (kind == K_MOVING || kind == K_SUBSTEP || (kind == K_STOPPED && k <= stop_after)) {
        defsim_collider_id id;
        TU_OK(defsim_world_get_collider(w, 1, &id, NULL));
        const double a = 0.02 * k;   /* turning about z: its surface drags the cube along y */
        const double p[3] = {-0.1001, 0.1, 0.1 + 0.0002 * k};
        const double q[4] = {cos(a / 2), 0.0, 0.0, sin(a / 2)};
        TU_OK(defsim_collider_set_pose(w, id, p, q));
    } else if (kind == K_COUPLED) {
        defsim_body_id ladder;
        TU_OK(defsim_world_body_at(w, 1, &ladder));
        const int32_t v = 7;
        const double p[3] = {0.6, 0.15, 0.05 + 0.001 * k};
        TU_OK(defsim_body_set_pin_targets(w, ladder, &v, 1, p));
    }
}

static double stat(const defsim_world *w, const char *name)
{
    double v = 0.0;
    TU_OK(defsim_world_stat(w, name, &v));
    return v;
}

/* The largest contact force on a vertex (N), and its largest part along the ground (x, z). */
static void contact_force(const defsim_world *w, double *tangential, double *normal)
{
    const int32_t n = defsim_world_vertex_count(w);
    double *f = calloc(3 * (size_t)n, sizeof *f);
    assert_non_null(f);
    TU_OK(defsim_world_get_contact_forces(w, f, n));
    *tangential = *normal = 0.0;
    for (int32_t i = 0; i < n; ++i) {
        *tangential = fmax(*tangential, hypot(f[3 * i], f[3 * i + 2]));
        *normal = fmax(*normal, sqrt(f[3 * i] * f[3 * i] + f[3 * i + 1] * f[3 * i + 1] +
                                     f[3 * i + 2] * f[3 * i + 2]));
    }
    free(f);
}

/* The largest contact forces and body contact pairs seen after any step of a run. */
typedef struct seen {
    double normal, tangential, body_active;
} seen;

static void look(const defsim_world *w, seen *s)
{
    double ft = 0.0, fn = 0.0;
    contact_force(w, &ft, &fn);
    s->normal = fmax(s->normal, fn);
    s->tangential = fmax(s->tangential, ft);
    s->body_active = fmax(s->body_active, stat(w, "contact.body_active"));
}

static void run(defsim_world *w, int kind, int from, int n, seen *s)
{
    for (int k = from; k < from + n; ++k) {
        prepare(w, kind, k);
        const defsim_status st = defsim_world_step(w, step_of(kind));
        if (st != DEFSIM_OK)
            fail_msg("%s step %d: %s (%s)", kind_name[kind], k, defsim_status_string(st),
                     defsim_world_last_error(w));
        look(w, s);
    }
}

/* The SDF collider of a loaded world gets its function again (docs/checkpoints.md). */
static void reinstall_sdf(defsim_world *w)
{
    defsim_collider_id id;
    TU_OK(defsim_world_get_collider(w, 0, &id, NULL));
    TU_OK(defsim_collider_set_sdf(w, id, ground_sdf, NULL));
}

/* A new world from w's checkpoint, with the host's functions installed again. */
static defsim_world *reload(const defsim_world *w, int kind)
{
    void *buf = NULL;
    size_t size = 0;
    TU_OK(defsim_world_save_buffer(w, &buf, &size));
    defsim_world *b = NULL;
    const defsim_status st = defsim_world_load_buffer(buf, size, NULL, NULL, &b);
    defsim_buffer_free(buf);
    if (st != DEFSIM_OK) fail_msg("load: %s (%s)", defsim_status_string(st), defsim_last_error());
    if (kind == K_COUPLED) TU_OK(defsim_world_set_force_callback(b, wind_force, NULL, &the_wind));
    if (kind == K_SDF) reinstall_sdf(b);
    return b;
}

/* max |a - b| over positions (m); -1 where only the velocities or the clock differ. */
static double compare(const defsim_world *a, const defsim_world *b)
{
    const int32_t n = defsim_world_vertex_count(a);
    assert_int_equal(n, defsim_world_vertex_count(b));
    double *xa = tu_positions(a), *xb = tu_positions(b);
    double *va = tu_velocities(a), *vb = tu_velocities(b);
    const size_t bytes = 3 * (size_t)n * sizeof(double);
    const double ta = defsim_world_time(a), tb = defsim_world_time(b);
    double d = 0.0;
    if (memcmp(xa, xb, bytes) != 0 || memcmp(va, vb, bytes) != 0 || memcmp(&ta, &tb, sizeof ta)) {
        d = -1.0;
        for (int64_t i = 0; i < 3 * (int64_t)n; ++i) d = fmax(d, fabs(xa[i] - xb[i]));
    }
    free(xa); free(xb); free(va); free(vb);
    return d;
}

/* Runs every backend on one scene kind: before steps, then after steps on the original and on
 * two loaded worlds (one loaded from the other's checkpoint). Returns the number of cases run. */
static int check_kind(int kind, int before, int after, int *failures)
{
    int cases = 0;
    for (int bi = 0; bi < NB; ++bi) {
        const char *backend = backends[bi];
        struct timespec t0, t1;
        clock_gettime(CLOCK_MONOTONIC, &t0);
        defsim_world *a = scene(backend, kind);
        if (!a) continue;
        cases++;
        seen sn = {0.0, 0.0, 0.0};
        run(a, kind, 1, before, &sn);
        prepare(a, kind, before + 1);   /* pending at the save */
        defsim_world *b = reload(a, kind);
        defsim_world *c = reload(b, kind);
        const double d0 = compare(a, b);
        assert_true(d0 == 0.0);
        for (int k = before + 1; k <= before + after; ++k) {
            defsim_world *ws[3] = {a, b, c};
            for (int j = 0; j < 3; ++j) {
                if (k > before + 1) prepare(ws[j], kind, k);
                const defsim_status st = defsim_world_step(ws[j], step_of(kind));
                if (st != DEFSIM_OK)
                    fail_msg("%s %s world %d step %d: %s (%s)", backend, kind_name[kind], j, k,
                             defsim_status_string(st), defsim_world_last_error(ws[j]));
            }
            look(a, &sn);
        }
        const double db = compare(a, b), dc = compare(a, c);
        clock_gettime(CLOCK_MONOTONIC, &t1);
        printf("%5.2f s",
               (double)(t1.tv_sec - t0.tv_sec) + 1e-9 * (double)(t1.tv_nsec - t0.tv_nsec));
        printf("  %-9s %-16s loaded: %s (%.3g m), loaded twice: %s (%.3g m); contact force up to "
               "%.3g N, %.3g N along the ground\n", kind_name[kind], backend,
               db == 0.0 ? "same bits" : "DIFFERS", db, dc == 0.0 ? "same bits" : "DIFFERS", dc,
               sn.normal, sn.tangential);
        /* The scene does what it claims. */
        assert_true(sn.normal > 1.0);
        if (kind != K_STILL && kind != K_BODY)
            assert_true(sn.tangential > 1.0);
        if (kind == K_BODY) assert_true(sn.body_active > 0.0);
        /* sundials_erk replays the saved run's last internal step at the load, and the replay
         * sees the colliders at their current pose, still, and no SDF collider (its function
         * comes after the load): after a step in which the sphere moved (and rubbed), followed
         * by steps in which it stays (no restart), or on the SDF ground, the replay does not
         * land and ERKStep restarts from the state (docs/checkpoints.md): close, not the same
         * bits. */
        const int exact = !((kind == K_STOPPED || kind == K_SDF) &&
                            strcmp(backend, "sundials_erk") == 0);
        if (exact && (db != 0.0 || dc != 0.0)) (*failures)++;
        if (!exact) {
            assert_true(fabs(db) < 1e-8);
            assert_true(fabs(dc) < 1e-8);
        }
        defsim_world_destroy(a);
        defsim_world_destroy(b);
        defsim_world_destroy(c);
    }
    return cases;
}

static void run_matrix(int before, int after, int substep)
{
    int failures = 0, cases = 0;
    stop_after = before;
    for (int kind = 0; kind < K_COUNT; ++kind)
        if (kind != K_SUBSTEP || substep) cases += check_kind(kind, before, after, &failures);
    printf("  %d cases, %d not bit for bit\n", cases, failures);
    /* At least the three built-in backends ran five kinds each (body contact needs modules). */
    assert_true(cases >= 3 * (K_COUNT - 2));
    assert_int_equal(failures, 0);
}

/* 40 steps (contact established), save, 20 more. */
static void test_matrix(void **state)
{
    (void)state;
    run_matrix(40, 20, 1);
}

/* Saved early (the cube still settling onto the ground, the sphere just touching) and late. */
static void test_matrix_early(void **state)
{
    (void)state;
    run_matrix(6, 20, 1);
}

/* The long run (ctest -L long): saved late; then saved at every 5th step of a run. */
static void test_matrix_late(void **state)
{
    (void)state;
    run_matrix(100, 30, 1);
}

/* Every kind on every backend saved after every 5th step of 60 (the next step's pose and target
 * pending), each save loaded and run to step 60 beside the uninterrupted run. (This sweep found
 * the roundoff velocity of still, rotated colliders that sundials_erk's replay missed.) */
static void test_sweep(void **state)
{
    (void)state;
    enum { T = 60, EVERY = 5 };
    int failures = 0, cases = 0;
    for (int kind = 0; kind < K_COUNT; ++kind)
        for (int bi = 0; bi < NB; ++bi) {
            const char *backend = backends[bi];
            defsim_world *a = scene(backend, kind);
            if (!a) continue;
            stop_after = T / 2;
            void *buf[T / EVERY] = {0};
            size_t size[T / EVERY] = {0};
            seen sn = {0.0, 0.0, 0.0};
            for (int k = 1; k <= T; ++k) {
                prepare(a, kind, k);
                if ((k - 1) % EVERY == 0 && k > 1)
                    TU_OK(defsim_world_save_buffer(a, &buf[(k - 1) / EVERY],
                                                   &size[(k - 1) / EVERY]));
                TU_OK(defsim_world_step(a, step_of(kind)));
                look(a, &sn);
            }
            int differ = 0;
            double worst = 0.0;
            for (int i = 1; i < T / EVERY; ++i) {
                const int saved = i * EVERY;   /* steps before the save */
                defsim_world *b = NULL;
                TU_OK(defsim_world_load_buffer(buf[i], size[i], NULL, NULL, &b));
                defsim_buffer_free(buf[i]);
                if (kind == K_COUPLED)
                    TU_OK(defsim_world_set_force_callback(b, wind_force, NULL, &the_wind));
                if (kind == K_SDF) reinstall_sdf(b);
                TU_OK(defsim_world_step(b, step_of(kind)));   /* the pending step */
                run(b, kind, saved + 2, T - saved - 1, &sn);
                const double d = compare(a, b);
                /* sundials_erk's exceptions: saved right after the sphere's last move; the SDF
                 * ground. */
                const int exact = !(((kind == K_STOPPED && saved == T / 2) || kind == K_SDF) &&
                                    strcmp(backend, "sundials_erk") == 0);
                if (d != 0.0) {
                    printf("    %s %s saved at step %d: %.3g m\n", kind_name[kind], backend,
                           saved, d);
                    if (exact) differ++;
                    else assert_true(fabs(d) < 1e-8);
                }
                worst = fmax(worst, fabs(d));
                defsim_world_destroy(b);
                cases++;
            }
            printf("  %-9s %-16s %d of %d saves not bit for bit (largest difference %.3g m)\n",
                   kind_name[kind], backend, differ, T / EVERY - 1, worst);
            failures += differ;
            defsim_world_destroy(a);
        }
    printf("  %d saves, %d not bit for bit\n", cases, failures);
    assert_true(cases >= 3 * (K_COUNT - 2) * (T / EVERY - 1));
    assert_int_equal(failures, 0);
}

/* Little-endian reads and writes in a checkpoint's bytes. */
static uint64_t get_le(const unsigned char *p, int n)
{
    uint64_t v = 0;
    for (int i = n - 1; i >= 0; --i) v = (v << 8) | p[i];
    return v;
}

static void put_le(unsigned char *p, uint64_t v, int n)
{
    for (int i = 0; i < n; ++i) p[i] = (unsigned char)(v >> (8 * i));
}

/* Offset of the chunk `tag` in a checkpoint (its tag's first byte), or 0. */
static size_t find_chunk(const unsigned char *p, size_t n, const char *tag)
{
    for (size_t at = DEFSIM__CKPT_HEADER; at + 16 <= n;) {
        if (memcmp(p + at, tag, 4) == 0) return at;
        at += 16 + (size_t)get_le(p + at + 4, 8);
    }
    return 0;
}

/* A copy of the checkpoint with the chunk at `at` given the payload `pay` (len bytes), its
 * length and CRC rewritten: contents that pass the CRC. */
static unsigned char *with_payload(const unsigned char *p, size_t n, size_t at, const void *pay,
                                   size_t len, size_t *out_n)
{
    assert_true(at > 0);
    const size_t old = (size_t)get_le(p + at + 4, 8), tail = at + 16 + old;
    *out_n = n - old + len;
    unsigned char *q = malloc(*out_n);
    assert_non_null(q);
    memcpy(q, p, at + 4);
    put_le(q + at + 4, len, 8);
    memcpy(q + at + 12, pay, len);
    put_le(q + at + 12 + len, defsim__crc32(0, q + at, 12 + len), 4);
    memcpy(q + at + 16 + len, p + tail, n - tail);
    return q;
}

/* The collider term's state (its TERM chunk: the name "collider", then the penalty's frequency,
 * the safe box's flag and corners, the velocities' vertex count and the velocities) comes from
 * a file like everything else: a frequency that is not finite or negative, a bad flag, a box
 * that is not finite, a wrong length, a non-finite velocity or a kind that is not the
 * collider's is refused with DEFSIM_ERR_IO and no world; a finite but absurd frequency loads,
 * and its step fails with a status, not a crash. The unchanged payload loads and continues bit
 * for bit. */
static void test_contact_state_damaged(void **state)
{
    (void)state;
    defsim_world *a = scene("sundials_kinsol", K_FRICTION);
    if (!a) a = scene("symplectic_euler", K_FRICTION);
    seen sn = {0.0, 0.0, 0.0};
    run(a, K_FRICTION, 1, 10, &sn);
    void *buf = NULL;
    size_t n = 0;
    TU_OK(defsim_world_save_buffer(a, &buf, &n));
    const unsigned char *p = buf;
    const size_t at = find_chunk(p, n, "TERM");
    assert_true(at > 0);
    const size_t len = (size_t)get_le(p + at + 4, 8);
    const int32_t nv = defsim_world_vertex_count(a);
    /* name (4 + 8), frequency, flag, box, count, velocities */
    enum { NAME = 12, OMEGA = NAME, SAFE = NAME + 8, BOX = SAFE + 4, NVEL = BOX + 48,
           VEL = NVEL + 4 };
    assert_int_equal(len, VEL + 24 * (size_t)nv);
    assert_memory_equal(p + at + 12 + 4, "collider", 8);
    assert_int_equal(get_le(p + at + 12 + NVEL, 4), (uint64_t)nv);
    unsigned char *pay = malloc(len);
    assert_non_null(pay);
    double omega;
    memcpy(&omega, p + at + 12 + OMEGA, 8);
    assert_true(omega > 0.0);   /* the frequency was computed and saved */

    const double bad[] = {NAN, -1.0, INFINITY};
    for (int m = 0; m < 9; ++m) {
        memcpy(pay, p + at + 12, len);
        size_t plen = len;
        if (m < 3) memcpy(pay + OMEGA, &bad[m], 8);
        if (m == 3) put_le(pay + SAFE, 2, 4);                  /* the box's flag */
        if (m == 4) plen = len - 8;                            /* one velocity short */
        if (m == 5) memcpy(pay + VEL + 8 * 7, &bad[0], 8);     /* a NaN velocity */
        if (m == 6) put_le(pay + NVEL, 0, 4);                  /* no velocities, but their bytes */
        if (m == 7) memcpy(pay + BOX + 8 * 4, &bad[2], 8);     /* a corner at infinity */
        if (m == 8) pay[4] = 'x';                              /* "xollider": no such kind */
        size_t qn = 0;
        unsigned char *q = with_payload(p, n, at, pay, plen, &qn);
        defsim_world *b = (defsim_world *)1;
        assert_int_equal(defsim_world_load_buffer(q, qn, NULL, NULL, &b), DEFSIM_ERR_IO);
        assert_null(b);
        free(q);
    }

    /* Finite and absurd: loads; the step fails cleanly and leaves the state as it was. */
    memcpy(pay, p + at + 12, len);
    const double huge = 1e300;
    memcpy(pay + OMEGA, &huge, 8);
    size_t qn = 0;
    unsigned char *q = with_payload(p, n, at, pay, len, &qn);
    defsim_world *b = NULL;
    TU_OK(defsim_world_load_buffer(q, qn, NULL, NULL, &b));
    assert_true(compare(a, b) == 0.0);
    assert_int_not_equal(defsim_world_step(b, H), DEFSIM_OK);
    assert_true(compare(a, b) == 0.0);
    defsim_world_destroy(b);
    free(q);

    /* Rewritten unchanged: the same bits as the original after 10 more steps. */
    memcpy(pay, p + at + 12, len);
    q = with_payload(p, n, at, pay, len, &qn);
    assert_int_equal(qn, n);
    assert_memory_equal(q, p, n);
    TU_OK(defsim_world_load_buffer(q, qn, NULL, NULL, &b));
    run(a, K_FRICTION, 11, 10, &sn);
    run(b, K_FRICTION, 11, 10, &sn);
    assert_true(compare(a, b) == 0.0);
    defsim_world_destroy(b);
    free(q);
    free(pay);
    defsim_buffer_free(buf);
    defsim_world_destroy(a);
}

/* Checkpoints with colliders, the contact state, a body-contact pattern and backend histories
 * (sundials_kinsol with friction, newmark with body contact, velocity_verlet and sundials_erk on
 * the SDF ground, sundials_ida with a moving sphere), changed in 1 to 3 bytes of a random chunk
 * with the CRC made valid again: each load is refused with a status and no world, or loads and
 * steps (any status) without a crash. `trials` per scene. */
static void mutate(int trials, int cap)
{
    static const struct {
        const char *backend;
        int kind;
    } cases[] = {{"sundials_kinsol", K_FRICTION}, {"newmark", K_BODY},
                 {"velocity_verlet", K_SDF},      {"sundials_erk", K_SDF},
                 {"sundials_ida", K_MOVING}};
    unsigned long long seed = 23;
    int refused = 0, loaded = 0, scenes = 0;
    for (size_t ci = 0; ci < sizeof cases / sizeof cases[0]; ++ci) {
        defsim_world *a = scene(cases[ci].backend, cases[ci].kind);
        if (!a) continue;
        scenes++;
        seen sn = {0.0, 0.0, 0.0};
        stop_after = 1 << 30;
        run(a, cases[ci].kind, 1, 30, &sn);
        prepare(a, cases[ci].kind, 31);
        void *data = NULL;
        size_t n = 0;
        TU_OK(defsim_world_save_buffer(a, &data, &n));
        unsigned char *buf = malloc(n);
        assert_non_null(buf);
        for (int trial = 0; trial < trials; ++trial) {
            memcpy(buf, data, n);
            size_t at = DEFSIM__CKPT_HEADER, len = 0;
            const int hops = (int)(6.0 * (tu_rand(&seed) + 1.0));
            for (int h = 0;; ++h) {
                len = (size_t)get_le(buf + at + 4, 8);
                if (h == hops || at + 16 + len >= n - 16) break;
                at += 16 + len;
            }
            if (len == 0) continue;
            const int changes = 1 + (int)(1.5 * (tu_rand(&seed) + 1.0));
            for (int c = 0; c < changes; ++c) {
                const size_t k = (size_t)((tu_rand(&seed) + 1.0) * 0.5 * (double)len) % len;
                buf[at + 12 + k] = (unsigned char)(128.0 * (tu_rand(&seed) + 1.0));
            }
            put_le(buf + at + 12 + len, defsim__crc32(0, buf + at, 12 + len), 4);
            defsim_world *w = (defsim_world *)1;
            const defsim_status st = defsim_world_load_buffer(buf, n, NULL, NULL, &w);
            if (st != DEFSIM_OK) {
                assert_true(st < 0);
                assert_null(w);
                ++refused;
                continue;
            }
            ++loaded;
            /* The host's functions, where the loaded world still has what they belong to. */
            defsim_collider_def cd;
            defsim_collider_id id;
            cd.size = sizeof cd;
            for (int32_t j = 0; j < defsim_world_collider_count(w); ++j)
                if (defsim_world_get_collider(w, j, &id, &cd) == DEFSIM_OK &&
                    cd.shape == DEFSIM_SHAPE_SDF)
                    TU_OK(defsim_collider_set_sdf(w, id, ground_sdf, NULL));
            /* A valid but absurd state or material can make an adaptive integrator take its
             * 100,000 internal steps per step (128 s for sundials_ida's 3 steps in one case):
             * with `cap` they stop at 2,000 (the option restarts their history). */
            if (cap) {
                char name[64];
                snprintf(name, sizeof name, "%s.max_internal_steps", cases[ci].backend);
                (void)defsim_world_set_option(w, name, "2000");   /* where there is one */
            }
            for (int k = 0; k < 3; ++k) (void)defsim_world_step(w, H);   /* any status */
            defsim_world_destroy(w);
        }
        free(buf);
        defsim_buffer_free(data);
        defsim_world_destroy(a);
    }
    printf("  %d mutated checkpoints of %d scenes with valid CRCs: %d refused, %d loaded and "
           "stepped\n", refused + loaded, scenes, refused, loaded);
    assert_true(refused > 0 && loaded > 0);
}

static void test_mutated(void **state)
{
    (void)state;
    mutate(60, 0);
}

static void test_mutated_long(void **state)
{
    (void)state;
    mutate(1000, 1);
}

/* The default run; with --long, the long one (registered as long_adv_ckpt, label long). */
int main(int argc, char **argv)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_matrix),
        cmocka_unit_test(test_matrix_early),
        cmocka_unit_test(test_contact_state_damaged),
        cmocka_unit_test(test_mutated),
    };
    const struct CMUnitTest long_tests[] = {
        cmocka_unit_test(test_matrix_late),
        cmocka_unit_test(test_sweep),
        cmocka_unit_test(test_mutated_long),
    };
    if (argc > 1 && strcmp(argv[1], "--long") == 0)
        return cmocka_run_group_tests(long_tests, NULL, NULL);
    return cmocka_run_group_tests(tests, NULL, NULL);
}
