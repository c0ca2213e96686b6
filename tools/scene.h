/* SPDX-License-Identifier: MIT */
/*
 * Scene files (JSON, parsed with cJSON): world settings, bodies and output settings, turned into
 * a defsim world. Shared by the tools (defsim run / bench / stress, defsim-render); not part of
 * the library. The format is documented in tools/README.md.
 *
 * The types are scene_types.h; the sections that scene.c hands on have their own files and
 * headers (scene_coupling, scene_collider, scene_output), included here for the tools.
 */
#ifndef DEFSIM_TOOLS_SCENE_H
#define DEFSIM_TOOLS_SCENE_H

#include "scene_collider.h"
#include "scene_coupling.h"
#include "scene_output.h"
#include "scene_types.h"

/* Reads and checks a scene file. `overrides` are "key.path=JSON" strings applied before the
 * checks (a value that is not JSON is taken as a string). Returns 0, or -1 with s->error set
 * (the scene is then freed). Relative mesh paths are taken from the scene file's folder. */
int scene_load(scene *s, const char *path, const char *const *overrides, int noverrides);
/* scene_load with limits other than the defaults (NULL: the defaults). */
int scene_load_limited(scene *s, const char *path, const char *const *overrides, int noverrides,
                       const scene_limits *limits);

/* scene_load from `len` bytes of JSON text (copied), named `label` in messages ("<string>" for
 * NULL), with mesh paths relative to the folder `dir` (NULL or "": the working directory). */
int scene_load_string(scene *s, const char *json, size_t len, const char *label,
                      const char *dir, const char *const *overrides, int noverrides);

/* Creates the world, sets the backend settings given by key (world.tolerance ..., each as the
 * option "<backend>.<key>" where the backend has one; ignored where it has none) and then
 * world.options (those of another backend than the world's are skipped with a warning on
 * stderr), and adds the bodies with their pins, external forces, driven pins and attachments. Returns DEFSIM_OK or an error with s->error naming the option, body or
 * attachment (and the library's detail). */
defsim_status scene_build(scene *s, defsim_world **out);

void scene_free(scene *s);

/* The scene JSON of world `w` (tools/scene_export.c; defsim_scene_export): `s`, when not NULL,
 * is the scene that built `w` (its names, colours, drives and keyed paths are written too), and
 * h, duration the run's (<= 0: the scene's). On success *json is malloc'd text (free it) and
 * *length its length (may be NULL). Errors as defsim_scene_export, with the reason in err. */
defsim_status scene_export(const scene *s, const defsim_world *w, double h, double duration,
                           char **json, size_t *length, char *err, size_t errsz);

/* Gives backend setting `which` (SCENE_TOLERANCE ...) the value scene_build sets, as the scene
 * file's key does (tools that override a scene's tolerances). */
void scene_setting(scene *s, int which, double value);

/* The material model a scene's "model" names: case, '-', '_', '.' and spaces are ignored, so
 * "co-rotated", "Corotated" and "stable neo-Hookean" are accepted, as are "StVK",
 * "St. Venant-Kirchhoff" and "mass-spring". Returns 1 and sets *out, or 0 for an unknown name. */
int scene_model_from_name(const char *name, defsim_model *out);

/* Bounds of the initial positions of all bodies. */
void scene_bounds(const scene *s, double lo[3], double hi[3]);

#endif
