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

static int usage(FILE *f)
{
    fprintf(f, "usage: defsim-render SCENE.json [defsim run options]\n"
               "       defsim-render RUN.pvd|FRAME.vtu... [--scene SCENE.json] [--out DIR] "
               "[--frames LIST] [--color body|stress|displacement|speed] [--contact-forces]\n");
    return f == stderr ? 2 : 0;
}

/* Render parts for one frame's cells: tet boundaries, triangles, lines, per body; with
 * tri_cell, each part's triangles' cells (tet boundaries: the tet's cell) for stress colours. */
static int parts_from_cells(const vtk_cells *c, const scene *s, rd_part **out, int *nout,
                            int32_t ***tri_cell)
{
    int32_t nb = 0;
    for (int64_t i = 0; i < c->ncells; ++i) if (c->body[i] + 1 > nb) nb = c->body[i] + 1;
    rd_part *p = calloc((size_t)(nb > 0 ? nb : 1), sizeof *p);
    int32_t **tc = calloc((size_t)(nb > 0 ? nb : 1), sizeof *tc);
    if (!p || !tc) return -1;
    *out = p;
    *nout = nb;
    *tri_cell = tc;
    for (int32_t b = 0; b < nb; ++b) {
        int64_t nt = 0, ntri = 0, nl = 0;
        for (int64_t i = 0; i < c->ncells; ++i)
            if (c->body[i] == b) {
                nt += c->types[i] == VTK_TETRA;
                ntri += c->types[i] == VTK_TRIANGLE;
                nl += c->types[i] == VTK_LINE;
            }
        int64_t *tets = malloc((size_t)(nt + 1) * 4 * sizeof *tets);
        int32_t *tris = malloc((size_t)(ntri + 1) * 3 * sizeof *tris);
        int32_t *lines = malloc((size_t)(nl + 1) * 2 * sizeof *lines);
        int32_t *cell = malloc((size_t)(nt + ntri + 1) * sizeof *cell);
        if (!tets || !tris || !lines || !cell) return -1;
        int64_t kt = 0, ktri = 0, kl = 0;
        for (int64_t i = 0; i < c->ncells; ++i) {
            if (c->body[i] != b) continue;
            const int64_t *q = c->conn + (i ? c->offsets[i - 1] : 0);
            if (c->types[i] == VTK_TETRA) for (int a = 0; a < 4; ++a) tets[4 * kt + a] = q[a];
            if (c->types[i] == VTK_TRIANGLE) for (int a = 0; a < 3; ++a) tris[3 * ktri + a] = (int32_t)q[a];
            if (c->types[i] == VTK_TETRA) cell[kt] = (int32_t)i;
            if (c->types[i] == VTK_TRIANGLE) cell[ktri] = (int32_t)i;
            if (c->types[i] == VTK_LINE) for (int a = 0; a < 2; ++a) lines[2 * kl + a] = (int32_t)q[a];
            kt += c->types[i] == VTK_TETRA;
            ktri += c->types[i] == VTK_TRIANGLE;
            kl += c->types[i] == VTK_LINE;
        }
        if (nt > 0) {
            free(tris);
            int32_t n = 0;
            tris = rd_tet_surface(tets, nt, &n);
            if (!tris) return -1;
            ntri = n;
            /* The surface's triangles, mapped to their tets' cells. */
            int32_t *t32 = malloc((size_t)(4 * nt + 1) * sizeof *t32), *of = malloc((size_t)(n + 1) * sizeof *of);
            if (!t32 || !of) return -1;
            for (int64_t k = 0; k < 4 * nt; ++k) t32[k] = (int32_t)tets[k];
            if (rd_triangle_tets(t32, nt, tris, n, of)) return -1;
            for (int32_t k = 0; k < n; ++k) of[k] = of[k] >= 0 ? cell[of[k]] : -1;
            free(t32);
            free(cell);
            cell = of;
        }
        free(tets);
        tc[b] = cell;
        p[b].tris = tris;
        p[b].ntris = (int32_t)ntri;
        p[b].lines = lines;
        p[b].nlines = (int32_t)nl;
        p[b].smooth = nt == 0;
        if (s && b < s->nbodies) memcpy(p[b].color, s->bodies[b].color, sizeof p[b].color);
        else scene_palette(b, p[b].color);
    }
    return 0;
}

static void parts_free(rd_part *p, int n, int32_t **tri_cell)
{
    for (int i = 0; p && i < n; ++i) {
        free((void *)p[i].tris);
        free((void *)p[i].lines);
        if (tri_cell) free(tri_cell[i]);
    }
    free(p);
    free(tri_cell);
}

