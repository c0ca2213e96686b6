/* SPDX-License-Identifier: MIT */
/*
 * Draws one picture of every collider shape with the renderer's overlay (tools/render/
 * overlay.c): a ground plane (the grid is put on it), a tilted second plane (a patch), a
 * sphere, a box turned 30 degrees, a capsule lying on its side, a mesh collider (a pyramid),
 * an SDF (the edges of its bounds box), and a tet body with two pinned vertices (markers).
 * usage: render_colliders OUT.png [--bodies-only]   (--bodies-only: no colliders, no markers)
 */
#include "render/image.h"
#include "render/render.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#ifndef M_PI
#define M_PI 3.14159265358979323846
#endif

static double sdf_ball(void *user, const double p[3], double grad[3])
{
    (void)user;
    const double r = sqrt(p[0] * p[0] + p[1] * p[1] + p[2] * p[2]);
    for (int i = 0; i < 3; ++i) grad[i] = r > 0.0 ? p[i] / r : 0.0;
    return r - 0.3;
}

/* The quaternion of a rotation by `deg` degrees about a unit axis. */
static void quat(double axis_x, double axis_y, double axis_z, double deg, double q[4])
{
    const double h = 0.5 * deg * M_PI / 180.0;
    q[0] = cos(h);
    q[1] = axis_x * sin(h);
    q[2] = axis_y * sin(h);
    q[3] = axis_z * sin(h);
}

int main(int argc, char **argv)
{
    if (argc < 2) {
        fprintf(stderr, "usage: render_colliders OUT.png [--bodies-only]\n");
        return 2;
    }
    const int colliders = !(argc > 2 && strcmp(argv[2], "--bodies-only") == 0);
    enum { NC = 8 };
    defsim_collider_def c[NC];
    for (int i = 0; i < NC; ++i) defsim_collider_def_init(&c[i], sizeof c[i]);
    /* 0: the ground y = 0; 1: a wall behind the scene, x = -2.6, leaning back 20 degrees. */
    c[1].position[0] = -2.6;
    c[1].normal[0] = 1.0;
    c[1].normal[1] = 0.0;
    quat(0, 0, 1, -20, c[1].rotation);
    c[2].shape = DEFSIM_SHAPE_SPHERE;
    c[2].radius = 0.5;
    c[2].position[0] = -1.6;
    c[2].position[1] = 0.5;
    c[3].shape = DEFSIM_SHAPE_BOX;
    c[3].half_extents[0] = c[3].half_extents[1] = c[3].half_extents[2] = 0.35;
    c[3].position[1] = 0.35;
    quat(0, 1, 0, 30, c[3].rotation);
    c[4].shape = DEFSIM_SHAPE_CAPSULE;
    c[4].radius = 0.25;
    c[4].half_height = 0.35;
    c[4].position[0] = 1.5;
    c[4].position[1] = 0.25;
    quat(0, 0, 1, 90, c[4].rotation);
    static const double pyramid_v[] = {-0.4, 0, -0.4, 0.4, 0, -0.4, 0.4, 0, 0.4, -0.4, 0, 0.4,
                                       0, 0.6, 0};
    static const int32_t pyramid_t[] = {0, 4, 1, 1, 4, 2, 2, 4, 3, 3, 4, 0};
    c[5].shape = DEFSIM_SHAPE_MESH;
    c[5].vertices = pyramid_v;
    c[5].vertex_count = 5;
    c[5].triangles = pyramid_t;
    c[5].triangle_count = 4;
    c[5].position[0] = -0.2;
    c[5].position[2] = 1.3;
    c[6].shape = DEFSIM_SHAPE_SDF;
    c[6].sdf = sdf_ball;
    for (int i = 0; i < 3; ++i) {
        c[6].sdf_bounds[i] = -0.3;
        c[6].sdf_bounds[3 + i] = 0.3;
    }
    c[6].position[0] = 1.3;
    c[6].position[1] = 0.3;
    c[6].position[2] = 1.3;
    /* 7: an unbounded SDF: nothing to draw. */
    c[7].shape = DEFSIM_SHAPE_SDF;
    c[7].sdf = sdf_ball;

    /* The body: one tet above the box, its two lower vertices pinned. */
    const double x[12] = {-0.3, 1.2, -0.2, 0.3, 1.2, -0.2, 0.0, 1.2, 0.35, 0.0, 1.7, 0.0};
    const int64_t tet[4] = {0, 1, 2, 3};
    int32_t ntris = 0;
    int32_t *tris = rd_tet_surface(tet, 1, &ntris);
    const uint8_t pinned[4] = {1, 1, 0, 0};
    rd_part body = {.tris = tris, .ntris = ntris, .color = {0.85f, 0.45f, 0.2f}};

    scene_camera cam = {.automatic = 1, .fov = 35.0, .azimuth = 25.0, .elevation = 22.0,
                        .zoom = 1.0, .ground = 1};
    const double lo[3] = {-2.1, 0.0, -0.6}, hi[3] = {2.2, 1.7, 1.8}, g[3] = {0, -9.81, 0};
    const int W = 480, H = 300;
    rd_view view;
    rd_view_make(&cam, lo, hi, g, (double)W / H, &view);
    char err[512];
    rd_renderer *rd = rd_create(W, H, 2, err, sizeof err);
    if (!rd || !tris) {
        fprintf(stderr, "render_colliders: %s\n", rd ? "out of memory" : err);
        return 1;
    }
    rd_overlay ov;
    memset(&ov, 0, sizeof ov);
    static const float marker[3] = {0.8f, 0.12f, 0.08f}, grey[3] = {0.6f, 0.6f, 0.64f};
    int bad = rd_overlay_begin(&ov, x, 4);
    if (colliders) {
        bad = bad || rd_overlay_markers(&ov, pinned, 2.5 * view.line_radius, marker);
        int ground = -1;
        for (int i = 0; i < NC && !bad; ++i) {
            if (ground < 0 && rd_view_ground_plane(&view, &c[i])) ground = i;
            bad = rd_overlay_collider(&ov, &c[i], &view, ground == i, grey);
        }
    }
    rd_part parts[16];
    int np = 0;
    parts[np++] = body;
    for (int i = 0; i < ov.nparts && np < 16; ++i) parts[np++] = ov.parts[i];
    image img = {W, H, malloc((size_t)W * H * 3)};
    if (bad || !img.rgb || rd_render(rd, &view, ov.x, parts, np, img.rgb, err, sizeof err) ||
        image_write_png(argv[1], &img, err, sizeof err)) {
        fprintf(stderr, "render_colliders: %s\n", bad || !img.rgb ? "out of memory" : err);
        return 1;
    }
    printf("%s: %d parts (%d collider and marker parts)\n", argv[1], np, ov.nparts);
    image_free(&img);
    rd_overlay_free(&ov);
    rd_destroy(rd);
    free(tris);
    return 0;
}
