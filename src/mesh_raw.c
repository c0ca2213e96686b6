/* SPDX-License-Identifier: MIT */
/* The raw mesh the parsers fill and the post-processing they all share (defsim__mesh_finish). */
#include "mesh_raw.h"

#include "mesh.h"
#include "tet10.h"
#include "tet_rest.h"

#include <math.h>
#include <stddef.h>
#include <stdlib.h>
#include <string.h>

int defsim__raw_room(defsim__reader *r, const defsim__raw_mesh *m, int vertex)
{
    if (r->st != DEFSIM_OK) return 0;
    const size_t have = vertex ? m->pos.n : m->tets.n + m->tris.n + m->segs.n;
    const int64_t max = vertex ? m->max_vertices : m->max_elements;
    if ((int64_t)have < max) return 1;
    defsim__rd_fail(r, DEFSIM_ERR_INVALID_MESH, r->line, "more than %lld %s, the limit "
                    "(defsim_set_limit(%s) raises it)", (long long)max,
                    vertex ? "vertices" : "elements",
                    vertex ? "DEFSIM_LIMIT_VERTICES" : "DEFSIM_LIMIT_ELEMENTS");
    return 0;
}

void defsim__raw_init(defsim__raw_mesh *m)
{
    memset(m, 0, sizeof *m);
    m->pos.elem = 3 * sizeof(double);
    m->tag.elem = sizeof(long long);
    m->tets.elem = 4 * sizeof(long long);
    m->tet_nodes = 4;
    m->tris.elem = 3 * sizeof(long long);
    m->segs.elem = 2 * sizeof(long long);
    m->tet_line.elem = m->tri_line.elem = m->seg_line.elem = sizeof(int);
    m->max_vertices = defsim_get_limit(DEFSIM_LIMIT_VERTICES);
    m->max_elements = defsim_get_limit(DEFSIM_LIMIT_ELEMENTS);
}

defsim_status defsim__raw_open(defsim__raw_mesh *m, defsim__reader *r, const char *path,
                               int hash_comments)
{
    defsim__raw_init(m);
    return defsim__rd_open(r, path, hash_comments);
}

void defsim__raw_free(defsim__raw_mesh *m)
{
    free(m->pos.p); free(m->tag.p); free(m->tets.p); free(m->tet_line.p);
    free(m->tris.p); free(m->tri_line.p); free(m->segs.p); free(m->seg_line.p);
}

int defsim__raw_quadratic(defsim__reader *r, defsim__raw_mesh *m, int line)
{
    if (m->tet_nodes == 10) return 1;
    if (m->tets.n > 0) {
        defsim__rd_fail(r, DEFSIM_ERR_INVALID_MESH, line, "the file mixes linear and quadratic "
                        "(10-node) tetrahedra");
        return 0;
    }
    m->tet_nodes = 10;
    m->tets.elem = 10 * sizeof(long long);
    return 1;
}

/* Puts the 6 mid-edge nodes of quadratic tet tt (indices into P) in VTK order: each edge takes
 * the node nearest its middle. Returns 0 when that is not one node per edge. */
static int order_mid_nodes(const double *P, int32_t tt[10])
{
    int32_t mid[6];
    int used = 0;
    for (int k = 0; k < 6; ++k) {
        const double *a = P + 3 * (int64_t)tt[defsim__tet10_edge[k][0]];
        const double *b = P + 3 * (int64_t)tt[defsim__tet10_edge[k][1]];
        int best = -1;
        double bd = INFINITY;
        for (int j = 0; j < 6; ++j) {
            const double *q = P + 3 * (int64_t)tt[4 + j];
            double d = 0.0;
            for (int i = 0; i < 3; ++i) d += (q[i] - 0.5 * (a[i] + b[i])) * (q[i] - 0.5 * (a[i] + b[i]));
            if (d < bd) { bd = d; best = j; }
        }
        if (used & (1 << best)) return 0;
        used |= 1 << best;
        mid[k] = tt[4 + best];
    }
    memcpy(tt + 4, mid, sizeof mid);
    return 1;
}

