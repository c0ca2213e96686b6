/* SPDX-License-Identifier: MIT */
/*
 * Scene files: checks every key and value of the world and the bodies and builds a world.
 * The JSON layer (positions, typed access, overrides) is scene_json.c; the output and camera
 * settings are scene_output.c.
 *
 * Forces, driven pins and attachments are scene_coupling.c; colliders are scene_collider.c. The
 * types are scene_types.h, so those files need nothing of this one: scene.c calls them, never
 * the other way round.
 *
 * Contents: world; bodies (transform, mesh, material, pins); scene_load; scene_build.
 */
#include "scene.h"
#include "scene_json.h"

#include "fileio.h"
#include "../src/file_read.h"

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* ------------------------------------------------------------------------------------------ */
/* World */

/* world.options: {"sundials_ida.rtol": 1e-6, "core.simd": "generic", "core.auto_substep": true}.
 * Shapes are checked here (with positions); values by the library when scene_build sets them. */
static int parse_options(sj_ctx *c, const cJSON *o)
{
    if (!o) return 0;
    if (!cJSON_IsObject(o)) return sj_fail(c, o, "world.options must be an object of option names");
    for (const cJSON *e = o->child; e; e = e->next) {
        const char *dot = strchr(e->string, '.');
        if (!dot || dot == e->string || !dot[1])
            return sj_fail(c, e, "world.options: \"%s\" is not of the form core.<name> or "
                           "<backend>.<name>", e->string);
        if (!cJSON_IsNumber(e) && !cJSON_IsString(e) && !cJSON_IsBool(e))
            return sj_fail(c, e, "world.options.%s must be a number, a string or true/false",
                           e->string);
    }
    c->s->options = cJSON_Duplicate(o, 1);
    if (!c->s->options) return sj_fail(c, o, "out of memory");
    return 0;
}

/* The keys of scene settings (SCENE_TOLERANCE ...), which are the options' names. */
static const char *const SETTING_KEYS[SCENE_SETTINGS] = {
    "tolerance", "max_iterations", "rtol", "atol", "projection", "max_order",
    "max_internal_steps"};

void scene_setting(scene *s, int which, double value)
{
    s->settings[which] = value;
    s->settings_given[which] = 1;
}

/* The settings given by key: each sets "<backend>.<key>" where the backend has that option (a
 * scene written for one backend runs on another, which ignores what it lacks) and
 * world.options does not name it (the option by name wins). */
static defsim_status apply_settings(scene *s, defsim_world *w)
{
    for (int k = 0; k < SCENE_SETTINGS; ++k) {
        if (!s->settings_given[k]) continue;
        char name[128];
        snprintf(name, sizeof name, "%s.%s", s->backend, SETTING_KEYS[k]);
        double now;
        if (defsim_world_get_option(w, name, &now) != DEFSIM_OK) continue;
        if (s->options && cJSON_GetObjectItemCaseSensitive(s->options, name)) continue;
        const defsim_status st = defsim_world_set_option_number(w, name, s->settings[k]);
        if (st != DEFSIM_OK) {
            snprintf(s->error, sizeof s->error, "%s: world.%s = %g (option %s): %s: %s", s->path,
                     SETTING_KEYS[k], s->settings[k], name, defsim_status_string(st),
                     defsim_world_last_error(w));
            return st;
        }
    }
    return DEFSIM_OK;
}

static defsim_status apply_options(scene *s, defsim_world *w)
{
    const defsim_status st = apply_settings(s, w);
    if (st != DEFSIM_OK) return st;
    for (const cJSON *e = s->options ? s->options->child : NULL; e; e = e->next) {
        const size_t plen = (size_t)(strchr(e->string, '.') - e->string);
        if (!(plen == 4 && !strncmp(e->string, "core", 4)) &&
            !(plen == strlen(s->backend) && !strncmp(e->string, s->backend, plen))) {
            fprintf(stderr, "warning: %s: world.options \"%s\" is not for this run's backend "
                    "%s: skipped\n", s->path, e->string, s->backend);
            continue;
        }
        defsim_status st = cJSON_IsString(e)
            ? defsim_world_set_option(w, e->string, e->valuestring)
            : defsim_world_set_option_number(w, e->string, cJSON_IsNumber(e) ? e->valuedouble
                                                                             : cJSON_IsTrue(e));
        if (st != DEFSIM_OK) {
            snprintf(s->error, sizeof s->error, "%s: world.options \"%s\": %s: %s", s->path,
                     e->string, defsim_status_string(st), defsim_world_last_error(w));
            return st;
        }
    }
    return DEFSIM_OK;
}

