/* SPDX-License-Identifier: MIT */
/* defsim_mesh_load: picks the parser by extension (mesh_tetgen.c, mesh_gmsh.c, mesh_obj.c); each
 * parser fills a raw mesh and finishes it (mesh_raw.c), so nothing here calls back up. */
#include "mesh.h"
#include "mesh_gmsh.h"
#include "mesh_obj.h"
#include "mesh_raw.h"
#include "mesh_tetgen.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static int ends_with(const char *s, const char *suffix)
{
    size_t n = strlen(s), k = strlen(suffix);
    if (n < k) return 0;
    for (size_t i = 0; i < k; ++i) {
        char c = s[n - k + i];
        if (c >= 'A' && c <= 'Z') c = (char)(c - 'A' + 'a');
        if (c != suffix[i]) return 0;
    }
    return 1;
}

defsim_status defsim_mesh_load(const char *path, defsim_mesh *mesh)
{
    if (!path || !mesh || mesh->size < DEFSIM__MESH_SIZE_V1) {
        defsim__set_last_error("defsim_mesh_load: NULL argument or mesh->size not "
                               "sizeof(defsim_mesh)");
        return DEFSIM_ERR_INVALID_ARGUMENT;
    }
    defsim__clear_last_error();
    if (ends_with(path, ".msh")) return defsim__load_gmsh(path, mesh);
    if (ends_with(path, ".obj")) return defsim__load_obj(path, mesh);
    size_t n = strlen(path);
    char *base = malloc(n + 1);
    if (!base) return defsim__mesh_oom(path);
    memcpy(base, path, n + 1);
    defsim_status st;
    if (ends_with(base, ".node")) base[n - 5] = '\0';
    else if (ends_with(base, ".ele")) base[n - 4] = '\0';
    else {
        /* A base name: TetGen if base.node exists. */
        char *node = malloc(n + 6);
        FILE *f = NULL;
        if (node) {
            snprintf(node, n + 6, "%s.node", base);
            f = fopen(node, "rb");
        }
        free(node);
        if (!f) {
            free(base);
            defsim__set_last_error("%s: unknown mesh format (expected .node/.ele, .msh or .obj, "
                                   "or a TetGen base name)", path);
            return DEFSIM_ERR_INVALID_ARGUMENT;
        }
        fclose(f);
    }
    st = defsim__load_tetgen(base, mesh);
    free(base);
    return st;
}
