/* SPDX-License-Identifier: MIT */
/*
 * Checkpoints (issue 17): a world saved mid-run and loaded continues bit for bit on every backend
 * (sundials_erk also from every point of a run, sundials_ida with KLU also where its pivots
 * matter); damaged files are refused
 * with DEFSIM_ERR_IO; writes are atomic; files of format version 1 still load; a get/set_state
 * round trip keeps IDA's history.
 */
#include "test_util.h"

#include <defsim/backend.h>

#include "checkpoint.h"
#include "shell_sheet_v9.h"

#include <dirent.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#ifndef DEFSIM_TEST_DATA
#error "DEFSIM_TEST_DATA must name tests/checkpoint"
#endif

enum { N_BEFORE = 15, N_AFTER = 15 };
static const double H = 1e-3;

/* The scene: a clamped, damped neo-Hookean beam; a spring ladder (one vertex driven, one
 * attached to the beam's tip, one to a world point); held external forces on the ladder; a
 * removed body before them, so that saved ids have a gap. Returns NULL when the backend is not
 * available here. */
static int substep = 0;   /* core.auto_substep in the scene */

static defsim_world *scene(const char *backend, const char *linear_solver)
{
    defsim_world_def d = tu_world_def(backend, -9.81, 1);
    defsim_world *w = NULL;
    defsim_status st = defsim_world_create(&d, &w);
    if (st == DEFSIM_ERR_BACKEND_UNAVAILABLE) return NULL;
    TU_OK(st);
    TU_OK(defsim_world_set_option_number(w, "core.auto_substep", substep));
    if (linear_solver) {
        char name[96];
        snprintf(name, sizeof name, "%s.linear_solver", backend);
        TU_OK(defsim_world_set_option(w, name, linear_solver));
    }
    const double lo0[3] = {5, 5, 5}, hi0[3] = {6, 6, 6};
    const defsim_body_id gone = tu_add_box(w, DEFSIM_MODEL_COROTATED, 1, 1, 1, lo0, hi0, 1e5, 0.3,
                                           1000);
    defsim_material m;
    defsim_material_init(&m, sizeof m, DEFSIM_MODEL_STABLE_NEOHOOKEAN);
    m.youngs_modulus = 2e5;
    m.mass_damping = 0.2;
    m.stiffness_damping = 1e-3;
    const double lo[3] = {0, 0, 0}, hi[3] = {1.0, 0.2, 0.2};
    const defsim_body_id beam = tu_add_box_material(w, 4, 1, 1, lo, hi, &m);
    tu_pin_below(w, beam, 0, 0.0);
    TU_OK(defsim_world_remove_body(w, gone));

    double x[24];
    int32_t springs[20];
    tu_ladder(1.2, 0.1, 0.0, x, springs);
    defsim_body_def bd;
    defsim_body_def_init(&bd, sizeof bd);
    defsim_material_init(&bd.material, sizeof bd.material, DEFSIM_MODEL_SPRING);
    bd.material.stiffness = 300.0;
    bd.material.vertex_mass = 0.02;
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
    ad.stiffness = 500.0;
    ad.damping = 0.5;
    ad.target_body = beam;
    ad.target_vertex_count = 1;
    ad.target_vertices[0] = 4;   /* the beam's tip at (1, 0, 0) */
    ad.target_weights[0] = 1.0;
    TU_OK(defsim_world_add_attachment(w, &ad, NULL));
    defsim_attachment_def_init(&ad, sizeof ad);
    ad.body = ladder;
    ad.vertex = 5;
    ad.stiffness = 200.0;
    ad.target[0] = 1.5;
    ad.target[1] = 0.3;
    TU_OK(defsim_world_add_attachment(w, &ad, NULL));

    const int32_t nv = defsim_world_vertex_count(w);
    double *f = calloc(3 * (size_t)nv, sizeof *f);
    assert_non_null(f);
    for (int32_t i = nv - 8; i < nv; ++i) f[3 * i + 2] = 0.05 * (i % 3);
    TU_OK(defsim_world_set_external_forces(w, f, nv));
    free(f);
    return w;
}

/* The ladder's last vertex is driven along z in every step (a new target each time). */
static void drive(defsim_world *w, int k)
{
    defsim_body_id ladder;
    TU_OK(defsim_world_body_at(w, 1, &ladder));
    const int32_t v = 7;
    const double p[3] = {1.5, 0.1, 0.002 * k};
    TU_OK(defsim_body_set_pin_targets(w, ladder, &v, 1, p));
}

/* Steps n times, driving the ladder's last vertex in each step when `driven` (which restarts the
 * adaptive backends in every step: their history is tested without it). */
static int driven = 1;

static void run(defsim_world *w, int from, int n)
{
    for (int k = from; k < from + n; ++k) {
        if (driven) drive(w, k + 1);
        TU_OK(defsim_world_step(w, H));
    }
}

/* max |a - b| over the world's positions and velocities (m and m/s together). */
static double state_diff(const defsim_world *a, const defsim_world *b)
{
    const int32_t n = defsim_world_vertex_count(a);
    assert_int_equal(n, defsim_world_vertex_count(b));
    double *xa = tu_positions(a), *xb = tu_positions(b);
    double *va = tu_velocities(a), *vb = tu_velocities(b);
    double d = 0.0;
    for (int64_t i = 0; i < 3 * (int64_t)n; ++i)
        d = fmax(d, fmax(fabs(xa[i] - xb[i]), fabs(va[i] - vb[i])));
    free(xa); free(xb); free(va); free(vb);
    return d;
}

static int same_bits(const defsim_world *a, const defsim_world *b)
{
    const int32_t n = defsim_world_vertex_count(a);
    double *xa = tu_positions(a), *xb = tu_positions(b);
    double *va = tu_velocities(a), *vb = tu_velocities(b);
    const size_t bytes = 3 * (size_t)n * sizeof(double);
    const int same = memcmp(xa, xb, bytes) == 0 && memcmp(va, vb, bytes) == 0;
    free(xa); free(xb); free(va); free(vb);
    const double ta = defsim_world_time(a), tb = defsim_world_time(b);
    return same && memcmp(&ta, &tb, sizeof ta) == 0;
}

/* Saves after N_BEFORE steps (with a target pending), loads, and steps both N_AFTER more.
 * Returns the largest difference of the states (0 when bit for bit), or -1 without backend. */
