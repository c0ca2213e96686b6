/* SPDX-License-Identifier: MIT */
/*
 * One frame as defsim run, defsim-render and libdefsim_render draw it, and the render parts of
 * a frame's cells.
 */
#include "render.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

int rd_draw_frame(rd_renderer *r, const rd_view *view, rd_overlay *o, const rd_part *parts,
                  int nparts, const rd_frame *f, uint8_t *rgb, int width, int height, char *err,
                  size_t errsz)
{
    static const float marker_rgb[3] = {0.8f, 0.12f, 0.08f}, collider_rgb[3] = {0.6f, 0.6f, 0.64f};
    rd_view v = *view;
    int ground = -1, bad = rd_overlay_begin(o, f->x, f->nv) ||
                           rd_overlay_markers(o, f->pinned, 2.5 * v.line_radius, marker_rgb) ||
                           (f->force && rd_overlay_arrows(o, f->force, f->arrow_scale,
                                                          f->force_max, 0.8 * v.line_radius));
    for (int32_t i = 0; !bad && i < f->ncolliders; ++i) {
        /* The first plane is the ground: the grid is drawn on it. */
        if (ground < 0 && rd_view_ground_plane(&v, &f->colliders[i])) ground = i;
        bad = rd_overlay_collider(o, &f->colliders[i], &v, ground == i, collider_rgb);
    }
    const int n = nparts + o->nparts;
    rd_part *all = bad ? NULL : malloc((size_t)(n > 0 ? n : 1) * sizeof *all);
    if (!all) {
        snprintf(err, errsz, "out of memory");
        return -1;
    }
    memcpy(all, parts, (size_t)nparts * sizeof *all);
    memcpy(all + nparts, o->parts, (size_t)o->nparts * sizeof *all);
    bad = rd_render(r, &v, o->x, all, n, rgb, err, errsz);
    free(all);
    if (bad) return -1;
    rd_colorbar(rgb, width, height, f->color, f->range[0], f->range[1]);
    rd_timestamp(rgb, width, height, f->time);
    return 0;
}

int rd_parts_from_cells(const vtk_cells *c, const scene *s, rd_part **out, int *nout,
                        int32_t ***tri_cell)
{
    int32_t nb = 0;
    for (int64_t i = 0; i < c->ncells; ++i) if (c->body[i] + 1 > nb) nb = c->body[i] + 1;
    rd_part *p = calloc((size_t)(nb > 0 ? nb : 1), sizeof *p);
    int32_t **tc = calloc((size_t)(nb > 0 ? nb : 1), sizeof *tc);
    if (!p || !tc) {
        free(p);
        free(tc);
        return -1;
    }
    *out = p;
    *nout = nb;
    *tri_cell = tc;
    for (int32_t b = 0; b < nb; ++b) {
        int64_t nt = 0, ntri = 0, nl = 0;
        for (int64_t i = 0; i < c->ncells; ++i)
            if (c->body[i] == b) {
                nt += c->types[i] == VTK_TETRA;
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
            return -1;
        }
        int64_t kt = 0, ktri = 0, kl = 0;
        for (int64_t i = 0; i < c->ncells; ++i) {
            if (c->body[i] != b) continue;
            const int64_t *q = c->conn + (i ? c->offsets[i - 1] : 0);
            if (c->types[i] == VTK_TETRA) for (int a = 0; a < 4; ++a) tets[4 * kt + a] = q[a];
            if (c->types[i] == VTK_TRIANGLE) for (int a = 0; a < 3; ++a) tris[3 * ktri + a] = (int32_t)q[a];
            if (c->types[i] == VTK_TETRA) cell[kt] = (int32_t)i;
            if (c->types[i] == VTK_TRIANGLE) cell[ktri] = (int32_t)i;
            if (c->types[i] == VTK_LINE) for (int a = 0; a < 2; ++a) lines[2 * kl + a] = (int32_t)q[a];
            kt += c->types[i] == VTK_TETRA;
            ktri += c->types[i] == VTK_TRIANGLE;
            kl += c->types[i] == VTK_LINE;
        }
        if (nt > 0) {
            free(tris);
            int32_t n = 0;
            p[b].tris = tris = rd_tet_surface(tets, nt, &n);
            if (!tris) {
                free(tets);
                return -1;
            }
            ntri = n;
            /* The surface's triangles, mapped to their tets' cells. */
            int32_t *t32 = malloc((size_t)(4 * nt + 1) * sizeof *t32), *of = malloc((size_t)(n + 1) * sizeof *of);
            for (int64_t k = 0; t32 && k < 4 * nt; ++k) t32[k] = (int32_t)tets[k];
            if (!t32 || !of || rd_triangle_tets(t32, nt, tris, n, of)) {
                free(t32);
                free(of);
                free(tets);
                return -1;
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
    }
    return 0;
}

void rd_parts_free(rd_part *p, int n, int32_t **tri_cell)
{
    for (int i = 0; p && i < n; ++i) {
        free((void *)p[i].tris);
        free((void *)p[i].lines);
        if (tri_cell) free(tri_cell[i]);
    }
    free(p);
    free(tri_cell);
}
