/* SPDX-License-Identifier: MIT */
/* Mesh loaders (TetGen, Gmsh 2 / 4, OBJ) and the cloth and rope generators. Each test writes
 * small files into a fresh temporary directory.
 *
 * Contents: checks shared by the loaders' tests; TetGen; Gmsh; OBJ; generators. */
#include "test_util.h"

#include "tet10.h"

#include <math.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

/* |a - b| <= tol, printing both values when not. */
#define assert_near(a, b, tol)                                                                  \
    do {                                                                                       \
        double a_ = (a), b_ = (b);                                                             \
        if (!(fabs(a_ - b_) <= (tol))) fail_msg("%s = %.17g, expected %.17g", #a, a_, b_);      \
    } while (0)

static defsim_mesh empty_mesh(void)
{
    defsim_mesh m;
    memset(&m, 0, sizeof m);
    m.size = sizeof m;
    return m;
}

/* The line number in "path:LINE: message" (0 if the message names no line). */
static int error_line(void)
{
    const char *e = defsim_last_error();
    const char *p = strstr(e, tu_tmpdir);
    if (!p) return 0;
    p = strchr(p + strlen(tu_tmpdir), ':');
    return p ? atoi(p + 1) : 0;
}

static void expect_error(const char *path, defsim_status want, int line)
{
    defsim_mesh m = empty_mesh();
    assert_int_equal(defsim_mesh_load(path, &m), want);
    print_message("    %s\n", defsim_last_error());
    assert_null(m.positions);
    assert_int_equal(m.vertex_count, 0);
    assert_int_equal(error_line(), line);
}

static double tet_volume(const double *P, const int32_t *t)
{
    double a[3], b[3], c[3];
    for (int i = 0; i < 3; ++i) {
        a[i] = P[3 * t[0] + i] - P[3 * t[3] + i];
        b[i] = P[3 * t[1] + i] - P[3 * t[3] + i];
        c[i] = P[3 * t[2] + i] - P[3 * t[3] + i];
    }
    return (a[0] * (b[1] * c[2] - b[2] * c[1]) - a[1] * (b[0] * c[2] - b[2] * c[0]) +
            a[2] * (b[0] * c[1] - b[1] * c[0])) / 6.0;
}

/* Volume from the boundary by the divergence theorem: outward triangles give +V. */
static double boundary_volume(const defsim_mesh *m)
{
    double v = 0.0;
    for (int t = 0; t < m->triangle_count; ++t) {
        const double *a = m->positions + 3 * m->triangles[3 * t];
        const double *b = m->positions + 3 * m->triangles[3 * t + 1];
        const double *c = m->positions + 3 * m->triangles[3 * t + 2];
        v += (a[0] * (b[1] * c[2] - b[2] * c[1]) - a[1] * (b[0] * c[2] - b[2] * c[0]) +
              a[2] * (b[0] * c[1] - b[1] * c[0])) / 6.0;
    }
    return v;
}

/* Every tet positive; sum of tet volumes and boundary volume both equal `volume`. */
static void check_solid(const defsim_mesh *m, double volume)
{
    double v = 0.0;
    for (int t = 0; t < m->tet_count; ++t) {
        double vt = tet_volume(m->positions, m->tets + (m->tet_nodes == 10 ? 10 : 4) * t);
        assert_true(vt > 0.0);
        v += vt;
    }
    assert_near(v, volume, 1e-12 * fabs(volume));
    assert_near(boundary_volume(m), volume, 1e-12 * fabs(volume));
}

/* ------------------------------------------------------------------------------------------ */
/* TetGen */

/* Two tets sharing the face 1-2-3 (1-based numbers), one given with negative orientation,
 * an unused point 6, comments, attributes and boundary markers. */
static const char *NODE =
    "# points: count dim attributes markers\n"
    "6 3 1 1\n"
    "1 0 0 0  7.5 1\n"
    "2 1 0 0  7.5 1   # comment after data\n"
    "3 0 1 0  7.5 0\n"
    "\n"
    "4 0 0 1  7.5 1\n"
    "5 0 0 -1 7.5 1\n"
    "6 9 9 9  7.5 0\n";
static const char *ELE =
    "2 4 1\n"
    "1  1 2 3 4  0.5\n"
    "2  1 2 3 5  0.5\n";

static void test_tetgen(void **state)
{
    (void)state;
    tu_write_file("two.node", NODE);
    const char *ele = tu_write_file("two.ele", ELE);
    char node[300], base[300];
    snprintf(node, sizeof node, "%s/two.node", tu_tmpdir);
    snprintf(base, sizeof base, "%s/two", tu_tmpdir);
    const char *paths[3] = {node, ele, base};
    for (int k = 0; k < 3; ++k) {
        defsim_mesh m = empty_mesh();
        TU_OK(defsim_mesh_load(paths[k], &m));
        assert_int_equal(m.vertex_count, 5);   /* point 6 is unused and dropped */
        assert_int_equal(m.tet_count, 2);
        assert_int_equal(m.triangle_count, 6);
        assert_int_equal(m.spring_count, 0);
        assert_near(m.positions[3 * 4 + 2], -1.0, 0.0);
        check_solid(&m, 2.0 / 6.0);
        /* Vertex sets of the tets are kept (only the order of two may change). */
        int sum0 = 0, sum1 = 0;
        for (int a = 0; a < 4; ++a) { sum0 += m.tets[a]; sum1 += m.tets[4 + a]; }
        assert_int_equal(sum0, 0 + 1 + 2 + 3);
        assert_int_equal(sum1, 0 + 1 + 2 + 4);
        defsim_mesh_free(&m);
        assert_null(m.positions);
    }
}

static void test_tetgen_zero_based(void **state)
{
    (void)state;
    tu_write_file("z.node", "4 3 0 0\n0 0 0 0\n1 1 0 0\n2 0 1 0\n3 0 0 1\n");
    const char *ele = tu_write_file("z.ele", "1 4 0\n0 0 1 2 3\n");
    defsim_mesh m = empty_mesh();
    TU_OK(defsim_mesh_load(ele, &m));
    assert_int_equal(m.vertex_count, 4);
    check_solid(&m, 1.0 / 6.0);
    defsim_mesh_free(&m);
}

static void test_tetgen_errors(void **state)
{
    (void)state;
    tu_write_file("bad.node", NODE);
    /* A tet refers to point 9 on line 3. */
    expect_error(tu_write_file("bad.ele", "2 4 1\n1 1 2 3 4 0\n2 1 2 3 9 0\n"),
                 DEFSIM_ERR_INVALID_MESH, 3);
    /* 7 nodes per tet: the header on line 2 (after a comment). */
    expect_error(tu_write_file("bad.ele", "# tets\n1 7 0\n1 1 2 3 4 5 6 1\n"),
                 DEFSIM_ERR_INVALID_MESH, 2);
    /* A missing value: the next line's tet number is read as a vertex. */
    expect_error(tu_write_file("bad.ele", "2 4 0\n1 1 2 3\n2 1 2 3 5\n"), DEFSIM_ERR_IO, 2);
    /* A tet repeats a vertex. */
    expect_error(tu_write_file("bad.ele", "1 4 0\n1 1 2 2 4\n"), DEFSIM_ERR_INVALID_MESH, 2);
    /* A degenerate (flat) tet on line 3. */
    tu_write_file("flat.node", "5 3 0 0\n1 0 0 0\n2 1 0 0\n3 0 1 0\n4 0 0 1\n5 1 1 0\n");
    expect_error(tu_write_file("flat.ele", "2 4 0\n1 1 2 3 4\n2 1 2 3 5\n"),
                 DEFSIM_ERR_INVALID_MESH, 3);
    /* A malformed coordinate on line 4 of the .node file. */
    tu_write_file("coord.node", "3 3 0 0\n1 0 0 0\n2 1 0 0\n3 0 x 0\n");
    tu_write_file("coord.ele", "1 4 0\n1 1 2 3 4\n");
    char p[300];
    snprintf(p, sizeof p, "%s/coord.node", tu_tmpdir);
    expect_error(p, DEFSIM_ERR_IO, 4);
    /* Two points with the same number (line numbers are not known then). */
    tu_write_file("dup.node", "4 3 0 0\n1 0 0 0\n2 1 0 0\n2 0 1 0\n4 0 0 1\n");
    snprintf(p, sizeof p, "%s/dup.ele", tu_tmpdir);
    tu_write_file("dup.ele", "1 4 0\n1 1 2 4 4\n");
    defsim_mesh m = empty_mesh();
    assert_int_equal(defsim_mesh_load(p, &m), DEFSIM_ERR_INVALID_MESH);
    /* 2-D .node file. */
    tu_write_file("flat2.node", "3 2 0 0\n1 0 0\n2 1 0\n3 0 1\n");
    tu_write_file("flat2.ele", "1 4 0\n1 1 2 3 4\n");
    snprintf(p, sizeof p, "%s/flat2.node", tu_tmpdir);
    expect_error(p, DEFSIM_ERR_INVALID_MESH, 1);
    /* The pair is incomplete, the name unknown, the argument bad. */
    tu_write_file("lonely.node", NODE);
    snprintf(p, sizeof p, "%s/lonely.node", tu_tmpdir);
    assert_int_equal(defsim_mesh_load(p, &m), DEFSIM_ERR_IO);
    snprintf(p, sizeof p, "%s/nothing", tu_tmpdir);
    assert_int_equal(defsim_mesh_load(p, &m), DEFSIM_ERR_INVALID_ARGUMENT);
    assert_int_equal(defsim_mesh_load(NULL, &m), DEFSIM_ERR_INVALID_ARGUMENT);
    assert_int_equal(defsim_mesh_load(p, NULL), DEFSIM_ERR_INVALID_ARGUMENT);
    m.size = 4;
    assert_int_equal(defsim_mesh_load(p, &m), DEFSIM_ERR_INVALID_ARGUMENT);
}

/* ------------------------------------------------------------------------------------------ */
/* Gmsh */

/* A 2x1x1-cell box as reference geometry. */
static defsim_mesh ref_box(void)
{
    defsim_mesh b = empty_mesh();
    const double lo[3] = {0, 0, 0}, hi[3] = {2, 1, 0.5};
    TU_OK(defsim_mesh_box(lo, hi, 2, 1, 1, &b));
    return b;
}

/* Node tags are 10 * (index + 1): sparse, so the loader must map them. */
#define TAG(i) (10 * ((i) + 1))

static char *gmsh_v2_text(const defsim_mesh *b, const char *extra_element)
{
    size_t cap = 1 << 16;
    char *s = malloc(cap);
    size_t n = 0;
    n += (size_t)snprintf(s + n, cap - n, "$MeshFormat\n2.2 0 8\n$EndMeshFormat\n"
                          "$PhysicalNames\n1\n3 1 \"solid\"\n$EndPhysicalNames\n"
                          "$Nodes\n%d\n", b->vertex_count);
    for (int i = 0; i < b->vertex_count; ++i)
        n += (size_t)snprintf(s + n, cap - n, "%d %.17g %.17g %.17g\n", TAG(i),
                              b->positions[3 * i], b->positions[3 * i + 1], b->positions[3 * i + 2]);
    int ne = b->tet_count + 3 + (extra_element ? 1 : 0);
    n += (size_t)snprintf(s + n, cap - n, "$EndNodes\n$Elements\n%d\n", ne);
    n += (size_t)snprintf(s + n, cap - n, "1 15 2 0 1 %d\n", TAG(0));            /* point */
    n += (size_t)snprintf(s + n, cap - n, "2 1 2 0 1 %d %d\n", TAG(0), TAG(1));  /* line */
    n += (size_t)snprintf(s + n, cap - n, "3 2 2 0 1 %d %d %d\n", TAG(0), TAG(1), TAG(3));
    for (int t = 0; t < b->tet_count; ++t) {
        const int32_t *q = b->tets + 4 * t;
        /* Odd tets are written with negative orientation. */
        if (t % 2)
            n += (size_t)snprintf(s + n, cap - n, "%d 4 2 1 1 %d %d %d %d\n", 4 + t, TAG(q[1]),
                                  TAG(q[0]), TAG(q[2]), TAG(q[3]));
        else
            n += (size_t)snprintf(s + n, cap - n, "%d 4 2 1 1 %d %d %d %d\n", 4 + t, TAG(q[0]),
                                  TAG(q[1]), TAG(q[2]), TAG(q[3]));
    }
    if (extra_element) n += (size_t)snprintf(s + n, cap - n, "%s\n", extra_element);
    snprintf(s + n, cap - n, "$EndElements\n");
    return s;
}

static void check_same_as_box(const defsim_mesh *m, const defsim_mesh *b)
{
    assert_int_equal(m->vertex_count, b->vertex_count);
    assert_int_equal(m->tet_count, b->tet_count);
    assert_int_equal(m->triangle_count, b->triangle_count);
    for (int i = 0; i < 3 * b->vertex_count; ++i)
        assert_near(m->positions[i], b->positions[i], 0.0);
    check_solid(m, 2.0 * 1.0 * 0.5);
}

static void test_gmsh_v2(void **state)
{
    (void)state;
    defsim_mesh b = ref_box();
    char *text = gmsh_v2_text(&b, NULL);
    defsim_mesh m = empty_mesh();
    TU_OK(defsim_mesh_load(tu_write_file("box.msh", text), &m));
    check_same_as_box(&m, &b);
    defsim_mesh_free(&m);
    free(text);

    /* Line of the first element: 3 header lines, 4 physical-name lines, $Nodes, count, nodes,
     * $EndNodes, $Elements, count. */
    const int first_elem = 3 + 4 + 2 + b.vertex_count + 1 + 2 + 1;
    const int extra = first_elem + 3 + b.tet_count;
    text = gmsh_v2_text(&b, "99 5 2 0 1 10 20 30 40 50 60 70 80");   /* a hexahedron */
    expect_error(tu_write_file("hex.msh", text), DEFSIM_ERR_INVALID_MESH, extra);
    free(text);
    text = gmsh_v2_text(&b, "99 11 2 0 1 10 20 30 40 50 60 70 80 90 100");   /* tet10 */
    expect_error(tu_write_file("tet10.msh", text), DEFSIM_ERR_INVALID_MESH, extra);
    free(text);
    text = gmsh_v2_text(&b, "99 4 2 0 1 10 20 30 777");   /* undefined node */
    expect_error(tu_write_file("undef.msh", text), DEFSIM_ERR_INVALID_MESH, extra);
    free(text);
    text = gmsh_v2_text(&b, "99 4 2 0 1 10 20 30");   /* too few nodes, then $EndElements */
    expect_error(tu_write_file("short.msh", text), DEFSIM_ERR_IO, extra + 1);
    free(text);
    expect_error(tu_write_file("bin.msh", "$MeshFormat\n2.2 1 8\n$EndMeshFormat\n"), DEFSIM_ERR_IO, 2);
    expect_error(tu_write_file("v3.msh", "$MeshFormat\n3.0 0 8\n$EndMeshFormat\n"), DEFSIM_ERR_IO, 2);
    expect_error(tu_write_file("notmsh.msh", "hello\n"), DEFSIM_ERR_IO, 1);
    /* Only surface elements: no tets at all. */
    expect_error(tu_write_file("surf.msh", "$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$Nodes\n3\n"
                            "1 0 0 0\n2 1 0 0\n3 0 1 0\n$EndNodes\n$Elements\n1\n"
                            "1 2 2 0 1 1 2 3\n$EndElements\n"),
                 DEFSIM_ERR_INVALID_MESH, 0);
    /* An unterminated section. */
    expect_error(tu_write_file("open.msh", "$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$Comments\n"
                            "bla\n"), DEFSIM_ERR_IO, 4);
    defsim_mesh_free(&b);
}

/* Quadratic tets from the files (issue 29): the reference is a 2x1x1-cell box made quadratic.
 * Each format writes it with the mid-edge nodes in an order of its own (Gmsh's type 11 swaps
 * VTK's last two; odd tets are written left-handed and with their mid-edge nodes rotated), and
 * the loader matches them to their edges by position: every loaded tet's node 4 + k is the middle
 * of its edge k in VTK's order, corners positively oriented, 4 boundary triangles per face. */
static void check_quadratic(const defsim_mesh *m, const defsim_mesh *b)
{
    assert_int_equal(m->tet_nodes, 10);
    assert_int_equal(m->vertex_count, b->vertex_count);
    assert_int_equal(m->tet_count, b->tet_count);
    assert_int_equal(m->triangle_count, b->triangle_count);
    for (int32_t t = 0; t < m->tet_count; ++t)
        for (int k = 0; k < 6; ++k) {
            const int32_t *q = m->tets + 10 * t;
            const double *a = m->positions + 3 * q[defsim__tet10_edge[k][0]];
            const double *c = m->positions + 3 * q[defsim__tet10_edge[k][1]];
            const double *mid = m->positions + 3 * q[4 + k];
            for (int i = 0; i < 3; ++i) assert_near(mid[i], 0.5 * (a[i] + c[i]), 1e-15);
        }
    check_solid(m, 2.0 * 1.0 * 0.5);
}

/* Tet t of the quadratic box as a file writes it: 10 tags (1-based + base), corners swapped and
 * mid-edge nodes rotated for odd t, else with the given order of the mid-edge nodes. */
static void quad_tet_tags(const defsim_mesh *b, int32_t t, const int order[6], long long base,
                          long long out[10])
{
    const int32_t *q = b->tets + 10 * t;
    for (int a = 0; a < 4; ++a) out[a] = q[a] + base;
    if (t % 2) { long long x = out[0]; out[0] = out[1]; out[1] = x; }
    for (int k = 0; k < 6; ++k) out[4 + k] = q[4 + (t % 2 ? (order[k] + 1) % 6 : order[k])] + base;
}

/* Appends one line per tet of b at s + n: its number (from base), `after` (a Gmsh v2 element's
 * type and tags), its 10 tags; returns the new length. */
static size_t put_quad_tets(char *s, size_t cap, size_t n, const defsim_mesh *b, const int order[6],
                            long long base, const char *after)
{
    for (int t = 0; t < b->tet_count; ++t) {
        long long v[10];
        quad_tet_tags(b, t, order, base, v);
        n += (size_t)snprintf(s + n, cap - n, "%lld%s", t + base, after);
        for (int a = 0; a < 10; ++a) n += (size_t)snprintf(s + n, cap - n, " %lld", v[a]);
        n += (size_t)snprintf(s + n, cap - n, "\n");
    }
    return n;
}

static void test_quadratic_files(void **state)
{
    (void)state;
    defsim_mesh b = ref_box();
    TU_OK(defsim_mesh_make_quadratic(&b));
    static const int gmsh_order[6] = {0, 1, 2, 3, 5, 4};   /* Gmsh: 01 12 02 03 23 13 */
    static const int scrambled[6] = {3, 0, 5, 1, 4, 2};
    size_t cap = 1 << 17;
    char *s = malloc(cap);
    /* Gmsh 2.2, type 11 */
    size_t n = (size_t)snprintf(s, cap, "$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$Nodes\n%d\n",
                                b.vertex_count);
    for (int i = 0; i < b.vertex_count; ++i)
        n += (size_t)snprintf(s + n, cap - n, "%d %.17g %.17g %.17g\n", i + 1, b.positions[3 * i],
                              b.positions[3 * i + 1], b.positions[3 * i + 2]);
    n += (size_t)snprintf(s + n, cap - n, "$EndNodes\n$Elements\n%d\n", b.tet_count);
    n = put_quad_tets(s, cap, n, &b, gmsh_order, 1, " 11 2 1 1");
    snprintf(s + n, cap - n, "$EndElements\n");
    defsim_mesh m = empty_mesh();
    TU_OK(defsim_mesh_load(tu_write_file("q2.msh", s), &m));
    check_quadratic(&m, &b);
    defsim_mesh_free(&m);
    /* Gmsh 4.1: one node block, one type-11 block */
    n = (size_t)snprintf(s, cap, "$MeshFormat\n4.1 0 8\n$EndMeshFormat\n$Nodes\n1 %d 1 %d\n"
                         "3 1 0 %d\n", b.vertex_count, b.vertex_count, b.vertex_count);
    for (int i = 0; i < b.vertex_count; ++i) n += (size_t)snprintf(s + n, cap - n, "%d\n", i + 1);
    for (int i = 0; i < b.vertex_count; ++i)
        n += (size_t)snprintf(s + n, cap - n, "%.17g %.17g %.17g\n", b.positions[3 * i],
                              b.positions[3 * i + 1], b.positions[3 * i + 2]);
    n += (size_t)snprintf(s + n, cap - n, "$EndNodes\n$Elements\n1 %d 1 %d\n3 1 11 %d\n",
                          b.tet_count, b.tet_count, b.tet_count);
    n = put_quad_tets(s, cap, n, &b, gmsh_order, 1, "");
    snprintf(s + n, cap - n, "$EndElements\n");
    m = empty_mesh();
    TU_OK(defsim_mesh_load(tu_write_file("q4.msh", s), &m));
    check_quadratic(&m, &b);
    defsim_mesh_free(&m);
    /* TetGen -o2, 0-based, mid-edge nodes scrambled */
    n = (size_t)snprintf(s, cap, "%d 3 0 0\n", b.vertex_count);
    for (int i = 0; i < b.vertex_count; ++i)
        n += (size_t)snprintf(s + n, cap - n, "%d %.17g %.17g %.17g\n", i, b.positions[3 * i],
                              b.positions[3 * i + 1], b.positions[3 * i + 2]);
    tu_write_file("q.node", s);
    n = (size_t)snprintf(s, cap, "%d 10 0\n", b.tet_count);
    n = put_quad_tets(s, cap, n, &b, scrambled, 0, "");
    m = empty_mesh();
    TU_OK(defsim_mesh_load(tu_write_file("q.ele", s), &m));
    check_quadratic(&m, &b);
    defsim_mesh_free(&m);
    /* a mid-edge node that is no edge's middle (edge 23's, moved next to edge 01's): two edges
     * pick one node (the tet on line 2) */
    tu_write_file("off.node", "10 3 0 0\n0 0 0 0\n1 1 0 0\n2 0 1 0\n3 0 0 1\n4 0.5 0 0\n"
                              "5 0.5 0.5 0\n6 0 0.5 0\n7 0 0 0.5\n8 0.5 0 0.5\n9 0.5 0.02 0\n");
    expect_error(tu_write_file("off.ele", "1 10 0\n0 1 0 2 3 4 5 6 7 8 9\n"),
                 DEFSIM_ERR_INVALID_MESH, 2);
    /* mixing linear and quadratic tets in one Gmsh file (line 14) */
    expect_error(tu_write_file("mix.msh", "$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$Nodes\n4\n"
                               "1 0 0 0\n2 1 0 0\n3 0 1 0\n4 0 0 1\n$EndNodes\n$Elements\n2\n"
                               "1 4 2 0 1 1 2 3 4\n2 11 2 0 1 1 2 3 4 1 2 3 4 1 2\n"
                               "$EndElements\n"), DEFSIM_ERR_INVALID_MESH, 14);
    free(s);
    defsim_mesh_free(&b);
}

/* Gmsh 4.1 (minor 1) or 4.0 (minor 0): a point entity, a curve with parametric nodes, the
 * volume's nodes, a surface triangle block and a tet block (split in two blocks). */
static char *gmsh_v4_text(const defsim_mesh *b, int minor, const char *extra_block)
{
    size_t cap = 1 << 16;
    char *s = malloc(cap);
    size_t n = 0;
    const int nv = b->vertex_count;
    n += (size_t)snprintf(s + n, cap - n, "$MeshFormat\n4.%d 0 8\n$EndMeshFormat\n"
                          "$Entities\n1 1 1 1\n1 0 0 0 0\n$EndEntities\n", minor);
    /* Blocks: node 0 on a point (dim 0), node 1 on a curve (dim 1, parametric), the rest. */
    if (minor == 1)
        n += (size_t)snprintf(s + n, cap - n, "$Nodes\n3 %d %d %d\n", nv, TAG(0), TAG(nv - 1));
    else
        n += (size_t)snprintf(s + n, cap - n, "$Nodes\n3 %d\n", nv);
    struct { int dim, first, count, param; } blocks[3] = {{0, 0, 1, 0}, {1, 1, 1, 1}, {3, 2, nv - 2, 0}};
    for (int k = 0; k < 3; ++k) {
        const int d = blocks[k].dim, f = blocks[k].first, c = blocks[k].count, p = blocks[k].param;
        if (minor == 1) {
            n += (size_t)snprintf(s + n, cap - n, "%d %d %d %d\n", d, k + 1, p, c);
            for (int i = f; i < f + c; ++i) n += (size_t)snprintf(s + n, cap - n, "%d\n", TAG(i));
            for (int i = f; i < f + c; ++i)
                n += (size_t)snprintf(s + n, cap - n, "%.17g %.17g %.17g%s\n", b->positions[3 * i],
                                      b->positions[3 * i + 1], b->positions[3 * i + 2],
                                      p ? " 0.25" : "");
        } else {
            n += (size_t)snprintf(s + n, cap - n, "%d %d %d %d\n", k + 1, d, p, c);
            for (int i = f; i < f + c; ++i)
                n += (size_t)snprintf(s + n, cap - n, "%d %.17g %.17g %.17g%s\n", TAG(i),
                                      b->positions[3 * i], b->positions[3 * i + 1],
                                      b->positions[3 * i + 2], p ? " 0.25" : "");
        }
    }
    const int half = b->tet_count / 2;
    const int nblocks = 3 + (extra_block ? 1 : 0);
    if (minor == 1)
        n += (size_t)snprintf(s + n, cap - n, "$EndNodes\n$Elements\n%d %d 1 %d\n", nblocks,
                              b->tet_count + 1, b->tet_count + 1);
    else
        n += (size_t)snprintf(s + n, cap - n, "$EndNodes\n$Elements\n%d %d\n", nblocks,
                              b->tet_count + 1);
    n += (size_t)snprintf(s + n, cap - n, minor == 1 ? "2 1 2 1\n" : "1 2 2 1\n");
    n += (size_t)snprintf(s + n, cap - n, "1 %d %d %d\n", TAG(0), TAG(1), TAG(3));
    for (int k = 0; k < 2; ++k) {
        int t0 = k ? half : 0, t1 = k ? b->tet_count : half;
        n += (size_t)snprintf(s + n, cap - n, minor == 1 ? "3 1 4 %d\n" : "1 3 4 %d\n", t1 - t0);
        for (int t = t0; t < t1; ++t) {
            const int32_t *q = b->tets + 4 * t;
            n += (size_t)snprintf(s + n, cap - n, "%d %d %d %d %d\n", 2 + t, TAG(q[0]), TAG(q[1]),
                                  TAG(q[2]), TAG(q[3]));
        }
    }
    if (extra_block) n += (size_t)snprintf(s + n, cap - n, "%s\n", extra_block);
    snprintf(s + n, cap - n, "$EndElements\n");
    return s;
}

static void test_gmsh_v4(void **state)
{
    (void)state;
    defsim_mesh b = ref_box();
    for (int minor = 0; minor <= 1; ++minor) {
        char *text = gmsh_v4_text(&b, minor, NULL);
        defsim_mesh m = empty_mesh();
        TU_OK(defsim_mesh_load(tu_write_file("box4.msh", text), &m));
        check_same_as_box(&m, &b);
        defsim_mesh_free(&m);
        free(text);
        /* Line of an extra block header: header 3 + entities 4 + ($Nodes, counts, blocks)
         * + $EndNodes + $Elements + counts + triangle block 2 + tet blocks. */
        const int nv = b.vertex_count;
        const int node_lines = minor == 1 ? 3 + 2 * nv : 3 + nv;
        const int extra = 3 + 4 + 2 + node_lines + 3 + 2 + 2 + b.tet_count + 1;
        text = gmsh_v4_text(&b, minor, minor == 1 ? "3 1 6 1\n99 10 20 30 40 50 60"
                                                  : "1 3 6 1\n99 10 20 30 40 50 60");
        expect_error(tu_write_file("prism4.msh", text), DEFSIM_ERR_INVALID_MESH, extra);
        free(text);
        text = gmsh_v4_text(&b, minor, minor == 1 ? "3 1 4 1\n99 10 20 30 555"
                                                  : "1 3 4 1\n99 10 20 30 555");
        expect_error(tu_write_file("undef4.msh", text), DEFSIM_ERR_INVALID_MESH, extra + 1);
        free(text);
    }
    defsim_mesh_free(&b);
}

/* ------------------------------------------------------------------------------------------ */
/* OBJ */

static int has_spring(const defsim_mesh *m, int a, int b)
{
    for (int s = 0; s < m->spring_count; ++s)
        if ((m->springs[2 * s] == a && m->springs[2 * s + 1] == b) ||
            (m->springs[2 * s] == b && m->springs[2 * s + 1] == a))
            return 1;
    return 0;
}

static void test_obj(void **state)
{
    (void)state;
    /* A unit square as two triangles in v/vt/vn and v//vn forms, then a pentagon with relative
     * indices (fan: 3 triangles), a continued line, an unused vertex, and a polyline. */
    const char *obj =
        "# square\n"
        "mtllib none.mtl\n"
        "o cloth\n"
        "v 0 0 0\n"
        "v 1 0 0\n"
        "v 1 1 0 1.0\n"
        "v 0 1 0 0.5 0.5 0.5\n"
        "vt 0 0\nvn 0 0 1\n"
        "usemtl a\ns off\n"
        "f 1/1/1 2/1/1 3/1/1\n"
        "f 1//1 3//1 4//1   # second\n"
        "v 5 0 0\n"
        "v 6 0 0\n"
        "v 6 1 0\n"
        "v 5.5 2 0\n"
        "v 5 1 0\n"
        "v 99 99 99\n"
        "f -6 -5 \\\n"
        "  -4 -3 -2\n"
        "l 2 5 -1\n";
    defsim_mesh m = empty_mesh();
    TU_OK(defsim_mesh_load(tu_write_file("cloth.obj", obj), &m));
    assert_int_equal(m.vertex_count, 10);   /* the 11th (99, 99, 99) is on the polyline */
    assert_int_equal(m.tet_count, 0);
    assert_int_equal(m.triangle_count, 2 + 3);
    const int32_t tris[15] = {0, 1, 2, 0, 2, 3, 4, 5, 6, 4, 6, 7, 4, 7, 8};
    for (int i = 0; i < 15; ++i) assert_int_equal(m.triangles[i], tris[i]);
    /* Edges: square 5, pentagon 5 + 2 diagonals, polyline 2 (1-4 and 4-9). */
    assert_int_equal(m.spring_count, 5 + 7 + 2);
    assert_true(has_spring(&m, 0, 2));
    assert_true(has_spring(&m, 4, 6));
    assert_true(has_spring(&m, 1, 4));
    assert_true(has_spring(&m, 4, 9));
    assert_false(has_spring(&m, 1, 3));
    for (int s = 1; s < m.spring_count; ++s) {   /* sorted, unique */
        const int32_t *p = m.springs + 2 * (s - 1), *q = m.springs + 2 * s;
        assert_true(p[0] < p[1] && q[0] < q[1]);
        assert_true(p[0] < q[0] || (p[0] == q[0] && p[1] < q[1]));
    }
    assert_near(m.positions[3 * 9], 99.0, 0.0);
    assert_near(m.positions[3 * 7 + 1], 2.0, 0.0);

    /* The springs make a valid spring body, at rest with zero elastic force. */
    defsim_world *w = tu_world("symplectic_euler", 0.0, 1);
    assert_int_equal(m.tet_count, 0);
    const defsim_body_def bd = test_mesh_body(&m, DEFSIM_MODEL_SPRING);
    TU_OK(defsim_world_add_body(w, &bd, NULL));
    double f[30];
    TU_OK(defsim_world_forces(w, NULL, f));
    for (int i = 0; i < 30; ++i) assert_near(f[i], 0.0, 1e-12);
    defsim_world_destroy(w);
    defsim_mesh_free(&m);
}

static void test_obj_errors(void **state)
{
    (void)state;
    /* Three vertices (lines 1-3) with a statement before and after them. */
    static const struct { const char *before, *after; defsim_status st; int line; } cases[] = {
        {"", "# c\nf 1 2 4\n", DEFSIM_ERR_INVALID_MESH, 5},
        {"", "f 1 2 0\n", DEFSIM_ERR_IO, 4},
        {"", "f 1 2\n", DEFSIM_ERR_INVALID_MESH, 4},
        {"", "f -1 -2 -4\n", DEFSIM_ERR_INVALID_MESH, 4},
        {"", "f 1 2 2\n", DEFSIM_ERR_INVALID_MESH, 4},
        {"v 0 0\n", "f 1 2 3\n", DEFSIM_ERR_IO, 1},
        {"", "v 0 0 0\nf 1 2 4\n", DEFSIM_ERR_INVALID_MESH, 5},   /* vertices 1 and 4 coincide */
        {"", "f a b c\n", DEFSIM_ERR_IO, 4},
        {"", "", DEFSIM_ERR_INVALID_MESH, 0},
    };
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; ++i) {
        char text[256], name[16];
        snprintf(text, sizeof text, "%sv 0 0 0\nv 1 0 0\nv 0 1 0\n%s", cases[i].before,
                 cases[i].after);
        snprintf(name, sizeof name, "e%zu.obj", i + 1);
        expect_error(tu_write_file(name, text), cases[i].st, cases[i].line);
    }
}

