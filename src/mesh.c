/* SPDX-License-Identifier: MIT */
/* Meshes made by the library: box, cloth and rope generators, and the boundary of tet meshes. */
#include "mesh.h"

#include "mat3.h"
#include "status.h"
#include "tet10.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

void defsim_mesh_free(defsim_mesh *m)
{
    if (!m) return;
    free(m->positions); free(m->tets); free(m->triangles); free(m->springs);
    if (m->size >= offsetof(defsim_mesh, spring_kinds) + sizeof m->spring_kinds) {
        free(m->spring_kinds);
        m->spring_kinds = NULL;
    }
    m->positions = NULL;
    m->tets = m->triangles = m->springs = NULL;
    m->vertex_count = m->tet_count = m->triangle_count = m->spring_count = 0;
}

void defsim__mesh_deliver(defsim_mesh *dst, defsim_mesh *src)
{
    const size_t n = dst->size < sizeof *src ? dst->size : sizeof *src;
    src->size = dst->size;
    if (n < offsetof(defsim_mesh, spring_kinds) + sizeof src->spring_kinds) {
        free(src->spring_kinds);
        src->spring_kinds = NULL;
    }
    memcpy(dst, src, n);
}

typedef struct face { int32_t key[3]; int32_t v[3]; int32_t opposite; int32_t t; } face;

static int cmp_face(const void *a, const void *b)
{
    const face *x = a, *y = b;
    for (int i = 0; i < 3; ++i)
        if (x->key[i] != y->key[i]) return x->key[i] < y->key[i] ? -1 : 1;
    return 0;
}

/* The mid-edge node of tet t (10 indices) between its corners u and w. */
static int32_t mid_node(const int32_t *tet, int32_t u, int32_t w)
{
    int cu = 0, cw = 0;
    for (int a = 0; a < 4; ++a) {
        if (tet[a] == u) cu = a;
        if (tet[a] == w) cw = a;
    }
    for (int k = 0; k < 6; ++k)
        if ((defsim__tet10_edge[k][0] == cu && defsim__tet10_edge[k][1] == cw) ||
            (defsim__tet10_edge[k][0] == cw && defsim__tet10_edge[k][1] == cu))
            return tet[4 + k];
    return -1;   /* not reached: u != w are corners of the tet */
}

