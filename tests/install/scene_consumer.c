/* SPDX-License-Identifier: MIT */
/* Builds against an installed libdefsim_scene (and libdefsim_render with DEFSIM_HAVE_RENDER):
 * `scene_consumer SCENE.json [OUT.png]` loads the scene, steps it for 20 steps of its own h and
 * checks that its lowest vertex fell (gravity along -y) and every coordinate is finite; with a
 * PNG path, renders the state into it (64 x 48 pixels). Proves that the targets of
 * find_package(defsim), or the pkg-config files, link the two libraries. */
#include <defsim/scene.h>
#ifdef DEFSIM_HAVE_RENDER
#include <defsim/render.h>
#endif
#include <math.h>
#include <stdio.h>
#include <stdlib.h>

static double lowest(const double *x, int32_t n)
{
    double y = INFINITY;
    for (int32_t i = 0; i < n; ++i) y = fmin(y, x[3 * i + 1]);
    return y;
}

int main(int argc, char **argv)
{
    if (argc < 2) return 2;
    char err[512];
    defsim_scene *s = NULL;
    defsim_world *w = NULL;
    if (defsim_scene_load(argv[1], NULL, 0, &s, err, sizeof err) != DEFSIM_OK) {
        fprintf(stderr, "%s\n", err);
        return 3;
    }
    defsim_scene_info info = {sizeof info};
    if (defsim_scene_get_info(s, &info) != DEFSIM_OK || defsim_scene_build(s, &w) != DEFSIM_OK) {
        fprintf(stderr, "%s\n", defsim_scene_last_error(s));
        return 4;
    }
    const int32_t n = defsim_world_vertex_count(w);
    double *x = malloc(3 * (size_t)n * sizeof *x);
    if (!x || defsim_world_get_positions(w, x, n) != DEFSIM_OK) return 5;
    const double y0 = lowest(x, n);
    for (int k = 0; k < 20; ++k)
        if (defsim_scene_step(s, w, info.step) != DEFSIM_OK) {
            fprintf(stderr, "step %d: %s\n", k, defsim_scene_last_error(s));
            return 6;
        }
    defsim_world_get_positions(w, x, n);
    for (int32_t i = 0; i < 3 * n; ++i)
        if (!isfinite(x[i])) return 7;
    const double y1 = lowest(x, n);
    printf("%s: %d vertices, lowest y %.6g -> %.6g after 20 steps of %g s\n", info.name, n, y0,
           y1, info.step);
    if (!(y1 < y0)) return 8;
#ifdef DEFSIM_HAVE_RENDER
    if (argc > 2) {
        /* The bodies' springs as lines, triangles as triangles (the shipped rope: lines). */
        defsim_render_part parts[16];
        int32_t count = 0;
        for (int32_t b = 0; b < info.body_count && count < 16; ++b) {
            defsim_scene_body body = {sizeof body};
            if (defsim_scene_get_body(s, b, &body) != DEFSIM_OK) return 9;
            int32_t *lines = malloc(2 * (size_t)(body.line_count + 1) * sizeof *lines);
            int32_t *tris = malloc(3 * (size_t)(body.mesh->triangle_count + 1) * sizeof *tris);
            if (!lines || !tris) return 9;
            for (int32_t i = 0; i < 2 * body.line_count; ++i)
                lines[i] = body.mesh->springs[i] + body.vertex_offset;
            for (int32_t i = 0; i < 3 * body.mesh->triangle_count; ++i)
                tris[i] = body.mesh->triangles[i] + body.vertex_offset;
            parts[count++] = (defsim_render_part){tris, body.mesh->triangle_count, lines,
                                                  body.line_count, {-1.0f, 0, 0}, 1};
        }
        if (defsim_render_png(argv[2], 64, 48, n, x, parts, count, info.gravity, err,
                              sizeof err) != DEFSIM_OK) {
            fprintf(stderr, "render: %s\n", err);
            return 10;
        }
        for (int32_t i = 0; i < count; ++i) {
            free((void *)parts[i].lines);
            free((void *)parts[i].triangles);
        }
        printf("rendered %s\n", argv[2]);
    }
#endif
    free(x);
    defsim_world_destroy(w);
    defsim_scene_free(s);
    return 0;
}
