/* SPDX-License-Identifier: MIT */
/*
 * `defsim run SCENE.json`: runs a scene, shows progress, writes VTK frames (.vtu + .pvd), an
 * energy log and the final state, and with --render PNG frames and a contact sheet.
 * Ctrl-C stops after the current frame; everything written so far stays valid.
 * --checkpoint-every N writes checkpoint.dfck into the output folder every N frames (and when
 * interrupted); --resume DIR continues the run whose output folder is DIR from its checkpoint,
 * bit for bit, appending to its outputs.
 *
 * Contents: options; frame output (energy.csv, VTK); PNG output (renderer, contact sheet);
 * progress and summary; run_main (the frame loop).
 */
#include "run.h"

#include "cli.h"
#include "clock.h"

#include "fields.h"
#include "frame.h"
#include "scene.h"
#include "vtk.h"
#ifdef DEFSIM_HAVE_RENDER
#include "render/image.h"
#include "render/render.h"
#endif

#include "../src/file_read.h"
#include "fileio.h"
#include "run_summary.h"

#include <dirent.h>
#include <errno.h>
#include <math.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

static volatile sig_atomic_t interrupted;

static void on_sigint(int sig)
{
    (void)sig;
    interrupted = 1;
}

/* ------------------------------------------------------------------------------------------ */
/* Options */

static void usage(FILE *f)
{
    fprintf(f,
        "usage: defsim run SCENE.json [options]\n"
        "  --out DIR          output folder (default: the scene's name); what an earlier run\n"
        "                     left there (frame_*.vtu/vtm/png, *.pvd, final.*, contact_sheet.png)\n"
        "                     is removed first\n"
        "  --render           also write PNG frames and a contact sheet (needs OSMesa)\n"
        "  --vtk MODE         all: .vtu frames, .pvd and final.vtu (default when the scene's\n"
        "                     output.formats has \"vtk\"); final: only final.vtu; none: no VTK\n"
        "  --no-vtk           the same as --vtk none\n"
        "  --frames LIST      write only these frames (comma-separated numbers, 0 = start)\n"
        "  --backend NAME     override world.backend\n"
        "  --threads N        override world.threads\n"
        "  --color MODE       colour rendered bodies by body (default), stress (von Mises),\n"
        "                     displacement or speed, with a colour bar on one scale for the\n"
        "                     whole run (= --set output.color=MODE)\n"
        "  --contact-forces   draw the contact forces as arrows in rendered frames\n"
        "                     (= --set output.contact_arrows=true)\n"
        "  --set KEY=VALUE    override any scene value (e.g. world.gravity=[0,9.81,0],\n"
        "                     bodies.0.material.youngs_modulus=1e4); repeatable\n"
        "  --option NAME=VALUE  set a world option after the scene's world.options\n"
        "                     (sundials_ida.rtol=1e-6, core.simd=generic); repeatable\n"
        "  --progress MODE    auto (bar on a terminal, lines otherwise), bar, lines, none\n"
        "  --checkpoint-every N  write OUT/checkpoint.dfck every N frames and when interrupted\n"
        "  --resume DIR       continue the run whose output folder is DIR from its\n"
        "                     checkpoint (same scene; outputs are appended there)\n"
        "  --summary-json FILE  write how the run ended (status, steps, energies, probes,\n"
        "                     stable-step estimate) as JSON\n"
        "  --max-vertices N   refuse scenes of more vertices (default 2000000)\n"
        "  --max-steps N      refuse runs of more time steps (default 10000000)\n"
        "  -h, --help         this text\n"
        "  --version          the library's version\n");
}

enum { PROGRESS_NONE = 0, PROGRESS_LINES = 1, PROGRESS_BAR = 2 };
enum { VTK_NONE = 0, VTK_FINAL = 1, VTK_ALL = 2 };

typedef struct run_opts {
    const char *scene_path, *out_dir, *summary_path, *resume_dir;
    int render, vtk, progress;   /* vtk: -1 as the scene says, else VTK_NONE, _FINAL, _ALL */
    int checkpoint_every;   /* frames; 0: none */
    const char **sets;   /* --set, --backend and --threads as scene overrides */
    int nsets;
    const char **opts;   /* --option NAME=VALUE, set after the scene's world.options */
    int nopts;
    int *list, nlist;    /* --frames */
    char backend_set[128], threads_set[64], color_set[128];
    scene_limits limits;   /* --max-vertices, --max-steps */
} run_opts;

static void opts_free(run_opts *o)
{
    free(o->sets);
    free(o->opts);
    free(o->list);
}

/* "3,10,20" into o->list. */
static int parse_frame_list(run_opts *o, char *s)
{
    char *end;
    for (;;) {
        long v = strtol(s, &end, 10);
        if (end == s || v < 0 || v > 1000000000) break;
        o->list[o->nlist++] = (int)v;
        if (*end != ',') {
            if (*end == '\0') return 0;
            break;
        }
        s = end + 1;
    }
    fprintf(stderr, "defsim run: --frames: expected comma-separated frame numbers\n");
    return 2;
}

/* --max-vertices / --max-steps N: a whole number >= 1 into *out; else 0. */
static int parse_limit(const char *flag, const char *arg, int64_t *out)
{
    char *end;
    errno = 0;
    const long long v = strtoll(arg, &end, 10);
    if (end == arg || *end != '\0' || errno != 0 || v < 1) {
        fprintf(stderr, "defsim run: %s: expected a whole number >= 1, got %s\n", flag, arg);
        return 0;
    }
    *out = v;
    return 1;
}

