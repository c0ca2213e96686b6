/* SPDX-License-Identifier: MIT */
/* The bodies of a world (or of a frame's cells) as the renderer's parts, and one frame of them
 * with its colours, markers, contact arrows, colliders, colour bar and time: defsim run's and
 * defsim-render's PNG frames, defsim_render_world_png and the viewer's window. */
#include "render.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

void rd_bodies_free(rd_bodies *b)
{
    for (int i = 0; b->parts && i < b->nparts; ++i) {
        free((void *)b->parts[i].tris);
        free((void *)b->parts[i].lines);
        if (b->tri_cell) free(b->tri_cell[i]);
        if (b->tri_rgb) free(b->tri_rgb[i]);
    }
    free(b->parts);
    free(b->tri_cell);
    free(b->tri_rgb);
    free(b->vertex_rgb);
    memset(b, 0, sizeof *b);
}

int rd_bodies_init(rd_bodies *b, const rd_body_src *src, int n, int32_t nv, int stress)
{
    memset(b, 0, sizeof *b);
    b->parts = calloc((size_t)n + 1, sizeof *b->parts);
    b->tri_cell = calloc((size_t)n + 1, sizeof *b->tri_cell);
    b->tri_rgb = calloc((size_t)n + 1, sizeof *b->tri_rgb);
    b->vertex_rgb = malloc(3 * (size_t)nv * sizeof *b->vertex_rgb + 1);
    b->nparts = n;
    b->nv = nv;
    if (!b->parts || !b->tri_cell || !b->tri_rgb || !b->vertex_rgb) goto fail;
    for (int i = 0; i < n; ++i) {
        const rd_body_src *q = &src[i];
        rd_part *p = &b->parts[i];
        int32_t *tris = malloc(3 * (size_t)(q->triangle_count + 1) * sizeof *tris);
        int32_t *lines = malloc(2 * (size_t)(q->line_count + 1) * sizeof *lines);
        p->tris = tris;
        p->lines = lines;
        if (!tris || !lines) goto fail;
        for (int64_t k = 0; k < 3 * (int64_t)q->triangle_count; ++k) {
            if (q->triangles[k] < 0 || q->offset + (int64_t)q->triangles[k] >= nv) goto fail;
            tris[k] = q->triangles[k] + q->offset;
        }
        for (int64_t k = 0; k < 2 * (int64_t)q->line_count; ++k) {
            if (q->lines[k] < 0 || q->offset + (int64_t)q->lines[k] >= nv) goto fail;
            lines[k] = q->lines[k] + q->offset;
        }
        p->ntris = q->triangle_count;
        p->nlines = q->line_count;
        memcpy(p->color, q->color, sizeof p->color);
        p->smooth = q->tet_count == 0;
        /* Stress colours: each boundary triangle takes its tet's cell. */
        if (stress && q->tet_count > 0) {
            const int32_t nt = q->triangle_count;
            int32_t *cell = b->tri_cell[i] = malloc((size_t)(nt + 1) * sizeof *cell);
            b->tri_rgb[i] = malloc(3 * (size_t)(nt + 1) * sizeof **b->tri_rgb);
            if (!cell || !b->tri_rgb[i] ||
                rd_triangle_tets(q->tets, q->tet_count, q->triangles, nt, cell))
                goto fail;
            for (int32_t t = 0; t < nt; ++t)
                if (cell[t] >= 0) cell[t] += (int32_t)q->cell_offset;
        }
    }
    return 0;
fail:
    rd_bodies_free(b);
    return -1;
}

int rd_draw_frame(rd_renderer *r, rd_bodies *b, rd_overlay *overlay, const rd_view *view_in,
                  const defsim_world *w, const double *x, const rd_frame_data *d, uint8_t *rgb,
                  char *err, size_t errsz)
{
    double range[2];
    rd_color_parts(d->mode, d->s, b->parts, b->nparts, b->tri_cell, d->cell, d->vec, b->nv,
                   d->top, b->vertex_rgb, b->tri_rgb, range);
    rd_view view = *view_in;
    int ground_plane = -1;
    static const float marker_rgb[3] = {0.8f, 0.12f, 0.08f}, collider_rgb[3] = {0.6f, 0.6f, 0.64f};
    if (rd_overlay_begin(overlay, x, b->nv) ||
        rd_overlay_markers(overlay, d->pinned, 2.5 * view.line_radius, marker_rgb) ||
        (d->force && rd_overlay_arrows(overlay, d->force, d->arrow_scale, d->force_max,
                                       0.8 * view.line_radius)))
        goto oom;
    int32_t ncol = d->ncolliders;
    if (!d->colliders) {
        const int32_t nw = w ? defsim_world_collider_count(w) : 0;
        if (ncol > nw) ncol = nw;
    }
    for (int32_t i = 0; i < ncol; ++i) {
        defsim_collider_def c = {.size = sizeof c};
        if (d->colliders) c = d->colliders[i];
        else defsim_world_get_collider(w, i, NULL, &c);
        if (d->poses) {
            memcpy(c.position, d->poses + 7 * i, 3 * sizeof(double));
            memcpy(c.rotation, d->poses + 7 * i + 3, 4 * sizeof(double));
        }
        /* The first plane is the ground: the grid is drawn on it. */
        if (ground_plane < 0 && rd_view_ground_plane(&view, &c)) ground_plane = i;
        if (rd_overlay_collider(overlay, &c, &view, ground_plane == i, collider_rgb)) goto oom;
    }
    static const float segment_rgb[3] = {0.85f, 0.1f, 0.55f};
    if (d->segment && rd_overlay_segment(overlay, d->segment, d->segment + 3, segment_rgb)) goto oom;
    const int n = b->nparts + overlay->nparts;
    rd_part *all = malloc((size_t)(n + 1) * sizeof *all);
    if (!all) goto oom;
    memcpy(all, b->parts, (size_t)b->nparts * sizeof *all);
    memcpy(all + b->nparts, overlay->parts, (size_t)overlay->nparts * sizeof *all);
    const int bad = rd_render(r, &view, overlay->x, all, n, rgb, err, errsz);
    free(all);
    if (bad) return -1;
    rd_colorbar(rgb, rd_width(r), rd_height(r), d->mode, range[0], range[1]);
    rd_timestamp(rgb, rd_width(r), rd_height(r), d->time);
    return 0;
oom:
    snprintf(err, errsz, "out of memory");
    return -1;
}

