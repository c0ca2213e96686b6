/* SPDX-License-Identifier: MIT */
/** @file
 * libdefsim_render: the OSMesa renderer of defsim-render behind one call, for bindings (the
 * Python package's Jupyter display) and hosts. Optional: built only when OSMesa and libpng are
 * found; it needs no display (off-screen, llvmpipe or softpipe). Plain C11 that cffi can parse.
 */
#ifndef DEFSIM_RENDER_H
#define DEFSIM_RENDER_H

#include "defsim/defsim.h"

#ifdef __cplusplus
extern "C" {
#endif

/// What to draw of one body; indices refer to the positions passed to defsim_render_png.
/// Borrowed for the call.
typedef struct defsim_render_part {
    const int32_t *triangles;   ///< 3 per triangle (a cloth, or the boundary of tets), or NULL.
    int32_t triangle_count;     ///< Triangles (0 when `triangles` is NULL).
    const int32_t *lines;       ///< 2 per segment, drawn as tubes (ropes), or NULL.
    int32_t line_count;         ///< Segments (0 when `lines` is NULL).
    float color[3];             ///< RGB in [0, 1]; color[0] < 0: part i's colour in `defsim run`.
    int32_t smooth;             ///< 1: smooth normals, two-sided lighting (cloth); 0: flat (solids).
} defsim_render_part;

/// Renders positions x (3 nv doubles, m) as `count` parts into an RGB PNG of width x height
/// pixels at `path` (written atomically), with the automatic camera of `defsim run` (fitted to
/// the bounds of x, looking down 20 degrees from 35 degrees azimuth), a ground grid below, and
/// "up" against `gravity` (m/s^2; +y when zero). Each call creates and destroys its own
/// off-screen context (median 0.23 s for 640 x 400 on the loaded 2-core build machine), so
/// calls keep no state between them. Returns DEFSIM_OK; DEFSIM_ERR_INVALID_ARGUMENT (NULL,
/// sizes outside 16..8192, an index out of range, a non-finite or no vertex);
/// DEFSIM_ERR_BACKEND_UNAVAILABLE (no OSMesa GL 3.3 context); DEFSIM_ERR_IO (cannot write the
/// file); with the reason in `err` (may be NULL).
DEFSIM_API defsim_status defsim_render_png(const char *path, int32_t width, int32_t height,
                                           int32_t nv, const double *x,
                                           const defsim_render_part *parts, int32_t count,
                                           const double gravity[3], char *err, size_t errsz);

/* A world's current state drawn as `defsim run` draws a frame (issue 28: Jupyter's display). */

/// What defsim_render_world_png colours the bodies by (the scene files' output.color).
typedef enum defsim_render_color {
    DEFSIM_RENDER_BODY = 0,          ///< Each body its colour.
    DEFSIM_RENDER_STRESS = 1,        ///< Von Mises stress per tet (Pa), flat on its faces.
    DEFSIM_RENDER_DISPLACEMENT = 2,  ///< |x - reference| per vertex (m).
    DEFSIM_RENDER_SPEED = 3          ///< |v| per vertex (m/s).
} defsim_render_color;

/// How defsim_render_world_png draws a world. Fill with defsim_render_world_def_init. Arrays
/// are borrowed for the call.
typedef struct defsim_render_world_def {
    uint32_t size;              ///< sizeof(defsim_render_world_def), set by the init function.
    int32_t width;              ///< Pixels, 16..8192. Default 640.
    int32_t height;             ///< Pixels, 16..8192. Default 400.
    int64_t cell_count;         ///< The bodies' cells as for defsim_vtk_frame_def (scene.h):
    const uint8_t *types;       ///< 3 line, 5 triangle, 10 tet per cell,
    const int64_t *offsets;     ///< the end of each cell in conn,
    const int64_t *conn;        ///< world vertex indices,
    const int32_t *body;        ///< the body of each cell (each body's cells in one run).
    const double *reference;    ///< 3 nv positions displacement is measured from (required for
                                ///< DEFSIM_RENDER_DISPLACEMENT).
    int32_t color;              ///< defsim_render_color. Default DEFSIM_RENDER_BODY.
    double color_range[2];      ///< [lo, hi] with hi > lo: a fixed colour scale; default 0, 0:
                                ///< from 0 to the largest value of the state.
    int32_t pins;               ///< 1 (default): a red marker on each pinned vertex.
    int32_t colliders;          ///< 1 (default): the colliders at their poses (the first plane
                                ///< carries the ground grid).
    int32_t contact_arrows;     ///< 1: the contact forces of the last step as arrows. Default 0.
    double arrow_scale;         ///< Their length, m per N; 0 (default): the largest 25 % of the
                                ///< bodies' bounds.
    double gravity[3];          ///< The world's gravity (m/s^2): "up" is against it (+y when
                                ///< zero). Default (0, -9.81, 0).
} defsim_render_world_def;

/// Fills *def with defaults. Does nothing if def is NULL.
DEFSIM_API void defsim_render_world_def_init(defsim_render_world_def *def, size_t size);

/// Renders the world's current state as `defsim run --render` draws a frame, with the same code
/// (the automatic camera of defsim_render_png fitted to the bodies, each body's surface: a tet
/// body's boundary, a cloth's triangles, a rope's lines as tubes; the colour mode with its
/// colour bar, pinned markers, colliders, contact arrows, the time) into an RGB PNG at `path`
/// (written atomically). Returns DEFSIM_OK; DEFSIM_ERR_INVALID_ARGUMENT (NULL, a def of the wrong
/// size, sizes, cells as defsim_vtk_write_vtu refuses them, body tags not the world's bodies,
/// an unknown colour, displacement without a reference, a non-finite position);
/// DEFSIM_ERR_BACKEND_UNAVAILABLE (no OSMesa GL 3.3 context); DEFSIM_ERR_IO;
/// DEFSIM_ERR_OUT_OF_MEMORY; with the reason in `err` (may be NULL).
DEFSIM_API defsim_status defsim_render_world_png(const char *path, defsim_world *world,
                                                 const defsim_render_world_def *def, char *err,
                                                 size_t errsz);

#ifdef __cplusplus
}
#endif

#endif