static double round_trip(const char *backend, const char *linear_solver, int via_file)
{
    defsim_world *a = scene(backend, linear_solver);
    if (!a) return -1.0;
    run(a, 0, N_BEFORE);
    if (driven) drive(a, N_BEFORE + 1);
    defsim_world *b = NULL;
    if (via_file) {
        char path[400];
        snprintf(path, sizeof path, "%s/%s.dfck", tu_tmpdir, backend);
        TU_OK(defsim_world_save(a, path));
        TU_OK(defsim_world_load(path, NULL, NULL, &b));
    } else {
        void *buf = NULL;
        size_t size = 0;
        TU_OK(defsim_world_save_buffer(a, &buf, &size));
        TU_OK(defsim_world_load_buffer(buf, size, NULL, NULL, &b));
        defsim_buffer_free(buf);
    }
    /* The loaded world starts where the saved one stands: state, clock, statistics. */
    assert_true(same_bits(a, b));
    defsim_stats sa, sb;
    sa.size = sb.size = sizeof sa;
    TU_OK(defsim_world_stats(a, &sa));
    TU_OK(defsim_world_stats(b, &sb));
    assert_int_equal(sa.steps, N_BEFORE);
    assert_int_equal(sb.steps, sa.steps);
    assert_int_equal(sb.force_evals, sa.force_evals);
    assert_int_equal(tu_bstat(b, "internal_steps"), tu_bstat(a, "internal_steps"));
    assert_int_equal(defsim_world_body_count(b), 2);
    assert_int_equal(defsim_world_attachment_count(b), 2);
    /* Both finish the pending drive, then go on. */
    TU_OK(defsim_world_step(a, H));
    TU_OK(defsim_world_step(b, H));
    run(a, N_BEFORE + 1, N_AFTER);
    run(b, N_BEFORE + 1, N_AFTER);
    TU_OK(defsim_world_stats(a, &sa));
    TU_OK(defsim_world_stats(b, &sb));
    assert_int_equal(sb.steps, sa.steps);
    double d = state_diff(a, b);
    if (d == 0.0 && !same_bits(a, b)) d = 1e-300;   /* -0.0 against 0.0, or the clock */
    if (d == 0.0) {
        assert_int_equal(tu_bstat(b, "internal_steps"), tu_bstat(a, "internal_steps"));
        assert_int_equal(tu_bstat(b, "newton_iterations"), tu_bstat(a, "newton_iterations"));
        assert_int_equal(sb.force_evals, sa.force_evals);
        assert_int_equal(sb.substeps, sa.substeps);
        assert_true(sb.stable_step == sa.stable_step);   /* no estimate made afresh */
    }
    printf("  %-18s %-8s %s %s: max |difference| after %d more steps = %.3g\n", backend,
           linear_solver ? linear_solver : "", via_file ? "file  " : "buffer",
           driven ? "driven" : "free  ", N_AFTER + 1, d);
    defsim_world_destroy(a);
    defsim_world_destroy(b);
    return d;
}

static void test_bit_exact_backends(void **state)
{
    (void)state;
    const char *exact[] = {"symplectic_euler", "explicit_euler", "velocity_verlet",
                           "newton_cholmod", "newmark", "bdf2", "sundials_kinsol",
                           "sundials_ida", "sundials_erk"};
    int ran = 0;
    for (size_t i = 0; i < sizeof exact / sizeof *exact; ++i)
        for (int via_file = 0; via_file < 2; ++via_file) {
            driven = !via_file;
            const double d = round_trip(exact[i], NULL, via_file);
            if (d < 0.0) continue;
            assert_true(d == 0.0);
            ++ran;
        }
    driven = 1;
    assert_true(ran >= 6);   /* the built-in backends at least */
    /* sundials_ida with KLU (test_ida_klu_pivots has a scene where its pivots matter). */
    for (int via_file = 0; via_file < 2; ++via_file) {
        driven = !via_file;
        const double d = round_trip("sundials_ida", "klu", via_file);
        assert_true(d <= 0.0);   /* 0: bit for bit; -1: no sundials_ida here */
    }
    driven = 1;
    /* auto_substep: the cached stable step (format version 2) keeps the substeps the same. */
    substep = 1;
    assert_true(round_trip("symplectic_euler", NULL, 0) == 0.0);
    assert_true(round_trip("velocity_verlet", NULL, 1) == 0.0);
    substep = 0;
}

/* sundials_erk replays the saved last internal step on load (README "Checkpoints"): bit for bit
 * from every save point of a run, including right after world steps in which ERKStep rejected an
 * attempt, with each
 * table. Worlds loaded at several points (every other one saved and loaded again right after its
 * load) run on beside the uninterrupted one to its end. */
static double erk_stat(const defsim_world *w, const char *name)
{
    double v = -1.0;
    TU_OK(defsim_world_stat(w, name, &v));
    return v;
}

