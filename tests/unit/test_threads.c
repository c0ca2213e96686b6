/* SPDX-License-Identifier: MIT */
/*
 * The threading contract (docs/threads.md): different worlds may be created, stepped, read
 * and destroyed on different threads at the same time, and give bit for bit what they give
 * one after another; the registry is thread-safe; defsim_last_error() is per thread.
 * Built in the ThreadSanitizer build (DEFSIM_TSAN=ON) too, where any data race between the
 * worlds is reported and fails the run.
 */
#include "test_util.h"

#include <math.h>
#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define NSCENES 4
#define ROUNDS 3
#define STEPS 150
#define H 2e-3

typedef struct result {
    int ok;                  /* every call returned what it should */
    int32_t nv;
    double *x, *v;           /* 3 nv each */
    double t, energy;
    char error[512];         /* defsim_last_error() after a failed creation on this thread */
} result;

/* A force callback with a potential: a spring of 20 N/m along z to z = 0 on every vertex. */
static int pull_down(void *user, const double *x, const double *v, double t, int32_t n,
                     double *f)
{
    (void)user; (void)v; (void)t;
    for (int32_t i = 0; i < n; ++i) f[3 * i + 2] -= 20.0 * x[3 * i + 2];
    return 0;
}

static const double LO[3] = {0, 0, 0}, HI[3] = {0.3, 0.1, 0.1};

/* Scene s, stepped STEPS times, into *r. Every scene uses one thread for assembly: the test is
 * about worlds on threads, and one thread keeps it quick under ThreadSanitizer. */
static void run_scene(int s, result *r)
{
    static const char *const backends[NSCENES] = {"symplectic_euler", "velocity_verlet",
                                                  "explicit_euler", "symplectic_euler"};
    static const defsim_model models[NSCENES] = {
        DEFSIM_MODEL_STABLE_NEOHOOKEAN, DEFSIM_MODEL_COROTATED, DEFSIM_MODEL_STVK,
        DEFSIM_MODEL_NEOHOOKEAN};
    memset(r, 0, sizeof *r);
    r->ok = 1;
    /* a failure whose message must be this thread's own */
    defsim_world_def bad;
    defsim_world_def_init(&bad, sizeof bad);
    bad.num_threads = -1 - s;
    defsim_world *none = NULL;
    r->ok &= defsim_world_create(&bad, &none) == DEFSIM_ERR_INVALID_ARGUMENT && !none;
    snprintf(r->error, sizeof r->error, "%s", defsim_last_error());

    defsim_world_def d;
    defsim_world_def_init(&d, sizeof d);
    d.backend = backends[s];
    d.num_threads = 1;
    defsim_world *w = NULL;
    if (defsim_world_create(&d, &w) != DEFSIM_OK) {
        r->ok = 0;
        return;
    }
    defsim_mesh mesh;
    mesh.size = sizeof mesh;
    r->ok &= defsim_mesh_box(LO, HI, 3, 1, 1, &mesh) == DEFSIM_OK;
    defsim_body_def bd = test_mesh_body(&mesh, models[s]);
    bd.material.youngs_modulus = 2e4 * (1 + s);
    /* explicit Euler is stable only with damping */
    bd.material.stiffness_damping = s == 2 ? 2e-3 : 0.0;
    defsim_body_id b;
    r->ok &= defsim_world_add_body(w, &bd, &b) == DEFSIM_OK;
    /* clamp the x = 0 end */
    int32_t pins[16], np = 0;
    for (int32_t i = 0; i < mesh.vertex_count && np < 16; ++i)
        if (mesh.positions[3 * i] == 0.0) pins[np++] = i;
    r->ok &= defsim_body_pin(w, b, pins, np) == DEFSIM_OK;
    if (s == 3) {
        /* the host's coupling terms: a force callback and an attachment */
        r->ok &= defsim_world_set_force_callback(w, pull_down, NULL, NULL) == DEFSIM_OK;
        defsim_attachment_def ad;
        defsim_attachment_def_init(&ad, sizeof ad);
        ad.body = b;
        ad.vertex = mesh.vertex_count - 1;
        ad.target[0] = 0.3;
        ad.target[1] = 0.2;
        r->ok &= defsim_world_add_attachment(w, &ad, NULL) == DEFSIM_OK;
    }
    defsim_mesh_free(&mesh);
    if (!r->ok) printf("scene %d: set-up failed: %s\n", s, defsim_world_last_error(w));
    for (int k = 0; k < STEPS && r->ok; ++k) {
        const defsim_status st = defsim_world_step(w, H);
        if (st != DEFSIM_OK) {
            printf("scene %d: step %d: %s\n", s, k, defsim_world_last_error(w));
            r->ok = 0;
        }
    }
    r->nv = defsim_world_vertex_count(w);
    r->x = malloc(3 * (size_t)r->nv * sizeof *r->x);
    r->v = malloc(3 * (size_t)r->nv * sizeof *r->v);
    r->ok &= defsim_world_get_positions(w, r->x, r->nv) == DEFSIM_OK;
    r->ok &= defsim_world_get_velocities(w, r->v, r->nv) == DEFSIM_OK;
    r->t = defsim_world_time(w);
    defsim_energy e;
    r->ok &= defsim_world_energy(w, &e) == DEFSIM_OK;
    r->energy = e.total;
    defsim_world_destroy(w);
}

