/* SPDX-License-Identifier: MIT */
/*
 * What the renderer draws besides the bodies: a marker on every pinned vertex and the world's
 * colliders, as more parts whose vertices follow the bodies' in one position array.
 */
#include "render.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>


static void qrotate(const double q[4], const double v[3], double out[3])
{
    /* v + 2 w (u x v) + 2 u x (u x v), u the vector part of the unit quaternion. */
    const double *u = q + 1, w = q[0];
    const double t[3] = {2.0 * (u[1] * v[2] - u[2] * v[1]), 2.0 * (u[2] * v[0] - u[0] * v[2]),
                         2.0 * (u[0] * v[1] - u[1] * v[0])};
    out[0] = v[0] + w * t[0] + (u[1] * t[2] - u[2] * t[1]);
    out[1] = v[1] + w * t[1] + (u[2] * t[0] - u[0] * t[2]);
    out[2] = v[2] + w * t[2] + (u[0] * t[1] - u[1] * t[0]);
}

/* Local point p of collider c in world coordinates. */
static void to_world(const defsim_collider_def *c, const double p[3], double out[3])
{
    qrotate(c->rotation, p, out);
    for (int i = 0; i < 3; ++i) out[i] += c->position[i];
}

int rd_overlay_begin(rd_overlay *o, const double *x, int32_t nv)
{
    for (int i = 0; i < o->nparts; ++i) {
        free((void *)o->parts[i].tris);
        free((void *)o->parts[i].lines);
    }
    o->nparts = 0;
    o->nx = 0;
    o->nbody = nv;
    if (nv > o->cap) {
        double *p = realloc(o->x, 3 * (size_t)nv * sizeof *p);
        if (!p) return -1;
        o->x = p;
        o->cap = nv;
    }
    if (nv > 0) memcpy(o->x, x, 3 * (size_t)nv * sizeof *x);
    o->nx = nv;
    return 0;
}

void rd_overlay_free(rd_overlay *o)
{
    rd_overlay_begin(o, NULL, 0);
    free(o->x);
    free(o->parts);
    memset(o, 0, sizeof *o);
}

/* Appends a vertex; returns its index, or -1 when out of memory. */
static int32_t add_vertex(rd_overlay *o, const double p[3])
{
    if (o->nx == o->cap) {
        const int32_t cap = o->cap ? 2 * o->cap : 1024;
        double *q = realloc(o->x, 3 * (size_t)cap * sizeof *q);
        if (!q) return -1;
        o->x = q;
        o->cap = cap;
    }
    memcpy(o->x + 3 * (int64_t)o->nx, p, 3 * sizeof *p);
    return o->nx++;
}

/* A new part with room for ntris triangles and nlines lines; NULL when out of memory. */
static rd_part *add_part(rd_overlay *o, int32_t ntris, int32_t nlines, const float rgb[3],
                         int smooth)
{
    if (o->nparts == o->pcap) {
        const int cap = o->pcap ? 2 * o->pcap : 8;
        rd_part *p = realloc(o->parts, (size_t)cap * sizeof *p);
        if (!p) return NULL;
        o->parts = p;
        o->pcap = cap;
    }
    rd_part *p = &o->parts[o->nparts];
    memset(p, 0, sizeof *p);
    p->tris = malloc(3 * (size_t)(ntris + 1) * sizeof *p->tris);
    p->lines = malloc(2 * (size_t)(nlines + 1) * sizeof *p->lines);
    if (!p->tris || !p->lines) {
        free((void *)p->tris);
        free((void *)p->lines);
        return NULL;
    }
    memcpy(p->color, rgb, sizeof p->color);
    p->smooth = smooth;
    ++o->nparts;
    return p;
}

