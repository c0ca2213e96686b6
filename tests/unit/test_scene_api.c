/* SPDX-License-Identifier: MIT */
/* libdefsim_scene and libdefsim_render (include/defsim/scene.h, render.h): a scene built and
 * stepped through the library, misuse answered with a status (never a crash), VTK frames checked
 * before anything is written and read back, a rendered PNG. Linked against the shared libraries
 * as a host would be. */
#include <defsim/render.h>
#include <defsim/scene.h>

#include "built_backends.h"
#include "mesh_body.h"
#include "vtk.h"

#include <math.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <setjmp.h>
#include <cmocka.h>
#include <unistd.h>

static char scene_path[1024], out_dir[1024];

static void test_scene_lifecycle(void **state)
{
    (void)state;
    char err[512];
    defsim_scene *s = (defsim_scene *)1;
    assert_int_equal(defsim_scene_load(NULL, NULL, 0, &s, err, sizeof err), DEFSIM_ERR_INVALID_ARGUMENT);
    assert_null(s);
    assert_true(strlen(err) > 0);
    assert_int_equal(defsim_scene_load(scene_path, NULL, -1, &s, err, sizeof err), DEFSIM_ERR_INVALID_ARGUMENT);
    const char *null_override[1] = {NULL};
    assert_int_equal(defsim_scene_load(scene_path, null_override, 1, &s, err, sizeof err), DEFSIM_ERR_INVALID_ARGUMENT);
    /* a scene file that cannot be read is an I/O error, as every missing file is (issue 28) */
    assert_int_equal(defsim_scene_load("/nonexistent/scene.json", NULL, 0, &s, err, sizeof err),
                     DEFSIM_ERR_IO);
    assert_non_null(strstr(err, "/nonexistent/scene.json"));
    const char *bad[1] = {"world.backend=3"};
    assert_int_equal(defsim_scene_load(scene_path, bad, 1, &s, err, sizeof err), DEFSIM_ERR_INVALID_ARGUMENT);

    const char *over[1] = {"world.h=5e-4"};
    assert_int_equal(defsim_scene_load(scene_path, over, 1, &s, err, sizeof err), DEFSIM_OK);
    defsim_scene_info info;
    info.size = 8;
    assert_int_equal(defsim_scene_get_info(s, &info), DEFSIM_ERR_INVALID_ARGUMENT);
    info.size = sizeof info;
    assert_int_equal(defsim_scene_get_info(s, &info), DEFSIM_OK);
    assert_string_equal(info.name, "rope");
    assert_true(info.step == 5e-4 && info.body_count == 1 && info.vertex_count > 1);
    defsim_scene_body b;
    b.size = sizeof b;
    assert_int_equal(defsim_scene_get_body(s, 1, &b), DEFSIM_ERR_INVALID_ARGUMENT);
    assert_int_equal(defsim_scene_get_body(s, -1, &b), DEFSIM_ERR_INVALID_ARGUMENT);
    assert_int_equal(defsim_scene_get_body(s, 0, &b), DEFSIM_OK);
    assert_int_equal(b.mesh->vertex_count, info.vertex_count);
    assert_true(b.id.index == 0 && b.id.generation == 0);   /* not built yet */

    defsim_world *w = NULL, *other = NULL;
    assert_int_equal(defsim_scene_step(s, NULL, 1e-3), DEFSIM_ERR_INVALID_ARGUMENT);
    assert_int_equal(defsim_scene_build(s, &w), DEFSIM_OK);
    assert_non_null(w);
    assert_int_equal(defsim_scene_build(s, &other), DEFSIM_ERR_INVALID_ARGUMENT);
    assert_null(other);
    assert_true(strlen(defsim_scene_last_error(s)) > 0);
    assert_int_equal(defsim_scene_get_body(s, 0, &b), DEFSIM_OK);
    assert_int_equal(defsim_body_vertex_count(w, b.id), info.vertex_count);
    defsim_world_def d;
    defsim_world_def_init(&d, sizeof d);
    assert_int_equal(defsim_world_create(&d, &other), DEFSIM_OK);
    assert_int_equal(defsim_scene_step(s, other, info.step), DEFSIM_ERR_INVALID_ARGUMENT);
    defsim_world_destroy(other);
    for (int i = 0; i < 4; ++i) assert_int_equal(defsim_scene_step(s, w, info.step), DEFSIM_OK);
    assert_true(fabs(defsim_world_time(w) - 4 * info.step) < 1e-15);
    assert_int_equal(defsim_scene_step(s, w, -1.0), DEFSIM_ERR_INVALID_ARGUMENT);
    assert_true(fabs(defsim_world_time(w) - 4 * info.step) < 1e-15);   /* unchanged */
    defsim_scene_free(s);          /* the world stays the caller's */
    assert_int_equal(defsim_world_step(w, 1e-4), DEFSIM_OK);
    defsim_world_destroy(w);
    defsim_scene_free(NULL);
}