typedef struct job {
    int scene;
    result r;
} job;

static void *thread_main(void *arg)
{
    job *j = arg;
    run_scene(j->scene, &j->r);
    return NULL;
}

static void free_result(result *r)
{
    free(r->x);
    free(r->v);
}

/* The same scenes, one after another and then each on its own thread (ROUNDS times, all
 * threads started together): the results agree bit for bit. */
static void test_worlds_on_threads(void **state)
{
    (void)state;
    result seq[NSCENES];
    for (int s = 0; s < NSCENES; ++s) {
        run_scene(s, &seq[s]);
        assert_true(seq[s].ok);
        for (int i = 0; i < 3 * seq[s].nv; ++i) assert_true(isfinite(seq[s].x[i]));
        /* the scenes move: a run that did nothing would agree trivially */
        assert_true(seq[s].energy != 0.0);
    }
    int mismatches = 0;
    for (int round = 0; round < ROUNDS; ++round) {
        job jobs[2 * NSCENES];
        pthread_t th[2 * NSCENES];
        for (int k = 0; k < 2 * NSCENES; ++k) {
            jobs[k].scene = k % NSCENES;
            assert_int_equal(pthread_create(&th[k], NULL, thread_main, &jobs[k]), 0);
        }
        for (int k = 0; k < 2 * NSCENES; ++k) assert_int_equal(pthread_join(th[k], NULL), 0);
        for (int k = 0; k < 2 * NSCENES; ++k) {
            const result *a = &jobs[k].r, *b = &seq[jobs[k].scene];
            assert_true(a->ok);
            assert_int_equal(a->nv, b->nv);
            const size_t bytes = 3 * (size_t)a->nv * sizeof(double);
            const int same = memcmp(a->x, b->x, bytes) == 0 && memcmp(a->v, b->v, bytes) == 0 &&
                             a->t == b->t && memcmp(&a->energy, &b->energy, sizeof a->energy) == 0;
            if (!same) {
                printf("round %d thread %d (scene %d) differs from the sequential run\n", round,
                       k, jobs[k].scene);
                ++mismatches;
            }
            /* each thread saw its own failure message */
            assert_string_equal(a->error, b->error);
            free_result(&jobs[k].r);
        }
    }
    printf("%d rounds of %d threads, %d mismatches\n", ROUNDS, 2 * NSCENES, mismatches);
    for (int s = 0; s < NSCENES; ++s) free_result(&seq[s]);
    assert_int_equal(mismatches, 0);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_worlds_on_threads),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