static int parse_world(sj_ctx *c, const cJSON *w)
{
    scene *s = c->s;
    static const char *const keys[] = {"backend", "h", "duration", "frame_steps", "fps",
                                       "gravity", "threads", "tolerance", "max_iterations",
                                       "rtol", "atol", "projection", "max_order",
                                       "max_internal_steps", "options", NULL};
    if (sj_keys(c, w, "world", keys)) return -1;
    defsim_world_def_init(&s->def, sizeof s->def);
    const cJSON *b = cJSON_GetObjectItemCaseSensitive(w, "backend");
    if (b) {
        if (!cJSON_IsString(b) || !b->valuestring[0] || strlen(b->valuestring) >= sizeof s->backend)
            return sj_fail(c, b, "world.backend must be a backend name");
        snprintf(s->backend, sizeof s->backend, "%s", b->valuestring);
    } else {
        snprintf(s->backend, sizeof s->backend, "%s", "symplectic_euler");
    }
    s->def.backend = s->backend;
    const cJSON *hj = sj_require(c, w, "h", "world");
    const cJSON *dj = sj_require(c, w, "duration", "world");
    if (!hj || !dj) return -1;
    if (sj_number(c, w, "h", "world", 0.0, 1e300, 1, &s->h) ||
        sj_number(c, w, "duration", "world", 0.0, 1e300, 1, &s->duration))
        return -1;
    const cJSON *fs = cJSON_GetObjectItemCaseSensitive(w, "frame_steps");
    const cJSON *fps = cJSON_GetObjectItemCaseSensitive(w, "fps");
    if (fs && fps) return sj_fail(c, fps, "world: give \"frame_steps\" or \"fps\", not both");
    s->frame_steps = 0;
    if (sj_int(c, w, "frame_steps", "world", 1, 1000000000, &s->frame_steps)) return -1;
    if (fps) {
        double f = 0.0;
        if (sj_number(c, w, "fps", "world", 0.0, 1e300, 1, &f)) return -1;
        const double steps = 1.0 / (f * s->h);
        if (!(steps <= 1e9))
            return sj_fail(c, fps, "world.fps = %g: 1 / (fps h) = %.3g steps per frame, more "
                           "than 1e9", f, steps);
        s->frame_steps = (int32_t)lround(steps);
        if (s->frame_steps < 1 || fabs(steps - s->frame_steps) > 1e-6 * steps)
            return sj_fail(c, fps, "world.fps = %g: 1 / (fps h) = %.6g steps per frame is not a "
                           "whole number; change h or fps, or give frame_steps", f, steps);
    }
    if (s->frame_steps == 0) {
        const double steps = 1.0 / (30.0 * s->h);   /* about 30 frames per second */
        /* Bounded before the conversion, which wraps for a tiny h. */
        if (steps > 1e9)
            return sj_fail(c, hj, "world.h = %g: a frame of 1/30 s would take %.3g steps (at "
                           "most 1e9); give a larger h, or \"frame_steps\"", s->h, steps);
        s->frame_steps = steps < 1.0 ? 1 : (int32_t)lround(steps);
    }
    const double frames = ceil(s->duration / (s->h * s->frame_steps) - 1e-9);
    if (frames > 1e8 || frames * s->frame_steps > 9e15)
        return sj_fail(c, dj, "world.duration gives %g frames: too many", frames);
    s->frames = frames < 1 ? 1 : (int32_t)frames;
    const double steps = (double)s->frames * s->frame_steps;
    if (steps > (double)s->limits.max_steps)
        return sj_fail(c, dj, "world.duration = %g s at h = %g s (%d frames of %d steps) takes "
                       "%.0f steps, more than the limit of %lld (defsim run --max-steps N raises "
                       "it)", s->duration, s->h, (int)s->frames, (int)s->frame_steps, steps,
                       (long long)s->limits.max_steps);
    if (sj_vec3(c, w, "gravity", "world", s->def.gravity) ||
        sj_int(c, w, "threads", "world", 0, 4096, &s->def.num_threads))
        return -1;
    /* The backend settings by key: their shapes here, their ranges by the library when
     * scene_build sets them (counts within the bounds they always had). */
    for (int k = 0; k < SCENE_SETTINGS; ++k) {
        const cJSON *e = cJSON_GetObjectItemCaseSensitive(w, SETTING_KEYS[k]);
        if (!e) continue;
        double v = 0.0;
        if (k == SCENE_PROJECTION) {
            static const char *const names[] = {"none", "clamp", "abs", "auto"};
            int found = -1;
            for (int i = 0; i < 4; ++i)
                if (cJSON_IsString(e) && !strcmp(e->valuestring, names[i])) found = i;
            if (found < 0)
                return sj_fail(c, e, "world.projection must be \"none\", \"clamp\", \"abs\" or "
                                     "\"auto\"");
            v = found;
        } else if (k == SCENE_MAX_ITERATIONS || k == SCENE_MAX_ORDER ||
                   k == SCENE_MAX_INTERNAL_STEPS) {
            const int hi = k == SCENE_MAX_ORDER ? 5 : k == SCENE_MAX_ITERATIONS ? 1000000
                                                                                 : 2000000000;
            int32_t n = 0;
            if (sj_int(c, w, SETTING_KEYS[k], "world", 1, hi, &n)) return -1;
            v = n;
        } else if (sj_number(c, w, SETTING_KEYS[k], "world", 0.0, 1e300, 1, &v)) {
            return -1;
        }
        scene_setting(s, k, v);
    }
    return parse_options(c, cJSON_GetObjectItemCaseSensitive(w, "options"));
}

/* ------------------------------------------------------------------------------------------ */
/* Bodies */

/* Applies p' = center + translate + R (S (M (p - center))) to n points. */
static int parse_transform(sj_ctx *c, const cJSON *j, const char *what,
                           const double *default_center, const double *in, double *out, int32_t n,
                           double *det_out)
{
    static const char *const keys[] = {"matrix", "scale", "rotate", "translate", "center", NULL};
    if (sj_keys(c, j, what, keys)) return -1;
    double M[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1}, S[3] = {1, 1, 1}, R[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1};
    double t[3] = {0, 0, 0}, ctr[3] = {0, 0, 0};
    if (default_center) memcpy(ctr, default_center, sizeof ctr);
    char w[200];
    const cJSON *m = cJSON_GetObjectItemCaseSensitive(j, "matrix");
    if (m) {
        if (!cJSON_IsArray(m) || cJSON_GetArraySize(m) != 3)
            return sj_fail(c, m, "%s.matrix must be 3 rows of 3 numbers", what);
        int r = 0;
        for (const cJSON *row = m->child; row; row = row->next, ++r) {
            snprintf(w, sizeof w, "%s.matrix[%d]", what, r);
            if (sj_vec(c, row, w, 3, M + 3 * r)) return -1;
        }
    }
    const cJSON *sc = cJSON_GetObjectItemCaseSensitive(j, "scale");
    if (sc) {
        if (cJSON_IsNumber(sc)) S[0] = S[1] = S[2] = sc->valuedouble;
        else if (snprintf(w, sizeof w, "%s.scale", what), sj_vec(c, sc, w, 3, S)) return -1;
        for (int i = 0; i < 3; ++i)
            if (!isfinite(S[i]) || S[i] == 0.0)
                return sj_fail(c, sc, "%s.scale must be finite and non-zero", what);
    }
    const cJSON *rot = cJSON_GetObjectItemCaseSensitive(j, "rotate");
    if (rot) {
        static const char *const rkeys[] = {"axis", "degrees", NULL};
        snprintf(w, sizeof w, "%s.rotate", what);
        double axis[3] = {0, 0, 1}, deg = 0.0;
        if (sj_keys(c, rot, w, rkeys) || sj_vec3(c, rot, "axis", w, axis) ||
            sj_number(c, rot, "degrees", w, -1e6, 1e6, 0, &deg))
            return -1;
        const double l = sqrt(axis[0] * axis[0] + axis[1] * axis[1] + axis[2] * axis[2]);
        if (!(l > 0.0)) return sj_fail(c, rot, "%s.rotate.axis must not be zero", what);
        const double x = axis[0] / l, y = axis[1] / l, z = axis[2] / l;
        const double a = deg * 3.14159265358979323846 / 180.0, co = cos(a), si = sin(a), k = 1.0 - co;
        const double Rr[9] = {co + x * x * k, x * y * k - z * si, x * z * k + y * si,
                              y * x * k + z * si, co + y * y * k, y * z * k - x * si,
                              z * x * k - y * si, z * y * k + x * si, co + z * z * k};
        memcpy(R, Rr, sizeof R);
    }
    if (sj_vec3(c, j, "translate", what, t) || sj_vec3(c, j, "center", what, ctr)) return -1;
    double A[9];   /* R S M */
    for (int r = 0; r < 3; ++r)
        for (int col = 0; col < 3; ++col) {
            double v = 0.0;
            for (int k = 0; k < 3; ++k) v += R[3 * r + k] * S[k] * M[3 * k + col];
            A[3 * r + col] = v;
        }
    *det_out = A[0] * (A[4] * A[8] - A[5] * A[7]) - A[1] * (A[3] * A[8] - A[5] * A[6]) +
               A[2] * (A[3] * A[7] - A[4] * A[6]);
    if (!(fabs(*det_out) > 1e-300)) return sj_fail(c, j, "%s is singular", what);
    for (int32_t i = 0; i < n; ++i) {
        const double d[3] = {in[3 * i] - ctr[0], in[3 * i + 1] - ctr[1], in[3 * i + 2] - ctr[2]};
        for (int r = 0; r < 3; ++r)
            out[3 * i + r] = ctr[r] + t[r] + A[3 * r] * d[0] + A[3 * r + 1] * d[1] + A[3 * r + 2] * d[2];
    }
    return 0;
}