/* defsim_scene_export and defsim_scene_load_string through the C ABI: the rope scene's world,
 * exported, loaded from the text, stepped beside the original: the same bits every step. */
static void test_export_round_trip(void **state)
{
    (void)state;
    char err[1024];
    defsim_scene *s = NULL, *s2 = NULL;
    defsim_world *w = NULL, *w2 = NULL;
    assert_int_equal(defsim_scene_load(scene_path, NULL, 0, &s, err, sizeof err), DEFSIM_OK);
    assert_int_equal(defsim_scene_build(s, &w), DEFSIM_OK);
    char *json = (char *)1;
    size_t len = 1;
    assert_int_equal(defsim_scene_export(NULL, NULL, 1e-3, 1.0, &json, &len, err, sizeof err),
                     DEFSIM_ERR_INVALID_ARGUMENT);
    assert_null(json);
    assert_int_equal(defsim_scene_export(w, NULL, -1.0, 1.0, &json, &len, err, sizeof err),
                     DEFSIM_ERR_INVALID_ARGUMENT);   /* no scene: h is needed */
    assert_int_equal(defsim_scene_export(w, s, 0.0, 0.0, &json, &len, err, sizeof err), DEFSIM_OK);
    assert_non_null(json);
    assert_int_equal(strlen(json), len);
    assert_non_null(strstr(json, "\"inline\""));
    assert_int_equal(defsim_scene_load_string(NULL, 0, NULL, NULL, NULL, 0, &s2, err, sizeof err),
                     DEFSIM_ERR_INVALID_ARGUMENT);
    assert_int_equal(defsim_scene_load_string("{\"world\": 3}", 13, "x.json", NULL, NULL, 0, &s2,
                                              err, sizeof err), DEFSIM_ERR_INVALID_ARGUMENT);
    assert_null(s2);
    assert_non_null(strstr(err, "x.json:1:"));
    assert_int_equal(defsim_scene_load_string(json, len, NULL, NULL, NULL, 0, &s2, err, sizeof err),
                     DEFSIM_OK);
    defsim_scene_string_free(json);
    defsim_scene_string_free(NULL);
    assert_int_equal(defsim_scene_build(s2, &w2), DEFSIM_OK);
    defsim_scene_info info;
    info.size = sizeof info;
    assert_int_equal(defsim_scene_get_info(s, &info), DEFSIM_OK);
    const int32_t nv = defsim_world_vertex_count(w);
    assert_int_equal(defsim_world_vertex_count(w2), nv);
    double *a = malloc(6 * (size_t)nv * sizeof *a), *b = malloc(6 * (size_t)nv * sizeof *b);
    assert_non_null(a);
    assert_non_null(b);
    for (int i = 0; i < 20; ++i) {
        assert_int_equal(defsim_scene_step(s, w, info.step), DEFSIM_OK);
        assert_int_equal(defsim_scene_step(s2, w2, info.step), DEFSIM_OK);
        assert_int_equal(defsim_world_get_positions(w, a, nv), DEFSIM_OK);
        assert_int_equal(defsim_world_get_velocities(w, a + 3 * nv, nv), DEFSIM_OK);
        assert_int_equal(defsim_world_get_positions(w2, b, nv), DEFSIM_OK);
        assert_int_equal(defsim_world_get_velocities(w2, b + 3 * nv, nv), DEFSIM_OK);
        assert_memory_equal(a, b, 6 * (size_t)nv * sizeof *a);
    }
    /* the borrowed state view is the world's own array */
    const double *x = NULL;
    int32_t n = -1;
    assert_int_equal(defsim_world_state_view(w, &x, NULL, &n), DEFSIM_OK);
    assert_int_equal(n, nv);
    assert_memory_equal(x, a, 3 * (size_t)nv * sizeof *a);
    assert_int_equal(defsim_world_step(w, info.step), DEFSIM_OK);
    assert_int_equal(defsim_world_get_positions(w, a, nv), DEFSIM_OK);
    assert_memory_equal(x, a, 3 * (size_t)nv * sizeof *a);   /* stepped in place */
    /* an export of another scene's world is refused */
    assert_int_equal(defsim_scene_export(w2, s, 0.0, 0.0, &json, NULL, err, sizeof err),
                     DEFSIM_ERR_INVALID_ARGUMENT);
    free(a);
    free(b);
    defsim_world_destroy(w);
    defsim_world_destroy(w2);
    defsim_scene_free(s);
    defsim_scene_free(s2);
}

