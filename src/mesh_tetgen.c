/* SPDX-License-Identifier: MIT */
/* TetGen .node/.ele (https://wias-berlin.de/software/tetgen/fformats.html). */
#include "mesh_tetgen.h"

#include "mesh_raw.h"

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

defsim_status defsim__load_tetgen(const char *base, defsim_mesh *out)
{
    size_t bl = strlen(base);
    char *node_path = malloc(bl + 6), *ele_path = malloc(bl + 6);
    if (!node_path || !ele_path) { free(node_path); free(ele_path); return defsim__mesh_oom(base); }
    snprintf(node_path, bl + 6, "%s.node", base);
    snprintf(ele_path, bl + 6, "%s.ele", base);
    defsim__raw_mesh m;
    defsim__raw_init(&m);
    defsim__reader r;
    long long n = 0, dim = 0, nattr = 0, nmark = 0;
    defsim_status st = defsim__rd_open(&r, node_path, 1);
    if (st != DEFSIM_OK) goto done;
    defsim__rd_count(&r, "number of points", 1, INT32_MAX / 3, &n);
    defsim__rd_i64(&r, "dimension", &dim);
    if (r.st == DEFSIM_OK && dim != 3)
        defsim__rd_fail(&r, DEFSIM_ERR_INVALID_MESH, r.line,
                        "dimension %lld: only 3-D meshes are read", dim);
    defsim__rd_count(&r, "number of attributes", 0, 1000, &nattr);
    defsim__rd_count(&r, "number of boundary markers", 0, 1, &nmark);
    for (long long i = 0; i < n && r.st == DEFSIM_OK; ++i) {
        long long tag;
        double p[3];
        int line;
        defsim__rd_skip_ws(&r);
        line = r.line;
        if (!defsim__rd_i64(&r, "point number", &tag) || !defsim__rd_coord(&r, "x", &p[0]) ||
            !defsim__rd_coord(&r, "y", &p[1]) || !defsim__rd_coord(&r, "z", &p[2]))
            break;
        for (long long a = 0; a < nattr + nmark; ++a) {
            double skip;
            if (!defsim__rd_f64(&r, "attribute or boundary marker", &skip)) break;
        }
        if (r.st == DEFSIM_OK && r.line != line)
            defsim__rd_fail(&r, DEFSIM_ERR_IO, line, "point %lld: expected %lld values on the line",
                            tag, 4 + nattr + nmark);
        if (defsim__raw_room(&r, &m, 1) &&
            (!defsim__vec_push(&m.pos, p, 1) || !defsim__vec_push(&m.tag, &tag, 1)))
            st = defsim__mesh_oom(node_path);
    }
    if (st == DEFSIM_OK) st = r.st;
    defsim__rd_close(&r);
    if (st != DEFSIM_OK) goto done;

    st = defsim__rd_open(&r, ele_path, 1);
    if (st != DEFSIM_OK) goto done;
    long long nt = 0, per = 0;
    defsim__rd_count(&r, "number of tetrahedra", 1, INT32_MAX / 4, &nt);
    defsim__rd_skip_ws(&r);
    int per_line = r.line;
    defsim__rd_i64(&r, "nodes per tetrahedron", &per);
    if (r.st == DEFSIM_OK && per != 4 && per != 10)
        defsim__rd_fail(&r, DEFSIM_ERR_INVALID_MESH, per_line,
                        "%lld nodes per tetrahedron: linear (4-node) and quadratic (10-node, "
                        "tetgen -o2) tets are supported", per);
    if (r.st == DEFSIM_OK && per == 10) defsim__raw_quadratic(&r, &m, per_line);
    defsim__rd_count(&r, "number of attributes", 0, 1000, &nattr);
    for (long long t = 0; t < nt && r.st == DEFSIM_OK; ++t) {
        long long tag, v[10];
        defsim__rd_skip_ws(&r);
        int line = r.line;
        if (!defsim__rd_i64(&r, "tet number", &tag)) break;
        for (int a = 0; a < (int)per; ++a)
            if (!defsim__rd_i64(&r, "vertex number", &v[a])) break;
        for (long long a = 0; a < nattr && r.st == DEFSIM_OK; ++a) {
            double skip;
            defsim__rd_f64(&r, "region attribute", &skip);
        }
        if (r.st == DEFSIM_OK && r.line != line)
            defsim__rd_fail(&r, DEFSIM_ERR_IO, line, "tet %lld: expected %lld values on the line",
                            tag, 1 + per + nattr);
        if (defsim__raw_room(&r, &m, 0) &&
            (!defsim__vec_push(&m.tets, v, 1) || !defsim__vec_push(&m.tet_line, &line, 1)))
            st = defsim__mesh_oom(ele_path);
    }
    if (st == DEFSIM_OK) st = r.st;
    defsim__rd_close(&r);
    if (st == DEFSIM_OK) st = defsim__mesh_finish(ele_path, &m, 0, out);
done:
    defsim__raw_free(&m);
    free(node_path);
    free(ele_path);
    return st;
}

