/* SPDX-License-Identifier: MIT */
/* Scene files (tools/scene.c): the shipped scenes, overrides, and errors that name file:line. */
#include "test_util.h"

#include "collider.h"
#include "scene.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

/* The line in "PATH:LINE:COL: ..." where PATH is `path` (0 if none). */
static int error_line(const scene *s, const char *path)
{
    const char *p = strstr(s->error, path);
    if (!p || p[strlen(path)] != ':') return 0;
    return atoi(p + strlen(path) + 1);
}

static void shipped(const char *name, scene *s)
{
    char path[512];
    snprintf(path, sizeof path, "%s/%s.json", DEFSIM_SCENES_DIR, name);
    if (scene_load(s, path, NULL, 0)) fail_msg("%s", s->error);
}

static void test_shipped_scenes(void **state)
{
    (void)state;
    static const char *names[] = {"cantilever", "cloth", "rope", "stiff_block", "squash",
                                  "driven_circle", "cantilever_stress", "ground_box_sphere",
                                  "cloth_sphere", "steps", "pushed_beam"};
    for (int i = 0; i < 11; ++i) {
        scene s;
        shipped(names[i], &s);
        defsim_world *w = NULL;
        if (scene_build(&s, &w) != DEFSIM_OK) fail_msg("%s", s.error);
        assert_int_equal(defsim_world_vertex_count(w), s.vertex_count);
        TU_OK(defsim_world_step(w, s.h));
        defsim_world_destroy(w);
        scene_free(&s);
    }
    /* The cantilever: 12 x 4 x 4 cells, clamped face x = 0, 40 steps per frame at 30 fps. */
    scene s;
    shipped("cantilever", &s);
    assert_int_equal(s.frame_steps, 40);
    assert_int_equal(s.frames, 60);
    assert_int_equal(s.bodies[0].mesh.vertex_count, 13 * 5 * 5);
    assert_int_equal(s.bodies[0].mesh.tet_count, 6 * 12 * 4 * 4);
    assert_int_equal(s.bodies[0].npins, 5 * 5);
    for (int i = 0; i < s.bodies[0].npins; ++i)
        assert_true(s.bodies[0].mesh.positions[3 * s.bodies[0].pins[i]] == 0.0);
    const double *p = s.bodies[0].mesh.positions + 3 * s.bodies[0].probe;
    assert_true(p[0] == 3.0 && p[1] == 1.0 && p[2] == 1.0);
    assert_true(s.bodies[0].material.model == DEFSIM_MODEL_STABLE_NEOHOOKEAN);
    assert_true(s.bodies[0].material.youngs_modulus == 1e6);
    scene_free(&s);

    /* Cloth stiffnesses by spring kind; total mass spread over the vertices. */
    shipped("cloth", &s);
    const scene_body *c = &s.bodies[0];
    const int nu = 20, nv = 20, nstruct = nu * (nv + 1) + (nu + 1) * nv, nshear = 2 * nu * nv;
    assert_non_null(c->spring_k);
    assert_true(c->spring_k[0] == 400.0 && c->spring_k[nstruct - 1] == 400.0);
    assert_true(c->spring_k[nstruct] == 100.0 && c->spring_k[nstruct + nshear - 1] == 100.0);
    assert_true(c->spring_k[nstruct + nshear] == 10.0 && c->spring_k[c->mesh.spring_count - 1] == 10.0);
    assert_true(fabs(c->material.vertex_mass * c->mesh.vertex_count - 0.2) < 1e-15);
    assert_int_equal(c->line_count, 0);
    scene_free(&s);

    /* Rope: links are drawn, bending springs are not. */
    shipped("rope", &s);
    assert_int_equal(s.bodies[0].line_count, 40);
    assert_int_equal(s.bodies[0].mesh.spring_count, 40 + 39);
    scene_free(&s);

    /* Squash: initial = mirror and half height about the centre (y = 0.5), so every rest tet
     * is inverted at the start. */
    shipped("squash", &s);
    const scene_body *b = &s.bodies[0];
    assert_non_null(b->initial);
    for (int i = 0; i < b->mesh.vertex_count; ++i) {
        const double y = b->mesh.positions[3 * i + 1], yi = b->initial[3 * i + 1];
        assert_true(fabs(yi - (0.5 - 0.5 * (y - 0.5))) < 1e-15);
        assert_true(b->initial[3 * i] == b->mesh.positions[3 * i]);
    }
    scene_free(&s);
}

static void test_overrides(void **state)
{
    (void)state;
    char path[512];
    snprintf(path, sizeof path, "%s/cantilever.json", DEFSIM_SCENES_DIR);
    const char *sets[] = {"world.gravity=[0, 9.81, 0]", "bodies.0.material.youngs_modulus=1e4",
                          "world.backend=explicit_euler", "output.width=320"};
    scene s;
    if (scene_load(&s, path, sets, 4)) fail_msg("%s", s.error);
    assert_true(s.def.gravity[1] == 9.81);
    assert_true(s.bodies[0].material.youngs_modulus == 1e4);
    assert_string_equal(s.backend, "explicit_euler");
    assert_int_equal(s.width, 320);
    scene_free(&s);
    const char *bad[] = {"bodies.5.name=x"};
    assert_int_equal(scene_load(&s, path, bad, 1), -1);
    const char *bad2[] = {"world.h=-1"};
    assert_int_equal(scene_load(&s, path, bad2, 1), -1);
}

/* A minimal valid scene with one line replaced. */
static const char *scene_text(const char *line3, const char *line6)
{
    static char buf[2048];
    snprintf(buf, sizeof buf,
             "{\n"
             "  \"world\": {\"h\": 1e-3, \"duration\": 0.01,\n"
             "  %s},\n"
             "  \"bodies\": [\n"
             "    {\"mesh\": {\"type\": \"box\", \"lo\": [0,0,0], \"hi\": [1,1,1], \"cells\": [1,1,1]},\n"
             "     %s}\n"
             "  ]\n"
             "}\n", line3, line6);
    return buf;
}

/* Writes `text` to tu_tmpdir/name and loads it, which must succeed. */
static void load_ok(const char *name, const char *text, scene *s)
{
    if (scene_load(s, tu_write_file(name, text), NULL, 0)) fail_msg("%s", s->error);
}

static void expect_line(const char *text, int line)
{
    const char *path = tu_write_file("s.json", text);
    scene s;
    assert_int_equal(scene_load(&s, path, NULL, 0), -1);
    print_message("    %s\n", s.error);
    assert_int_equal(error_line(&s, path), line);
}

