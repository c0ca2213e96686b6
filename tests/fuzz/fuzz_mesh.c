/* SPDX-License-Identifier: MIT */
/*
 * Fuzz target for one mesh format of defsim_mesh_load, chosen at compile time by
 * FUZZ_FORMAT: 1 OBJ, 2 Gmsh, 3 TetGen. The input is written to a file with the format's
 * extension and loaded; a loaded mesh is checked (indices in range, finite positions), so a
 * loader that returns garbage as success crashes the target too. TetGen reads two files: the
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

static void check_indices(const int32_t *idx, int64_t n, int32_t nv)
{
    for (int64_t i = 0; i < n; ++i)
        if (idx[i] < 0 || idx[i] >= nv) abort();
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
        check_indices(m.tets, 4 * (int64_t)m.tet_count, m.vertex_count);
        check_indices(m.triangles, 3 * (int64_t)m.triangle_count, m.vertex_count);
        check_indices(m.springs, 2 * (int64_t)m.spring_count, m.vertex_count);
        defsim_mesh_free(&m);
    } else if (m.positions || m.vertex_count || !defsim_last_error()[0]) {
        abort();   /* a failure must leave the mesh unchanged and say why */
    }
    return 0;
}
