/* SPDX-License-Identifier: MIT */
/*
 * The live viewer: a GLFW window whose GL 3.3 core context the renderer draws with (a
 * framebuffer object read back, so that the colour bar, the time stamp and the text of the
 * overlay are drawn as in defsim run's PNG frames, then shown with rd_present).
 *
 * Input goes through four handlers (key, button, cursor, wheel), from GLFW's callbacks or from
 * the script, so that a script drives exactly what the mouse does. Dragging a vertex adds an
 * attachment (defsim_world_add_attachment) from it to the point under the cursor on the plane
 * through the vertex facing the camera, moved with the cursor and removed on release.
 *
 * Contents: the viewer's state; bodies and the start state; the camera (orbit, zoom, picking,
 * the cursor's point); stepping; dragging; input handlers; the text overlay; a frame; the
 * script (its quantities, one frame of it); vw_run.
 */
#include "viewer.h"

#include "clock.h"
#include "render/image.h"

#include <GLFW/glfw3.h>

#include <ctype.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#ifndef M_PI
#define M_PI 3.14159265358979323846
#endif

enum { PICK_RADIUS = 14 };   /* pixels: how near the cursor a vertex must be to be grabbed */

typedef struct viewer {
    const vw_def *def;
    vw_result *res;
    defsim_world *w;
    GLFWwindow *win;
    rd_renderer *rd;
    rd_body_src *src;          /* def->bodies with the world's offsets */
    defsim_body_id *ids;       /* of each body, in vertex order */
    rd_bodies bodies;
    rd_overlay overlay;
    int32_t nv;
    int64_t ncells;
    double *x, *x0, *v0, *vec, *cell, *mass;
    int width, height;         /* of the image: the window's size in screen coordinates */
    uint8_t *rgb;
    scene_camera cam;
    double lo[3], hi[3];       /* the bodies' bounds at the start: the automatic camera fits them */
    rd_view view;
    int playing, timing, quit;
    scene_color color;
    double top;                /* the colour scale's top since the start or the mode's change */
    /* mouse */
    double mx, my;
    int orbiting;
    int dragging;
    int32_t drag_v, drag_body, drag_local;
    defsim_attachment_id att;
    double plane_point[3];     /* the dragged vertex where it was grabbed */
    /* steps */
    double step_ms, steps_per_s;
    defsim_status fail;
    char fail_msg[600];
    char err[1024];
    defsim_status status;      /* of the error in err */
} viewer;

static double dot3(const double *a, const double *b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }
static double dist3(const double *a, const double *b)
{
    const double d[3] = {a[0] - b[0], a[1] - b[1], a[2] - b[2]};
    return sqrt(dot3(d, d));
}

/* ------------------------------------------------------------------------------------------ */
/* Bodies and the start state */

/* The bodies' ids and offsets from the world (after a reset they may be new) and the parts. */
static int bind_bodies(viewer *v)
{
    const vw_def *d = v->def;
    if (defsim_world_body_count(v->w) != d->nbodies) {
        snprintf(v->err, sizeof v->err, "the world has %d bodies, the viewer was given %d",
                 (int)defsim_world_body_count(v->w), (int)d->nbodies);
        return -1;
    }
    v->nv = defsim_world_vertex_count(v->w);
    int64_t cells = 0;
    for (int32_t i = 0; i < d->nbodies; ++i) {
        defsim_world_body_at(v->w, i, &v->ids[i]);
        v->src[i] = d->bodies[i];
        v->src[i].offset = defsim_body_vertex_offset(v->w, v->ids[i]);
        v->src[i].cell_offset = cells;
        cells += d->bodies[i].tet_count;
    }
    v->ncells = cells;
    rd_bodies_free(&v->bodies);
    if (rd_bodies_init(&v->bodies, v->src, d->nbodies, v->nv, 1)) {
        snprintf(v->err, sizeof v->err, "out of memory, or a triangle or line index outside its "
                                        "body");
        return -1;
    }
    const size_t n3 = 3 * (size_t)v->nv + 1;
    free(v->x); free(v->x0); free(v->v0); free(v->vec); free(v->cell); free(v->mass);
    v->x = malloc(n3 * sizeof *v->x);
    v->x0 = malloc(n3 * sizeof *v->x0);
    v->v0 = malloc(n3 * sizeof *v->v0);
    v->vec = malloc(n3 * sizeof *v->vec);
    v->cell = calloc((size_t)cells + 1, sizeof *v->cell);
    v->mass = malloc(((size_t)v->nv + 1) * sizeof *v->mass);
    if (!v->x || !v->x0 || !v->v0 || !v->vec || !v->cell || !v->mass) {
        snprintf(v->err, sizeof v->err, "out of memory");
        v->status = DEFSIM_ERR_OUT_OF_MEMORY;
        return -1;
    }
    defsim_world_get_positions(v->w, v->x0, v->nv);
    defsim_world_get_velocities(v->w, v->v0, v->nv);
    defsim_world_get_masses(v->w, v->mass, v->nv);
    memcpy(v->x, v->x0, 3 * (size_t)v->nv * sizeof *v->x);
    return 0;
}

