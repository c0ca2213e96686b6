/* SPDX-License-Identifier: MIT */
/* The shell world of tests/checkpoint/v9_shell.dfck (format 9, before BODY held the strain
 * limit): a 6 x 6 StVK sheet with hinges, pinned along one edge, falling on symplectic_euler;
 * the file holds it after SHELL_V9_STEPS steps of SHELL_V9_H. Only the public API (and
 * tests/common/mesh_body.h), so that the library that wrote the file compiles it too. */
#ifndef SHELL_SHEET_V9_H
#define SHELL_SHEET_V9_H

#include "defsim/defsim.h"
#include "mesh_body.h"

#include <string.h>

#define SHELL_V9_STEPS 40
#define SHELL_V9_H 2e-4

/* The world, or NULL; *mesh receives the mesh (the caller frees it). */
static inline defsim_world *shell_sheet_v9(defsim_mesh *mesh)
{
    defsim_world_def wd;
    defsim_world_def_init(&wd, sizeof wd);
    wd.backend = "symplectic_euler";
    wd.gravity[1] = -9.81;
    wd.num_threads = 1;
    defsim_world *w = NULL;
    if (defsim_world_create(&wd, &w) != DEFSIM_OK) return NULL;
    const double o[3] = {0, 0, 0}, u[3] = {0.3, 0, 0}, v[3] = {0, 0, 0.3};
    memset(mesh, 0, sizeof *mesh);
    mesh->size = sizeof *mesh;
    if (defsim_mesh_cloth(o, u, v, 6, 6, mesh) != DEFSIM_OK) return NULL;
    defsim_body_def d = test_shell_body(mesh);
    d.shell_membrane = DEFSIM_SHELL_MEMBRANE_STVK;
    d.shell_youngs_modulus = 3e5;
    d.shell_poisson_ratio = 0.35;
    d.shell_thickness = 8e-4;
    d.shell_areal_density = 0.15;
    d.shell_bending_rigidity = 2e-5;
    d.material.mass_damping = 0.3;
    defsim_body_id id;
    const int32_t edge[7] = {0, 1, 2, 3, 4, 5, 6};
    if (defsim_world_add_body(w, &d, &id) != DEFSIM_OK ||
        defsim_body_pin(w, id, edge, 7) != DEFSIM_OK)
        return NULL;
    return w;
}

#endif
