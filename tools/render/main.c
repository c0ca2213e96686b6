/* SPDX-License-Identifier: MIT */
/*
 * defsim-render: PNG frames of a simulation.
 *
 *   defsim-render SCENE.json [defsim run options]
 *       runs the scene and renders while running (same as defsim run --render --no-vtk)
 *   defsim-render RUN.pvd | FRAME.vtu ... [--scene SCENE.json] [--out DIR] [--frames LIST]
 *                 [--color body|stress|displacement|speed] [--contact-forces]
 *       renders frames written by defsim run (--contact-forces: their contact_force arrays as
 *       arrows, as output.contact_arrows does); size, colours and camera settings come from the
 *       scene when given; the camera and ground are fitted to the bodies over all frames, and
 *       the colour scale to the largest value over all frames
 */
#include "image.h"
#include "render.h"
#include "../defsim/run.h"
#include "../cli.h"
#include "../fileio.h"
#include "../scene.h"
#include "../vtk.h"

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static int ends_with(const char *s, const char *t)
{
    size_t n = strlen(s), k = strlen(t);
    return n >= k && !strcmp(s + n - k, t);
}

static void usage(FILE *f)
{
    fprintf(f, "usage: defsim-render SCENE.json [defsim run options]\n"
               "       defsim-render RUN.pvd|FRAME.vtu... [--scene SCENE.json] [--out DIR]\n"
               "                     [--frames LIST] [--color body|stress|displacement|speed]\n"
               "                     [--contact-forces]\n"
               "With a scene: runs it and renders while running (defsim run --render --no-vtk;\n"
               "defsim-render SCENE.json --help lists those options). With frames written by\n"
               "defsim run: renders them.\n"
               "  --scene FILE   camera, size, colours and output.color from this scene\n"
               "  --out DIR      where the PNGs go (default: next to the frames)\n"
               "  --frames LIST  render only these frames (comma-separated indices)\n"
               "  --color MODE   body, stress (von Mises), displacement or speed\n"
               "  --contact-forces  draw the frames' contact_force as arrows\n"
               "  -h, --help     this text\n"
               "  --version      the library's version\n");
}