static void test_erk_every_point(void **state)
{
    (void)state;
    const char *tables[] = {"dormand_prince_5", "bogacki_shampine_3", "zonneveld_4",
                            "cash_karp_5", "verner_6", "fehlberg_8"};
    enum { STEPS = 30, MAX_LOADED = 12 };
    driven = 0;
    int after_failure = 0, compared = 0;
    for (size_t t = 0; t < sizeof tables / sizeof *tables; ++t) {
        defsim_world *a = scene("sundials_erk", NULL);
        if (!a) break;
        TU_OK(defsim_world_set_option(a, "sundials_erk.table", tables[t]));
        TU_OK(defsim_world_set_option(a, "sundials_erk.rtol", "1e-2"));
        defsim_world *loaded[MAX_LOADED];
        int n = 0;
        for (int k = 0; k < STEPS; ++k) {
            const double etf = erk_stat(a, "sundials_erk.error_test_failures");
            TU_OK(defsim_world_step(a, H));
            for (int i = 0; i < n; ++i) TU_OK(defsim_world_step(loaded[i], H));
            const int failed = erk_stat(a, "sundials_erk.error_test_failures") > etf;
            if (n == MAX_LOADED || k == STEPS - 1 || !(failed || k % 4 == 0)) continue;
            after_failure += failed;
            void *buf = NULL;
            size_t size = 0;
            TU_OK(defsim_world_save_buffer(a, &buf, &size));
            TU_OK(defsim_world_load_buffer(buf, size, NULL, NULL, &loaded[n]));
            defsim_buffer_free(buf);
            if (n % 2) {   /* saved again right after the load: the same checkpoint */
                defsim_world *again = NULL;
                TU_OK(defsim_world_save_buffer(loaded[n], &buf, &size));
                TU_OK(defsim_world_load_buffer(buf, size, NULL, NULL, &again));
                defsim_buffer_free(buf);
                defsim_world_destroy(loaded[n]);
                loaded[n] = again;
            }
            ++n;
        }
        for (int i = 0; i < n; ++i) {
            if (!same_bits(a, loaded[i]))
                printf("  sundials_erk %s: world %d of %d differs by %.3g\n", tables[t], i, n,
                       state_diff(a, loaded[i]));
            assert_true(same_bits(a, loaded[i]));
            assert_true(erk_stat(a, "sundials_erk.internal_steps") ==
                        erk_stat(loaded[i], "sundials_erk.internal_steps"));
            assert_true(erk_stat(a, "sundials_erk.rhs_evals") ==
                        erk_stat(loaded[i], "sundials_erk.rhs_evals"));
            defsim_world_destroy(loaded[i]);
            ++compared;
        }
        defsim_world_destroy(a);
    }
    driven = 1;
    if (compared == 0) return;   /* no sundials_erk in this build */
    printf("  sundials_erk: %d loaded worlds bit for bit, %d saved right after a step with a "
           "rejected attempt\n", compared, after_failure);
    assert_true(after_failure >= 1);
}

/* sundials_ida with KLU: KLU keeps the pivots of its first factorisation after a restart through
 * its refactorisations, so a loaded world factorises the saved matrix that chose them before it
 * refactorises the last one. A light, stiff cloth (1e-8 kg per vertex, 1e3 N/m) is a scene where
 * pivoting from the last matrix instead gives other bits (4.3e-21 m, saved after 2 steps, rtol
 * 1e-2, 10 steps later). */
static void test_ida_klu_pivots(void **state)
{
    (void)state;
    int ran = 0;
    for (int save_at = 2; save_at <= 10; save_at += 8)
        for (int r = 0; r < 2; ++r) {
            defsim_world_def d = tu_world_def("sundials_ida", -9.81, 1);
            defsim_world *a = NULL, *b = NULL;
            defsim_status st = defsim_world_create(&d, &a);
            if (st == DEFSIM_ERR_BACKEND_UNAVAILABLE) return;
            TU_OK(st);
            TU_OK(defsim_world_set_option(a, "sundials_ida.linear_solver", "klu"));
            TU_OK(defsim_world_set_option(a, "sundials_ida.rtol", r ? "1e-5" : "1e-2"));
            const double o[3] = {0, 0, 0}, u[3] = {1, 0, 0}, v[3] = {0, 1, 0};
            defsim_mesh m;
            memset(&m, 0, sizeof m);
            m.size = sizeof m;
            TU_OK(defsim_mesh_cloth(o, u, v, 6, 6, &m));
            defsim_body_def bd;
            defsim_body_def_init(&bd, sizeof bd);
            defsim_material_init(&bd.material, sizeof bd.material, DEFSIM_MODEL_SPRING);
            bd.material.stiffness = 1e3;
            bd.material.vertex_mass = 1e-8;
            bd.material.mass_damping = 0.1;
            bd.rest_positions = m.positions;
            bd.vertex_count = m.vertex_count;
            bd.springs = m.springs;
            bd.spring_count = m.spring_count;
            defsim_body_id body;
            TU_OK(defsim_world_add_body(a, &bd, &body));
            defsim_mesh_free(&m);
            tu_pin_below(a, body, 1, 0.0);
            for (int k = 0; k < save_at; ++k) TU_OK(defsim_world_step(a, 1.0 / 60.0));
            void *buf = NULL;
            size_t size = 0;
            TU_OK(defsim_world_save_buffer(a, &buf, &size));
            TU_OK(defsim_world_load_buffer(buf, size, NULL, NULL, &b));
            defsim_buffer_free(buf);
            for (int k = 0; k < 10; ++k) {
                TU_OK(defsim_world_step(a, 1.0 / 60.0));
                TU_OK(defsim_world_step(b, 1.0 / 60.0));
            }
            const double diff = state_diff(a, b);
            printf("  sundials_ida klu cloth, saved after %d steps, rtol %s: max |difference| %.3g\n",
                   save_at, r ? "1e-5" : "1e-2", diff);
            assert_true(same_bits(a, b));
            defsim_world_destroy(a);
            defsim_world_destroy(b);
            ++ran;
        }
    assert_int_equal(ran, 4);
}

/* Saving does not change the world: a world saved every step runs as one that never is. */
static void test_save_changes_nothing(void **state)
{
    (void)state;
    const char *backends[] = {"sundials_ida", "velocity_verlet", "bdf2"};
    for (size_t i = 0; i < 3; ++i) {
        defsim_world *a = scene(backends[i], NULL), *b = scene(backends[i], NULL);
        if (!a) continue;
        for (int k = 0; k < 10; ++k) {
            void *buf;
            size_t size;
            TU_OK(defsim_world_save_buffer(a, &buf, &size));
            defsim_buffer_free(buf);
            run(a, k, 1);
            run(b, k, 1);
        }
        assert_true(same_bits(a, b));
        defsim_world_destroy(a);
        defsim_world_destroy(b);
    }
}

static unsigned char *saved(const char *backend, size_t *size)
{
    defsim_world *w = scene(backend, NULL);
    run(w, 0, 5);
    void *buf = NULL;
    TU_OK(defsim_world_save_buffer(w, &buf, size));
    defsim_world_destroy(w);
    unsigned char *copy = malloc(*size);
    assert_non_null(copy);
    memcpy(copy, buf, *size);
    defsim_buffer_free(buf);
    return copy;
}

