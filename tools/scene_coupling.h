/* SPDX-License-Identifier: MIT */
/*
 * Scene files, scene_coupling.c: a body's "forces" and "drive", the scene's "attachments";
 * building them into a world, moving them along their paths step by step (scene_step).
 */
#ifndef DEFSIM_TOOLS_SCENE_COUPLING_H
#define DEFSIM_TOOLS_SCENE_COUPLING_H

#include "scene_types.h"

/* The JSON layer's context (scene_json.h), named here so that the tools need no cJSON header. */
typedef struct sj_ctx sj_ctx;

/* Called by scene.c: a body's "forces" and "drive" (after its pins and initial positions), the
 * scene's "attachments" (after all bodies), and what scene_build and scene_free do for them. */
int scene_parse_forces(sj_ctx *c, const struct cJSON *j, const char *what, scene_body *b,
                       double tol);
int scene_parse_drive(sj_ctx *c, const struct cJSON *j, const char *what, scene_body *b,
                      double tol);
int scene_parse_attachments(sj_ctx *c, const struct cJSON *j);
defsim_status scene_build_coupling(scene *s, defsim_world *w);
void scene_free_coupling(scene *s);

/* One step of h: first moves the driven pins and keyframed attachment points to where their
 * paths are at t + h (t = the world's time), then defsim_world_step. A failure leaves the error
 * in the world's last error. */
defsim_status scene_step(scene *s, defsim_world *w, double h);

/* 1 if the scene moves anything along a path (driven pins, keyframed attachments, colliders). */
int scene_has_paths(const scene *s);

#endif
