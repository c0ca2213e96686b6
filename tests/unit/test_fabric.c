/* SPDX-License-Identifier: MIT */
/*
 * Shells by name and from OBJ rest shapes (docs/shells.md, "Fabrics by name" and "Rest shapes
 * from OBJ"):
 *   - the table of measured fabrics gives exactly the numbers that docs/shells.md lists (copied
 *     here), defsim_body_def_set_fabric puts them into a body def, and the body's total mass is
 *     the fabric's areal density times its area; unknown names and bad arguments are refused and
 *     leave the def as it was;
 *   - the garment panels of tests/shells load from OBJ with their counts, are at rest in their
 *     rest shape (no force: the flat gore, and the same gore sewn onto its cone, whose hinges have
 *     non-zero rest angles), and the gore flattened is not; bad OBJ files are refused.
 */
#include "test_util.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#ifndef DEFSIM_SHELLS_DIR
#error "DEFSIM_SHELLS_DIR (tests/shells) must be defined"
#endif

typedef struct expected_fabric {
    const char *name;
    double rho, warp, weft, shear, nu12, d_warp, d_weft;
} expected_fabric;

/* docs/shells.md's table. */
static const expected_fabric TABLE[] = {
    {"denim", 0.324, 410.5, 2026.8, 53.387, 0.01009, 2.424e-5, 1.605e-5},
    {"cotton_polyester", 0.220, 4033.0, 4069.9, 104.76, 0.004506, 3.135e-5, 3.135e-5},
    {"polyester_tablecloth", 0.128, 4004.2, 4055.0, 19.189, 0.0001705, 7.821e-6, 1.293e-5},
    {"polyester_blanket", 0.228, 211.17, 341.26, 30.250, 0.4331, 1.494e-5, 2.927e-5},
    {"polyester_jacket", 0.113, 51.643, 205.56, 14.315, 0.3172, 5.086e-6, 3.573e-6},
    {"swimwear_knit", 0.204, 95.049, 207.28, 60.774, 0.06533, 1.275e-5, 1.506e-5},
};

static void test_table(void **state)
{
    (void)state;
    const int n = (int)(sizeof TABLE / sizeof TABLE[0]);
    assert_int_equal(defsim_fabric_count(), n);
    for (int i = 0; i < n; ++i) {
        defsim_fabric f, g;
        memset(&f, 0, sizeof f);
        f.size = sizeof f;
        g = f;
        TU_OK(defsim_fabric_get(i, &f));
        assert_string_equal(f.name, TABLE[i].name);
        assert_non_null(f.description);
        assert_true(f.areal_density == TABLE[i].rho);
        assert_true(f.warp_modulus == TABLE[i].warp);
        assert_true(f.weft_modulus == TABLE[i].weft);
        assert_true(f.shear_modulus == TABLE[i].shear);
        assert_true(f.warp_poisson == TABLE[i].nu12);
        assert_true(f.bending_rigidity == TABLE[i].d_warp);
        assert_true(f.bending_rigidity_weft == TABLE[i].d_weft);
        TU_OK(defsim_fabric_find(TABLE[i].name, &g));
        assert_memory_equal(&f, &g, sizeof f);
        /* Into a body def: every shell field it sets, the rest as they were. */
        defsim_body_def d, before;
        defsim_body_def_init(&d, sizeof d);
        d.shell_warp_direction[1] = 2.0;
        before = d;
        TU_OK(defsim_body_def_set_fabric(&d, TABLE[i].name));
        assert_int_equal(d.shell_membrane, DEFSIM_SHELL_MEMBRANE_ORTHOTROPIC_STVK);
        assert_true(d.shell_areal_density == TABLE[i].rho);
        assert_true(d.shell_warp_modulus == TABLE[i].warp);
        assert_true(d.shell_weft_modulus == TABLE[i].weft);
        assert_true(d.shell_shear_modulus == TABLE[i].shear);
        assert_true(d.shell_warp_poisson == TABLE[i].nu12);
        assert_true(d.shell_bending_rigidity == TABLE[i].d_warp);
        assert_true(d.shell_bending_rigidity_weft == TABLE[i].d_weft);
        d.shell_membrane = before.shell_membrane;
        d.shell_areal_density = before.shell_areal_density;
        d.shell_warp_modulus = before.shell_warp_modulus;
        d.shell_weft_modulus = before.shell_weft_modulus;
        d.shell_shear_modulus = before.shell_shear_modulus;
        d.shell_warp_poisson = before.shell_warp_poisson;
        d.shell_bending_rigidity = before.shell_bending_rigidity;
        d.shell_bending_rigidity_weft = before.shell_bending_rigidity_weft;
        assert_memory_equal(&d, &before, sizeof d);
    }
}