/* Every truncation and every single-byte change is refused with DEFSIM_ERR_IO. */
static void test_damaged_files(void **state)
{
    (void)state;
    size_t n = 0;
    unsigned char *buf = saved("velocity_verlet", &n);
    defsim_world *w = (defsim_world *)&w;   /* must come back NULL */
    int truncated = 0;
    for (size_t len = 0; len < n; len += 1 + len / 64, ++truncated) {
        assert_int_equal(defsim_world_load_buffer(buf, len, NULL, NULL, &w), DEFSIM_ERR_IO);
        assert_null(w);
    }
    int refused = 0;
    for (size_t at = 0; at < n; at += 3) {
        buf[at] ^= 0x10;
        w = (defsim_world *)&w;
        assert_int_equal(defsim_world_load_buffer(buf, n, NULL, NULL, &w), DEFSIM_ERR_IO);
        assert_null(w);
        buf[at] ^= 0x10;
        ++refused;
    }
    printf("  %d truncations and %d corrupted copies of a %zu-byte checkpoint refused\n",
           truncated, refused, n);
    assert_true(strstr(defsim_last_error(), "CRC") != NULL);
    /* A trailing byte, and a version from the future. */
    unsigned char *longer = malloc(n + 1);
    assert_non_null(longer);
    memcpy(longer, buf, n);
    longer[n] = 0;
    assert_int_equal(defsim_world_load_buffer(longer, n + 1, NULL, NULL, &w), DEFSIM_ERR_IO);
    free(longer);
    buf[8] = (unsigned char)(DEFSIM__CKPT_VERSION + 1);
    assert_int_equal(defsim_world_load_buffer(buf, n, NULL, NULL, &w), DEFSIM_ERR_IO);
    assert_true(strstr(defsim_last_error(), "version") != NULL);
    buf[8] = (unsigned char)DEFSIM__CKPT_VERSION;
    TU_OK(defsim_world_load_buffer(buf, n, NULL, NULL, &w));
    defsim_world_destroy(w);
    free(buf);
    assert_int_equal(defsim_world_load(NULL, NULL, NULL, &w), DEFSIM_ERR_INVALID_ARGUMENT);
    char path[400];
    snprintf(path, sizeof path, "%s/none.dfck", tu_tmpdir);
    assert_int_equal(defsim_world_load(path, NULL, NULL, &w), DEFSIM_ERR_IO);
}

/* A chunk that validates (its CRC recomputed) but holds nonsense is refused too. */
static void test_valid_crc_bad_contents(void **state)
{
    (void)state;
    size_t n = 0;
    unsigned char *buf = saved("symplectic_euler", &n);
    /* The STAT chunk's vertex count: find the tag, change the count, fix the CRC. */
    size_t at = DEFSIM__CKPT_HEADER;
    while (memcmp(buf + at, "STAT", 4) != 0) {
        uint64_t len = 0;
        for (int k = 0; k < 8; ++k) len |= (uint64_t)buf[at + 4 + k] << (8 * k);
        at += 16 + (size_t)len;
        assert_true(at < n);
    }
    uint64_t len = 0;
    for (int k = 0; k < 8; ++k) len |= (uint64_t)buf[at + 4 + k] << (8 * k);
    buf[at + 12] ^= 1;
    const uint32_t crc = defsim__crc32(0, buf + at, 12 + (size_t)len);
    for (int k = 0; k < 4; ++k) buf[at + 12 + len + k] = (unsigned char)(crc >> (8 * k));
    defsim_world *w = NULL;
    assert_int_equal(defsim_world_load_buffer(buf, n, NULL, NULL, &w), DEFSIM_ERR_IO);
    assert_null(w);
    assert_true(strstr(defsim_last_error(), "STAT") != NULL);
    free(buf);
}

/* Contents that pass the CRC but were changed at random (1 to 4 bytes of one chunk, the CRC
 * recomputed) never crash the loader: each load either fails with a status or gives a world that
 * steps or refuses to step with a status. */
static void test_mutated_contents(void **state)
{
    (void)state;
    size_t n = 0;
    unsigned char *orig = saved("velocity_verlet", &n);
    unsigned char *buf = malloc(n);
    assert_non_null(buf);
    unsigned long long seed = 17;
    int refused = 0, loaded = 0;
    for (int trial = 0; trial < 3000; ++trial) {
        memcpy(buf, orig, n);
        /* Pick a chunk by walking a random number of them. */
        size_t at = DEFSIM__CKPT_HEADER, len = 0;
        const int hops = (int)(8.0 * (tu_rand(&seed) + 1.0));
        for (int h = 0;; ++h) {
            len = 0;
            for (int k = 0; k < 8; ++k) len |= (size_t)buf[at + 4 + k] << (8 * k);
            if (h == hops || at + 16 + len >= n - 16) break;
            at += 16 + len;
        }
        if (len == 0) continue;
        const int changes = 1 + (int)(2.0 * (tu_rand(&seed) + 1.0));
        for (int c = 0; c < changes; ++c) {
            const size_t k = (size_t)((tu_rand(&seed) + 1.0) * 0.5 * (double)len) % len;
            buf[at + 12 + k] = (unsigned char)(256.0 * 0.5 * (tu_rand(&seed) + 1.0));
        }
        const uint32_t crc = defsim__crc32(0, buf + at, 12 + len);
        for (int k = 0; k < 4; ++k) buf[at + 12 + len + k] = (unsigned char)(crc >> (8 * k));
        defsim_world *w = NULL;
        const defsim_status st = defsim_world_load_buffer(buf, n, NULL, NULL, &w);
        if (st != DEFSIM_OK) {
            assert_null(w);
            ++refused;
            continue;
        }
        ++loaded;
        (void)defsim_world_step(w, H);   /* any status, no crash */
        defsim_world_destroy(w);
    }
    printf("  3000 mutated checkpoints with valid CRCs: %d refused, %d loaded (and stepped)\n",
           refused, loaded);
    assert_true(refused > 0 && loaded > 0);
    free(buf);
    free(orig);
}

static int count_entries(const char *dir)
{
    DIR *d = opendir(dir);
    assert_non_null(d);
    int n = 0;
    for (struct dirent *e; (e = readdir(d));) n += e->d_name[0] != '.';
    closedir(d);
    return n;
}

/* Writes go through a temporary file: a failed save leaves the old checkpoint as it was, a good
 * one replaces it, and no temporary file is left behind. */