/* ------------------------------------------------------------------------------------------ */
/* Generators */

static double len(const defsim_mesh *m, int s)
{
    const double *a = m->positions + 3 * m->springs[2 * s], *b = m->positions + 3 * m->springs[2 * s + 1];
    return sqrt((a[0] - b[0]) * (a[0] - b[0]) + (a[1] - b[1]) * (a[1] - b[1]) +
                (a[2] - b[2]) * (a[2] - b[2]));
}

static void test_cloth(void **state)
{
    (void)state;
    const double o[3] = {1, 2, 3}, u[3] = {0.6, 0, 0}, v[3] = {0, 0, -0.4};
    const int nu = 3, nv = 4;
    defsim_mesh m = empty_mesh();
    TU_OK(defsim_mesh_cloth(o, u, v, nu, nv, &m));
    assert_int_equal(m.vertex_count, 4 * 5);
    assert_int_equal(m.triangle_count, 2 * 12);
    const int ns_u = nu * (nv + 1), ns_v = (nu + 1) * nv, nsh = 2 * nu * nv;
    const int nb_u = (nu - 1) * (nv + 1), nb_v = (nu + 1) * (nv - 1);
    assert_int_equal(m.spring_count, ns_u + ns_v + nsh + nb_u + nb_v);
    /* Vertex (i, j) sits at o + i/nu u + j/nv v. */
    const double *p = m.positions + 3 * (2 + 4 * 3);
    assert_near(p[0], 1.0 + 0.4, 1e-15);
    assert_near(p[1], 2.0, 0.0);
    assert_near(p[2], 3.0 - 0.3, 1e-15);
    /* Rest lengths by kind, in the documented order. */
    const double du = 0.2, dv = 0.1, dd = sqrt(du * du + dv * dv);
    int s = 0;
    for (int k = 0; k < ns_u; ++k) assert_near(len(&m, s++), du, 1e-14);
    for (int k = 0; k < ns_v; ++k) assert_near(len(&m, s++), dv, 1e-14);
    for (int k = 0; k < nsh; ++k) assert_near(len(&m, s++), dd, 1e-14);
    for (int k = 0; k < nb_u; ++k) assert_near(len(&m, s++), 2 * du, 1e-14);
    for (int k = 0; k < nb_v; ++k) assert_near(len(&m, s++), 2 * dv, 1e-14);
    /* Triangles: normals along u x v = (0, 0.24, 0), total area |u x v|. */
    double area = 0.0;
    for (int t = 0; t < m.triangle_count; ++t) {
        const double *a = m.positions + 3 * m.triangles[3 * t];
        const double *b = m.positions + 3 * m.triangles[3 * t + 1];
        const double *c = m.positions + 3 * m.triangles[3 * t + 2];
        double e1[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]};
        double e2[3] = {c[0] - a[0], c[1] - a[1], c[2] - a[2]};
        double ny = e1[2] * e2[0] - e1[0] * e2[2];
        assert_true(ny > 0.0);
        area += 0.5 * ny;
    }
    assert_near(area, 0.24, 1e-14);
    /* Every triangle edge is a structural or shear spring. */
    for (int t = 0; t < m.triangle_count; ++t)
        for (int a = 0; a < 3; ++a) {
            int x = m.triangles[3 * t + a], y = m.triangles[3 * t + (a + 1) % 3], found = 0;
            for (int k = 0; k < ns_u + ns_v + nsh && !found; ++k)
                found = (m.springs[2 * k] == x && m.springs[2 * k + 1] == y) ||
                        (m.springs[2 * k] == y && m.springs[2 * k + 1] == x);
            assert_true(found);
        }
    defsim_mesh_free(&m);

    /* One cell: no bending springs. */
    TU_OK(defsim_mesh_cloth(o, u, v, 1, 1, &m));
    assert_int_equal(m.spring_count, 2 + 2 + 2);
    defsim_mesh_free(&m);
    assert_int_equal(defsim_mesh_cloth(o, u, u, 2, 2, &m), DEFSIM_ERR_INVALID_ARGUMENT);
    assert_int_equal(defsim_mesh_cloth(o, u, v, 0, 2, &m), DEFSIM_ERR_INVALID_ARGUMENT);
    assert_int_equal(defsim_mesh_cloth(NULL, u, v, 2, 2, &m), DEFSIM_ERR_INVALID_ARGUMENT);
    const double bad[3] = {NAN, 0, 0};
    assert_int_equal(defsim_mesh_cloth(bad, u, v, 2, 2, &m), DEFSIM_ERR_INVALID_ARGUMENT);
    assert_null(m.positions);
}