defsim_status defsim__tet_surface(const double *pos, const int32_t *tets, int nodes, int32_t nt,
                                  int32_t **tris_out, int32_t *ntris_out)
{
    static const int fv[4][3] = {{1, 2, 3}, {0, 2, 3}, {0, 1, 3}, {0, 1, 2}};
    face *f = malloc((size_t)(nt > 0 ? nt : 1) * 4 * sizeof *f);
    if (!f) return DEFSIM_ERR_OUT_OF_MEMORY;
    for (int64_t t = 0; t < nt; ++t)
        for (int k = 0; k < 4; ++k) {
            face *q = &f[4 * t + k];
            for (int i = 0; i < 3; ++i) q->v[i] = q->key[i] = tets[nodes * t + fv[k][i]];
            q->opposite = tets[nodes * t + k];
            q->t = (int32_t)t;
            /* sort the key */
            for (int i = 0; i < 3; ++i)
                for (int j = i + 1; j < 3; ++j)
                    if (q->key[j] < q->key[i]) { int32_t s = q->key[i]; q->key[i] = q->key[j]; q->key[j] = s; }
        }
    const int64_t nf = 4 * (int64_t)nt;
    qsort(f, (size_t)nf, sizeof *f, cmp_face);
    const int split = nodes == 10 ? 4 : 1;
    int32_t *tris = malloc((size_t)(nf > 0 ? nf : 1) * 3 * split * sizeof *tris);
    if (!tris) { free(f); return DEFSIM_ERR_OUT_OF_MEMORY; }
    int32_t n = 0;
    for (int64_t i = 0; i < nf;) {
        int64_t j = i + 1;
        while (j < nf && cmp_face(&f[i], &f[j]) == 0) ++j;
        if (j - i == 1) {
            /* Orient outward: the normal points away from the opposite vertex. */
            const double *a = pos + 3 * (int64_t)f[i].v[0], *b = pos + 3 * (int64_t)f[i].v[1];
            const double *c = pos + 3 * (int64_t)f[i].v[2], *o = pos + 3 * (int64_t)f[i].opposite;
            double e1[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]};
            double e2[3] = {c[0] - a[0], c[1] - a[1], c[2] - a[2]};
            double nrm[3] = {e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2],
                             e1[0] * e2[1] - e1[1] * e2[0]};
            double d = nrm[0] * (a[0] - o[0]) + nrm[1] * (a[1] - o[1]) + nrm[2] * (a[2] - o[2]);
            const int32_t v0 = f[i].v[0], v1 = d >= 0.0 ? f[i].v[1] : f[i].v[2],
                          v2 = d >= 0.0 ? f[i].v[2] : f[i].v[1];
            if (split == 1) {
                int32_t *tr = tris + 3 * (int64_t)n++;
                tr[0] = v0;
                tr[1] = v1;
                tr[2] = v2;
            } else {
                /* The quadratic face as 4 triangles through its mid-edge nodes, oriented as
                 * the face. */
                const int32_t *tet = tets + 10 * (int64_t)f[i].t;
                const int32_t m01 = mid_node(tet, v0, v1), m12 = mid_node(tet, v1, v2),
                              m20 = mid_node(tet, v2, v0);
                const int32_t sub[4][3] = {{v0, m01, m20}, {m01, v1, m12}, {m20, m12, v2},
                                           {m01, m12, m20}};
                for (int k = 0; k < 4; ++k) {
                    int32_t *tr = tris + 3 * (int64_t)n++;
                    for (int c3 = 0; c3 < 3; ++c3) tr[c3] = sub[k][c3];
                }
            }
        }
        i = j;
    }
    free(f);
    *tris_out = tris;
    *ntris_out = n;
    return DEFSIM_OK;
}

defsim_status defsim__tet_boundary(const double *pos, const int32_t *tets, int32_t nt,
                                   int32_t **tris_out, int32_t *ntris_out)
{
    return defsim__tet_surface(pos, tets, 4, nt, tris_out, ntris_out);
}

/* Finite and within +-DEFSIM__COORD_MAX (NaN fails). */
static int coord_ok(double x) { return fabs(x) <= DEFSIM__COORD_MAX; }

/* A zeroed mesh with room for nv vertices and nt tets, ntri triangles, ns springs (arrays of
 * zero items stay NULL). On failure nothing is left allocated. */
static defsim_status mesh_alloc(defsim_mesh *out, int64_t nv, int64_t nt, int64_t ntri,
                                int64_t ns, int kinds)
{
    memset(out, 0, sizeof *out);
    out->size = sizeof *out;
    out->tet_nodes = 4;
    if (kinds && ns > 0) out->spring_kinds = malloc((size_t)ns * sizeof *out->spring_kinds);
    out->positions = malloc((size_t)nv * 3 * sizeof *out->positions);
    if (nt > 0) out->tets = malloc((size_t)nt * 4 * sizeof *out->tets);
    if (ntri > 0) out->triangles = malloc((size_t)ntri * 3 * sizeof *out->triangles);
    if (ns > 0) out->springs = malloc((size_t)ns * 2 * sizeof *out->springs);
    if (!out->positions || (nt > 0 && !out->tets) || (ntri > 0 && !out->triangles) ||
        (ns > 0 && !out->springs) || (kinds && ns > 0 && !out->spring_kinds)) {
        defsim_mesh_free(out);
        defsim__set_last_error("out of memory");
        return DEFSIM_ERR_OUT_OF_MEMORY;
    }
    return DEFSIM_OK;
}