enum { MESH_FILE, MESH_BOX, MESH_CLOTH, MESH_ROPE, MESH_INLINE };

/* A mesh of n more vertices must fit within limits.max_vertices with the bodies before it:
 * checked before a generator makes it. */
static int vertex_budget(sj_ctx *c, const cJSON *where, const char *what, double n)
{
    const double total = (double)c->s->vertex_count + n;
    if (total <= (double)c->s->limits.max_vertices) return 0;
    return sj_fail(c, where, "%s: %.0f vertices would make %.0f in the scene, more than the "
                   "limit of %lld (defsim run --max-vertices N raises it)", what, n, total,
                   (long long)c->s->limits.max_vertices);
}

static int parse_mesh(sj_ctx *c, const cJSON *j, const char *what, scene_body *b, int *kind,
                      int32_t *bending, int32_t *shear_first, int32_t *shear_count)
{
    *bending = *shear_first = *shear_count = 0;
    *kind = MESH_FILE;
    defsim_mesh *m = &b->mesh;
    memset(m, 0, sizeof *m);
    m->size = sizeof *m;
    char w[200];
    snprintf(w, sizeof w, "%s.mesh", what);
    const char *file = NULL;
    const cJSON *where_node = j;
    if (cJSON_IsString(j)) file = j->valuestring;
    else if (cJSON_IsObject(j)) {
        const cJSON *type = sj_require(c, j, "type", w);
        if (!type) return -1;
        if (!cJSON_IsString(type)) return sj_fail(c, type, "%s.type must be a string", w);
        const char *ty = type->valuestring;
        defsim_status st = DEFSIM_OK;
        if (!strcmp(ty, "box")) {
            static const char *const keys[] = {"type", "lo", "hi", "cells", "quadratic", NULL};
            double lo[3], hi[3], cells[3];
            const cJSON *qj = cJSON_GetObjectItemCaseSensitive(j, "quadratic");
            if (qj && !cJSON_IsBool(qj))
                return sj_fail(c, qj, "%s.quadratic must be true or false", w);
            const int quad = qj && cJSON_IsTrue(qj);
            if (sj_keys(c, j, w, keys) || !sj_require(c, j, "lo", w) ||
                !sj_require(c, j, "hi", w) || !sj_require(c, j, "cells", w) || sj_vec3(c, j, "lo", w, lo) ||
                sj_vec3(c, j, "hi", w, hi) || sj_vec3(c, j, "cells", w, cells))
                return -1;
            for (int i = 0; i < 3; ++i) {
                if (cells[i] != floor(cells[i]) || cells[i] < 1 || cells[i] > 1e4)
                    return sj_fail(c, cJSON_GetObjectItemCaseSensitive(j, "cells"),
                                   "%s.cells must be 3 integers >= 1", w);
                if (!(hi[i] > lo[i]))
                    return sj_fail(c, cJSON_GetObjectItemCaseSensitive(j, "hi"),
                                   "%s: hi must be above lo on every axis", w);
            }
            const int r = quad ? 2 : 1;   /* quadratic: a vertex at every edge's middle too */
            if (vertex_budget(c, cJSON_GetObjectItemCaseSensitive(j, "cells"), w,
                              (r * cells[0] + 1) * (r * cells[1] + 1) * (r * cells[2] + 1)))
                return -1;
            *kind = MESH_BOX;
            st = defsim_mesh_box(lo, hi, (int32_t)cells[0], (int32_t)cells[1], (int32_t)cells[2], m);
            if (st == DEFSIM_OK && quad) st = defsim_mesh_make_quadratic(m);
        } else if (!strcmp(ty, "cloth")) {
            static const char *const keys[] = {"type", "origin", "u", "v", "cells", NULL};
            double o[3], u[3], v[3], cells[2];
            const cJSON *cj = cJSON_GetObjectItemCaseSensitive(j, "cells");
            if (sj_keys(c, j, w, keys) || !sj_require(c, j, "origin", w) || !sj_require(c, j, "u", w) ||
                !sj_require(c, j, "v", w) || !sj_require(c, j, "cells", w) ||
                sj_vec3(c, j, "origin", w, o) || sj_vec3(c, j, "u", w, u) ||
                sj_vec3(c, j, "v", w, v) || sj_vec(c, cj, "cells", 2, cells))
                return -1;
            if (cells[0] != floor(cells[0]) || cells[1] != floor(cells[1]) || cells[0] < 1 ||
                cells[1] < 1 || cells[0] * cells[1] > 1e7)
                return sj_fail(c, cj, "%s.cells must be 2 integers >= 1", w);
            if (vertex_budget(c, cj, w, (cells[0] + 1) * (cells[1] + 1))) return -1;
            const int32_t nu = (int32_t)cells[0], nv = (int32_t)cells[1];
            *kind = MESH_CLOTH;
            st = defsim_mesh_cloth(o, u, v, nu, nv, m);
            *shear_first = nu * (nv + 1) + (nu + 1) * nv;
            *shear_count = 2 * nu * nv;
            *bending = (nu - 1) * (nv + 1) + (nu + 1) * (nv - 1);
        } else if (!strcmp(ty, "rope")) {
            static const char *const keys[] = {"type", "a", "b", "segments", NULL};
            double a[3], bb[3];
            int32_t seg = 0;
            if (sj_keys(c, j, w, keys) || !sj_require(c, j, "a", w) || !sj_require(c, j, "b", w) ||
                !sj_require(c, j, "segments", w) || sj_vec3(c, j, "a", w, a) ||
                sj_vec3(c, j, "b", w, bb) || sj_int(c, j, "segments", w, 1, 10000000, &seg) ||
                vertex_budget(c, cJSON_GetObjectItemCaseSensitive(j, "segments"), w,
                              (double)seg + 1))
                return -1;
            *kind = MESH_ROPE;
            st = defsim_mesh_rope(a, bb, seg, m);
            *bending = seg - 1;
        } else if (!strcmp(ty, "inline")) {
            /* The arrays themselves (what defsim_scene_export writes): rows or flat lists. */
            static const char *const keys[] = {"type", "positions", "tets", "triangles",
                                               "springs", "spring_kinds", "tet_nodes", NULL};
            const cJSON *pj = sj_require(c, j, "positions", w);
            if (sj_keys(c, j, w, keys) || !pj) return -1;
            char wa[240];
            snprintf(wa, sizeof wa, "%s.positions", w);
            if (sj_doubles(c, pj, wa, 3, &m->positions, &m->vertex_count)) return -1;
            if (m->vertex_count < 1) return sj_fail(c, pj, "%s needs at least one vertex", wa);
            if (vertex_budget(c, pj, w, m->vertex_count)) return -1;
            const int32_t top = m->vertex_count - 1;
            static const char *const names[] = {"tets", "triangles", "springs"};
            int widths[] = {4, 3, 2};
            if (cJSON_GetObjectItemCaseSensitive(j, "tet_nodes")) {
                int32_t tn = 4;
                if (sj_int(c, j, "tet_nodes", w, 4, 10, &tn)) return -1;
                if (tn != 4 && tn != 10)
                    return sj_fail(c, cJSON_GetObjectItemCaseSensitive(j, "tet_nodes"),
                                   "%s.tet_nodes must be 4 or 10", w);
                widths[0] = tn;
                m->tet_nodes = tn;
            }
            int32_t **arrays[] = {&m->tets, &m->triangles, &m->springs};
            int32_t *counts[] = {&m->tet_count, &m->triangle_count, &m->spring_count};
            for (int a = 0; a < 3; ++a) {
                const cJSON *e = cJSON_GetObjectItemCaseSensitive(j, names[a]);
                snprintf(wa, sizeof wa, "%s.%s", w, names[a]);
                if (e && sj_ints(c, e, wa, widths[a], 0, top, arrays[a], counts[a])) return -1;
            }
            const cJSON *kj = cJSON_GetObjectItemCaseSensitive(j, "spring_kinds");
            if (kj) {
                int32_t nk = 0;
                snprintf(wa, sizeof wa, "%s.spring_kinds", w);
                if (sj_ints(c, kj, wa, 1, DEFSIM_SPRING_STRETCH, DEFSIM_SPRING_BEND,
                            &m->spring_kinds, &nk))
                    return -1;
                if (nk != m->spring_count)
                    return sj_fail(c, kj, "%s has %d entries for %d springs", wa, (int)nk,
                                   (int)m->spring_count);
            }
            *kind = MESH_INLINE;
            /* Drawn as lines: a body of springs alone, its leading stretch springs. */
            if (m->tet_count == 0 && m->triangle_count == 0 && m->spring_kinds) {
                int32_t lead = 0;
                while (lead < m->spring_count && m->spring_kinds[lead] == DEFSIM_SPRING_STRETCH)
                    ++lead;
                *bending = m->spring_count - lead;
            }
        } else if (!strcmp(ty, "file")) {
            static const char *const keys[] = {"type", "path", NULL};
            const cJSON *p = sj_require(c, j, "path", w);
            if (sj_keys(c, j, w, keys) || !p) return -1;
            if (!cJSON_IsString(p)) return sj_fail(c, p, "%s.path must be a string", w);
            file = p->valuestring;
            where_node = p;
        } else {
            return sj_fail(c, type, "%s.type \"%s\" is unknown (known: box, cloth, rope, file, "
                           "inline)", w, ty);
        }
        if (st != DEFSIM_OK)
            return sj_fail(c, j, "%s: %s: %s", w, defsim_status_string(st), defsim_last_error());
    } else {
        return sj_fail(c, j, "%s must be a file name or an object with \"type\"", w);
    }
    if (file) {
        char full[2200];
        if (file[0] == '/') snprintf(full, sizeof full, "%s", file);
        else snprintf(full, sizeof full, "%s%s", c->dir, file);
        defsim_status st = defsim_mesh_load(full, m);
        c->s->io_failure = st == DEFSIM_ERR_IO;
        if (st != DEFSIM_OK)
            return sj_fail(c, where_node, "%s: %s: %s", w, defsim_status_string(st),
                           defsim_last_error());
        if (vertex_budget(c, where_node, w, m->vertex_count)) return -1;
    }
    return 0;
}

