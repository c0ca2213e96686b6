/* SPDX-License-Identifier: MIT */
/* The Gmsh parser, called by defsim_mesh_load (mesh_load.c). */
#ifndef DEFSIM_MESH_GMSH_H
#define DEFSIM_MESH_GMSH_H

#include "defsim/defsim.h"

/* Gmsh 2 and 4 ASCII `.msh`. On success fills *out (owning); else the error is in
 * defsim_last_error. */
defsim_status defsim__load_gmsh(const char *path, defsim_mesh *out);

#endif