static void test_atomic_write(void **state)
{
    (void)state;
    defsim_world *w = scene("symplectic_euler", NULL);
    char path[400], bad[400];
    snprintf(path, sizeof path, "%s/atomic.dfck", tu_tmpdir);
    snprintf(bad, sizeof bad, "%s/missing/dir/x.dfck", tu_tmpdir);
    const int before = count_entries(tu_tmpdir);
    TU_OK(defsim_world_save(w, path));
    assert_int_equal(count_entries(tu_tmpdir), before + 1);
    assert_int_equal(defsim_world_save(w, bad), DEFSIM_ERR_IO);
    assert_non_null(strstr(defsim_world_last_error(w), "open"));
    /* A directory in the way of the rename: the temporary file goes, the directory stays. */
    char dir[400];
    snprintf(dir, sizeof dir, "%s/adir", tu_tmpdir);
    assert_int_equal(mkdir(dir, 0700), 0);
    assert_int_equal(defsim_world_save(w, dir), DEFSIM_ERR_IO);
    assert_non_null(strstr(defsim_world_last_error(w), "rename"));
    assert_int_equal(count_entries(tu_tmpdir), before + 2);
    run(w, 0, 3);
    TU_OK(defsim_world_save(w, path));
    assert_int_equal(count_entries(tu_tmpdir), before + 2);
    defsim_world *b = NULL;
    TU_OK(defsim_world_load(path, NULL, NULL, &b));
    assert_true(same_bits(w, b));
    defsim_world_destroy(b);
    defsim_world_destroy(w);
}

/* set_state with the world's own values (or NULL, NULL) keeps IDA's history: the run goes on
 * bit for bit; a changed value still restarts it. */
static void test_set_state_keeps_history(void **state)
{
    (void)state;
    driven = 0;
    defsim_world *a = scene("sundials_ida", NULL), *b = scene("sundials_ida", NULL);
    if (!a) skip();
    run(a, 0, 15);
    run(b, 0, 15);
    double *x = tu_positions(b), *v = tu_velocities(b);
    TU_OK(defsim_world_set_state(b, x, v));
    TU_OK(defsim_world_set_state(b, NULL, NULL));
    TU_OK(defsim_world_set_state(b, x, NULL));
    run(a, 15, 15);
    run(b, 15, 15);
    assert_true(same_bits(a, b));
    /* A real change restarts IDA: the runs part (by far more than the change). */
    const int32_t n = defsim_world_vertex_count(b);
    free(x);
    x = tu_positions(b);
    x[3 * (n - 2)] += 1e-9;
    TU_OK(defsim_world_set_state(b, x, NULL));
    x[3 * (n - 2)] -= 1e-9;
    TU_OK(defsim_world_set_state(b, x, NULL));
    run(a, 30, 15);
    run(b, 30, 15);
    printf("  sundials_ida after a restart: max |difference| %.3g\n", state_diff(a, b));
    assert_false(same_bits(a, b));
    driven = 1;
    free(x);
    free(v);
    defsim_world_destroy(a);
    defsim_world_destroy(b);
}

/* Files of older format versions, committed as written by the library of their time: the
 * symplectic_euler scene with auto_substep after 20 steps. Each loads, holds what that run
 * computes now, and steps on. Version 1 held no auto_substep cache, so the loaded world
 * estimates the stable step afresh at its first step, where the uninterrupted run keeps its
 * estimate from step 1; from version 2 on the estimate comes back with the file. */
static void check_old_file(const char *path, int has_cache)
{
    defsim_world *old = NULL;
    TU_OK(defsim_world_load(path, NULL, NULL, &old));
    defsim_world *now = scene("symplectic_euler", NULL);
    TU_OK(defsim_world_set_option(now, "core.auto_substep", "true"));
    run(now, 0, 20);
    assert_true(defsim_world_time(old) == defsim_world_time(now));
    double on;
    TU_OK(defsim_world_get_option(old, "core.auto_substep", &on));
    assert_true(on == 1.0);
    const int32_t n = defsim_world_vertex_count(now);
    double *a = tu_positions(old), *b = tu_positions(now);
    /* The same code on the same machine gives the same bits; another compiler may contract
     * differently, so compare to roundoff. */
    assert_true(tu_rel_diff(a, b, 3 * n, 1.0) < 1e-12);
    free(a);
    free(b);
    defsim_stats so, sn;
    so.size = sn.size = sizeof so;
    TU_OK(defsim_world_stats(old, &so));
    assert_int_equal(so.steps, 20);
    run(old, 20, 5);
    run(now, 20, 5);
    assert_true(state_diff(old, now) < 1e-9);
    TU_OK(defsim_world_stats(old, &so));
    TU_OK(defsim_world_stats(now, &sn));
    assert_true(so.stable_step > 0.0 && sn.stable_step > 0.0);
    if (has_cache)
        assert_true(so.stable_step == sn.stable_step);
    else
        assert_true(so.stable_step != sn.stable_step);
    defsim_world_destroy(old);
    defsim_world_destroy(now);
}

static void test_version_1_file(void **state)
{
    (void)state;
    check_old_file(DEFSIM_TEST_DATA "/v1.dfck", 0);
}

static void test_version_2_file(void **state)
{
    (void)state;
    check_old_file(DEFSIM_TEST_DATA "/v2.dfck", 1);
}

/* Format version 4 with a collider: tests/checkpoint/v4_colliders.dfck, written by the library
 * of commit 28c0d99 (docs/checkpoints.md, "Versioning policy"): a stable neo-Hookean cube
 * (2x2x2 cells, 0.2 m, Rayleigh beta 2e-3) started at 0.5 m/s along x on a ground with friction
 * 0.6, symplectic_euler, 40 steps of 0.5 ms. It loads and holds that run's state. It lacks
 * version 5's contact state, so the loaded world computes the penalty frequency again, at the
 * loaded state, and continues close to the uninterrupted run, not bit for bit (a file saved now
 * does: test_adv_checkpoint). */
static defsim_world *sliding_cube(void)
{
    defsim_world *w = tu_world("symplectic_euler", -9.81, 1);
    defsim_material m;
    defsim_material_init(&m, sizeof m, DEFSIM_MODEL_STABLE_NEOHOOKEAN);
    m.youngs_modulus = 1e5;
    m.poisson_ratio = 0.3;
    m.density = 1000.0;
    m.stiffness_damping = 2e-3;
    const double lo[3] = {0.0, 0.0001, 0.0}, hi[3] = {0.2, 0.2001, 0.2};
    tu_add_box_material(w, 2, 2, 2, lo, hi, &m);
    defsim_collider_def cd;
    defsim_collider_def_init(&cd, sizeof cd);
    cd.friction = 0.6;
    TU_OK(defsim_world_add_collider(w, &cd, NULL));
    const int32_t n = defsim_world_vertex_count(w);
    double *x = tu_positions(w), *v = tu_velocities(w);
    for (int32_t i = 0; i < n; ++i) v[3 * i] += 0.5;
    TU_OK(defsim_world_set_state(w, x, v));
    free(x);
    free(v);
    return w;
}