int scene_model_from_name(const char *name, defsim_model *out)
{
    /* The name folded to lower case without separators, so that the README's spellings
     * ("co-rotated", "stable neo-Hookean", "St. Venant-Kirchhoff") all name their model. */
    char key[64];
    size_t n = 0;
    for (const char *p = name; *p; ++p) {
        if (*p == '-' || *p == '_' || *p == ' ' || *p == '.') continue;
        if (n + 1 >= sizeof key) return 0;
        key[n++] = (char)(*p >= 'A' && *p <= 'Z' ? *p - 'A' + 'a' : *p);
    }
    key[n] = '\0';
    static const struct { const char *key; defsim_model m; } models[] = {
        {"spring", DEFSIM_MODEL_SPRING}, {"springs", DEFSIM_MODEL_SPRING},
        {"massspring", DEFSIM_MODEL_SPRING}, {"stvk", DEFSIM_MODEL_STVK},
        {"stvenantkirchhoff", DEFSIM_MODEL_STVK}, {"saintvenantkirchhoff", DEFSIM_MODEL_STVK},
        {"corotated", DEFSIM_MODEL_COROTATED}, {"corotational", DEFSIM_MODEL_COROTATED},
        {"neohookean", DEFSIM_MODEL_NEOHOOKEAN},
        {"stableneohookean", DEFSIM_MODEL_STABLE_NEOHOOKEAN}};
    for (size_t i = 0; i < sizeof models / sizeof models[0]; ++i)
        if (strcmp(key, models[i].key) == 0) {
            *out = models[i].m;
            return 1;
        }
    return 0;
}

static int parse_material(sj_ctx *c, const cJSON *j, const char *what, scene_body *b, int kind,
                          int32_t bending, int32_t shear_first, int32_t shear_count)
{
    const int tets = b->mesh.tet_count > 0;
    defsim_model model = tets ? DEFSIM_MODEL_STABLE_NEOHOOKEAN : DEFSIM_MODEL_SPRING;
    char w[200];
    snprintf(w, sizeof w, "%s.material", what);
    static const char *const keys[] = {"model", "youngs_modulus", "poisson_ratio", "density",
                                       "stiffness", "shear_stiffness", "bending_stiffness",
                                       "vertex_mass", "total_mass", "mass_damping",
                                       "stiffness_damping", NULL};
    if (j && sj_keys(c, j, w, keys)) return -1;
    /* A key of the other kind of body would be silently ignored by the library: refuse it. */
    static const char *const tet_only[] = {"youngs_modulus", "poisson_ratio", "density", NULL};
    static const char *const spring_only[] = {"stiffness", "shear_stiffness", "bending_stiffness",
                                              NULL};
    for (const char *const *k = tets ? spring_only : tet_only; j && *k; ++k) {
        const cJSON *bad = cJSON_GetObjectItemCaseSensitive(j, *k);
        if (bad)
            return sj_fail(c, bad, tets ? "%s.%s applies to spring bodies (cloth, rope), not to "
                                          "this body of tets (use youngs_modulus, poisson_ratio, "
                                          "density)"
                                        : "%s.%s applies to tet bodies, not to this spring body "
                                          "(cloth, rope: use stiffness, vertex_mass or total_mass)",
                           w, *k);
    }
    const cJSON *mj = j ? cJSON_GetObjectItemCaseSensitive(j, "model") : NULL;
    if (mj && !(cJSON_IsString(mj) && scene_model_from_name(mj->valuestring, &model)))
        return sj_fail(c, mj, "%s.model must be one of spring, stvk, corotated, neohookean, "
                       "stable_neohookean (case, '-', '_', '.' and spaces are ignored: "
                       "\"co-rotated\", \"stable neo-Hookean\" and \"StVK\" are accepted)", w);
    defsim_material *m = &b->material;
    defsim_material_init(m, sizeof *m, model);
    if (!j) return 0;
    double shear = -1.0, bend = -1.0, total = -1.0;
    if (sj_number(c, j, "youngs_modulus", w, 0.0, 1e300, 1, &m->youngs_modulus) ||
        sj_number(c, j, "poisson_ratio", w, 0.0, nextafter(0.5, 0.0), 0, &m->poisson_ratio) ||
        sj_number(c, j, "density", w, 0.0, 1e300, 0, &m->density) ||
        sj_number(c, j, "stiffness", w, 0.0, 1e300, 0, &m->stiffness) ||
        sj_number(c, j, "shear_stiffness", w, 0.0, 1e300, 0, &shear) ||
        sj_number(c, j, "bending_stiffness", w, 0.0, 1e300, 0, &bend) ||
        sj_number(c, j, "vertex_mass", w, 0.0, 1e300, 0, &m->vertex_mass) ||
        sj_number(c, j, "total_mass", w, 0.0, 1e300, 1, &total) ||
        sj_number(c, j, "mass_damping", w, 0.0, 1e300, 0, &m->mass_damping) ||
        sj_number(c, j, "stiffness_damping", w, 0.0, 1e300, 0, &m->stiffness_damping))
        return -1;
    if (total > 0.0) {
        if (cJSON_GetObjectItemCaseSensitive(j, "vertex_mass"))
            return sj_fail(c, cJSON_GetObjectItemCaseSensitive(j, "total_mass"),
                           "%s: give vertex_mass or total_mass, not both", w);
        m->vertex_mass = total / b->mesh.vertex_count;
    }
    const int kinds = kind == MESH_INLINE && b->mesh.spring_kinds;   /* inline with kinds */
    if (shear >= 0.0 && kind != MESH_CLOTH && !kinds)
        return sj_fail(c, cJSON_GetObjectItemCaseSensitive(j, "shear_stiffness"),
                       "%s: shear_stiffness needs a \"cloth\" mesh", w);
    if (bend >= 0.0 && kind != MESH_CLOTH && kind != MESH_ROPE && !kinds)
        return sj_fail(c, cJSON_GetObjectItemCaseSensitive(j, "bending_stiffness"),
                       "%s: bending_stiffness needs a \"cloth\" or \"rope\" mesh (boxes and mesh "
                       "files have no bending springs)", w);
    b->shear_k = shear;
    b->bend_k = bend;
    if ((shear >= 0.0 || bend >= 0.0) && b->mesh.spring_count > 0) {
        const int32_t ns = b->mesh.spring_count;
        b->spring_k = malloc((size_t)ns * sizeof *b->spring_k);
        if (!b->spring_k) return sj_fail(c, j, "out of memory");
        for (int32_t s = 0; s < ns; ++s) b->spring_k[s] = m->stiffness;
        if (shear >= 0.0)
            for (int32_t s = shear_first; s < shear_first + shear_count; ++s) b->spring_k[s] = shear;
        if (bend >= 0.0)
            for (int32_t s = ns - bending; s < ns; ++s) b->spring_k[s] = bend;
    }
    return 0;
}

