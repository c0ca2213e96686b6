/* SPDX-License-Identifier: MIT */
/*
 * Triangle-mesh colliders: the data built at creation (unit face normals, angle-weighted
 * pseudo-normals of edges and vertices, an AABB tree over the triangles) and the closest-point
 * query through the tree. The sign of the distance is that of (p - c) . n at the closest point c,
 * n the pseudo-normal of the feature (face, edge, vertex) that c lies on (Baerentzen & Aanaes
 * 2005): for a closed, consistently oriented mesh it is negative exactly inside.
 */
#include "collider.h"
#include "contact_prim.h"
#include "mat3.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

enum { LEAF_SIZE = 4 };

typedef struct bvh_node {
    double lo[3], hi[3];
    int32_t index;   /* leaf: first slot in order[]; inner: the right child (left is this + 1) */
    int32_t count;   /* leaf: triangles (> 0); inner: 0 */
} bvh_node;

struct defsim__bvh {
    const double *x;       /* the collider's vertex copy (borrowed) */
    const int32_t *tri;    /* the collider's triangle copy (borrowed) */
    int32_t nt;
    double *fn;            /* 3 nt: unit face normals */
    double *en;            /* 9 nt: edge k of triangle t (corner k to k + 1): pseudo-normal */
    double *vn;            /* 3 nv: vertex pseudo-normals */
    bvh_node *node;
    int32_t nnode;
    int32_t *order;        /* triangles in leaf order */
    double *tx;            /* 9 nt: the corners of order[i] at 9 i, so that leaves read memory in
                              sequence */
};

/* ------------------------------------------------------------------------------------------ */
/* Validation */

#define BAD(...) do { defsim__error(msg, __VA_ARGS__); return DEFSIM_ERR_INVALID_ARGUMENT; } while (0)

defsim_status defsim__mesh_check(defsim__messages *msg, const defsim_collider_def *d)
{
    if (!d->vertices || !d->triangles)
        BAD("add_collider: a mesh needs vertices and triangles (NULL given)");
    if (d->vertex_count < 3 || d->triangle_count < 1 || d->vertex_count > INT32_MAX / 3 ||
        d->triangle_count > INT32_MAX / 3)
        BAD("add_collider: a mesh needs >= 3 vertices and >= 1 triangle (%d, %d given)",
            (int)d->vertex_count, (int)d->triangle_count);
    for (int64_t i = 0; i < 3 * (int64_t)d->vertex_count; ++i)
        if (!defsim__collider_coords_ok(d->vertices + i, 1))
            BAD("add_collider: mesh vertex %d is not finite or beyond +-1e100 m (the coordinate "
                "bound of meshes)", (int)(i / 3));
    for (int32_t t = 0; t < d->triangle_count; ++t) {
        const int32_t *v = d->triangles + 3 * (int64_t)t;
        for (int k = 0; k < 3; ++k)
            if (v[k] < 0 || v[k] >= d->vertex_count)
                BAD("add_collider: mesh triangle %d has vertex index %d out of range [0, %d)",
                    (int)t, (int)v[k], (int)d->vertex_count);
        const double *a = d->vertices + 3 * (int64_t)v[0], *b = d->vertices + 3 * (int64_t)v[1],
                     *c = d->vertices + 3 * (int64_t)v[2];
        double ab[3], ac[3], bc[3], n[3];
        defsim__v3_sub(b, a, ab); defsim__v3_sub(c, a, ac); defsim__v3_sub(c, b, bc);
        defsim__v3_cross(ab, ac, n);
        double l2 = defsim__v3_dot(ab, ab);
        if (defsim__v3_dot(ac, ac) > l2) l2 = defsim__v3_dot(ac, ac);
        if (defsim__v3_dot(bc, bc) > l2) l2 = defsim__v3_dot(bc, bc);
        /* relative to the longest edge, so that the test does not depend on units */
        if (!(sqrt(defsim__v3_dot(n, n)) > 1e-12 * l2))
            BAD("add_collider: mesh triangle %d (%d, %d, %d) is degenerate (zero area)", (int)t,
                (int)v[0], (int)v[1], (int)v[2]);
    }
    return DEFSIM_OK;
}

/* ------------------------------------------------------------------------------------------ */
/* Construction */

typedef struct half_edge {
    int32_t a, b;     /* vertex indices, a < b */
    int32_t slot;     /* 3 t + k */
} half_edge;