static void test_rope(void **state)
{
    (void)state;
    const double a[3] = {0, 1, 0}, b[3] = {2, 1, 0};
    defsim_mesh m = empty_mesh();
    TU_OK(defsim_mesh_rope(a, b, 8, &m));
    assert_int_equal(m.vertex_count, 9);
    assert_int_equal(m.spring_count, 8 + 7);
    assert_int_equal(m.tet_count, 0);
    assert_int_equal(m.triangle_count, 0);
    for (int s = 0; s < 8; ++s) {
        assert_int_equal(m.springs[2 * s], s);
        assert_int_equal(m.springs[2 * s + 1], s + 1);
        assert_near(len(&m, s), 0.25, 1e-15);
    }
    for (int s = 8; s < 15; ++s) {
        assert_int_equal(m.springs[2 * s + 1] - m.springs[2 * s], 2);
        assert_near(len(&m, s), 0.5, 1e-15);
    }
    assert_near(m.positions[3 * 8], 2.0, 0.0);

    /* A rope hanging from one end, heavily damped, settles to a static state in which the top
     * spring carries the weight of everything below it: k (l - l0) = (n - 1) m g (straight). */
    defsim_world *w = tu_world("symplectic_euler", -9.81, 1);
    const double top[3] = {0, 0, 0}, bottom[3] = {0, -1, 0};
    defsim_mesh r = empty_mesh();
    TU_OK(defsim_mesh_rope(top, bottom, 4, &r));
    defsim_body_def bd;
    defsim_body_def_init(&bd, sizeof bd);
    bd.rest_positions = r.positions;
    bd.vertex_count = r.vertex_count;
    bd.springs = r.springs;
    bd.spring_count = 4;   /* links only */
    defsim_material_init(&bd.material, sizeof bd.material, DEFSIM_MODEL_SPRING);
    bd.material.stiffness = 100.0;
    bd.material.vertex_mass = 0.01;
    bd.material.mass_damping = 20.0;
    defsim_body_id id;
    TU_OK(defsim_world_add_body(w, &bd, &id));
    const int32_t pin = 0;
    TU_OK(defsim_body_pin(w, id, &pin, 1));
    for (int i = 0; i < 20000; ++i) TU_OK(defsim_world_step(w, 1e-3));
    double x[15];
    TU_OK(defsim_world_get_positions(w, x, 5));
    const double stretch = 4 * 0.01 * 9.81 / 100.0;
    assert_near(-x[3 * 1 + 1], 0.25 + stretch, 1e-9);
    defsim_world_destroy(w);
    defsim_mesh_free(&r);

    assert_int_equal(defsim_mesh_rope(a, a, 3, &m), DEFSIM_ERR_INVALID_ARGUMENT);
    assert_int_equal(defsim_mesh_rope(a, b, 0, &m), DEFSIM_ERR_INVALID_ARGUMENT);
    assert_int_equal(defsim_mesh_rope(a, b, 3, NULL), DEFSIM_ERR_INVALID_ARGUMENT);
    defsim_mesh_free(&m);
}

