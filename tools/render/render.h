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
    const float *vertex_colors;   /* NULL, or RGB per vertex of x (indexed like tris and lines),
                                     interpolated over triangles: replaces color */
    const float *tri_colors;      /* NULL, or RGB per triangle (flat): replaces color */
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

/* For each of the ntris triangles, the index of a tet (of ntets, 4 vertex indices each) that has
 * all three of its vertices, or -1: maps a body's boundary triangles to the cells whose values
 * colour them. Returns 0, or -1 when out of memory. */
int rd_triangle_tets(const int32_t *tets, int64_t ntets, const int32_t *tris, int32_t ntris,
                     int32_t *tet_of);

/* The colliders of a scene as parts (colliders.c): grey surfaces of its spheres, capsules, boxes
 * and meshes (planes and SDFs are not drawn), whose vertices come after the bodies' nv_bodies
 * positions. make: 0, or -1 when out of memory (free in either case). place: the bodies'
 * positions followed by the colliders' surfaces at their poses of time t (a buffer of c).
 * ground_from_colliders: a camera without a ground height gets the height of a static plane
 * collider whose normal points against gravity, so that the grid is drawn on it. */
typedef struct rd_colliders {
    const scene *s;
    rd_part *parts;           /* n of them */
    int32_t n;
    int32_t *col;             /* the collider of each part */
    double **local;           /* each part's surface in its collider's frame */
    int32_t *nv;              /* its vertex count */
    int32_t nv_bodies;        /* the bodies' vertices, first in x */
    int32_t nv_all;           /* the bodies' vertices and all the parts' */
    double *x;                /* 3 nv_all */
} rd_colliders;
int rd_colliders_make(const scene *s, int32_t nv_bodies, rd_colliders *c);
const double *rd_colliders_place(rd_colliders *c, double t, const double *x_bodies);
void rd_colliders_free(rd_colliders *c);
void rd_ground_from_colliders(const scene *s, scene_camera *cam);

/* Colour scales (scene_color): the colour of a value, and the bar drawn into a finished image
 * (right edge: the scale, its range with units, and a label). */

/* RGB of s in [0, 1] (clamped) on a perceptually ordered scale (dark blue, teal, green, yellow). */
void rd_colormap(double s, float rgb[3]);

/* Colours the parts of one frame by `mode`: stress sets the tri_colors (in tbuf[i], 3 per
 * triangle) of each part i whose tri_cell[i] (the cell of each triangle, -1 for none) is not
 * NULL, from cell_value (von Mises per cell, Pa); displacement sets every part's vertex_colors
 * (vbuf, 3 per vertex) from |displacement|. range receives the scale: the scene's color_range,
 * else 0 .. the frame's largest value. Body mode, a missing array or no tets (for stress)
 * clears both and gives the range [0, 0]. */
void rd_color_parts(scene_color mode, const scene *s, rd_part *parts, int nparts,
                    int32_t *const *tri_cell, const double *cell_value, const double *displacement,
                    int32_t nv, float *vbuf, float *const *tbuf, double range[2]);

/* Draws the colour bar of [lo, hi] for `mode` into the width x height RGB8 image; nothing for
 * body colours or an empty range (hi <= lo). */
void rd_colorbar(uint8_t *rgb, int width, int height, scene_color mode, double lo, double hi);

#endif