int main(int argc, char **argv)
{
    if (argc >= 2 && ends_with(argv[1], ".json")) {
        /* Render while running: defsim run with PNG output and no VTK (the tool's own
         * options first, so that an option of the user's that lacks its value is reported, not
         * given one of ours). */
        char **args = calloc((size_t)argc + 3, sizeof *args);
        if (!args) return 1;
        int n = 0;
        args[n++] = "defsim-render";
        args[n++] = "--render";
        args[n++] = "--no-vtk";
        for (int i = 1; i < argc; ++i) args[n++] = argv[i];
        int rc = run_main(n, args);
        free(args);
        return rc;
    }
    const char *scene_path = NULL, *out_dir = NULL, *color = NULL;
    /* --frames lists at most one number per two characters of the arguments. */
    size_t chars = 0;
    for (int i = 0; i < argc; ++i) chars += strlen(argv[i]) + 1;
    int arrows = 0;
    char **inputs = calloc((size_t)argc, sizeof *inputs);
    int ninputs = 0, *list = calloc(chars / 2 + 1, sizeof *list), nlist = 0;
    if (!inputs || !list) return 1;
    const char *frames_arg = NULL;
    static const cli_tool tool = {"defsim-render", usage, NULL, ""};
    const cli_opt opts[] = {{"scene", CLI_STRING, &scene_path, 0, 0}, {"out", CLI_STRING, &out_dir, 0, 0},
                            {"color", CLI_STRING, &color, 0, 0}, {"frames", CLI_STRING, &frames_arg, 0, 0},
                            {"contact-forces", CLI_FLAG, &arrows, 0, 0},
                            {0}};
    int first;
    const int parsed = cli_parse(&tool, opts, argc, argv, &first);
    if (parsed >= 0) return parsed;
    for (const char *s = frames_arg; s;) {
        char *end;
        const long v = strtol(s, &end, 10);
        if (end == s || v < 0 || v > 1000000000 || (*end && *end != ','))
            return cli_fail(&tool, "--frames: comma-separated frame numbers (got %s)", frames_arg);
        list[nlist++] = (int)v;
        s = *end ? end + 1 : NULL;
    }
    for (int i = first; i < argc; ++i) inputs[ninputs++] = argv[i];
    /* The frame files and their times. */
    char **files = NULL;
    double *times = NULL;
    int nfiles = 0;
    char err[1024], dir[2048] = ".";
    if (ninputs == 1 && ends_with(inputs[0], ".pvd")) {
        nfiles = vtk_read_pvd(inputs[0], &files, &times, err, sizeof err);
        if (nfiles < 0) { fprintf(stderr, "defsim-render: %s\n", err); return 1; }
        const char *slash = strrchr(inputs[0], '/');
        if (slash) snprintf(dir, sizeof dir, "%.*s", (int)(slash - inputs[0]), inputs[0]);
        for (int i = 0; i < nfiles; ++i) {
            char *full = malloc(strlen(dir) + strlen(files[i]) + 2);
            if (!full) return 1;
            sprintf(full, "%s/%s", dir, files[i]);
            free(files[i]);
            files[i] = full;
        }
    } else {
        files = calloc((size_t)ninputs + 1, sizeof *files);
        times = calloc((size_t)ninputs + 1, sizeof *times);
        for (int i = 0; i < ninputs; ++i) files[nfiles++] = strdup(inputs[i]);
        if (ninputs > 0) {
            const char *slash = strrchr(inputs[0], '/');
            if (slash) snprintf(dir, sizeof dir, "%.*s", (int)(slash - inputs[0]), inputs[0]);
        }
    }
    if (nfiles == 0) {
        fprintf(stderr, "defsim-render: no frames to render\n");
        return 2;
    }
    scene s;
    int have_scene = 0;
    if (scene_path) {
        if (scene_load(&s, scene_path, NULL, 0)) {
            fprintf(stderr, "defsim-render: %s\n", s.error);
            return 1;
        }
        have_scene = 1;
    } else {
        memset(&s, 0, sizeof s);
        s.width = 640;
        s.height = 400;
        s.supersample = 2;
        s.camera.automatic = 1;
        s.camera.fov = 35.0;
        s.camera.azimuth = 35.0;
        s.camera.elevation = 20.0;
        s.camera.zoom = 1.0;
        s.camera.ground = 1;
        s.def.gravity[1] = -9.81;
    }
    if (color && (s.color = scene_color_parse(color)) < 0) {
        fprintf(stderr, "defsim-render: --color must be body, stress, displacement or speed\n");
        return 2;
    }
    if (arrows) s.contact_arrows = 1;
    const char *od = out_dir ? out_dir : dir;
    if (tools_make_dirs(od)) {
        fprintf(stderr, "defsim-render: cannot create the output folder %s: %s\n", od,
                strerror(errno));
        return 1;
    }
    /* First pass: the bounds of the whole motion (camera and ground) and the largest value of
     * the colour field over every frame (one scale for all), with the parts of the first
     * frame (the cells do not change between frames). */
    rd_bodies bodies;
    memset(&bodies, 0, sizeof bodies);
    int have_bodies = 0, rc = 0;
    double lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
    double top = 0.0, force_max = 0.0;
    for (int i = 0; i < nfiles && rc == 0; ++i) {
        vtk_frame fr;
        if (vtk_read_vtu(files[i], &fr, err, sizeof err)) {
            fprintf(stderr, "defsim-render: %s\n", err);
            rc = 1;
            break;
        }
        if (!have_bodies) {
            if (rd_bodies_from_cells(&bodies, &fr.cells, have_scene ? &s : NULL, fr.nv)) {
                fprintf(stderr, "defsim-render: out of memory\n");
                rc = 1;
            }
            have_bodies = 1;
        }
        if (rc == 0 && fr.nv != bodies.nv) {
            fprintf(stderr, "defsim-render: %s: %d vertices, the first frame has %d\n", files[i],
                    (int)fr.nv, (int)bodies.nv);
            rc = 1;
        }
        const double *vec = s.color == SCENE_COLOR_SPEED ? fr.velocity : fr.displacement;
        if (rc == 0 && s.color != SCENE_COLOR_BODY &&
            !(s.color == SCENE_COLOR_STRESS ? fr.von_mises != NULL : vec != NULL)) {
            fprintf(stderr, "defsim-render: %s: no %s array to colour by (written by defsim run "
                    "with output.fields)\n", files[i],
                    s.color == SCENE_COLOR_STRESS ? "von_mises"
                    : s.color == SCENE_COLOR_SPEED ? "velocity" : "displacement");
            rc = 1;
        }
        if (rc == 0 && s.contact_arrows && !fr.contact_force) {
            fprintf(stderr, "defsim-render: %s: no contact_force array to draw (written by "
                    "defsim run for scenes with colliders or body contact)\n", files[i]);
            rc = 1;
        }
        if (rc == 0) {
            force_max = fmax(force_max, rd_force_max(fr.contact_force, fr.nv));
            top = fmax(top, rd_color_top((scene_color)s.color, bodies.parts, bodies.nparts,
                                         bodies.tri_cell, fr.von_mises, vec, fr.nv));
            for (int32_t k = 0; k < fr.nv; ++k)
                for (int c = 0; c < 3; ++c) {
                    lo[c] = fmin(lo[c], fr.x[3 * k + c]);
                    hi[c] = fmax(hi[c], fr.x[3 * k + c]);
                }
        }
        vtk_frame_free(&fr);
    }
    if (rc) {
        rd_bodies_free(&bodies);
        return rc;
    }
    rd_view view;
    rd_view_make(&s.camera, lo, hi, s.def.gravity, (double)s.width / s.height, &view);
    const double arrow_scale = rd_arrow_scale(s.arrow_scale, force_max, lo, hi);
    rd_renderer *rd = rd_create(s.width, s.height, s.supersample, err, sizeof err);
    if (!rd) {
        fprintf(stderr, "defsim-render: %s\n", err);
        rd_bodies_free(&bodies);
        return 1;
    }
    image img = {s.width, s.height, malloc((size_t)s.width * s.height * 3)};
    image thumbs[12];
    double tt[12];
    int nthumbs = 0;
    rd_overlay overlay;
    memset(&overlay, 0, sizeof overlay);
    if (!img.rgb) rc = 1;
    for (int i = 0; i < nfiles && rc == 0; ++i) {
        const char *base = strrchr(files[i], '/');
        base = base ? base + 1 : files[i];
        int fnum = -1;
        if (sscanf(base, "frame_%d.vtu", &fnum) != 1) fnum = -1;
        int want = nlist == 0;
        for (int k = 0; k < nlist; ++k) want |= list[k] == fnum;
        if (!want) continue;
        vtk_frame fr;
        if (vtk_read_vtu(files[i], &fr, err, sizeof err)) {
            fprintf(stderr, "defsim-render: %s\n", err);
            rc = 1;
            break;
        }
        char path[4200];
        snprintf(path, sizeof path, "%s/%.*s.png", od, (int)(strlen(base) - 4), base);
        int bad = fr.nv != bodies.nv;
        if (bad) snprintf(err, sizeof err, "%d vertices, the first frame has %d", (int)fr.nv,
                          (int)bodies.nv);
        /* Pinned vertices (the frames' "pinned" array) as markers, the contact arrows, and
         * with --scene the scene's colliders at their poses of the frame's time. */
        defsim_collider_def *cols = have_scene && s.ncolliders > 0
                                        ? malloc((size_t)s.ncolliders * sizeof *cols) : NULL;
        if (!bad && have_scene && s.ncolliders > 0 && !cols) {
            snprintf(err, sizeof err, "out of memory");
            bad = 1;
        }
        for (int32_t k = 0; cols && k < s.ncolliders; ++k) {
            cols[k] = s.colliders[k].def;
            if (s.colliders[k].nkeys > 0)
                scene_collider_pose(&s.colliders[k], fr.time, cols[k].position, cols[k].rotation);
        }
        const rd_frame_data d = {
            .mode = (scene_color)s.color, .s = &s, .top = top,
            .vec = s.color == SCENE_COLOR_SPEED ? fr.velocity : fr.displacement,
            .cell = fr.von_mises, .pinned = fr.pinned, .ncolliders = cols ? s.ncolliders : 0,
            .colliders = cols, .time = fr.time, .force = s.contact_arrows ? fr.contact_force : NULL,
            .arrow_scale = arrow_scale, .force_max = force_max};
        if (!bad)
            bad = rd_draw_frame(rd, &bodies, &overlay, &view, NULL, fr.x, &d, img.rgb, err,
                                sizeof err);
        free(cols);
        if (bad || image_write_png(path, &img, err, sizeof err)) {
            fprintf(stderr, "defsim-render: %s: %s\n", files[i], err);
            rc = 1;
        } else {
            printf("%s\n", path);
            if (nthumbs < 12 && image_downscale(&img, 2, &thumbs[nthumbs]) == 0)
                tt[nthumbs++] = fr.time;
        }
        vtk_frame_free(&fr);
    }
    rd_overlay_free(&overlay);
    rd_bodies_free(&bodies);
    if (rc == 0 && nthumbs > 1) {
        char path[4200];
        snprintf(path, sizeof path, "%s/contact_sheet.png", od);
        if (image_write_contact_sheet(path, thumbs, tt, nthumbs, 4, err, sizeof err)) {
            fprintf(stderr, "defsim-render: contact sheet: %s\n", err);
            rc = 1;
        }
    }
    for (int k = 0; k < nthumbs; ++k) image_free(&thumbs[k]);
    for (int i = 0; i < nfiles; ++i) free(files[i]);
    free(files);
    free(times);
    free(inputs);
    free(list);
    image_free(&img);
    rd_destroy(rd);
    if (have_scene) scene_free(&s);
    return rc;
}
