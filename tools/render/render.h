/* SPDX-License-Identifier: MIT */
/*
 * The renderer: draws shaded surfaces (tet boundaries flat-shaded, cloth smooth and two-sided),
 * lines as tubes, a ground grid and a sky gradient with any GL 3.3 core context, supersampled and
 * box-filtered down to RGB8. rd_create makes an off-screen OSMesa context (osmesa.c, llvmpipe
 * or softpipe: defsim run's PNG frames); rd_create_with takes another (the viewer's window).
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
/* A segment from a to b, drawn as a tube (the viewer's pulling spring). */
int rd_overlay_segment(rd_overlay *o, const double a[3], const double b[3], const float rgb[3]);
void rd_overlay_free(rd_overlay *o);

/* Puts the view's ground grid on a plane collider (its point and normal at the current pose).
 * Returns 1 if c is a plane, else 0 (the view is unchanged). */
int rd_view_ground_plane(rd_view *v, const defsim_collider_def *c);

typedef struct rd_renderer rd_renderer;

/* Creates an OSMesa context for width x height output images, rendered at supersample x that
 * size (osmesa.c). Returns NULL with a message in err when OSMesa or GL 3.3 core is not
 * available. */
rd_renderer *rd_create(int width, int height, int supersample, char *err, size_t errsz);

/* A GL 3.3 core context that the renderer draws with, and where to: its own buffer
 * (into_buffer: OSMesa renders into the memory it is made current on), or a framebuffer object
 * that the renderer makes and reads back (a window's context). */
typedef void (*rd_glproc)(void);
typedef struct rd_context {
    const char *name;       /* in messages: "OSMesa", "GLFW" */
    void *ctx;
    /* Makes ctx current (for into_buffer: on buffer, RGBA of width x height). 0, or -1. */
    int (*make_current)(void *ctx, uint8_t *buffer, int width, int height);
    void (*destroy)(void *ctx);   /* by rd_destroy (and by rd_create_with when it fails); or NULL */
    rd_glproc (*getproc)(const char *name);   /* every GL entry point, GL 1.1's included */
    int into_buffer;
} rd_context;

/* rd_create over the given context (taken over: destroyed with the renderer). */
rd_renderer *rd_create_with(const rd_context *context, int width, int height, int supersample,
                            char *err, size_t errsz);
void rd_destroy(rd_renderer *r);

/* The output size, and a new one (the viewer's window was resized). rd_resize: 0, or -1. */
int rd_width(const rd_renderer *r);
int rd_height(const rd_renderer *r);
int rd_resize(rd_renderer *r, int width, int height, char *err, size_t errsz);

/* Renders positions x (3 per vertex) into rgb (width * height * 3, top row first).
 * Returns 0, or -1 with a message in err. */
int rd_render(rd_renderer *r, const rd_view *view, const double *x, const rd_part *parts,
              int nparts, uint8_t *rgb, char *err, size_t errsz);

/* Draws an RGB8 image (width x height, top row first) over the context's default framebuffer
 * of fb_width x fb_height pixels (a window: swap its buffers next). Not for into_buffer
 * contexts. Returns 0, or -1 with a message in err. */
int rd_present(rd_renderer *r, const uint8_t *rgb, int width, int height, int fb_width,
               int fb_height, char *err, size_t errsz);

/* The camera's unit vectors: forward f (eye to target), right s and up u on screen; and the
 * column-major projection times view matrix of rd_render for an image of that aspect. */
void rd_view_basis(const rd_view *v, double f[3], double s[3], double u[3]);
void rd_view_matrix(const rd_view *v, double aspect, double out[16]);

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

/* The bodies of a world as parts, and one frame of them as defsim run draws it (render/frame.c):
 * shared by defsim run's PNG frames and the viewer. */

/* One body: its index arrays are body-local, as the host gave them. */
typedef struct rd_body_src {
    int32_t offset;                      /* its first vertex in the world's positions */
    const int32_t *tets;                 /* 4 per tet, or NULL */
    int32_t tet_count;
    int64_t cell_offset;                 /* its first tet in the frame's cell values */
    const int32_t *triangles;            /* 3 per triangle: a cloth, or the boundary of tets */
    int32_t triangle_count;
    const int32_t *lines;                /* 2 per segment (springs drawn as tubes) */
    int32_t line_count;
    float color[3];
} rd_body_src;

/* The parts of the bodies (world indices) and the buffers their colours go into. */
typedef struct rd_bodies {
    rd_part *parts;
    int nparts;
    int32_t **tri_cell;   /* per part: the cell of each triangle (its tet), or NULL */
    float **tri_rgb;      /* per part: 3 per triangle, where tri_cell is not NULL */
    float *vertex_rgb;    /* 3 nv */
    int32_t nv;
} rd_bodies;

/* Builds the parts of n bodies of a world of nv vertices; with `stress`, the cells of the
 * triangles of bodies with tets (for stress colours). Returns 0, or -1 (out of memory, or a
 * triangle index outside the body: b is then freed). */
int rd_bodies_init(rd_bodies *b, const rd_body_src *src, int n, int32_t nv, int stress);
void rd_bodies_free(rd_bodies *b);

/* The bodies of a frame's cells (nv vertices), one part per body (the cells' body tags): tet
 * boundaries, triangles, lines; each part's triangles carry their cells (a tet boundary's: its
 * tet's) for stress colours. Colours from the scene's bodies (s may be NULL: the palette).
 * Returns 0, or -1 when out of memory (b is then freed). */
int rd_bodies_from_cells(rd_bodies *b, const vtk_cells *c, const scene *s, int32_t nv);

/* What one frame shows besides the positions. */
typedef struct rd_frame_data {
    scene_color mode;             /* colours: body, stress, displacement, speed */
    const scene *s;               /* its color_range, or NULL */
    double top;                   /* the colour scale's top over the run, or 0: this frame's */
    const double *vec;            /* 3 nv: displacement or velocity (colours), or NULL */
    const double *cell;           /* von Mises per cell (stress colours), or NULL */
    const uint8_t *pinned;        /* nv flags: markers, or NULL */
    const double *poses;          /* 7 per collider (position, rotation), or NULL: current */
    int32_t ncolliders;           /* of the world, drawn (the first plane is the ground) */
    double time;                  /* stamped at the top left */
    const double *segment;        /* 6: two points joined by a tube (the viewer's pulling
                                     spring, vertex to target), or NULL */
    const double *force;          /* 3 nv: contact forces drawn as arrows on top, or NULL */
    double arrow_scale, force_max; /* rd_overlay_arrows' length per unit force, largest force */
    const defsim_collider_def *colliders; /* ncolliders at the frame's poses, drawn instead of
                                     the world's (then w may be NULL), or NULL */
} rd_frame_data;

/* Renders the bodies at x with the colliders of w (or d->colliders) into rgb (the renderer's
 * size): colours, pinned markers, contact arrows (on top), colliders (overlay, reused between
 * frames), colour bar and time stamp. defsim run's PNG frames, defsim-render's, libdefsim_render's
 * world picture and the viewer's window all draw through it. Returns 0, or -1 with err. */
int rd_draw_frame(rd_renderer *r, rd_bodies *b, rd_overlay *overlay, const rd_view *view,
                  const defsim_world *w, const double *x, const rd_frame_data *d, uint8_t *rgb,
                  char *err, size_t errsz);

/* Stamps "t = 1.234 s" (simulated time t) at the top left of the width x height RGB8 image. */
void rd_timestamp(uint8_t *rgb, int width, int height, double t);

#endif
