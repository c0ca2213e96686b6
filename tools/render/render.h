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
#include "vtk.h"

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
    int on_top;               /* drawn last, over everything else (arrows) */
} rd_part;

/* Geometry drawn besides the bodies (render/overlay.c): markers on pinned vertices and the
 * world's colliders, as parts whose vertices follow the bodies' in `x`. Render with x and the
 * bodies' parts followed by `parts`. Zero-initialise; rd_overlay_begin starts each frame. */
typedef struct rd_overlay {
    double *x;            /* 3 nx: the bodies' nbody positions, then the overlay's vertices */
    int32_t nx, cap, nbody;
    rd_part *parts;       /* nparts parts of the overlay (they own their index arrays) */
    int nparts, pcap;
} rd_overlay;

/* Starts a frame: copies the bodies' nv positions and drops the previous frame's parts.
 * Returns 0, or -1 when out of memory (as do the functions below). */
int rd_overlay_begin(rd_overlay *o, const double *x, int32_t nv);
/* A small octahedron (half-diagonal `size`, m) on each body vertex whose flag is non-zero. */
int rd_overlay_markers(rd_overlay *o, const uint8_t *flag, double size, const float rgb[3]);
/* An arrow (orange) for each body vertex whose force f (3 per body vertex, N) is longer than 1 %
 * of `fmax` (the largest over the run, N): from the vertex along f, scale m per N long, a
 * six-sided shaft of radius r (m) and a cone of radius 2.2 r at its tip. */
int rd_overlay_arrows(rd_overlay *o, const double *f, double scale, double fmax, double r);
/* The arrows' scale (m per N): `given` when > 0 (output.arrow_scale), else the largest force
 * fmax 25 % of the diagonal of the bodies' bounds lo..hi over the run (0 without forces). */
double rd_arrow_scale(double given, double fmax, const double lo[3], const double hi[3]);
/* The arrows' part is drawn on top of everything (rd_part.on_top), so that forces on faces the
 * body hides (a block's bottom on the ground) stay visible. */
/* The largest |f| over n vertices (3 per vertex), 0 for NULL. */
double rd_force_max(const double *f, int32_t n);
/* A collider at its pose: spheres, capsules, boxes and mesh colliders by the scene code's
 * tessellation (scene_collider_surface), a plane as a square patch around the view's target (nothing
 * when `as_ground`: rd_view_ground_plane made it the ground), an SDF as the edges of its
 * sdf_bounds box (nothing when unbounded). */
int rd_overlay_collider(rd_overlay *o, const defsim_collider_def *c, const rd_view *v,
                        int as_ground, const float rgb[3]);
void rd_overlay_free(rd_overlay *o);

/* Puts the view's ground grid on a plane collider (its point and normal at the current pose).
 * Returns 1 if c is a plane, else 0 (the view is unchanged). */
int rd_view_ground_plane(rd_view *v, const defsim_collider_def *c);

typedef struct rd_renderer rd_renderer;

/* One frame to draw (render/draw.c): the bodies' positions, the pinned flags (NULL: no markers),
 * the contact forces (NULL: no arrows; rd_overlay_arrows' scale and largest force), the
 * colliders at the frame's poses (the first plane carries the ground grid), the colour scale of
 * the bar (`color`, range; rd_color_parts coloured the parts) and the time stamped on it. */
typedef struct rd_frame {
    const double *x;
    int32_t nv;
    const uint8_t *pinned;
    const double *force;
    double arrow_scale, force_max;
    const defsim_collider_def *colliders;
    int32_t ncolliders;
    scene_color color;
    double range[2];
    double time;
} rd_frame;

/* Draws frame f with the bodies' parts into rgb (width x height, as rd_render), the overlay o
 * (kept between frames for its buffers) holding markers, arrows and colliders, then the colour
 * bar and the time. Returns 0, or -1 with a message in err. */
int rd_draw_frame(rd_renderer *r, const rd_view *view, rd_overlay *o, const rd_part *parts,
                  int nparts, const rd_frame *f, uint8_t *rgb, int width, int height, char *err,
                  size_t errsz);

/* Render parts for a frame's cells, one per body (the cells' body tags): tet boundaries,
 * triangles, lines; tri_cell receives each part's triangles' cells (a tet boundary's: its tet's)
 * for stress colours. Colours from the scene's bodies (s may be NULL: the palette). Returns 0,
 * or -1 when out of memory (what was made is the caller's to free with rd_parts_free). */
int rd_parts_from_cells(const vtk_cells *c, const scene *s, rd_part **out, int *nout,
                        int32_t ***tri_cell);
void rd_parts_free(rd_part *p, int n, int32_t **tri_cell);

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

/* Colour scales (scene_color): the colour of a value, and the bar drawn into a finished image
 * (right edge: the scale, its range with units, and a label). */

/* RGB of s in [0, 1] (clamped) on a perceptually ordered scale (dark blue, teal, green, yellow). */
void rd_colormap(double s, float rgb[3]);

/* The largest value that `mode` colours by in one frame: von Mises over the cells that colour
 * the parts' triangles (stress), or |vertex_vec| over the nv vertices (displacement, speed);
 * 0 for body colours or a missing array. */
double rd_color_top(scene_color mode, const rd_part *parts, int nparts,
                    int32_t *const *tri_cell, const double *cell_value, const double *vertex_vec,
                    int32_t nv);

/* Colours the parts of one frame by `mode`: stress sets the tri_colors (in tbuf[i], 3 per
 * triangle) of each part i whose tri_cell[i] (the cell of each triangle, -1 for none) is not
 * NULL, from cell_value (von Mises per cell, Pa); displacement and speed set every part's
 * vertex_colors (vbuf, 3 per vertex) from |vertex_vec| (displacement, m, or velocity, m/s).
 * range receives the scale: the scene's color_range, else 0 .. top when top > 0 (the largest
 * value over the run, so that every frame shares one scale), else 0 .. the frame's largest
 * value. Body mode, a missing array or no tets (for stress) clears both and gives [0, 0]. */
void rd_color_parts(scene_color mode, const scene *s, rd_part *parts, int nparts,
                    int32_t *const *tri_cell, const double *cell_value, const double *vertex_vec,
                    int32_t nv, double top, float *vbuf, float *const *tbuf, double range[2]);

/* Draws the colour bar of [lo, hi] for `mode` into the width x height RGB8 image; nothing for
 * body colours or an empty range (hi <= lo). */
void rd_colorbar(uint8_t *rgb, int width, int height, scene_color mode, double lo, double hi);

/* Stamps "t = 1.234 s" (simulated time t) at the top left of the width x height RGB8 image. */
void rd_timestamp(uint8_t *rgb, int width, int height, double t);

#endif
