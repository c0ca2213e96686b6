/* SPDX-License-Identifier: MIT */
/*
 * `defsim view SCENE.json [options]`: the scene in a window (tools/view/README.md). The scene's
 * step, frames per second, camera, colours and image size; play, pause, step, reset, orbit,
 * zoom, colours, dragging a vertex; --script FILE feeds it an input script and exits when the
 * script ends (with status 1 when one of its expectations failed).
 */
#include "view/viewer.h"

#include "../defsim/run.h"

#include "cli.h"
#include "scene.h"

#include <getopt.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

int defsim_tool_view(int argc, char **argv);

static void usage(FILE *f)
{
    fprintf(f,
        "usage: defsim view SCENE.json [options]\n"
        "  --script FILE       run an input script (tools/view/README.md), then exit: status 1\n"
        "                      when one of its expectations failed\n"
        "  --paused            start paused\n"
        "  --color MODE        body (default: the scene's), stress, displacement or speed\n"
        "  --size WxH          the window's size in pixels (default: the scene's image size)\n"
        "  --supersample N     render at N x the size, box-filtered (1..4, default 1)\n"
        "  --drag-stiffness K  the pulling spring (N/m; default from the body's mass and h)\n"
        "  --no-timing         show no measured times (for screenshots compared to goldens)\n"
        "  --set KEY=VALUE     override a scene value (as defsim run --set); repeatable\n"
        "  --option NAME=VALUE set a world option after the scene's (as defsim run --option)\n"
        "  --backend NAME      override world.backend\n"
        "  --threads N         override world.threads\n"
        "  -h, --help          this text; --version: the library's version\n"
        "keys: space play/pause, n step, r reset, c colour (1-4 choose), t timing, q quit;\n"
        "mouse: left drag orbits, wheel zooms, right drag (or Ctrl + left) pulls a vertex\n");
}

typedef struct view_scene {
    scene s;
    const char **opts;
    int nopts;
} view_scene;

static defsim_status step_scene(void *user, defsim_world *w, double h)
{
    return scene_step(&((view_scene *)user)->s, w, h);
}

/* Reset: the scene's world built again (time 0, the drives and colliders at their start). */
static defsim_status reset_scene(void *user, defsim_world **w)
{
    view_scene *vs = user;
    defsim_world *nw = NULL;
    defsim_status st = scene_build(&vs->s, &nw);
    if (st == DEFSIM_OK && run_set_options("defsim view", nw, vs->opts, vs->nopts)) st = DEFSIM_ERR_INVALID_ARGUMENT;
    if (st != DEFSIM_OK) {
        defsim_world_destroy(nw);
        return st;
    }
    defsim_world_destroy(*w);
    *w = nw;
    return DEFSIM_OK;
}