/* A world loaded from an older file, saved again: a file of this version, whose world continues
 * bit for bit with `old` over 20 steps. */
static void check_saved_again(defsim_world *old)
{
    void *buf = NULL;
    size_t size = 0;
    TU_OK(defsim_world_save_buffer(old, &buf, &size));
    assert_int_equal(((const unsigned char *)buf)[8], DEFSIM__CKPT_VERSION);
    defsim_world *again = NULL;
    TU_OK(defsim_world_load_buffer(buf, size, NULL, NULL, &again));
    defsim_buffer_free(buf);
    for (int k = 0; k < 20; ++k) {
        TU_OK(defsim_world_step(old, 5e-4));
        TU_OK(defsim_world_step(again, 5e-4));
    }
    assert_true(same_bits(old, again));
    defsim_world_destroy(again);
}

static void test_version_4_file(void **state)
{
    (void)state;
    defsim_world *old = NULL;
    TU_OK(defsim_world_load(DEFSIM_TEST_DATA "/v4_colliders.dfck", NULL, NULL, &old));
    defsim_world *now = sliding_cube();
    for (int k = 0; k < 40; ++k) TU_OK(defsim_world_step(now, 5e-4));
    assert_int_equal(defsim_world_collider_count(old), 1);
    defsim_collider_def cd;
    cd.size = sizeof cd;
    TU_OK(defsim_world_get_collider(old, 0, NULL, &cd));
    assert_true(cd.friction == 0.6);
    assert_true(defsim_world_time(old) == defsim_world_time(now));
    const int32_t n = defsim_world_vertex_count(now);
    assert_int_equal(defsim_world_vertex_count(old), n);
    double *a = tu_positions(old), *b = tu_positions(now);
    assert_true(tu_rel_diff(a, b, 3 * n, 1.0) < 1e-12);   /* roundoff: another compiler */
    free(a);
    free(b);
    for (int k = 0; k < 20; ++k) {
        TU_OK(defsim_world_step(old, 5e-4));
        TU_OK(defsim_world_step(now, 5e-4));
    }
    const double d = state_diff(old, now);
    printf("  version 4 with a collider: max |difference| 20 steps after the load = %.3g\n", d);
    assert_true(d > 0.0 && d < 1e-3);
    /* Saved again, it is a file of this version, and continues bit for bit from there. */
    check_saved_again(old);
    defsim_world_destroy(old);
    defsim_world_destroy(now);
}

/* Format version 5: tests/checkpoint/v5_friction.dfck, written by the library of commit 520ba06
 * (the last to write version 5) from the sliding cube above after 40 steps. Its CNTC chunk holds
 * the penalty's frequency and friction's velocities, which version 6 keeps in the collider
 * term's TERM chunk: the loaded world continues as the uninterrupted run does (the same bits
 * with this compiler; roundoff with another, which may contract differently), and saved again
 * it is a version 6 file with a TERM chunk and no CNTC, which continues bit for bit. */
/* The sliding cube saved after 40 steps in `file`, loaded: it holds the uninterrupted run's
 * state and, 20 steps on, is within 1e-9 of it (the same bits with this compiler; roundoff with
 * another). Returns the loaded world. */
static defsim_world *sliding_cube_file(const char *file, const char *what)
{
    defsim_world *old = NULL;
    TU_OK(defsim_world_load(file, NULL, NULL, &old));
    defsim_world *now = sliding_cube();
    for (int k = 0; k < 40; ++k) TU_OK(defsim_world_step(now, 5e-4));
    assert_true(defsim_world_time(old) == defsim_world_time(now));
    const int32_t n = defsim_world_vertex_count(now);
    double *a = tu_positions(old), *b = tu_positions(now);
    assert_true(tu_rel_diff(a, b, 3 * n, 1.0) < 1e-12);
    free(a);
    free(b);
    for (int k = 0; k < 20; ++k) {
        TU_OK(defsim_world_step(old, 5e-4));
        TU_OK(defsim_world_step(now, 5e-4));
    }
    const double d = state_diff(old, now);
    printf("  %s: max |difference| 20 steps after the load = %.3g\n", what, d);
    assert_true(d < 1e-9);   /* version 4's file, without CNTC, is 1e-6 .. 1e-3 off */
    defsim_world_destroy(now);
    return old;
}

static void test_version_5_file(void **state)
{
    (void)state;
    defsim_world *old = sliding_cube_file(DEFSIM_TEST_DATA "/v5_friction.dfck",
                                          "version 5 with friction");
    void *buf = NULL;
    size_t size = 0;
    TU_OK(defsim_world_save_buffer(old, &buf, &size));
    const unsigned char *p = buf;
    assert_int_equal(p[8], DEFSIM__CKPT_VERSION);
    int term = 0, cntc = 0;
    for (size_t at = DEFSIM__CKPT_HEADER; at + 16 <= size;) {
        uint64_t len = 0;
        for (int k = 7; k >= 0; --k) len = (len << 8) | p[at + 4 + k];
        term += memcmp(p + at, "TERM", 4) == 0;
        cntc += memcmp(p + at, "CNTC", 4) == 0;
        at += 16 + (size_t)len;
    }
    assert_int_equal(term, 1);
    assert_int_equal(cntc, 0);
    defsim_world *again = NULL;
    TU_OK(defsim_world_load_buffer(buf, size, NULL, NULL, &again));
    defsim_buffer_free(buf);
    for (int k = 0; k < 20; ++k) {
        TU_OK(defsim_world_step(old, 5e-4));
        TU_OK(defsim_world_step(again, 5e-4));
    }
    assert_true(same_bits(old, again));
    defsim_world_destroy(old);
    defsim_world_destroy(again);
}