/* Adds triangle (a, b, c) to p, turned to face away from `center` (convex shapes). */
static void add_tri(rd_overlay *o, rd_part *p, int32_t a, int32_t b, int32_t c,
                    const double *center)
{
    int32_t *t = (int32_t *)p->tris + 3 * (int64_t)p->ntris++;
    t[0] = a;
    t[1] = b;
    t[2] = c;
    if (!center) return;
    const double *xa = o->x + 3 * (int64_t)a, *xb = o->x + 3 * (int64_t)b,
                 *xc = o->x + 3 * (int64_t)c;
    double e1[3], e2[3], n[3], m[3];
    for (int i = 0; i < 3; ++i) {
        e1[i] = xb[i] - xa[i];
        e2[i] = xc[i] - xa[i];
        m[i] = (xa[i] + xb[i] + xc[i]) / 3.0 - center[i];
    }
    n[0] = e1[1] * e2[2] - e1[2] * e2[1];
    n[1] = e1[2] * e2[0] - e1[0] * e2[2];
    n[2] = e1[0] * e2[1] - e1[1] * e2[0];
    if (n[0] * m[0] + n[1] * m[1] + n[2] * m[2] < 0.0) {
        t[1] = c;
        t[2] = b;
    }
}

int rd_overlay_markers(rd_overlay *o, const uint8_t *flag, double size, const float rgb[3])
{
    int32_t n = 0;
    for (int32_t v = 0; flag && v < o->nbody; ++v) n += flag[v] != 0;
    if (n == 0) return 0;
    rd_part *p = add_part(o, 8 * n, 0, rgb, 0);
    if (!p) return -1;
    /* An octahedron of half-diagonal `size` on each flagged vertex. */
    for (int32_t v = 0; v < o->nbody; ++v) {
        if (!flag[v]) continue;
        double c[3];
        memcpy(c, o->x + 3 * (int64_t)v, sizeof c);
        int32_t k[6];
        for (int a = 0; a < 6; ++a) {
            double q[3] = {c[0], c[1], c[2]};
            q[a / 2] += a % 2 ? -size : size;
            if ((k[a] = add_vertex(o, q)) < 0) return -1;
        }
        for (int f = 0; f < 8; ++f)
            add_tri(o, p, k[f & 1 ? 1 : 0], k[f & 2 ? 3 : 2], k[f & 4 ? 5 : 4], c);
    }
    return 0;
}

/* A closed or open surface (sphere, capsule, box, mesh): the scene's tessellation of the
 * collider (scene_collider_surface, in its local frame) at the def's pose. */
static int add_surface(rd_overlay *o, const defsim_collider_def *c, const float rgb[3])
{
    scene_collider sc;
    memset(&sc, 0, sizeof sc);
    sc.def = *c;
    double *lx = NULL;
    int32_t nv = 0, nt = 0, *tri = NULL;
    int smooth = 0, rc = scene_collider_surface(&sc, &lx, &nv, &tri, &nt, &smooth);
    rd_part *p = rc || nt == 0 ? NULL : add_part(o, nt, 0, rgb, smooth);
    if (!rc && nt > 0 && !p) rc = -1;
    const int32_t first = o->nx;
    for (int32_t k = 0; p && rc == 0 && k < nv; ++k) {
        double w[3];
        to_world(c, lx + 3 * (int64_t)k, w);
        if (add_vertex(o, w) < 0) rc = -1;
    }
    for (int32_t t = 0; p && rc == 0 && t < nt; ++t)
        add_tri(o, p, first + tri[3 * t], first + tri[3 * t + 1], first + tri[3 * t + 2], NULL);
    free(lx);
    free(tri);
    return rc;
}

/* The 12 edges of the SDF's bounding box, drawn as tubes (the distance field itself is not
 * drawn: it has no surface to sample without a mesher). Unbounded SDFs draw nothing. */
static int add_sdf_bounds(rd_overlay *o, const defsim_collider_def *c, const float rgb[3])
{
    const double *b = c->sdf_bounds;
    if (!(b[3] > b[0] && b[4] > b[1] && b[5] > b[2])) return 0;
    rd_part *p = add_part(o, 0, 12, rgb, 0);
    if (!p) return -1;
    const int32_t first = o->nx;
    for (int k = 0; k < 8; ++k) {
        const double local[3] = {b[k & 1 ? 3 : 0], b[k & 2 ? 4 : 1], b[k & 4 ? 5 : 2]};
        double w[3];
        to_world(c, local, w);
        if (add_vertex(o, w) < 0) return -1;
    }
    int32_t *l = (int32_t *)p->lines;
    for (int k = 0; k < 8; ++k)
        for (int axis = 0; axis < 3; ++axis)
            if (!(k & (1 << axis))) {
                l[2 * p->nlines] = first + k;
                l[2 * p->nlines + 1] = first + (k | (1 << axis));
                ++p->nlines;
            }
    return 0;
}