/* Spring kinds: the cloth and rope report each spring's kind in the documented order, a body
 * takes a stiffness per kind, and a uniform stretch by (1 + e) stores
 * e^2 / 2 sum_kind k_kind sum l0^2 (computed here from the rest lengths by kind). */
static void test_spring_kinds(void **state)
{
    (void)state;
    const double o[3] = {0, 0, 0}, u[3] = {0.6, 0, 0}, v[3] = {0, 0, -0.4};
    const int nu = 3, nv = 4;
    defsim_mesh m = empty_mesh();
    TU_OK(defsim_mesh_cloth(o, u, v, nu, nv, &m));
    assert_non_null(m.spring_kinds);
    const int ns_u = nu * (nv + 1), ns_v = (nu + 1) * nv, nsh = 2 * nu * nv;
    const double du = 0.2, dv = 0.1;
    double sum_l2[3] = {0, 0, 0};
    for (int s = 0; s < m.spring_count; ++s) {
        const int32_t kind = m.spring_kinds[s];
        assert_int_equal(kind, s < ns_u + ns_v ? DEFSIM_SPRING_STRETCH
                               : s < ns_u + ns_v + nsh ? DEFSIM_SPRING_SHEAR : DEFSIM_SPRING_BEND);
        const double l = len(&m, s);
        /* Kinds agree with the geometry: bending springs span two cells, shear ones a diagonal. */
        if (kind == DEFSIM_SPRING_BEND) assert_true(fabs(l - 2 * du) < 1e-12 || fabs(l - 2 * dv) < 1e-12);
        if (kind == DEFSIM_SPRING_SHEAR) assert_near(l, sqrt(du * du + dv * dv), 1e-12);
        sum_l2[kind] += l * l;
    }
    const double k[3] = {300.0, 40.0, 5.0}, e = 0.01;
    defsim_world *w = tu_world("symplectic_euler", 0.0, 1);
    defsim_body_def bd;
    defsim_body_def_init(&bd, sizeof bd);
    assert_true(bd.shear_stiffness < 0.0 && bd.bend_stiffness < 0.0 && bd.spring_kinds == NULL);
    bd.rest_positions = m.positions;
    bd.vertex_count = m.vertex_count;
    bd.springs = m.springs;
    bd.spring_count = m.spring_count;
    bd.spring_kinds = m.spring_kinds;
    bd.shear_stiffness = k[DEFSIM_SPRING_SHEAR];
    bd.bend_stiffness = k[DEFSIM_SPRING_BEND];
    defsim_material_init(&bd.material, sizeof bd.material, DEFSIM_MODEL_SPRING);
    bd.material.stiffness = k[DEFSIM_SPRING_STRETCH];
    bd.material.vertex_mass = 0.01;
    TU_OK(defsim_world_add_body(w, &bd, NULL));
    double *x = malloc(3 * (size_t)m.vertex_count * sizeof *x);
    assert_non_null(x);
    for (int i = 0; i < 3 * m.vertex_count; ++i) x[i] = (1.0 + e) * m.positions[i];
    TU_OK(defsim_world_set_state(w, x, NULL));
    defsim_energy en;
    TU_OK(defsim_world_energy(w, &en));
    const double want = 0.5 * e * e * (k[0] * sum_l2[0] + k[1] * sum_l2[1] + k[2] * sum_l2[2]);
    assert_near(en.elastic, want, 1e-12 * want);

    /* Kinds left at their default stiffness take material.stiffness. */
    bd.shear_stiffness = bd.bend_stiffness = -1.0;
    TU_OK(defsim_world_add_body(w, &bd, NULL));
    /* Misuse: both per-spring stiffness and kinds; a kind outside the enum. */
    const int32_t nw = defsim_world_vertex_count(w);
    bd.spring_stiffness = x;
    assert_int_equal(defsim_world_add_body(w, &bd, NULL), DEFSIM_ERR_INVALID_ARGUMENT);
    bd.spring_stiffness = NULL;
    int32_t *bad = malloc((size_t)m.spring_count * sizeof *bad);
    assert_non_null(bad);
    memcpy(bad, m.spring_kinds, (size_t)m.spring_count * sizeof *bad);
    bad[m.spring_count - 1] = 7;
    bd.spring_kinds = bad;
    assert_int_equal(defsim_world_add_body(w, &bd, NULL), DEFSIM_ERR_INVALID_MESH);
    assert_int_equal(defsim_world_vertex_count(w), nw);
    free(bad);
    free(x);
    defsim_world_destroy(w);
    defsim_mesh_free(&m);
    assert_null(m.spring_kinds);

    /* Rope: links then bending springs. */
    const double a[3] = {0, 0, 0}, b[3] = {1, 0, 0};
    TU_OK(defsim_mesh_rope(a, b, 5, &m));
    for (int s = 0; s < m.spring_count; ++s)
        assert_int_equal(m.spring_kinds[s], s < 5 ? DEFSIM_SPRING_STRETCH : DEFSIM_SPRING_BEND);
    defsim_mesh_free(&m);

    /* A caller compiled before spring_kinds existed passes the older, smaller size: the mesh is
     * made and nothing past its struct is written. */
    unsigned char buf[sizeof(defsim_mesh) + 16];
    memset(buf, 0xAB, sizeof buf);
    defsim_mesh *old = (defsim_mesh *)(void *)buf;
    old->size = (uint32_t)offsetof(defsim_mesh, spring_kinds);
    TU_OK(defsim_mesh_cloth(o, u, v, 2, 2, old));
    assert_int_equal(old->spring_count, 2 * 3 + 3 * 2 + 8 + 3 + 3);
    for (size_t i = offsetof(defsim_mesh, spring_kinds); i < sizeof buf; ++i)
        assert_int_equal(buf[i], 0xAB);
    defsim_mesh_free(old);
    for (size_t i = offsetof(defsim_mesh, spring_kinds); i < sizeof buf; ++i)
        assert_int_equal(buf[i], 0xAB);
}