defsim_status defsim_mesh_box(const double lo[3], const double hi[3], int32_t nx, int32_t ny,
                              int32_t nz, defsim_mesh *m)
{
    if (!lo || !hi || !m || m->size < DEFSIM__MESH_SIZE_V1) {
        defsim__set_last_error("defsim_mesh_box: NULL argument or mesh->size not "
                               "sizeof(defsim_mesh)");
        return DEFSIM_ERR_INVALID_ARGUMENT;
    }
    if (nx < 1 || ny < 1 || nz < 1 || (int64_t)nx * ny * nz > 50000000) {
        defsim__set_last_error("defsim_mesh_box: cells %d x %d x %d out of range", (int)nx,
                               (int)ny, (int)nz);
        return DEFSIM_ERR_INVALID_ARGUMENT;
    }
    for (int i = 0; i < 3; ++i)
        if (!coord_ok(lo[i]) || !coord_ok(hi[i]) || !(hi[i] > lo[i])) {
            defsim__set_last_error("defsim_mesh_box: empty box, or a corner beyond +-%g m, "
                                   "along axis %d", DEFSIM__COORD_MAX, i);
            return DEFSIM_ERR_INVALID_ARGUMENT;
        }
    const int64_t nv = (int64_t)(nx + 1) * (ny + 1) * (nz + 1);
    const int64_t nt = 6 * (int64_t)nx * ny * nz;
    defsim_mesh out;
    defsim_status st = mesh_alloc(&out, nv, nt, 0, 0, 0);
    if (st != DEFSIM_OK) return st;
    const int32_t n[3] = {nx, ny, nz};
    for (int32_t k = 0; k <= nz; ++k)
        for (int32_t j = 0; j <= ny; ++j)
            for (int32_t i = 0; i <= nx; ++i) {
                const int32_t ijk[3] = {i, j, k};
                double *p = out.positions + 3 * ((int64_t)i + (nx + 1) * ((int64_t)j + (ny + 1) * k));
                for (int c = 0; c < 3; ++c)
                    p[c] = ijk[c] == n[c] ? hi[c] : lo[c] + (hi[c] - lo[c]) * ijk[c] / n[c];
            }
    /* Kuhn split: the 6 monotone paths from corner 000 to 111 of each cell. */
    static const int perms[6][3] = {{0, 1, 2}, {0, 2, 1}, {1, 0, 2}, {1, 2, 0}, {2, 0, 1}, {2, 1, 0}};
    int64_t t = 0;
    for (int32_t k = 0; k < nz; ++k)
        for (int32_t j = 0; j < ny; ++j)
            for (int32_t i = 0; i < nx; ++i)
                for (int p = 0; p < 6; ++p) {
                    int c[3] = {0, 0, 0};
                    int32_t *tt = out.tets + 4 * t++;
                    for (int s = 0; s < 4; ++s) {
                        if (s > 0) c[perms[p][s - 1]] = 1;
                        tt[s] = (i + c[0]) + (nx + 1) * ((j + c[1]) + (ny + 1) * (k + c[2]));
                    }
                    /* Positive orientation: det [x0 - x3, x1 - x3, x2 - x3] > 0. */
                    double dm[9];
                    const double *p3 = out.positions + 3 * (int64_t)tt[3];
                    for (int a = 0; a < 3; ++a)
                        for (int r = 0; r < 3; ++r)
                            dm[3 * r + a] = out.positions[3 * (int64_t)tt[a] + r] - p3[r];
                    if (defsim__m3_det(dm) < 0.0) { int32_t s = tt[0]; tt[0] = tt[1]; tt[1] = s; }
                }
    out.vertex_count = (int32_t)nv;
    out.tet_count = (int32_t)nt;
    st = defsim__tet_boundary(out.positions, out.tets, out.tet_count, &out.triangles,
                              &out.triangle_count);
    if (st != DEFSIM_OK) {
        defsim_mesh_free(&out);
        defsim__set_last_error("out of memory");
        return st;
    }
    defsim__mesh_deliver(m, &out);
    return DEFSIM_OK;
}

/* Pairs of int64 in lexicographic order. */
static int cmp_pair(const void *a, const void *b)
{
    const int64_t *x = a, *y = b;
    if (x[0] != y[0]) return x[0] < y[0] ? -1 : 1;
    return x[1] < y[1] ? -1 : x[1] > y[1];
}