/* Returns -1 to go on, or the exit status (usage, help, bad options). */
static int parse_args(int argc, char **argv, run_opts *o)
{
    memset(o, 0, sizeof *o);
    o->vtk = -1;
    o->limits.max_vertices = SCENE_MAX_VERTICES;
    o->limits.max_steps = SCENE_MAX_STEPS;
    o->sets = calloc((size_t)argc + 4, sizeof *o->sets);
    /* --frames lists at most one number per two characters of the arguments. */
    size_t chars = 0;
    for (int i = 0; i < argc; ++i) chars += strlen(argv[i]) + 1;
    o->list = calloc(chars / 2 + 1, sizeof *o->list);
    o->opts = calloc((size_t)argc + 1, sizeof *o->opts);
    if (!o->sets || !o->list || !o->opts) return 1;
    const char *progress = "auto";
    enum { O_OUT = CLI_OPT, O_RENDER, O_NO_VTK, O_VTK, O_PROGRESS, O_SET, O_OPTION, O_SUMMARY,
           O_MAX_VERTICES, O_MAX_STEPS, O_RESUME, O_CHECKPOINT_EVERY, O_BACKEND, O_COLOR,
           O_THREADS, O_FRAMES, O_CONTACT_FORCES };
    static const struct option options[] = {
        {"out", required_argument, NULL, O_OUT}, {"render", no_argument, NULL, O_RENDER},
        {"no-vtk", no_argument, NULL, O_NO_VTK}, {"vtk", required_argument, NULL, O_VTK},
        {"progress", required_argument, NULL, O_PROGRESS},
        {"set", required_argument, NULL, O_SET}, {"option", required_argument, NULL, O_OPTION},
        {"summary-json", required_argument, NULL, O_SUMMARY},
        {"max-vertices", required_argument, NULL, O_MAX_VERTICES},
        {"max-steps", required_argument, NULL, O_MAX_STEPS},
        {"resume", required_argument, NULL, O_RESUME},
        {"checkpoint-every", required_argument, NULL, O_CHECKPOINT_EVERY},
        {"backend", required_argument, NULL, O_BACKEND},
        {"color", required_argument, NULL, O_COLOR},
        {"threads", required_argument, NULL, O_THREADS},
        {"frames", required_argument, NULL, O_FRAMES},
        {"contact-forces", no_argument, NULL, O_CONTACT_FORCES}, {0}};
    const cli_tool tool = {strcmp(argv[0], "run") ? argv[0] : "defsim run", usage, options, ""};
    cli c;
    cli_begin(&c, &tool, argc, argv);
    for (int opt; (opt = cli_next(&c)) != CLI_END;) {
        const char *v = c.arg;
        switch (opt) {
        case CLI_EXIT: return c.status;
        case O_OUT: o->out_dir = v; break;
        case O_RENDER: o->render = 1; break;
        case O_CONTACT_FORCES: o->sets[o->nsets++] = "output.contact_arrows=true"; break;
        case O_NO_VTK: o->vtk = VTK_NONE; break;
        case O_VTK:
            o->vtk = !strcmp(v, "all") ? VTK_ALL : !strcmp(v, "final") ? VTK_FINAL
                     : !strcmp(v, "none") ? VTK_NONE : -2;
            if (o->vtk == -2) return cli_error(&c, "--vtk must be all, final or none");
            break;
        case O_PROGRESS: progress = v; break;
        case O_SET: o->sets[o->nsets++] = v; break;
        case O_OPTION: o->opts[o->nopts++] = v; break;
        case O_SUMMARY: o->summary_path = v; break;
        case O_MAX_VERTICES:
            if (!parse_limit(c.flag, v, &o->limits.max_vertices)) return 2;
            break;
        case O_MAX_STEPS:
            if (!parse_limit(c.flag, v, &o->limits.max_steps)) return 2;
            break;
        case O_RESUME: o->resume_dir = v; break;
        case O_CHECKPOINT_EVERY:
            if (!cli_int(&c, 1, 1000000000, &o->checkpoint_every)) return c.status;
            break;
        case O_BACKEND:
            snprintf(o->backend_set, sizeof o->backend_set, "world.backend=\"%s\"", v);
            o->sets[o->nsets++] = o->backend_set;
            break;
        case O_COLOR:
            snprintf(o->color_set, sizeof o->color_set, "output.color=\"%s\"", v);
            o->sets[o->nsets++] = o->color_set;
            break;
        case O_THREADS:
            snprintf(o->threads_set, sizeof o->threads_set, "world.threads=%s", v);
            o->sets[o->nsets++] = o->threads_set;
            break;
        case O_FRAMES:
            if (parse_frame_list(o, (char *)v)) return 2;
            break;
        }
    }
    if (c.optind + 1 < argc)
        return cli_error(&c, "one scene file at a time (got %s and %s)", argv[c.optind],
                         argv[c.optind + 1]);
    if (c.optind < argc) o->scene_path = argv[c.optind];
    if (!o->scene_path) return cli_error(&c, "no scene file");
    if (o->resume_dir && o->out_dir && strcmp(o->resume_dir, o->out_dir) != 0) {
        fprintf(stderr, "defsim run: --resume writes into the folder it resumes; --out differs\n");
        return 2;
    }
    if (o->resume_dir) o->out_dir = o->resume_dir;
    if (!strcmp(progress, "auto"))
        o->progress = isatty(STDOUT_FILENO) ? PROGRESS_BAR : PROGRESS_LINES;
    else if (!strcmp(progress, "bar")) o->progress = PROGRESS_BAR;
    else if (!strcmp(progress, "lines")) o->progress = PROGRESS_LINES;
    else if (!strcmp(progress, "none")) o->progress = PROGRESS_NONE;
    else {
        fprintf(stderr, "defsim run: --progress must be auto, bar, lines or none\n");
        return 2;
    }
    return -1;
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

/* ------------------------------------------------------------------------------------------ */
/* Frame output: energy.csv every frame, VTK frames with their .pvd index, final.vtu */

/* The files of a .pvd and their times. */
typedef struct pvd_list {
    char **files;
    double *times;
    int n, cap;
} pvd_list;

typedef struct frame_out {
    char dir[2048], path[4200], pvd_path[4200], scene_pvd_path[4200], err[1024];
    FILE *csv;
    vtk_cells cells;
    fields fl;      /* stress, displacement, pin, attachment and contact forces: VTK data, colours */
    frame_plane plane;   /* where plane colliders are drawn (sized to the scene at the start) */
    int colliders;  /* the scene has colliders: frames carry them, with a .vtm */
    pvd_list bodies;     /* written .vtu frames, for <name>.pvd */
    pvd_list scene;      /* written .vtm frames (bodies and colliders), for <name>_scene.pvd */
    int n;          /* VTK frames written */
} frame_out;

static int pvd_add(pvd_list *o, const char *file, double t)
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

static void pvd_free(pvd_list *o)
{
    for (int i = 0; i < o->n; ++i) free(o->files[i]);
    free(o->files);
    free(o->times);
    memset(o, 0, sizeof *o);
}

/* Resuming after frame f0: keeps energy.csv's header and rows of frames 0 .. f0 (a run that
 * went on past its last checkpoint wrote more), reads frame 0's energies into *e0, and lists the
 * VTK frames up to f0 that exist for the .pvd, at the times the run had then (h added step by
 * step, as the world adds it). */
static int out_resume(frame_out *o, const scene *s, int f0, const run_opts *ro,
                      defsim_energy *e0)
{
    char *text = NULL;
    size_t len = 0;
    if (defsim__read_file(o->path, DEFSIM__FILE_MAX, &text, &len) != 0) {
        fprintf(stderr, "defsim run: --resume: cannot read %s\n", o->path);
        return -1;
    }
    char *line = text, *keep_end = text;
    for (int row = 0; *line; ++row) {
        char *nl = strchr(line, '\n');
        char *next = nl ? nl + 1 : line + strlen(line);
        if (row > 0) {
            const int f = atoi(line);
            if (f > f0) break;
            if (f == 0)
                sscanf(line, "%*d,%*g,%lg,%lg,%lg,%lg", &e0->kinetic, &e0->elastic,
                       &e0->gravitational, &e0->total);
        }
        keep_end = line = next;
    }
    o->csv = fopen(o->path, "w");
    const int bad = !o->csv || fwrite(text, 1, (size_t)(keep_end - text), o->csv) !=
                                   (size_t)(keep_end - text);
    free(text);
    if (bad) {
        fprintf(stderr, "defsim run: cannot write %s\n", o->path);
        return -1;
    }
    double t = 0.0;
    for (int f = 0; f <= f0; ++f) {
        for (int32_t k = 0; f > 0 && k < s->frame_steps; ++k) t += s->h;
        if (!s->write_vtk || !wanted(f, s->frames, s->every, ro->list, ro->nlist)) continue;
        for (int kind = 0; kind < 2; ++kind) {
            char name[64];
            snprintf(name, sizeof name, kind ? "frame_%05d.vtm" : "frame_%05d.vtu", f);
            snprintf(o->path, sizeof o->path, "%s/%s", o->dir, name);
            if (access(o->path, R_OK) == 0 && pvd_add(kind ? &o->scene : &o->bodies, name, t)) {
                fprintf(stderr, "defsim run: out of memory\n");
                return -1;
            }
        }
    }
    o->n = o->bodies.n;
    return 0;
}

/* 1 for the names defsim run writes: frame_<digits>.vtu / .vtm / .png,
 * frame_<digits>_colliders.vtu, *.pvd, final.vtu / .vtm, final_colliders.vtu,
 * contact_sheet.png, and their ".tmp" files. */
static int own_output(const char *name)
{
    size_t n = strlen(name);
    if (n > 4 && !strcmp(name + n - 4, ".tmp")) n -= 4;
    static const char *const fixed[] = {"final.vtu", "final.vtm", "final_colliders.vtu",
                                        "contact_sheet.png"};
    for (int k = 0; k < 4; ++k)
        if (n == strlen(fixed[k]) && !strncmp(name, fixed[k], n)) return 1;
    if (n > 4 && !strncmp(name + n - 4, ".pvd", 4)) return 1;
    if (n < 11 || strncmp(name, "frame_", 6) ||
        (strncmp(name + n - 4, ".vtu", 4) && strncmp(name + n - 4, ".vtm", 4) &&
         strncmp(name + n - 4, ".png", 4)))
        return 0;
    size_t end = n - 4;
    if (end > 16 && !strncmp(name + end - 10, "_colliders", 10) &&
        !strncmp(name + n - 4, ".vtu", 4))
        end -= 10;
    for (size_t i = 6; i < end; ++i)
        if (name[i] < '0' || name[i] > '9') return 0;
    return end > 6;
}

/* Removes what an earlier run wrote into dir, so that a reused --out holds only this run's
 * frames (a shorter run would otherwise leave later frames, and a .pvd listing them). Other
 * files are left alone. Returns the number removed, or -1. */
static int clear_stale(const char *dir)
{
    DIR *d = opendir(dir);
    if (!d) return errno == ENOENT ? 0 : -1;
    int n = 0, rc = 0;
    char path[4200];
    for (struct dirent *e; (e = readdir(d));) {
        if (!own_output(e->d_name)) continue;
        snprintf(path, sizeof path, "%s/%s", dir, e->d_name);
        if (unlink(path) == 0) ++n;
        else if (errno != ENOENT) rc = -1;
    }
    closedir(d);
    return rc ? -1 : n;
}

/* Creates the folder (clearing an earlier run's outputs), the VTK cells of all bodies and
 * energy.csv with its header; when resuming after frame f0 >= 0, keeps what the run wrote up to
 * it instead (out_resume). */
static int out_open(frame_out *o, const scene *s, const char *dir, int f0, const run_opts *ro,
                    defsim_energy *e0, int verbose)
{
    snprintf(o->dir, sizeof o->dir, "%s", dir);
    if (tools_make_dirs(o->dir)) {
        fprintf(stderr, "defsim run: cannot create the output folder %s: %s\n", o->dir,
                strerror(errno));
        return -1;
    }
    const int stale = f0 >= 0 ? 0 : clear_stale(o->dir);
    if (stale < 0) {
        fprintf(stderr, "defsim run: cannot clear the earlier outputs from %s: %s\n", o->dir,
                strerror(errno));
        return -1;
    }
    if (stale > 0 && verbose)
        printf("%s/: removed %d files of an earlier run\n", o->dir, stale);
    snprintf(o->pvd_path, sizeof o->pvd_path, "%s/%s.pvd", o->dir, s->name);
    snprintf(o->scene_pvd_path, sizeof o->scene_pvd_path, "%s/%s_scene.pvd", o->dir, s->name);
    o->colliders = s->ncolliders > 0;
    for (int32_t i = 0; i < s->nbodies; ++i) {
        const scene_body *b = &s->bodies[i];
        int bad = 0;
        if (b->mesh.tet_count > 0)
            bad = b->mesh.tet_nodes == 10
                      ? vtk_cells_add(&o->cells, b->mesh.tets, b->mesh.tet_count, 10, b->offset,
                                      VTK_QUADRATIC_TETRA, i)
                      : vtk_cells_add(&o->cells, b->mesh.tets, b->mesh.tet_count, 4, b->offset,
                                      VTK_TETRA, i);
        else if (b->mesh.triangle_count > 0)
            bad = vtk_cells_add(&o->cells, b->mesh.triangles, b->mesh.triangle_count, 3,
                                b->offset, VTK_TRIANGLE, i);
        else
            bad = vtk_cells_add(&o->cells, b->mesh.springs, b->line_count, 2, b->offset,
                                VTK_LINE, i);
        if (bad) {
            fprintf(stderr, "defsim run: out of memory\n");
            return -1;
        }
    }
    snprintf(o->path, sizeof o->path, "%s/energy.csv", o->dir);
    if (f0 >= 0) return out_resume(o, s, f0, ro, e0);
    o->csv = fopen(o->path, "w");
    if (!o->csv) {
        fprintf(stderr, "defsim run: cannot write %s\n", o->path);
        return -1;
    }
    fprintf(o->csv, "frame,time,kinetic,elastic,gravitational,total");
    for (int32_t i = 0; i < s->nbodies; ++i)
        if (s->bodies[i].probe >= 0) fprintf(o->csv, ",probe%d_x,probe%d_y,probe%d_z", i, i, i);
    fprintf(o->csv, "\n");
    return 0;
}

/* Position of the probe of body i in x. */
static const double *probe_of(const scene *s, int32_t i, const double *x)
{
    return x + 3 * ((int64_t)s->bodies[i].offset + s->bodies[i].probe);
}

static void out_energy(frame_out *o, const scene *s, int f, double t, const defsim_energy *e,
                       const double *x)
{
    fprintf(o->csv, "%d,%.17g,%.17g,%.17g,%.17g,%.17g", f, t, e->kinetic, e->elastic,
            e->gravitational, e->total);
    for (int32_t i = 0; i < s->nbodies; ++i)
        if (s->bodies[i].probe >= 0) {
            const double *p = probe_of(s, i, x);
            fprintf(o->csv, ",%.17g,%.17g,%.17g", p[0], p[1], p[2]);
        }
    fprintf(o->csv, "\n");
    fflush(o->csv);
}

/* frame_NNNNN.vtu (with the colliders: frame_NNNNN_colliders.vtu and frame_NNNNN.vtm) and the
 * .pvd indexes rewritten to include it: <name>.pvd the bodies' frames, <name>_scene.pvd the
 * .vtm frames. */
static int out_vtk(frame_out *o, defsim_world *w, int f, double t, const double *x,
                   const double *v)
{
    char name[64], vtm[64];
    snprintf(name, sizeof name, "frame_%05d.vtu", f);
    snprintf(vtm, sizeof vtm, "frame_%05d.vtm", f);
    snprintf(o->path, sizeof o->path, "%s/%s", o->dir, name);
    int wrote_vtm = 0;
    if (frame_write(o->path, w, x, v, &o->cells, &o->fl, t, o->colliders, &o->plane, &wrote_vtm,
                    o->err, sizeof o->err) ||
        pvd_add(&o->bodies, name, t) ||
        vtk_write_pvd(o->pvd_path, o->bodies.n, o->bodies.times,
                      (const char *const *)o->bodies.files, o->err, sizeof o->err) ||
        (wrote_vtm && (pvd_add(&o->scene, vtm, t) ||
                       vtk_write_pvd(o->scene_pvd_path, o->scene.n, o->scene.times,
                                     (const char *const *)o->scene.files, o->err,
                                     sizeof o->err)))) {
        fprintf(stderr, "defsim run: %s\n", o->err);
        return -1;
    }
    ++o->n;
    return 0;
}

static int out_final(frame_out *o, defsim_world *w, const double *x, const double *v)
{
    snprintf(o->path, sizeof o->path, "%s/final.vtu", o->dir);
    if (fields_eval(&o->fl, w, o->err, sizeof o->err) ||
        frame_write(o->path, w, x, v, &o->cells, &o->fl, defsim_world_time(w), o->colliders,
                    &o->plane, NULL, o->err, sizeof o->err)) {
        fprintf(stderr, "defsim run: %s\n", o->err);
        return -1;
    }
    return 0;
}

static void out_close(frame_out *o)
{
    if (o->csv) fclose(o->csv);
    o->csv = NULL;
    pvd_free(&o->bodies);
    pvd_free(&o->scene);
    vtk_cells_free(&o->cells);
    fields_free(&o->fl);
}

/* ------------------------------------------------------------------------------------------ */
/* PNG output: a renderer with one part per body, frames, and a contact sheet of up to 12 */

#ifdef DEFSIM_HAVE_RENDER
enum { SHEET_MAX = 12 };

/* Frames are spooled while the run goes (positions, the colour field, collider poses) and
 * rendered when it ends, so that the camera, the ground and the colour scale come from the
 * whole motion rather than from the first frame. */
typedef struct png_out {
    rd_renderer *rd;
    rd_view view;
    rd_bodies bodies;     /* one part per body, with their colour buffers */
    rd_overlay overlay;   /* pinned markers, contact arrows and colliders */
    FILE *spool;          /* unlinked scratch file in the output folder */
    int nspooled;
    double lo[3], hi[3], top;   /* bounds of the bodies and largest colour value over the run */
    double fmax;                /* largest contact force over the run (N), for the arrows */
    double *x, *vec, *cell;     /* one spooled frame: positions, |vec| colours, cell colours */
    double *force;              /* and its contact forces, with output.contact_arrows */
    double *poses;              /* 7 per collider: position, rotation */
    image frame;
    image thumbs[SHEET_MAX];
    double thumb_t[SHEET_MAX];
    int nthumbs, sheet_frames[SHEET_MAX], nsheet;
    char err[1024];
} png_out;

static int png_open(png_out *p, const scene *s, const run_opts *o, const fields *fl,
                    const char *dir, defsim_world *w)
{
    p->rd = rd_create(s->width, s->height, s->supersample, p->err, sizeof p->err);
    p->x = malloc(3 * (size_t)fl->nv * sizeof *p->x + 1);
    p->vec = malloc(3 * (size_t)fl->nv * sizeof *p->vec + 1);
    p->cell = malloc((size_t)(fl->ncells + 1) * sizeof *p->cell);
    p->force = malloc(3 * (size_t)fl->nv * sizeof *p->force + 1);
    p->poses = malloc(7 * (size_t)(defsim_world_collider_count(w) + 1) * sizeof *p->poses);
    p->frame.width = s->width;
    p->frame.height = s->height;
    p->frame.rgb = malloc((size_t)s->width * s->height * 3);
    rd_body_src *src = calloc((size_t)s->nbodies + 1, sizeof *src);
    int bad = !p->x || !p->vec || !p->cell || !p->force || !p->poses || !p->frame.rgb || !src;
    for (int32_t i = 0; !bad && i < s->nbodies; ++i) {
        const scene_body *b = &s->bodies[i];
        src[i] = (rd_body_src){b->offset,
                               /* quadratic tets: drawn by their boundary's sub-triangles,
                                  without stress colours */
                               b->mesh.tet_nodes == 10 ? NULL : b->mesh.tets,
                               b->mesh.tet_nodes == 10 ? 0 : b->mesh.tet_count, fl->cell_offset[i],
                               b->mesh.triangles, b->mesh.triangle_count, b->mesh.springs,
                               b->line_count, {b->color[0], b->color[1], b->color[2]}};
    }
    /* Stress colours: each boundary triangle takes its tet's cell. */
    bad = bad || rd_bodies_init(&p->bodies, src, s->nbodies, fl->nv,
                                s->color == SCENE_COLOR_STRESS);
    free(src);
    if (!p->rd || bad) {
        fprintf(stderr, "defsim run: renderer: %s\n", p->rd ? "out of memory" : p->err);
        return -1;
    }
    char path[4200];
    snprintf(path, sizeof path, "%s/.render_spool.tmp", dir);
    p->spool = fopen(path, "w+b");
    if (!p->spool) {
        fprintf(stderr, "defsim run: cannot write %s: %s\n", path, strerror(errno));
        return -1;
    }
    remove(path);   /* the open stream keeps it; nothing is left behind however the run ends */
    for (int c = 0; c < 3; ++c) {
        p->lo[c] = INFINITY;
        p->hi[c] = -INFINITY;
    }
    /* Contact sheet: up to 12 of the written frames, evenly spread. */
    int written[4096], nw = 0;
    for (int f = 0; f <= s->frames && nw < 4096; ++f)
        if (f == 0 ? (o->nlist == 0 || wanted(0, s->frames, s->every, o->list, o->nlist))
                   : wanted(f, s->frames, s->every, o->list, o->nlist))
            written[nw++] = f;
    if (nw > 1 && s->contact_sheet) {
        p->nsheet = nw < SHEET_MAX ? nw : SHEET_MAX;
        for (int k = 0; k < p->nsheet; ++k)
            p->sheet_frames[k] = written[(int)lround((double)k * (nw - 1) / (p->nsheet - 1))];
    }
    return 0;
}

/* Takes frame f into the bounds and the colour scale of the run (every frame, written or
 * not, so that a frame looks the same whichever frames are written) and, when `keep`, spools
 * it: its number and time, positions, the vector coloured by its length (displacement or
 * velocity) or the cells' von Mises stress, and the colliders' poses. */
static int png_spool(png_out *p, const scene *s, const fields *fl, defsim_world *w, int f,
                     double t, const double *x, int keep)
{
    const int32_t nv = fl->nv, nc = defsim_world_collider_count(w);
    const double *vec = NULL;
    if (s->color == SCENE_COLOR_DISPLACEMENT) vec = fl->displacement;
    if (s->color == SCENE_COLOR_SPEED) {
        defsim_world_get_velocities(w, p->vec, nv);
        vec = p->vec;
    }
    for (int32_t i = 0; i < nc; ++i) {
        defsim_collider_def c = {.size = sizeof c};
        defsim_world_get_collider(w, i, NULL, &c);
        memcpy(p->poses + 7 * i, c.position, 3 * sizeof(double));
        memcpy(p->poses + 7 * i + 3, c.rotation, 4 * sizeof(double));
    }
    for (int32_t k = 0; k < nv; ++k)
        for (int c = 0; c < 3; ++c) {
            p->lo[c] = fmin(p->lo[c], x[3 * k + c]);
            p->hi[c] = fmax(p->hi[c], x[3 * k + c]);
        }
    p->top = fmax(p->top, rd_color_top((scene_color)s->color, p->bodies.parts, p->bodies.nparts,
                                       p->bodies.tri_cell, fl->von_mises, vec, nv));
    const double *force = s->contact_arrows ? fl->contact_force : NULL;
    p->fmax = fmax(p->fmax, rd_force_max(force, nv));
    if (!keep) return 0;
    int ok = fwrite(&f, sizeof f, 1, p->spool) == 1 && fwrite(&t, sizeof t, 1, p->spool) == 1 &&
             fwrite(&nc, sizeof nc, 1, p->spool) == 1 &&
             fwrite(x, sizeof *x, 3 * (size_t)nv, p->spool) == 3 * (size_t)nv &&
             (nc == 0 || fwrite(p->poses, sizeof *p->poses, 7 * (size_t)nc, p->spool) ==
                             7 * (size_t)nc);
    if (ok && vec) ok = fwrite(vec, sizeof *vec, 3 * (size_t)nv, p->spool) == 3 * (size_t)nv;
    if (ok && s->color == SCENE_COLOR_STRESS && fl->von_mises)
        ok = fwrite(fl->von_mises, sizeof(double), (size_t)fl->ncells, p->spool) ==
             (size_t)fl->ncells;
    if (ok && force) ok = fwrite(force, sizeof *force, 3 * (size_t)nv, p->spool) == 3 * (size_t)nv;
    if (!ok) {
        fprintf(stderr, "defsim run: render: cannot write the frame spool: %s\n", strerror(errno));
        return -1;
    }
    ++p->nspooled;
    return 0;
}

/* Renders one spooled frame into p->frame: bodies coloured on the run's scale, pinned
 * markers, contact arrows, colliders at the frame's poses, the colour bar and the time. */
static int png_draw(png_out *p, const scene *s, const fields *fl, defsim_world *w,
                    const double *x, const double *vec, const double *cell,
                    const double *force, int32_t nc, const double *poses, double t)
{
    const rd_frame_data d = {.mode = (scene_color)s->color, .s = s, .top = p->top, .vec = vec,
                             .cell = cell, .pinned = fl->pinned, .poses = poses, .ncolliders = nc,
                             .time = t, .force = force,
                             .arrow_scale = rd_arrow_scale(s->arrow_scale, p->fmax, p->lo, p->hi),
                             .force_max = p->fmax};
    return rd_draw_frame(p->rd, &p->bodies, &p->overlay, &p->view, w, x, &d, p->frame.rgb,
                         p->err, sizeof p->err);
}

/* Renders the spooled frames (frame_NNNNN.png and the contact sheet) and frees everything.
 * Returns the number of PNG frames written, or -1. */
static int png_close(png_out *p, const scene *s, const fields *fl, defsim_world *w,
                     const char *dir)
{
    int rc = 0, written = 0;
    if (p->spool && p->nspooled > 0) {
        rd_view_make(&s->camera, p->lo, p->hi, s->def.gravity, (double)s->width / s->height,
                     &p->view);
        rewind(p->spool);
    }
    const int32_t nv = fl->nv;
    for (int k = 0; p->spool && k < p->nspooled && rc == 0; ++k) {
        int f = 0;
        int32_t nc = 0;
        double t = 0.0;
        const int vec = s->color == SCENE_COLOR_DISPLACEMENT || s->color == SCENE_COLOR_SPEED;
        const int cell = s->color == SCENE_COLOR_STRESS && fl->von_mises;
        int ok = fread(&f, sizeof f, 1, p->spool) == 1 && fread(&t, sizeof t, 1, p->spool) == 1 &&
                 fread(&nc, sizeof nc, 1, p->spool) == 1 && nc >= 0 &&
                 nc <= defsim_world_collider_count(w) &&
                 fread(p->x, sizeof *p->x, 3 * (size_t)nv, p->spool) == 3 * (size_t)nv &&
                 (nc == 0 || fread(p->poses, sizeof *p->poses, 7 * (size_t)nc, p->spool) ==
                                 7 * (size_t)nc);
        if (ok && vec && (s->color == SCENE_COLOR_SPEED || fl->displacement))
            ok = fread(p->vec, sizeof *p->vec, 3 * (size_t)nv, p->spool) == 3 * (size_t)nv;
        if (ok && cell)
            ok = fread(p->cell, sizeof *p->cell, (size_t)fl->ncells, p->spool) ==
                 (size_t)fl->ncells;
        const int force = s->contact_arrows && fl->contact_force;
        if (ok && force)
            ok = fread(p->force, sizeof *p->force, 3 * (size_t)nv, p->spool) == 3 * (size_t)nv;
        char path[4200];
        snprintf(path, sizeof path, "%s/frame_%05d.png", dir, f);
        if (!ok) {
            snprintf(p->err, sizeof p->err, "the frame spool is short");
            rc = -1;
        } else if (png_draw(p, s, fl, w, p->x,
                            vec && (s->color == SCENE_COLOR_SPEED || fl->displacement) ? p->vec
                                                                                        : NULL,
                            cell ? p->cell : NULL, force ? p->force : NULL, nc, p->poses, t) ||
                   image_write_png(path, &p->frame, p->err, sizeof p->err)) {
            rc = -1;
        } else {
            ++written;
            for (int j = 0; j < p->nsheet; ++j)
                if (p->sheet_frames[j] == f && p->nthumbs < SHEET_MAX &&
                    image_downscale(&p->frame, 2, &p->thumbs[p->nthumbs]) == 0)
                    p->thumb_t[p->nthumbs++] = t;
        }
        if (rc) fprintf(stderr, "defsim run: render: %s\n", p->err);
    }
    if (rc == 0 && p->nthumbs > 1) {
        char path[4200];
        snprintf(path, sizeof path, "%s/contact_sheet.png", dir);
        if (image_write_contact_sheet(path, p->thumbs, p->thumb_t, p->nthumbs, 4, p->err,
                                      sizeof p->err)) {
            fprintf(stderr, "defsim run: contact sheet: %s\n", p->err);
            rc = -1;
        }
    }
    if (p->spool) fclose(p->spool);
    for (int k = 0; k < p->nthumbs; ++k) image_free(&p->thumbs[k]);
    image_free(&p->frame);
    rd_bodies_free(&p->bodies);
    free(p->x);
    free(p->vec);
    free(p->cell);
    free(p->force);
    free(p->poses);
    rd_overlay_free(&p->overlay);
    rd_destroy(p->rd);
    return rc ? -1 : written;
}
#endif

/* ------------------------------------------------------------------------------------------ */
/* Progress and summary */

typedef struct progress {
    int mode;
    double t_start, last_bar;
} progress;

/* Steps per second of simulation: the steps over the library's time in defsim_world_step (no
 * output, no rendering, no frame bookkeeping). */
static double sim_steps_per_s(defsim_world *w)
{
    defsim_stats st = {.size = sizeof st};
    defsim_world_stats(w, &st);
    return st.time_step > 0.0 ? (double)st.steps / st.time_step : 0.0;
}

static void progress_frame(progress *pr, const scene *s, defsim_world *w, int f, int written,
                           double t, const defsim_energy *e, const double *x)
{
    const double wall = tools_now() - pr->t_start;
    char probe[160] = "";
    for (int32_t i = 0; i < s->nbodies; ++i)
        if (s->bodies[i].probe >= 0) {
            const double *p = probe_of(s, i, x);
            snprintf(probe, sizeof probe, "  probe (%.4f, %.4f, %.4f)", p[0], p[1], p[2]);
            break;
        }
    const double sps = sim_steps_per_s(w);
    if (pr->mode == PROGRESS_LINES && written) {
        printf("frame %5d/%d  t %8.4f s  wall %7.2f s  %9.0f steps/s  E %12.6g J "
               "(kin %.4g, ela %.4g, grav %.4g)%s\n", f, (int)s->frames, t, wall, sps, e->total,
               e->kinetic, e->elastic, e->gravitational, probe);
        fflush(stdout);
    } else if (pr->mode == PROGRESS_BAR &&
               (wall - pr->last_bar >= 0.1 || f == s->frames || interrupted)) {
        pr->last_bar = wall;
        const int width = 24, fill = (int)lround((double)width * f / s->frames);
        char bar[32];
        for (int k = 0; k < width; ++k) bar[k] = k < fill ? '#' : '.';
        bar[width] = '\0';
        printf("\r[%s] frame %d/%d  t %.3f s  wall %.1f s  %.0f steps/s  E %.6g J%s\x1b[K",
               bar, f, (int)s->frames, t, wall, sps, e->total, probe);
        fflush(stdout);
    }
}

typedef struct run_result {
    int rc, last_frame, vtk_frames, png_frames, final_vtu;
    double e0, t_out, t_render;
    defsim_energy e;
} run_result;

static void print_summary(const progress *pr, const scene *s, defsim_world *w,
                          const run_result *r, const double *x, const char *dir)
{
    defsim_stats st = {.size = sizeof st};
    defsim_world_stats(w, &st);
    const double wall = tools_now() - pr->t_start;
    const defsim_energy *e = &r->e;
    /* Two rates: the simulation's (time in step only) and the run's (output, rendering). */
    printf("%s %d frames, %lld steps (%lld failed) in %.3f s wall: %.0f steps/s simulating, "
           "%.0f steps/s with output and rendering\n",
           interrupted ? "interrupted after" : r->rc ? "stopped after" : "done:", r->last_frame,
           (long long)st.steps, (long long)st.failed_steps, wall,
           st.time_step > 0 ? (double)st.steps / st.time_step : 0.0,
           wall > 0 ? (double)st.steps / wall : 0.0);
    printf("  time: step %.3f s (forces %.3f, hessian %.3f), output %.3f s, render %.3f s\n",
           st.time_step, st.time_forces, st.time_hessian, r->t_out, r->t_render);
    /* The backend's counters, by name (iterations, solves, internal steps, its timings). */
    const size_t bl = strlen(s->backend);
    int listed = 0;
    for (int32_t i = 0; i < defsim_world_stat_count(w); ++i) {
        const char *name;
        double v;
        if (defsim_world_stat_info(w, i, &name, &v) != DEFSIM_OK || strncmp(name, s->backend, bl) ||
            name[bl] != '.' || v == 0.0)
            continue;
        printf("%s%s %.6g", listed++ ? ", " : "  backend: ", name + bl + 1, v);
    }
    if (listed) printf("\n");
    printf("  energy: start %.6g J, end %.6g J (kinetic %.6g, elastic %.6g, gravitational %.6g)\n",
           r->e0, e->total, e->kinetic, e->elastic, e->gravitational);
    for (int32_t i = 0; i < s->nbodies; ++i)
        if (s->bodies[i].probe >= 0) {
            const double *p = probe_of(s, i, x);
            printf("  probe of %s (vertex %d): (%.6f, %.6f, %.6f)\n", s->bodies[i].name,
                   (int)s->bodies[i].probe, p[0], p[1], p[2]);
        }
    printf("  output: %s/ (%d VTK frames, %d PNG frames%s, energy.csv)\n", dir, r->vtk_frames,
           r->png_frames, r->final_vtu ? ", final.vtu" : "");
}

/* ------------------------------------------------------------------------------------------ */
/* The run */

int run_set_options(const char *tool, defsim_world *w, const char *const *opts, int n)
{
    for (int i = 0; i < n; ++i) {
        const char *eq = strchr(opts[i], '=');
        char name[160];
        if (!eq || eq == opts[i] || (size_t)(eq - opts[i]) >= sizeof name) {
            fprintf(stderr, "%s: --option %s: expected NAME=VALUE\n", tool, opts[i]);
            return -1;
        }
        snprintf(name, sizeof name, "%.*s", (int)(eq - opts[i]), opts[i]);
        if (defsim_world_set_option(w, name, eq + 1) != DEFSIM_OK) {
            fprintf(stderr, "%s: --option %s: %s\n", tool, opts[i], defsim_world_last_error(w));
            return -1;
        }
    }
    return 0;
}

/* The checkpoint of a run's output folder. */
static void checkpoint_path(const char *dir, char *path, size_t size)
{
    snprintf(path, size, "%s/checkpoint.dfck", dir);
}

/* --resume: the world from the checkpoint instead of the scene's, with the scene's body and
 * attachment ids pointing into it; *f0 receives the frame it was written after. Returns 0, or
 * -1 with the reason printed. */
static int resume_world(const run_opts *o, scene *s, defsim_world **w, int *f0)
{
    char path[4200];
    checkpoint_path(o->resume_dir, path, sizeof path);
    if (defsim_world_load(path, s->def.log, s->def.log_user, w) != DEFSIM_OK) {
        fprintf(stderr, "defsim run: --resume: %s\n", defsim_last_error());
        return -1;
    }
    defsim_stats st = {.size = sizeof st};
    defsim_world_stats(*w, &st);
    const char *why = NULL;
    if (defsim_world_body_count(*w) != s->nbodies ||
        defsim_world_attachment_count(*w) != s->nattachments)
        why = "its bodies and attachments are not the scene's";
    for (int32_t i = 0; !why && i < s->nbodies; ++i) {
        scene_body *b = &s->bodies[i];
        defsim_world_body_at(*w, i, &b->id);
        b->offset = defsim_body_vertex_offset(*w, b->id);
        if (defsim_body_vertex_count(*w, b->id) != b->mesh.vertex_count)
            why = "a body's vertex count is not the scene's";
    }
    for (int32_t i = 0; !why && i < s->nattachments; ++i)
        defsim_world_attachment_at(*w, i, &s->attachments[i].id);
    if (!why && (st.steps % s->frame_steps != 0 || st.steps / s->frame_steps > s->frames))
        why = "it was not written at a frame of this scene";
    if (why) {
        fprintf(stderr, "defsim run: --resume: %s: %s\n", path, why);
        defsim_world_destroy(*w);
        *w = NULL;
        return -1;
    }
    *f0 = (int)(st.steps / s->frame_steps);
    return 0;
}

/* Loads the scene with the options applied and checks what needs the scene. Returns -1 to go
 * on (world built, or loaded when resuming after frame *f0; else *f0 = -1), or the exit
 * status. */
static int load(const run_opts *o, scene *s, defsim_world **w, int *f0)
{
    *f0 = -1;
    if (scene_load_limited(s, o->scene_path, o->sets, o->nsets, &o->limits)) {
        fprintf(stderr, "defsim run: %s\n", s->error);
        return 1;
    }
    if (o->render) s->write_png = 1;
    if (o->vtk >= 0) s->write_vtk = o->vtk == VTK_ALL;
    for (int i = 0; i < o->nlist; ++i)
        if (o->list[i] > s->frames) {
            fprintf(stderr, "defsim run: --frames: frame %d is past the last frame (%d)\n",
                    o->list[i], (int)s->frames);
            scene_free(s);
            return 2;
        }
#ifndef DEFSIM_HAVE_RENDER
    if (s->write_png) {
        fprintf(stderr, "defsim run: PNG output needs the OSMesa renderer, and this build has "
                        "none (configure with -DDEFSIM_WITH_OSMESA=ON and libosmesa6-dev)\n");
        scene_free(s);
        return 1;
    }
#endif
    if (o->resume_dir ? resume_world(o, s, w, f0) : scene_build(s, w) != DEFSIM_OK) {
        if (!o->resume_dir) fprintf(stderr, "defsim run: %s\n", s->error);
        scene_free(s);
        return 1;
    }
    if (run_set_options("defsim run", *w, o->opts, o->nopts)) {
        defsim_world_destroy(*w);
        *w = NULL;
        scene_free(s);
        return 2;
    }
    return -1;
}

int run_main(int argc, char **argv)
{
    run_opts o;
    int rc = parse_args(argc, argv, &o);
    scene s;
    defsim_world *w = NULL;
    int f0 = -1;   /* resuming after this frame */
    if (rc < 0) rc = load(&o, &s, &w, &f0);
    if (rc >= 0) {
        opts_free(&o);
        return rc;
    }
    /* final.vtu: with the frames, or alone with --vtk final. */
    const int write_final = o.vtk < 0 ? s.write_vtk : o.vtk >= VTK_FINAL;
    const int32_t nv = defsim_world_vertex_count(w);
    double *x = malloc(3 * (size_t)nv * sizeof *x), *v = malloc(3 * (size_t)nv * sizeof *v);
    frame_out out;
    memset(&out, 0, sizeof out);
    run_result r;
    memset(&r, 0, sizeof r);
    defsim_energy e_start = {0};
#ifdef DEFSIM_HAVE_RENDER
    png_out png;
    memset(&png, 0, sizeof png);
#endif
    if (!x || !v) {
        fprintf(stderr, "defsim run: out of memory\n");
        r.rc = 1;
    } else if (out_open(&out, &s, o.out_dir ? o.out_dir : s.name, f0, &o, &e_start,
                        o.progress != PROGRESS_NONE)) {
        r.rc = 1;
    }
    /* The fields the VTK frames carry and what the renderer colours by. */
    const unsigned need =
        (s.write_vtk || write_final ? s.fields : 0u) |
        (s.write_png && s.color == SCENE_COLOR_STRESS ? (unsigned)SCENE_FIELD_STRESS : 0u) |
        (s.write_png && s.color == SCENE_COLOR_DISPLACEMENT ? (unsigned)SCENE_FIELD_DISPLACEMENT : 0u) |
        (s.write_png && s.contact_arrows ? (unsigned)SCENE_FIELD_CONTACT_FORCES : 0u);
    if (r.rc == 0 && fields_init(&out.fl, w, &out.cells, need, out.err, sizeof out.err)) {
        fprintf(stderr, "defsim run: %s\n", out.err);
        r.rc = 1;
    }
    /* Displacements stay measured from the start of the run, not from where it resumed. */
    for (int32_t i = 0; r.rc == 0 && f0 >= 0 && i < s.nbodies; ++i) {
        const scene_body *b = &s.bodies[i];
        memcpy(out.fl.x0 + 3 * (int64_t)b->offset, b->initial ? b->initial : b->mesh.positions,
               3 * (size_t)b->mesh.vertex_count * sizeof *out.fl.x0);
    }
    /* Planes are drawn as squares sized to the scene at its start (also when resuming). */
    if (r.rc == 0) frame_plane_extent(w, out.fl.x0, &out.plane);
#ifdef DEFSIM_HAVE_RENDER
    if (r.rc == 0 && s.write_png && png_open(&png, &s, &o, &out.fl, out.dir, w)) r.rc = 1;
#endif

    struct sigaction sa, old_sa;
    memset(&sa, 0, sizeof sa);
    sa.sa_handler = on_sigint;
    sigemptyset(&sa.sa_mask);
    sigaction(SIGINT, &sa, &old_sa);
    interrupted = 0;

    /* The estimate costs some force evaluations, so only a summary asks for it. */
    double stable_step = 0.0;
    defsim_status run_st = DEFSIM_OK;
    if (o.summary_path) defsim_world_stable_step(w, &stable_step, NULL);
    progress pr = {o.progress, tools_now(), -1.0};
    const double h = s.h, t_start = tools_now();
    int64_t steps = f0 > 0 ? (int64_t)f0 * s.frame_steps : 0;
    r.e0 = e_start.total;
    r.last_frame = f0 > 0 ? f0 : 0;
    char ckpt_path[4200];
    checkpoint_path(out.dir, ckpt_path, sizeof ckpt_path);
    const int started = r.rc == 0;   /* else nothing was written: no final state, no summary */
    if (started && pr.mode != PROGRESS_NONE) {
        printf("%s: %d bodies, %d vertices, backend %s, h = %g s, %d frames of %d steps\n",
               s.name, (int)s.nbodies, (int)nv, s.backend, h, (int)s.frames, (int)s.frame_steps);
        if (f0 >= 0) printf("resumed from %s after frame %d (t = %g s)\n", ckpt_path, f0,
                            defsim_world_time(w));
    }
    fflush(stdout);
    for (int f = f0 + 1 > 0 ? f0 + 1 : 0; r.rc == 0 && f <= s.frames; ++f) {
        for (int32_t k = 0; f > 0 && k < s.frame_steps; ++k, ++steps) {
            defsim_status st = scene_step(&s, w, h);
            if (st != DEFSIM_OK) {
                run_st = st;
                if (pr.mode == PROGRESS_BAR) printf("\n");
                fprintf(stderr, "defsim run: %s: step %lld (t = %g s, frame %d) failed: %s: %s\n",
                        s.path, (long long)steps + 1, defsim_world_time(w), f,
                        defsim_status_string(st), defsim_world_last_error(w));
                r.rc = 1;
                break;
            }
        }
        if (r.rc) break;
        const double t = defsim_world_time(w);
        defsim_world_get_positions(w, x, nv);
        defsim_world_energy(w, &r.e);
        if (f == 0) {
            r.e0 = r.e.total;
            e_start = r.e;
        }
        out_energy(&out, &s, f, t, &r.e, x);
        r.last_frame = f;
        const int written = wanted(f, s.frames, s.every, o.list, o.nlist);
        const int colours = s.write_png && (s.color != SCENE_COLOR_BODY || s.contact_arrows);
        if ((written || colours) && (s.write_vtk || s.write_png) &&
            fields_eval(&out.fl, w, out.err, sizeof out.err)) {
            fprintf(stderr, "defsim run: frame %d: %s\n", f, out.err);
            r.rc = 1;
            break;
        }
        if (written && s.write_vtk) {
            const double t0 = tools_now();
            defsim_world_get_velocities(w, v, nv);
            if (out_vtk(&out, w, f, t, x, v)) { r.rc = 1; break; }
            r.t_out += tools_now() - t0;
        }
#ifdef DEFSIM_HAVE_RENDER
        if (s.write_png) {
            const double t0 = tools_now();
            if (png_spool(&png, &s, &out.fl, w, f, t, x, written)) { r.rc = 1; break; }
            r.t_render += tools_now() - t0;
        }
#endif
        progress_frame(&pr, &s, w, f, written, t, &r.e, x);
        /* After the frame's output, so that a resumed run starts with the next frame. */
        if (o.checkpoint_every > 0 && f > 0 &&
            (f % o.checkpoint_every == 0 || interrupted) &&
            defsim_world_save(w, ckpt_path) != DEFSIM_OK) {
            fprintf(stderr, "defsim run: checkpoint: %s\n", defsim_world_last_error(w));
            r.rc = 1;
            break;
        }
        if (interrupted) break;
    }
    sigaction(SIGINT, &old_sa, NULL);
    if (started && pr.mode == PROGRESS_BAR) printf("\n");
    r.vtk_frames = out.n;
    if (started) {
        /* The final state, whatever stopped the run. */
        defsim_world_get_positions(w, x, nv);
        defsim_world_get_velocities(w, v, nv);
        if (write_final && out_final(&out, w, x, v)) r.rc = 1;
        r.final_vtu = write_final && r.rc == 0;
    }
#ifdef DEFSIM_HAVE_RENDER
    {
        const double t0 = tools_now();
        r.png_frames = png_close(&png, &s, &out.fl, w, out.dir);
        if (r.png_frames < 0) {
            r.png_frames = 0;
            r.rc = 1;
        }
        r.t_render += tools_now() - t0;
    }
#endif
    if (started && pr.mode != PROGRESS_NONE) print_summary(&pr, &s, w, &r, x, out.dir);
    if (o.summary_path) {
        char err[1024];
        run_summary sum = {.status = run_st != DEFSIM_OK ? defsim_status_string(run_st)
                                     : interrupted ? "interrupted" : r.rc ? "error" : "ok",
                           .step_status = run_st, .frames = r.last_frame,
                           .wall = tools_now() - t_start, .stable_step = stable_step, .x = x,
                           .message = run_st != DEFSIM_OK ? defsim_world_last_error(w) : ""};
        sum.start = e_start;
        defsim_world_energy(w, &sum.end);
        if (run_summary_write(o.summary_path, &s, w, &sum, err, sizeof err)) {
            fprintf(stderr, "defsim run: %s\n", err);
            r.rc = 1;
        }
    }
    if (interrupted && r.rc == 0) {
        fprintf(stderr, "defsim run: interrupted after frame %d; the output up to it is complete\n",
                r.last_frame);
        r.rc = 130;
    }
    out_close(&out);
    free(x);
    free(v);
    opts_free(&o);
    defsim_world_destroy(w);
    scene_free(&s);
    return r.rc;
}