/* A square patch of the plane around the point nearest the view's target. */
static int add_plane(rd_overlay *o, const defsim_collider_def *c, const rd_view *v,
                     const float rgb[3])
{
    double n[3], t1[3], t2[3], q[3];
    qrotate(c->rotation, c->normal, n);
    const double len = sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
    if (!(len > 0.0)) return 0;
    for (int i = 0; i < 3; ++i) n[i] /= len;
    const double ref[3] = {fabs(n[0]) < 0.9 ? 1.0 : 0.0, fabs(n[0]) < 0.9 ? 0.0 : 1.0, 0.0};
    t1[0] = n[1] * ref[2] - n[2] * ref[1];
    t1[1] = n[2] * ref[0] - n[0] * ref[2];
    t1[2] = n[0] * ref[1] - n[1] * ref[0];
    const double l1 = sqrt(t1[0] * t1[0] + t1[1] * t1[1] + t1[2] * t1[2]);
    for (int i = 0; i < 3; ++i) t1[i] /= l1;
    t2[0] = n[1] * t1[2] - n[2] * t1[1];
    t2[1] = n[2] * t1[0] - n[0] * t1[2];
    t2[2] = n[0] * t1[1] - n[1] * t1[0];
    double d = 0.0;
    for (int i = 0; i < 3; ++i) d += (v->target[i] - c->position[i]) * n[i];
    for (int i = 0; i < 3; ++i) q[i] = v->target[i] - d * n[i];
    const double e = 0.5 * v->ground_extent;
    rd_part *p = add_part(o, 2, 0, rgb, 1);
    if (!p) return -1;
    int32_t k[4];
    for (int a = 0; a < 4; ++a) {
        const double s1 = a == 1 || a == 2 ? e : -e, s2 = a >= 2 ? e : -e;
        double w[3];
        for (int i = 0; i < 3; ++i) w[i] = q[i] + s1 * t1[i] + s2 * t2[i];
        if ((k[a] = add_vertex(o, w)) < 0) return -1;
    }
    add_tri(o, p, k[0], k[1], k[2], NULL);
    add_tri(o, p, k[0], k[2], k[3], NULL);
    return 0;
}

int rd_view_ground_plane(rd_view *v, const defsim_collider_def *c)
{
    if (c->shape != DEFSIM_SHAPE_PLANE) return 0;
    double n[3];
    qrotate(c->rotation, c->normal, n);
    const double len = sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
    if (!(len > 0.0)) return 0;
    for (int i = 0; i < 3; ++i) {
        v->ground_normal[i] = n[i] / len;
        v->ground_origin[i] = c->position[i];
    }
    v->ground = 1;
    return 1;
}

int rd_overlay_collider(rd_overlay *o, const defsim_collider_def *c, const rd_view *v,
                        int as_ground, const float rgb[3])
{
    switch (c->shape) {
    case DEFSIM_SHAPE_PLANE: return as_ground ? 0 : add_plane(o, c, v, rgb);
    case DEFSIM_SHAPE_SPHERE:
    case DEFSIM_SHAPE_CAPSULE:
    case DEFSIM_SHAPE_BOX:
    case DEFSIM_SHAPE_MESH: return add_surface(o, c, rgb);
    case DEFSIM_SHAPE_SDF: return add_sdf_bounds(o, c, rgb);
    }
    return 0;
}

int rd_overlay_segment(rd_overlay *o, const double a[3], const double b[3], const float rgb[3])
{
    rd_part *p = add_part(o, 0, 1, rgb, 0);
    if (!p) return -1;
    const int32_t ia = add_vertex(o, a), ib = add_vertex(o, b);
    if (ia < 0 || ib < 0) return -1;
    int32_t *l = (int32_t *)p->lines;
    l[0] = ia;
    l[1] = ib;
    p->nlines = 1;
    return 0;
}
