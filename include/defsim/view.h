/* SPDX-License-Identifier: MIT */
/*
 * libdefsim_view: the live viewer of `defsim view` (tools/view/README.md) on a host's world, for
 * bindings (Python's defsim.view) and hosts. Optional: built only when GLFW (libglfw3-dev) and
 * libpng are found; at run time it needs a display (X11 or Wayland, or Xvfb) with OpenGL 3.3
 * core (Mesa's llvmpipe suffices). Plain C11 that cffi can parse. Thread safety: call it from
 * the thread that may open windows (the main thread on most systems), one viewer at a time.
 */
#ifndef DEFSIM_VIEW_H
#define DEFSIM_VIEW_H

#include "defsim/defsim.h"

#ifdef __cplusplus
extern "C" {
#endif

/// What to draw of one body. Indices are body-local (as in defsim_mesh). Borrowed for the call.
typedef struct defsim_view_body {
    const int32_t *triangles;   ///< 3 per triangle (a cloth, or the boundary of tets), or NULL.
    int32_t triangle_count;
    const int32_t *lines;       ///< 2 per segment, drawn as tubes (ropes), or NULL.
    int32_t line_count;
    const int32_t *tets;        ///< 4 per tet as given to defsim_world_add_body (stress colours),
                                ///< or NULL.
    int32_t tet_count;          ///< The body's tet count (defsim_body_element_stress), or 0.
    float color[3];             ///< RGB in [0, 1]; color[0] < 0: body i's colour in `defsim run`.
} defsim_view_body;

/// What the bodies are coloured by.
typedef enum defsim_view_color {
    DEFSIM_VIEW_COLOR_BODY = 0,          ///< Each body its colour.
    DEFSIM_VIEW_COLOR_STRESS = 1,        ///< Von Mises stress per tet (Pa).
    DEFSIM_VIEW_COLOR_DISPLACEMENT = 2,  ///< |x - x(start)| per vertex (m).
    DEFSIM_VIEW_COLOR_SPEED = 3          ///< |v| per vertex (m/s).
} defsim_view_color;

/// Settings of a viewer session. Fill with defsim_view_def_init, then change what you need.
typedef struct defsim_view_def {
    uint32_t size;              ///< sizeof(defsim_view_def), set by the init function.
    double h;                   ///< Step (s), > 0. Required (init sets 0).
    int32_t steps_per_frame;    ///< Steps per drawn frame while playing, >= 1. Default 1.
    int32_t width, height;      ///< The window's size (pixels), 64..8192. Default 960 x 600.
    int32_t supersample;        ///< Rendered at this multiple and box-filtered, 1..4. Default 1.
    defsim_view_color color;    ///< Default DEFSIM_VIEW_COLOR_BODY.
    int32_t paused;             ///< Non-zero: start paused. Default 0.
    int32_t show_timing;        ///< Zero: measured times shown as "-" (screenshots). Default 1.
    double drag_stiffness;      ///< N/m of the spring that pulls a dragged vertex; 0 (default):
                                ///< from the body's mass and h (tools/view/README.md).
    const char *script;         ///< An input script (tools/view/README.md), or NULL: interactive.
                                ///< With a script the window closes when it ends.
    const char *title;          ///< The window's title, or NULL.
    double gravity[3];          ///< The world's gravity (m/s^2): the camera's "up" and the
                                ///< ground are against it (+y when zero). Default (0, -9.81, 0).
} defsim_view_def;

/// How a session went (defsim_view_world fills it; may be NULL).
typedef struct defsim_view_result {
    uint32_t size;              ///< Set by the caller to sizeof(defsim_view_result).
    int64_t steps;              ///< Successful steps the viewer took.
    defsim_status last_failure; ///< Status of the last step that failed (shown, the viewer
                                ///< paused), or DEFSIM_OK.
    int32_t drag_vertex;        ///< World index of the last vertex dragged, or -1.
    double drag_start[3];       ///< Its position when it was grabbed (m).
    double drag_target[3];      ///< The pulling spring's target when it was last moved (m).
    double drag_end[3];         ///< Its position when it was released (m).
    int32_t expectations;       ///< The script's `expect` lines that ran...
    int32_t expectations_failed;///< ...and those that failed.
} defsim_view_result;

/// Fills *def with the defaults above. `size` must be sizeof *def. Does nothing if def is NULL.
DEFSIM_API void defsim_view_def_init(defsim_view_def *def, size_t size);

/// Opens a window on `world` and runs until the user closes it (or the script ends): play
/// (space), pause, single step (n), reset (r: the positions and velocities the world had when
/// the call began, through defsim_world_set_state; the time keeps counting), orbit (left drag),
/// zoom (wheel), colours (c, 1-4), and dragging a vertex (right drag, or Ctrl + left drag): an
/// attachment (defsim_world_add_attachment) from the vertex to the point under the cursor,
/// removed on release and when the call returns. The step time and the watchdog's diagnostics
/// (defsim_stats) are shown over the picture; a failed step is shown and pauses the viewer.
/// `bodies` holds one entry per live body in vertex order (defsim_world_body_at), `count` of
/// them. The world stays the caller's: on return it holds the state the session left, with no
/// attachment added. The call blocks; the world must not be used elsewhere meanwhile.
/// Errors: DEFSIM_ERR_INVALID_ARGUMENT (NULL world or def, a size field too small, count not the
/// world's body count, an index outside its body, h not > 0, a setting outside its range, a
/// script that does not parse, or whose `press` or `drag` finds no vertex);
/// DEFSIM_ERR_BACKEND_UNAVAILABLE (no display, or no OpenGL 3.3 core context);
/// DEFSIM_ERR_IO (a script that cannot be read, a screenshot that cannot be written);
/// DEFSIM_ERR_OUT_OF_MEMORY; with the reason in `err` (may be NULL).
DEFSIM_API defsim_status defsim_view_world(defsim_world *world, const defsim_view_body *bodies,
                                           int32_t count, const defsim_view_def *def,
                                           defsim_view_result *result, char *err, size_t errsz);

#ifdef __cplusplus
}
#endif

#endif