/* ------------------------------------------------------------------------------------------ */
/* Input bounds (issue 17): regular files only, limits, coordinates */

/* The load fails with `want` and a message containing `text`. Only for files that are not
 * regular, where the status (DEFSIM_ERR_IO) was the same before the check: the old reader read
 * /dev/zero up to its 1 GiB limit and a folder until fread failed. */
static void expect_message(const char *path, defsim_status want, const char *text)
{
    defsim_mesh m = empty_mesh();
    assert_int_equal(defsim_mesh_load(path, &m), want);
    print_message("    %s\n", defsim_last_error());
    assert_non_null(strstr(defsim_last_error(), text));
    assert_null(m.positions);
}

static void test_not_regular_files(void **state)
{
    (void)state;
    char p[300];
    /* A file that never ends: refused before reading a byte (it used to read up to 1 GiB). */
    snprintf(p, sizeof p, "%s/zero.obj", tu_tmpdir);
    assert_int_equal(symlink("/dev/zero", p), 0);
    expect_message(p, DEFSIM_ERR_IO, "not a regular file");
    /* A FIFO without a writer: opening it used to block for ever (the alarm fails the test). */
    snprintf(p, sizeof p, "%s/fifo.msh", tu_tmpdir);
    assert_int_equal(mkfifo(p, 0600), 0);
    alarm(20);
    expect_message(p, DEFSIM_ERR_IO, "not a regular file");
    /* TetGen: the .ele of the pair is a FIFO. */
    tu_write_file("pair.node", "4 3 0 0\n1 0 0 0\n2 1 0 0\n3 0 1 0\n4 0 0 1\n");
    snprintf(p, sizeof p, "%s/pair.ele", tu_tmpdir);
    assert_int_equal(mkfifo(p, 0600), 0);
    expect_message(p, DEFSIM_ERR_IO, "not a regular file");
    alarm(0);
    /* A folder named like a mesh. */
    snprintf(p, sizeof p, "%s/dir.obj", tu_tmpdir);
    assert_int_equal(mkdir(p, 0700), 0);
    expect_message(p, DEFSIM_ERR_IO, "directory");
}