static int parse_pins(sj_ctx *c, const cJSON *j, const char *what, scene_body *b, double tol)
{
    char w[200];
    snprintf(w, sizeof w, "%s.pin", what);
    const int32_t nv = b->mesh.vertex_count;
    const cJSON *indices = NULL, *boxes = NULL;
    if (cJSON_IsArray(j)) indices = j;
    else if (cJSON_IsObject(j)) {
        static const char *const keys[] = {"indices", "box", NULL};
        if (sj_keys(c, j, w, keys)) return -1;
        indices = cJSON_GetObjectItemCaseSensitive(j, "indices");
        boxes = cJSON_GetObjectItemCaseSensitive(j, "box");
    } else {
        return sj_fail(c, j, "%s must be an array of vertex indices or an object with \"indices\" "
                       "and/or \"box\"", w);
    }
    uint8_t *mark = calloc((size_t)nv, 1);
    if (!mark) return sj_fail(c, j, "out of memory");
    const int rc = sj_select(c, indices, boxes, w, b->mesh.positions, nv, tol, mark) ||
                   sj_marked(c, j, mark, nv, &b->pins, &b->npins);
    free(mark);
    return rc ? -1 : 0;
}

/* A body's "shell": the shell_* fields of defsim_body_def without the prefix (SI units), the
 * membrane by name; ranges are the library's to check (add_body names the bad field). */
static int parse_shell(sj_ctx *c, const cJSON *j, const char *w, scene_body *b)
{
    char ws[120];
    snprintf(ws, sizeof ws, "%s.shell", w);
    if (!cJSON_IsObject(j)) return sj_fail(c, j, "%s must be an object", ws);
    static const char *const keys[] = {"membrane", "youngs_modulus", "poisson_ratio", "thickness",
                                       "warp_modulus", "weft_modulus", "shear_modulus",
                                       "warp_poisson", "warp_direction", "areal_density",
                                       "bending_rigidity", "bending_rigidity_weft", "strain_limit",
                                       "fabric",
                                       NULL};
    if (sj_keys(c, j, ws, keys)) return -1;
    defsim_body_def *d = &b->shell;
    defsim_body_def_init(d, sizeof *d);
    /* A fabric by name first (defsim_body_def_set_fabric), so that the keys below override it. */
    const cJSON *fab = cJSON_GetObjectItemCaseSensitive(j, "fabric");
    if (fab) {
        if (!cJSON_IsString(fab)) return sj_fail(c, fab, "%s.fabric must be a string", ws);
        if (defsim_body_def_set_fabric(d, fab->valuestring) != DEFSIM_OK)
            return sj_fail(c, fab, "%s.fabric: %s", ws, defsim_last_error());
    }
    const cJSON *m = cJSON_GetObjectItemCaseSensitive(j, "membrane");
    if (m) {
        static const char *const names[] = {"none", "stvk", "neohookean", "orthotropic_stvk"};
        int found = -1;
        for (int i = 0; i < 4 && cJSON_IsString(m); ++i)
            if (strcmp(m->valuestring, names[i]) == 0) found = i;
        if (found < 0)
            return sj_fail(c, m, "%s.membrane must be \"none\", \"stvk\", \"neohookean\" or "
                           "\"orthotropic_stvk\"", ws);
        d->shell_membrane = found;
    }
    const double big = 1e300;
    if (sj_number(c, j, "youngs_modulus", ws, -big, big, 0, &d->shell_youngs_modulus) ||
        sj_number(c, j, "poisson_ratio", ws, -big, big, 0, &d->shell_poisson_ratio) ||
        sj_number(c, j, "thickness", ws, -big, big, 0, &d->shell_thickness) ||
        sj_number(c, j, "warp_modulus", ws, -big, big, 0, &d->shell_warp_modulus) ||
        sj_number(c, j, "weft_modulus", ws, -big, big, 0, &d->shell_weft_modulus) ||
        sj_number(c, j, "shear_modulus", ws, -big, big, 0, &d->shell_shear_modulus) ||
        sj_number(c, j, "warp_poisson", ws, -big, big, 0, &d->shell_warp_poisson) ||
        sj_number(c, j, "areal_density", ws, -big, big, 0, &d->shell_areal_density) ||
        sj_number(c, j, "bending_rigidity", ws, -big, big, 0, &d->shell_bending_rigidity) ||
        sj_number(c, j, "bending_rigidity_weft", ws, -big, big, 0,
                  &d->shell_bending_rigidity_weft) ||
        sj_number(c, j, "strain_limit", ws, -big, big, 0, &d->shell_strain_limit) ||
        sj_vec3(c, j, "warp_direction", ws, d->shell_warp_direction))
        return -1;
    b->has_shell = 1;
    return 0;
}

