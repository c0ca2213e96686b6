/* SPDX-License-Identifier: MIT */
/* Gmsh .msh, ASCII formats 2.x, 4.0 and 4.1: linear tets (type 4) or quadratic ones (type 11);
 * lower-dimensional elements skipped. */
#include "mesh_gmsh.h"

#include "mesh_raw.h"

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* Gmsh element types: node count and dimension (0 for unknown types). */
static void gmsh_type(long long type, int *nodes, int *dim, const char **name)
{
    static const struct { int type, nodes, dim; const char *name; } T[] = {
        {1, 2, 1, "2-node line"}, {2, 3, 2, "3-node triangle"}, {3, 4, 2, "4-node quadrangle"},
        {4, 4, 3, "4-node tetrahedron"}, {5, 8, 3, "8-node hexahedron"},
        {6, 6, 3, "6-node prism"}, {7, 5, 3, "5-node pyramid"}, {8, 3, 1, "3-node line"},
        {9, 6, 2, "6-node triangle"}, {10, 9, 2, "9-node quadrangle"},
        {11, 10, 3, "10-node (quadratic) tetrahedron"}, {12, 27, 3, "27-node hexahedron"},
        {13, 18, 3, "18-node prism"}, {14, 14, 3, "14-node pyramid"}, {15, 1, 0, "point"},
        {16, 8, 2, "8-node quadrangle"}, {17, 20, 3, "20-node hexahedron"},
        {18, 15, 3, "15-node prism"}, {19, 13, 3, "13-node pyramid"},
        {20, 9, 2, "9-node triangle"}, {21, 10, 2, "10-node triangle"},
        {22, 12, 2, "12-node triangle"}, {23, 15, 2, "15-node triangle"},
        {24, 15, 2, "15-node triangle"}, {25, 21, 2, "21-node triangle"},
        {26, 4, 1, "4-node line"}, {27, 5, 1, "5-node line"}, {28, 6, 1, "6-node line"},
        {29, 20, 3, "20-node tetrahedron"}, {30, 35, 3, "35-node tetrahedron"},
        {31, 56, 3, "56-node tetrahedron"}, {92, 64, 3, "64-node hexahedron"},
        {93, 125, 3, "125-node hexahedron"}};
    *nodes = 0;
    *dim = -1;
    *name = "unknown element type";
    for (size_t i = 0; i < sizeof T / sizeof T[0]; ++i)
        if (T[i].type == type) { *nodes = T[i].nodes; *dim = T[i].dim; *name = T[i].name; }
}

/* Reads "$Name" and checks it; skips unknown sections. Returns 1 if a section was opened. */
static int gmsh_section(defsim__reader *r, const char **name, size_t *n)
{
    *n = defsim__rd_token(r, name);
    return *n > 0;
}

static void gmsh_skip_section(defsim__reader *r, const char *name, size_t n)
{
    char end[128];
    snprintf(end, sizeof end, "$End%.*s", (int)(n > 100 ? 100 : n) - 1, name + 1);
    int line = r->line;
    for (;;) {
        const char *tok;
        size_t k = defsim__rd_token(r, &tok);
        if (k == 0) {
            defsim__rd_fail(r, DEFSIM_ERR_IO, line, "section %.*s has no %s", (int)n, name, end);
            return;
        }
        if (defsim__tok_is(tok, k, end)) return;
    }
}

static void gmsh_expect_end(defsim__reader *r, const char *end)
{
    if (r->st != DEFSIM_OK) return;
    const char *tok;
    size_t k = defsim__rd_token(r, &tok);
    if (!defsim__tok_is(tok, k, end)) {
        char shown[64];
        defsim__rd_show(shown, sizeof shown, tok, k);
        defsim__rd_fail(r, DEFSIM_ERR_IO, r->line, "expected %s, found %s", end, shown);
    }
}

static int gmsh_push_node(defsim__reader *r, defsim__raw_mesh *m, long long tag, const double p[3])
{
    if (!defsim__raw_room(r, m, 1)) return 0;
    if (!defsim__vec_push(&m->pos, p, 1) || !defsim__vec_push(&m->tag, &tag, 1)) {
        r->st = defsim__mesh_oom(r->path);
        return 0;
    }
    return 1;
}

