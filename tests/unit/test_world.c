/* SPDX-License-Identifier: MIT */
/* World and body API: defaults, bodies, masses, pins, state, ids, and every bad-input path. */
#include "test_util.h"

#include "tet_rest.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

static const double LO[3] = {0, 0, 0}, HI[3] = {1, 1, 1};

/* One unit tet with vertices at the origin and the unit axes (x3 at the origin). */
static const double TET_X[12] = {1, 0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0};
static const int32_t TET_I[4] = {0, 1, 2, 3};

static defsim_body_def tet_def(void)
{
    defsim_body_def bd;
    defsim_body_def_init(&bd, sizeof bd);
    bd.rest_positions = TET_X;
    bd.vertex_count = 4;
    bd.tets = TET_I;
    bd.tet_count = 1;
    return bd;
}

static void test_defaults(void **state)
{
    (void)state;
    defsim_world_def d;
    defsim_world_def_init(&d, sizeof d);
    assert_int_equal(d.size, sizeof d);
    assert_string_equal(d.backend, "symplectic_euler");
    assert_true(d.gravity[1] == -9.81);
    defsim_material m;
    defsim_material_init(&m, sizeof m, DEFSIM_MODEL_COROTATED);
    assert_int_equal(m.model, DEFSIM_MODEL_COROTATED);
    assert_true(m.youngs_modulus == 1e6 && m.poisson_ratio == 0.3 && m.density == 1000.0);
    defsim_body_def bd;
    defsim_body_def_init(&bd, sizeof bd);
    assert_int_equal(bd.material.model, DEFSIM_MODEL_STABLE_NEOHOOKEAN);
    assert_null(bd.rest_positions);
    assert_true(defsim_version_number() == DEFSIM_VERSION_NUMBER);
    assert_string_equal(defsim_status_string(DEFSIM_OK), "ok");
    assert_string_equal(defsim_status_string((defsim_status)-99), "unknown status");
}

static void test_create_errors(void **state)
{
    (void)state;
    defsim_world *w = (defsim_world *)0x1;
    defsim_world_def d;
    defsim_world_def_init(&d, sizeof d);
    assert_int_equal(defsim_world_create(NULL, &w), DEFSIM_ERR_INVALID_ARGUMENT);
    assert_null(w);
    assert_int_equal(defsim_world_create(&d, NULL), DEFSIM_ERR_INVALID_ARGUMENT);
    defsim_world_def z = d;
    z.size = 0;
    assert_int_equal(defsim_world_create(&z, &w), DEFSIM_ERR_INVALID_ARGUMENT);
    assert_true(strlen(defsim_last_error()) > 0);
    z = d;
    z.backend = "no_such_backend";
    assert_int_equal(defsim_world_create(&z, &w), DEFSIM_ERR_BACKEND_UNAVAILABLE);
    z.backend = "../evil";
    assert_int_equal(defsim_world_create(&z, &w), DEFSIM_ERR_BACKEND_UNAVAILABLE);
    z = d;
    z.gravity[0] = NAN;
    assert_int_equal(defsim_world_create(&z, &w), DEFSIM_ERR_INVALID_ARGUMENT);
    z = d;
    z.num_threads = -1;
    assert_int_equal(defsim_world_create(&z, &w), DEFSIM_ERR_INVALID_ARGUMENT);
    z = d;
    z.backend = "a_backend_name_of_64_characters_is_one_too_long_for_the_world_xx";
    assert_int_equal(strlen(z.backend), 64);
    assert_int_equal(defsim_world_create(&z, &w), DEFSIM_ERR_INVALID_ARGUMENT);
    defsim_world_destroy(NULL);
    assert_string_equal(defsim_world_last_error(NULL), "");
}