static void test_errors(void **state)
{
    (void)state;
    /* The valid base first. */
    const char *path = tu_write_file("ok.json", scene_text("\"threads\": 1", "\"name\": \"b\""));
    scene s;
    if (scene_load(&s, path, NULL, 0)) fail_msg("%s", s.error);
    scene_free(&s);

    expect_line(scene_text("\"thredas\": 1", "\"name\": \"b\""), 3);                 /* typo */
    expect_line(scene_text("\"threads\": -1", "\"name\": \"b\""), 3);                /* range */
    expect_line(scene_text("\"threads\": 1,", "\"name\": \"b\""), 3);                /* syntax */
    expect_line(scene_text("\"gravity\": [0, 1]", "\"name\": \"b\""), 3);            /* shape */
    expect_line(scene_text("\"threads\": 1", "\"material\": {\"youngs_modulus\": 0}"), 6);
    expect_line(scene_text("\"threads\": 1", "\"material\": {\"model\": \"rubber\"}"), 6);
    expect_line(scene_text("\"threads\": 1", "\"pin\": {\"box\": {\"lo\": [5,5,5], \"hi\": [6,6,6]}}"), 6);
    expect_line(scene_text("\"threads\": 1", "\"pin\": [0, 8]"), 6);
    expect_line(scene_text("\"threads\": 1", "\"material\": {\"bending_stiffness\": 1}"), 6);
    expect_line(scene_text("\"fps\": 7", "\"name\": \"b\""), 3);   /* 1 / (fps h) not whole */

    /* A mesh file that does not load: the error names the scene line and the mesh file's line. */
    tu_write_file("bad.obj", "v 0 0 0\nv 1 0 0\nf 1 2 3\n");
    const char *text = "{\"world\": {\"h\": 1e-3, \"duration\": 0.01},\n"
                       " \"bodies\": [{\"mesh\": \"bad.obj\"}]}\n";
    path = tu_write_file("m.json", text);
    assert_int_equal(scene_load(&s, path, NULL, 0), -1);
    print_message("    %s\n", s.error);
    assert_int_equal(error_line(&s, path), 2);
    char obj[300];
    snprintf(obj, sizeof obj, "%s/bad.obj", tu_tmpdir);
    assert_int_equal(error_line(&s, obj), 3);

    /* A backend that does not exist fails when the world is built. */
    path = tu_write_file("b.json", scene_text("\"backend\": \"no_such_backend\"", "\"name\": \"b\""));
    if (scene_load(&s, path, NULL, 0)) fail_msg("%s", s.error);
    defsim_world *w = NULL;
    assert_int_equal(scene_build(&s, &w), DEFSIM_ERR_BACKEND_UNAVAILABLE);
    assert_null(w);
    scene_free(&s);

    /* A missing file. */
    snprintf(obj, sizeof obj, "%s/missing.json", tu_tmpdir);
    assert_int_equal(scene_load(&s, obj, NULL, 0), -1);
}

/* Issue 16: material names in the README's spellings name their model; a misspelt one and a
 * key of the other kind of body (youngs_modulus on a rope, stiffness on tets) are errors at
 * their line, like unknown keys. */
static void test_model_spellings_and_kind_keys(void **state)
{
    (void)state;
    static const struct { const char *name; defsim_model m; } ok[] = {
        {"co-rotated", DEFSIM_MODEL_COROTATED}, {"Corotated", DEFSIM_MODEL_COROTATED},
        {"corotated", DEFSIM_MODEL_COROTATED}, {"co_rotated", DEFSIM_MODEL_COROTATED},
        {"stable neo-Hookean", DEFSIM_MODEL_STABLE_NEOHOOKEAN},
        {"stable-neohookean", DEFSIM_MODEL_STABLE_NEOHOOKEAN},
        {"stable_neohookean", DEFSIM_MODEL_STABLE_NEOHOOKEAN},
        {"neo-Hookean", DEFSIM_MODEL_NEOHOOKEAN}, {"StVK", DEFSIM_MODEL_STVK},
        {"St. Venant-Kirchhoff", DEFSIM_MODEL_STVK}};
    char line6[200];
    for (size_t i = 0; i < sizeof ok / sizeof ok[0]; ++i) {
        snprintf(line6, sizeof line6, "\"material\": {\"model\": \"%s\"}", ok[i].name);
        scene s;
        load_ok("m.json", scene_text("\"threads\": 1", line6), &s);
        assert_int_equal(s.bodies[0].material.model, ok[i].m);
        scene_free(&s);
    }
    expect_line(scene_text("\"threads\": 1", "\"material\": {\"model\": \"co-rotatd\"}"), 6);
    expect_line(scene_text("\"threads\": 1", "\"material\": {\"stiffness\": 100}"), 6);
    /* A rope: spring keys are fine, tet keys are not. */
    const char *rope = "{\n"
                       "  \"world\": {\"h\": 1e-3, \"duration\": 0.01},\n"
                       "  \"bodies\": [\n"
                       "    {\"mesh\": {\"type\": \"rope\", \"a\": [0,0,0], \"b\": [1,0,0], \"segments\": 4},\n"
                       "     \"material\": {\"model\": \"mass-spring\", \"stiffness\": 100,\n"
                       "                  %s}}\n"
                       "  ]\n"
                       "}\n";
    char text[1024];
    snprintf(text, sizeof text, rope, "\"bending_stiffness\": 1");
    scene s;
    load_ok("r.json", text, &s);
    assert_int_equal(s.bodies[0].material.model, DEFSIM_MODEL_SPRING);
    assert_true(s.bodies[0].material.stiffness == 100.0);
    scene_free(&s);
    const char *tet_keys[] = {"\"youngs_modulus\": 1e5", "\"poisson_ratio\": 0.3",
                              "\"density\": 500"};
    for (int i = 0; i < 3; ++i) {
        snprintf(text, sizeof text, rope, tet_keys[i]);
        expect_line(text, 6);
    }
}

/* cJSON takes every byte up to 0x20 as whitespace, the position scanner must too (issue 17: a
 * 0x0C or NUL after '[' or in an object overflowed its table, 0x0B gave an internal error).
 * Each '@' of a template becomes the byte; valid scenes load, invalid ones name the right line. */
static void test_control_bytes_as_whitespace(void **state)
{
    (void)state;
    static const unsigned char bytes[] = {0x00, 0x01, 0x09, 0x0B, 0x0C, 0x1F, 0x20};
    static const struct { const char *line3, *line6; int error_line; } cases[] = {
        {"\"gravity\": [@0, -9.81, 0]", "\"name\": \"b\"", 0},
        {"@\"threads\"@:@1", "\"name\"@:@\"b\"@", 0},
        {"\"threads\": 1", "\"velocity\": [@1,@0,@0@]@, \"name\": \"b\"", 0},
        {"\"threads\": 1", "\"pin\": [@0@, 1, [@]@]", 6},
        {"\"gravity\": [@0, 1]", "\"name\": \"b\"", 3},
        {"\"threads\": 1", "@\"material\":@{@\"youngs_modulus\":@0}", 6},
        {"\"threads\": 1", "\"material\": {\"model\":@\"rubber\"@}", 6},
    };
    for (size_t b = 0; b < sizeof bytes; ++b)
        for (size_t i = 0; i < sizeof cases / sizeof cases[0]; ++i) {
            char text[2048];
            snprintf(text, sizeof text, "%s", scene_text(cases[i].line3, cases[i].line6));
            const size_t n = strlen(text);
            for (size_t k = 0; k < n; ++k)
                if (text[k] == '@') text[k] = (char)bytes[b];
            const char *path = tu_write_bytes("ws.json", text, n);
            scene s;
            const int rc = scene_load(&s, path, NULL, 0);
            if (cases[i].error_line == 0) {
                if (rc) fail_msg("byte 0x%02x, case %zu: %s", bytes[b], i, s.error);
                assert_int_equal(s.bodies[0].mesh.vertex_count, 8);
                scene_free(&s);
            } else {
                assert_int_equal(rc, -1);
                assert_int_equal(error_line(&s, path), cases[i].error_line);
            }
        }
}


/* What a scene may ask for (issue 17): steps and vertices within the limits, checked before
 * anything large is made; the messages name the option that raises them. */
static void expect_refused(const char *text, const scene_limits *lim, int line)
{
    const char *path = tu_write_file("lim.json", text);
    scene s;
    assert_int_equal(scene_load_limited(&s, path, NULL, 0, lim), -1);
    print_message("    %s\n", s.error);
    assert_int_equal(error_line(&s, path), line);
}

