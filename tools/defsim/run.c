/* SPDX-License-Identifier: MIT */
/*
 * `defsim run SCENE.json`: runs a scene, shows progress, writes VTK frames (.vtu + .pvd), an
 * energy log and the final state, and with --render PNG frames and a contact sheet.
 * Ctrl-C stops after the current frame; everything written so far stays valid.
 */
#include "run.h"

#include "clock.h"

#include "fields.h"
#include "scene.h"
#include "vtk.h"
#ifdef DEFSIM_HAVE_RENDER
#include "render/image.h"
#include "render/render.h"
#endif

#include "fileio.h"

#include <errno.h>
#include <math.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <time.h>
#include <unistd.h>

static volatile sig_atomic_t interrupted;

static void on_sigint(int sig)
{
    (void)sig;
    interrupted = 1;
}

static int usage(FILE *f)
{
    fprintf(f,
        "usage: defsim run SCENE.json [options]\n"
        "  --out DIR          output folder (default: the scene's name)\n"
        "  --render           also write PNG frames and a contact sheet (needs OSMesa)\n"
        "  --no-vtk           do not write .vtu/.pvd frames\n"
        "  --frames LIST      write only these frames (comma-separated numbers, 0 = start)\n"
        "  --backend NAME     override world.backend\n"
        "  --threads N        override world.threads\n"
        "  --color MODE       colour rendered bodies by body (default), stress (von Mises) or\n"
        "                     displacement, with a colour bar (= --set output.color=MODE)\n"
        "  --set KEY=VALUE    override any scene value (e.g. world.gravity=[0,9.81,0],\n"
        "                     bodies.0.material.youngs_modulus=1e4); repeatable\n"
        "  --progress MODE    auto (bar on a terminal, lines otherwise), bar, lines, none\n"
        "  -h, --help         this text\n");
    return f == stderr ? 2 : 0;
}

/* Frames to write: every n-th and the last, or an explicit list. */
static int wanted(int f, int frames, int every, const int *list, int nlist)
{
    if (nlist > 0) {
        for (int i = 0; i < nlist; ++i)
            if (list[i] == f) return 1;
        return 0;
    }
    return f % every == 0 || f == frames;
}

typedef struct out_state {
    char **files;
    double *times;
    int n, cap;
} out_state;

static int pvd_add(out_state *o, const char *file, double t)
{
    if (o->n == o->cap) {
        int cap = o->cap ? 2 * o->cap : 64;
        char **f = realloc(o->files, (size_t)cap * sizeof *f);
        if (!f) return -1;
        o->files = f;
        double *tt = realloc(o->times, (size_t)cap * sizeof *tt);
        if (!tt) return -1;
        o->times = tt;
        o->cap = cap;
    }
    o->files[o->n] = strdup(file);
    o->times[o->n++] = t;
    return 0;
}