/* ------------------------------------------------------------------------------------------ */
/* The camera */

static void make_view(viewer *v)
{
    rd_view_make(&v->cam, v->lo, v->hi, v->def->gravity, (double)v->width / v->height, &v->view);
}

/* Orbiting and zooming move the automatic camera (azimuth, elevation, zoom); an explicit one
 * becomes the automatic camera looking from the same direction at the same distance. */
static void make_automatic(viewer *v)
{
    if (v->cam.automatic) return;
    double up[3] = {-v->def->gravity[0], -v->def->gravity[1], -v->def->gravity[2]};
    if (dot3(up, up) == 0.0) up[1] = 1.0;
    const double ul = sqrt(dot3(up, up));
    for (int i = 0; i < 3; ++i) up[i] /= ul;
    double dir[3] = {v->view.eye[0] - v->view.target[0], v->view.eye[1] - v->view.target[1],
                     v->view.eye[2] - v->view.target[2]};
    const double dist = sqrt(dot3(dir, dir));
    if (dist > 0.0) for (int i = 0; i < 3; ++i) dir[i] /= dist;
    /* rd_view_make's frame: f the ground projection of +z (+x when up is near z), s = up x f. */
    double ref[3] = {0.0, 0.0, 1.0};
    if (fabs(dot3(ref, up)) > 0.9) { ref[0] = 1.0; ref[2] = 0.0; }
    double f[3], s[3];
    const double d0 = dot3(ref, up);
    for (int i = 0; i < 3; ++i) f[i] = ref[i] - d0 * up[i];
    const double fl = sqrt(dot3(f, f));
    for (int i = 0; i < 3; ++i) f[i] /= fl;
    s[0] = up[1] * f[2] - up[2] * f[1];
    s[1] = up[2] * f[0] - up[0] * f[2];
    s[2] = up[0] * f[1] - up[1] * f[0];
    v->cam.elevation = asin(fmax(-1.0, fmin(1.0, dot3(dir, up)))) * 180.0 / M_PI;
    v->cam.azimuth = atan2(dot3(dir, s), dot3(dir, f)) * 180.0 / M_PI;
    const double *lo = v->cam.has_fit ? v->cam.fit_lo : v->lo, *hi = v->cam.has_fit ? v->cam.fit_hi : v->hi;
    const double half[3] = {0.5 * (hi[0] - lo[0]), 0.5 * (hi[1] - lo[1]), 0.5 * (hi[2] - lo[2])};
    double radius = sqrt(dot3(half, half));
    if (!(radius > 0.0)) radius = 1.0;
    const double vf = v->cam.fov * M_PI / 360.0, hf = atan(tan(vf) * v->width / v->height);
    v->cam.zoom = dist > 0.0 ? radius / sin(fmin(vf, hf)) / dist : 1.0;
    v->cam.automatic = 1;
}

static void orbit(viewer *v, double dx, double dy)
{
    make_automatic(v);
    v->cam.azimuth -= 0.4 * dx;
    v->cam.elevation = fmax(-85.0, fmin(85.0, v->cam.elevation + 0.4 * dy));
    make_view(v);
}

static void zoom(viewer *v, double clicks)
{
    make_automatic(v);
    v->cam.zoom = fmax(0.05, fmin(50.0, v->cam.zoom * pow(1.1, clicks)));
    make_view(v);
}

/* The front-most vertex within PICK_RADIUS pixels of (px, py), or -1. */
static int32_t pick(const viewer *v, double px, double py)
{
    double m[16];
    rd_view_matrix(&v->view, (double)v->width / v->height, m);
    int32_t best = -1;
    double best_z = INFINITY;
    for (int32_t i = 0; i < v->nv; ++i) {
        const double *p = v->x + 3 * (int64_t)i;
        double c[4];
        for (int r = 0; r < 4; ++r) c[r] = m[r] * p[0] + m[4 + r] * p[1] + m[8 + r] * p[2] + m[12 + r];
        if (!(c[3] > 0.0)) continue;
        const double sx = 0.5 * (c[0] / c[3] + 1.0) * v->width;
        const double sy = 0.5 * (1.0 - c[1] / c[3]) * v->height;
        const double d2 = (sx - px) * (sx - px) + (sy - py) * (sy - py);
        if (d2 <= PICK_RADIUS * PICK_RADIUS && c[2] / c[3] < best_z) {
            best_z = c[2] / c[3];
            best = i;
        }
    }
    return best;
}

/* The point under the cursor (px, py) on the plane through `point` facing the camera. */
static void cursor_point(const viewer *v, double px, double py, const double point[3],
                         double out[3])
{
    double f[3], s[3], u[3];
    rd_view_basis(&v->view, f, s, u);
    const double th = tan(v->view.fov * M_PI / 360.0), aspect = (double)v->width / v->height;
    const double nx = 2.0 * px / v->width - 1.0, ny = 1.0 - 2.0 * py / v->height;
    double d[3], rel[3];
    for (int i = 0; i < 3; ++i) {
        d[i] = f[i] + nx * th * aspect * s[i] + ny * th * u[i];
        rel[i] = point[i] - v->view.eye[i];
    }
    const double t = dot3(rel, f) / dot3(d, f);
    for (int i = 0; i < 3; ++i) out[i] = v->view.eye[i] + t * d[i];
}