static void test_masses_and_reorder(void **state)
{
    (void)state;
    defsim_world *w = tu_world("symplectic_euler", 0.0, 1);
    defsim_body_id b = tu_add_box(w, DEFSIM_MODEL_NEOHOOKEAN, 2, 3, 1, LO, HI, 1e5, 0.3, 500.0);
    int n = defsim_world_vertex_count(w);
    assert_int_equal(n, 3 * 4 * 2);
    double *m = malloc((size_t)n * sizeof *m);
    TU_OK(defsim_world_get_masses(w, m, n));
    double total = 0;
    for (int i = 0; i < n; ++i) total += m[i];
    assert_true(fabs(total - 500.0) < 1e-12 * 500.0);   /* rho * volume of the unit box */
    free(m);
    assert_int_equal(defsim_body_vertex_offset(w, b), 0);

    /* A negatively oriented tet is reordered and counted. */
    defsim_body_def bd = tet_def();
    int32_t neg[4] = {1, 0, 2, 3};
    bd.tets = neg;
    TU_OK(defsim_world_add_body(w, &bd, NULL));
    defsim_stats s = {.size = sizeof s};
    TU_OK(defsim_world_stats(w, &s));
    assert_int_equal(s.reordered_tets, 1);
    defsim_energy e;
    TU_OK(defsim_world_energy(w, &e));
    assert_true(fabs(e.elastic) < 1e-12 && e.kinetic == 0.0);
    defsim_world_destroy(w);
}