/* A generated box with "quadratic": true (issue 29): quadratic tets (10 per tet, the mid-edge
 * vertices after the lattice's), exported as an inline mesh with "tet_nodes": 10 that loads back
 * to a world stepping with the same bits; a non-boolean value is refused. */
static void test_quadratic_box(void **state)
{
    (void)state;
    static const char json[] =
        "{\"world\": {\"backend\": \"symplectic_euler\", \"h\": 1e-4, \"duration\": 0.01,"
        " \"gravity\": [0, -9.81, 0]}, \"bodies\": [{\"mesh\": {\"type\": \"box\", \"lo\": [0, 0, 0],"
        " \"hi\": [2, 1, 1], \"cells\": [2, 1, 1], \"quadratic\": true}, \"material\":"
        " {\"model\": \"corotated\", \"youngs_modulus\": 1e5}, \"pin\": {\"box\":"
        " {\"lo\": [0, 0, 0], \"hi\": [0, 1, 1]}}}]}";
    char err[1024];
    defsim_scene *s = NULL, *s2 = NULL;
    defsim_world *w = NULL, *w2 = NULL;
    assert_int_equal(defsim_scene_load_string(json, sizeof json - 1, NULL, NULL, NULL, 0, &s, err,
                                              sizeof err), DEFSIM_OK);
    defsim_scene_body b;
    b.size = sizeof b;
    assert_int_equal(defsim_scene_get_body(s, 0, &b), DEFSIM_OK);
    assert_int_equal(b.mesh->tet_nodes, 10);
    assert_int_equal(b.mesh->tet_count, 12);
    assert_int_equal(b.mesh->vertex_count, 5 * 3 * 3);
    assert_int_equal(defsim_scene_build(s, &w), DEFSIM_OK);
    char *out = NULL;
    size_t len = 0;
    assert_int_equal(defsim_scene_export(w, s, 0.0, 0.0, &out, &len, err, sizeof err), DEFSIM_OK);
    assert_non_null(strstr(out, "\"tet_nodes\": 10"));
    assert_int_equal(defsim_scene_load_string(out, len, NULL, NULL, NULL, 0, &s2, err, sizeof err),
                     DEFSIM_OK);
    defsim_scene_string_free(out);
    assert_int_equal(defsim_scene_build(s2, &w2), DEFSIM_OK);
    const int32_t nv = defsim_world_vertex_count(w);
    assert_int_equal(defsim_world_vertex_count(w2), nv);
    double *x = malloc(3 * (size_t)nv * sizeof *x), *y = malloc(3 * (size_t)nv * sizeof *y);
    for (int k = 0; k < 10; ++k) {
        assert_int_equal(defsim_scene_step(s, w, 1e-4), DEFSIM_OK);
        assert_int_equal(defsim_scene_step(s2, w2, 1e-4), DEFSIM_OK);
    }
    assert_int_equal(defsim_world_get_positions(w, x, nv), DEFSIM_OK);
    assert_int_equal(defsim_world_get_positions(w2, y, nv), DEFSIM_OK);
    assert_memory_equal(x, y, 3 * (size_t)nv * sizeof *x);
    free(x);
    free(y);
    defsim_world_destroy(w);
    defsim_world_destroy(w2);
    defsim_scene_free(s);
    defsim_scene_free(s2);
    static const char bad[] = "{\"world\": {\"h\": 1e-3}, \"bodies\": [{\"mesh\": {\"type\": "
                              "\"box\", \"lo\": [0, 0, 0], \"hi\": [1, 1, 1], \"cells\": [1, 1, 1], "
                              "\"quadratic\": 1}}]}";
    assert_int_equal(defsim_scene_load_string(bad, sizeof bad - 1, NULL, NULL, NULL, 0, &s, err,
                                              sizeof err), DEFSIM_ERR_INVALID_ARGUMENT);
}