static int cmp_edge(const void *pa, const void *pb)
{
    const half_edge *a = pa, *b = pb;
    if (a->a != b->a) return a->a < b->a ? -1 : 1;
    if (a->b != b->b) return a->b < b->b ? -1 : 1;
    return 0;
}

static void normalise(double *v)
{
    const double n = sqrt(defsim__v3_dot(v, v));
    if (n > 0.0) for (int k = 0; k < 3; ++k) v[k] /= n;
}

static int normals(struct defsim__bvh *m, int32_t nv)
{
    const int32_t nt = m->nt;
    for (int32_t t = 0; t < nt; ++t) {
        const int32_t *v = m->tri + 3 * t;
        double e[3][3];   /* e[k]: from corner k to corner k + 1 */
        for (int k = 0; k < 3; ++k)
            defsim__v3_sub(m->x + 3 * v[(k + 1) % 3], m->x + 3 * v[k], e[k]);
        double *n = m->fn + 3 * t;
        defsim__v3_cross(e[0], e[2], n);
        for (int k = 0; k < 3; ++k) n[k] = -n[k];   /* (b - a) x (c - a) */
        normalise(n);
        /* angle-weighted vertex normals */
        for (int k = 0; k < 3; ++k) {
            const double *u = e[k], *w = e[(k + 2) % 3];   /* out of corner k: u, -w */
            double c = -defsim__v3_dot(u, w) / sqrt(defsim__v3_dot(u, u) * defsim__v3_dot(w, w));
            c = c > 1.0 ? 1.0 : c < -1.0 ? -1.0 : c;
            const double ang = acos(c);
            for (int j = 0; j < 3; ++j) m->vn[3 * v[k] + j] += ang * n[j];
        }
    }
    for (int32_t i = 0; i < nv; ++i) normalise(m->vn + 3 * i);
    /* edge normals: the sum of the normals of the triangles sharing the edge (one for a
     * boundary edge) */
    half_edge *he = malloc(3 * (size_t)nt * sizeof *he);
    if (!he) return 0;
    for (int32_t t = 0; t < nt; ++t)
        for (int k = 0; k < 3; ++k) {
            const int32_t a = m->tri[3 * t + k], b = m->tri[3 * t + (k + 1) % 3];
            he[3 * t + k] = (half_edge){a < b ? a : b, a < b ? b : a, 3 * t + k};
        }
    qsort(he, 3 * (size_t)nt, sizeof *he, cmp_edge);
    for (int32_t i = 0; i < 3 * nt;) {
        int32_t j = i;
        double s[3] = {0.0, 0.0, 0.0};
        while (j < 3 * nt && he[j].a == he[i].a && he[j].b == he[i].b) {
            const double *n = m->fn + 3 * (he[j].slot / 3);
            for (int k = 0; k < 3; ++k) s[k] += n[k];
            ++j;
        }
        normalise(s);
        for (int32_t q = i; q < j; ++q) memcpy(m->en + 3 * he[q].slot, s, sizeof s);
        i = j;
    }
    free(he);
    return 1;
}

/* Partitions order[lo..hi) so that the element of rank k (by centroid along axis) is at k. */
static void select_kth(int32_t *order, const double *cen, int axis, int32_t lo, int32_t hi,
                       int32_t k)
{
    while (hi - lo > 1) {
        const double pivot = cen[3 * order[lo + (hi - lo) / 2] + axis];
        int32_t i = lo, j = hi - 1;
        while (i <= j) {
            while (cen[3 * order[i] + axis] < pivot) ++i;
            while (cen[3 * order[j] + axis] > pivot) --j;
            if (i <= j) {
                const int32_t tmp = order[i];
                order[i++] = order[j];
                order[j--] = tmp;
            }
        }
        if (k <= j) hi = j + 1;
        else if (k >= i) lo = i;
        else return;
    }
}