static void test_bad_bodies(void **state)
{
    (void)state;
    defsim_world *w = tu_world("explicit_euler", -9.81, 1);
    defsim_body_def bd = tet_def();
    defsim_body_id id = {7, 7};
    assert_int_equal(defsim_world_add_body(NULL, &bd, &id), DEFSIM_ERR_INVALID_ARGUMENT);
    assert_int_equal(defsim_world_add_body(w, NULL, &id), DEFSIM_ERR_INVALID_ARGUMENT);
    defsim_body_def z = bd;
    z.size = 0;
    assert_int_equal(defsim_world_add_body(w, &z, &id), DEFSIM_ERR_INVALID_ARGUMENT);
    z = bd;
    z.rest_positions = NULL;
    assert_int_equal(defsim_world_add_body(w, &z, &id), DEFSIM_ERR_INVALID_ARGUMENT);
    z = bd;
    z.tets = NULL;
    assert_int_equal(defsim_world_add_body(w, &z, &id), DEFSIM_ERR_INVALID_ARGUMENT);
    z = bd;
    z.vertex_count = 0;
    assert_int_equal(defsim_world_add_body(w, &z, &id), DEFSIM_ERR_INVALID_ARGUMENT);

    int32_t out_of_range[4] = {0, 1, 2, 4};
    z = bd;
    z.tets = out_of_range;
    assert_int_equal(defsim_world_add_body(w, &z, &id), DEFSIM_ERR_INVALID_MESH);
    assert_non_null(strstr(defsim_world_last_error(w), "tet 0"));
    int32_t negative[4] = {0, -1, 2, 3};
    z.tets = negative;
    assert_int_equal(defsim_world_add_body(w, &z, &id), DEFSIM_ERR_INVALID_MESH);
    int32_t repeated[4] = {0, 1, 1, 3};
    z.tets = repeated;
    assert_int_equal(defsim_world_add_body(w, &z, &id), DEFSIM_ERR_INVALID_MESH);

    double nanx[12];
    memcpy(nanx, TET_X, sizeof nanx);
    nanx[4] = NAN;
    z = bd;
    z.rest_positions = nanx;
    assert_int_equal(defsim_world_add_body(w, &z, &id), DEFSIM_ERR_INVALID_MESH);
    nanx[4] = INFINITY;
    assert_int_equal(defsim_world_add_body(w, &z, &id), DEFSIM_ERR_INVALID_MESH);

    double flat[12] = {1, 0, 0, 0, 1, 0, 1, 1, 0, 0, 0, 0};   /* all in z = 0 */
    z = bd;
    z.rest_positions = flat;
    assert_int_equal(defsim_world_add_body(w, &z, &id), DEFSIM_ERR_INVALID_MESH);
    /* The rule of tet_rest.h: a sliver of height twice the threshold is a body, half is not. */
    const double l = sqrt(2.0), limit = DEFSIM__DEGENERATE_REL * l * l * l;
    double sliver[12] = {1, 0, 0, 0, 1, 0, 0, 0, 2.0 * limit, 0, 0, 0};
    z.rest_positions = sliver;
    defsim_body_id thin;
    TU_OK(defsim_world_add_body(w, &z, &thin));
    TU_OK(defsim_world_remove_body(w, thin));
    sliver[8] = 0.5 * limit;
    assert_int_equal(defsim_world_add_body(w, &z, &id), DEFSIM_ERR_INVALID_MESH);
    /* Two tets, the second degenerate: its index is in the message. */
    double x5[15] = {1, 0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 2, 0, 0};
    int32_t t2[8] = {0, 1, 2, 3, 0, 4, 3, 3};
    t2[7] = 1;
    double x5b[15];
    memcpy(x5b, x5, sizeof x5b);
    x5b[12] = 0.5; x5b[13] = 0.5; x5b[14] = 0.0;   /* vertex 4 in the plane of 0, 1, 3 */
    z = bd;
    z.rest_positions = x5b;
    z.vertex_count = 5;
    z.tets = t2;
    z.tet_count = 2;
    assert_int_equal(defsim_world_add_body(w, &z, &id), DEFSIM_ERR_INVALID_MESH);
    assert_non_null(strstr(defsim_world_last_error(w), "tet 1"));

    z = bd;
    z.material.density = -1.0;
    assert_int_equal(defsim_world_add_body(w, &z, &id), DEFSIM_ERR_INVALID_MATERIAL);
    z = bd;
    z.material.youngs_modulus = 0.0;
    assert_int_equal(defsim_world_add_body(w, &z, &id), DEFSIM_ERR_INVALID_MATERIAL);
    z = bd;
    z.material.poisson_ratio = 0.5;
    assert_int_equal(defsim_world_add_body(w, &z, &id), DEFSIM_ERR_INVALID_MATERIAL);
    z = bd;
    z.material.model = DEFSIM_MODEL_SPRING;   /* tets with a spring model */
    assert_int_equal(defsim_world_add_body(w, &z, &id), DEFSIM_ERR_INVALID_MATERIAL);
    z = bd;
    z.material.model = (defsim_model)42;
    assert_int_equal(defsim_world_add_body(w, &z, &id), DEFSIM_ERR_INVALID_MATERIAL);
    z = bd;
    z.material.size = 0;
    assert_int_equal(defsim_world_add_body(w, &z, &id), DEFSIM_ERR_INVALID_ARGUMENT);
    z = bd;
    z.material.density = 0.0;   /* vertices without mass */
    assert_int_equal(defsim_world_add_body(w, &z, &id), DEFSIM_ERR_INVALID_MESH);

    /* Springs: negative stiffness, index out of range, zero rest length. */
    defsim_body_def sd;
    defsim_body_def_init(&sd, sizeof sd);
    defsim_material_init(&sd.material, sizeof sd.material, DEFSIM_MODEL_SPRING);
    double sx[6] = {0, 0, 0, 1, 0, 0};
    int32_t sp[2] = {0, 1};
    sd.rest_positions = sx;
    sd.vertex_count = 2;
    sd.springs = sp;
    sd.spring_count = 1;
    z = sd;
    z.material.stiffness = -5.0;
    assert_int_equal(defsim_world_add_body(w, &z, &id), DEFSIM_ERR_INVALID_MATERIAL);
    double kneg = -1.0;
    z = sd;
    z.spring_stiffness = &kneg;
    assert_int_equal(defsim_world_add_body(w, &z, &id), DEFSIM_ERR_INVALID_MATERIAL);
    int32_t sbad[2] = {0, 2};
    z = sd;
    z.springs = sbad;
    assert_int_equal(defsim_world_add_body(w, &z, &id), DEFSIM_ERR_INVALID_MESH);
    double same[6] = {0, 0, 0, 0, 0, 0};
    z = sd;
    z.rest_positions = same;
    assert_int_equal(defsim_world_add_body(w, &z, &id), DEFSIM_ERR_INVALID_MESH);
    double mneg[2] = {1.0, -1.0};
    z = sd;
    z.vertex_mass = mneg;
    assert_int_equal(defsim_world_add_body(w, &z, &id), DEFSIM_ERR_INVALID_MATERIAL);

    /* Nothing of the failed calls stuck: the world is empty and still works. */
    assert_int_equal(defsim_world_vertex_count(w), 0);
    TU_OK(defsim_world_add_body(w, &sd, &id));
    assert_int_equal(defsim_world_vertex_count(w), 2);
    TU_OK(defsim_world_step(w, 1e-3));
    defsim_world_destroy(w);
}