defsim_status defsim_mesh_make_quadratic(defsim_mesh *m)
{
    if (!m || m->size < offsetof(defsim_mesh, tet_nodes) + sizeof m->tet_nodes ||
        m->tet_count < 1 || !m->tets || m->tet_nodes != 4 || !m->positions) {
        defsim__set_last_error("defsim_mesh_make_quadratic: NULL mesh, mesh->size that does not "
                               "cover tet_nodes, no tets, or tets that are not linear");
        return DEFSIM_ERR_INVALID_ARGUMENT;
    }
    const int64_t nt = m->tet_count, nv = m->vertex_count;
    /* The edges, each as its key (lo << 32 | hi) and where it is first met (6 t + k): sorted by
     * key with the place in the low bits, the first of each run is where it is first met. */
    int64_t *occ = malloc((size_t)nt * 6 * 2 * sizeof *occ);
    int32_t *edge_of = malloc((size_t)nt * 6 * sizeof *edge_of);
    int64_t *first = malloc((size_t)nt * 6 * sizeof *first);
    int32_t *tets = malloc((size_t)nt * 10 * sizeof *tets);
    defsim_status st = DEFSIM_ERR_OUT_OF_MEMORY;
    double *pos = NULL;
    int32_t *tris = NULL, ntri = 0;
    if (!occ || !edge_of || !first || !tets) goto done;
    for (int64_t t = 0; t < nt; ++t)
        for (int k = 0; k < 6; ++k) {
            int64_t a = m->tets[4 * t + defsim__tet10_edge[k][0]];
            int64_t b = m->tets[4 * t + defsim__tet10_edge[k][1]];
            if (a > b) { const int64_t c = a; a = b; b = c; }
            occ[2 * (6 * t + k)] = a * nv + b;
            occ[2 * (6 * t + k) + 1] = 6 * t + k;
        }
    qsort(occ, (size_t)(6 * nt), 2 * sizeof *occ, cmp_pair);   /* by key, then place */
    int64_t ne = 0;
    for (int64_t i = 0; i < 6 * nt; ++i) {
        if (i == 0 || occ[2 * i] != occ[2 * (i - 1)]) first[ne++] = occ[2 * i + 1];
        edge_of[occ[2 * i + 1]] = (int32_t)(ne - 1);
    }
    if (nv + ne > INT32_MAX / 3) {
        defsim__set_last_error("defsim_mesh_make_quadratic: too many vertices");
        st = DEFSIM_ERR_INVALID_ARGUMENT;
        goto done;
    }
    /* New vertices in the order their edges are first met: rank the first places. */
    int64_t *order = malloc((size_t)(ne > 0 ? ne : 1) * 2 * sizeof *order);
    int32_t *rank = malloc((size_t)(ne > 0 ? ne : 1) * sizeof *rank);
    pos = malloc((size_t)(nv + ne) * 3 * sizeof *pos);
    if (!order || !rank || !pos) { free(order); free(rank); goto done; }
    for (int64_t e = 0; e < ne; ++e) { order[2 * e] = first[e]; order[2 * e + 1] = e; }
    qsort(order, (size_t)ne, 2 * sizeof *order, cmp_pair);
    for (int64_t r = 0; r < ne; ++r) rank[order[2 * r + 1]] = (int32_t)r;
    memcpy(pos, m->positions, (size_t)nv * 3 * sizeof *pos);
    for (int64_t r = 0; r < ne; ++r) {
        const int64_t place = order[2 * r], t = place / 6;
        const int k = (int)(place % 6);
        const double *pa = m->positions + 3 * (int64_t)m->tets[4 * t + defsim__tet10_edge[k][0]];
        const double *pb = m->positions + 3 * (int64_t)m->tets[4 * t + defsim__tet10_edge[k][1]];
        for (int c = 0; c < 3; ++c) pos[3 * (nv + r) + c] = 0.5 * (pa[c] + pb[c]);
    }
    for (int64_t t = 0; t < nt; ++t) {
        for (int a = 0; a < 4; ++a) tets[10 * t + a] = m->tets[4 * t + a];
        for (int k = 0; k < 6; ++k) tets[10 * t + 4 + k] = (int32_t)(nv + rank[edge_of[6 * t + k]]);
    }
    free(order);
    free(rank);
    if ((st = defsim__tet_surface(pos, tets, 10, (int32_t)nt, &tris, &ntri)) != DEFSIM_OK) goto done;
    free(m->positions);
    free(m->tets);
    free(m->triangles);
    m->positions = pos;
    m->tets = tets;
    m->triangles = tris;
    m->vertex_count = (int32_t)(nv + ne);
    m->triangle_count = ntri;
    m->tet_nodes = 10;
    pos = NULL;
    tets = NULL;
done:
    if (st == DEFSIM_ERR_OUT_OF_MEMORY) defsim__set_last_error("out of memory");
    free(occ); free(edge_of); free(first); free(tets); free(pos);
    return st;
}