static int parse_body(sj_ctx *c, const cJSON *j, int index, scene_body *b)
{
    char w[100];
    snprintf(w, sizeof w, "bodies[%d]", index);
    static const char *const keys[] = {"name", "mesh", "transform", "material", "pin", "velocity",
                                       "initial_transform", "color", "probe", "forces", "drive",
                                       "self_contact", "collision_group", "collision_mask",
                                       "friction", "masses", "spring_stiffness",
                                       "initial_positions", "initial_velocities",
                                       "volume_averaging", "shell", "contact_thickness",
                                       NULL};
    if (sj_keys(c, j, w, keys)) return -1;
    b->line = sj_node_line(c, j);
    const cJSON *shell = cJSON_GetObjectItemCaseSensitive(j, "shell");
    if (shell && parse_shell(c, shell, w, b)) return -1;
    b->probe = -1;
    b->shear_k = b->bend_k = -1.0;
    b->self_contact = 1;
    b->collision_group = 1u;
    b->collision_mask = 0xFFFFFFFFu;
    b->friction = 0.5;
    double group = 1.0, mask = 4294967295.0;
    if (sj_bool(c, j, "self_contact", w, &b->self_contact) ||
        sj_number(c, j, "collision_group", w, 0.0, 4294967295.0, 0, &group) ||
        sj_number(c, j, "collision_mask", w, 0.0, 4294967295.0, 0, &mask) ||
        sj_number(c, j, "friction", w, 0.0, 10.0, 0, &b->friction) ||
        sj_number(c, j, "contact_thickness", w, 0.0, 1e3, 0, &b->contact_thickness) ||
        sj_bool(c, j, "volume_averaging", w, &b->volume_averaging))
        return -1;
    if (group != floor(group) || mask != floor(mask))
        return sj_fail(c, cJSON_GetObjectItemCaseSensitive(j, group != floor(group)
                                                                  ? "collision_group"
                                                                  : "collision_mask"),
                       "%s: collision_group and collision_mask must be integers in [0, 2^32)", w);
    b->collision_group = (uint32_t)group;
    b->collision_mask = (uint32_t)mask;
    scene_palette(index, b->color);
    const cJSON *name = cJSON_GetObjectItemCaseSensitive(j, "name");
    if (name) {
        if (!cJSON_IsString(name)) return sj_fail(c, name, "%s.name must be a string", w);
        snprintf(b->name, sizeof b->name, "%s", name->valuestring);
    } else {
        snprintf(b->name, sizeof b->name, "body %d", index);
    }
    const cJSON *mesh = sj_require(c, j, "mesh", w);
    int32_t bending, shear_first, shear_count;
    int kind;
    if (!mesh || parse_mesh(c, mesh, w, b, &kind, &bending, &shear_first, &shear_count)) return -1;
    b->inline_mesh = kind == MESH_INLINE;
    const int32_t nv = b->mesh.vertex_count;
    b->line_count = b->mesh.triangle_count == 0 && b->mesh.tet_count == 0
                        ? b->mesh.spring_count - bending : 0;
    const cJSON *tr = cJSON_GetObjectItemCaseSensitive(j, "transform");
    char wt[120];
    double det = 1.0;
    if (tr) {
        snprintf(wt, sizeof wt, "%s.transform", w);
        if (parse_transform(c, tr, wt, NULL, b->mesh.positions, b->mesh.positions, nv, &det))
            return -1;
        if (det < 0.0) {
            /* A mirroring placement turns every tet and triangle inside out: flip them back. */
            const int tn = b->mesh.tet_nodes == 10 ? 10 : 4;
            for (int32_t t = 0; t < b->mesh.tet_count; ++t) {
                int32_t *q = b->mesh.tets + tn * t, tmp = q[0];
                q[0] = q[1];
                q[1] = tmp;
                if (tn == 10) {   /* the mid-edge nodes follow: 12 <-> 02, 03 <-> 13 */
                    tmp = q[5]; q[5] = q[6]; q[6] = tmp;
                    tmp = q[7]; q[7] = q[8]; q[8] = tmp;
                }
            }
            for (int32_t t = 0; t < b->mesh.triangle_count; ++t) {
                int32_t *q = b->mesh.triangles + 3 * t, tmp = q[1];
                q[1] = q[2];
                q[2] = tmp;
            }
        }
    }
    const cJSON *mat = cJSON_GetObjectItemCaseSensitive(j, "material");
    if (parse_material(c, mat, w, b, kind, bending, shear_first, shear_count)) return -1;
    /* A shell's masses come from its areal density: the spring model's default vertex mass is
     * not added unless the material gives one. */
    if (b->has_shell && !(mat && (cJSON_GetObjectItemCaseSensitive(mat, "vertex_mass") ||
                                  cJSON_GetObjectItemCaseSensitive(mat, "total_mass"))))
        b->material.vertex_mass = 0.0;

    double lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
    for (int32_t i = 0; i < nv; ++i)
        for (int k = 0; k < 3; ++k) {
            lo[k] = fmin(lo[k], b->mesh.positions[3 * i + k]);
            hi[k] = fmax(hi[k], b->mesh.positions[3 * i + k]);
        }
    const double diag = sqrt((hi[0] - lo[0]) * (hi[0] - lo[0]) + (hi[1] - lo[1]) * (hi[1] - lo[1]) +
                             (hi[2] - lo[2]) * (hi[2] - lo[2]));
    const cJSON *pin = cJSON_GetObjectItemCaseSensitive(j, "pin");
    if (pin && parse_pins(c, pin, w, b, 1e-9 * diag)) return -1;
    /* Arrays of one value per vertex or spring (what defsim_scene_export writes). */
    const char *const arr_keys[] = {"masses", "spring_stiffness", "initial_positions",
                                    "initial_velocities"};
    const int arr_width[] = {1, 1, 3, 3};
    double **arr_out[] = {&b->masses, &b->spring_k, &b->initial, &b->velocity};
    const char *const arr_other[] = {NULL, NULL, "initial_transform", "velocity"};
    for (int a = 0; a < 4; ++a) {
        const cJSON *e = cJSON_GetObjectItemCaseSensitive(j, arr_keys[a]);
        if (!e) continue;
        const int32_t want = a == 1 ? b->mesh.spring_count : nv;
        if (arr_other[a] && cJSON_GetObjectItemCaseSensitive(j, arr_other[a]))
            return sj_fail(c, e, "%s: give %s or %s, not both", w, arr_keys[a], arr_other[a]);
        if (a == 1 && (b->spring_k || b->mesh.spring_kinds))
            return sj_fail(c, e, "%s: spring_stiffness (one per spring) cannot be combined with "
                           "stiffness by kind (the mesh's spring kinds, shear_stiffness, "
                           "bending_stiffness)", w);
        char wa[140];
        snprintf(wa, sizeof wa, "%s.%s", w, arr_keys[a]);
        int32_t n = 0;
        if (sj_doubles(c, e, wa, arr_width[a], arr_out[a], &n)) return -1;
        if (n != want)
            return sj_fail(c, e, "%s has %d entries for %d %s", wa, (int)n, (int)want,
                           a == 1 ? "springs" : "vertices");
    }
    const cJSON *it = cJSON_GetObjectItemCaseSensitive(j, "initial_transform");
    if (it) {
        const double center[3] = {0.5 * (lo[0] + hi[0]), 0.5 * (lo[1] + hi[1]), 0.5 * (lo[2] + hi[2])};
        b->initial = malloc(3 * (size_t)nv * sizeof *b->initial);
        if (!b->initial) return sj_fail(c, it, "out of memory");
        snprintf(wt, sizeof wt, "%s.initial_transform", w);
        if (parse_transform(c, it, wt, center, b->mesh.positions, b->initial, nv, &det)) return -1;
    }
    double vel[3];
    const cJSON *vj = cJSON_GetObjectItemCaseSensitive(j, "velocity");
    if (vj) {
        if (sj_vec3(c, j, "velocity", w, vel)) return -1;
        b->velocity = malloc(3 * (size_t)nv * sizeof *b->velocity);
        if (!b->velocity) return sj_fail(c, vj, "out of memory");
        for (int32_t i = 0; i < nv; ++i) memcpy(b->velocity + 3 * i, vel, sizeof vel);
    }
    const cJSON *fj = cJSON_GetObjectItemCaseSensitive(j, "forces");
    const cJSON *drive = cJSON_GetObjectItemCaseSensitive(j, "drive");
    if ((fj && scene_parse_forces(c, fj, w, b, 1e-9 * diag)) ||
        (drive && scene_parse_drive(c, drive, w, b, 1e-9 * diag)))
        return -1;
    const cJSON *col = cJSON_GetObjectItemCaseSensitive(j, "color");
    if (col) {
        double rgb[3];
        if (sj_vec3(c, j, "color", w, rgb)) return -1;
        for (int k = 0; k < 3; ++k) {
            if (rgb[k] < 0.0 || rgb[k] > 1.0)
                return sj_fail(c, col, "%s.color components must be in [0, 1]", w);
            b->color[k] = (float)rgb[k];
        }
    }
    const cJSON *probe = cJSON_GetObjectItemCaseSensitive(j, "probe");
    if (probe) {
        if (cJSON_IsNumber(probe)) {
            if (probe->valuedouble != floor(probe->valuedouble) || probe->valuedouble < 0 ||
                probe->valuedouble >= nv)
                return sj_fail(c, probe, "%s.probe must be a vertex index in [0, %d) or a point",
                            w, (int)nv);
            b->probe = (int32_t)probe->valuedouble;
        } else {
            /* The vertex nearest to the point, at rest. */
            double p[3];
            if (sj_vec3(c, j, "probe", w, p)) return -1;
            double best = INFINITY;
            for (int32_t i = 0; i < nv; ++i) {
                const double *q = b->mesh.positions + 3 * i;
                const double d = (q[0] - p[0]) * (q[0] - p[0]) + (q[1] - p[1]) * (q[1] - p[1]) +
                                 (q[2] - p[2]) * (q[2] - p[2]);
                if (d < best) { best = d; b->probe = i; }
            }
        }
    }
    return 0;
}

