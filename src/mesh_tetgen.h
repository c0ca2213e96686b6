/* SPDX-License-Identifier: MIT */
/* The TetGen parser, called by defsim_mesh_load (mesh_load.c). */
#ifndef DEFSIM_MESH_TETGEN_H
#define DEFSIM_MESH_TETGEN_H

#include "defsim/defsim.h"

/* TetGen `.node` / `.ele`: `base` is the path without the extension. On success fills *out
 * (owning); else the error is in defsim_last_error. */
defsim_status defsim__load_tetgen(const char *base, defsim_mesh *out);

#endif
