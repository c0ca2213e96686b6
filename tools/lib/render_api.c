/* SPDX-License-Identifier: MIT */
/* libdefsim_render (include/defsim/render.h): one checked call over the tools' OSMesa renderer. */
#include <defsim/render.h>

#include "api_error.h"
#include "fields.h"
#include "render/image.h"
#include "render/render.h"
#include "scene.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static int in_range(const int32_t *idx, int64_t n, int32_t nv)
{
    for (int64_t i = 0; i < n; ++i)
        if (idx[i] < 0 || idx[i] >= nv) return 0;
    return 1;
}

defsim_status defsim_render_png(const char *path, int32_t width, int32_t height, int32_t nv,
                                const double *x, const defsim_render_part *parts, int32_t count,
                                const double gravity[3], char *err, size_t errsz)
{
    const defsim_status bad = DEFSIM_ERR_INVALID_ARGUMENT;
    if (err && errsz > 0) err[0] = '\0';
    if (!path || !x || nv < 1 || count < 0 || (count > 0 && !parts) || !gravity ||
        width < 16 || height < 16 || width > 8192 || height > 8192)
        return api_fail(err, errsz, bad, "defsim_render_png: NULL argument, no vertex, or a size "
                                     "outside 16..8192");
    for (int32_t i = 0; i < count; ++i) {
        const defsim_render_part *p = &parts[i];
        if (p->triangle_count < 0 || p->line_count < 0 ||
            (p->triangle_count > 0 && !p->triangles) || (p->line_count > 0 && !p->lines) ||
            (p->triangles && !in_range(p->triangles, 3 * (int64_t)p->triangle_count, nv)) ||
            (p->lines && !in_range(p->lines, 2 * (int64_t)p->line_count, nv)))
            return api_fail(err, errsz, bad, "part %d: negative count, NULL array, or an index "
                                         "outside [0, %d)", (int)i, (int)nv);
    }
    double lo[3], hi[3];
    for (int k = 0; k < 3; ++k) { lo[k] = INFINITY; hi[k] = -INFINITY; }
    for (int64_t i = 0; i < nv; ++i)
        for (int k = 0; k < 3; ++k) {
            const double c = x[3 * i + k];
            if (!isfinite(c)) return api_fail(err, errsz, bad, "vertex %lld is not finite", (long long)i);
            lo[k] = fmin(lo[k], c);
            hi[k] = fmax(hi[k], c);
        }
    /* The camera and ground of `defsim run` with its defaults. */
    scene *defaults = calloc(1, sizeof *defaults);
    rd_part *rp = calloc((size_t)(count > 0 ? count : 1), sizeof *rp);
    image im = {width, height, malloc((size_t)width * height * 3)};
    if (!defaults || !rp || !im.rgb) {
        free(defaults); free(rp); free(im.rgb);
        return api_fail(err, errsz, DEFSIM_ERR_OUT_OF_MEMORY, "out of memory");
    }
    scene_output_defaults(defaults);
    rd_view view;
    rd_view_make(&defaults->camera, lo, hi, gravity, (double)width / height, &view);
    const int supersample = defaults->supersample;
    free(defaults);
    for (int32_t i = 0; i < count; ++i) {
        rp[i].tris = parts[i].triangles;
        rp[i].ntris = parts[i].triangle_count;
        rp[i].lines = parts[i].lines;
        rp[i].nlines = parts[i].line_count;
        if (parts[i].color[0] < 0.0f) scene_palette(i, rp[i].color);
        else memcpy(rp[i].color, parts[i].color, sizeof rp[i].color);
        rp[i].smooth = parts[i].smooth != 0;
    }
    char msg[1024] = "";
    defsim_status st = DEFSIM_OK;
    rd_renderer *r = rd_create(width, height, supersample, msg, sizeof msg);
    if (!r)
        st = api_fail(err, errsz, DEFSIM_ERR_BACKEND_UNAVAILABLE, "renderer: %s", msg);
    else if (rd_render(r, &view, x, rp, count, im.rgb, msg, sizeof msg))
        st = api_fail(err, errsz, DEFSIM_ERR_BACKEND_UNAVAILABLE, "renderer: %s", msg);
    else if (image_write_png(path, &im, msg, sizeof msg))
        st = api_fail(err, errsz, DEFSIM_ERR_IO, "%s", msg);
    rd_destroy(r);
    free(rp);
    free(im.rgb);
    return st;
}