/* ------------------------------------------------------------------------------------------ */
/* Loading and building */

void scene_free(scene *s)
{
    if (!s) return;
    for (int32_t i = 0; i < s->nbodies; ++i) {
        scene_body *b = &s->bodies[i];
        defsim_mesh_free(&b->mesh);
        free(b->initial); free(b->velocity); free(b->spring_k); free(b->pins); free(b->masses);
    }
    scene_free_coupling(s);
    scene_free_colliders(s);
    free(s->bodies);
    s->bodies = NULL;
    s->nbodies = 0;
    cJSON_Delete(s->options);
    s->options = NULL;
}

int scene_load(scene *s, const char *path, const char *const *overrides, int noverrides)
{
    return scene_load_limited(s, path, overrides, noverrides, NULL);
}

/* What scene_load_limited and scene_load_string share: the scene named `label` in messages
 * (its file name gives the scene's name), mesh paths relative to `dir` ("" or ending in '/'). */
static void load_begin(scene *s, sj_ctx *c, const char *label, const char *dir,
                       const scene_limits *limits)
{
    memset(s, 0, sizeof *s);
    s->limits.max_vertices = limits ? limits->max_vertices : SCENE_MAX_VERTICES;
    s->limits.max_steps = limits ? limits->max_steps : SCENE_MAX_STEPS;
    snprintf(s->path, sizeof s->path, "%s", label);
    const char *base = strrchr(label, '/');
    base = base ? base + 1 : label;
    snprintf(s->name, sizeof s->name, "%s", base);
    size_t nl = strlen(s->name);
    if (nl > 5 && !strcmp(s->name + nl - 5, ".json")) s->name[nl - 5] = '\0';
    scene_output_defaults(s);
    memset(c, 0, sizeof *c);
    c->s = s;
    snprintf(c->dir, sizeof c->dir, "%s", dir);
}

static int load_text(scene *s, sj_ctx *c, char *text, size_t len, const char *const *overrides,
                     int noverrides);

int scene_load_string(scene *s, const char *json, size_t len, const char *label,
                      const char *dir, const char *const *overrides, int noverrides)
{
    sj_ctx c;
    char folder[1024] = "";
    if (dir && dir[0])
        snprintf(folder, sizeof folder, "%s%s", dir, dir[strlen(dir) - 1] == '/' ? "" : "/");
    load_begin(s, &c, label && label[0] ? label : "<string>", folder, NULL);
    char *text = malloc(len + 1);
    if (!text) {
        snprintf(s->error, sizeof s->error, "out of memory");
        return -1;
    }
    memcpy(text, json, len);
    text[len] = '\0';
    return load_text(s, &c, text, len, overrides, noverrides);
}

int scene_load_limited(scene *s, const char *path, const char *const *overrides, int noverrides,
                       const scene_limits *limits)
{
    sj_ctx c;
    const char *base = strrchr(path, '/');
    char dir[1024] = "";
    if (base) snprintf(dir, sizeof dir, "%.*s", (int)(base + 1 - path), path);
    load_begin(s, &c, path, dir, limits);
    size_t len = 0;
    char *text = tools_read_file(path, &len);
    if (!text) {
        snprintf(s->error, sizeof s->error, "%s: cannot read the scene file: %s", path,
                 defsim__read_strerror(errno));
        s->io_failure = 1;
        return -1;
    }
    return load_text(s, &c, text, len, overrides, noverrides);
}

