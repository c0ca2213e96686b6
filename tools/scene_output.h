/* SPDX-License-Identifier: MIT */
/*
 * Scene files, scene_output.c: the settings of the rendered output (frames, image size, camera,
 * colours).
 */
#ifndef DEFSIM_TOOLS_SCENE_OUTPUT_H
#define DEFSIM_TOOLS_SCENE_OUTPUT_H

#include "scene_types.h"

/* The JSON layer's context (scene_json.h), named here so that the tools need no cJSON header. */
typedef struct sj_ctx sj_ctx;

/* Called by scene.c: defaults of the output settings, and the "output" section. */
void scene_output_defaults(scene *s);
int scene_parse_output(sj_ctx *c, const struct cJSON *o);

/* "body", "stress", "displacement", "speed" -> scene_color, or -1. */
int scene_color_parse(const char *name);

/* The default colour of body i. */
void scene_palette(int i, float rgb[3]);

#endif