int run_main(int argc, char **argv)
{
    const char *scene_path = NULL, *out_dir = NULL, *progress = "auto";
    int render = 0, vtk = 1;
    const char **sets = calloc((size_t)argc + 4, sizeof *sets);
    int nsets = 0, *list = calloc((size_t)argc + 1, sizeof *list), nlist = 0;
    char backend_set[128], threads_set[64], color_set[128];
    if (!sets || !list) return 1;
    for (int i = 0; i < argc; ++i) {
        const char *a = argv[i];
        const int has = i + 1 < argc;
        if (!strcmp(a, "-h") || !strcmp(a, "--help")) return usage(stdout);
        else if (!strcmp(a, "--out") && has) out_dir = argv[++i];
        else if (!strcmp(a, "--render")) render = 1;
        else if (!strcmp(a, "--no-vtk")) vtk = 0;
        else if (!strcmp(a, "--progress") && has) progress = argv[++i];
        else if (!strcmp(a, "--set") && has) sets[nsets++] = argv[++i];
        else if (!strcmp(a, "--backend") && has) {
            snprintf(backend_set, sizeof backend_set, "world.backend=\"%s\"", argv[++i]);
            sets[nsets++] = backend_set;
        } else if (!strcmp(a, "--color") && has) {
            snprintf(color_set, sizeof color_set, "output.color=\"%s\"", argv[++i]);
            sets[nsets++] = color_set;
        } else if (!strcmp(a, "--threads") && has) {
            snprintf(threads_set, sizeof threads_set, "world.threads=%s", argv[++i]);
            sets[nsets++] = threads_set;
        } else if (!strcmp(a, "--frames") && has) {
            char *s = argv[++i], *end;
            for (;;) {
                long v = strtol(s, &end, 10);
                if (end == s || v < 0 || v > 1000000000) {
                    fprintf(stderr, "defsim run: --frames: expected comma-separated frame numbers\n");
                    return 2;
                }
                list[nlist++] = (int)v;
                if (*end != ',') break;
                s = end + 1;
            }
            if (*end) {
                fprintf(stderr, "defsim run: --frames: expected comma-separated frame numbers\n");
                return 2;
            }
        } else if (a[0] == '-') {
            fprintf(stderr, "defsim run: unknown option %s\n", a);
            return usage(stderr);
        } else if (!scene_path) scene_path = a;
        else {
            fprintf(stderr, "defsim run: one scene file at a time (got %s and %s)\n", scene_path, a);
            return 2;
        }
    }
    if (!scene_path) return usage(stderr);
    int mode = 0;   /* 0 none, 1 lines, 2 bar */
    if (!strcmp(progress, "auto")) mode = isatty(STDOUT_FILENO) ? 2 : 1;
    else if (!strcmp(progress, "bar")) mode = 2;
    else if (!strcmp(progress, "lines")) mode = 1;
    else if (strcmp(progress, "none")) {
        fprintf(stderr, "defsim run: --progress must be auto, bar, lines or none\n");
        return 2;
    }

    scene s;
    if (scene_load(&s, scene_path, sets, nsets)) {
        fprintf(stderr, "defsim run: %s\n", s.error);
        return 1;
    }
    free(sets);
    if (render) s.write_png = 1;
    if (!vtk) s.write_vtk = 0;
    for (int i = 0; i < nlist; ++i)
        if (list[i] > s.frames) {
            fprintf(stderr, "defsim run: --frames: frame %d is past the last frame (%d)\n",
                    list[i], (int)s.frames);
            scene_free(&s);
            return 2;
        }
#ifndef DEFSIM_HAVE_RENDER
    if (s.write_png) {
        fprintf(stderr, "defsim run: PNG output needs the OSMesa renderer, and this build has "
                        "none (configure with -DDEFSIM_WITH_OSMESA=ON and libosmesa6-dev)\n");
        scene_free(&s);
        return 1;
    }
#endif
    defsim_world *w = NULL;
    if (scene_build(&s, &w) != DEFSIM_OK) {
        fprintf(stderr, "defsim run: %s\n", s.error);
        scene_free(&s);
        return 1;
    }
    char dir[2048];
    snprintf(dir, sizeof dir, "%s", out_dir ? out_dir : s.name);
    if (tools_make_dirs(dir)) {
        fprintf(stderr, "defsim run: cannot create the output folder %s: %s\n", dir, strerror(errno));
        defsim_world_destroy(w);
        scene_free(&s);
        return 1;
    }
    int rc = 0;
    const int32_t nv = defsim_world_vertex_count(w);
    double *x = malloc(3 * (size_t)nv * sizeof *x), *v = malloc(3 * (size_t)nv * sizeof *v);
    vtk_cells cells = {0};
    out_state pvd = {0};
    char err[1024], path[4200], pvd_path[4200];
    snprintf(pvd_path, sizeof pvd_path, "%s/%s.pvd", dir, s.name);
    for (int32_t i = 0; i < s.nbodies; ++i) {
        const scene_body *b = &s.bodies[i];
        int bad = 0;
        if (b->mesh.tet_count > 0)
            bad = vtk_cells_add(&cells, b->mesh.tets, b->mesh.tet_count, 4, b->offset, VTK_TETRA, i);
        else if (b->mesh.triangle_count > 0)
            bad = vtk_cells_add(&cells, b->mesh.triangles, b->mesh.triangle_count, 3, b->offset,
                                VTK_TRIANGLE, i);
        else
            bad = vtk_cells_add(&cells, b->mesh.springs, b->line_count, 2, b->offset, VTK_LINE, i);
        if (bad) { fprintf(stderr, "defsim run: out of memory\n"); return 1; }
    }
    /* Stress, displacement, pin and attachment forces: written into the VTK frames, and what
     * the renderer colours by. */
    fields fl;
    const unsigned need =
        (s.write_vtk ? s.fields : 0u) |
        (s.write_png && s.color == SCENE_COLOR_STRESS ? (unsigned)SCENE_FIELD_STRESS : 0u) |
        (s.write_png && s.color == SCENE_COLOR_DISPLACEMENT ? (unsigned)SCENE_FIELD_DISPLACEMENT : 0u);
    if (fields_init(&fl, &s, w, need, err, sizeof err)) {
        fprintf(stderr, "defsim run: %s\n", err);
        return 1;
    }
    snprintf(path, sizeof path, "%s/energy.csv", dir);
    FILE *csv = fopen(path, "w");
    if (!x || !v || !csv) {
        fprintf(stderr, "defsim run: cannot write %s\n", path);
        return 1;
    }
    fprintf(csv, "frame,time,kinetic,elastic,gravitational,total");
    for (int32_t i = 0; i < s.nbodies; ++i)
        if (s.bodies[i].probe >= 0) fprintf(csv, ",probe%d_x,probe%d_y,probe%d_z", i, i, i);
    fprintf(csv, "\n");

#ifdef DEFSIM_HAVE_RENDER
    rd_renderer *rd = NULL;
    rd_view view;
    rd_part *parts = NULL;
    int32_t **tri_cell = NULL;
    float **tri_rgb = NULL, *vertex_rgb = NULL;
    image frame_img = {0, 0, NULL};
    enum { SHEET_MAX = 12 };
    image thumbs[SHEET_MAX];
    double thumb_t[SHEET_MAX];
    int nthumbs = 0, sheet_frames[SHEET_MAX], nsheet = 0;
    if (s.write_png) {
        rd = rd_create(s.width, s.height, s.supersample, err, sizeof err);
        parts = calloc((size_t)s.nbodies, sizeof *parts);
        tri_cell = calloc((size_t)s.nbodies, sizeof *tri_cell);
        tri_rgb = calloc((size_t)s.nbodies, sizeof *tri_rgb);
        vertex_rgb = malloc(3 * (size_t)nv * sizeof *vertex_rgb + 1);
        if (!tri_cell || !tri_rgb || !vertex_rgb) return 1;
        frame_img.width = s.width;
        frame_img.height = s.height;
        frame_img.rgb = malloc((size_t)s.width * s.height * 3);
        if (!rd || !parts || !frame_img.rgb) {
            fprintf(stderr, "defsim run: renderer: %s\n", rd ? "out of memory" : err);
            return 1;
        }
        double lo[3], hi[3];
        scene_bounds(&s, lo, hi);
        rd_view_make(&s.camera, lo, hi, s.def.gravity, (double)s.width / s.height, &view);
        for (int32_t i = 0; i < s.nbodies; ++i) {
            const scene_body *b = &s.bodies[i];
            int32_t *tris = malloc(3 * (size_t)(b->mesh.triangle_count + 1) * sizeof *tris);
            int32_t *lines = malloc(2 * (size_t)(b->line_count + 1) * sizeof *lines);
            if (!tris || !lines) return 1;
            for (int64_t k = 0; k < 3 * (int64_t)b->mesh.triangle_count; ++k)
                tris[k] = b->mesh.triangles[k] + b->offset;
            for (int64_t k = 0; k < 2 * (int64_t)b->line_count; ++k)
                lines[k] = b->mesh.springs[k] + b->offset;
            parts[i].tris = tris;
            parts[i].ntris = b->mesh.triangle_count;
            parts[i].lines = lines;
            parts[i].nlines = b->line_count;
            memcpy(parts[i].color, b->color, sizeof parts[i].color);
            parts[i].smooth = b->mesh.tet_count == 0;
            /* Stress colours: each boundary triangle takes its tet's cell. */
            if (s.color == SCENE_COLOR_STRESS && b->mesh.tet_count > 0) {
                tri_cell[i] = malloc((size_t)(b->mesh.triangle_count + 1) * sizeof **tri_cell);
                tri_rgb[i] = malloc(3 * (size_t)(b->mesh.triangle_count + 1) * sizeof **tri_rgb);
                if (!tri_cell[i] || !tri_rgb[i] ||
                    rd_triangle_tets(b->mesh.tets, b->mesh.tet_count, b->mesh.triangles,
                                     b->mesh.triangle_count, tri_cell[i]))
                    return 1;
                for (int32_t t = 0; t < b->mesh.triangle_count; ++t)
                    if (tri_cell[i][t] >= 0) tri_cell[i][t] += (int32_t)fl.cell_offset[i];
            }
        }
        /* Contact sheet: up to 12 of the written frames, evenly spread. */
        int written[4096], nw = 0;
        for (int f = 0; f <= s.frames && nw < 4096; ++f)
            if (f == 0 ? (nlist == 0 || wanted(0, s.frames, s.every, list, nlist))
                       : wanted(f, s.frames, s.every, list, nlist))
                written[nw++] = f;
        if (nw > 1 && s.contact_sheet) {
            nsheet = nw < SHEET_MAX ? nw : SHEET_MAX;
            for (int k = 0; k < nsheet; ++k)
                sheet_frames[k] = written[(int)lround((double)k * (nw - 1) / (nsheet - 1))];
        }
    }
#endif

    struct sigaction sa, old_sa;
    memset(&sa, 0, sizeof sa);
    sa.sa_handler = on_sigint;
    sigemptyset(&sa.sa_mask);
    sigaction(SIGINT, &sa, &old_sa);
    interrupted = 0;

    const double h = s.h, t_start = tools_now();
    double t_out = 0.0, t_render = 0.0, last_bar = -1.0, e0 = 0.0;
    int64_t steps = 0;
    int last_frame = 0;
    defsim_energy e = {0};
    if (mode == 1 || mode == 2)
        printf("%s: %d bodies, %d vertices, backend %s, h = %g s, %d frames of %d steps\n",
               s.name, (int)s.nbodies, (int)nv, s.backend, h, (int)s.frames, (int)s.frame_steps);
    fflush(stdout);
    for (int f = 0; f <= s.frames; ++f) {
        if (f > 0) {
            for (int32_t k = 0; k < s.frame_steps; ++k) {
                defsim_status st = scene_step(&s, w, h);
                if (st != DEFSIM_OK) {
                    if (mode == 2) printf("\n");
                    fprintf(stderr, "defsim run: %s: step %lld (t = %g s, frame %d) failed: %s: %s\n",
                            s.path, (long long)steps + 1, defsim_world_time(w), f,
                            defsim_status_string(st), defsim_world_last_error(w));
                    rc = 1;
                    goto finish;
                }
                ++steps;
            }
        }
        const double t = defsim_world_time(w);
        defsim_world_get_positions(w, x, nv);
        defsim_world_energy(w, &e);
        if (f == 0) e0 = e.total;
        fprintf(csv, "%d,%.17g,%.17g,%.17g,%.17g,%.17g", f, t, e.kinetic, e.elastic,
                e.gravitational, e.total);
        for (int32_t i = 0; i < s.nbodies; ++i)
            if (s.bodies[i].probe >= 0) {
                const double *p = x + 3 * ((int64_t)s.bodies[i].offset + s.bodies[i].probe);
                fprintf(csv, ",%.17g,%.17g,%.17g", p[0], p[1], p[2]);
            }
        fprintf(csv, "\n");
        fflush(csv);
        last_frame = f;
        const int out = nlist > 0 ? wanted(f, s.frames, s.every, list, nlist)
                                  : wanted(f, s.frames, s.every, NULL, 0);
        if (out && (s.write_vtk || s.write_png) && fields_eval(&fl, &s, w, err, sizeof err)) {
            fprintf(stderr, "defsim run: frame %d: %s\n", f, err);
            rc = 1;
            goto finish;
        }
        if (out && s.write_vtk) {
            const double t0 = tools_now();
            char name[64];
            snprintf(name, sizeof name, "frame_%05d.vtu", f);
            snprintf(path, sizeof path, "%s/%s", dir, name);
            defsim_world_get_velocities(w, v, nv);
            if (vtk_write_vtu(path, nv, x, v, &cells, t, fl.arrays, fl.narrays, err, sizeof err) ||
                pvd_add(&pvd, name, t) ||
                vtk_write_pvd(pvd_path, pvd.n, pvd.times, (const char *const *)pvd.files, err,
                              sizeof err)) {
                fprintf(stderr, "defsim run: %s\n", err);
                rc = 1;
                goto finish;
            }
            t_out += tools_now() - t0;
        }
#ifdef DEFSIM_HAVE_RENDER
        if (out && s.write_png) {
            const double t0 = tools_now();
            snprintf(path, sizeof path, "%s/frame_%05d.png", dir, f);
            double range[2];
            rd_color_parts((scene_color)s.color, &s, parts, s.nbodies, tri_cell, fl.von_mises,
                           fl.displacement, nv, vertex_rgb, tri_rgb, range);
            const int bad = rd_render(rd, &view, x, parts, s.nbodies, frame_img.rgb, err, sizeof err);
            if (!bad) rd_colorbar(frame_img.rgb, s.width, s.height, (scene_color)s.color, range[0], range[1]);
            if (bad || image_write_png(path, &frame_img, err, sizeof err)) {
                fprintf(stderr, "defsim run: render: %s\n", err);
                rc = 1;
                goto finish;
            }
            for (int k = 0; k < nsheet; ++k)
                if (sheet_frames[k] == f && nthumbs < SHEET_MAX &&
                    image_downscale(&frame_img, 2, &thumbs[nthumbs]) == 0)
                    thumb_t[nthumbs++] = t;
            t_render += tools_now() - t0;
        }
#endif
        /* Progress. */
        const double wall = tools_now() - t_start;
        char probe[160] = "";
        for (int32_t i = 0; i < s.nbodies; ++i)
            if (s.bodies[i].probe >= 0) {
                const double *p = x + 3 * ((int64_t)s.bodies[i].offset + s.bodies[i].probe);
                snprintf(probe, sizeof probe, "  probe (%.4f, %.4f, %.4f)", p[0], p[1], p[2]);
                break;
            }
        const double sps = wall > 0.0 ? (double)steps / wall : 0.0;
        if (mode == 1 && out) {
            printf("frame %5d/%d  t %8.4f s  wall %7.2f s  %9.0f steps/s  E %12.6g J "
                   "(kin %.4g, ela %.4g, grav %.4g)%s\n", f, (int)s.frames, t, wall, sps, e.total,
                   e.kinetic, e.elastic, e.gravitational, probe);
            fflush(stdout);
        } else if (mode == 2 && (wall - last_bar >= 0.1 || f == s.frames || interrupted)) {
            last_bar = wall;
            const int width = 24, fill = (int)lround((double)width * f / s.frames);
            char bar[32];
            for (int k = 0; k < width; ++k) bar[k] = k < fill ? '#' : '.';
            bar[width] = '\0';
            printf("\r[%s] frame %d/%d  t %.3f s  wall %.1f s  %.0f steps/s  E %.6g J%s\x1b[K",
                   bar, f, (int)s.frames, t, wall, sps, e.total, probe);
            fflush(stdout);
        }
        if (interrupted) break;
    }
finish:
    sigaction(SIGINT, &old_sa, NULL);
    if (mode == 2) printf("\n");
    fclose(csv);
    /* The final state, whatever stopped the run. */
    defsim_world_get_positions(w, x, nv);
    defsim_world_get_velocities(w, v, nv);
    snprintf(path, sizeof path, "%s/final.vtu", dir);
    if (fields_eval(&fl, &s, w, err, sizeof err) ||
        vtk_write_vtu(path, nv, x, v, &cells, defsim_world_time(w), fl.arrays, fl.narrays, err,
                      sizeof err)) {
        fprintf(stderr, "defsim run: %s\n", err);
        rc = 1;
    }
#ifdef DEFSIM_HAVE_RENDER
    if (s.write_png && nthumbs > 1) {
        image sheet;
        snprintf(path, sizeof path, "%s/contact_sheet.png", dir);
        if (image_contact_sheet(thumbs, thumb_t, nthumbs, 4, &sheet) ||
            image_write_png(path, &sheet, err, sizeof err)) {
            fprintf(stderr, "defsim run: contact sheet: %s\n", err);
            rc = 1;
        }
        image_free(&sheet);
    }
    for (int k = 0; k < nthumbs; ++k) image_free(&thumbs[k]);
    image_free(&frame_img);
    if (parts)
        for (int32_t i = 0; i < s.nbodies; ++i) {
            free((void *)parts[i].tris);
            free((void *)parts[i].lines);
        }
    free(parts);
    for (int32_t i = 0; tri_cell && i < s.nbodies; ++i) {
        free(tri_cell[i]);
        free(tri_rgb[i]);
    }
    free(tri_cell);
    free(tri_rgb);
    free(vertex_rgb);
    rd_destroy(rd);
#endif
    if (mode != 0) {
        defsim_stats st = {.size = sizeof st};
        defsim_world_stats(w, &st);
        const double wall = tools_now() - t_start;
        printf("%s %d frames, %lld steps (%lld failed) in %.3f s wall (%.0f steps/s)\n",
               interrupted ? "interrupted after" : rc ? "stopped after" : "done:", last_frame,
               (long long)st.steps, (long long)st.failed_steps, wall,
               wall > 0 ? (double)st.steps / wall : 0.0);
        printf("  time: step %.3f s (forces %.3f, hessian %.3f, factor %.3f, solve %.3f), "
               "output %.3f s, render %.3f s\n", st.time_step, st.time_forces, st.time_hessian,
               st.time_factor, st.time_solve, t_out, t_render);
        if (st.newton_iterations || st.linear_solves)
            printf("  Newton: %lld iterations, %lld line-search backtracks, %lld linear solves, "
                   "%lld convergence failures\n", (long long)st.newton_iterations,
                   (long long)st.line_search_backtracks, (long long)st.linear_solves,
                   (long long)st.convergence_failures);
        if (st.internal_steps)
            printf("  adaptive: %lld internal steps, %lld residual and %lld Jacobian evaluations, "
                   "%lld error-test and %lld convergence failures, last order %d\n",
                   (long long)st.internal_steps, (long long)st.residual_evals,
                   (long long)st.jacobian_evals, (long long)st.error_test_failures,
                   (long long)st.convergence_failures, (int)st.last_order);
        printf("  energy: start %.6g J, end %.6g J (kinetic %.6g, elastic %.6g, gravitational %.6g)\n",
               e0, e.total, e.kinetic, e.elastic, e.gravitational);
        for (int32_t i = 0; i < s.nbodies; ++i)
            if (s.bodies[i].probe >= 0) {
                const double *p = x + 3 * ((int64_t)s.bodies[i].offset + s.bodies[i].probe);
                printf("  probe of %s (vertex %d): (%.6f, %.6f, %.6f)\n", s.bodies[i].name,
                       (int)s.bodies[i].probe, p[0], p[1], p[2]);
            }
        printf("  output: %s/ (%s%d frames%s, final.vtu, energy.csv)\n", dir,
               s.write_vtk ? "" : "no VTK, ", pvd.n, s.write_png ? ", PNG" : "");
    }
    if (interrupted && rc == 0) {
        fprintf(stderr, "defsim run: interrupted after frame %d; the output up to it is complete\n",
                last_frame);
        rc = 130;
    }
    for (int i = 0; i < pvd.n; ++i) free(pvd.files[i]);
    free(pvd.files);
    free(pvd.times);
    vtk_cells_free(&cells);
    fields_free(&fl);
    free(x);
    free(v);
    free(list);
    defsim_world_destroy(w);
    scene_free(&s);
    return rc;
}