defsim_status defsim__mesh_oom(const char *path)
{
    defsim__set_last_error("%s: out of memory", path);
    return DEFSIM_ERR_OUT_OF_MEMORY;
}

typedef struct tagidx { long long tag; int32_t idx; } tagidx;

static int cmp_tagidx(const void *a, const void *b)
{
    const tagidx *x = a, *y = b;
    return (x->tag > y->tag) - (x->tag < y->tag);
}

static int32_t find_tag(const tagidx *map, size_t n, long long tag)
{
    size_t lo = 0, hi = n;
    while (lo < hi) {
        size_t mid = lo + (hi - lo) / 2;
        if (map[mid].tag < tag) lo = mid + 1;
        else hi = mid;
    }
    return lo < n && map[lo].tag == tag ? map[lo].idx : -1;
}

typedef struct edge { int32_t a, b; } edge;

static int cmp_edge(const void *p, const void *q)
{
    const edge *x = p, *y = q;
    if (x->a != y->a) return x->a < y->a ? -1 : 1;
    return (x->b > y->b) - (x->b < y->b);
}

static double dist(const double *p, const double *q)
{
    return sqrt((p[0] - q[0]) * (p[0] - q[0]) + (p[1] - q[1]) * (p[1] - q[1]) +
                (p[2] - q[2]) * (p[2] - q[2]));
}

