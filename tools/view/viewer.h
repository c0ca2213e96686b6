/* SPDX-License-Identifier: MIT */
/*
 * The live viewer (tools/view/README.md): a GLFW window over a world, drawn by the renderer of
 * defsim run (render/render.c over the window's GL context, with render/frame.c's colours,
 * markers and colliders). Play, pause, single step, reset, orbit and zoom, colour by stress,
 * displacement or speed, drag a vertex with the mouse (a temporary attachment through the public
 * API, removed on release), with the step time and the watchdog's diagnostics as text over the
 * picture. An input script (script.c) feeds it the same events as the mouse and keyboard, takes
 * screenshots and checks numbers. Used by `defsim view` (main.c) and libdefsim_view
 * (include/defsim/view.h).
 */
#ifndef DEFSIM_TOOLS_VIEWER_H
#define DEFSIM_TOOLS_VIEWER_H

#include "render/render.h"
#include "scene.h"

#include <defsim/defsim.h>

#include <stddef.h>
#include <stdint.h>

/* What the viewer shows and how it steps. Bodies are the world's, in vertex order
 * (defsim_world_body_at): bodies[i] describes body i (its offset and cell_offset are set by the
 * viewer). */
typedef struct vw_def {
    defsim_world *world;            /* stepped and drawn; the caller keeps it */
    const rd_body_src *bodies;
    int32_t nbodies;
    double h;                       /* s, > 0 */
    int32_t frame_steps;            /* steps per drawn frame while playing, >= 1 */
    double gravity[3];              /* m/s^2: "up" of the camera and the ground */
    const uint8_t *pinned;          /* per vertex: markers on pinned vertices, or NULL */
    scene_camera camera;            /* the initial view */
    const scene *s;                 /* its colour range, or NULL */
    int width, height, supersample; /* the window's size (pixels) */
    scene_color color;
    int paused;                     /* start paused */
    int timing;                     /* show measured times (0: "-", for screenshots) */
    double drag_stiffness;          /* N/m, 0: from the body's mass and h (README) */
    const char *script;             /* an input script, or NULL: interactive */
    const char *title;
    /* Steps the world by h (NULL: defsim_world_step): the scene's drives and moving colliders. */
    defsim_status (*step)(void *user, defsim_world *w, double h);
    /* Back to the start: may replace *w (the scene built again), keeping the bodies. NULL:
     * defsim_world_set_state with the positions and velocities the world had at the start. */
    defsim_status (*reset)(void *user, defsim_world **w);
    void *user;
} vw_def;

/* How the session went. */
typedef struct vw_result {
    int64_t steps;              /* successful steps taken by the viewer */
    defsim_status last_failure; /* of the last step that failed, or DEFSIM_OK */
    int32_t drag_vertex;        /* world index of the last vertex dragged, or -1 */
    double drag_start[3];       /* its position when it was grabbed (m) */
    double drag_target[3];      /* the attachment's target when it was last moved (m) */
    double drag_end[3];         /* its position when it was released, or now if still held */
    int expectations, expectations_failed;   /* the script's `expect` lines */
    defsim_world *world;        /* the world at the end (a reset may have replaced it) */
} vw_result;

/* Runs the viewer until the window is closed (or the script ends). Returns DEFSIM_OK, or with
 * err: DEFSIM_ERR_BACKEND_UNAVAILABLE (no display, no GL 3.3 core context),
 * DEFSIM_ERR_INVALID_ARGUMENT (bad settings, a script that does not parse or whose press or
 * drag finds no vertex, a world whose bodies are not those given), DEFSIM_ERR_IO (a script
 * that cannot be read, a screenshot that cannot be written), DEFSIM_ERR_OUT_OF_MEMORY. */
defsim_status vw_run(const vw_def *def, vw_result *res, char *err, size_t errsz);

/* Script (script.c): the commands of an input script, parsed whole before the window opens. */
typedef enum vw_op {
    VW_PLAY, VW_PAUSE, VW_STEP, VW_RESET, VW_COLOR, VW_WAIT, VW_ORBIT, VW_ZOOM, VW_PRESS,
    VW_MOVE, VW_RELEASE, VW_DRAG, VW_SCREENSHOT, VW_EXPECT, VW_TIMING, VW_QUIT
} vw_op;

typedef struct vw_cmd {
    vw_op op;
    int line;
    int n;                  /* step: steps; wait, drag: frames; color: scene_color; timing: on */
    double a[4];            /* orbit dx dy; zoom clicks; press / move x y; drag x1 y1 x2 y2 */
    char text[1024];        /* screenshot path; expect: quantity */
    int cmp;                /* expect: '<', '>', 'l' (<=), 'g' (>=), '=' */
    double value;           /* expect */
} vw_cmd;

typedef struct vw_script {
    char path[1024];
    vw_cmd *cmds;
    int n;
} vw_script;

/* Reads a script: one command a line, '#' starts a comment (tools/view/README.md). Returns 0,
 * -1 with "file:line: what" in err, or -2 when the file cannot be read. */
int vw_script_load(vw_script *sc, const char *path, char *err, size_t errsz);
void vw_script_free(vw_script *sc);

#endif