static void test_limits(void **state)
{
    (void)state;
    /* 1 / (30 h) for h = 1e-12 used to wrap to -1026405035 steps per frame: 0 steps, exit 0. */
    expect_refused("{\"world\": {\"h\": 1e-12,\n \"duration\": 1},\n \"bodies\": [{\"mesh\": "
                   "{\"type\": \"rope\", \"a\": [0,0,0], \"b\": [1,0,0], \"segments\": 2}}]}",
                   NULL, 1);
    expect_refused(scene_text("\"fps\": 1e-20", "\"name\": \"b\""), NULL, 3);
    /* 2e7 steps: past the default limit, within a raised one. */
    const char *long_run = scene_text("\"h\": 1e-5, \"duration\": 200, \"frame_steps\": 1000",
                                      "\"name\": \"b\"");
    char text[2048];
    snprintf(text, sizeof text, "%s", long_run);
    /* scene_text has its own h and duration; this one replaces them. */
    char *dup = strstr(text, "\"h\": 1e-3, \"duration\": 0.01,");
    memcpy(dup, "                            ", strlen("\"h\": 1e-3, \"duration\": 0.01,"));
    expect_refused(text, NULL, 3);
    const scene_limits more_steps = {SCENE_MAX_VERTICES, 20000000};
    scene s;
    if (scene_load_limited(&s, tu_write_file("long.json", text), NULL, 0, &more_steps))
        fail_msg("%s", s.error);
    assert_int_equal((int64_t)s.frames * s.frame_steps, 20000000);
    scene_free(&s);

    /* 201 x 201 x 101 vertices: refused before the box is made (it used to take 3 GB). */
    expect_refused("{\"world\": {\"h\": 1e-3, \"duration\": 0.01},\n \"bodies\": [{\"mesh\": "
                   "{\"type\": \"box\", \"lo\": [0,0,0], \"hi\": [1,1,1],\n \"cells\": [200,200,100]}}]}",
                   NULL, 3);
    /* Copies of a body: 64 vertices each, the third passes 150. */
    const char *copies =
        "{\"world\": {\"h\": 1e-3, \"duration\": 0.01},\n \"bodies\": [\n"
        "  {\"mesh\": {\"type\": \"box\", \"lo\": [0,0,0], \"hi\": [1,1,1], \"cells\": [3,3,3]}},\n"
        "  {\"mesh\": {\"type\": \"box\", \"lo\": [0,0,0], \"hi\": [1,1,1], \"cells\": [3,3,3]}},\n"
        "  {\"mesh\": {\"type\": \"box\", \"lo\": [0,0,0], \"hi\": [1,1,1], \"cells\": [3,3,3]}}]}\n";
    const scene_limits few = {150, SCENE_MAX_STEPS};
    expect_refused(copies, &few, 5);
    /* Mesh files, cloth and rope count as well. */
    tu_write_file("quad.obj", "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\n");
    const scene_limits three = {3, SCENE_MAX_STEPS};
    expect_refused("{\"world\": {\"h\": 1e-3, \"duration\": 0.01},\n \"bodies\": [{\"mesh\": "
                   "\"quad.obj\"}]}", &three, 2);
    expect_refused("{\"world\": {\"h\": 1e-3, \"duration\": 0.01},\n \"bodies\": [{\"mesh\": "
                   "{\"type\": \"cloth\", \"origin\": [0,0,0], \"u\": [1,0,0], \"v\": [0,1,0],\n"
                   "\"cells\": [1, 1]}}]}", &three, 3);
    expect_refused("{\"world\": {\"h\": 1e-3, \"duration\": 0.01},\n \"bodies\": [{\"mesh\": "
                   "{\"type\": \"rope\", \"a\": [0,0,0], \"b\": [1,0,0],\n\"segments\": 3}}]}",
                   &three, 3);
    const scene_limits four = {4, SCENE_MAX_STEPS};
    if (scene_load_limited(&s, tu_write_file("q.json", "{\"world\": {\"h\": 1e-3, \"duration\": "
                                             "0.01}, \"bodies\": [{\"mesh\": \"quad.obj\"}]}"),
                           NULL, 0, &four))
        fail_msg("%s", s.error);
    assert_int_equal(s.vertex_count, 4);
    scene_free(&s);
}

static void test_mesh_file_and_transform(void **state)
{
    (void)state;
    /* A square cloth from OBJ, placed by a mirroring transform: positions and normals follow. */
    tu_write_file("sq.obj", "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\n");
    const char *text =
        "{\"world\": {\"h\": 1e-3, \"duration\": 0.01, \"gravity\": [0, 0, 0]},\n"
        " \"bodies\": [{\"mesh\": {\"type\": \"file\", \"path\": \"sq.obj\"},\n"
        "   \"transform\": {\"scale\": [-2, 1, 1], \"translate\": [0, 0, 3]},\n"
        "   \"material\": {\"stiffness\": 50, \"vertex_mass\": 0.5},\n"
        "   \"velocity\": [1, 0, 0]}]}\n";
    scene s;
    load_ok("obj.json", text, &s);
    const scene_body *b = &s.bodies[0];
    assert_int_equal(b->mesh.vertex_count, 4);
    assert_int_equal(b->mesh.triangle_count, 2);
    assert_int_equal(b->mesh.spring_count, 5);
    assert_true(b->mesh.positions[3 * 2] == -2.0 && b->mesh.positions[3 * 2 + 2] == 3.0);
    /* Mirrored: the triangle normal stays +z (order flipped back). */
    const int32_t *t = b->mesh.triangles;
    const double *P = b->mesh.positions;
    double e1x = P[3 * t[1]] - P[3 * t[0]], e1y = P[3 * t[1] + 1] - P[3 * t[0] + 1];
    double e2x = P[3 * t[2]] - P[3 * t[0]], e2y = P[3 * t[2] + 1] - P[3 * t[0] + 1];
    assert_true(e1x * e2y - e1y * e2x > 0.0);
    assert_true(b->material.model == DEFSIM_MODEL_SPRING);
    defsim_world *w = NULL;
    if (scene_build(&s, &w) != DEFSIM_OK) fail_msg("%s", s.error);
    /* Free flight at 1 m/s without gravity: the energy is kinetic, 1/2 (4 * 0.5) 1^2. */
    defsim_energy e;
    TU_OK(defsim_world_energy(w, &e));
    assert_true(fabs(e.kinetic - 1.0) < 1e-14);
    defsim_world_destroy(w);
    scene_free(&s);
}

/* world.options set options by name after creation (numbers, strings, booleans); those of
 * another backend are skipped; bad shapes fail at load with their line, bad values at build.
 * testmod (tests/unit/testmod.c) divides velocities by 1 + h damping after each step. */
/* A body's "shell" builds the body that the C API's shell fields do (same forces at a bent
 * state, bit for bit, and the same energies), leaves out the cloth's springs, and a bad
 * membrane name or key is refused at its line. */
/* "fabric": a name from the table of measured fabrics (defsim_body_def_set_fabric) under a
 * shell: the same forces and masses as the C API's body with that fabric, a key beside it
 * overriding the table's value; an unknown name fails at its line. */