/* One element; keeps tets, skips lower-dimensional ones, rejects other volume elements. */
static void gmsh_element(defsim__reader *r, defsim__raw_mesh *m, long long type, int dim_hint,
                         int line, long long nodes[], int nn)
{
    int tn, dim;
    const char *name;
    gmsh_type(type, &tn, &dim, &name);
    if (dim < 0) dim = dim_hint;
    if (type == 4 || type == 11) {
        if (!defsim__raw_room(r, m, 0)) return;
        if ((m->tet_nodes == 10) != (type == 11)) {
            defsim__rd_fail(r, DEFSIM_ERR_INVALID_MESH, line, "the file mixes linear (type 4) "
                            "and quadratic (type 11) tetrahedra");
            return;
        }
        if (!defsim__vec_push(&m->tets, nodes, 1) || !defsim__vec_push(&m->tet_line, &line, 1))
            r->st = defsim__mesh_oom(r->path);
    } else if (dim == 3) {
        defsim__rd_fail(r, DEFSIM_ERR_INVALID_MESH, line,
                        "element type %lld (%s): only tetrahedra (types 4 and 11) are supported "
                        "as volume elements", type, name);
    } else if (dim < 0) {
        defsim__rd_fail(r, DEFSIM_ERR_INVALID_MESH, line, "unknown element type %lld", type);
    }
    (void)nn;
}

/* The k (4 or 10) node tags of tet element `tag`, which began on line `eline` and must end
 * there; a quadratic one makes the raw mesh's tets quadratic first. */
static int gmsh_tet_nodes(defsim__reader *r, defsim__raw_mesh *m, const char *what, long long tag,
                          int eline, long long v[10], int k)
{
    if (k == 10 && !defsim__raw_quadratic(r, m, eline)) return 0;
    for (int a = 0; a < k; ++a)
        if (!defsim__rd_i64(r, what, &v[a])) return 0;
    if (r->line != eline) {
        defsim__rd_fail(r, DEFSIM_ERR_IO, eline, "element %lld: line ends early", tag);
        return 0;
    }
    return 1;
}

/* Format 4 entity block header: "dim tag" (4.1) or "tag dim" (4.0). */
static int gmsh_entity(defsim__reader *r, int minor, long long *dim)
{
    long long etag;
    if (minor >= 1)
        return defsim__rd_count(r, "entity dimension", 0, 3, dim) &&
               defsim__rd_i64(r, "entity tag", &etag);
    return defsim__rd_i64(r, "entity tag", &etag) &&
           defsim__rd_count(r, "entity dimension", 0, 3, dim);
}

static void gmsh_nodes_v2(defsim__reader *r, defsim__raw_mesh *m, int minor)
{
    (void)minor;
    long long nn;
    if (!defsim__rd_count(r, "number of nodes", 0, INT32_MAX / 3, &nn)) return;
    for (long long i = 0; i < nn; ++i) {
        long long tag;
        double p[3];
        if (!defsim__rd_i64(r, "node number", &tag) || !defsim__rd_coord(r, "x", &p[0]) ||
            !defsim__rd_coord(r, "y", &p[1]) || !defsim__rd_coord(r, "z", &p[2]))
            return;
        if (!gmsh_push_node(r, m, tag, p)) return;
    }
}

static void gmsh_elements_v2(defsim__reader *r, defsim__raw_mesh *m, int minor)
{
    (void)minor;
    long long ne;
    if (!defsim__rd_count(r, "number of elements", 0, INT32_MAX, &ne)) return;
    for (long long e = 0; e < ne; ++e) {
        long long tag, type, ntags, skip, v[10];
        defsim__rd_skip_ws(r);
        int eline = r->line;
        if (!defsim__rd_i64(r, "element number", &tag) ||
            !defsim__rd_i64(r, "element type", &type) ||
            !defsim__rd_count(r, "number of tags", 0, 1000, &ntags))
            return;
        for (long long k = 0; k < ntags; ++k)
            if (!defsim__rd_i64(r, "tag", &skip)) return;
        if (type == 4 || type == 11) {
            if (!gmsh_tet_nodes(r, m, "node number", tag, eline, v, type == 4 ? 4 : 10)) return;
        } else {
            defsim__rd_to_eol(r);
        }
        gmsh_element(r, m, type, -1, eline, v, type == 11 ? 10 : 4);
        if (r->st != DEFSIM_OK) return;
    }
}