/* Format version 6: tests/checkpoint/v6_sliding.dfck, written by the library of commit 12b74cf
 * (the last to write version 6) from the sliding cube above after 40 steps. Version 7 adds BODY's
 * volume_averaging, version 8 its indices per tet (quadratic tets), version 9 its shell fields,
 * version 10 its strain limit, version 11 its contact thickness:
 * the file's body loads with the standard linear element, no shell and thickness 0, and continues as the
 * uninterrupted run does; saved again it is a file of today's version that continues bit for
 * bit. */
static void test_version_6_file(void **state)
{
    (void)state;
    defsim_world *old = sliding_cube_file(DEFSIM_TEST_DATA "/v6_sliding.dfck", "version 6");
    assert_int_equal(DEFSIM__CKPT_VERSION, 11);
    check_saved_again(old);
    defsim_world_destroy(old);
}

/* Format version 7: tests/checkpoint/v7_sliding.dfck, written by the library of commit 8c08767
 * (the last to write version 7, before BODY held the indices per tet) from the same cube and
 * steps: it loads, continues as the uninterrupted run does, and saved again continues bit for
 * bit. */
static void test_version_7_file(void **state)
{
    (void)state;
    defsim_world *old = sliding_cube_file(DEFSIM_TEST_DATA "/v7_sliding.dfck", "version 7");
    check_saved_again(old);
    defsim_world_destroy(old);
}

/* Format version 8: tests/checkpoint/v8_sliding.dfck, written by the library of commit ef40028
 * (the last to write version 8, before BODY held the shell fields) from the same cube and steps:
 * it loads (the body without a shell), continues as the uninterrupted run does, and saved again
 * continues bit for bit. */
static void test_version_8_file(void **state)
{
    (void)state;
    defsim_world *old = sliding_cube_file(DEFSIM_TEST_DATA "/v8_sliding.dfck", "version 8");
    check_saved_again(old);
    defsim_world_destroy(old);
}

/* Format version 9: tests/checkpoint/v9_sliding.dfck, written by the library of commit bd1fbe0
 * (the last to write version 9, before BODY held the contact thickness) from the same cube and
 * steps: it loads (the body with thickness 0), continues as the uninterrupted run does, and saved
 * again continues bit for bit. */
static void test_version_9_file(void **state)
{
    (void)state;
    defsim_world *old = sliding_cube_file(DEFSIM_TEST_DATA "/v9_sliding.dfck", "version 9");
    check_saved_again(old);
    defsim_world_destroy(old);
}

/* Format version 10: tests/checkpoint/v10_sliding.dfck, written by the library of commit 9f677ab
 * (the last to write version 10: BODY ends with the strain limit, before it held the contact
 * thickness) from the same cube and steps: it loads (the body with thickness 0), continues as the
 * uninterrupted run does, and saved again continues bit for bit. Read as version 11, the chunk
 * would lack the thickness's 8 bytes and fail its length check. */
static void test_version_10_file(void **state)
{
    (void)state;
    defsim_world *old = sliding_cube_file(DEFSIM_TEST_DATA "/v10_sliding.dfck", "version 10");
    check_saved_again(old);
    defsim_world_destroy(old);
}

/* Format version 9 with a shell: tests/checkpoint/v9_shell.dfck, written by the library of commit
 * 7c07447 (format 9, before BODY held the strain limit) from shell_sheet_v9.h's sheet after its
 * 40 steps: it loads (the shell without a strain limit), is where this library's run of the
 * same sheet is, continues as that run does, and saved again (today's version) continues bit for bit.
 * The file's bytes after BODY's shell fields would be read as a limit if the reader took version
 * 9 for 10: the chunk's length check fails then. */
static void test_version_9_shell_file(void **state)
{
    (void)state;
    defsim_world *old = NULL;
    TU_OK(defsim_world_load(DEFSIM_TEST_DATA "/v9_shell.dfck", NULL, NULL, &old));
    defsim_mesh m;
    defsim_world *now = shell_sheet_v9(&m);
    assert_non_null(now);
    for (int k = 0; k < SHELL_V9_STEPS; ++k) TU_OK(defsim_world_step(now, SHELL_V9_H));
    assert_true(defsim_world_time(old) == defsim_world_time(now));
    const double d0 = state_diff(old, now);
    for (int k = 0; k < 20; ++k) {
        TU_OK(defsim_world_step(old, SHELL_V9_H));
        TU_OK(defsim_world_step(now, SHELL_V9_H));
    }
    const double d = state_diff(old, now);
    const int32_t n = defsim_world_vertex_count(now);
    double *x = tu_positions(old);
    printf("  version 9 shell: max |difference| at the load %.3g, 20 steps after %.3g; the far "
           "corner at y = %.4g m\n", d0, d, x[3 * (n - 1) + 1]);
    assert_true(d0 < 1e-12 && d < 1e-9);
    assert_true(x[3 * (n - 1) + 1] < -1e-4);   /* it fell: the shell acts */
    free(x);
    check_saved_again(old);
    defsim_world_destroy(old);
    defsim_world_destroy(now);
    defsim_mesh_free(&m);
}

/* sundials_erk's history layout 1 (written by commit f44ad41, before the replay: the next step
 * length only) still loads, and continues close to the saved run, not bit for bit (1.3e-6 m at
 * rtol 1e-2): the files are a cantilever at step 15 of 1/60 s and the same run at step 31. */
static void test_erk_layout_1(void **state)
{
    (void)state;
    if (!tu_available("sundials_erk")) return;
    defsim_world *a = NULL, *b = NULL;
    TU_OK(defsim_world_load(DEFSIM_TEST_DATA "/erk_layout1_step15.dfck", NULL, NULL, &a));
    TU_OK(defsim_world_load(DEFSIM_TEST_DATA "/erk_layout1_step31.dfck", NULL, NULL, &b));
    for (int k = 0; k < 16; ++k) TU_OK(defsim_world_step(a, 1.0 / 60.0));
    assert_true(fabs(defsim_world_time(a) - defsim_world_time(b)) < 1e-15);
    const double d = state_diff(a, b);
    printf("  sundials_erk layout 1: max |difference| after 16 steps = %.3g\n", d);
    assert_true(d > 0.0 && d < 1e-5);
    defsim_world_destroy(a);
    defsim_world_destroy(b);
}

/* Colliders (format version 3): shape, friction and both poses come back with the same bits,
 * a pending pose included, and ids of the loaded world list them in order. */