int defsim_tool_view(int argc, char **argv)
{
    enum { O_SCRIPT = CLI_OPT, O_PAUSED, O_COLOR, O_SIZE, O_SUPERSAMPLE, O_DRAG, O_NO_TIMING,
           O_SET, O_OPTION, O_BACKEND, O_THREADS };
    static const struct option longs[] = {
        {"script", required_argument, NULL, O_SCRIPT}, {"paused", no_argument, NULL, O_PAUSED},
        {"color", required_argument, NULL, O_COLOR}, {"size", required_argument, NULL, O_SIZE},
        {"supersample", required_argument, NULL, O_SUPERSAMPLE},
        {"drag-stiffness", required_argument, NULL, O_DRAG},
        {"no-timing", no_argument, NULL, O_NO_TIMING}, {"set", required_argument, NULL, O_SET},
        {"option", required_argument, NULL, O_OPTION},
        {"backend", required_argument, NULL, O_BACKEND},
        {"threads", required_argument, NULL, O_THREADS}, {NULL, 0, NULL, 0}};
    static const cli_tool tool = {"defsim view", usage, longs, ""};
    const char **sets = calloc((size_t)argc + 2, sizeof *sets);
    const char **opts = calloc((size_t)argc + 1, sizeof *opts);
    char (*made)[160] = calloc((size_t)argc + 1, sizeof *made);
    if (!sets || !opts || !made) {
        free(sets); free(opts); free(made);
        fprintf(stderr, "defsim view: out of memory\n");
        return 1;
    }
    int nsets = 0, nopts = 0, nmade = 0, paused = 0, timing = 1, width = 0, height = 0;
    int supersample = 1, threads = 0, rc = -1;
    const char *script = NULL, *color = NULL, *path = NULL;
    double k_drag = 0.0;
    cli c;
    cli_begin(&c, &tool, argc, argv);
    for (int o; rc < 0 && (o = cli_next(&c)) != CLI_END;) {
        switch (o) {
        case CLI_EXIT: rc = c.status; break;
        case O_SCRIPT: script = c.arg; break;
        case O_PAUSED: paused = 1; break;
        case O_COLOR: color = c.arg; break;
        case O_NO_TIMING: timing = 0; break;
        case O_SET: sets[nsets++] = c.arg; break;
        case O_OPTION: opts[nopts++] = c.arg; break;
        case O_SIZE:
            if (sscanf(c.arg, "%dx%d", &width, &height) != 2 || width < 64 || height < 64 ||
                width > 8192 || height > 8192)
                rc = cli_error(&c, "--size: expected WxH, 64..8192 each");
            break;
        case O_SUPERSAMPLE:
            if (!cli_int(&c, 1, 4, &supersample)) rc = c.status;
            break;
        case O_DRAG:
            if (!cli_positive(&c, &k_drag)) rc = c.status;
            break;
        case O_BACKEND:
            snprintf(made[nmade], sizeof made[nmade], "world.backend=\"%s\"", c.arg);
            sets[nsets++] = made[nmade++];
            break;
        case O_THREADS:
            if (!cli_int(&c, 0, 4096, &threads)) {
                rc = c.status;
                break;
            }
            snprintf(made[nmade], sizeof made[nmade], "world.threads=%d", threads);
            sets[nsets++] = made[nmade++];
            break;
        }
    }
    if (rc < 0 && c.optind != argc - 1)
        rc = cli_error(&c, c.optind >= argc ? "no scene file" : "one scene file at a time");
    if (rc < 0) path = argv[c.optind];
    view_scene *vs = rc < 0 ? calloc(1, sizeof *vs) : NULL;
    defsim_world *w = NULL;
    if (rc < 0 && !vs) rc = 1;
    if (rc < 0 && scene_load(&vs->s, path, sets, nsets)) {
        fprintf(stderr, "defsim view: %s\n", vs->s.error);
        free(vs);
        vs = NULL;
        rc = 1;
    }
    scene *s = vs ? &vs->s : NULL;
    if (rc < 0 && color && (s->color = scene_color_parse(color)) < 0) {
        fprintf(stderr, "defsim view: --color must be body, stress, displacement or speed\n");
        rc = 2;
    }
    if (rc < 0) {
        vs->opts = opts;
        vs->nopts = nopts;
        if (scene_build(s, &w) != DEFSIM_OK) {
            fprintf(stderr, "defsim view: %s\n", s->error);
            rc = 1;
        } else if (run_set_options("defsim view", w, opts, nopts)) {
            rc = 2;
        }
    }
    rd_body_src *bodies = rc < 0 ? calloc((size_t)s->nbodies + 1, sizeof *bodies) : NULL;
    uint8_t *pinned = rc < 0 ? calloc((size_t)s->vertex_count + 1, 1) : NULL;
    if (rc < 0 && (!bodies || !pinned)) {
        fprintf(stderr, "defsim view: out of memory\n");
        rc = 1;
    }
    if (rc < 0) {
        for (int32_t i = 0; i < s->nbodies; ++i) {
            const scene_body *b = &s->bodies[i];
            bodies[i] = (rd_body_src){b->offset,
                               /* quadratic tets: drawn by their boundary's sub-triangles,
                                  without stress colours */
                               b->mesh.tet_nodes == 10 ? NULL : b->mesh.tets,
                               b->mesh.tet_nodes == 10 ? 0 : b->mesh.tet_count, 0,
                                      b->mesh.triangles, b->mesh.triangle_count, b->mesh.springs,
                                      b->line_count, {b->color[0], b->color[1], b->color[2]}};
            for (int32_t k = 0; k < b->npins; ++k) pinned[b->offset + b->pins[k]] = 1;
            for (int32_t d = 0; d < b->ndrives; ++d)
                for (int32_t k = 0; k < b->drives[d].n; ++k)
                    pinned[b->offset + b->drives[d].verts[k]] = 1;
        }
        char title[400];
        snprintf(title, sizeof title, "defsim view: %s (%s)", s->name, s->backend);
        vw_def def = {.world = w, .bodies = bodies, .nbodies = s->nbodies, .h = s->h,
                      .frame_steps = s->frame_steps, .pinned = pinned, .camera = s->camera,
                      .s = s, .width = width ? width : s->width,
                      .height = height ? height : s->height, .supersample = supersample,
                      .color = (scene_color)s->color, .paused = paused, .timing = timing,
                      .drag_stiffness = k_drag, .script = script, .title = title,
                      .step = step_scene, .reset = reset_scene, .user = vs};
        memcpy(def.gravity, s->def.gravity, sizeof def.gravity);
        vw_result res;
        char err[1024];
        if (vw_run(&def, &res, err, sizeof err) != DEFSIM_OK) {
            fprintf(stderr, "defsim view: %s\n", err);
            rc = 1;
        } else {
            rc = res.expectations_failed > 0;
            if (script)
                printf("%s: %lld steps, t = %.6g s; %d expectations, %d failed\n", script,
                       (long long)res.steps, defsim_world_time(res.world), res.expectations,
                       res.expectations_failed);
        }
        w = res.world;
    }
    defsim_world_destroy(w);
    if (vs) scene_free(&vs->s);
    free(vs);
    free(bodies);
    free(pinned);
    free(sets);
    free(opts);
    free(made);
    return rc;
}