/* ------------------------------------------------------------------------------------------ */
/* Stepping */

static void advance(viewer *v, int n)
{
    const vw_def *d = v->def;
    double spent = 0.0;
    int done = 0;
    for (int k = 0; k < n; ++k) {
        const double t0 = tools_now();
        const defsim_status st = d->step ? d->step(d->user, v->w, d->h) : defsim_world_step(v->w, d->h);
        spent += tools_now() - t0;
        if (st != DEFSIM_OK) {
            v->fail = st;
            v->res->last_failure = st;
            snprintf(v->fail_msg, sizeof v->fail_msg, "%s: %s", defsim_status_string(st),
                     defsim_world_last_error(v->w));
            v->playing = 0;
            break;
        }
        ++done;
        ++v->res->steps;
    }
    if (done > 0) {
        v->step_ms = 1e3 * spent / done;
        v->steps_per_s = spent > 0.0 ? done / spent : 0.0;
    }
    defsim_world_get_positions(v->w, v->x, v->nv);
}

/* ------------------------------------------------------------------------------------------ */
/* Dragging */

static void release(viewer *v)
{
    if (!v->dragging) return;
    defsim_world_get_positions(v->w, v->x, v->nv);
    memcpy(v->res->drag_end, v->x + 3 * (int64_t)v->drag_v, sizeof v->res->drag_end);
    defsim_world_remove_attachment(v->w, v->att);
    v->dragging = 0;
}

static void grab(viewer *v, double px, double py)
{
    const int32_t i = pick(v, px, py);
    if (i < 0) return;
    int32_t b = 0;
    while (b + 1 < v->def->nbodies && v->src[b + 1].offset <= i) ++b;
    /* The spring: a 2 Hz pull of the whole body (k = M (4 pi)^2), no stiffer than an explicit
     * step takes on the vertex alone (k h^2 / m <= 1/4), damped at half the critical rate of
     * the body on it and no more than the step takes (c h / m <= 1/2). */
    const int32_t nb = defsim_body_vertex_count(v->w, v->ids[b]);
    double M = 0.0;
    for (int32_t k = 0; k < nb; ++k) M += v->mass[v->src[b].offset + k];
    const double m = v->mass[i], h = v->def->h;
    double k = v->def->drag_stiffness;
    if (!(k > 0.0)) k = fmin(M * 16.0 * M_PI * M_PI, 0.25 * m / (h * h));
    const double c = fmin(sqrt(k * M), 0.5 * m / h);
    defsim_attachment_def ad;
    defsim_attachment_def_init(&ad, sizeof ad);
    ad.body = v->ids[b];
    ad.vertex = i - v->src[b].offset;
    ad.stiffness = k > 0.0 ? k : 1.0;
    ad.damping = c > 0.0 ? c : 0.0;
    memcpy(ad.target, v->x + 3 * (int64_t)i, sizeof ad.target);
    const defsim_status st = defsim_world_add_attachment(v->w, &ad, &v->att);
    if (st != DEFSIM_OK) {
        snprintf(v->fail_msg, sizeof v->fail_msg, "drag: %s: %s", defsim_status_string(st),
                 defsim_world_last_error(v->w));
        return;
    }
    v->dragging = 1;
    v->drag_v = i;
    v->drag_body = b;
    v->drag_local = ad.vertex;
    memcpy(v->plane_point, ad.target, sizeof v->plane_point);
    v->res->drag_vertex = i;
    memcpy(v->res->drag_start, ad.target, sizeof ad.target);
    memcpy(v->res->drag_target, ad.target, sizeof ad.target);
    memcpy(v->res->drag_end, ad.target, sizeof ad.target);
}

static void drag_to(viewer *v, double px, double py)
{
    double p[3];
    cursor_point(v, px, py, v->plane_point, p);
    if (defsim_attachment_set_target(v->w, v->att, p) == DEFSIM_OK)
        memcpy(v->res->drag_target, p, sizeof p);
}

/* ------------------------------------------------------------------------------------------ */
/* Input: the same handlers for GLFW's callbacks and the script */

static void do_reset(viewer *v)
{
    release(v);
    const vw_def *d = v->def;
    defsim_status st = DEFSIM_OK;
    if (d->reset) {
        st = d->reset(d->user, &v->w);
        if (st == DEFSIM_OK && bind_bodies(v)) st = DEFSIM_ERR_OUT_OF_MEMORY;
    } else {
        st = defsim_world_set_state(v->w, v->x0, v->v0);
        defsim_world_get_positions(v->w, v->x, v->nv);
    }
    v->fail = st;
    v->fail_msg[0] = '\0';
    if (st != DEFSIM_OK)
        snprintf(v->fail_msg, sizeof v->fail_msg, "reset: %s: %.500s", defsim_status_string(st),
                 d->reset ? v->err : defsim_world_last_error(v->w));
    v->top = 0.0;
}