/* Format 4 section header: entity blocks, `item`s (at most `max`), in 4.1 the range of tags. */
static int gmsh_v4_counts(defsim__reader *r, int minor, const char *item, long long max,
                          long long *nblocks)
{
    char what[3][48];
    snprintf(what[0], sizeof what[0], "number of %ss", item);
    snprintf(what[1], sizeof what[1], "minimum %s tag", item);
    snprintf(what[2], sizeof what[2], "maximum %s tag", item);
    long long n, skip;
    return defsim__rd_count(r, "number of entity blocks", 0, INT32_MAX, nblocks) &&
           defsim__rd_count(r, what[0], 0, max, &n) &&
           (minor < 1 || (defsim__rd_i64(r, what[1], &skip) && defsim__rd_i64(r, what[2], &skip)));
}

static void gmsh_nodes_v4(defsim__reader *r, defsim__raw_mesh *m, int minor)
{
    long long nblocks;
    if (!gmsh_v4_counts(r, minor, "node", INT32_MAX / 3, &nblocks)) return;
    for (long long b = 0; b < nblocks; ++b) {
        long long dim, param, cnt;
        if (!gmsh_entity(r, minor, &dim)) return;
        if (!defsim__rd_count(r, "parametric flag", 0, 1, &param) ||
            !defsim__rd_count(r, "nodes in block", 0, INT32_MAX / 3, &cnt))
            return;
        /* Parametric coordinates follow x y z: one per entity dimension. */
        const long long npar = param ? (minor >= 1 ? dim : (dim < 2 ? dim : 2)) : 0;
        if (minor >= 1) {
            size_t first = m->tag.n;
            for (long long i = 0; i < cnt; ++i) {
                long long tag;
                const double zero[3] = {0, 0, 0};
                if (!defsim__rd_i64(r, "node tag", &tag) ||
                    !gmsh_push_node(r, m, tag, zero))
                    return;
            }
            double *P = m->pos.p;
            for (long long i = 0; i < cnt; ++i) {
                double *p = P + 3 * (first + (size_t)i), u;
                if (!defsim__rd_coord(r, "x", &p[0]) || !defsim__rd_coord(r, "y", &p[1]) ||
                    !defsim__rd_coord(r, "z", &p[2]))
                    return;
                for (long long k = 0; k < npar; ++k)
                    if (!defsim__rd_f64(r, "parametric coordinate", &u)) return;
            }
        } else {
            for (long long i = 0; i < cnt; ++i) {
                long long tag;
                double p[3], u;
                if (!defsim__rd_i64(r, "node tag", &tag) ||
                    !defsim__rd_coord(r, "x", &p[0]) ||
                    !defsim__rd_coord(r, "y", &p[1]) || !defsim__rd_coord(r, "z", &p[2]))
                    return;
                for (long long k = 0; k < npar; ++k)
                    if (!defsim__rd_f64(r, "parametric coordinate", &u)) return;
                if (!gmsh_push_node(r, m, tag, p)) return;
            }
        }
    }
}

static void gmsh_elements_v4(defsim__reader *r, defsim__raw_mesh *m, int minor)
{
    long long nblocks;
    if (!gmsh_v4_counts(r, minor, "element", INT32_MAX, &nblocks)) return;
    for (long long b = 0; b < nblocks; ++b) {
        long long dim, type, cnt;
        defsim__rd_skip_ws(r);
        int bline = r->line;
        if (!gmsh_entity(r, minor, &dim)) return;
        if (!defsim__rd_i64(r, "element type", &type) ||
            !defsim__rd_count(r, "elements in block", 0, INT32_MAX, &cnt))
            return;
        if (type != 4 && type != 11) {
            /* Boundary elements are skipped line by line; other volumes are errors. */
            gmsh_element(r, m, type, (int)dim, bline, NULL, 0);
            if (r->st != DEFSIM_OK) return;
            defsim__rd_skip_line(r);
            for (long long e = 0; e < cnt; ++e) defsim__rd_skip_line(r);
            continue;
        }
        const int k = type == 11 ? 10 : 4;
        for (long long e = 0; e < cnt; ++e) {
            long long tag, v[10];
            defsim__rd_skip_ws(r);
            int eline = r->line;
            if (!defsim__rd_i64(r, "element tag", &tag) ||
                !gmsh_tet_nodes(r, m, "node tag", tag, eline, v, k))
                return;
            gmsh_element(r, m, type, 3, eline, v, k);
            if (r->st != DEFSIM_OK) return;
        }
    }
}