static void test_limits(void **state)
{
    (void)state;
    assert_int_equal(defsim_get_limit(DEFSIM_LIMIT_FILE_BYTES), 1 << 30);
    assert_int_equal(defsim_get_limit(DEFSIM_LIMIT_VERTICES), 10000000);
    assert_int_equal(defsim_get_limit(DEFSIM_LIMIT_ELEMENTS), 50000000);
    assert_int_equal(defsim_get_limit((defsim_limit)7), -1);
    /* Out of range: refused, nothing changes. */
    assert_int_equal(defsim_set_limit(DEFSIM_LIMIT_VERTICES, 0), DEFSIM_ERR_INVALID_ARGUMENT);
    assert_int_equal(defsim_set_limit(DEFSIM_LIMIT_VERTICES, INT32_MAX / 3 + 1),
                     DEFSIM_ERR_INVALID_ARGUMENT);
    assert_int_equal(defsim_set_limit(DEFSIM_LIMIT_ELEMENTS, INT32_MAX / 6 + 1),
                     DEFSIM_ERR_INVALID_ARGUMENT);
    assert_int_equal(defsim_set_limit((defsim_limit)-1, 5), DEFSIM_ERR_INVALID_ARGUMENT);
    assert_int_equal(defsim_get_limit(DEFSIM_LIMIT_VERTICES), 10000000);

    /* 4 vertices and a quad (2 triangles) in 42 bytes. */
    const char *quad = tu_write_file("quad.obj", "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\n");
    defsim_mesh m = empty_mesh();
    TU_OK(defsim_set_limit(DEFSIM_LIMIT_FILE_BYTES, 42));
    TU_OK(defsim_mesh_load(quad, &m));   /* exactly at the limit */
    defsim_mesh_free(&m);
    TU_OK(defsim_set_limit(DEFSIM_LIMIT_FILE_BYTES, 41));
    expect_error(quad, DEFSIM_ERR_IO, 0);
    TU_OK(defsim_set_limit(DEFSIM_LIMIT_FILE_BYTES, 1 << 30));

    TU_OK(defsim_set_limit(DEFSIM_LIMIT_VERTICES, 4));
    TU_OK(defsim_mesh_load(quad, &m));
    defsim_mesh_free(&m);
    TU_OK(defsim_set_limit(DEFSIM_LIMIT_VERTICES, 3));
    expect_error(quad, DEFSIM_ERR_INVALID_MESH, 4);   /* the fourth vertex */
    TU_OK(defsim_set_limit(DEFSIM_LIMIT_VERTICES, 10000000));

    TU_OK(defsim_set_limit(DEFSIM_LIMIT_ELEMENTS, 2));
    TU_OK(defsim_mesh_load(quad, &m));
    defsim_mesh_free(&m);
    TU_OK(defsim_set_limit(DEFSIM_LIMIT_ELEMENTS, 1));
    expect_error(quad, DEFSIM_ERR_INVALID_MESH, 5);   /* the quad's second triangle */
    /* The same for tets (TetGen) and for Gmsh nodes. */
    tu_write_file("lim.node", "5 3 0 0\n1 0 0 0\n2 1 0 0\n3 0 1 0\n4 0 0 1\n5 0 0 -1\n");
    expect_error(tu_write_file("lim.ele", "2 4 0\n1 1 2 3 4\n2 1 3 2 5\n"),
                 DEFSIM_ERR_INVALID_MESH, 3);
    TU_OK(defsim_set_limit(DEFSIM_LIMIT_ELEMENTS, 50000000));
    TU_OK(defsim_set_limit(DEFSIM_LIMIT_VERTICES, 4));
    expect_error(tu_write_file("lim.msh", "$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$Nodes\n5\n"
                               "1 0 0 0\n2 1 0 0\n3 0 1 0\n4 0 0 1\n5 0 0 -1\n$EndNodes\n"),
                 DEFSIM_ERR_INVALID_MESH, 10);
    TU_OK(defsim_set_limit(DEFSIM_LIMIT_VERTICES, 10000000));
}