/* A shell world (docs/shells.md) exported: a cloth sheet of 4 x 4 cells, 0.2 m, with an
 * orthotropic membrane (warp at an angle), warp and weft bending and a diagonal spring, pinned
 * along one edge, stepped 20 times on newton_cholmod and on symplectic_euler; its export writes
 * the body's "shell" object, loads back to a world with the same masses, and steps 20 more to the
 * same bits as the original; the sheet falls meanwhile. */
static void test_shell_export(void **state)
{
    (void)state;
    const char *backends[] = {"newton_cholmod", "symplectic_euler"};
    for (int k = 0; k < 2; ++k) {
        defsim_world_def wd;
        defsim_world_def_init(&wd, sizeof wd);
        wd.backend = backends[k];
        wd.gravity[1] = -9.81;
        wd.num_threads = 1;
        defsim_world *w = NULL, *w2 = NULL;
        if (!built_backend(backends[k])) continue;
        assert_int_equal(defsim_world_create(&wd, &w), DEFSIM_OK);
        defsim_mesh m;
        memset(&m, 0, sizeof m);
        m.size = sizeof m;
        const double o[3] = {0, 0, 0}, u[3] = {0.2, 0, 0}, v[3] = {0, 0, 0.2};
        assert_int_equal(defsim_mesh_cloth(o, u, v, 4, 4, &m), DEFSIM_OK);
        defsim_body_def d = test_shell_body(&m);
        const int32_t diag[2] = {0, 24}, edge[5] = {0, 1, 2, 3, 4};
        d.springs = diag;
        d.spring_count = 1;
        d.material.stiffness = 20.0;
        d.material.mass_damping = 0.2;
        d.shell_membrane = DEFSIM_SHELL_MEMBRANE_ORTHOTROPIC_STVK;
        d.shell_warp_modulus = 2500;
        d.shell_weft_modulus = 900;
        d.shell_shear_modulus = 250;
        d.shell_warp_poisson = 0.3;
        d.shell_warp_direction[2] = 0.4;
        d.shell_areal_density = 0.2;
        d.shell_bending_rigidity = 1e-5;
        d.shell_bending_rigidity_weft = 3e-6;
        if (k == 0) d.shell_strain_limit = 0.02;   /* a 2 % cap (implicit backends only) */
        defsim_body_id id;
        assert_int_equal(defsim_world_add_body(w, &d, &id), DEFSIM_OK);
        assert_int_equal(defsim_body_pin(w, id, edge, 5), DEFSIM_OK);
        double h = 5e-3;
        if (k == 1) {
            assert_int_equal(defsim_world_stable_step(w, &h, NULL), DEFSIM_OK);
            h *= 0.9;
        }
        for (int i = 0; i < 20; ++i) assert_int_equal(defsim_world_step(w, h), DEFSIM_OK);
        char err[1024], *out = NULL;
        size_t len = 0;
        assert_int_equal(defsim_scene_export(w, NULL, h, 1.0, &out, &len, err, sizeof err),
                         DEFSIM_OK);
        assert_non_null(strstr(out, "\"shell\": {\"membrane\": \"orthotropic_stvk\""));
        assert_non_null(strstr(out, "\"bending_rigidity_weft\": 3.0000000000000001e-06"));
        assert_true((strstr(out, "\"strain_limit\": 0.02") != NULL) == (k == 0));
        defsim_scene *s2 = NULL;
        assert_int_equal(defsim_scene_load_string(out, len, NULL, NULL, NULL, 0, &s2, err,
                                                  sizeof err), DEFSIM_OK);
        defsim_scene_string_free(out);
        assert_int_equal(defsim_scene_build(s2, &w2), DEFSIM_OK);
        const int32_t nv = defsim_world_vertex_count(w);
        assert_int_equal(defsim_world_vertex_count(w2), nv);
        const size_t bytes = 3 * (size_t)nv * sizeof(double);
        double *x = malloc(bytes), *y = malloc(bytes), *va = malloc(bytes), *vb = malloc(bytes);
        assert_int_equal(defsim_world_get_masses(w, x, nv), DEFSIM_OK);
        assert_int_equal(defsim_world_get_masses(w2, y, nv), DEFSIM_OK);
        assert_memory_equal(x, y, (size_t)nv * sizeof(double));
        for (int i = 0; i < 20; ++i) {
            assert_int_equal(defsim_world_step(w, h), DEFSIM_OK);
            assert_int_equal(defsim_world_step(w2, h), DEFSIM_OK);
        }
        assert_int_equal(defsim_world_get_positions(w, x, nv), DEFSIM_OK);
        assert_int_equal(defsim_world_get_positions(w2, y, nv), DEFSIM_OK);
        assert_int_equal(defsim_world_get_velocities(w, va, nv), DEFSIM_OK);
        assert_int_equal(defsim_world_get_velocities(w2, vb, nv), DEFSIM_OK);
        assert_memory_equal(x, y, bytes);
        assert_memory_equal(va, vb, bytes);
        printf("  %s: shell export after 20 steps, 20 more with the same bits; far corner "
               "y = %.6f m\n", backends[k], x[3 * 24 + 1]);
        assert_true(x[3 * 24 + 1] < -1e-4);
        free(x); free(y); free(va); free(vb);
        defsim_mesh_free(&m);
        defsim_world_destroy(w);
        defsim_world_destroy(w2);
        defsim_scene_free(s2);
    }
}