static int finite3(const double *p)
{
    return coord_ok(p[0]) && coord_ok(p[1]) && coord_ok(p[2]);
}

defsim_status defsim_mesh_cloth(const double origin[3], const double u[3], const double v[3],
                                int32_t nu, int32_t nv, defsim_mesh *m)
{
    if (!origin || !u || !v || !m || m->size < DEFSIM__MESH_SIZE_V1) {
        defsim__set_last_error("defsim_mesh_cloth: NULL argument or mesh->size not "
                               "sizeof(defsim_mesh)");
        return DEFSIM_ERR_INVALID_ARGUMENT;
    }
    /* 64-bit before adding 1: nu + 1 overflows for nu = INT32_MAX. */
    if (nu < 1 || nv < 1 || ((int64_t)nu + 1) * ((int64_t)nv + 1) > 20000000) {
        defsim__set_last_error("defsim_mesh_cloth: cells %d x %d out of range", (int)nu, (int)nv);
        return DEFSIM_ERR_INVALID_ARGUMENT;
    }
    const double n[3] = {u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2],
                         u[0] * v[1] - u[1] * v[0]};
    const double area = sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
    const double lu = sqrt(u[0] * u[0] + u[1] * u[1] + u[2] * u[2]);
    const double lv = sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
    const double far[3] = {origin[0] + u[0] + v[0], origin[1] + u[1] + v[1],
                           origin[2] + u[2] + v[2]};
    if (!finite3(origin) || !finite3(u) || !finite3(v) || !finite3(far) ||
        !(area > 1e-12 * lu * lv)) {
        defsim__set_last_error("defsim_mesh_cloth: origin, u and v must be finite with every "
                               "corner within +-%g m, u and v non-zero and not parallel",
                               DEFSIM__COORD_MAX);
        return DEFSIM_ERR_INVALID_ARGUMENT;
    }
    const int64_t W = nu + 1, nvert = W * (nv + 1);
    const int64_t nstruct = (int64_t)nu * (nv + 1) + (int64_t)(nu + 1) * nv;
    const int64_t nshear = 2 * (int64_t)nu * nv;
    const int64_t nbend = (int64_t)(nu - 1) * (nv + 1) + (int64_t)(nu + 1) * (nv - 1);
    const int64_t ns = nstruct + nshear + nbend, ntri = 2 * (int64_t)nu * nv;
    defsim_mesh out;
    defsim_status st = mesh_alloc(&out, nvert, 0, ntri, ns, 1);
    if (st != DEFSIM_OK) return st;
    for (int32_t j = 0; j <= nv; ++j)
        for (int32_t i = 0; i <= nu; ++i) {
            double *p = out.positions + 3 * (i + W * j);
            const double a = (double)i / nu, b = (double)j / nv;
            for (int c = 0; c < 3; ++c) p[c] = origin[c] + a * u[c] + b * v[c];
        }
    int32_t *t = out.triangles;
    for (int32_t j = 0; j < nv; ++j)
        for (int32_t i = 0; i < nu; ++i) {
            const int32_t v00 = (int32_t)(i + W * j), v10 = v00 + 1;
            const int32_t v01 = (int32_t)(v00 + W), v11 = v01 + 1;
            *t++ = v00; *t++ = v10; *t++ = v11;
            *t++ = v00; *t++ = v11; *t++ = v01;
        }
    int32_t *s = out.springs;
    for (int32_t j = 0; j <= nv; ++j)
        for (int32_t i = 0; i < nu; ++i) { *s++ = (int32_t)(i + W * j); *s++ = (int32_t)(i + 1 + W * j); }
    for (int32_t j = 0; j < nv; ++j)
        for (int32_t i = 0; i <= nu; ++i) { *s++ = (int32_t)(i + W * j); *s++ = (int32_t)(i + W * (j + 1)); }
    for (int32_t j = 0; j < nv; ++j)
        for (int32_t i = 0; i < nu; ++i) {
            *s++ = (int32_t)(i + W * j); *s++ = (int32_t)(i + 1 + W * (j + 1));
            *s++ = (int32_t)(i + 1 + W * j); *s++ = (int32_t)(i + W * (j + 1));
        }
    for (int32_t j = 0; j <= nv; ++j)
        for (int32_t i = 0; i + 2 <= nu; ++i) { *s++ = (int32_t)(i + W * j); *s++ = (int32_t)(i + 2 + W * j); }
    for (int32_t j = 0; j + 2 <= nv; ++j)
        for (int32_t i = 0; i <= nu; ++i) { *s++ = (int32_t)(i + W * j); *s++ = (int32_t)(i + W * (j + 2)); }
    for (int64_t k = 0; k < ns; ++k)
        out.spring_kinds[k] = k < nstruct ? DEFSIM_SPRING_STRETCH
                              : k < nstruct + nshear ? DEFSIM_SPRING_SHEAR : DEFSIM_SPRING_BEND;
    out.vertex_count = (int32_t)nvert;
    out.triangle_count = (int32_t)ntri;
    out.spring_count = (int32_t)ns;
    defsim__mesh_deliver(m, &out);
    return DEFSIM_OK;
}

