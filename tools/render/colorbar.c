/* SPDX-License-Identifier: MIT */
/* Colour scales for stress, displacement and speed, the colour bar drawn into finished images,
 * and the time stamp. */
#include "image.h"
#include "render.h"

#include <math.h>
#include <stdio.h>
#include <string.h>

void rd_colormap(double s, float rgb[3])
{
    /* Five samples of matplotlib's viridis (monotonic in lightness, readable in grey), linear
     * between them. */
    static const float stops[5][3] = {{0.267f, 0.005f, 0.329f}, {0.230f, 0.322f, 0.546f},
                                      {0.128f, 0.567f, 0.551f}, {0.369f, 0.789f, 0.383f},
                                      {0.993f, 0.906f, 0.144f}};
    if (!(s > 0.0)) s = 0.0;   /* NaN too */
    if (s > 1.0) s = 1.0;
    const double u = 4.0 * s;
    int k = (int)u;
    if (k > 3) k = 3;
    const float f = (float)(u - k);
    for (int c = 0; c < 3; ++c) rgb[c] = stops[k][c] + f * (stops[k + 1][c] - stops[k][c]);
}

void rd_colorbar(uint8_t *rgb, int width, int height, scene_color mode, double lo, double hi)
{
    if (mode == SCENE_COLOR_BODY || !(hi > lo)) return;   /* nothing was coloured */
    image im = {width, height, rgb};
    const int scale = height >= 300 ? 2 : 1, ch = 4 * scale;   /* character advance */
    const int bar_w = 6 * scale + 4, bar_h = height / 2;
    const int x0 = width - bar_w - 12 * ch - 8, y0 = height / 4;
    /* The bar: hi at the top, with a dark frame. */
    for (int y = -1; y <= bar_h; ++y)
        for (int x = -1; x <= bar_w; ++x) {
            const int px = x0 + x, py = y0 + y;
            if (px < 0 || py < 0 || px >= width || py >= height) continue;
            uint8_t *p = rgb + 3 * ((size_t)py * width + px);
            if (y < 0 || y == bar_h || x < 0 || x == bar_w) {
                memset(p, 40, 3);
                continue;
            }
            float c[3];
            rd_colormap(1.0 - (double)y / (bar_h - 1), c);
            for (int k = 0; k < 3; ++k) p[k] = (uint8_t)lrintf(255.0f * c[k]);
        }
    /* Values at the top, middle and bottom, then the quantity and its unit above the bar. */
    const double values[3] = {hi, 0.5 * (lo + hi), lo};
    for (int i = 0; i < 3; ++i) {
        char text[32];
        snprintf(text, sizeof text, "%.3g", values[i]);
        const int ty = y0 + i * (bar_h - 1) / 2 - 5 * scale / 2;
        for (int x = 0; x < 3 * scale; ++x)   /* tick */
            if (x0 + bar_w + x < width) memset(rgb + 3 * ((size_t)(y0 + i * (bar_h - 1) / 2) * width + x0 + bar_w + x), 40, 3);
        image_draw_text(&im, x0 + bar_w + 4 * scale, ty, scale, 40, text);
    }
    const char *label = mode == SCENE_COLOR_STRESS ? "VON MISES (Pa)"
                        : mode == SCENE_COLOR_SPEED ? "SPEED (m/s)" : "DISPLACEMENT (m)";
    int lx = width - (int)strlen(label) * ch - 6;
    if (lx > x0) lx = x0;
    image_draw_text(&im, lx, y0 - 7 * scale - 4, scale, 40, label);
}

static double vec_norm(const double *d) { return sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]); }

double rd_color_top(scene_color mode, const rd_part *parts, int nparts,
                    int32_t *const *tri_cell, const double *cell_value, const double *vertex_vec,
                    int32_t nv)
{
    double top = 0.0;
    if (mode == SCENE_COLOR_DISPLACEMENT || mode == SCENE_COLOR_SPEED) {
        for (int32_t v = 0; vertex_vec && v < nv; ++v)
            top = fmax(top, vec_norm(vertex_vec + 3 * (int64_t)v));
    } else if (mode == SCENE_COLOR_STRESS && cell_value) {
        for (int i = 0; i < nparts; ++i)
            for (int32_t t = 0; tri_cell[i] && t < parts[i].ntris; ++t)
                if (tri_cell[i][t] >= 0) top = fmax(top, cell_value[tri_cell[i][t]]);
    }
    return top;
}

void rd_color_parts(scene_color mode, const scene *s, rd_part *parts, int nparts,
                    int32_t *const *tri_cell, const double *cell_value, const double *vertex_vec,
                    int32_t nv, double top, float *vbuf, float *const *tbuf, double range[2])
{
    range[0] = 0.0;
    range[1] = 0.0;
    for (int i = 0; i < nparts; ++i) parts[i].vertex_colors = parts[i].tri_colors = NULL;
    if (mode == SCENE_COLOR_BODY) return;
    const int per_vertex = mode == SCENE_COLOR_DISPLACEMENT || mode == SCENE_COLOR_SPEED;
    if (per_vertex && !vertex_vec) return;
    int any = per_vertex;
    for (int i = 0; i < nparts; ++i) any |= tri_cell[i] != NULL;
    if (mode == SCENE_COLOR_STRESS && (!cell_value || !any)) return;   /* no tets: no bar */
    /* The scale: fixed by the scene, else from zero to `top` (the run's largest value), else
     * to this frame's largest. */
    if (!(top > 0.0)) top = rd_color_top(mode, parts, nparts, tri_cell, cell_value, vertex_vec, nv);
    if (s && s->has_color_range) {
        range[0] = s->color_range[0];
        range[1] = s->color_range[1];
    } else {
        range[1] = top > 0.0 ? top : 1.0;
    }
    const double span = range[1] - range[0];
    if (per_vertex) {
        for (int32_t v = 0; v < nv; ++v)
            rd_colormap((vec_norm(vertex_vec + 3 * (int64_t)v) - range[0]) / span,
                        vbuf + 3 * (int64_t)v);
        /* Only the bodies' parts: overlays (markers, colliders) keep their colours. */
        for (int i = 0; i < nparts; ++i) parts[i].vertex_colors = vbuf;
        return;
    }
    for (int i = 0; i < nparts; ++i) {
        if (!tri_cell[i]) continue;   /* a body without tets keeps its colour */
        for (int32_t t = 0; t < parts[i].ntris; ++t) {
            const int32_t c = tri_cell[i][t];
            rd_colormap(c >= 0 ? (cell_value[c] - range[0]) / span : 0.0, tbuf[i] + 3 * (int64_t)t);
        }
        parts[i].tri_colors = tbuf[i];
    }
}

void rd_timestamp(uint8_t *rgb, int width, int height, double t)
{
    image im = {width, height, rgb};
    const int scale = height >= 300 ? 2 : 1;
    char text[48];
    snprintf(text, sizeof text, "t = %.3f s", t);
    image_draw_text(&im, 6 * scale, 6 * scale, scale, 40, text);
}