/* Each fabric makes a valid body whose mass is its areal density times the sheet's area. */
static void test_bodies(void **state)
{
    (void)state;
    defsim_mesh m;
    memset(&m, 0, sizeof m);
    m.size = sizeof m;
    const double o[3] = {0, 0, 0}, u[3] = {0.4, 0, 0}, v[3] = {0, 0, 0.3};
    TU_OK(defsim_mesh_cloth(o, u, v, 8, 6, &m));
    double *mass = malloc((size_t)m.vertex_count * sizeof *mass);
    assert_non_null(mass);
    for (int i = 0; i < defsim_fabric_count(); ++i) {
        defsim_fabric f;
        f.size = sizeof f;
        TU_OK(defsim_fabric_get(i, &f));
        defsim_world *w = tu_world("symplectic_euler", -9.81, 1);
        defsim_body_def d;
        defsim_body_def_init(&d, sizeof d);
        d.rest_positions = m.positions;
        d.vertex_count = m.vertex_count;
        d.triangles = m.triangles;
        d.triangle_count = m.triangle_count;
        TU_OK(defsim_body_def_set_fabric(&d, f.name));
        TU_OK(defsim_world_add_body(w, &d, NULL));
        TU_OK(defsim_world_get_masses(w, mass, m.vertex_count));
        double total = 0.0;
        for (int k = 0; k < m.vertex_count; ++k) total += mass[k];
        assert_true(fabs(total - f.areal_density * 0.12) < 1e-12);
        defsim_world_destroy(w);
    }
    free(mass);
    defsim_mesh_free(&m);
}

static void test_refused(void **state)
{
    (void)state;
    defsim_fabric f;
    memset(&f, 0, sizeof f);
    f.size = sizeof f;
    assert_int_equal(defsim_fabric_find("velvet", &f), DEFSIM_ERR_INVALID_MATERIAL);
    print_message("    %s\n", defsim_last_error());
    assert_int_equal(defsim_fabric_find("Denim", &f), DEFSIM_ERR_INVALID_MATERIAL);
    assert_int_equal(defsim_fabric_find(NULL, &f), DEFSIM_ERR_INVALID_MATERIAL);
    assert_int_equal(defsim_fabric_find("denim", NULL), DEFSIM_ERR_INVALID_ARGUMENT);
    assert_int_equal(defsim_fabric_get(-1, &f), DEFSIM_ERR_INVALID_ARGUMENT);
    assert_int_equal(defsim_fabric_get(defsim_fabric_count(), &f), DEFSIM_ERR_INVALID_ARGUMENT);
    defsim_fabric small = f;
    small.size = 4;
    assert_int_equal(defsim_fabric_get(0, &small), DEFSIM_ERR_INVALID_ARGUMENT);
    assert_null(f.name);   /* nothing was written */
    defsim_body_def d, before;
    defsim_body_def_init(&d, sizeof d);
    before = d;
    assert_int_equal(defsim_body_def_set_fabric(&d, "velvet"), DEFSIM_ERR_INVALID_MATERIAL);
    assert_int_equal(defsim_body_def_set_fabric(&d, NULL), DEFSIM_ERR_INVALID_MATERIAL);
    assert_memory_equal(&d, &before, sizeof d);
    d.size = 0;
    assert_int_equal(defsim_body_def_set_fabric(&d, "denim"), DEFSIM_ERR_INVALID_ARGUMENT);
    assert_int_equal(defsim_body_def_set_fabric(NULL, "denim"), DEFSIM_ERR_INVALID_ARGUMENT);
}

/* A shell body of an OBJ mesh, denim with the warp along x; returns the world. */
static defsim_world *obj_world(const defsim_mesh *m, defsim_status *st)
{
    defsim_world *w = tu_world("symplectic_euler", 0.0, 1);
    defsim_body_def d;
    defsim_body_def_init(&d, sizeof d);
    d.rest_positions = m->positions;
    d.vertex_count = m->vertex_count;
    d.triangles = m->triangles;
    d.triangle_count = m->triangle_count;
    TU_OK(defsim_body_def_set_fabric(&d, "denim"));
    *st = defsim_world_add_body(w, &d, NULL);
    return w;
}

static double max_abs(const double *f, int n)
{
    double mx = 0.0;
    for (int i = 0; i < n; ++i) mx = fmax(mx, fabs(f[i]));
    return mx;
}