int rd_bodies_from_cells(rd_bodies *out, const vtk_cells *c, const scene *s, int32_t nv)
{
    memset(out, 0, sizeof *out);
    int32_t nb = 0;
    for (int64_t i = 0; i < c->ncells; ++i) if (c->body[i] + 1 > nb) nb = c->body[i] + 1;
    rd_part *p = out->parts = calloc((size_t)nb + 1, sizeof *p);
    int32_t **tc = out->tri_cell = calloc((size_t)nb + 1, sizeof *tc);
    out->tri_rgb = calloc((size_t)nb + 1, sizeof *out->tri_rgb);
    out->vertex_rgb = malloc(3 * (size_t)nv * sizeof *out->vertex_rgb + 1);
    out->nparts = nb;
    out->nv = nv;
    if (!p || !tc || !out->tri_rgb || !out->vertex_rgb) goto fail;
    for (int32_t b = 0; b < nb; ++b) {
        int64_t nt = 0, ntri = 0, nl = 0;
        for (int64_t i = 0; i < c->ncells; ++i)
            if (c->body[i] == b) {
                nt += vtk_is_tet(c->types[i]);
                ntri += c->types[i] == VTK_TRIANGLE;
                nl += c->types[i] == VTK_LINE;
            }
        int64_t *tets = malloc((size_t)(nt + 1) * 4 * sizeof *tets);
        int32_t *tris = malloc((size_t)(ntri + 1) * 3 * sizeof *tris);
        int32_t *lines = malloc((size_t)(nl + 1) * 2 * sizeof *lines);
        int32_t *cell = malloc((size_t)(nt + ntri + 1) * sizeof *cell);
        p[b].tris = tris;
        p[b].lines = lines;
        tc[b] = cell;
        if (!tets || !tris || !lines || !cell) {
            free(tets);
            goto fail;
        }
        int64_t kt = 0, ktri = 0, kl = 0;
        for (int64_t i = 0; i < c->ncells; ++i) {
            if (c->body[i] != b) continue;
            const int64_t *q = c->conn + (i ? c->offsets[i - 1] : 0);
            /* a quadratic tet is drawn by its corners (its first 4 vertices) */
            if (vtk_is_tet(c->types[i])) for (int a = 0; a < 4; ++a) tets[4 * kt + a] = q[a];
            if (c->types[i] == VTK_TRIANGLE) for (int a = 0; a < 3; ++a) tris[3 * ktri + a] = (int32_t)q[a];
            if (vtk_is_tet(c->types[i])) cell[kt] = (int32_t)i;
            if (c->types[i] == VTK_TRIANGLE) cell[ktri] = (int32_t)i;
            if (c->types[i] == VTK_LINE) for (int a = 0; a < 2; ++a) lines[2 * kl + a] = (int32_t)q[a];
            kt += vtk_is_tet(c->types[i]);
            ktri += c->types[i] == VTK_TRIANGLE;
            kl += c->types[i] == VTK_LINE;
        }
        if (nt > 0) {
            free(tris);
            int32_t n = 0;
            p[b].tris = tris = rd_tet_surface(tets, nt, &n);
            if (!tris) {
                free(tets);
                goto fail;
            }
            ntri = n;
            /* The surface's triangles, mapped to their tets' cells. */
            int32_t *t32 = malloc((size_t)(4 * nt + 1) * sizeof *t32), *of = malloc((size_t)(n + 1) * sizeof *of);
            for (int64_t k = 0; t32 && k < 4 * nt; ++k) t32[k] = (int32_t)tets[k];
            if (!t32 || !of || rd_triangle_tets(t32, nt, tris, n, of)) {
                free(t32);
                free(of);
                free(tets);
                goto fail;
            }
            for (int32_t k = 0; k < n; ++k) of[k] = of[k] >= 0 ? cell[of[k]] : -1;
            free(t32);
            free(cell);
            tc[b] = cell = of;
        }
        free(tets);
        p[b].ntris = (int32_t)ntri;
        p[b].nlines = (int32_t)nl;
        p[b].smooth = nt == 0;
        if (s && b < s->nbodies) memcpy(p[b].color, s->bodies[b].color, sizeof p[b].color);
        else scene_palette(b, p[b].color);
        if (!(out->tri_rgb[b] = malloc(3 * (size_t)(ntri + 1) * sizeof **out->tri_rgb))) goto fail;
    }
    return 0;
fail:
    rd_bodies_free(out);
    return -1;
}
