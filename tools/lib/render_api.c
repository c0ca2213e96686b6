/* SPDX-License-Identifier: MIT */
/* libdefsim_render (include/defsim/render.h): one checked call over the tools' OSMesa renderer. */
#include <defsim/render.h>

#include "api_error.h"
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