static void set_color(viewer *v, scene_color c)
{
    v->color = c;
    v->top = 0.0;
}

static void on_key(viewer *v, int key)
{
    switch (key) {
    case GLFW_KEY_SPACE: v->playing = !v->playing; break;
    case GLFW_KEY_N: case GLFW_KEY_RIGHT: v->playing = 0; advance(v, 1); break;
    case GLFW_KEY_R: do_reset(v); break;
    case GLFW_KEY_C: set_color(v, (scene_color)((v->color + 1) % 4)); break;
    case GLFW_KEY_1: case GLFW_KEY_2: case GLFW_KEY_3: case GLFW_KEY_4:
        set_color(v, (scene_color)(key - GLFW_KEY_1));
        break;
    case GLFW_KEY_T: v->timing = !v->timing; break;
    case GLFW_KEY_ESCAPE: case GLFW_KEY_Q: v->quit = 1; break;
    default: break;
    }
}

/* Left: orbit; right (or left with Ctrl): drag a vertex. */
static void on_button(viewer *v, int button, int down, int ctrl)
{
    const int pull = button == GLFW_MOUSE_BUTTON_RIGHT || (button == GLFW_MOUSE_BUTTON_LEFT && ctrl);
    if (!down) {
        v->orbiting = 0;
        if (pull || button == GLFW_MOUSE_BUTTON_LEFT) release(v);
        return;
    }
    if (pull && !v->dragging) grab(v, v->mx, v->my);
    else if (button == GLFW_MOUSE_BUTTON_LEFT) v->orbiting = 1;
}

static void on_move(viewer *v, double x, double y)
{
    const double dx = x - v->mx, dy = y - v->my;
    v->mx = x;
    v->my = y;
    if (v->orbiting) orbit(v, dx, dy);
    if (v->dragging) drag_to(v, x, y);
}

static viewer *of(GLFWwindow *win) { return glfwGetWindowUserPointer(win); }

static void key_cb(GLFWwindow *win, int key, int scancode, int action, int mods)
{
    (void)scancode;
    (void)mods;
    if (action == GLFW_PRESS || action == GLFW_REPEAT) on_key(of(win), key);
}

static void button_cb(GLFWwindow *win, int button, int action, int mods)
{
    on_button(of(win), button, action == GLFW_PRESS, (mods & GLFW_MOD_CONTROL) != 0);
}

static void cursor_cb(GLFWwindow *win, double x, double y) { on_move(of(win), x, y); }

static void scroll_cb(GLFWwindow *win, double dx, double dy)
{
    (void)dx;
    zoom(of(win), dy);
}

/* ------------------------------------------------------------------------------------------ */
/* The text overlay */

static void fmt(char *out, size_t n, double x)
{
    if (isfinite(x)) snprintf(out, n, "%.4g", x);
    else snprintf(out, n, "-");
}

/* A text line over a lightened band, so that it reads over the bodies too. */
static void text_line(viewer *v, int x0, int y, int sc, uint8_t grey, const char *text)
{
    image im = {v->width, v->height, v->rgb};
    const int w = (int)strlen(text) * 4 * sc + 2 * sc, h = 7 * sc;
    for (int yy = y - sc; yy < y - sc + h; ++yy)
        for (int xx = x0 - sc; xx < x0 - sc + w; ++xx) {
            if (xx < 0 || yy < 0 || xx >= v->width || yy >= v->height) continue;
            uint8_t *p = v->rgb + 3 * ((size_t)yy * v->width + xx);
            for (int c = 0; c < 3; ++c) p[c] = (uint8_t)(p[c] + (255 - p[c]) * 3 / 5);
        }
    image_draw_text(&im, x0, y, sc, grey, text);
}