static void test_fabric_key(void **state)
{
    (void)state;
    const char *text =
        "{\"world\": {\"backend\": \"symplectic_euler\", \"h\": 1e-3, \"duration\": 1e-3},\n"
        " \"bodies\": [{\"mesh\": {\"type\": \"cloth\", \"origin\": [0, 0, 0], \"u\": [0.3, 0, 0],\n"
        "   \"v\": [0, 0, 0.2], \"cells\": [6, 4]},\n"
        "   \"shell\": {\"fabric\": \"denim\", \"warp_direction\": [1, 0, 1],\n"
        "             \"bending_rigidity_weft\": 1e-5}}]}\n";
    scene s;
    load_ok("fabric.json", text, &s);
    defsim_world *w = NULL;
    if (scene_build(&s, &w) != DEFSIM_OK) fail_msg("%s", s.error);
    defsim_world *v = tu_world("symplectic_euler", -9.81, 1);
    defsim_mesh m;
    memset(&m, 0, sizeof m);
    m.size = sizeof m;
    const double o[3] = {0, 0, 0}, u[3] = {0.3, 0, 0}, vv[3] = {0, 0, 0.2};
    TU_OK(defsim_mesh_cloth(o, u, vv, 6, 4, &m));
    defsim_body_def d;
    defsim_body_def_init(&d, sizeof d);
    d.rest_positions = m.positions;
    d.vertex_count = m.vertex_count;
    d.triangles = m.triangles;
    d.triangle_count = m.triangle_count;
    TU_OK(defsim_body_def_set_fabric(&d, "denim"));
    d.shell_warp_direction[2] = 1;
    d.shell_bending_rigidity_weft = 1e-5;
    TU_OK(defsim_world_add_body(v, &d, NULL));
    const int n = m.vertex_count;
    assert_int_equal(defsim_world_vertex_count(w), n);
    double *x = malloc(3 * (size_t)n * sizeof *x), *f1 = malloc(3 * (size_t)n * sizeof *f1),
           *f2 = malloc(3 * (size_t)n * sizeof *f2);
    for (int i = 0; i < n; ++i) {
        x[3 * i] = 1.05 * m.positions[3 * i];
        x[3 * i + 1] = 0.3 * m.positions[3 * i] * m.positions[3 * i];
        x[3 * i + 2] = 0.97 * m.positions[3 * i + 2];
    }
    TU_OK(defsim_world_forces(w, x, f1));
    TU_OK(defsim_world_forces(v, x, f2));
    double fmax = 0.0;
    for (int i = 0; i < 3 * n; ++i) {
        assert_true(f1[i] == f2[i]);
        fmax = fmax > fabs(f1[i]) ? fmax : fabs(f1[i]);
    }
    assert_true(fmax > 1e-3);
    for (int i = 0; i < 3 * n; ++i) f2[i] = 0.1 * (i % 7);
    TU_OK(defsim_world_set_state(w, x, f2));
    TU_OK(defsim_world_set_state(v, x, f2));
    defsim_energy e1, e2;
    TU_OK(defsim_world_energy(w, &e1));
    TU_OK(defsim_world_energy(v, &e2));
    assert_true(e1.elastic == e2.elastic && e1.kinetic == e2.kinetic);
    free(x);
    free(f1);
    free(f2);
    defsim_mesh_free(&m);
    defsim_world_destroy(v);
    defsim_world_destroy(w);
    scene_free(&s);
    const char *bad =
        "{\"world\": {\"backend\": \"symplectic_euler\", \"h\": 1e-3, \"duration\": 1e-3},\n"
        " \"bodies\": [{\"mesh\": {\"type\": \"cloth\", \"origin\": [0, 0, 0], \"u\": [1, 0, 0],\n"
        "   \"v\": [0, 0, 1], \"cells\": [2, 2]},\n"
        "   \"shell\": {\"fabric\": \"velvet\"}}]}\n";
    expect_line(bad, 4);
    const char *notstr =
        "{\"world\": {\"backend\": \"symplectic_euler\", \"h\": 1e-3, \"duration\": 1e-3},\n"
        " \"bodies\": [{\"mesh\": {\"type\": \"cloth\", \"origin\": [0, 0, 0], \"u\": [1, 0, 0],\n"
        "   \"v\": [0, 0, 1], \"cells\": [2, 2]},\n"
        "   \"shell\": {\"fabric\": 3}}]}\n";
    expect_line(notstr, 4);
}

static void test_shell_key(void **state)
{
    (void)state;
    const char *text =
        "{\"world\": {\"backend\": \"symplectic_euler\", \"h\": 1e-3, \"duration\": 1e-3},\n"
        " \"bodies\": [{\"mesh\": {\"type\": \"cloth\", \"origin\": [0, 0, 0], \"u\": [0.3, 0, 0],\n"
        "   \"v\": [0, 0, 0.2], \"cells\": [6, 4]},\n"
        "   \"shell\": {\"membrane\": \"orthotropic_stvk\", \"warp_modulus\": 2000, \"weft_modulus\": 800,\n"
        "             \"shear_modulus\": 60, \"warp_poisson\": 0.1, \"warp_direction\": [1, 0, 1],\n"
        "             \"areal_density\": 0.15, \"bending_rigidity\": 2e-5,\n"
        "             \"bending_rigidity_weft\": 1e-5}}]}\n";
    scene s;
    load_ok("shell.json", text, &s);
    defsim_world *w = NULL;
    if (scene_build(&s, &w) != DEFSIM_OK) fail_msg("%s", s.error);
    defsim_world *v = tu_world("symplectic_euler", -9.81, 1);
    defsim_mesh m;
    memset(&m, 0, sizeof m);
    m.size = sizeof m;
    const double o[3] = {0, 0, 0}, u[3] = {0.3, 0, 0}, vv[3] = {0, 0, 0.2};
    TU_OK(defsim_mesh_cloth(o, u, vv, 6, 4, &m));
    defsim_body_def d;
    defsim_body_def_init(&d, sizeof d);
    d.rest_positions = m.positions;
    d.vertex_count = m.vertex_count;
    d.triangles = m.triangles;
    d.triangle_count = m.triangle_count;
    d.shell_membrane = DEFSIM_SHELL_MEMBRANE_ORTHOTROPIC_STVK;
    d.shell_warp_modulus = 2000;
    d.shell_weft_modulus = 800;
    d.shell_shear_modulus = 60;
    d.shell_warp_poisson = 0.1;
    d.shell_warp_direction[0] = 1;
    d.shell_warp_direction[2] = 1;
    d.shell_areal_density = 0.15;
    d.shell_bending_rigidity = 2e-5;
    d.shell_bending_rigidity_weft = 1e-5;
    TU_OK(defsim_world_add_body(v, &d, NULL));
    const int n = m.vertex_count;
    assert_int_equal(defsim_world_vertex_count(w), n);
    double *x = malloc(3 * (size_t)n * sizeof *x), *f1 = malloc(3 * (size_t)n * sizeof *f1),
           *f2 = malloc(3 * (size_t)n * sizeof *f2);
    for (int i = 0; i < n; ++i) {
        x[3 * i] = 1.05 * m.positions[3 * i];
        x[3 * i + 1] = 0.3 * m.positions[3 * i] * m.positions[3 * i];
        x[3 * i + 2] = 0.97 * m.positions[3 * i + 2];
    }
    TU_OK(defsim_world_forces(w, x, f1));
    TU_OK(defsim_world_forces(v, x, f2));
    double fmax = 0.0;
    for (int i = 0; i < 3 * n; ++i) {
        assert_true(f1[i] == f2[i]);
        fmax = fmax > fabs(f1[i]) ? fmax : fabs(f1[i]);
    }
    assert_true(fmax > 1e-3);
    /* The same masses: the kinetic energy of one velocity field. */
    for (int i = 0; i < 3 * n; ++i) f2[i] = 0.1 * (i % 7);
    TU_OK(defsim_world_set_state(w, x, f2));
    TU_OK(defsim_world_set_state(v, x, f2));
    defsim_energy e1, e2;
    TU_OK(defsim_world_energy(w, &e1));
    TU_OK(defsim_world_energy(v, &e2));
    print_message("    shell scene: elastic %.6g / %.6g J, kinetic %.6g / %.6g J\n", e1.elastic,
                  e2.elastic, e1.kinetic, e2.kinetic);
    assert_true(e1.elastic == e2.elastic && e1.kinetic == e2.kinetic);
    free(x);
    free(f1);
    free(f2);
    defsim_mesh_free(&m);
    defsim_world_destroy(v);
    defsim_world_destroy(w);
    scene_free(&s);
    const char *bad =
        "{\"world\": {\"backend\": \"symplectic_euler\", \"h\": 1e-3, \"duration\": 1e-3},\n"
        " \"bodies\": [{\"mesh\": {\"type\": \"cloth\", \"origin\": [0, 0, 0], \"u\": [1, 0, 0],\n"
        "   \"v\": [0, 0, 1], \"cells\": [2, 2]},\n"
        "   \"shell\": {\"membrane\": \"rubber\"}}]}\n";
    expect_line(bad, 4);
    const char *badkey =
        "{\"world\": {\"backend\": \"symplectic_euler\", \"h\": 1e-3, \"duration\": 1e-3},\n"
        " \"bodies\": [{\"mesh\": {\"type\": \"cloth\", \"origin\": [0, 0, 0], \"u\": [1, 0, 0],\n"
        "   \"v\": [0, 0, 1], \"cells\": [2, 2]},\n"
        "   \"shell\": {\"membrane\": \"stvk\", \"thicknes\": 1}}]}\n";
    expect_line(badkey, 4);
}