static void test_ids_and_pins(void **state)
{
    (void)state;
    defsim_world *w = tu_world("symplectic_euler", -9.81, 1);
    defsim_body_def bd = tet_def();
    defsim_body_id a, b, c;
    TU_OK(defsim_world_add_body(w, &bd, &a));
    TU_OK(defsim_world_add_body(w, &bd, &b));
    TU_OK(defsim_world_add_body(w, &bd, &c));
    assert_int_equal(defsim_world_vertex_count(w), 12);
    assert_int_equal(defsim_body_vertex_offset(w, c), 8);

    /* Move body c so that removing b shows its state carried over. */
    double *x = tu_positions(w);
    for (int i = 8; i < 12; ++i) x[3 * i + 2] += 5.0;
    TU_OK(defsim_world_set_state(w, x, NULL));
    TU_OK(defsim_world_remove_body(w, b));
    assert_int_equal(defsim_world_vertex_count(w), 8);
    assert_int_equal(defsim_body_vertex_offset(w, c), 4);
    double *y = tu_positions(w);
    assert_true(y[3 * 4 + 2] == x[3 * 8 + 2]);
    free(x);
    free(y);

    /* Stale, null and foreign ids. */
    assert_int_equal(defsim_world_remove_body(w, b), DEFSIM_ERR_STALE_ID);
    assert_int_equal(defsim_body_pin(w, b, TET_I, 1), DEFSIM_ERR_STALE_ID);
    assert_int_equal(defsim_body_vertex_count(w, b), DEFSIM_ERR_STALE_ID);
    defsim_body_id null_id = {0, 0}, wild = {99, 1}, wrong_gen = {a.index, 2};
    assert_int_equal(defsim_body_pin(w, null_id, TET_I, 1), DEFSIM_ERR_STALE_ID);
    assert_int_equal(defsim_body_pin(w, wild, TET_I, 1), DEFSIM_ERR_STALE_ID);
    assert_int_equal(defsim_body_pin(w, wrong_gen, TET_I, 1), DEFSIM_ERR_STALE_ID);
    assert_int_equal(defsim_world_remove_body(NULL, a), DEFSIM_ERR_INVALID_ARGUMENT);

    /* Pin errors. */
    int32_t bad[1] = {4};
    assert_int_equal(defsim_body_pin(w, a, bad, 1), DEFSIM_ERR_INVALID_ARGUMENT);
    assert_int_equal(defsim_body_pin(w, a, NULL, 2), DEFSIM_ERR_INVALID_ARGUMENT);
    assert_int_equal(defsim_body_pin(w, a, TET_I, -1), DEFSIM_ERR_INVALID_ARGUMENT);
    TU_OK(defsim_body_pin(w, a, NULL, 0));

    /* Pinned vertices do not move under gravity; unpinned ones fall. */
    int32_t pin[2] = {0, 3};
    TU_OK(defsim_body_pin(w, a, pin, 2));
    double *x0 = tu_positions(w);
    for (int i = 0; i < 50; ++i) TU_OK(defsim_world_step(w, 1e-3));
    double *x1 = tu_positions(w);
    for (int k = 0; k < 3; ++k) {
        assert_true(x1[k] == x0[k]);
        assert_true(x1[9 + k] == x0[9 + k]);
    }
    assert_true(x1[3 * 5 + 1] < x0[3 * 5 + 1]);   /* body c falls */
    TU_OK(defsim_body_unpin(w, a, pin, 2));
    TU_OK(defsim_world_step(w, 1e-3));
    double *x2 = tu_positions(w);
    assert_true(x2[1] < x1[1]);
    free(x0); free(x1); free(x2);
    defsim_world_destroy(w);
}

