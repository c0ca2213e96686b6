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

/* A collider's geometry in world coordinates at the pose of its def, for drawing and for VTK
 * frames: the tessellation of scene_collider_surface at the pose (sphere, capsule, box, mesh), a
 * plane as the square of half side `half` (m) about the point of the plane nearest `centre`
 * (two triangles), an SDF as the 12 edges of its sdf_bounds box (nothing when unbounded).
 * Fill with scene_geometry_make, free with scene_geometry_free. */
typedef struct scene_geometry {
    double *x;              /* 3 nv */
    int32_t nv;
    int32_t *tri;           /* 3 nt, outward (counter-clockwise seen from outside) */
    int32_t nt;
    int32_t *lines;         /* 2 nl */
    int32_t nl;
    int smooth;             /* 1 for curved surfaces (sphere, capsule) and the plane */
} scene_geometry;
/* Returns 0, or -1 when out of memory (g then holds nothing). */
int scene_geometry_make(const defsim_collider_def *d, const double centre[3], double half,
                        scene_geometry *g);
void scene_geometry_free(scene_geometry *g);

/* Unit vectors t1, t2 across the unit vector n, (t1, t2, n) right-handed. */
void scene_across(const double n[3], double t1[3], double t2[3]);

/* v rotated by the unit quaternion q (w, x, y, z). */
void scene_quat_rotate(const double q[4], const double v[3], double out[3]);

/* The nv local points moved to the collider's pose at time t (its path's, else its own). */
void scene_collider_place(const scene_collider *col, double t, const double *local, int32_t nv,
                          double *out);

#endif