static void test_world_options(void **state)
{
    (void)state;
    const char *opts = "\"backend\": \"testmod\", \"gravity\": [0, 0, 0],\n"
                       "  \"options\": {\"testmod.damping\": 2.5, \"core.simd\": \"scalar\",\n"
                       "              \"core.auto_substep\": true, \"sundials_ida.rtol\": 1e-6}";
    const char *path = tu_write_file("opt.json", scene_text(opts, "\"name\": \"b\""));
    scene s;
    if (scene_load(&s, path, NULL, 0)) fail_msg("%s", s.error);
    defsim_world *w = NULL;
    if (scene_build(&s, &w) != DEFSIM_OK) fail_msg("%s", s.error);
    double v;
    TU_OK(defsim_world_get_option(w, "testmod.damping", &v));
    assert_true(v == 2.5);
    TU_OK(defsim_world_get_option(w, "core.simd", &v));
    assert_true(v == 1.0);   /* scalar */
    TU_OK(defsim_world_get_option(w, "core.auto_substep", &v));
    assert_true(v == 1.0);
    /* A uniform translation has no elastic force: one step divides v by 1 + h damping. */
    const int n = defsim_world_vertex_count(w);
    double *vel = malloc(3 * (size_t)n * sizeof *vel);
    for (int i = 0; i < 3 * n; ++i) vel[i] = i % 3 == 0 ? 1.0 : 0.0;
    TU_OK(defsim_world_set_state(w, NULL, vel));
    TU_OK(defsim_world_set_option(w, "core.auto_substep", "false"));
    TU_OK(defsim_world_step(w, s.h));
    TU_OK(defsim_world_get_velocities(w, vel, n));
    for (int i = 0; i < n; ++i) assert_true(fabs(vel[3 * i] - 1.0 / (1.0 + 2.5 * s.h)) < 1e-9);
    TU_OK(defsim_world_stat(w, "testmod.steps", &v));
    assert_true(v == 1.0);
    free(vel);
    defsim_world_destroy(w);
    scene_free(&s);

    /* --backend symplectic_euler: the testmod option is skipped, the core's still apply. */
    const char *sets[] = {"world.backend=symplectic_euler"};
    if (scene_load(&s, path, sets, 1)) fail_msg("%s", s.error);
    if (scene_build(&s, &w) != DEFSIM_OK) fail_msg("%s", s.error);
    TU_OK(defsim_world_get_option(w, "core.simd", &v));
    assert_true(v == 1.0);
    assert_int_equal(defsim_world_get_option(w, "testmod.damping", &v),
                     DEFSIM_ERR_INVALID_ARGUMENT);
    defsim_world_destroy(w);
    scene_free(&s);

    expect_line(scene_text("\"options\": [1]", "\"name\": \"b\""), 3);
    expect_line(scene_text("\"options\": {\"rtol\": 1}", "\"name\": \"b\""), 3);
    expect_line(scene_text("\"options\": {\"core.simd\": [1]}", "\"name\": \"b\""), 3);
    path = tu_write_file("v.json", scene_text("\"options\": {\"core.substep_safety\": 2}",
                                              "\"name\": \"b\""));
    if (scene_load(&s, path, NULL, 0)) fail_msg("%s", s.error);
    assert_int_equal(scene_build(&s, &w), DEFSIM_ERR_INVALID_ARGUMENT);
    assert_null(w);
    scene_free(&s);
}

/* The backend settings a scene's world object gives by key (world.tolerance, world.projection,
 * ...) set the options of the run's backend of the same name; a key the backend has no option
 * for is ignored; an entry of world.options of the same full name wins; a value the option
 * refuses fails the build. */
static void test_world_setting_keys(void **state)
{
    (void)state;
    if (!tu_available("newton_cholmod")) {
        tu_skip("test_world_setting_keys: newton_cholmod not built");
        return;
    }
    const char *keys = "\"backend\": \"newton_cholmod\", \"tolerance\": 1e-8, \"rtol\": 1e-3,\n"
                       "  \"projection\": \"abs\", \"max_iterations\": 9,\n"
                       "  \"options\": {\"newton_cholmod.max_iterations\": 7}";
    const char *path = tu_write_file("keys.json", scene_text(keys, "\"name\": \"b\""));
    scene s;
    if (scene_load(&s, path, NULL, 0)) fail_msg("%s", s.error);
    defsim_world *w = NULL;
    if (scene_build(&s, &w) != DEFSIM_OK) fail_msg("%s", s.error);
    double v;
    TU_OK(defsim_world_get_option(w, "newton_cholmod.tolerance", &v));
    assert_true(v == 1e-8);
    TU_OK(defsim_world_get_option(w, "newton_cholmod.projection", &v));
    assert_true(v == DEFSIM_PROJECTION_ABS);
    TU_OK(defsim_world_get_option(w, "newton_cholmod.max_iterations", &v));
    assert_true(v == 7.0);
    TU_OK(defsim_world_step(w, s.h));
    defsim_world_destroy(w);
    scene_free(&s);

    /* On symplectic_euler, which has none of these options, the keys change nothing. */
    const char *sets[] = {"world.backend=symplectic_euler", "world.options={}"};
    if (scene_load(&s, path, sets, 2)) fail_msg("%s", s.error);
    if (scene_build(&s, &w) != DEFSIM_OK) fail_msg("%s", s.error);
    assert_int_equal(defsim_world_option_count(w), 11);
    defsim_world_destroy(w);
    scene_free(&s);

    expect_line(scene_text("\"projection\": \"sideways\"", "\"name\": \"b\""), 3);
    expect_line(scene_text("\"max_order\": 6", "\"name\": \"b\""), 3);
    path = tu_write_file("kb.json", scene_text("\"backend\": \"newton_cholmod\", \"tolerance\": 1e-300",
                                               "\"name\": \"b\""));
    if (scene_load(&s, path, NULL, 0)) fail_msg("%s", s.error);
    assert_int_equal(scene_build(&s, &w), DEFSIM_ERR_INVALID_ARGUMENT);
    assert_null(w);
    scene_free(&s);
}