static void hud(viewer *v)
{
    const int sc = v->height >= 300 ? 2 : 1, lh = 8 * sc, x0 = 6 * sc;
    int y = 6 * sc + lh;   /* below rd_timestamp's line */
    char line[1024], a[32], b[32], c[32], e[32];
    static const char *colors[4] = {"BODY", "STRESS", "DISPLACEMENT", "SPEED"};
    fmt(a, sizeof a, v->def->h);
    if (v->timing && v->step_ms > 0.0) {
        fmt(b, sizeof b, v->step_ms);
        snprintf(c, sizeof c, "%.0f", v->steps_per_s);
    } else {
        snprintf(b, sizeof b, "-");
        snprintf(c, sizeof c, "-");
    }
    snprintf(line, sizeof line, "%s  H %s s  STEP %s ms (%s STEPS/s)  STEPS %lld  COLOR %s",
             v->playing ? "PLAYING" : "PAUSED", a, b, c, (long long)v->res->steps,
             colors[v->color]);
    text_line(v, x0, y, sc, 40, line);
    y += lh;
    defsim_stats st = {.size = sizeof st};
    defsim_world_stats(v->w, &st);
    fmt(a, sizeof a, st.min_volume_ratio);
    fmt(b, sizeof b, st.energy_drift);
    snprintf(line, sizeof line, "WATCHDOG  J MIN %s  INVERTED %lld  DRIFT %s J  TRIPS %lld", a,
             (long long)st.inverted_elements, b, (long long)st.watchdog_trips);
    text_line(v, x0, y, sc, 40, line);
    y += lh;
    if (v->dragging) {
        double f[3] = {0.0, 0.0, 0.0};
        defsim_world_get_attachment_force(v->w, v->att, f);
        fmt(a, sizeof a, sqrt(dot3(f, f)));
        fmt(e, sizeof e, dist3(v->x + 3 * (int64_t)v->drag_v, v->res->drag_target));
        snprintf(line, sizeof line, "DRAG  VERTEX %d OF BODY %d  F %s N  TO TARGET %s m",
                 (int)v->drag_local, (int)v->drag_body, a, e);
        text_line(v, x0, y, sc, 40, line);
        y += lh;
    }
    if (v->fail_msg[0]) {
        /* The failure (the watchdog's message), in capitals, wrapped to the width. */
        const int cols = (v->width - 2 * x0) / (4 * sc);
        char msg[700];
        snprintf(msg, sizeof msg, "%s%s", v->fail != DEFSIM_OK ? "STEP FAILED: " : "", v->fail_msg);
        for (char *p = msg; *p; ++p) *p = (char)toupper((unsigned char)*p);
        const size_t len = strlen(msg);
        for (size_t at = 0; at < len && cols > 0 && y < v->height / 2;) {
            size_t n = len - at;
            if (n > (size_t)cols) {   /* break at the last space that fits, if any */
                n = (size_t)cols;
                while (n > 0 && msg[at + n] != ' ') --n;
                if (n == 0) n = (size_t)cols;
            }
            snprintf(line, sizeof line, "%.*s", (int)n, msg + at);
            text_line(v, x0, y, sc, 40, line);
            y += lh;
            at += n;
            while (msg[at] == ' ') ++at;
        }
    }
    text_line(v, x0, v->height - 6 * sc - 5 * sc, sc, 90,
                    "SPACE PLAY  N STEP  R RESET  C COLOR  LEFT ORBIT  WHEEL ZOOM  RIGHT PULL");
}

/* ------------------------------------------------------------------------------------------ */
/* A frame */

static int draw(viewer *v)
{
    int ww = v->width, wh = v->height;
    glfwGetWindowSize(v->win, &ww, &wh);
    if (ww > 0 && wh > 0 && (ww != v->width || wh != v->height)) {
        uint8_t *rgb = malloc((size_t)ww * wh * 3);
        if (!rgb || rd_resize(v->rd, ww, wh, v->err, sizeof v->err)) {
            free(rgb);
            snprintf(v->err, sizeof v->err, "out of memory");
        v->status = DEFSIM_ERR_OUT_OF_MEMORY;
            return -1;
        }
        free(v->rgb);
        v->rgb = rgb;
        v->width = ww;
        v->height = wh;
        make_view(v);
    }
    defsim_world_get_positions(v->w, v->x, v->nv);
    const double *vec = NULL, *cell = NULL;
    if (v->color == SCENE_COLOR_DISPLACEMENT) {
        for (int64_t k = 0; k < 3 * (int64_t)v->nv; ++k) v->vec[k] = v->x[k] - v->x0[k];
        vec = v->vec;
    } else if (v->color == SCENE_COLOR_SPEED) {
        defsim_world_get_velocities(v->w, v->vec, v->nv);
        vec = v->vec;
    } else if (v->color == SCENE_COLOR_STRESS) {
        for (int32_t i = 0; i < v->def->nbodies; ++i)
            if (v->src[i].tet_count > 0)
                defsim_body_element_stress(v->w, v->ids[i], NULL, v->cell + v->src[i].cell_offset,
                                           NULL, v->src[i].tet_count);
        cell = v->cell;
    }
    v->top = fmax(v->top, rd_color_top(v->color, v->bodies.parts, v->bodies.nparts,
                                       v->bodies.tri_cell, cell, vec, v->nv));
    double spring[6];   /* the pulling spring, vertex to target */
    if (v->dragging) {
        memcpy(spring, v->x + 3 * (int64_t)v->drag_v, 3 * sizeof *spring);
        memcpy(spring + 3, v->res->drag_target, 3 * sizeof *spring);
    }
    const rd_frame_data d = {.mode = v->color, .s = v->def->s, .top = v->top, .vec = vec,
                             .cell = cell, .pinned = v->def->pinned,
                             .ncolliders = defsim_world_collider_count(v->w),
                             .time = defsim_world_time(v->w),
                             .segment = v->dragging ? spring : NULL};
    if (rd_draw_frame(v->rd, &v->bodies, &v->overlay, &v->view, v->w, v->x, &d, v->rgb, v->err,
                      sizeof v->err))
        return -1;
    hud(v);
    int fw = v->width, fh = v->height;
    glfwGetFramebufferSize(v->win, &fw, &fh);
    if (rd_present(v->rd, v->rgb, v->width, v->height, fw, fh, v->err, sizeof v->err)) return -1;
    glfwSwapBuffers(v->win);
    return 0;
}

