/* SPDX-License-Identifier: MIT */
#include "frame.h"

#include "scene_collider.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

void frame_plane_extent(defsim_world *w, const double *x, frame_plane *out)
{
    double lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
    const int32_t nv = defsim_world_vertex_count(w);
    double *own = x ? NULL : malloc(3 * (size_t)nv * sizeof *own + 1);
    if (own && defsim_world_get_positions(w, own, nv) == DEFSIM_OK) x = own;
    for (int64_t k = 0; x && k < 3 * (int64_t)nv; ++k) {
        lo[k % 3] = fmin(lo[k % 3], x[k]);
        hi[k % 3] = fmax(hi[k % 3], x[k]);
    }
    free(own);
    const double zero[3] = {0.0, 0.0, 0.0};
    for (int32_t i = 0; i < defsim_world_collider_count(w); ++i) {
        defsim_collider_def d = {.size = sizeof d};
        scene_geometry g;
        if (defsim_world_get_collider(w, i, NULL, &d) != DEFSIM_OK ||
            d.shape == DEFSIM_SHAPE_PLANE || scene_geometry_make(&d, zero, 0.0, &g))
            continue;
        for (int64_t k = 0; k < 3 * (int64_t)g.nv; ++k) {
            lo[k % 3] = fmin(lo[k % 3], g.x[k]);
            hi[k % 3] = fmax(hi[k % 3], g.x[k]);
        }
        scene_geometry_free(&g);
    }
    out->half = 0.0;
    for (int k = 0; k < 3; ++k) {
        const int any = lo[k] <= hi[k];
        out->centre[k] = any ? 0.5 * (lo[k] + hi[k]) : 0.0;
        if (any) out->half = fmax(out->half, 2.0 * (hi[k] - lo[k]));
    }
    if (!(out->half > 0.0) || !isfinite(out->half)) out->half = 1.0;
}

int frame_vtm_path(const char *path, char *out, size_t size)
{
    const size_t n = strlen(path);
    if (n < 4 || strcmp(path + n - 4, ".vtu") != 0 || n + 1 > size) return -1;
    memcpy(out, path, n - 4);
    memcpy(out + n - 4, ".vtm", 5);
    return 0;
}

/* The colliders' geometry at their current poses as one unstructured grid. */
static int write_colliders(const char *path, defsim_world *w, const frame_plane *plane, double t,
                           char *err, size_t errsz)
{
    const int32_t n = defsim_world_collider_count(w);
    double *x = NULL;
    int32_t nx = 0;
    vtk_cells c;
    memset(&c, 0, sizeof c);
    c.tag = "collider";
    uint8_t *shape = NULL;
    int rc = 0;
    for (int32_t i = 0; i < n && rc == 0; ++i) {
        defsim_collider_def d = {.size = sizeof d};
        scene_geometry g;
        if (defsim_world_get_collider(w, i, NULL, &d) != DEFSIM_OK) continue;
        if (scene_geometry_make(&d, plane->centre, plane->half, &g)) {
            rc = -1;
            break;
        }
        double *nxp = realloc(x, 3 * (size_t)(nx + g.nv + 1) * sizeof *x);
        if (nxp) x = nxp;
        const int64_t before = c.ncells;
        if (!nxp || vtk_cells_add(&c, g.tri, g.nt, 3, nx, VTK_TRIANGLE, i) ||
            vtk_cells_add(&c, g.lines, g.nl, 2, nx, VTK_LINE, i)) {
            rc = -1;
        } else {
            memcpy(x + 3 * (int64_t)nx, g.x, 3 * (size_t)g.nv * sizeof *x);
            nx += g.nv;
            uint8_t *s = realloc(shape, (size_t)c.ncells + 1);
            if (!s) rc = -1;
            else {
                shape = s;
                for (int64_t k = before; k < c.ncells; ++k) shape[k] = (uint8_t)d.shape;
            }
        }
        scene_geometry_free(&g);
    }
    if (rc) {
        snprintf(err, errsz, "%s: out of memory", path);
    } else {
        const vtk_array a = {"shape", 1, 1, NULL, shape};
        rc = vtk_write_vtu(path, nx, x, NULL, &c, t, &a, c.ncells > 0, err, errsz);
    }
    free(x);
    free(shape);
    vtk_cells_free(&c);
    return rc;
}

int frame_write(const char *path, defsim_world *w, const double *x, const double *v,
                const vtk_cells *c, const fields *fl, double t, int colliders,
                const frame_plane *plane, int *vtm, char *err, size_t errsz)
{
    if (vtm) *vtm = 0;
    if (vtk_write_vtu(path, defsim_world_vertex_count(w), x, v, c, t, fl ? fl->arrays : NULL,
                      fl ? fl->narrays : 0, err, errsz))
        return -1;
    if (!colliders || defsim_world_collider_count(w) == 0) return 0;
    char vtm_path[4200], col_path[4200];
    if (frame_vtm_path(path, vtm_path, sizeof vtm_path) ||
        snprintf(col_path, sizeof col_path, "%.*s_colliders.vtu", (int)(strlen(path) - 4),
                 path) >= (int)sizeof col_path) {
        snprintf(err, errsz, "%s: the frame's name must end in .vtu (and be shorter)", path);
        return -1;
    }
    if (write_colliders(col_path, w, plane, t, err, errsz)) return -1;
    /* The blocks by file name, relative to the .vtm's folder. */
    const char *slash = strrchr(path, '/'), *cslash = strrchr(col_path, '/');
    const char *names[2] = {"bodies", "colliders"};
    const char *files[2] = {slash ? slash + 1 : path, cslash ? cslash + 1 : col_path};
    if (vtk_write_vtm(vtm_path, 2, names, files, err, errsz)) return -1;
    if (vtm) *vtm = 1;
    return 0;
}