/* Forces, drives and attachments: errors name their line; the tool's barycentric weights
 * reproduce the attached point; a total force is spread by mass; driven pins follow the path. */
static void test_coupling(void **state)
{
    (void)state;
    expect_line(scene_text("\"threads\": 1", "\"forces\": {\"total\": [0,1,0], \"per_vertex\": [0,1,0]}"), 6);
    expect_line(scene_text("\"threads\": 1", "\"forces\": [{\"total\": [0,1,0], \"boxx\": 1}]"), 6);
    expect_line(scene_text("\"threads\": 1", "\"drive\": {\"indices\": [0], \"keys\": []}"), 6);
    expect_line(scene_text("\"threads\": 1", "\"drive\": {\"indices\": [0], \"keys\": [{\"t\": 1}, {\"t\": 0.5}]}"), 6);
    expect_line(scene_text("\"threads\": 1", "\"drive\": {\"keys\": [{\"t\": 0}]}"), 6);
    expect_line(scene_text("\"threads\": 1", "\"drive\": {\"indices\": [0], \"keys\": [{\"t\": 0, \"rotate\": {\"axis\": [0,0,0], \"degrees\": 3}}]}"), 6);
    const char *bad_att =
        "{\"world\": {\"h\": 1e-3, \"duration\": 0.01},\n"
        " \"bodies\": [{\"mesh\": {\"type\": \"box\", \"lo\": [0,0,0], \"hi\": [1,1,1], \"cells\": [1,1,1]}}],\n"
        " \"attachments\": [\n"
        "   {\"body\": 0, \"vertex\": 0, \"stiffness\": 10},\n"
        "   {\"body\": \"nobody\", \"vertex\": 0, \"stiffness\": 10}]}\n";
    expect_line(bad_att, 5);
    const char *bad_key =
        "{\"world\": {\"h\": 1e-3, \"duration\": 0.01},\n"
        " \"bodies\": [{\"mesh\": {\"type\": \"box\", \"lo\": [0,0,0], \"hi\": [1,1,1], \"cells\": [1,1,1]}}],\n"
        " \"attachments\": [{\"body\": 0, \"vertex\": 0,\n"
        "   \"stiffness\": 10, \"target\": {\"body\": 0}}]}\n";
    expect_line(bad_key, 4);

    /* A rope whose middle vertex sits inside a box of tets, attached to it; a total force on
     * the box; the rope's first vertex driven 0.1 m along x over 0.01 s. */
    const char *text =
        "{\"world\": {\"h\": 1e-3, \"duration\": 0.01, \"gravity\": [0, 0, 0]},\n"
        " \"bodies\": [\n"
        "  {\"name\": \"box\", \"mesh\": {\"type\": \"box\", \"lo\": [0,0,0], \"hi\": [1,1,1], \"cells\": [2,2,2]},\n"
        "   \"material\": {\"youngs_modulus\": 1e4, \"density\": 100},\n"
        "   \"forces\": {\"total\": [3, 0, 0], \"box\": {\"lo\": [0,0,0], \"hi\": [0.5,1,1]}}},\n"
        "  {\"name\": \"rope\", \"mesh\": {\"type\": \"rope\", \"a\": [0.3,0.2,0.1], \"b\": [1.3,0.4,0.9], \"segments\": 2},\n"
        "   \"material\": {\"stiffness\": 10, \"vertex_mass\": 0.01},\n"
        "   \"drive\": {\"indices\": [0], \"keys\": [{\"t\": 0}, {\"t\": 0.01, \"translate\": [0.1, 0, 0]}]}}],\n"
        " \"attachments\": [{\"body\": \"rope\", \"point\": [0.8,0.3,0.5], \"stiffness\": 50,\n"
        "                   \"target\": {\"body\": \"box\"}},\n"
        "                  {\"body\": \"rope\", \"vertex\": 2, \"stiffness\": 5, \"damping\": 0.1,\n"
        "                   \"target\": {\"keys\": [{\"t\": 0}, {\"t\": 1, \"rotate\": {\"axis\": [0,0,1], \"degrees\": 90, \"center\": [1.3,0,0]}}]}}]}\n";
    scene s;
    load_ok("c.json", text, &s);
    assert_int_equal(s.nattachments, 2);
    const scene_attachment *a = &s.attachments[0];
    assert_int_equal(a->body, 1);
    assert_int_equal(a->vertex, 1);
    assert_int_equal(a->target_body, 0);
    assert_int_equal(a->target_count, 4);
    const double *X = s.bodies[0].mesh.positions, p[3] = {0.8, 0.3, 0.5};
    double q[3] = {0, 0, 0}, wsum = 0.0;
    for (int j = 0; j < 4; ++j) {
        assert_true(a->target_weights[j] >= 0.0);
        wsum += a->target_weights[j];
        for (int c = 0; c < 3; ++c) q[c] += a->target_weights[j] * X[3 * a->target_vertices[j] + c];
    }
    assert_true(fabs(wsum - 1.0) < 1e-14);
    for (int c = 0; c < 3; ++c) assert_true(fabs(q[c] - p[c]) < 1e-12);
    assert_int_equal(s.attachments[1].target_body, -1);
    assert_true(s.attachments[1].path >= 0);
    assert_int_equal(s.bodies[0].nforces, 1);
    assert_int_equal(s.bodies[0].forces[0].n, 3 * 3 * 2);   /* x in {0, 0.5}: 2 planes of 3 x 3 */
    assert_int_equal(s.bodies[1].ndrives, 1);
    assert_true(scene_has_paths(&s));

    defsim_world *w = NULL;
    if (scene_build(&s, &w) != DEFSIM_OK) fail_msg("%s", s.error);
    const double h = 1e-3;
    for (int k = 0; k < 5; ++k) TU_OK(scene_step(&s, w, h));
    const int32_t nv = defsim_world_vertex_count(w);
    double *x = malloc(3 * (size_t)nv * sizeof *x), *v = malloc(3 * (size_t)nv * sizeof *v);
    double *m = malloc((size_t)nv * sizeof *m);
    TU_OK(defsim_world_get_positions(w, x, nv));
    TU_OK(defsim_world_get_velocities(w, v, nv));
    TU_OK(defsim_world_get_masses(w, m, nv));
    /* The driven vertex is where the path puts it at t = 5 ms: half of 0.1 m along x. */
    const double *d = x + 3 * s.bodies[1].offset;
    assert_true(fabs(d[0] - 0.35) < 1e-12 && fabs(d[1] - 0.2) < 1e-12 && fabs(d[2] - 0.1) < 1e-12);
    /* The attachment to the box: its spring is relaxed at rest, so it pulls with -k (x - p). */
    double f[3];
    TU_OK(defsim_world_get_attachment_force(w, s.attachments[0].id, f));
    assert_true(isfinite(f[0]) && isfinite(f[1]) && isfinite(f[2]));
    scene_free(&s);
    defsim_world_destroy(w);

    /* A drive that turns a rope's end a quarter turn about z through the origin in 10 ms:
     * after 5 ms it has turned 45 degrees, after 20 ms (past the last key) it stays at 90. */
    text = "{\"world\": {\"h\": 1e-3, \"duration\": 0.02, \"gravity\": [0, 0, 0]},\n"
           " \"bodies\": [{\"mesh\": {\"type\": \"rope\", \"a\": [-1,0,0], \"b\": [1,0,0], \"segments\": 2},\n"
           "   \"material\": {\"stiffness\": 10, \"vertex_mass\": 0.01},\n"
           "   \"drive\": {\"indices\": [2], \"keys\": [{\"t\": 0},\n"
           "     {\"t\": 0.01, \"rotate\": {\"axis\": [0,0,2], \"degrees\": 90, \"center\": [0,0,0]}}]}}]}\n";
    load_ok("r.json", text, &s);
    if (scene_build(&s, &w) != DEFSIM_OK) fail_msg("%s", s.error);
    for (int k = 0; k < 20; ++k) {
        TU_OK(scene_step(&s, w, h));
        TU_OK(defsim_world_get_positions(w, x, 3));
        const double a = (k < 9 ? (k + 1) * 0.1 : 1.0) * acos(-1.0) / 2.0;
        if (!(fabs(x[6] - cos(a)) < 1e-12 && fabs(x[7] - sin(a)) < 1e-12 && fabs(x[8]) < 1e-15))
            fail_msg("step %d: (%g, %g, %g), expected (%g, %g, 0)", k + 1, x[6], x[7], x[8],
                     cos(a), sin(a));
    }
    scene_free(&s);
    defsim_world_destroy(w);

    /* A total force spread by mass: after the first step from rest (no elastic force yet) every
     * selected vertex has v = h F / M_selected, the others none. */
    text = "{\"world\": {\"h\": 1e-3, \"duration\": 0.01, \"gravity\": [0, 0, 0]},\n"
           " \"bodies\": [{\"mesh\": {\"type\": \"box\", \"lo\": [0,0,0], \"hi\": [1,1,1], \"cells\": [2,2,2]},\n"
           "   \"forces\": {\"total\": [0, 0, 6], \"box\": {\"lo\": [0,0,0], \"hi\": [0.5,1,1]}}}]}\n";
    load_ok("f.json", text, &s);
    if (scene_build(&s, &w) != DEFSIM_OK) fail_msg("%s", s.error);
    TU_OK(scene_step(&s, w, h));
    TU_OK(defsim_world_get_velocities(w, v, 27));
    TU_OK(defsim_world_get_masses(w, m, 27));
    double M = 0.0;
    for (int32_t i = 0; i < s.bodies[0].forces[0].n; ++i) M += m[s.bodies[0].forces[0].verts[i]];
    for (int32_t i = 0; i < 27; ++i) {
        const int sel = s.bodies[0].mesh.positions[3 * i] <= 0.5;
        /* Elastic forces at rest are zero to rounding. */
        const double tol = 1e-9 * h * 6.0 / M;
        if (!(fabs(v[3 * i]) < tol && fabs(v[3 * i + 1]) < tol &&
              fabs(v[3 * i + 2] - (sel ? h * 6.0 / M : 0.0)) < tol))
            fail_msg("vertex %d: v = (%g, %g, %g), selected %d, h F / M = %g", (int)i, v[3 * i],
                     v[3 * i + 1], v[3 * i + 2], sel, h * 6.0 / M);
    }
    scene_free(&s);
    defsim_world_destroy(w);
    free(x); free(v); free(m);
}