static void test_colliders(void **state)
{
    (void)state;
    defsim_world *a = scene("symplectic_euler", NULL);
    defsim_collider_def cd;
    defsim_collider_def_init(&cd, sizeof cd);
    cd.position[1] = -0.5;
    cd.friction = 0.4;
    defsim_collider_id ground, ball;
    TU_OK(defsim_world_add_collider(a, &cd, &ground));
    defsim_collider_def_init(&cd, sizeof cd);
    cd.shape = DEFSIM_SHAPE_SPHERE;
    cd.radius = 0.15;
    cd.position[0] = 1.5;
    cd.position[1] = -0.3;
    const double q[4] = {0.9, 0.1, 0.3, 0.2};   /* normalised by the world */
    const double n = sqrt(0.81 + 0.01 + 0.09 + 0.04);
    for (int k = 0; k < 4; ++k) cd.rotation[k] = q[k] / n;
    TU_OK(defsim_world_add_collider(a, &cd, &ball));
    TU_OK(defsim_world_remove_collider(a, ground));
    TU_OK(defsim_world_add_collider(a, &cd, &ground));
    run(a, 0, 4);
    const double p1[3] = {1.5, -0.25, 0.01}, r1[4] = {1, 0, 0, 0};
    TU_OK(defsim_collider_set_pose(a, ball, p1, r1));   /* pending: reached at the next step */
    void *buf = NULL;
    size_t size = 0;
    TU_OK(defsim_world_save_buffer(a, &buf, &size));
    defsim_world *b = NULL;
    TU_OK(defsim_world_load_buffer(buf, size, NULL, NULL, &b));
    defsim_buffer_free(buf);
    assert_int_equal(defsim_world_collider_count(b), 2);
    for (int32_t i = 0; i < 2; ++i) {
        defsim_collider_def da, db;
        da.size = db.size = sizeof da;
        TU_OK(defsim_world_get_collider(a, i, NULL, &da));
        TU_OK(defsim_world_get_collider(b, i, NULL, &db));
        assert_int_equal(da.shape, db.shape);
        assert_memory_equal(da.position, db.position, sizeof da.position);
        assert_memory_equal(da.rotation, db.rotation, sizeof da.rotation);
        assert_memory_equal(da.normal, db.normal, sizeof da.normal);
        assert_true(da.radius == db.radius && da.friction == db.friction);
    }
    double *fa = calloc(3 * (size_t)defsim_world_vertex_count(a), sizeof *fa);
    double *fb = calloc(3 * (size_t)defsim_world_vertex_count(a), sizeof *fb);
    TU_OK(defsim_world_get_contact_forces(a, fa, defsim_world_vertex_count(a)));
    TU_OK(defsim_world_get_contact_forces(b, fb, defsim_world_vertex_count(b)));
    assert_memory_equal(fa, fb, 3 * (size_t)defsim_world_vertex_count(a) * sizeof *fa);
    run(a, 4, 6);
    run(b, 4, 6);
    assert_true(same_bits(a, b));
    /* The ball (slot 2) had a pose pending; both worlds hold the same pose after the steps. */
    defsim_collider_def da, db;
    da.size = db.size = sizeof da;
    TU_OK(defsim_world_get_collider(a, 1, NULL, &da));
    TU_OK(defsim_world_get_collider(b, 1, NULL, &db));
    assert_memory_equal(da.position, db.position, sizeof da.position);
    assert_memory_equal(da.rotation, db.rotation, sizeof da.rotation);
    /* SDF functions are the host's: only an SDF collider takes one. */
    defsim_collider_id id;
    TU_OK(defsim_world_get_collider(b, 0, &id, NULL));
    assert_int_equal(defsim_collider_set_sdf(b, id, NULL, NULL), DEFSIM_ERR_INVALID_ARGUMENT);
    free(fa);
    free(fb);
    defsim_world_destroy(a);
    defsim_world_destroy(b);
}

/* A backend table with save_state but no load_state is refused at registration (ABI 5). */
static defsim_status nop_init(const defsim_host *h, defsim_system *s, void *st)
{
    (void)h; (void)s; (void)st;
    return DEFSIM_OK;
}

static defsim_status nop_step(const defsim_host *h, defsim_system *s, void *st, double dt)
{
    (void)h; (void)s; (void)st; (void)dt;
    return DEFSIM_OK;
}

static void nop_fini(const defsim_host *h, defsim_system *s, void *st)
{
    (void)h; (void)s; (void)st;
}

static defsim_status nop_save(const defsim_host *h, defsim_system *s, const void *st,
                              const defsim_state_writer *w)
{
    (void)h; (void)s; (void)st; (void)w;
    return DEFSIM_OK;
}

static void test_register_half_pair(void **state)
{
    (void)state;
    defsim_backend b = {.abi_version = DEFSIM_BACKEND_ABI_VERSION,
                        .struct_size = sizeof(defsim_backend), .name = "ckpt_half",
                        .init = nop_init, .step = nop_step, .fini = nop_fini,
                        .save_state = nop_save};
    assert_int_equal(defsim_register_backend(&b), DEFSIM_ERR_INVALID_ARGUMENT);
    assert_non_null(strstr(defsim_last_error(), "save_state and load_state"));
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_bit_exact_backends),
        cmocka_unit_test(test_erk_every_point),
        cmocka_unit_test(test_ida_klu_pivots),
        cmocka_unit_test(test_save_changes_nothing),
        cmocka_unit_test(test_damaged_files),
        cmocka_unit_test(test_valid_crc_bad_contents),
        cmocka_unit_test(test_mutated_contents),
        cmocka_unit_test(test_atomic_write),
        cmocka_unit_test(test_set_state_keeps_history),
        cmocka_unit_test(test_version_1_file),
        cmocka_unit_test(test_version_2_file),
        cmocka_unit_test(test_version_4_file),
        cmocka_unit_test(test_version_5_file), cmocka_unit_test(test_version_6_file),
        cmocka_unit_test(test_version_7_file), cmocka_unit_test(test_version_8_file),
        cmocka_unit_test(test_version_9_file), cmocka_unit_test(test_version_10_file),
        cmocka_unit_test(test_version_9_shell_file),
        cmocka_unit_test(test_erk_layout_1),
        cmocka_unit_test(test_colliders),
        cmocka_unit_test(test_register_half_pair),
    };
    return tu_exit(cmocka_run_group_tests(tests, tu_tmpdir_setup, tu_tmpdir_teardown));
}