static void test_vtk(void **state)
{
    (void)state;
    char path[1200], err[512];
    snprintf(path, sizeof path, "%s/one.vtu", out_dir);
    unlink(path);
    const double x[15] = {0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1, 2, 2, 2};
    const int64_t conn[6] = {0, 1, 2, 3, 3, 4};
    int64_t offsets[2] = {4, 6};
    uint8_t types[2] = {DEFSIM_VTK_TETRA, DEFSIM_VTK_LINE};
    const int32_t body[2] = {0, 1};
    const double vm[2] = {10.0, 0.0};
    defsim_vtk_array arr = {"von_mises", 1, 1, vm};
    /* Misuse: rejected before the file is opened. */
    assert_int_equal(defsim_vtk_write_vtu(path, 5, x, NULL, 2, types, offsets, conn, body, 0.5,
                                          &arr, -1, err, sizeof err), DEFSIM_ERR_INVALID_ARGUMENT);
    types[1] = 7;
    assert_int_equal(defsim_vtk_write_vtu(path, 5, x, NULL, 2, types, offsets, conn, body, 0.5,
                                          &arr, 1, err, sizeof err), DEFSIM_ERR_INVALID_ARGUMENT);
    types[1] = DEFSIM_VTK_TRIANGLE;   /* offsets say 2 vertices */
    assert_int_equal(defsim_vtk_write_vtu(path, 5, x, NULL, 2, types, offsets, conn, body, 0.5,
                                          &arr, 1, err, sizeof err), DEFSIM_ERR_INVALID_ARGUMENT);
    types[1] = DEFSIM_VTK_LINE;
    assert_int_equal(defsim_vtk_write_vtu(path, 4, x, NULL, 2, types, offsets, conn, body, 0.5,
                                          &arr, 1, err, sizeof err), DEFSIM_ERR_INVALID_ARGUMENT);
    defsim_vtk_array bad = {"von mises", 1, 1, vm};
    assert_int_equal(defsim_vtk_write_vtu(path, 5, x, NULL, 2, types, offsets, conn, body, 0.5,
                                          &bad, 1, err, sizeof err), DEFSIM_ERR_INVALID_ARGUMENT);
    assert_int_equal(access(path, F_OK), -1);
    /* A frame, read back by the tools' reader. */
    assert_int_equal(defsim_vtk_write_vtu(path, 5, x, NULL, 2, types, offsets, conn, body, 0.5,
                                          &arr, 1, err, sizeof err), DEFSIM_OK);
    vtk_frame f;
    memset(&f, 0, sizeof f);
    assert_int_equal(vtk_read_vtu(path, &f, err, sizeof err), 0);
    assert_int_equal(f.nv, 5);
    assert_true(f.time == 0.5);
    assert_memory_equal(f.x, x, sizeof x);
    assert_int_equal(f.cells.ncells, 2);
    assert_non_null(f.von_mises);
    assert_true(f.von_mises[0] == 10.0);
    vtk_frame_free(&f);
    char dir_missing[1300];
    snprintf(dir_missing, sizeof dir_missing, "%s/no/such/dir/f.vtu", out_dir);
    assert_int_equal(defsim_vtk_write_vtu(dir_missing, 5, x, NULL, 2, types, offsets, conn, NULL,
                                          0.0, NULL, 0, err, sizeof err), DEFSIM_ERR_IO);
    /* A series. */
    const char *files[2] = {"one.vtu", "two\".vtu"};
    const double times[2] = {0.5, 1.0};
    char pvd[1200];
    snprintf(pvd, sizeof pvd, "%s/s.pvd", out_dir);
    assert_int_equal(defsim_vtk_write_pvd(pvd, 2, times, files, err, sizeof err), DEFSIM_ERR_INVALID_ARGUMENT);
    assert_int_equal(defsim_vtk_write_pvd(pvd, 1, times, files, err, sizeof err), DEFSIM_OK);
    char **names = NULL;
    double *t = NULL;
    assert_int_equal(vtk_read_pvd(pvd, &names, &t, err, sizeof err), 1);
    assert_string_equal(names[0], "one.vtu");
    assert_true(t[0] == 0.5);
    free(names[0]); free(names); free(t);
}

