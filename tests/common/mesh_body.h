/* SPDX-License-Identifier: MIT */
/*
 * The body def of a whole mesh (its tets and its springs) with a fresh material of `model`: the
 * lines nearly every test program writes before defsim_world_add_body. Header-only C that also
 * compiles as C++, over the public API alone, so that the unit tests and the bindings' tests
 * (C++, and the Python bit-match program) share one copy. The install consumer keeps its own
 * lines: it must build from the installed files alone.
 */
#ifndef DEFSIM_TESTS_MESH_BODY_H
#define DEFSIM_TESTS_MESH_BODY_H

#include <defsim/defsim.h>

/* The arrays stay the mesh's: add the body before freeing the mesh. */
static inline defsim_body_def test_mesh_body(const defsim_mesh *m, defsim_model model)
{
    defsim_body_def bd;
    defsim_body_def_init(&bd, sizeof bd);
    bd.rest_positions = m->positions;
    bd.vertex_count = m->vertex_count;
    bd.tets = m->tets;
    bd.tet_count = m->tet_count;
    bd.springs = m->springs;
    bd.spring_count = m->spring_count;
    bd.tet_nodes = m->tet_nodes;
    defsim_material_init(&bd.material, sizeof bd.material, model);
    return bd;
}

/* A shell body's def over a cloth mesh (docs/shells.md): its triangles, without its springs;
 * the shell_* fields are the caller's to set. The arrays stay the mesh's. */
static inline defsim_body_def test_shell_body(const defsim_mesh *m)
{
    defsim_body_def bd;
    defsim_body_def_init(&bd, sizeof bd);
    bd.rest_positions = m->positions;
    bd.vertex_count = m->vertex_count;
    bd.triangles = m->triangles;
    bd.triangle_count = m->triangle_count;
    return bd;
}

#endif