typedef void (*gmsh_reader_fn)(defsim__reader *r, defsim__raw_mesh *m, int minor);

/* The sections of the file: $Nodes and $Elements by the version's readers, others skipped. */
static void gmsh_sections(defsim__reader *r, defsim__raw_mesh *m, int minor,
                          gmsh_reader_fn nodes, gmsh_reader_fn elements)
{
    const char *name;
    size_t n;
    while (r->st == DEFSIM_OK && gmsh_section(r, &name, &n)) {
        int line = r->line;
        if (defsim__tok_is(name, n, "$Nodes")) {
            nodes(r, m, minor);
            gmsh_expect_end(r, "$EndNodes");
        } else if (defsim__tok_is(name, n, "$Elements")) {
            elements(r, m, minor);
            gmsh_expect_end(r, "$EndElements");
        } else if (name[0] == '$') {
            gmsh_skip_section(r, name, n);
        } else {
            defsim__rd_fail(r, DEFSIM_ERR_IO, line, "expected a section ($Name), found '%.*s'",
                            (int)(n > 40 ? 40 : n), name);
        }
    }
}

defsim_status defsim__load_gmsh(const char *path, defsim_mesh *out)
{
    defsim__reader r;
    defsim__raw_mesh m;
    defsim_status st = defsim__raw_open(&m, &r, path, 0);
    if (st != DEFSIM_OK) return st;
    const char *tok;
    size_t n = defsim__rd_token(&r, &tok);
    if (!defsim__tok_is(tok, n, "$MeshFormat")) {
        defsim__rd_fail(&r, DEFSIM_ERR_IO, r.line, "not a Gmsh file: expected $MeshFormat");
        goto done;
    }
    defsim__rd_skip_ws(&r);
    int vline = r.line;
    double version;
    long long ftype, dsize;
    if (!defsim__rd_f64(&r, "format version", &version) ||
        !defsim__rd_i64(&r, "file type", &ftype) ||
        !defsim__rd_i64(&r, "data size", &dsize))
        goto done;
    if (ftype != 0) {
        defsim__rd_fail(&r, DEFSIM_ERR_IO, vline, "binary .msh files are not read; save as ASCII "
                        "(Mesh.Binary = 0, the default)");
        goto done;
    }
    /* Range first: converting a huge version to int would be undefined. */
    const int known = version >= 2.0 && version < 5.0;
    const int major = known ? (int)floor(version) : 0;
    const int minor = known ? (int)lround((version - major) * 10.0) : 0;
    if (!(major == 2 || (major == 4 && minor <= 1))) {
        defsim__rd_fail(&r, DEFSIM_ERR_IO, vline, "Gmsh format %g is not supported (2.x and 4.0, "
                        "4.1 ASCII are)", version);
        goto done;
    }
    gmsh_expect_end(&r, "$EndMeshFormat");
    if (r.st != DEFSIM_OK) goto done;
    if (major == 2) gmsh_sections(&r, &m, minor, gmsh_nodes_v2, gmsh_elements_v2);
    else gmsh_sections(&r, &m, minor, gmsh_nodes_v4, gmsh_elements_v4);
    if (r.st == DEFSIM_OK && m.tets.n == 0)
        defsim__rd_fail(&r, DEFSIM_ERR_INVALID_MESH, 0,
                        "no tetrahedra (element type 4 or 11) in the file");
done:
    st = r.st;
    defsim__rd_close(&r);
    if (st == DEFSIM_OK) st = defsim__mesh_finish(path, &m, 0, out);
    defsim__raw_free(&m);
    return st;
}