defsim_status defsim_mesh_rope(const double a[3], const double b[3], int32_t segments,
                               defsim_mesh *m)
{
    if (!a || !b || !m || m->size < DEFSIM__MESH_SIZE_V1) {
        defsim__set_last_error("defsim_mesh_rope: NULL argument or mesh->size not "
                               "sizeof(defsim_mesh)");
        return DEFSIM_ERR_INVALID_ARGUMENT;
    }
    if (segments < 1 || segments > 50000000) {
        defsim__set_last_error("defsim_mesh_rope: segments %d out of range", (int)segments);
        return DEFSIM_ERR_INVALID_ARGUMENT;
    }
    const double d[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]};
    if (!finite3(a) || !finite3(b) || !(d[0] * d[0] + d[1] * d[1] + d[2] * d[2] > 0.0)) {
        defsim__set_last_error("defsim_mesh_rope: ends must be distinct and finite, within "
                               "+-%g m", DEFSIM__COORD_MAX);
        return DEFSIM_ERR_INVALID_ARGUMENT;
    }
    const int64_t nvert = (int64_t)segments + 1, ns = 2 * (int64_t)segments - 1;
    defsim_mesh out;
    defsim_status st = mesh_alloc(&out, nvert, 0, 0, ns, 1);
    if (st != DEFSIM_OK) return st;
    for (int64_t i = 0; i < nvert; ++i)
        for (int c = 0; c < 3; ++c)
            out.positions[3 * i + c] = i == segments ? b[c] : a[c] + d[c] * (double)i / segments;
    int32_t *s = out.springs;
    for (int32_t i = 0; i < segments; ++i) { *s++ = i; *s++ = i + 1; }
    for (int32_t i = 0; i + 2 <= segments; ++i) { *s++ = i; *s++ = i + 2; }
    for (int64_t k = 0; k < ns; ++k)
        out.spring_kinds[k] = k < segments ? DEFSIM_SPRING_STRETCH : DEFSIM_SPRING_BEND;
    out.vertex_count = (int32_t)nvert;
    out.spring_count = (int32_t)ns;
    defsim__mesh_deliver(m, &out);
    return DEFSIM_OK;
}
