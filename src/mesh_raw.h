/* SPDX-License-Identifier: MIT */
/*
 * What the mesh parsers share after tokenizing: the collected mesh (vertices by the tag the file
 * gives them, elements by vertex tags, each with its line) and `defsim__mesh_finish`, which maps
 * tags to indices, drops vertices that no element uses (they would have no mass), orients tets
 * positively, rejects degenerate elements (tet_rest.h; quadratic ones by tet10.h, their mid-edge
 * nodes put in VTK order by position) and adds the tets' boundary triangles.
 * It sits below the parsers (mesh_tetgen.c, mesh_gmsh.c, mesh_obj.c), which sit below
 * mesh_load.c: each parser finishes its own mesh, so no call goes back up.
 */
#ifndef DEFSIM_MESH_RAW_H
#define DEFSIM_MESH_RAW_H

#include "mesh_reader.h"

typedef struct defsim__raw_mesh {
    defsim__vec pos;      /* double x3 */
    defsim__vec tag;      /* long long, one per vertex */
    defsim__vec tets;     /* long long x tet_nodes (vertex tags) */
    int tet_nodes;        /* 4, or 10 (quadratic: defsim__raw_quadratic) */
    defsim__vec tet_line; /* int */
    defsim__vec tris;     /* long long x3 */
    defsim__vec tri_line; /* int */
    defsim__vec segs;     /* long long x2: explicit springs (OBJ 'l') */
    defsim__vec seg_line; /* int */
    int tags_are_indices; /* tags are 0-based indices already (OBJ) */
    int64_t max_vertices, max_elements;   /* the limits when the load started */
} defsim__raw_mesh;

void defsim__raw_init(defsim__raw_mesh *m);
/* defsim__raw_init, then defsim__rd_open of the loader's file; on failure nothing needs freeing. */
defsim_status defsim__raw_open(defsim__raw_mesh *m, defsim__reader *r, const char *path,
                               int hash_comments);
void defsim__raw_free(defsim__raw_mesh *m);

/* 1 if m may take one more vertex (`vertex`) or element (tet, triangle or segment); else 0 with
 * the error "more than N vertices, the limit ..." recorded in r (0 at once after an error). */
int defsim__raw_room(defsim__reader *r, const defsim__raw_mesh *m, int vertex);

/* Makes m's tets quadratic (10 vertex tags each, the 4 corners first, the mid-edge nodes in any
 * order: finish matches them to their edges by position) before the first is pushed. Returns 1,
 * or 0 with the error recorded in r (at `line`) when linear tets came first. */
int defsim__raw_quadratic(defsim__reader *r, defsim__raw_mesh *m, int line);

/* Sets "path: out of memory" and returns DEFSIM_ERR_OUT_OF_MEMORY. */
defsim_status defsim__mesh_oom(const char *path);

/* Maps tags to indices, compacts, checks and orients; on success fills *out (owning). With
 * `edge_springs`, the unique edges of the triangles become springs (OBJ cloth). */
defsim_status defsim__mesh_finish(const char *path, defsim__raw_mesh *m, int edge_springs,
                                  defsim_mesh *out);

#endif
