/* SPDX-License-Identifier: MIT */
/*
 * Private to tools/scene*.c: the JSON layer of scene files (scene_json.c): source positions,
 * typed checks, overrides and vertex selections, shared by the parsers of the scene's sections
 * (scene.c, scene_coupling.c, scene_collider.c, scene_output.c). It calls none of them.
 * Every function that checks returns 0, or -1 with s->error set to "file:line:col: message".
 */
#ifndef DEFSIM_TOOLS_SCENE_JSON_H
#define DEFSIM_TOOLS_SCENE_JSON_H

#include "scene_types.h"

#include <cjson/cJSON.h>

#include <stddef.h>
#include <stdint.h>

typedef struct sj_pos { const cJSON *node; size_t offset; } sj_pos;

/* What the parsers of one scene file share. */
typedef struct sj_ctx {
    scene *s;
    const char *text;
    size_t text_len;
    sj_pos *pos;   /* sorted by node pointer; malloc'd by sj_parse */
    size_t npos;
    char dir[1024];   /* folder of the scene file, with a trailing '/' (or empty) */
} sj_ctx;

/* Parses c->text and maps the source position of every value (c->pos). Returns the root
 * (cJSON_Delete it and free c->pos), or NULL with c->s->error set and nothing to free. */
cJSON *sj_parse(sj_ctx *c);

/* Sets c->s->error to "file:line:col: message" for `node` (the file alone for nodes that
 * overrides made) and returns -1. */
int sj_fail(sj_ctx *c, const cJSON *node, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 3, 4)))
#endif
    ;

/* The line of `node` in the file (0 for nodes that overrides made). */
int sj_node_line(const sj_ctx *c, const cJSON *node);

/* Every key of `obj` must be in the NULL-terminated list `known`, once. */
int sj_keys(sj_ctx *c, const cJSON *obj, const char *what, const char *const *known);

/* obj.key, when present, into *out: a finite number in [lo, hi] (lo excluded with lo_open), an
 * integer in [lo, hi], a boolean; `what` names obj in messages. Absent keys leave *out as is. */
int sj_number(sj_ctx *c, const cJSON *obj, const char *key, const char *what,
                     double lo, double hi, int lo_open, double *out);
int sj_int(sj_ctx *c, const cJSON *obj, const char *key, const char *what, int lo,
                  int hi, int32_t *out);
int sj_bool(sj_ctx *c, const cJSON *obj, const char *key, const char *what, int *out);
/* j as an array of n finite numbers. */
int sj_vec(sj_ctx *c, const cJSON *j, const char *what, int n, double *out);
int sj_vec3(sj_ctx *c, const cJSON *obj, const char *key, const char *what,
                   double out[3]);
/* j as a list of n rows of `width` numbers: an array of n arrays of width numbers, or a flat
 * array of width * n numbers. Doubles must be finite; integers (sj_ints) whole numbers in
 * [lo, hi]. *out is malloc'd (free it; NULL with n = 0 for an empty array). */
int sj_doubles(sj_ctx *c, const cJSON *j, const char *what, int width, double **out,
               int32_t *n);
int sj_ints(sj_ctx *c, const cJSON *j, const char *what, int width, int32_t lo, int32_t hi,
            int32_t **out, int32_t *n);
/* obj.key, or NULL with the error "what needs key". */
const cJSON *sj_require(sj_ctx *c, const cJSON *obj, const char *key, const char *what);

/* Applies one "--set a.b.0.c=JSON" to the tree (a value that is not JSON becomes a string). */
int sj_override(scene *s, cJSON *root, const char *spec);

/* Marks the vertices selected by `indices` (an array of indices) and `boxes` (a box {lo, hi} or
 * a list of them, each selecting at least one vertex within tol) among nv positions. Either
 * node may be NULL. `what` names the selection in messages. */
int sj_select(sj_ctx *c, const cJSON *indices, const cJSON *boxes, const char *what,
              const double *pos, int32_t nv, double tol, uint8_t *mark);
/* The marked vertices as a malloc'd list. */
int sj_marked(sj_ctx *c, const cJSON *where, const uint8_t *mark, int32_t nv, int32_t **out,
              int32_t *n);

#endif
