/* SPDX-License-Identifier: MIT */
/* Meshes made by the library: the box generator and the boundary surface of tet meshes. */
#include "mesh.h"

#include "mat3.h"
#include "status.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

void defsim_mesh_free(defsim_mesh *m)
{
    if (!m) return;
    free(m->positions); free(m->tets); free(m->triangles); free(m->springs);
    m->positions = NULL;
    m->tets = m->triangles = m->springs = NULL;
    m->vertex_count = m->tet_count = m->triangle_count = m->spring_count = 0;
}

typedef struct face { int32_t key[3]; int32_t v[3]; int32_t opposite; } face;

static int cmp_face(const void *a, const void *b)
{
    const face *x = a, *y = b;
    for (int i = 0; i < 3; ++i)
        if (x->key[i] != y->key[i]) return x->key[i] < y->key[i] ? -1 : 1;
    return 0;
}

defsim_status defsim__tet_boundary(const double *pos, const int32_t *tets, int32_t nt,
                                   int32_t **tris_out, int32_t *ntris_out)
{
    static const int fv[4][3] = {{1, 2, 3}, {0, 2, 3}, {0, 1, 3}, {0, 1, 2}};
    face *f = malloc((size_t)(nt > 0 ? nt : 1) * 4 * sizeof *f);
    if (!f) return DEFSIM_ERR_OUT_OF_MEMORY;
    for (int64_t t = 0; t < nt; ++t)
        for (int k = 0; k < 4; ++k) {
            face *q = &f[4 * t + k];
            for (int i = 0; i < 3; ++i) q->v[i] = q->key[i] = tets[4 * t + fv[k][i]];
            q->opposite = tets[4 * t + k];
            /* sort the key */
            for (int i = 0; i < 3; ++i)
                for (int j = i + 1; j < 3; ++j)
                    if (q->key[j] < q->key[i]) { int32_t s = q->key[i]; q->key[i] = q->key[j]; q->key[j] = s; }
        }
    const int64_t nf = 4 * (int64_t)nt;
    qsort(f, (size_t)nf, sizeof *f, cmp_face);
    int32_t *tris = malloc((size_t)(nf > 0 ? nf : 1) * 3 * sizeof *tris);
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
            int32_t *tr = tris + 3 * (int64_t)n++;
            tr[0] = f[i].v[0];
            tr[1] = d >= 0.0 ? f[i].v[1] : f[i].v[2];
            tr[2] = d >= 0.0 ? f[i].v[2] : f[i].v[1];
        }
        i = j;
    }
    free(f);
    *tris_out = tris;
    *ntris_out = n;
    return DEFSIM_OK;
}

defsim_status defsim_mesh_box(const double lo[3], const double hi[3], int32_t nx, int32_t ny,
                              int32_t nz, defsim_mesh *m)
{
    if (!lo || !hi || !m || m->size < sizeof(defsim_mesh)) {
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
        if (!isfinite(lo[i]) || !isfinite(hi[i]) || !(hi[i] > lo[i])) {
            defsim__set_last_error("defsim_mesh_box: empty or non-finite box along axis %d", i);
            return DEFSIM_ERR_INVALID_ARGUMENT;
        }
    const int64_t nv = (int64_t)(nx + 1) * (ny + 1) * (nz + 1);
    const int64_t nt = 6 * (int64_t)nx * ny * nz;
    defsim_mesh out;
    memset(&out, 0, sizeof out);
    out.positions = malloc((size_t)nv * 3 * sizeof *out.positions);
    out.tets = malloc((size_t)nt * 4 * sizeof *out.tets);
    if (!out.positions || !out.tets) {
        defsim_mesh_free(&out);
        defsim__set_last_error("out of memory");
        return DEFSIM_ERR_OUT_OF_MEMORY;
    }
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
    defsim_status st = defsim__tet_boundary(out.positions, out.tets, out.tet_count,
                                            &out.triangles, &out.triangle_count);
    if (st != DEFSIM_OK) {
        defsim_mesh_free(&out);
        defsim__set_last_error("out of memory");
        return st;
    }
    out.size = m->size;
    *m = out;
    return DEFSIM_OK;
}