defsim_status defsim__mesh_finish(const char *path, defsim__raw_mesh *m, int edge_springs,
                                  defsim_mesh *out)
{
    const size_t nv = m->pos.n, nt = m->tets.n, ntri = m->tris.n, nseg = m->segs.n;
    const int tn = m->tet_nodes;
    const long long *tags = m->tag.p;
    if (nv > (size_t)INT32_MAX / 3 || nt > (size_t)INT32_MAX / 10 || ntri > (size_t)INT32_MAX / 6 ||
        nseg > (size_t)INT32_MAX / 4) {
        defsim__set_last_error("%s: mesh too large for 32-bit indices", path);
        return DEFSIM_ERR_INVALID_MESH;
    }
    tagidx *map = malloc((nv ? nv : 1) * sizeof *map);
    int32_t *remap = malloc((nv ? nv : 1) * sizeof *remap);
    int32_t *tets = malloc((nt ? nt : 1) * (size_t)tn * sizeof *tets);
    int32_t *tris = malloc((ntri ? ntri : 1) * 3 * sizeof *tris);
    int32_t *segs = malloc((nseg ? nseg : 1) * 2 * sizeof *segs);
    defsim_mesh res;
    memset(&res, 0, sizeof res);
    res.tet_nodes = 4;
    defsim_status st = DEFSIM_ERR_INVALID_MESH;
    if (!map || !remap || !tets || !tris || !segs) { st = defsim__mesh_oom(path); goto done; }

    /* Tags to indices (a sorted table; duplicate tags are an error). */
    for (size_t i = 0; i < nv; ++i) {
        map[i].tag = m->tags_are_indices ? (long long)i : tags[i];
        map[i].idx = (int32_t)i;
    }
    if (!m->tags_are_indices) {
        qsort(map, nv, sizeof *map, cmp_tagidx);
        for (size_t i = 1; i < nv; ++i)
            if (map[i].tag == map[i - 1].tag) {
                defsim__set_last_error("%s: vertex number %lld is defined twice", path, map[i].tag);
                goto done;
            }
    }
    struct {
        const defsim__vec *src, *line;
        int32_t *dst;
        size_t n;
        int k;
        const char *what;
    } groups[3] = {
        {&m->tets, &m->tet_line, tets, nt, tn, "tet"},
        {&m->tris, &m->tri_line, tris, ntri, 3, "face"},
        {&m->segs, &m->seg_line, segs, nseg, 2, "line"}};
    for (int g = 0; g < 3; ++g) {
        const long long *src = groups[g].src->p;
        const int *line = groups[g].line->p;
        const int k = groups[g].k;
        for (size_t e = 0; e < groups[g].n; ++e)
            for (int a = 0; a < k; ++a) {
                long long t = src[(size_t)k * e + (size_t)a];
                int32_t idx = m->tags_are_indices ? (t >= 0 && (size_t)t < nv ? (int32_t)t : -1)
                                                  : find_tag(map, nv, t);
                if (idx < 0) {
                    if (m->tags_are_indices)
                        defsim__set_last_error("%s:%d: %s refers to vertex %lld, but the file "
                                               "has %zu vertices", path, line[e], groups[g].what,
                                               t + 1, nv);
                    else
                        defsim__set_last_error("%s:%d: %s refers to vertex %lld, which is not "
                                               "defined", path, line[e], groups[g].what, t);
                    goto done;
                }
                for (int b = 0; b < a; ++b)
                    if (groups[g].dst[(size_t)k * e + (size_t)b] == idx) {
                        defsim__set_last_error("%s:%d: %s repeats vertex %lld", path, line[e],
                                               groups[g].what, m->tags_are_indices ? t + 1 : t);
                        goto done;
                    }
                groups[g].dst[(size_t)k * e + (size_t)a] = idx;
            }
    }

    /* Keep only the vertices that some element uses, in file order. */
    for (size_t i = 0; i < nv; ++i) remap[i] = -1;
    for (size_t i = 0; i < (size_t)tn * nt; ++i) remap[tets[i]] = 0;
    for (size_t i = 0; i < 3 * ntri; ++i) remap[tris[i]] = 0;
    for (size_t i = 0; i < 2 * nseg; ++i) remap[segs[i]] = 0;
    int32_t nkeep = 0;
    for (size_t i = 0; i < nv; ++i)
        if (remap[i] == 0) remap[i] = nkeep++;
    if (nkeep == 0) {
        defsim__set_last_error("%s: the file has no elements this loader reads", path);
        goto done;
    }
    res.positions = malloc((size_t)nkeep * 3 * sizeof *res.positions);
    if (!res.positions) { st = defsim__mesh_oom(path); goto done; }
    const double *pos = m->pos.p;
    for (size_t i = 0; i < nv; ++i)
        if (remap[i] >= 0)
            memcpy(res.positions + 3 * (size_t)remap[i], pos + 3 * i, 3 * sizeof *pos);
    for (size_t i = 0; i < (size_t)tn * nt; ++i) tets[i] = remap[tets[i]];
    for (size_t i = 0; i < 3 * ntri; ++i) tris[i] = remap[tris[i]];
    for (size_t i = 0; i < 2 * nseg; ++i) segs[i] = remap[segs[i]];
    res.vertex_count = nkeep;
    const double *P = res.positions;

    /* Tets: positive orientation, not degenerate. */
    for (size_t t = 0; t < nt; ++t) {
        int32_t *tt = tets + (size_t)tn * t;
        const int line = ((const int *)m->tet_line.p)[t];
        defsim__tet_rest rest;
        if (defsim__tet_rest_eval(P, tt, &rest, NULL)) {
            defsim__set_last_error("%s:%d: tet %zu is degenerate (volume %g)", path, line, t,
                                   rest.det / 6.0);
            goto done;
        }
        if (tn == 10) {
            if (!order_mid_nodes(P, tt)) {
                defsim__set_last_error("%s:%d: quadratic tet %zu: its mid-edge nodes are not one "
                                       "near each edge's middle", path, line, t);
                goto done;
            }
            if (rest.det < 0.0) defsim__tet10_flip(tt);
            const double r = defsim__tet10_min_jacobian(P, tt);
            if (!(r > DEFSIM__TET10_MIN_JACOBIAN)) {
                defsim__set_last_error("%s:%d: quadratic tet %zu is degenerate or inverted by its "
                                       "mid-edge nodes (Jacobian determinant down to %g of its "
                                       "corners' tet)", path, line, t, r);
                goto done;
            }
        } else if (rest.det < 0.0) {
            int32_t s = tt[0]; tt[0] = tt[1]; tt[1] = s;
        }
    }
    /* Edges and polylines must have length: they become springs. */
    for (size_t e = 0; e < ntri; ++e)
        for (int a = 0; a < 3; ++a)
            if (!(dist(P + 3 * (size_t)tris[3 * e + (size_t)a],
                       P + 3 * (size_t)tris[3 * e + (size_t)(a + 1) % 3]) > 0.0)) {
                defsim__set_last_error("%s:%d: face has two vertices at the same point", path,
                                       ((const int *)m->tri_line.p)[e]);
                goto done;
            }
    for (size_t e = 0; e < nseg; ++e)
        if (!(dist(P + 3 * (size_t)segs[2 * e], P + 3 * (size_t)segs[2 * e + 1]) > 0.0)) {
            defsim__set_last_error("%s:%d: line segment of zero length", path,
                                   ((const int *)m->seg_line.p)[e]);
            goto done;
        }

    if (nt > 0) {
        res.tets = tets; tets = NULL;
        res.tet_count = (int32_t)nt;
        res.tet_nodes = tn;
        st = defsim__tet_surface(res.positions, res.tets, tn, res.tet_count, &res.triangles,
                                 &res.triangle_count);
        if (st != DEFSIM_OK) { st = defsim__mesh_oom(path); goto done; }
    } else if (ntri > 0) {
        res.triangles = tris; tris = NULL;
        res.triangle_count = (int32_t)ntri;
    }
    if (edge_springs && (res.triangle_count > 0 || nseg > 0) && nt == 0) {
        /* Unique edges of the faces and the polylines, sorted, become springs. */
        size_t ne = 3 * (size_t)res.triangle_count + nseg;
        edge *E = malloc(ne * sizeof *E);
        if (!E) { st = defsim__mesh_oom(path); goto done; }
        size_t k = 0;
        for (int32_t t = 0; t < res.triangle_count; ++t)
            for (int a = 0; a < 3; ++a) {
                int32_t u = res.triangles[3 * t + a], v = res.triangles[3 * t + (a + 1) % 3];
                E[k].a = u < v ? u : v;
                E[k++].b = u < v ? v : u;
            }
        for (size_t s = 0; s < nseg; ++s) {
            int32_t u = segs[2 * s], v = segs[2 * s + 1];
            E[k].a = u < v ? u : v;
            E[k++].b = u < v ? v : u;
        }
        qsort(E, ne, sizeof *E, cmp_edge);
        size_t nu = 0;
        for (size_t i = 0; i < ne; ++i)
            if (nu == 0 || cmp_edge(&E[i], &E[nu - 1]) != 0) E[nu++] = E[i];
        res.springs = malloc(2 * nu * sizeof *res.springs);
        if (!res.springs) { free(E); st = defsim__mesh_oom(path); goto done; }
        for (size_t i = 0; i < nu; ++i) {
            res.springs[2 * i] = E[i].a;
            res.springs[2 * i + 1] = E[i].b;
        }
        res.spring_count = (int32_t)nu;
        free(E);
    }
    if (tn == 10 && out->size < offsetof(defsim_mesh, tet_nodes) + sizeof out->tet_nodes) {
        /* the caller's struct cannot say that its tets hold 10 indices each */
        defsim__set_last_error("%s: quadratic tets need a defsim_mesh whose size covers "
                               "tet_nodes", path);
        st = DEFSIM_ERR_INVALID_ARGUMENT;
        goto done;
    }
    defsim__mesh_deliver(out, &res);
    memset(&res, 0, sizeof res);
    st = DEFSIM_OK;
done:
    defsim_mesh_free(&res);
    free(map); free(remap); free(tets); free(tris); free(segs);
    return st;
}