static void test_state_and_errors(void **state)
{
    (void)state;
    defsim_world *w = tu_world("symplectic_euler", 0.0, 1);
    defsim_body_def bd = tet_def();
    TU_OK(defsim_world_add_body(w, &bd, NULL));
    double x[12], v[12], out[12];
    for (int i = 0; i < 12; ++i) { x[i] = TET_X[i] * 1.01 + 0.1 * i; v[i] = 0.01 * i; }
    TU_OK(defsim_world_set_state(w, x, v));
    TU_OK(defsim_world_get_positions(w, out, 4));
    assert_memory_equal(out, x, sizeof x);
    TU_OK(defsim_world_get_velocities(w, out, 4));
    assert_memory_equal(out, v, sizeof v);
    assert_int_equal(defsim_world_get_positions(w, out, 3), DEFSIM_ERR_INVALID_ARGUMENT);
    assert_int_equal(defsim_world_get_positions(w, NULL, 4), DEFSIM_ERR_INVALID_ARGUMENT);
    assert_int_equal(defsim_world_get_positions(NULL, out, 4), DEFSIM_ERR_INVALID_ARGUMENT);
    double bad[12];
    memcpy(bad, x, sizeof bad);
    bad[5] = NAN;
    assert_int_equal(defsim_world_set_state(w, bad, NULL), DEFSIM_ERR_INVALID_ARGUMENT);
    TU_OK(defsim_world_get_positions(w, out, 4));
    assert_memory_equal(out, x, sizeof x);   /* unchanged */
    assert_int_equal(defsim_world_step(w, 0.0), DEFSIM_ERR_INVALID_ARGUMENT);
    assert_int_equal(defsim_world_step(w, -1.0), DEFSIM_ERR_INVALID_ARGUMENT);
    assert_int_equal(defsim_world_step(w, NAN), DEFSIM_ERR_INVALID_ARGUMENT);
    assert_int_equal(defsim_world_step(NULL, 1e-3), DEFSIM_ERR_INVALID_ARGUMENT);
    assert_int_equal(defsim_world_energy(w, NULL), DEFSIM_ERR_INVALID_ARGUMENT);
    assert_int_equal(defsim_world_forces(w, NULL, NULL), DEFSIM_ERR_INVALID_ARGUMENT);
    defsim_stats s = {0};
    assert_int_equal(defsim_world_stats(w, &s), DEFSIM_ERR_INVALID_ARGUMENT);
    s.size = sizeof s;
    TU_OK(defsim_world_stats(w, &s));
    assert_int_equal(s.steps, 0);
    assert_true(defsim_world_time(w) == 0.0);
    TU_OK(defsim_world_step(w, 1.0 / 256));   /* below the stable step, 6e-3 s */
    assert_true(defsim_world_time(w) == 1.0 / 256);
    defsim_world_destroy(w);
}