/* ------------------------------------------------------------------------------------------ */
/* The script */

/* Quantities of `expect` (tools/view/README.md). Returns 0, or -1 for an unknown name (with
 * v NULL: only checks the name). */
static int quantity(viewer *v, const char *name, double *out)
{
    int32_t i;
    char axis, tail;
    if (sscanf(name, "vertex.%d.%c%c", &i, &axis, &tail) == 2 && i >= 0 && axis >= 'x' &&
        axis <= 'z') {
        if (!v) return 0;
        if (i >= v->nv) return -1;
        *out = v->x[3 * (int64_t)i + (axis - 'x')];
        return 0;
    }
    static const char *names[] = {"time", "steps", "attachments", "failed", "drag.vertex",
                                  "drag.distance", "drag.start_distance", "drag.progress",
                                  "drag.moved", "min_volume_ratio", "inverted_elements",
                                  "energy_drift", "watchdog_trips"};
    int k = -1;
    for (int j = 0; j < (int)(sizeof names / sizeof names[0]); ++j)
        if (!strcmp(name, names[j])) k = j;
    if (k < 0 || !v) return k < 0 ? -1 : 0;
    const vw_result *r = v->res;
    const int held = r->drag_vertex >= 0;
    const double *xd = held ? v->x + 3 * (int64_t)r->drag_vertex : NULL;
    defsim_stats st = {.size = sizeof st};
    if (k >= 9) defsim_world_stats(v->w, &st);
    switch (k) {
    case 0: *out = defsim_world_time(v->w); break;
    case 1: *out = (double)r->steps; break;
    case 2: *out = defsim_world_attachment_count(v->w); break;
    case 3: *out = v->fail != DEFSIM_OK; break;
    case 4: *out = r->drag_vertex; break;
    case 5: *out = held ? dist3(xd, r->drag_target) : NAN; break;
    case 6: *out = held ? dist3(r->drag_start, r->drag_target) : NAN; break;
    case 7: {
        const double d0 = held ? dist3(r->drag_start, r->drag_target) : 0.0;
        *out = d0 > 0.0 ? 1.0 - dist3(xd, r->drag_target) / d0 : NAN;
        break;
    }
    case 8: *out = held ? dist3(xd, r->drag_start) : NAN; break;
    case 9: *out = st.min_volume_ratio; break;
    case 10: *out = (double)st.inverted_elements; break;
    case 11: *out = st.energy_drift; break;
    default: *out = (double)st.watchdog_trips; break;
    }
    return 0;
}

/* The right button pressed at (a[0], a[1]): 0, or -1 with v->err when no vertex is near. */
static int script_press(viewer *v, const vw_script *sc, const vw_cmd *c, const char *what)
{
    on_move(v, c->a[0], c->a[1]);
    on_button(v, GLFW_MOUSE_BUTTON_RIGHT, 1, 0);
    if (v->dragging) return 0;
    snprintf(v->err, sizeof v->err, "%.500s:%d: %s: no vertex within %d pixels of (%g, %g)",
             sc->path, c->line, what, PICK_RADIUS, c->a[0], c->a[1]);
    return -1;
}

typedef struct script_pos {
    int pc, left;   /* the command, and the frames left of a wait or a drag */
} script_pos;

/* Runs the script's commands of one frame. Returns 0, 1 when the script has ended, -1 with
 * v->err. */
