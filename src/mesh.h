/* SPDX-License-Identifier: MIT */
/* Private mesh helpers shared by the generators and the loaders. */
#ifndef DEFSIM_MESH_H
#define DEFSIM_MESH_H

#include "defsim/defsim.h"

#include <stddef.h>

/* The smallest defsim_mesh.size accepted: the struct before spring_kinds was appended. */
#define DEFSIM__MESH_SIZE_V1 offsetof(defsim_mesh, spring_kinds)

/* Hands a finished mesh to the caller's struct, copying only the fields its size covers (an
 * older caller's struct lacks spring_kinds, which is then freed). */
void defsim__mesh_deliver(defsim_mesh *dst, defsim_mesh *src);
/* The largest |coordinate| (m) the generators and loaders accept: differences of coordinates,
 * their squares (lengths) and products of three (volumes) all stay finite below it. */
#define DEFSIM__COORD_MAX 1e100

/* Outward-oriented boundary triangles of a tet mesh (faces used by exactly one tet).
 * *tris_out is malloc'd (3 * *ntris_out indices). */
defsim_status defsim__tet_boundary(const double *pos, const int32_t *tets, int32_t nt,
                                   int32_t **tris_out, int32_t *ntris_out);
/* The same for tets of `nodes` indices each (4, or 10: quadratic, tet10.h): a quadratic
 * boundary face becomes 4 triangles through its mid-edge nodes (corner, corner, corner, then
 * the middle one), oriented as the face. */
defsim_status defsim__tet_surface(const double *pos, const int32_t *tets, int nodes, int32_t nt,
                                  int32_t **tris_out, int32_t *ntris_out);

#endif