/* A world holding one StVK tet at rest positions x (4 vertices) with vertex `pinned` pinned;
 * its body's id in *b. The caller destroys the world. */
static defsim_world *pinned_tet_world(const double x[12], int32_t pinned, defsim_body_id *b)
{
    defsim_world_def wd;
    defsim_world_def_init(&wd, sizeof wd);
    defsim_world *w = NULL;
    assert_int_equal(defsim_world_create(&wd, &w), DEFSIM_OK);
    const int32_t tet[4] = {0, 1, 2, 3};
    defsim_body_def bd;
    defsim_body_def_init(&bd, sizeof bd);
    bd.rest_positions = x;
    bd.vertex_count = 4;
    bd.tets = tet;
    bd.tet_count = 1;
    defsim_material_init(&bd.material, sizeof bd.material, DEFSIM_MODEL_STVK);
    assert_int_equal(defsim_world_add_body(w, &bd, b), DEFSIM_OK);
    assert_int_equal(defsim_body_pin(w, *b, &pinned, 1), DEFSIM_OK);
    return w;
}

/* defsim_vtk_write_world: a tet with a pinned vertex above a plane and a turned capsule; misuse
 * answered before anything is written; the bodies' frame, the colliders' and the .vtm. */
static void test_vtk_world(void **state)
{
    (void)state;
    char path[1200], err[512];
    const double x[12] = {0, 1, 0, 1, 1, 0, 0, 2, 0, 0, 1, 1};
    defsim_body_id b;
    defsim_world *w = pinned_tet_world(x, 2, &b);
    defsim_collider_def cd;
    defsim_collider_def_init(&cd, sizeof cd);
    assert_int_equal(defsim_world_add_collider(w, &cd, NULL), DEFSIM_OK);
    cd.shape = DEFSIM_SHAPE_CAPSULE;
    cd.position[0] = 3.0;
    cd.rotation[0] = cd.rotation[3] = sqrt(0.5);   /* 90 degrees about z: the axis along x */
    assert_int_equal(defsim_world_add_collider(w, &cd, NULL), DEFSIM_OK);
    assert_int_equal(defsim_world_step(w, 1e-3), DEFSIM_OK);

    const uint8_t types[1] = {DEFSIM_VTK_TETRA};
    const int64_t offsets[1] = {4}, conn[4] = {0, 1, 2, 3};
    int32_t body[1] = {0};
    defsim_vtk_frame_def fd;
    defsim_vtk_frame_def_init(&fd, sizeof fd);
    assert_int_equal(fd.fields, DEFSIM_VTK_ALL);
    fd.cell_count = 1;
    fd.types = types;
    fd.offsets = offsets;
    fd.conn = conn;
    fd.body = body;
    fd.reference = x;
    double plane[4] = {0};
    int32_t vtm = -1;
    snprintf(path, sizeof path, "%s/w.vtk", out_dir);
    assert_int_equal(defsim_vtk_write_world(path, w, &fd, 0.0, plane, &vtm, err, sizeof err),
                     DEFSIM_ERR_INVALID_ARGUMENT);
    assert_int_equal(vtm, 0);
    snprintf(path, sizeof path, "%s/w.vtu", out_dir);
    remove(path);   /* of an earlier run */
    assert_int_equal(defsim_vtk_write_world(NULL, w, &fd, 0.0, NULL, NULL, err, sizeof err),
                     DEFSIM_ERR_INVALID_ARGUMENT);
    assert_int_equal(defsim_vtk_write_world(path, NULL, &fd, 0.0, NULL, NULL, err, sizeof err),
                     DEFSIM_ERR_INVALID_ARGUMENT);
    body[0] = 1;   /* no such body */
    assert_int_equal(defsim_vtk_write_world(path, w, &fd, 0.0, NULL, NULL, err, sizeof err),
                     DEFSIM_ERR_INVALID_ARGUMENT);
    body[0] = 0;
    const int64_t out_of_range[4] = {0, 1, 2, 4};
    fd.conn = out_of_range;
    assert_int_equal(defsim_vtk_write_world(path, w, &fd, 0.0, NULL, NULL, err, sizeof err),
                     DEFSIM_ERR_INVALID_ARGUMENT);
    fd.conn = conn;
    fd.size = 8;
    assert_int_equal(defsim_vtk_write_world(path, w, &fd, 0.0, NULL, NULL, err, sizeof err),
                     DEFSIM_ERR_INVALID_ARGUMENT);
    fd.size = sizeof fd;
    assert_true(access(path, F_OK) != 0);   /* nothing written so far */
    assert_int_equal(defsim_vtk_write_world(path, w, &fd, 0.5, plane, &vtm, err, sizeof err),
                     DEFSIM_OK);
    assert_int_equal(vtm, 1);
    assert_true(plane[3] > 0.0);   /* sized to the scene: bodies and the capsule */
    vtk_frame f;
    assert_int_equal(vtk_read_vtu(path, &f, err, sizeof err), 0);
    assert_int_equal(f.nv, 4);
    assert_non_null(f.pinned);
    assert_true(f.pinned[2] == 1 && f.pinned[0] == 0);
    assert_non_null(f.displacement);
    assert_true(f.time == 0.5);
    vtk_frame_free(&f);
    char vtm_path[1200], text[2048];
    snprintf(vtm_path, sizeof vtm_path, "%s/w.vtm", out_dir);
    FILE *in = fopen(vtm_path, "r");
    assert_non_null(in);
    const size_t n = fread(text, 1, sizeof text - 1, in);
    fclose(in);
    text[n] = '\0';
    assert_non_null(strstr(text, "name=\"bodies\" file=\"w.vtu\""));
    assert_non_null(strstr(text, "name=\"colliders\" file=\"w_colliders.vtu\""));
    snprintf(path, sizeof path, "%s/w_colliders.vtu", out_dir);
    assert_true(access(path, R_OK) == 0);
    /* Without DEFSIM_VTK_COLLIDERS: the bodies alone. */
    fd.fields = DEFSIM_VTK_STRESS;
    snprintf(path, sizeof path, "%s/v.vtu", out_dir);
    assert_int_equal(defsim_vtk_write_world(path, w, &fd, 0.5, NULL, &vtm, err, sizeof err),
                     DEFSIM_OK);
    assert_int_equal(vtm, 0);
    snprintf(path, sizeof path, "%s/v.vtm", out_dir);
    assert_true(access(path, F_OK) != 0);
    defsim_world_destroy(w);
}