static int script_frame(viewer *v, const vw_script *sc, script_pos *sp)
{
    while (sp->pc < sc->n) {
        const vw_cmd *c = &sc->cmds[sp->pc];
        switch (c->op) {
        case VW_PLAY: v->playing = 1; break;
        case VW_PAUSE: v->playing = 0; break;
        case VW_STEP: v->playing = 0; advance(v, c->n); break;
        case VW_RESET: do_reset(v); break;
        case VW_COLOR: set_color(v, (scene_color)c->n); break;
        case VW_TIMING: v->timing = c->n; break;
        case VW_QUIT: sp->pc = sc->n; return 1;
        case VW_ZOOM: zoom(v, c->a[0]); break;
        case VW_ORBIT:
            on_move(v, 0.5 * v->width, 0.5 * v->height);
            on_button(v, GLFW_MOUSE_BUTTON_LEFT, 1, 0);
            on_move(v, 0.5 * v->width + c->a[0], 0.5 * v->height + c->a[1]);
            on_button(v, GLFW_MOUSE_BUTTON_LEFT, 0, 0);
            break;
        case VW_PRESS:
            if (script_press(v, sc, c, "press")) return -1;
            break;
        case VW_MOVE: on_move(v, c->a[0], c->a[1]); break;
        case VW_RELEASE: on_button(v, GLFW_MOUSE_BUTTON_RIGHT, 0, 0); break;
        case VW_WAIT:
            if (sp->left == 0) sp->left = c->n;
            /* A frame of it; the last one ends the command (each of the n frames steps). */
            if (--sp->left == 0) ++sp->pc;
            return 0;
        case VW_DRAG:
            if (sp->left == 0) {
                if (script_press(v, sc, c, "drag")) return -1;
                sp->left = c->n;
            }
            {
                const double s = (double)(c->n - sp->left + 1) / c->n;
                on_move(v, c->a[0] + s * (c->a[2] - c->a[0]), c->a[1] + s * (c->a[3] - c->a[1]));
            }
            if (--sp->left == 0) ++sp->pc;
            return 0;
        case VW_SCREENSHOT: {
            if (draw(v)) return -1;
            const image im = {v->width, v->height, v->rgb};
            char e[1024];
            if (image_write_png(c->text, &im, e, sizeof e)) {
                snprintf(v->err, sizeof v->err, "%.400s:%d: %.500s", sc->path, c->line, e);
                v->status = DEFSIM_ERR_IO;
                return -1;
            }
            printf("screenshot %s (%d x %d, t = %.6g s)\n", c->text, v->width, v->height,
                   defsim_world_time(v->w));
            break;
        }
        case VW_EXPECT: {
            double q = NAN;
            if (quantity(v, c->text, &q)) {
                snprintf(v->err, sizeof v->err, "%.400s:%d: expect: no %.400s here", sc->path, c->line,
                         c->text);
                return -1;
            }
            const int ok = c->cmp == '<' ? q < c->value : c->cmp == '>' ? q > c->value
                         : c->cmp == 'l' ? q <= c->value : c->cmp == 'g' ? q >= c->value
                                                         : q == c->value;
            static const char *ops = "<>lg=";
            static const char *op_text[] = {"<", ">", "<=", ">=", "=="};
            const char *op = op_text[strchr(ops, c->cmp) - ops];
            ++v->res->expectations;
            if (!ok) ++v->res->expectations_failed;
            fprintf(ok ? stdout : stderr, "%s:%d: expect %s %s %.9g: %.9g, %s\n", sc->path,
                    c->line, c->text, op, c->value, q, ok ? "ok" : "FAILED");
            break;
        }
        }
        ++sp->pc;
    }
    return 1;
}

/* ------------------------------------------------------------------------------------------ */

static char glfw_message[512];

static void glfw_error(int code, const char *text)
{
    snprintf(glfw_message, sizeof glfw_message, "GLFW error 0x%x: %s", code, text);
}

static int glfw_make_current(void *ctx, uint8_t *buffer, int width, int height)
{
    (void)buffer;
    (void)width;
    (void)height;
    glfwMakeContextCurrent((GLFWwindow *)ctx);
    return 0;
}

static rd_glproc glfw_getproc(const char *name) { return (rd_glproc)glfwGetProcAddress(name); }

static void viewer_free(viewer *v)
{
    rd_overlay_free(&v->overlay);
    rd_bodies_free(&v->bodies);
    free(v->src); free(v->ids);
    free(v->x); free(v->x0); free(v->v0); free(v->vec); free(v->cell); free(v->mass);
    free(v->rgb);
}

