/* SPDX-License-Identifier: MIT */
/* The OBJ parser, called by defsim_mesh_load (mesh_load.c). */
#ifndef DEFSIM_MESH_OBJ_H
#define DEFSIM_MESH_OBJ_H

#include "defsim/defsim.h"

/* Wavefront `.obj`: faces and polylines, whose unique edges become springs. On success fills
 * *out (owning); else the error is in defsim_last_error. */
defsim_status defsim__load_obj(const char *path, defsim_mesh *out);

#endif