static void test_render(void **state)
{
    (void)state;
#ifdef DEFSIM_TEST_RENDER
    char path[1200], err[512];
    snprintf(path, sizeof path, "%s/r.png", out_dir);
    const double x[12] = {0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1};
    const int32_t tris[12] = {0, 2, 1, 0, 1, 3, 0, 3, 2, 1, 2, 3};
    const int32_t bad_tris[3] = {0, 1, 4};
    const double g[3] = {0, -9.81, 0};
    defsim_render_part p = {tris, 4, NULL, 0, {-1.0f, 0, 0}, 0};
    assert_int_equal(defsim_render_png(path, 8, 8, 4, x, &p, 1, g, err, sizeof err), DEFSIM_ERR_INVALID_ARGUMENT);
    defsim_render_part q = {bad_tris, 1, NULL, 0, {1, 0, 0}, 0};
    assert_int_equal(defsim_render_png(path, 64, 48, 4, x, &q, 1, g, err, sizeof err), DEFSIM_ERR_INVALID_ARGUMENT);
    const defsim_status st = defsim_render_png(path, 64, 48, 4, x, &p, 1, g, err, sizeof err);
    if (st == DEFSIM_ERR_BACKEND_UNAVAILABLE) {
        print_message("no OSMesa context here: %s\n", err);
        skip();
    }
    assert_int_equal(st, DEFSIM_OK);
    FILE *f = fopen(path, "rb");
    assert_non_null(f);
    unsigned char head[24];
    assert_int_equal(fread(head, 1, sizeof head, f), sizeof head);
    fclose(f);
    assert_memory_equal(head, "\x89PNG\r\n\x1a\n", 8);
    assert_int_equal((head[16] << 24) | (head[17] << 16) | (head[18] << 8) | head[19], 64);
    assert_int_equal((head[20] << 24) | (head[21] << 16) | (head[22] << 8) | head[23], 48);

    /* defsim_render_world_png: a pinned tet above a plane, coloured by stress, with arrows;
     * misuse refused before anything is drawn. */
    defsim_body_id b;
    defsim_world *w = pinned_tet_world(x, 0, &b);
    defsim_collider_def cd;
    defsim_collider_def_init(&cd, sizeof cd);
    cd.position[1] = -0.5;
    assert_int_equal(defsim_world_add_collider(w, &cd, NULL), DEFSIM_OK);
    assert_int_equal(defsim_world_step(w, 1e-3), DEFSIM_OK);
    const uint8_t types[1] = {DEFSIM_VTK_TETRA};
    const int64_t offsets[1] = {4}, conn[4] = {0, 1, 2, 3};
    const int32_t body[1] = {0};
    defsim_render_world_def rd;
    defsim_render_world_def_init(&rd, sizeof rd);
    assert_true(rd.width == 640 && rd.pins == 1 && rd.colliders == 1 && rd.gravity[1] == -9.81);
    rd.width = 64;
    rd.height = 48;
    rd.cell_count = 1;
    rd.types = types;
    rd.offsets = offsets;
    rd.conn = conn;
    rd.body = body;
    rd.color = DEFSIM_RENDER_DISPLACEMENT;   /* without a reference */
    assert_int_equal(defsim_render_world_png(path, w, &rd, err, sizeof err), DEFSIM_ERR_INVALID_ARGUMENT);
    rd.color = 7;
    assert_int_equal(defsim_render_world_png(path, w, &rd, err, sizeof err), DEFSIM_ERR_INVALID_ARGUMENT);
    rd.color = DEFSIM_RENDER_STRESS;
    rd.size = 4;
    assert_int_equal(defsim_render_world_png(path, w, &rd, err, sizeof err), DEFSIM_ERR_INVALID_ARGUMENT);
    rd.size = sizeof rd;
    assert_int_equal(defsim_render_world_png(path, NULL, &rd, err, sizeof err), DEFSIM_ERR_INVALID_ARGUMENT);
    const int64_t bad_conn[4] = {0, 1, 2, 9};
    rd.conn = bad_conn;
    assert_int_equal(defsim_render_world_png(path, w, &rd, err, sizeof err), DEFSIM_ERR_INVALID_ARGUMENT);
    rd.conn = conn;
    rd.contact_arrows = 1;
    remove(path);
    assert_int_equal(defsim_render_world_png(path, w, &rd, err, sizeof err), DEFSIM_OK);
    f = fopen(path, "rb");
    assert_non_null(f);
    assert_int_equal(fread(head, 1, sizeof head, f), sizeof head);
    fclose(f);
    assert_memory_equal(head, "\x89PNG\r\n\x1a\n", 8);
    assert_int_equal((head[16] << 24) | (head[17] << 16) | (head[18] << 8) | head[19], 64);
    defsim_world_destroy(w);
#else
    skip();
#endif
}

int main(int argc, char **argv)
{
    if (argc != 3) {
        fprintf(stderr, "usage: test_scene_api SCENE.json OUT_DIR\n");
        return 2;
    }
    snprintf(scene_path, sizeof scene_path, "%s", argv[1]);
    snprintf(out_dir, sizeof out_dir, "%s", argv[2]);
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_scene_lifecycle),
        cmocka_unit_test(test_export_round_trip),
        cmocka_unit_test(test_quadratic_box),
        cmocka_unit_test(test_shell_export),
        cmocka_unit_test(test_vtk),
        cmocka_unit_test(test_vtk_world),
        cmocka_unit_test(test_render),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