static void test_obj_panels(void **state)
{
    (void)state;
    defsim_mesh flat, gore;
    memset(&flat, 0, sizeof flat);
    flat.size = sizeof flat;
    gore = flat;
    TU_OK(defsim_mesh_load(DEFSIM_SHELLS_DIR "/skirt_panel.obj", &flat));
    TU_OK(defsim_mesh_load(DEFSIM_SHELLS_DIR "/skirt_gore.obj", &gore));
    /* 7 x 13 vertices, 6 x 12 quads of two triangles. */
    assert_int_equal(flat.vertex_count, 91);
    assert_int_equal(flat.triangle_count, 144);
    assert_int_equal(gore.vertex_count, 91);
    assert_int_equal(gore.triangle_count, 144);
    assert_int_equal(flat.tet_count, 0);
    const int n = flat.vertex_count;
    double *f = malloc(3 * (size_t)n * sizeof *f);
    assert_non_null(f);
    defsim_status st;
    defsim_world *wf = obj_world(&flat, &st);
    TU_OK(st);
    defsim_world *wg = obj_world(&gore, &st);
    TU_OK(st);
    /* At rest in the rest shape: the flat gore, and the sewn gore with its rest angles. */
    TU_OK(defsim_world_forces(wf, flat.positions, f));
    const double rest_flat = max_abs(f, 3 * n);
    TU_OK(defsim_world_forces(wg, gore.positions, f));
    const double rest_gore = max_abs(f, 3 * n);
    defsim_energy e;
    TU_OK(defsim_world_energy(wg, &e));
    const double e_rest = e.elastic;
    /* The sewn gore laid flat: its hinges leave their rest angles (and its chords stretch). */
    TU_OK(defsim_world_forces(wg, flat.positions, f));
    const double flattened = max_abs(f, 3 * n);
    TU_OK(defsim_world_set_state(wg, flat.positions, NULL));
    TU_OK(defsim_world_energy(wg, &e));
    print_message("    skirt gore: max |f| at rest %.3g N (flat), %.3g N (sewn); laid flat %.3g N, "
                  "%.3g J\n", rest_flat, rest_gore, flattened, e.elastic);
    assert_true(rest_flat < 1e-10);
    assert_true(rest_gore < 1e-10);
    assert_true(fabs(e_rest) < 1e-14);
    assert_true(flattened > 1e-3);
    assert_true(e.elastic > 1e-6);
    defsim_world_destroy(wf);
    defsim_world_destroy(wg);
    free(f);
    defsim_mesh_free(&flat);
    defsim_mesh_free(&gore);
}

static void test_obj_refused(void **state)
{
    (void)state;
    defsim_mesh m;
    memset(&m, 0, sizeof m);
    m.size = sizeof m;
    /* A face on a vertex the file does not have, a malformed line, no faces at all. */
    assert_int_equal(defsim_mesh_load(tu_write_file("undef.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\n"
                                                    "f 1 2 4\n"), &m), DEFSIM_ERR_INVALID_MESH);
    print_message("    %s\n", defsim_last_error());
    assert_int_equal(defsim_mesh_load(tu_write_file("bad.obj", "v 0 0 zero\nf 1 2 3\n"), &m),
                     DEFSIM_ERR_IO);
    print_message("    %s\n", defsim_last_error());
    assert_int_equal(defsim_mesh_load(tu_write_file("empty.obj", "v 0 0 0\n"), &m),
                     DEFSIM_ERR_INVALID_MESH);
    assert_int_equal(defsim_mesh_load(DEFSIM_SHELLS_DIR "/no_such_panel.obj", &m), DEFSIM_ERR_IO);
    assert_null(m.positions);
    /* It loads, but is no shell: an edge of three triangles, a zero-area triangle. */
    defsim_status st;
    TU_OK(defsim_mesh_load(tu_write_file("fin.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 -1 0\n"
                                         "v 0 0 1\nf 1 2 3\nf 2 1 4\nf 1 2 5\n"), &m));
    defsim_world *w = obj_world(&m, &st);
    assert_int_equal(st, DEFSIM_ERR_INVALID_MESH);
    print_message("    %s\n", defsim_world_last_error(w));
    assert_int_equal(defsim_world_vertex_count(w), 0);
    defsim_world_destroy(w);
    defsim_mesh_free(&m);
    TU_OK(defsim_mesh_load(tu_write_file("flat.obj", "v 0 0 0\nv 1 0 0\nv 2 0 0\nv 0 1 0\n"
                                         "f 1 2 3\nf 1 2 4\n"), &m));
    w = obj_world(&m, &st);
    assert_int_equal(st, DEFSIM_ERR_INVALID_MESH);
    print_message("    %s\n", defsim_world_last_error(w));
    defsim_world_destroy(w);
    defsim_mesh_free(&m);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_table),
        cmocka_unit_test(test_bodies),
        cmocka_unit_test(test_refused),
        cmocka_unit_test(test_obj_panels),
        cmocka_unit_test_setup_teardown(test_obj_refused, tu_tmpdir_setup, tu_tmpdir_teardown),
    };
    return tu_exit(cmocka_run_group_tests_name("fabric", tests, NULL, NULL));
}
