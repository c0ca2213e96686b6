/* SPDX-License-Identifier: MIT */
/*
 * Fuzz target for one mesh format of defsim_mesh_load, chosen at compile time by
 * FUZZ_FORMAT: 1 OBJ, 2 Gmsh, 3 TetGen. The input is written to a file with the format's
 * extension and loaded; a loaded mesh is checked (indices in range, finite positions, finite
 * edge lengths and tet volumes: what the first step computes), so a loader that returns
 * garbage as success crashes the target too. TetGen reads two files: the
 * input up to the first line "@ele" is the .node file, the rest the .ele file.
 */
#include "fuzz_util.h"

#include <defsim/defsim.h>

#include <math.h>
#include <stdlib.h>
#include <string.h>

int LLVMFuzzerInitialize(int *argc, char ***argv)
{
    (void)argc;
    (void)argv;
    fz_small_limits();
    return 0;
}

/* Every index in range; each element's edges have a finite length and (tets) a finite
 * volume. */
static void check_elements(const double *x, const int32_t *idx, int64_t n, int k, int32_t nv)
{
    for (int64_t i = 0; i < n * k; ++i)
        if (idx[i] < 0 || idx[i] >= nv) abort();
    for (int64_t e = 0; e < n; ++e) {
        const int32_t *q = idx + k * e;
        double d[3][3];
        for (int a = 1; a < k; ++a) {
            double l2 = 0.0;
            for (int c = 0; c < 3; ++c) {
                d[a - 1][c] = x[3 * (int64_t)q[a] + c] - x[3 * (int64_t)q[0] + c];
                l2 += d[a - 1][c] * d[a - 1][c];
            }
            if (!isfinite(l2)) abort();
        }
        if (k == 4) {
            const double det = d[0][0] * (d[1][1] * d[2][2] - d[1][2] * d[2][1]) -
                               d[0][1] * (d[1][0] * d[2][2] - d[1][2] * d[2][0]) +
                               d[0][2] * (d[1][0] * d[2][1] - d[1][1] * d[2][0]);
            if (!isfinite(det)) abort();
        }
    }
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    const char *path;
#if FUZZ_FORMAT == 1
    path = fz_write("m.obj", data, size);
#elif FUZZ_FORMAT == 2
    path = fz_write("m.msh", data, size);
#elif FUZZ_FORMAT == 3
    static const char sep[] = "\n@ele\n";
    size_t split = size;
    for (size_t i = 0; i + sizeof sep - 1 <= size; ++i)
        if (!memcmp(data + i, sep, sizeof sep - 1)) { split = i; break; }
    const size_t rest = split < size ? split + sizeof sep - 1 : size;
    fz_write("m.node", data, split);
    path = fz_write("m.ele", data + rest, size - rest);
#else
#error "FUZZ_FORMAT must be 1 (OBJ), 2 (Gmsh) or 3 (TetGen)"
#endif
    defsim_mesh m;
    memset(&m, 0, sizeof m);
    m.size = sizeof m;
    if (defsim_mesh_load(path, &m) == DEFSIM_OK) {
        if (m.vertex_count < 1 || !m.positions) abort();
        for (int64_t i = 0; i < 3 * (int64_t)m.vertex_count; ++i)
            if (!isfinite(m.positions[i])) abort();
        check_elements(m.positions, m.tets, m.tet_count, 4, m.vertex_count);
        check_elements(m.positions, m.triangles, m.triangle_count, 3, m.vertex_count);
        check_elements(m.positions, m.springs, m.spring_count, 2, m.vertex_count);
        defsim_mesh_free(&m);
    } else if (m.positions || m.vertex_count || !defsim_last_error()[0]) {
        abort();   /* a failure must leave the mesh unchanged and say why */
    }
    return 0;
}