void defsim_render_world_def_init(defsim_render_world_def *def, size_t size)
{
    if (!def) return;
    defsim_render_world_def d;
    memset(&d, 0, sizeof d);
    d.size = (uint32_t)sizeof d;
    d.width = 640;
    d.height = 400;
    d.color = DEFSIM_RENDER_BODY;
    d.pins = 1;
    d.colliders = 1;
    d.gravity[1] = -9.81;
    if (size > sizeof d) size = sizeof d;
    memcpy(def, &d, size);
    def->size = (uint32_t)size;
}

/* What a world render needs, freed in one place. */
typedef struct world_render {
    scene *s;               /* the output defaults of defsim run (camera, colours) */
    fields fl;
    double *x, *v;
    rd_bodies bodies;
    rd_overlay overlay;
    rd_renderer *r;
    image im;
} world_render;

static void world_render_free(world_render *wr)
{
    rd_bodies_free(&wr->bodies);
    fields_free(&wr->fl);
    free(wr->x);
    free(wr->v);
    free(wr->s);
    rd_overlay_free(&wr->overlay);
    rd_destroy(wr->r);
    free(wr->im.rgb);
}

defsim_status defsim_render_world_png(const char *path, defsim_world *w,
                                      const defsim_render_world_def *d, char *err, size_t errsz)
{
    const defsim_status bad = DEFSIM_ERR_INVALID_ARGUMENT;
    if (err && errsz > 0) err[0] = '\0';
    if (!path || !w || !d || d->size != sizeof *d || d->cell_count < 0 ||
        (d->cell_count > 0 && (!d->types || !d->offsets || !d->conn || !d->body)) ||
        d->width < 16 || d->height < 16 || d->width > 8192 || d->height > 8192 ||
        d->color < DEFSIM_RENDER_BODY || d->color > DEFSIM_RENDER_SPEED ||
        (d->color == DEFSIM_RENDER_DISPLACEMENT && !d->reference) || !(d->arrow_scale >= 0.0) ||
        !isfinite(d->color_range[0]) || !isfinite(d->color_range[1]) ||
        !isfinite(d->gravity[0]) || !isfinite(d->gravity[1]) || !isfinite(d->gravity[2]))
        return api_fail(err, errsz, bad, "defsim_render_world_png: NULL argument, a def of the "
                                     "wrong size, a size outside 16..8192, an unknown colour, "
                                     "displacement without a reference or a bad scale");
    const int32_t nv = defsim_world_vertex_count(w);
    if (nv < 1) return api_fail(err, errsz, bad, "defsim_render_world_png: the world is empty");
    char msg[1024] = "";
    vtk_cells cells;
    memset(&cells, 0, sizeof cells);
    if (vtk_check_cells(nv, d->cell_count, d->types, d->offsets, d->conn, &cells.nconn, msg,
                        sizeof msg))
        return api_fail(err, errsz, bad, "%s", msg);
    cells.conn = (int64_t *)d->conn;
    cells.offsets = (int64_t *)d->offsets;
    cells.types = (uint8_t *)d->types;
    cells.body = (int32_t *)d->body;
    cells.ncells = d->cell_count;
    world_render wr;
    memset(&wr, 0, sizeof wr);
    defsim_status st = DEFSIM_OK;
    const unsigned which =
        (d->color == DEFSIM_RENDER_STRESS ? (unsigned)SCENE_FIELD_STRESS : 0u) |
        (d->color == DEFSIM_RENDER_DISPLACEMENT ? (unsigned)SCENE_FIELD_DISPLACEMENT : 0u) |
        (d->contact_arrows ? (unsigned)SCENE_FIELD_CONTACT_FORCES : 0u);
    wr.s = calloc(1, sizeof *wr.s);
    wr.x = malloc(3 * (size_t)nv * sizeof *wr.x);
    wr.v = malloc(3 * (size_t)nv * sizeof *wr.v);
    const int32_t nc = d->colliders ? defsim_world_collider_count(w) : 0;
    wr.im = (image){d->width, d->height, malloc((size_t)d->width * d->height * 3)};
    if (!wr.s || !wr.x || !wr.v || !wr.im.rgb) {
        world_render_free(&wr);
        return api_fail(err, errsz, DEFSIM_ERR_OUT_OF_MEMORY, "out of memory");
    }
    scene_output_defaults(wr.s);
    wr.s->color = d->color;
    if (d->color_range[1] > d->color_range[0]) {
        wr.s->has_color_range = 1;
        memcpy(wr.s->color_range, d->color_range, sizeof wr.s->color_range);
    }
    defsim_world_get_positions(w, wr.x, nv);
    defsim_world_get_velocities(w, wr.v, nv);
    double lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
    for (int64_t i = 0; i < 3 * (int64_t)nv; ++i) {
        if (!isfinite(wr.x[i])) {
            world_render_free(&wr);
            return api_fail(err, errsz, bad, "vertex %lld is not finite", (long long)(i / 3));
        }
        lo[i % 3] = fmin(lo[i % 3], wr.x[i]);
        hi[i % 3] = fmax(hi[i % 3], wr.x[i]);
    }
    if (fields_init(&wr.fl, w, &cells, which, msg, sizeof msg) ||
        (d->reference && (memcpy(wr.fl.x0, d->reference, 3 * (size_t)nv * sizeof *wr.fl.x0), 0)) ||
        fields_eval(&wr.fl, w, msg, sizeof msg)) {
        world_render_free(&wr);
        return api_fail(err, errsz, strstr(msg, "memory") ? DEFSIM_ERR_OUT_OF_MEMORY : bad, "%s",
                        msg);
    }
    if (rd_bodies_from_cells(&wr.bodies, &cells, NULL, nv)) {
        world_render_free(&wr);
        return api_fail(err, errsz, DEFSIM_ERR_OUT_OF_MEMORY, "out of memory");
    }
    rd_view view;
    rd_view_make(&wr.s->camera, lo, hi, d->gravity, (double)d->width / d->height,
                 &view);
    const double fmax_ = rd_force_max(wr.fl.contact_force, nv);
    /* The colliders at their current poses (the world's), the scale of this picture alone. */
    const rd_frame_data frame = {
        .mode = (scene_color)d->color, .s = wr.s, .top = 0.0,
        .vec = d->color == DEFSIM_RENDER_SPEED ? wr.v : wr.fl.displacement,
        .cell = wr.fl.von_mises, .pinned = d->pins ? wr.fl.pinned : NULL, .ncolliders = nc,
        .time = defsim_world_time(w), .force = d->contact_arrows ? wr.fl.contact_force : NULL,
        .arrow_scale = rd_arrow_scale(d->arrow_scale, fmax_, lo, hi), .force_max = fmax_};
    wr.r = rd_create(d->width, d->height, wr.s->supersample, msg, sizeof msg);
    if (!wr.r)
        st = api_fail(err, errsz, DEFSIM_ERR_BACKEND_UNAVAILABLE, "renderer: %s", msg);
    else if (rd_draw_frame(wr.r, &wr.bodies, &wr.overlay, &view, w, wr.x, &frame, wr.im.rgb, msg,
                           sizeof msg))
        st = api_fail(err, errsz, strstr(msg, "memory") ? DEFSIM_ERR_OUT_OF_MEMORY
                                                         : DEFSIM_ERR_BACKEND_UNAVAILABLE,
                      "renderer: %s", msg);
    else if (image_write_png(path, &wr.im, msg, sizeof msg))
        st = api_fail(err, errsz, DEFSIM_ERR_IO, "%s", msg);
    world_render_free(&wr);
    return st;
}
