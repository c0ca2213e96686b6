/* SPDX-License-Identifier: MIT */
/*
 * A frame of a world as VTK files, the whole scene: the bodies (`<stem>.vtu`: their cells,
 * velocities and the fields of fields.h), and when the world has colliders their geometry at
 * the frame's poses (`<stem>_colliders.vtu`: scene_geometry_make's triangles and lines, cell
 * data "collider" (its index among the world's colliders) and "shape" (defsim_shape)) with a
 * multiblock `<stem>.vtm` that holds both (blocks "bodies" and "colliders"), which ParaView
 * opens as one scene. Shared by defsim run and libdefsim_scene (the writer Python calls).
 */
#ifndef DEFSIM_TOOLS_FRAME_H
#define DEFSIM_TOOLS_FRAME_H

#include "fields.h"
#include "vtk.h"

#include <stddef.h>

/* Where planes are drawn: a square of half side `half` (m) about the point of the plane nearest
 * `centre`. frame_plane_extent sizes it to the scene: centred on the bounds of the bodies and
 * of the colliders other than planes, half the largest side of those bounds times 2 (1 m for a
 * scene of one point), with the bodies at x (3 per vertex; NULL: the world's positions). */
typedef struct frame_plane {
    double centre[3];
    double half;
} frame_plane;
void frame_plane_extent(defsim_world *w, const double *x, frame_plane *out);

/* Writes the bodies' frame `path` (ending in ".vtu"): positions x and velocities v (3 nv each;
 * v may be NULL), the cells c, the fields' arrays as last evaluated (fl may be NULL: none), at
 * time t; with `colliders` and a world that has colliders, also <stem>_colliders.vtu and
 * <stem>.vtm. *vtm (may be NULL) receives 1 when the .vtm was written. Returns 0, or -1 with err
 * set. */
int frame_write(const char *path, defsim_world *w, const double *x, const double *v,
                const vtk_cells *c, const fields *fl, double t, int colliders,
                const frame_plane *plane, int *vtm, char *err, size_t errsz);

/* The .vtm's name for the bodies' frame `path` (".vtu" replaced by ".vtm"), into out. Returns
 * 0, or -1 when path does not end in ".vtu" or out is too small. */
int frame_vtm_path(const char *path, char *out, size_t size);

#endif
