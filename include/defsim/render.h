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

#ifdef __cplusplus
}
#endif

#endif
