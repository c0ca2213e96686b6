/* SPDX-License-Identifier: MIT */
/*
 * Scene files, scene_collider.c: the "colliders" array, adding them to a world, their keyed
 * poses, and their surfaces for drawing.
 */
#ifndef DEFSIM_TOOLS_SCENE_COLLIDER_H
#define DEFSIM_TOOLS_SCENE_COLLIDER_H

#include "scene_types.h"

/* The JSON layer's context (scene_json.h), named here so that the tools need no cJSON header. */
typedef struct sj_ctx sj_ctx;

/* Called by scene.c and scene_step: the "colliders" array; adding them to a world (after the
 * bodies); setting the poses of moving ones for the end of a step at time t; freeing them. */
int scene_parse_colliders(sj_ctx *c, const struct cJSON *j);
defsim_status scene_build_colliders(scene *s, defsim_world *w);
defsim_status scene_move_colliders(scene *s, defsim_world *w, double t);
void scene_free_colliders(scene *s);

/* The pose of a collider's path at time t (position linear between keys, rotation along the
 * shortest arc; held outside the keys). */
void scene_collider_pose(const scene_collider *col, double t, double p[3], double q[4]);

/* A triangle surface of a collider for drawing, in its local frame: positions (3 per vertex)
 * and outward triangles, malloc'd (free both); none for planes and SDFs (0 and NULL). smooth:
 * 1 for the curved shapes. Returns 0, or -1 when out of memory. */
int scene_collider_surface(const scene_collider *col, double **x, int32_t *nv, int32_t **tri,
                           int32_t *nt, int *smooth);

/* The nv local points moved to the collider's pose at time t (its path's, else its own). */
void scene_collider_place(const scene_collider *col, double t, const double *local, int32_t nv,
                          double *out);

#endif
