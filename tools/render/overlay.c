/* SPDX-License-Identifier: MIT */
/*
 * What the renderer draws besides the bodies: a marker on every pinned vertex and the world's
 * colliders, as more parts whose vertices follow the bodies' in one position array.
 */
#include "render.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>


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

double rd_force_max(const double *f, int32_t n)
{
    double m = 0.0;
    for (int32_t v = 0; f && v < n; ++v) {
        const double *g = f + 3 * (int64_t)v;
        m = fmax(m, sqrt(g[0] * g[0] + g[1] * g[1] + g[2] * g[2]));
    }
    return m;
}

double rd_arrow_scale(double given, double fmax, const double lo[3], const double hi[3])
{
    if (given > 0.0) return given;
    double diag = 0.0;
    for (int c = 0; c < 3; ++c) diag += (hi[c] - lo[c]) * (hi[c] - lo[c]);
    return fmax > 0.0 && isfinite(diag) ? 0.25 * sqrt(diag) / fmax : 0.0;
}

int rd_overlay_arrows(rd_overlay *o, const double *f, double scale, double fmax, double r)
{
    enum { SIDES = 6 };
    static const float rgb[3] = {0.95f, 0.62f, 0.08f};
    const double min = 0.01 * fmax;
    int32_t n = 0;
    for (int32_t v = 0; f && v < o->nbody; ++v) {
        const double *g = f + 3 * (int64_t)v;
        n += sqrt(g[0] * g[0] + g[1] * g[1] + g[2] * g[2]) > min;
    }
    if (n == 0 || !(scale > 0.0)) return 0;
    /* Per arrow: the shaft's sides, the ring under the head, the cone. */
    rd_part *p = add_part(o, n * 5 * SIDES, 0, rgb, 0);
    if (!p) return -1;
    p->on_top = 1;
    for (int32_t v = 0; v < o->nbody; ++v) {
        const double *g = f + 3 * (int64_t)v;
        const double fl = sqrt(g[0] * g[0] + g[1] * g[1] + g[2] * g[2]);
        if (!(fl > min)) continue;
        double base[3], u[3], a[3], b[3];
        memcpy(base, o->x + 3 * (int64_t)v, sizeof base);
        const double len = scale * fl;
        for (int i = 0; i < 3; ++i) u[i] = g[i] / fl;
        scene_across(u, a, b);   /* unit vectors across the axis */
        const double head = fmin(0.35 * len, 6.0 * r), neck = len - head;
        double centre_shaft[3], neck_c[3], tip[3];
        for (int i = 0; i < 3; ++i) {
            centre_shaft[i] = base[i] + 0.5 * neck * u[i];
            neck_c[i] = base[i] + neck * u[i];
            tip[i] = base[i] + len * u[i];
        }
        int32_t ring[3][SIDES];
        for (int k = 0; k < 3; ++k)
            for (int j = 0; j < SIDES; ++j) {
                const double th = 2.0 * 3.14159265358979323846 * j / SIDES;
                const double rad = k < 2 ? r : 2.2 * r, along = k == 0 ? 0.0 : neck;
                double q[3];
                for (int i = 0; i < 3; ++i)
                    q[i] = base[i] + along * u[i] + rad * (cos(th) * a[i] + sin(th) * b[i]);
                if ((ring[k][j] = add_vertex(o, q)) < 0) return -1;
            }
        const int32_t t = add_vertex(o, tip);
        if (t < 0) return -1;
        for (int j = 0; j < SIDES; ++j) {
            const int jn = (j + 1) % SIDES;
            add_tri(o, p, ring[0][j], ring[0][jn], ring[1][jn], centre_shaft);
            add_tri(o, p, ring[0][j], ring[1][jn], ring[1][j], centre_shaft);
            /* The flat ring under the head faces back, away from the tip. */
            add_tri(o, p, ring[1][j], ring[2][jn], ring[2][j], tip);
            add_tri(o, p, ring[1][j], ring[1][jn], ring[2][jn], tip);
            add_tri(o, p, ring[2][j], ring[2][jn], t, neck_c);
        }
    }
    return 0;
}

/* A collider's geometry (scene_geometry_make: its surface, a plane's square patch, an SDF's
 * bounds box as tubes) as one part. */
static int add_geometry(rd_overlay *o, const defsim_collider_def *c, const double centre[3],
                        double half, const float rgb[3])
{
    scene_geometry g;
    if (scene_geometry_make(c, centre, half, &g)) return -1;
    int rc = 0;
    rd_part *p = g.nt == 0 && g.nl == 0 ? NULL : add_part(o, g.nt, g.nl, rgb, g.smooth);
    if ((g.nt > 0 || g.nl > 0) && !p) rc = -1;
    const int32_t first = o->nx;
    for (int32_t k = 0; p && rc == 0 && k < g.nv; ++k)
        if (add_vertex(o, g.x + 3 * (int64_t)k) < 0) rc = -1;
    for (int32_t t = 0; p && rc == 0 && t < g.nt; ++t)
        add_tri(o, p, first + g.tri[3 * t], first + g.tri[3 * t + 1], first + g.tri[3 * t + 2],
                NULL);
    for (int32_t l = 0; p && rc == 0 && l < g.nl; ++l) {
        int32_t *e = (int32_t *)p->lines + 2 * (int64_t)p->nlines++;
        e[0] = first + g.lines[2 * l];
        e[1] = first + g.lines[2 * l + 1];
    }
    scene_geometry_free(&g);
    return rc;
}

int rd_view_ground_plane(rd_view *v, const defsim_collider_def *c)
{
    if (c->shape != DEFSIM_SHAPE_PLANE) return 0;
    double n[3];
    scene_quat_rotate(c->rotation, c->normal, n);
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
    /* A plane: a square patch around the point nearest the view's target. */
    if (c->shape == DEFSIM_SHAPE_PLANE && as_ground) return 0;
    return add_geometry(o, c, v->target, 0.5 * v->ground_extent, rgb);
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