/* Explicit Euler far beyond its stable step: DEFSIM_ERR_UNSTABLE, state exactly as before. */
static void test_unstable_rolls_back(void **state)
{
    (void)state;
    defsim_world *w = tu_world("explicit_euler", -9.81, 1);
    tu_add_box(w, DEFSIM_MODEL_STVK, 2, 1, 1, LO, HI, 1e9, 0.3, 1.0);
    int n = defsim_world_vertex_count(w);
    double *x = tu_positions(w);
    unsigned long long seed = 3;
    double *xs = tu_positions(w);
    for (int i = 0; i < 3 * n; ++i) xs[i] = x[i] + 0.2 * tu_rand(&seed);
    TU_OK(defsim_world_set_state(w, xs, NULL));
    free(xs);
    defsim_status st = DEFSIM_OK;
    int steps = 0;
    double *xb = NULL, *vb = NULL;
    while (st == DEFSIM_OK && steps < 2000) {
        free(xb); free(vb);
        xb = tu_positions(w);
        vb = tu_velocities(w);
        st = defsim_world_step(w, 0.05);
        ++steps;
    }
    assert_int_equal(st, DEFSIM_ERR_UNSTABLE);
    assert_true(strlen(defsim_world_last_error(w)) > 0);
    double *xa = tu_positions(w), *va = tu_velocities(w);
    assert_memory_equal(xa, xb, 3 * (size_t)n * sizeof *xa);
    assert_memory_equal(va, vb, 3 * (size_t)n * sizeof *va);
    for (int i = 0; i < 3 * n; ++i) assert_true(isfinite(xa[i]) && isfinite(va[i]));
    defsim_stats s = {.size = sizeof s};
    TU_OK(defsim_world_stats(w, &s));
    assert_int_equal(s.failed_steps, 1);
    /* Still usable: back at rest, a small step works. */
    double *rest = calloc(3 * (size_t)n, sizeof *rest);
    TU_OK(defsim_world_set_state(w, x, rest));
    TU_OK(defsim_world_step(w, 1e-6));
    free(rest);
    free(x); free(xb); free(vb); free(xa); free(va);
    defsim_world_destroy(w);
}

static void test_mesh_box(void **state)
{
    (void)state;
    defsim_mesh m;
    memset(&m, 0, sizeof m);
    assert_int_equal(defsim_mesh_box(LO, HI, 1, 1, 1, &m), DEFSIM_ERR_INVALID_ARGUMENT);
    m.size = sizeof m;
    assert_int_equal(defsim_mesh_box(LO, HI, 0, 1, 1, &m), DEFSIM_ERR_INVALID_ARGUMENT);
    assert_int_equal(defsim_mesh_box(HI, LO, 1, 1, 1, &m), DEFSIM_ERR_INVALID_ARGUMENT);
    TU_OK(defsim_mesh_box(LO, HI, 3, 2, 2, &m));
    assert_int_equal(m.vertex_count, 4 * 3 * 3);
    assert_int_equal(m.tet_count, 6 * 12);
    /* Boundary: 2 triangles per boundary cell face. */
    assert_int_equal(m.triangle_count, 2 * 2 * (3 * 2 + 3 * 2 + 2 * 2));
    /* Volumes positive and summing to the box. */
    double vol = 0;
    for (int t = 0; t < m.tet_count; ++t) {
        const int32_t *tt = m.tets + 4 * t;
        double d[9];
        for (int a = 0; a < 3; ++a)
            for (int i = 0; i < 3; ++i)
                d[3 * i + a] = m.positions[3 * tt[a] + i] - m.positions[3 * tt[3] + i];
        double det = d[0] * (d[4] * d[8] - d[5] * d[7]) - d[1] * (d[3] * d[8] - d[5] * d[6]) +
                     d[2] * (d[3] * d[7] - d[4] * d[6]);
        assert_true(det > 0);
        vol += det / 6;
    }
    assert_true(fabs(vol - 1.0) < 1e-12);
    defsim_mesh_free(&m);
    assert_null(m.positions);
    defsim_mesh_free(NULL);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_defaults),
        cmocka_unit_test(test_create_errors),
        cmocka_unit_test(test_masses_and_reorder),
        cmocka_unit_test(test_bad_bodies),
        cmocka_unit_test(test_ids_and_pins),
        cmocka_unit_test(test_state_and_errors),
        cmocka_unit_test(test_unstable_rolls_back),
        cmocka_unit_test(test_mesh_box),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
