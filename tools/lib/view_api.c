/* SPDX-License-Identifier: MIT */
/* libdefsim_view (include/defsim/view.h): the viewer of tools/view on a host's world. */
#include <defsim/view.h>

#include "api_error.h"
#include "scene.h"
#include "view/viewer.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

void defsim_view_def_init(defsim_view_def *def, size_t size)
{
    if (!def || size < sizeof *def) return;
    memset(def, 0, sizeof *def);
    def->size = (uint32_t)sizeof *def;
    def->steps_per_frame = 1;
    def->width = 960;
    def->height = 600;
    def->supersample = 1;
    def->color = DEFSIM_VIEW_COLOR_BODY;
    def->show_timing = 1;
    def->gravity[1] = -9.81;
}

defsim_status defsim_view_world(defsim_world *world, const defsim_view_body *bodies,
                                int32_t count, const defsim_view_def *def,
                                defsim_view_result *result, char *err, size_t errsz)
{
    const defsim_status bad = DEFSIM_ERR_INVALID_ARGUMENT;
    if (err && errsz > 0) err[0] = '\0';
    if (!world || !def || def->size < sizeof *def || (result && result->size < sizeof *result))
        return api_fail(err, errsz, bad, "defsim_view_world: NULL world or def, or a size field "
                                         "smaller than its struct");
    if (count != defsim_world_body_count(world) || (count > 0 && !bodies))
        return api_fail(err, errsz, bad, "defsim_view_world: %d bodies given, the world has %d",
                        (int)count, (int)defsim_world_body_count(world));
    if (!isfinite(def->gravity[0]) || !isfinite(def->gravity[1]) || !isfinite(def->gravity[2]))
        return api_fail(err, errsz, bad, "defsim_view_world: gravity is not finite");
    if ((int)def->color < DEFSIM_VIEW_COLOR_BODY || (int)def->color > DEFSIM_VIEW_COLOR_SPEED)
        return api_fail(err, errsz, bad, "defsim_view_world: color %d is not a defsim_view_color",
                        (int)def->color);
    rd_body_src *src = calloc((size_t)count + 1, sizeof *src);
    if (!src) return api_fail(err, errsz, DEFSIM_ERR_OUT_OF_MEMORY, "out of memory");
    for (int32_t i = 0; i < count; ++i) {
        const defsim_view_body *b = &bodies[i];
        defsim_body_id id;
        defsim_world_body_at(world, i, &id);
        const int32_t n = defsim_body_vertex_count(world, id);
        const int32_t *arr[3] = {b->triangles, b->lines, b->tets};
        const int64_t len[3] = {3 * (int64_t)b->triangle_count, 2 * (int64_t)b->line_count,
                                4 * (int64_t)b->tet_count};
        for (int a = 0; a < 3; ++a) {
            int ok = len[a] >= 0 && (len[a] == 0 || arr[a]);
            for (int64_t k = 0; ok && k < len[a]; ++k) ok = arr[a][k] >= 0 && arr[a][k] < n;
            if (!ok) {
                free(src);
                return api_fail(err, errsz, bad, "body %d: a negative count, a NULL array, or "
                                "an index outside [0, %d)", (int)i, (int)n);
            }
        }
        src[i] = (rd_body_src){0, b->tets, b->tet_count, 0, b->triangles, b->triangle_count,
                               b->lines, b->line_count, {b->color[0], b->color[1], b->color[2]}};
        if (b->color[0] < 0.0f) scene_palette(i, src[i].color);
    }
    /* The camera of `defsim run` with its defaults, "up" against gravity. */
    scene *defaults = calloc(1, sizeof *defaults);
    if (!defaults) {
        free(src);
        return api_fail(err, errsz, DEFSIM_ERR_OUT_OF_MEMORY, "out of memory");
    }
    scene_output_defaults(defaults);
    vw_def vd = {.world = world, .bodies = src, .nbodies = count, .h = def->h,
                 .frame_steps = def->steps_per_frame, .camera = defaults->camera,
                 .width = def->width, .height = def->height, .supersample = def->supersample,
                 .color = (scene_color)def->color, .paused = def->paused != 0,
                 .timing = def->show_timing != 0, .drag_stiffness = def->drag_stiffness,
                 .script = def->script, .title = def->title ? def->title : "defsim view"};
    free(defaults);
    memcpy(vd.gravity, def->gravity, sizeof vd.gravity);
    vw_result r;
    char msg[1024];
    defsim_status st = vw_run(&vd, &r, msg, sizeof msg);
    if (st != DEFSIM_OK) api_fail(err, errsz, st, "%s", msg);
    if (result) {
        result->steps = r.steps;
        result->last_failure = r.last_failure;
        result->drag_vertex = r.drag_vertex;
        memcpy(result->drag_start, r.drag_start, sizeof r.drag_start);
        memcpy(result->drag_target, r.drag_target, sizeof r.drag_target);
        memcpy(result->drag_end, r.drag_end, sizeof r.drag_end);
        result->expectations = r.expectations;
        result->expectations_failed = r.expectations_failed;
    }
    free(src);
    return st;
}