/* Parses and checks `text` (malloc'd; freed here). */
static int load_text(scene *s, sj_ctx *c_, char *text, size_t len, const char *const *overrides,
                     int noverrides)
{
    sj_ctx c = *c_;
    c.text = text;
    c.text_len = len;
    int rc = -1;
    cJSON *root = sj_parse(&c);
    if (!root) goto done;

    for (int i = 0; i < noverrides; ++i)
        if (sj_override(s, root, overrides[i])) goto done;

    static const char *const keys[] = {"description", "world", "bodies", "attachments", "output",
                                       "colliders", NULL};
    if (sj_keys(&c, root, "the scene", keys)) goto done;
    const cJSON *desc = cJSON_GetObjectItemCaseSensitive(root, "description");
    if (desc && !cJSON_IsString(desc)) { sj_fail(&c, desc, "description must be a string"); goto done; }
    const cJSON *world = sj_require(&c, root, "world", "the scene");
    if (!world || parse_world(&c, world)) goto done;
    const cJSON *out = cJSON_GetObjectItemCaseSensitive(root, "output");
    if (out && scene_parse_output(&c, out)) goto done;
    const cJSON *bodies = sj_require(&c, root, "bodies", "the scene");
    if (!bodies) goto done;
    if (!cJSON_IsArray(bodies) || cJSON_GetArraySize(bodies) < 1) {
        sj_fail(&c, bodies, "bodies must be a non-empty array");
        goto done;
    }
    const int nb = cJSON_GetArraySize(bodies);
    s->bodies = calloc((size_t)nb, sizeof *s->bodies);
    if (!s->bodies) { snprintf(s->error, sizeof s->error, "out of memory"); goto done; }
    int i = 0;
    for (const cJSON *b = bodies->child; b; b = b->next, ++i) {
        s->nbodies = i + 1;   /* so that scene_free releases what this body has so far */
        if (parse_body(&c, b, i, &s->bodies[i])) goto done;
        if (s->vertex_count > INT32_MAX / 3 - s->bodies[i].mesh.vertex_count) {
            sj_fail(&c, b, "too many vertices");
            goto done;
        }
        s->vertex_count += s->bodies[i].mesh.vertex_count;
    }
    const cJSON *att = cJSON_GetObjectItemCaseSensitive(root, "attachments");
    if (att && scene_parse_attachments(&c, att)) goto done;
    const cJSON *col = cJSON_GetObjectItemCaseSensitive(root, "colliders");
    if (col && scene_parse_colliders(&c, col)) goto done;
    rc = 0;
done:
    free(c.pos);
    cJSON_Delete(root);
    free(text);
    if (rc) scene_free(s);
    return rc;
}

defsim_status scene_build(scene *s, defsim_world **out)
{
    *out = NULL;
    defsim_world *w = NULL;
    defsim_status st = defsim_world_create(&s->def, &w);
    if (st != DEFSIM_OK) {
        snprintf(s->error, sizeof s->error, "%s: world.backend \"%s\": %s: %s", s->path,
                 s->backend, defsim_status_string(st), defsim_last_error());
        return st;
    }
    if ((st = apply_options(s, w)) != DEFSIM_OK) {
        defsim_world_destroy(w);
        return st;
    }
    for (int32_t i = 0; i < s->nbodies; ++i) {
        scene_body *b = &s->bodies[i];
        defsim_body_def bd;
        defsim_body_def_init(&bd, sizeof bd);
        bd.rest_positions = b->mesh.positions;
        bd.vertex_count = b->mesh.vertex_count;
        bd.tets = b->mesh.tets;
        bd.tet_count = b->mesh.tet_count;
        bd.tet_nodes = b->mesh.tet_nodes == 10 ? 10 : 4;
        /* Tet bodies are elastic solids: their boundary triangles and any springs of a mesh
         * file are not simulated; spring bodies use their springs. An inline mesh is taken as
         * given. */
        if (b->mesh.tet_count == 0 || b->inline_mesh) {
            bd.springs = b->mesh.springs;
            bd.spring_count = b->mesh.spring_count;
            /* Kinds where the mesh has them (the same stiffnesses as spring_k): body contact
             * takes a rope's stretch springs as its edges. A cloth's triangles are its contact
             * surface; a tet body's is its boundary, which the library extracts. */
            if (b->mesh.spring_kinds) {
                bd.spring_kinds = b->mesh.spring_kinds;
                bd.shear_stiffness = b->shear_k;
                bd.bend_stiffness = b->bend_k;
            } else {
                bd.spring_stiffness = b->spring_k;
            }
            bd.triangles = b->mesh.triangles;
            bd.triangle_count = b->mesh.triangle_count;
        }
        /* A shell takes the triangles alone: a cloth mesh's or mesh file's springs are left
         * out; an inline mesh's are taken as given (defsim_scene_export writes a shell's). */
        if (b->has_shell) {
            const defsim_body_def *sh = &b->shell;
            if (!b->inline_mesh) {
                bd.springs = NULL;
                bd.spring_count = 0;
                bd.spring_kinds = NULL;
                bd.spring_stiffness = NULL;
            }
            bd.triangles = b->mesh.triangles;
            bd.triangle_count = b->mesh.triangle_count;
            bd.shell_membrane = sh->shell_membrane;
            bd.shell_youngs_modulus = sh->shell_youngs_modulus;
            bd.shell_poisson_ratio = sh->shell_poisson_ratio;
            bd.shell_thickness = sh->shell_thickness;
            bd.shell_warp_modulus = sh->shell_warp_modulus;
            bd.shell_weft_modulus = sh->shell_weft_modulus;
            bd.shell_shear_modulus = sh->shell_shear_modulus;
            bd.shell_warp_poisson = sh->shell_warp_poisson;
            memcpy(bd.shell_warp_direction, sh->shell_warp_direction,
                   sizeof bd.shell_warp_direction);
            bd.shell_areal_density = sh->shell_areal_density;
            bd.shell_bending_rigidity = sh->shell_bending_rigidity;
            bd.shell_bending_rigidity_weft = sh->shell_bending_rigidity_weft;
            bd.shell_strain_limit = sh->shell_strain_limit;
        }
        bd.self_contact = b->self_contact;
        bd.collision_group = b->collision_group;
        bd.collision_mask = b->collision_mask;
        bd.friction = b->friction;
        bd.contact_thickness = b->contact_thickness;
        bd.volume_averaging = b->volume_averaging;
        bd.initial_positions = b->initial;
        bd.initial_velocities = b->velocity;
        bd.vertex_mass = b->masses;
        bd.material = b->material;
        st = defsim_world_add_body(w, &bd, &b->id);
        if (st == DEFSIM_OK && b->npins > 0) st = defsim_body_pin(w, b->id, b->pins, b->npins);
        if (st != DEFSIM_OK) {
            snprintf(s->error, sizeof s->error, "%s:%d: bodies[%d] (%s): %s: %s", s->path,
                     b->line, (int)i, b->name, defsim_status_string(st),
                     defsim_world_last_error(w));
            defsim_world_destroy(w);
            return st;
        }
        b->offset = defsim_body_vertex_offset(w, b->id);
    }
    st = scene_build_coupling(s, w);
    if (st == DEFSIM_OK) st = scene_build_colliders(s, w);
    if (st != DEFSIM_OK) {
        defsim_world_destroy(w);
        return st;
    }
    *out = w;
    return DEFSIM_OK;
}

void scene_bounds(const scene *s, double lo[3], double hi[3])
{
    for (int k = 0; k < 3; ++k) { lo[k] = INFINITY; hi[k] = -INFINITY; }
    for (int32_t i = 0; i < s->nbodies; ++i) {
        const scene_body *b = &s->bodies[i];
        const double *x = b->initial ? b->initial : b->mesh.positions;
        for (int32_t v = 0; v < b->mesh.vertex_count; ++v)
            for (int k = 0; k < 3; ++k) {
                lo[k] = fmin(lo[k], x[3 * v + k]);
                hi[k] = fmax(hi[k], x[3 * v + k]);
            }
    }
}