static int32_t build(struct defsim__bvh *m, const double *cen, int32_t lo, int32_t hi)
{
    const int32_t id = m->nnode++;
    bvh_node *nd = &m->node[id];
    double clo[3] = {INFINITY, INFINITY, INFINITY}, chi[3] = {-INFINITY, -INFINITY, -INFINITY};
    for (int k = 0; k < 3; ++k) {
        nd->lo[k] = INFINITY;
        nd->hi[k] = -INFINITY;
    }
    for (int32_t i = lo; i < hi; ++i) {
        const int32_t t = m->order[i];
        for (int c = 0; c < 3; ++c) {
            const double *p = m->x + 3 * m->tri[3 * t + c];
            for (int k = 0; k < 3; ++k) {
                if (p[k] < nd->lo[k]) nd->lo[k] = p[k];
                if (p[k] > nd->hi[k]) nd->hi[k] = p[k];
            }
        }
        for (int k = 0; k < 3; ++k) {
            if (cen[3 * t + k] < clo[k]) clo[k] = cen[3 * t + k];
            if (cen[3 * t + k] > chi[k]) chi[k] = cen[3 * t + k];
        }
    }
    if (hi - lo <= LEAF_SIZE) {
        nd->index = lo;
        nd->count = hi - lo;
        return id;
    }
    int axis = 0;
    for (int k = 1; k < 3; ++k)
        if (chi[k] - clo[k] > chi[axis] - clo[axis]) axis = k;
    const int32_t mid = lo + (hi - lo) / 2;
    select_kth(m->order, cen, axis, lo, hi, mid);
    build(m, cen, lo, mid);
    const int32_t right = build(m, cen, mid, hi);
    m->node[id].index = right;   /* m->node does not move: allocated for 2 nt nodes */
    m->node[id].count = 0;
    return id;
}

defsim_status defsim__mesh_build(defsim__collider *c)
{
    const int32_t nt = c->def.triangle_count, nv = c->def.vertex_count;
    struct defsim__bvh *m = calloc(1, sizeof *m);
    double *cen = malloc(3 * (size_t)nt * sizeof *cen);
    if (!m || !cen) goto oom;
    m->x = c->mesh_x;
    m->tri = c->mesh_t;
    m->nt = nt;
    m->fn = malloc(3 * (size_t)nt * sizeof *m->fn);
    m->en = malloc(9 * (size_t)nt * sizeof *m->en);
    m->vn = calloc(3 * (size_t)nv, sizeof *m->vn);
    m->node = malloc(2 * (size_t)nt * sizeof *m->node);
    m->order = malloc((size_t)nt * sizeof *m->order);
    m->tx = malloc(9 * (size_t)nt * sizeof *m->tx);
    if (!m->fn || !m->en || !m->vn || !m->node || !m->order || !m->tx || !normals(m, nv)) goto oom;
    for (int32_t t = 0; t < nt; ++t) {
        m->order[t] = t;
        for (int k = 0; k < 3; ++k)
            cen[3 * t + k] = (m->x[3 * m->tri[3 * t] + k] + m->x[3 * m->tri[3 * t + 1] + k] +
                              m->x[3 * m->tri[3 * t + 2] + k]) / 3.0;
    }
    build(m, cen, 0, nt);
    free(cen);
    for (int32_t i = 0; i < nt; ++i)
        for (int c3 = 0; c3 < 3; ++c3)
            memcpy(m->tx + 9 * i + 3 * c3, m->x + 3 * m->tri[3 * m->order[i] + c3], 3 * sizeof *m->tx);
    c->bvh = m;
    return DEFSIM_OK;
oom:
    free(cen);
    c->bvh = m;
    defsim__mesh_free(c);
    return DEFSIM_ERR_OUT_OF_MEMORY;
}

void defsim__mesh_free(defsim__collider *c)
{
    struct defsim__bvh *m = c->bvh;
    if (!m) return;
    free(m->fn);
    free(m->en);
    free(m->vn);
    free(m->node);
    free(m->order);
    free(m->tx);
    free(m);
    c->bvh = NULL;
}

void defsim__mesh_local_bounds(const defsim__collider *c, double lo[3], double hi[3])
{
    const bvh_node *root = &c->bvh->node[0];
    memcpy(lo, root->lo, 3 * sizeof *lo);
    memcpy(hi, root->hi, 3 * sizeof *hi);
}

/* ------------------------------------------------------------------------------------------ */
/* Queries */

/* Closest point q on triangle (a, b, c) to p and its feature (defsim__triangle_closest: 0 + k
 * corner k, 3 + k the edge from corner k to k + 1, 6 the face), from the feature's parameters
 * (on the edge and the face, from the corner that starts it). */