int main(int argc, char **argv)
{
    if (argc < 2) return usage(stderr);
    if (!strcmp(argv[1], "-h") || !strcmp(argv[1], "--help")) return usage(stdout);
    if (ends_with(argv[1], ".json")) {
        /* Render while running: defsim run with PNG output and no VTK. */
        char **args = calloc((size_t)argc + 3, sizeof *args);
        if (!args) return 1;
        int n = 0;
        for (int i = 1; i < argc; ++i) args[n++] = argv[i];
        args[n++] = "--render";
        args[n++] = "--no-vtk";
        int rc = run_main(n, args);
        free(args);
        return rc;
    }
    const char *scene_path = NULL, *out_dir = NULL, *color = NULL;
    int arrows = 0;
    char **inputs = calloc((size_t)argc, sizeof *inputs);
    int ninputs = 0, *list = calloc((size_t)argc, sizeof *list), nlist = 0;
    if (!inputs || !list) return 1;
    for (int i = 1; i < argc; ++i) {
        if (!strcmp(argv[i], "--scene") && i + 1 < argc) scene_path = argv[++i];
        else if (!strcmp(argv[i], "--out") && i + 1 < argc) out_dir = argv[++i];
        else if (!strcmp(argv[i], "--color") && i + 1 < argc) color = argv[++i];
        else if (!strcmp(argv[i], "--contact-forces")) arrows = 1;
        else if (!strcmp(argv[i], "--frames") && i + 1 < argc) {
            for (char *s = argv[++i], *end;; s = end + 1) {
                list[nlist++] = (int)strtol(s, &end, 10);
                if (end == s || (*end && *end != ',')) return usage(stderr);
                if (!*end) break;
            }
        } else if (argv[i][0] == '-') return usage(stderr);
        else inputs[ninputs++] = argv[i];
    }
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
    rd_part *parts = NULL;
    int32_t **tri_cell = NULL;
    int np = 0, rc = 0;
    double lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
    double top = 0.0, force_max = 0.0;
    for (int i = 0; i < nfiles && rc == 0; ++i) {
        vtk_frame fr;
        if (vtk_read_vtu(files[i], &fr, err, sizeof err)) {
            fprintf(stderr, "defsim-render: %s\n", err);
            rc = 1;
            break;
        }
        if (!parts && parts_from_cells(&fr.cells, have_scene ? &s : NULL, &parts, &np, &tri_cell)) {
            fprintf(stderr, "defsim-render: out of memory\n");
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
            top = fmax(top, rd_color_top((scene_color)s.color, parts, np, tri_cell, fr.von_mises,
                                         vec, fr.nv));
            for (int32_t k = 0; k < fr.nv; ++k)
                for (int c = 0; c < 3; ++c) {
                    lo[c] = fmin(lo[c], fr.x[3 * k + c]);
                    hi[c] = fmax(hi[c], fr.x[3 * k + c]);
                }
        }
        vtk_frame_free(&fr);
    }
    if (rc) {
        parts_free(parts, np, tri_cell);
        return rc;
    }
    rd_view view;
    rd_view_make(&s.camera, lo, hi, s.def.gravity, (double)s.width / s.height, &view);
    const double arrow_scale = rd_arrow_scale(s.arrow_scale, force_max, lo, hi);
    rd_renderer *rd = rd_create(s.width, s.height, s.supersample, err, sizeof err);
    if (!rd) { fprintf(stderr, "defsim-render: %s\n", err); return 1; }
    image img = {s.width, s.height, malloc((size_t)s.width * s.height * 3)};
    image thumbs[12];
    double tt[12];
    int nthumbs = 0;
    rd_overlay overlay;
    memset(&overlay, 0, sizeof overlay);
    float **trgb = calloc((size_t)np + 1, sizeof *trgb);
    float *vrgb = NULL;
    for (int k = 0; trgb && k < np; ++k)
        if (!(trgb[k] = malloc(3 * (size_t)(parts[k].ntris + 1) * sizeof **trgb))) rc = 1;
    if (!trgb || !img.rgb) rc = 1;
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
        double range[2] = {0.0, 0.0};
        float *nv_rgb = realloc(vrgb, 3 * (size_t)fr.nv * sizeof *vrgb + 1);
        int bad = !nv_rgb;
        if (nv_rgb) vrgb = nv_rgb;
        if (!bad)
            rd_color_parts((scene_color)s.color, &s, parts, np, tri_cell, fr.von_mises,
                           s.color == SCENE_COLOR_SPEED ? fr.velocity : fr.displacement, fr.nv,
                           top, vrgb, trgb, range);
        /* Pinned vertices (the frames' "pinned" array) as markers, and with --scene the
         * scene's colliders at their poses of the frame's time (the first plane carries the
         * ground grid). */
        static const float marker_rgb[3] = {0.8f, 0.12f, 0.08f};
        static const float collider_rgb[3] = {0.6f, 0.6f, 0.64f};
        rd_view fview = view;
        rd_part *all = NULL;
        if (!bad)
            bad = rd_overlay_begin(&overlay, fr.x, fr.nv) ||
                  rd_overlay_markers(&overlay, fr.pinned, 2.5 * view.line_radius, marker_rgb) ||
                  (s.contact_arrows &&
                   rd_overlay_arrows(&overlay, fr.contact_force, arrow_scale, force_max,
                                     0.8 * view.line_radius));
        for (int32_t k = 0, ground = -1; have_scene && !bad && k < s.ncolliders; ++k) {
            defsim_collider_def c = s.colliders[k].def;
            if (s.colliders[k].nkeys > 0)
                scene_collider_pose(&s.colliders[k], fr.time, c.position, c.rotation);
            if (ground < 0 && rd_view_ground_plane(&fview, &c)) ground = k;
            bad = rd_overlay_collider(&overlay, &c, &fview, ground == k, collider_rgb);
        }
        if (!bad) bad = !(all = malloc((size_t)(np + overlay.nparts + 1) * sizeof *all));
        if (bad) snprintf(err, sizeof err, "out of memory");
        if (!bad) {
            memcpy(all, parts, (size_t)np * sizeof *all);
            memcpy(all + np, overlay.parts, (size_t)overlay.nparts * sizeof *all);
            bad = rd_render(rd, &fview, overlay.x, all, np + overlay.nparts, img.rgb, err,
                            sizeof err);
        }
        free(all);
        if (!bad) {
            rd_colorbar(img.rgb, s.width, s.height, (scene_color)s.color, range[0], range[1]);
            rd_timestamp(img.rgb, s.width, s.height, fr.time);
        }
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
    for (int k = 0; trgb && k < np; ++k) free(trgb[k]);
    free(trgb);
    free(vrgb);
    rd_overlay_free(&overlay);
    parts_free(parts, np, tri_cell);
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
