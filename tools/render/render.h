/* SPDX-License-Identifier: MIT */
/*
 * Offscreen renderer: OSMesa with a GL 3.3 core context (llvmpipe or softpipe). Draws shaded
 * surfaces (tet boundaries flat-shaded, cloth smooth and two-sided), lines as tubes, a ground
 * grid and a sky gradient, supersampled and box-filtered down to RGB8.
 */
#ifndef DEFSIM_TOOLS_RENDER_H
#define DEFSIM_TOOLS_RENDER_H

#include <stddef.h>
#include <stdint.h>

#include "scene.h"

/* A fixed view: computed once per run so that every frame uses the same camera. */
typedef struct rd_view {
    double eye[3], target[3], up[3];
    double fov;               /* vertical, degrees */
    double near_plane, far_plane;
    int ground;
    double ground_origin[3];  /* a point of the ground plane */
    double ground_normal[3];  /* unit, pointing up */
    double ground_extent;     /* half size of the drawn ground square (m) */
    double grid_spacing;      /* m */
    double line_radius;       /* tube radius for lines (m) */
} rd_view;

/* Computes the view for a camera spec and the scene's bounds; `gravity` sets "up" (-g, or +y
 * when g = 0) for the automatic camera and the ground. */
void rd_view_make(const scene_camera *cam, const double lo[3], const double hi[3],
                  const double gravity[3], double aspect, rd_view *out);

/* What to draw of one body: indices into the positions passed to rd_render. */
typedef struct rd_part {
    const int32_t *tris;      /* 3 per triangle */
    int32_t ntris;
    const int32_t *lines;     /* 2 per segment, drawn as tubes */
    int32_t nlines;
    float color[3];
    int smooth;               /* smooth normals and two-sided lighting (cloth) */
} rd_part;

typedef struct rd_renderer rd_renderer;

/* Creates a context for width x height output images, rendered at supersample x that size.
 * Returns NULL with a message in err when OSMesa or GL 3.3 core is not available. */
rd_renderer *rd_create(int width, int height, int supersample, char *err, size_t errsz);
void rd_destroy(rd_renderer *r);

/* Renders positions x (3 per vertex) into rgb (width * height * 3, top row first).
 * Returns 0, or -1 with a message in err. */
int rd_render(rd_renderer *r, const rd_view *view, const double *x, const rd_part *parts,
              int nparts, uint8_t *rgb, char *err, size_t errsz);

/* Outward boundary triangles of tets (faces used once), oriented by the tets' orientation:
 * malloc'd, 3 per triangle. Positively oriented tets give outward triangles. */
int32_t *rd_tet_surface(const int64_t *tets, int64_t ntets, int32_t *ntris);

#endif
