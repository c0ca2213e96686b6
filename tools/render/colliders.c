/* SPDX-License-Identifier: MIT */
/*
 * Drawing a scene's colliders: their surfaces (scene_collider_surface) as grey parts whose
 * vertices follow the bodies' positions, placed at each frame's time, and the ground grid on a
 * static plane collider that faces up.
 */
#include "render.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

int rd_colliders_make(const scene *s, int32_t nv_bodies, rd_colliders *c)
{
    memset(c, 0, sizeof *c);
    c->s = s;
    c->nv_bodies = c->nv_all = nv_bodies;
    const size_t n = (size_t)s->ncolliders + 1;
    c->parts = calloc(n, sizeof *c->parts);
    c->col = calloc(n, sizeof *c->col);
    c->local = calloc(n, sizeof *c->local);
    c->nv = calloc(n, sizeof *c->nv);
    if (!c->parts || !c->col || !c->local || !c->nv) return -1;
    for (int32_t i = 0; i < s->ncolliders; ++i) {
        double *lx;
        int32_t nv, nt, *tri;
        int smooth;
        if (scene_collider_surface(&s->colliders[i], &lx, &nv, &tri, &nt, &smooth)) return -1;
        if (nt == 0) continue;
        for (int64_t k = 0; k < 3 * (int64_t)nt; ++k) tri[k] += c->nv_all;
        rd_part *p = &c->parts[c->n];
        p->tris = tri;
        p->ntris = nt;
        p->color[0] = p->color[1] = 0.62f;
        p->color[2] = 0.66f;
        p->smooth = smooth;
        c->col[c->n] = i;
        c->local[c->n] = lx;
        c->nv[c->n++] = nv;
        c->nv_all += nv;
    }
    return (c->x = malloc(3 * (size_t)c->nv_all * sizeof *c->x + 1)) ? 0 : -1;
}

const double *rd_colliders_place(rd_colliders *c, double t, const double *x_bodies)
{
    int32_t off = c->nv_bodies;
    memcpy(c->x, x_bodies, 3 * (size_t)off * sizeof *c->x);
    for (int32_t k = 0; k < c->n; off += c->nv[k++])
        scene_collider_place(&c->s->colliders[c->col[k]], t, c->local[k], c->nv[k],
                             c->x + 3 * (int64_t)off);
    return c->x;
}

void rd_colliders_free(rd_colliders *c)
{
    for (int32_t k = 0; c->parts && k < c->n; ++k) {
        free((void *)c->parts[k].tris);
        free(c->local[k]);
    }
    free(c->parts);
    free(c->col);
    free(c->local);
    free(c->nv);
    free(c->x);
    memset(c, 0, sizeof *c);
}

void rd_ground_from_colliders(const scene *s, scene_camera *cam)
{
    const double *g = s->def.gravity, gn = sqrt(g[0] * g[0] + g[1] * g[1] + g[2] * g[2]);
    for (int32_t i = 0; i < s->ncolliders && !cam->has_ground_height && gn > 0.0; ++i) {
        const scene_collider *col = &s->colliders[i];
        const defsim_collider_def *d = &col->def;
        if (d->shape != DEFSIM_SHAPE_PLANE || col->nkeys > 0) continue;
        double n[3];
        scene_collider_place(col, 0.0, d->normal, 1, n);   /* rotated, then moved */
        for (int k = 0; k < 3; ++k) n[k] -= d->position[k];
        const double nn = sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
        if (fabs(-(n[0] * g[0] + n[1] * g[1] + n[2] * g[2]) / (nn * gn) - 1.0) > 1e-9) continue;
        cam->has_ground_height = 1;
        cam->ground_height =
            -(d->position[0] * g[0] + d->position[1] * g[1] + d->position[2] * g[2]) / gn;
    }
}