static void test_huge_coordinates(void **state)
{
    (void)state;
    /* +-1e308 used to load and fail only at the first step (differences overflow to inf). */
    expect_error(tu_write_file("far.obj", "v -1e308 0 0\nv 1e308 0 0\nv 0 1 0\nf 1 2 3\n"),
                 DEFSIM_ERR_INVALID_MESH, 1);
    expect_error(tu_write_file("far2.obj", "v 0 0 0\nv 1 0 0\nv 0 1 -2e100\nf 1 2 3\n"),
                 DEFSIM_ERR_INVALID_MESH, 3);
    tu_write_file("far.node", "4 3 0 0\n1 0 0 0\n2 1e101 0 0\n3 0 1 0\n4 0 0 1\n");
    expect_error(tu_write_file("far.ele", "1 4 0\n1 1 2 3 4\n"), DEFSIM_ERR_INVALID_MESH, 3);
    expect_error(tu_write_file("far.msh", "$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$Nodes\n4\n"
                               "1 0 0 0\n2 1 0 0\n3 0 -1e300 0\n4 0 0 1\n$EndNodes\n"),
                 DEFSIM_ERR_INVALID_MESH, 8);
    /* At the bound the mesh loads and its volume is finite: (1e100)^3 / 6. */
    defsim_mesh m = empty_mesh();
    TU_OK(defsim_mesh_load(tu_write_file("big.obj", "v 0 0 0\nv 1e100 0 0\nv 0 1e100 0\n"
                                         "f 1 2 3\n"), &m));
    assert_near(m.positions[3], 1e100, 0.0);
    defsim_mesh_free(&m);
    tu_write_file("big.node", "4 3 0 0\n1 0 0 0\n2 1e100 0 0\n3 0 1e100 0\n4 0 0 -1e100\n");
    TU_OK(defsim_mesh_load(tu_write_file("big.ele", "1 4 0\n1 1 2 3 4\n"), &m));
    const double v = tet_volume(m.positions, m.tets);
    assert_true(isfinite(v) && fabs(v / (1e300 / 6.0) - 1.0) < 1e-12);
    defsim_mesh_free(&m);
}