defsim_status vw_run(const vw_def *def, vw_result *res, char *err, size_t errsz)
{
    memset(res, 0, sizeof *res);
    res->drag_vertex = -1;
    res->world = def->world;
    if (!def->world || def->nbodies < 0 || (def->nbodies > 0 && !def->bodies) ||
        !(def->h > 0.0) || !isfinite(def->h) || def->frame_steps < 1 || def->width < 64 ||
        def->height < 64 || def->width > 8192 || def->height > 8192 || def->supersample < 1 ||
        def->supersample > 4 || def->color < SCENE_COLOR_BODY || def->color > SCENE_COLOR_SPEED) {
        snprintf(err, errsz, "viewer: NULL world, h not > 0, steps per frame < 1, a window "
                             "size outside 64..8192, supersample outside 1..4 or a bad colour");
        return DEFSIM_ERR_INVALID_ARGUMENT;
    }
    vw_script sc = {0};
    if (def->script) {
        const int k = vw_script_load(&sc, def->script, err, errsz);
        if (k) return k == -2 ? DEFSIM_ERR_IO : DEFSIM_ERR_INVALID_ARGUMENT;
        for (int i = 0; i < sc.n; ++i)
            if (sc.cmds[i].op == VW_EXPECT && quantity(NULL, sc.cmds[i].text, NULL)) {
                snprintf(err, errsz, "%s:%d: expect: unknown quantity %s (time, steps, "
                         "attachments, failed, drag.vertex, drag.distance, drag.start_distance, "
                         "drag.progress, drag.moved, vertex.N.x|y|z, min_volume_ratio, "
                         "inverted_elements, energy_drift, watchdog_trips)", sc.path,
                         sc.cmds[i].line, sc.cmds[i].text);
                vw_script_free(&sc);
                return DEFSIM_ERR_INVALID_ARGUMENT;
            }
    }
    viewer *v = calloc(1, sizeof *v);
    if (!v) {
        vw_script_free(&sc);
        snprintf(err, errsz, "out of memory");
        return DEFSIM_ERR_OUT_OF_MEMORY;
    }
    v->def = def;
    v->res = res;
    v->w = def->world;
    v->cam = def->camera;
    v->color = def->color;
    v->playing = !def->paused;
    v->timing = def->timing;
    v->width = def->width;
    v->height = def->height;
    v->src = calloc((size_t)def->nbodies + 1, sizeof *v->src);
    v->ids = calloc((size_t)def->nbodies + 1, sizeof *v->ids);
    v->rgb = malloc((size_t)v->width * v->height * 3);
    int rc = 0;
    if (!v->src || !v->ids || !v->rgb) {
        snprintf(v->err, sizeof v->err, "out of memory");
        v->status = DEFSIM_ERR_OUT_OF_MEMORY;
        rc = -1;
    }
    if (rc == 0) rc = bind_bodies(v);
    for (int k = 0; k < 3; ++k) { v->lo[k] = INFINITY; v->hi[k] = -INFINITY; }
    for (int64_t i = 0; rc == 0 && i < v->nv; ++i)
        for (int k = 0; k < 3; ++k) {
            v->lo[k] = fmin(v->lo[k], v->x0[3 * i + k]);
            v->hi[k] = fmax(v->hi[k], v->x0[3 * i + k]);
        }
    if (rc == 0 && v->nv == 0) {
        for (int k = 0; k < 3; ++k) { v->lo[k] = -1.0; v->hi[k] = 1.0; }
    }
    glfwSetErrorCallback(glfw_error);
    glfw_message[0] = '\0';
    int inited = 0;
    if (rc == 0 && !(inited = glfwInit())) {
        snprintf(v->err, sizeof v->err, "no display for a window (%s; set DISPLAY, or run under "
                 "xvfb-run)", glfw_message[0] ? glfw_message : "glfwInit failed");
        v->status = DEFSIM_ERR_BACKEND_UNAVAILABLE;
        rc = -1;
    } else if (rc == 0) {
        glfwWindowHint(GLFW_CONTEXT_VERSION_MAJOR, 3);
        glfwWindowHint(GLFW_CONTEXT_VERSION_MINOR, 3);
        glfwWindowHint(GLFW_OPENGL_PROFILE, GLFW_OPENGL_CORE_PROFILE);
        glfwWindowHint(GLFW_OPENGL_FORWARD_COMPAT, GLFW_TRUE);
        glfwWindowHint(GLFW_SAMPLES, 0);
        v->win = glfwCreateWindow(v->width, v->height, def->title ? def->title : "defsim view",
                                  NULL, NULL);
        if (!v->win) {
            snprintf(v->err, sizeof v->err, "no window with a GL 3.3 core context (%s)",
                     glfw_message[0] ? glfw_message : "glfwCreateWindow failed");
            v->status = DEFSIM_ERR_BACKEND_UNAVAILABLE;
            rc = -1;
        }
    }
    if (rc == 0) {
        glfwMakeContextCurrent(v->win);
        glfwSwapInterval(def->script ? 0 : 1);
        glfwGetWindowSize(v->win, &v->width, &v->height);
        free(v->rgb);
        v->rgb = malloc((size_t)v->width * v->height * 3);
        const rd_context c = {"GLFW", v->win, glfw_make_current, NULL, glfw_getproc, 0};
        v->rd = v->rgb ? rd_create_with(&c, v->width, v->height, def->supersample, v->err,
                                        sizeof v->err)
                       : NULL;
        if (!v->rd) {
            v->status = v->rgb ? DEFSIM_ERR_BACKEND_UNAVAILABLE : DEFSIM_ERR_OUT_OF_MEMORY;
            rc = -1;
        }
    }
    if (rc == 0) {
        glfwSetWindowUserPointer(v->win, v);
        glfwSetKeyCallback(v->win, key_cb);
        glfwSetMouseButtonCallback(v->win, button_cb);
        glfwSetCursorPosCallback(v->win, cursor_cb);
        glfwSetScrollCallback(v->win, scroll_cb);
        make_view(v);
        script_pos sp = {0, 0};
        int ended = 0;
        while (rc == 0 && !ended && !v->quit && !glfwWindowShouldClose(v->win)) {
            glfwPollEvents();
            if (def->script) {
                const int k = script_frame(v, &sc, &sp);
                if (k < 0) rc = -1;
                ended = k == 1;
            }
            if (rc == 0 && !ended && v->playing) advance(v, def->frame_steps);
            if (rc == 0 && !ended && draw(v)) rc = -1;
        }
    }
    if (v->w) release(v);
    res->world = v->w;
    if (rc) snprintf(err, errsz, "%s", v->err);
    const defsim_status st = rc == 0 ? DEFSIM_OK : v->status ? v->status : DEFSIM_ERR_INVALID_ARGUMENT;
    if (v->rd) rd_destroy(v->rd);
    if (v->win) glfwDestroyWindow(v->win);
    if (inited) glfwTerminate();
    viewer_free(v);
    free(v);
    vw_script_free(&sc);
    return st;
}