/* "colliders": every shape, rotations by quaternion and Euler angles, a mesh file, keyed poses,
 * and errors that name the line (unknown key, a key of another shape, wrong type, bad path). */
static void test_colliders(void **state)
{
    (void)state;
    tu_write_file("cube.obj", "v -1 -1 -1\nv 1 -1 -1\nv 1 1 -1\nv -1 1 -1\n"
                              "v -1 -1 1\nv 1 -1 1\nv 1 1 1\nv -1 1 1\n"
                              "f 1 3 2\nf 1 4 3\nf 5 6 7\nf 5 7 8\nf 1 2 6\nf 1 6 5\n"
                              "f 3 4 8\nf 3 8 7\nf 2 3 7\nf 2 7 6\nf 1 5 8\nf 1 8 4\n");
    const char *text =
        "{\"world\": {\"h\": 1e-3, \"duration\": 0.01},\n"
        " \"bodies\": [{\"mesh\": {\"type\": \"box\", \"lo\": [0,2,0], \"hi\": [1,3,1], \"cells\": [1,1,1]}}],\n"
        " \"colliders\": [\n"
        "   {\"shape\": \"plane\", \"normal\": [0, 2, 0], \"friction\": 0.5},\n"
        "   {\"shape\": \"sphere\", \"position\": [3, 0, 0], \"radius\": 0.25},\n"
        "   {\"shape\": \"box\", \"half_extents\": [1, 0.5, 0.25], \"euler_deg\": [0, 90, 0]},\n"
        "   {\"shape\": \"capsule\", \"radius\": 0.1, \"half_height\": 0.3,\n"
        "    \"rotation\": [0.7071067811865476, 0, 0, 0.7071067811865476]},\n"
        "   {\"shape\": \"mesh\", \"mesh\": \"cube.obj\", \"position\": [0, -5, 0]},\n"
        "   {\"shape\": \"box\", \"position\": [1, 2, 3], \"path\": [\n"
        "      {\"t\": 0.5, \"position\": [0, 0, 0]},\n"
        "      {\"t\": 1.5, \"position\": [2, 0, 0], \"euler_deg\": [0, 90, 0]}]}]}\n";
    scene s;
    load_ok("c.json", text, &s);
    assert_int_equal(s.ncolliders, 6);
    assert_int_equal(s.colliders[0].def.shape, DEFSIM_SHAPE_PLANE);
    assert_true(s.colliders[0].def.normal[1] == 2.0 && s.colliders[0].def.friction == 0.5);
    assert_true(s.colliders[1].def.radius == 0.25 && s.colliders[1].def.position[0] == 3.0);
    /* 90 degrees about y: (cos 45, 0, sin 45, 0) */
    const double *q = s.colliders[2].def.rotation;
    assert_true(fabs(q[0] - sqrt(0.5)) < 1e-15 && fabs(q[2] - sqrt(0.5)) < 1e-15 && q[1] == 0.0 &&
                fabs(q[3]) < 1e-15);
    assert_true(s.colliders[3].def.half_height == 0.3);
    assert_int_equal(s.colliders[4].def.triangle_count, 12);
    assert_int_equal(s.colliders[4].def.vertex_count, 8);
    /* keyed poses: held before the first key and after the last, linear and slerp between */
    double p[3], r[4];
    scene_collider_pose(&s.colliders[5], 0.0, p, r);
    assert_true(p[0] == 0.0 && r[0] == 1.0);
    scene_collider_pose(&s.colliders[5], 1.0, p, r);
    assert_true(fabs(p[0] - 1.0) < 1e-15 && p[1] == 0.0);
    assert_true(fabs(r[0] - cos(3.14159265358979 / 8)) < 1e-12 &&
                fabs(r[2] - sin(3.14159265358979 / 8)) < 1e-12);
    scene_collider_pose(&s.colliders[5], 9.0, p, r);
    assert_true(p[0] == 2.0 && fabs(r[2] - sqrt(0.5)) < 1e-15);
    assert_true(scene_has_paths(&s));
    /* drawn surfaces: every vertex on the shape (at t = 1, on the path for the moving box),
     * every triangle facing out; none for the plane */
    for (int32_t i = 0; i < s.ncolliders; ++i) {
        double *lx, *wx;
        int32_t nv, nt, *tri;
        int smooth;
        assert_int_equal(scene_collider_surface(&s.colliders[i], &lx, &nv, &tri, &nt, &smooth), 0);
        assert_true(i == 0 ? nt == 0 : nt >= 12);
        wx = malloc(3 * (size_t)nv * sizeof *wx + 1);
        scene_collider_place(&s.colliders[i], 1.0, lx, nv, wx);
        defsim__messages msg;
        defsim__collider col;
        defsim_collider_def d = s.colliders[i].def;
        if (s.colliders[i].nkeys) scene_collider_pose(&s.colliders[i], 1.0, d.position, d.rotation);
        assert_int_equal(defsim__collider_make(&msg, &d, &col), DEFSIM_OK);
        defsim__pose pose;
        defsim__pose_set(&pose, col.pos, col.rot);
        for (int32_t v = 0; v < nv; ++v) {
            double dd, g[3];
            TU_OK(defsim__collider_distance(&col, &pose, wx + 3 * v, &dd, g, NULL));
            assert_true(fabs(dd) < 1e-12);
        }
        for (int32_t t = 0; t < nt; ++t) {
            const double *a = wx + 3 * tri[3 * t], *b = wx + 3 * tri[3 * t + 1], *c = wx + 3 * tri[3 * t + 2];
            double e1[3], e2[3], n[3], m[3], dd, g[3];
            for (int k = 0; k < 3; ++k) { e1[k] = b[k] - a[k]; e2[k] = c[k] - a[k]; m[k] = (a[k] + b[k] + c[k]) / 3; }
            n[0] = e1[1] * e2[2] - e1[2] * e2[1]; n[1] = e1[2] * e2[0] - e1[0] * e2[2]; n[2] = e1[0] * e2[1] - e1[1] * e2[0];
            /* outward: the distance grows along the triangle's normal */
            const double nn = sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
            double m2[3], d2;
            for (int k = 0; k < 3; ++k) m2[k] = m[k] + 1e-4 * n[k] / nn;
            TU_OK(defsim__collider_distance(&col, &pose, m, &dd, g, NULL));
            TU_OK(defsim__collider_distance(&col, &pose, m2, &d2, g, NULL));
            assert_true(d2 > dd);
        }
        defsim__collider_free(&col);
        free(lx); free(wx); free(tri);
    }
    defsim_world *w = NULL;
    if (scene_build(&s, &w) != DEFSIM_OK) fail_msg("%s", s.error);
    assert_int_equal(defsim_world_collider_count(w), 6);
    defsim_collider_def d;
    defsim_collider_def_init(&d, sizeof d);
    TU_OK(defsim_world_get_collider(w, 4, NULL, &d));
    assert_true(d.shape == DEFSIM_SHAPE_MESH && d.position[1] == -5.0 && d.triangle_count == 12);
    TU_OK(defsim_world_get_collider(w, 0, NULL, &d));
    assert_true(d.normal[1] == 1.0);   /* normalised by the library */
    defsim_world_destroy(w);
    scene_free(&s);

    /* values the library rejects: the error names the collider's line */
    const char *bad_value =
        "{\"world\": {\"h\": 1e-3, \"duration\": 0.01},\n"
        " \"bodies\": [{\"mesh\": {\"type\": \"box\", \"lo\": [0,0,0], \"hi\": [1,1,1], \"cells\": [1,1,1]}}],\n"
        " \"colliders\": [{\"shape\": \"sphere\"},\n"
        "   {\"shape\": \"sphere\", \"radius\": -1}]}\n";
    const char *path = tu_write_file("v.json", bad_value);
    if (scene_load(&s, path, NULL, 0)) fail_msg("%s", s.error);
    assert_int_equal(scene_build(&s, &w), DEFSIM_ERR_INVALID_ARGUMENT);
    assert_null(w);
    assert_int_equal(error_line(&s, path), 4);
    scene_free(&s);

    static const char *const bad[] = {
        "{\"shape\": \"box\", \"radius\": 1}",                       /* a key of another shape */
        "{\"shape\": \"sphere\", \"raduis\": 1}",                    /* unknown key */
        "{\"shape\": \"cone\"}",                                      /* unknown shape */
        "{\"radius\": 1}",                                            /* no shape */
        "{\"shape\": \"sphere\", \"position\": \"here\"}",            /* wrong type */
        "{\"shape\": \"sphere\", \"rotation\": [1, 0, 0]}",           /* wrong length */
        "{\"shape\": \"box\", \"rotation\": [1, 0, 0, 0], \"euler_deg\": [0, 0, 0]}",
        "{\"shape\": \"box\", \"path\": [{\"t\": 1}, {\"t\": 0.5}]}", /* times must increase */
        "{\"shape\": \"box\", \"path\": [{\"t\": 1, \"speed\": 2}]}",
        "{\"shape\": \"mesh\", \"mesh\": \"missing.obj\"}",
        "{\"shape\": \"mesh\"}",
    };
    for (size_t i = 0; i < sizeof bad / sizeof *bad; ++i) {
        char buf[1024];
        snprintf(buf, sizeof buf,
                 "{\"world\": {\"h\": 1e-3, \"duration\": 0.01},\n"
                 " \"bodies\": [{\"mesh\": {\"type\": \"box\", \"lo\": [0,0,0], \"hi\": [1,1,1], \"cells\": [1,1,1]}}],\n"
                 " \"colliders\": [{\"shape\": \"plane\"},\n"
                 "   %s]}\n", bad[i]);
        expect_line(buf, 4);
    }
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_shipped_scenes),
        cmocka_unit_test(test_overrides),
        cmocka_unit_test_setup_teardown(test_errors, tu_tmpdir_setup, tu_tmpdir_teardown),
        cmocka_unit_test_setup_teardown(test_limits, tu_tmpdir_setup, tu_tmpdir_teardown),
        cmocka_unit_test_setup_teardown(test_model_spellings_and_kind_keys, tu_tmpdir_setup,
                                        tu_tmpdir_teardown),
        cmocka_unit_test_setup_teardown(test_mesh_file_and_transform, tu_tmpdir_setup, tu_tmpdir_teardown),
        cmocka_unit_test_setup_teardown(test_world_options, tu_tmpdir_setup, tu_tmpdir_teardown),
        cmocka_unit_test_setup_teardown(test_shell_key, tu_tmpdir_setup, tu_tmpdir_teardown),
        cmocka_unit_test_setup_teardown(test_fabric_key, tu_tmpdir_setup, tu_tmpdir_teardown),
        cmocka_unit_test_setup_teardown(test_world_setting_keys, tu_tmpdir_setup,
                                        tu_tmpdir_teardown),
        cmocka_unit_test_setup_teardown(test_coupling, tu_tmpdir_setup, tu_tmpdir_teardown),
        cmocka_unit_test_setup_teardown(test_colliders, tu_tmpdir_setup, tu_tmpdir_teardown),
        cmocka_unit_test_setup_teardown(test_control_bytes_as_whitespace, tu_tmpdir_setup,
                                        tu_tmpdir_teardown),
    };
    return tu_exit(cmocka_run_group_tests_name("scene", tests, NULL, NULL));
}