/* The generators refuse what would give non-finite vertices or overflow their counts. */
static void test_generator_bounds(void **state)
{
    (void)state;
    defsim_mesh m = empty_mesh();
    const double lo[3] = {-1e308, 0, 0}, hi[3] = {1e308, 1, 1};
    /* These used to return DEFSIM_OK with NaN vertices (hi - lo = inf). */
    assert_int_equal(defsim_mesh_rope(lo, hi, 4, &m), DEFSIM_ERR_INVALID_ARGUMENT);
    assert_int_equal(defsim_mesh_box(lo, hi, 1, 1, 1, &m), DEFSIM_ERR_INVALID_ARGUMENT);
    const double o[3] = {0, 0, 0}, u[3] = {1e308, 0, 0}, v[3] = {0, 1, 0}, uu[3] = {1, 0, 0};
    assert_int_equal(defsim_mesh_cloth(o, u, v, 2, 2, &m), DEFSIM_ERR_INVALID_ARGUMENT);
    assert_null(m.positions);
    /* (nu + 1) (nv + 1) overflowed int32 for nu = INT32_MAX and passed the size guard. */
    assert_int_equal(defsim_mesh_cloth(o, uu, v, INT32_MAX, 1, &m), DEFSIM_ERR_INVALID_ARGUMENT);
    assert_int_equal(defsim_mesh_cloth(o, uu, v, 1, INT32_MAX, &m), DEFSIM_ERR_INVALID_ARGUMENT);
    assert_null(m.positions);
    /* Within the bound: finite vertices. */
    const double a[3] = {-1e100, 0, 0}, b[3] = {1e100, 0, 0};
    TU_OK(defsim_mesh_rope(a, b, 4, &m));
    for (int i = 0; i < 3 * m.vertex_count; ++i) assert_true(isfinite(m.positions[i]));
    assert_near(m.positions[3 * 2], 0.0, 0.0);
    defsim_mesh_free(&m);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test_setup_teardown(test_tetgen, tu_tmpdir_setup, tu_tmpdir_teardown),
        cmocka_unit_test_setup_teardown(test_tetgen_zero_based, tu_tmpdir_setup, tu_tmpdir_teardown),
        cmocka_unit_test_setup_teardown(test_tetgen_errors, tu_tmpdir_setup, tu_tmpdir_teardown),
        cmocka_unit_test_setup_teardown(test_gmsh_v2, tu_tmpdir_setup, tu_tmpdir_teardown),
        cmocka_unit_test_setup_teardown(test_gmsh_v4, tu_tmpdir_setup, tu_tmpdir_teardown),
        cmocka_unit_test_setup_teardown(test_quadratic_files, tu_tmpdir_setup, tu_tmpdir_teardown),
        cmocka_unit_test_setup_teardown(test_obj, tu_tmpdir_setup, tu_tmpdir_teardown),
        cmocka_unit_test_setup_teardown(test_obj_errors, tu_tmpdir_setup, tu_tmpdir_teardown),
        cmocka_unit_test(test_cloth),
        cmocka_unit_test(test_rope),
        cmocka_unit_test(test_spring_kinds),
        cmocka_unit_test_setup_teardown(test_not_regular_files, tu_tmpdir_setup, tu_tmpdir_teardown),
        cmocka_unit_test_setup_teardown(test_limits, tu_tmpdir_setup, tu_tmpdir_teardown),
        cmocka_unit_test_setup_teardown(test_huge_coordinates, tu_tmpdir_setup, tu_tmpdir_teardown),
        cmocka_unit_test(test_generator_bounds),
    };
    return cmocka_run_group_tests_name("mesh_io", tests, NULL, NULL);
}