static void closest_on_triangle(const double *p, const double *a, const double *b,
                                const double *c, double q[3], int *feature)
{
    double w[3];
    const int f = defsim__triangle_closest(p, a, b, c, w);
    *feature = f;
    for (int k = 0; k < 3; ++k) {
        switch (f) {
        case 0: q[k] = a[k]; break;
        case 1: q[k] = b[k]; break;
        case 2: q[k] = c[k]; break;
        case 3: q[k] = a[k] + w[1] * (b[k] - a[k]); break;
        case 4: q[k] = b[k] + w[2] * (c[k] - b[k]); break;
        case 5: q[k] = a[k] + w[2] * (c[k] - a[k]); break;
        default: q[k] = a[k] + w[1] * (b[k] - a[k]) + w[2] * (c[k] - a[k]); break;
        }
    }
}

static double box_dist2(const bvh_node *n, const double *p)
{
    double s = 0.0;
    for (int k = 0; k < 3; ++k) {
        const double e = p[k] < n->lo[k] ? n->lo[k] - p[k] : p[k] > n->hi[k] ? p[k] - n->hi[k] : 0.0;
        s += e * e;
    }
    return s;
}

double defsim__mesh_distance_brute(const defsim__collider *c, const double p[3])
{
    const struct defsim__bvh *m = c->bvh;
    double best = INFINITY;
    for (int32_t t = 0; t < m->nt; ++t) {
        const int32_t *v = m->tri + 3 * t;
        double r[3], e[3];
        int f;
        closest_on_triangle(p, m->x + 3 * v[0], m->x + 3 * v[1], m->x + 3 * v[2], r, &f);
        defsim__v3_sub(p, r, e);
        if (defsim__v3_dot(e, e) < best) best = defsim__v3_dot(e, e);
    }
    return sqrt(best);
}

void defsim__mesh_distance(const defsim__collider *c, const double p[3], double *d, double g[3],
                           double h[9])
{
    const struct defsim__bvh *m = c->bvh;
    double best = INFINITY, q[3] = {0.0, 0.0, 0.0};
    int32_t best_t = 0;
    int best_f = 6;
    int32_t stack[128];
    int sp = 0;
    stack[sp++] = 0;
    while (sp > 0) {
        const bvh_node *n = &m->node[stack[--sp]];
        if (box_dist2(n, p) >= best) continue;
        if (n->count > 0) {
            for (int32_t i = n->index; i < n->index + n->count; ++i) {
                const double *tx = m->tx + 9 * (size_t)i;
                double r[3], e[3];
                int f;
                closest_on_triangle(p, tx, tx + 3, tx + 6, r, &f);
                defsim__v3_sub(p, r, e);
                const double d2 = defsim__v3_dot(e, e);
                if (d2 < best) {
                    best = d2;
                    best_t = m->order[i];
                    best_f = f;
                    memcpy(q, r, sizeof q);
                }
            }
            continue;
        }
        /* the nearer child last, so that it is popped first */
        const int32_t l = (int32_t)(n - m->node) + 1, r = n->index;
        const double dl = box_dist2(&m->node[l], p), dr = box_dist2(&m->node[r], p);
        if (dl < dr) {
            if (dr < best) stack[sp++] = r;
            if (dl < best) stack[sp++] = l;
        } else {
            if (dl < best) stack[sp++] = l;
            if (dr < best) stack[sp++] = r;
        }
    }
    const int32_t *v = m->tri + 3 * best_t;
    const double *pn = best_f == 6 ? m->fn + 3 * best_t
                     : best_f >= 3 ? m->en + 9 * best_t + 3 * (best_f - 3)
                                   : m->vn + 3 * v[best_f];
    double e[3];
    defsim__v3_sub(p, q, e);
    const double u = sqrt(best);
    const double s = defsim__v3_dot(e, pn) < 0.0 ? -1.0 : 1.0;
    if (h) memset(h, 0, 9 * sizeof *h);
    if (!(u > 0.0)) {
        *d = 0.0;
        memcpy(g, pn, 3 * sizeof *g);
        return;
    }
    *d = s * u;
    for (int k = 0; k < 3; ++k) g[k] = s * e[k] / u;
    if (!h || best_f == 6) return;   /* face region: the distance is affine */
    /* edge: s (I - t t^T - n n^T) / u, t the edge direction; corner: s (I - n n^T) / u */
    double t[3] = {0.0, 0.0, 0.0};
    if (best_f >= 3) {
        const int k = best_f - 3;
        defsim__v3_sub(m->x + 3 * v[(k + 1) % 3], m->x + 3 * v[k], t);
        normalise(t);
    }
    const double n[3] = {e[0] / u, e[1] / u, e[2] / u};
    for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j)
            h[3 * i + j] = s * ((i == j) - t[i] * t[j] - n[i] * n[j]) / u;
}
