/* SPDX-License-Identifier: MIT */
/*
 * `defsim bench --spatial SCENE.json`: the work-precision front against the continuum. The scene
 * has one body on a generated box; the sweep runs it on boxes of k times a coarse cell count
 * (refinements k of each element order: linear and quadratic tets) with each backend at its
 * steps (tolerances), and measures the error of the motion of fixed material points (the free
 * vertices of the coarse box, which are vertices of every refinement) at every frame up to T
 * against a converged reference: quadratic tets on a finer box, with a small step, cached in the
 * output folder under a hash of what it depends on and checked against the next coarser
 * quadratic box (spatial) and against itself at twice the step (temporal). Writes a CSV, the
 * front (for each error level the cheapest configuration) and a plot (tools/plot_wp.py).
 * tools/README.md and docs/work-precision.md ("Against the continuum") document it.
 *
 * Contents: options; loading one mesh of the sweep; running one trajectory; the reference (cache,
 * checks); the sweep; the front table and CSV; defsim_tool_bench_spatial.
 */
#include "bench.h"

#include "cli.h"
#include "clock.h"
#include "fileio.h"
#include "scene.h"
#include "stat.h"

#include <errno.h>
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

/* Bump when the way the reference is computed or stored changes (old caches are then unused). */
#define SREF_FORMAT "bench-spatial-reference-1"
#define MAX_SETS 64
#define MAX_LIST 16
#define MAX_BACKENDS 12
#define MAX_VALUES 32
/* The explicit backends' step: this fraction of defsim_world_stable_step's estimate. */
#define STABLE_FRACTION 0.9
/* The reference's default step: this fraction of its mesh's stable step (second order: its
 * time error is then about a quarter of that at the stable step). */
#define REF_FRACTION 0.45
#define DIVERGED_RMS 1.0

typedef struct spatial {
    const char *scene_path;
    const char *sets[MAX_SETS + 2];
    int nsets;
    double T, frame_dt;
    int frames;            /* time samples: the ends of the frames up to T */
    int repeats, threads;
    int coarse[3];         /* cells of refinement 1 */
    double size;           /* bounding-box diagonal of the rest shape, m */
    int S;                 /* sample points: the free vertices of the coarse linear box */
    double *rest;          /* 3 S rest positions, then the probe's (3 more) */
    int has_probe;
} spatial;

/* One mesh of the sweep: its scene, and where the sample points and the probe are in it. */
typedef struct sp_mesh {
    scene s;
    int order;             /* 1 linear, 2 quadratic */
    int cells[3];
    int32_t nv;
    int32_t *idx;          /* S + 1 vertex indices (the last: the probe, or -1) */
} sp_mesh;

/* A trajectory: the samples and the probe (S + 1 points) at each of the frames. */
static size_t traj_len(const spatial *sp) { return (size_t)sp->frames * (size_t)(sp->S + 1) * 3; }

static void usage(FILE *f)
{
    fprintf(f,
        "usage: defsim bench --spatial SCENE.json [options]\n"
        "Total (spatial + temporal) error against CPU time: the scene's one body on generated\n"
        "boxes of k x the coarse cells, linear and quadratic tets, each backend and step, against\n"
        "a converged quadratic reference; the error is the RMS over the frames up to T and over\n"
        "the free vertices of the coarse box of the position error, relative to the body size.\n"
        "  --cells NXxNYxNZ    the coarse box (refinement 1; default: the scene's box, halved\n"
        "                      where all its cell counts are even)\n"
        "  --linear LIST       refinements with linear tets (default 1,2,3,4; \"none\")\n"
        "  --quadratic LIST    refinements with quadratic tets (default 1,2,3; \"none\")\n"
        "  --reference-refine K  the reference's refinement, quadratic tets (default: one more\n"
        "                      than the finest swept); checked against K - 1 (when K >= 2)\n"
        "  --reference-backend NAME  (default velocity_verlet)\n"
        "  --reference-h H     its step, s (default: %.2f x its stable step, or a frame / 8 for\n"
        "                      an implicit backend)\n"
        "  --backends A,B,...  (default velocity_verlet,newmark,newton_cholmod)\n"
        "  --h LIST            steps, s, shortened to whole steps per frame: implicit backends\n"
        "                      (default a frame / 1, 2, 4, 8); explicit ones run at %.1f x\n"
        "                      their stable step on each mesh and at the listed steps below it\n"
        "  --implicit-max-vertices N  implicit backends skip meshes of more vertices\n"
        "  --tol LIST          sundials_ida and sundials_erk tolerances (default 1e-3,1e-4,1e-5)\n"
        "  --time T            end time, s, a whole number of frames (default: the whole\n"
        "                      frames within min(0.5, the scene's duration))\n"
        "  --repeats R         timed repeats per point, median reported (default 3)\n"
        "  --threads N         assembly threads (default 1)\n"
        "  --set KEY=VALUE     override a scene value, as in defsim run; repeatable\n"
        "  --out DIR           output folder (default bench_<scene>)\n"
        "  --python PATH, --plot-script PATH, --no-plot   as in defsim bench\n"
        "Writes DIR/<scene>_spatial.csv, DIR/<scene>_spatial_front.md (also printed),\n"
        "DIR/<scene>_spatial.png and the cached reference\n"
        "DIR/<scene>_spatial_reference_<key>.txt.\n"
        "Exit status: 0 done, 1 error, 2 usage error.\n",
        REF_FRACTION, STABLE_FRACTION);
}

/* "12x4x4" into c. Returns 0, or -1. */
static int parse_cells(const char *s, int c[3])
{
    char end;
    if (sscanf(s, "%dx%dx%d%c", &c[0], &c[1], &c[2], &end) != 3) return -1;
    return c[0] >= 1 && c[1] >= 1 && c[2] >= 1 && c[0] <= 4096 && c[1] <= 4096 && c[2] <= 4096
               ? 0 : -1;
}

/* Whole refinement factors "1,2,3" (or "none": zero of them). Returns the count, or -1. */
static int parse_refine(const char *s, int *out)
{
    if (!strcmp(s, "none")) return 0;
    double v[MAX_LIST];
    const int n = bench_parse_list(s, v, MAX_LIST);
    for (int i = 0; i < n; ++i) {
        if (v[i] != floor(v[i]) || v[i] > 64) return -1;
        out[i] = (int)v[i];
    }
    return n;
}

/* Loads the scene on a box of `cells` with tets of `order` and finds the sample points in it
 * (when sp->rest is set). Returns 0, or -1 with a message in err. */
static int load_mesh(spatial *sp, int order, const int cells[3], sp_mesh *m, char *err,
                     size_t errlen)
{
    memset(m, 0, sizeof *m);
    char c1[96], c2[64];
    snprintf(c1, sizeof c1, "bodies.0.mesh.cells=[%d,%d,%d]", cells[0], cells[1], cells[2]);
    snprintf(c2, sizeof c2, "bodies.0.mesh.quadratic=%s", order == 2 ? "true" : "false");
    sp->sets[sp->nsets] = c1;
    sp->sets[sp->nsets + 1] = c2;
    if (scene_load(&m->s, sp->scene_path, sp->sets, sp->nsets + 2) != 0) {
        snprintf(err, errlen, "%s (--spatial sets bodies.0.mesh.cells and .quadratic: it needs a "
                 "scene of one body on a generated box)", m->s.error);
        return -1;
    }
    m->order = order;
    memcpy(m->cells, cells, sizeof m->cells);
    const int r = order == 2 ? 2 : 1;
    const int32_t expect = (r * cells[0] + 1) * (r * cells[1] + 1) * (r * cells[2] + 1);
    if (m->s.nbodies != 1 || m->s.bodies[0].mesh.vertex_count != expect) {
        snprintf(err, errlen, "%s: --spatial needs a scene of one body on a generated box "
                 "(\"mesh\": {\"type\": \"box\", ...}), whose cells it changes",
                 sp->scene_path);
        scene_free(&m->s);
        return -1;
    }
    if (scene_has_paths(&m->s)) {
        snprintf(err, errlen, "%s: driven pins and keyframed attachments are not supported by "
                 "the work-precision benchmark", sp->scene_path);
        scene_free(&m->s);
        return -1;
    }
    m->nv = expect;
    if (!sp->rest) return 0;
    m->idx = malloc((size_t)(sp->S + 1) * sizeof *m->idx);
    if (!m->idx) {
        snprintf(err, errlen, "out of memory");
        scene_free(&m->s);
        return -1;
    }
    const double *X = m->s.bodies[0].mesh.positions, tol = 1e-9 * sp->size;
    for (int k = 0; k < sp->S + 1; ++k) {
        m->idx[k] = -1;
        if (k == sp->S && !sp->has_probe) break;
        const double *p = sp->rest + 3 * k;
        for (int32_t v = 0; v < m->nv && m->idx[k] < 0; ++v)
            if (fabs(X[3 * v] - p[0]) <= tol && fabs(X[3 * v + 1] - p[1]) <= tol &&
                fabs(X[3 * v + 2] - p[2]) <= tol)
                m->idx[k] = v;
        if (m->idx[k] < 0) {
            snprintf(err, errlen, "the %s box of %dx%dx%d cells has no vertex at the sample "
                     "point (%g, %g, %g): refinements must be whole multiples of --cells",
                     order == 2 ? "quadratic" : "linear", cells[0], cells[1], cells[2], p[0],
                     p[1], p[2]);
            free(m->idx);
            scene_free(&m->s);
            return -1;
        }
    }
    return 0;
}

static void free_mesh(sp_mesh *m)
{
    free(m->idx);
    scene_free(&m->s);
    memset(m, 0, sizeof *m);
}

static defsim_status build(const spatial *sp, sp_mesh *m, const char *backend, double tol,
                           defsim_world **w)
{
    return bench_build(&m->s, backend, sp->threads, tol, sp->size, w);
}

/* The largest step a backend takes stably on mesh m at rest (+INFINITY for implicit ones). */
static defsim_status stable_step(const spatial *sp, sp_mesh *m, const char *backend, double *h)
{
    defsim_world *w = NULL;
    defsim_status st = build(sp, m, backend, 0.0, &w);
    if (st == DEFSIM_OK) st = defsim_world_stable_step(w, h, NULL);
    defsim_world_destroy(w);
    return st;
}

/* Whole steps per frame: the step nearest below h that divides the frame interval. */
static double frame_step(const spatial *sp, double h)
{
    const double n = ceil(sp->frame_dt / h - 1e-6);
    return sp->frame_dt / (n < 1.0 ? 1.0 : n);
}

/* Runs mesh m with `backend` at step h (is_tol 0) or tolerance h (is_tol 1) to T, recording the
 * sample points and the probe at the end of each frame into traj (traj_len doubles; the probe's
 * three are NaN without one) when not NULL. *cpu and *wall: the process CPU time and the wall
 * time of the stepping calls only. */
static defsim_status run_traj(const spatial *sp, sp_mesh *m, const char *backend, int is_tol,
                              double h, double *traj, double *cpu, double *wall, long long *steps,
                              long long *newton, char *err, size_t errlen)
{
    defsim_world *w = NULL;
    defsim_status st = build(sp, m, backend, is_tol ? h : 0.0, &w);
    *wall = *cpu = 0.0;
    if (st != DEFSIM_OK) {
        snprintf(err, errlen, "%s", m->s.error);
        return st;
    }
    double *x = traj ? malloc(3 * (size_t)m->nv * sizeof *x) : NULL;
    if (traj && !x) {
        defsim_world_destroy(w);
        snprintf(err, errlen, "out of memory");
        return DEFSIM_ERR_OUT_OF_MEMORY;
    }
    for (int k = 1; k <= sp->frames && st == DEFSIM_OK; ++k) {
        const double t_end = k == sp->frames ? sp->T : k * sp->frame_dt;
        const double t0 = tools_now(), c0 = tools_cpu_now();
        if (is_tol) {
            st = defsim_world_step(w, t_end - defsim_world_time(w));
        } else {
            const double len = t_end - defsim_world_time(w);
            long long n = (long long)ceil(len / h - 1e-9);
            if (n < 1) n = 1;
            for (long long i = 0; i < n && st == DEFSIM_OK; ++i)
                st = defsim_world_step(w, len / (double)n);
        }
        *cpu += tools_cpu_now() - c0;
        *wall += tools_now() - t0;
        if (st != DEFSIM_OK) {
            snprintf(err, errlen, "%s", defsim_world_last_error(w));
            break;
        }
        if (!traj) continue;
        defsim_world_get_positions(w, x, m->nv);
        double *o = traj + (size_t)(k - 1) * (size_t)(sp->S + 1) * 3;
        for (int s = 0; s <= sp->S; ++s)
            for (int c = 0; c < 3; ++c)
                o[3 * s + c] = m->idx[s] >= 0 ? x[3 * m->idx[s] + c] : NAN;
    }
    defsim_stats stats = {.size = sizeof stats};
    defsim_world_stats(w, &stats);
    if (steps) *steps = stats.steps;
    if (newton) *newton = (long long)tools_backend_stat(w, "newton_iterations");
    free(x);
    defsim_world_destroy(w);
    return st;
}

/* Errors of trajectory a against reference r: RMS and max over frames and sample points of the
 * position error relative to the body size, and the probe's error at T relative to the
 * reference's displacement of it there (NaN without a probe). */
static void traj_error(const spatial *sp, const double *a, const double *r, double *rms,
                       double *max, double *tip)
{
    double sum = 0.0, mx = 0.0;
    const size_t stride = (size_t)(sp->S + 1) * 3;
    for (int k = 0; k < sp->frames; ++k)
        for (int s = 0; s < sp->S; ++s) {
            const double *p = a + k * stride + 3 * s, *q = r + k * stride + 3 * s;
            const double d2 = (p[0] - q[0]) * (p[0] - q[0]) + (p[1] - q[1]) * (p[1] - q[1]) +
                              (p[2] - q[2]) * (p[2] - q[2]);
            sum += d2;
            if (d2 > mx) mx = d2;
        }
    const double n = (double)sp->frames * sp->S;
    *rms = n > 0 ? sqrt(sum / n) / sp->size : 0.0;
    *max = sqrt(mx) / sp->size;
    *tip = NAN;
    if (sp->has_probe) {
        const double *p = a + (sp->frames - 1) * stride + 3 * sp->S;
        const double *q = r + (sp->frames - 1) * stride + 3 * sp->S, *X = sp->rest + 3 * sp->S;
        double d = 0.0, u = 0.0;
        for (int c = 0; c < 3; ++c) {
            d += (p[c] - q[c]) * (p[c] - q[c]);
            u += (q[c] - X[c]) * (q[c] - X[c]);
        }
        *tip = u > 0.0 ? sqrt(d / u) : NAN;
    }
}

/* What the reference knows of itself. */
typedef struct sref {
    int refine;
    char backend[64];
    double h, wall;
    double check_rms, check_tip, time_rms;   /* NaN: not checked */
    int check_refine;
    double *traj;
} sref;

static int reference_key(const spatial *sp, int refine, const char *backend, double h_req,
                         char key[17], char *err, size_t errlen)
{
    size_t len = 0;
    char *text = tools_read_file(sp->scene_path, &len);
    if (!text) {
        snprintf(err, errlen, "%s: %s", sp->scene_path, strerror(errno));
        return -1;
    }
    uint64_t h = 14695981039346656037ULL;
    h = tools_fnv1a(h, SREF_FORMAT, sizeof SREF_FORMAT);
    h = tools_fnv1a(h, text, len);
    free(text);
    for (int i = 0; i < sp->nsets; ++i) h = tools_fnv1a(h, sp->sets[i], strlen(sp->sets[i]) + 1);
    char buf[256];
    snprintf(buf, sizeof buf, "T=%.17g cells=%dx%dx%d refine=%d backend=%s h=%.17g", sp->T,
             sp->coarse[0], sp->coarse[1], sp->coarse[2], refine, backend, h_req);
    h = tools_fnv1a(h, buf, strlen(buf) + 1);
    snprintf(key, 17, "%016llx", (unsigned long long)h);
    return 0;
}

static int write_reference(const spatial *sp, const char *path, const char *key,
                           const sref *r)
{
    char tmp[1500], err[1600];
    FILE *f = tools_tmp_open(path, tmp, sizeof tmp, err, sizeof err);
    if (!f) {
        fprintf(stderr, "defsim bench: %s\n", err);
        return -1;
    }
    fprintf(f, "defsim-spatial-reference 1\nkey %s\nformat %s\nscene %s\n", key, SREF_FORMAT,
            sp->scene_path);
    for (int i = 0; i < sp->nsets; ++i) fprintf(f, "set %s\n", sp->sets[i]);
    fprintf(f, "mesh %dx%dx%d quadratic\nbackend %s\nh %.17g\nwall_seconds %.3f\n",
            r->refine * sp->coarse[0], r->refine * sp->coarse[1], r->refine * sp->coarse[2],
            r->backend, r->h, r->wall);
    fprintf(f, "check_refine %d\ncheck_rms_err %.17g\ncheck_tip_err %.17g\n"
               "time_check_rms_err %.17g\n", r->check_refine, r->check_rms, r->check_tip,
            r->time_rms);
    fprintf(f, "samples %d\nframes %d\nend_time %.17g\ndata\n", sp->S, sp->frames, sp->T);
    const size_t n = traj_len(sp);
    for (size_t i = 0; i < n; i += 3)
        fprintf(f, "%.17g %.17g %.17g\n", r->traj[i], r->traj[i + 1], r->traj[i + 2]);
    return tools_tmp_commit(f, tmp, path, 1, err, sizeof err) == 0
               ? 0 : (fprintf(stderr, "defsim bench: %s\n", err), -1);
}

/* Reads a cached reference. Returns 0, 1 (no such file) or -1 (a bad or foreign file). */
static int read_reference(const spatial *sp, const char *path, const char *key, sref *r)
{
    FILE *f = fopen(path, "r");
    if (!f) return 1;
    char line[1024], k[64] = "";
    int S = -1, frames = -1, ok = 0;
    while (fgets(line, sizeof line, f)) {
        if (!strncmp(line, "data", 4)) { ok = 1; break; }
        sscanf(line, "key %63s", k);
        sscanf(line, "backend %63s", r->backend);
        sscanf(line, "h %lf", &r->h);
        sscanf(line, "wall_seconds %lf", &r->wall);
        sscanf(line, "check_refine %d", &r->check_refine);
        sscanf(line, "check_rms_err %lf", &r->check_rms);
        sscanf(line, "check_tip_err %lf", &r->check_tip);
        sscanf(line, "time_check_rms_err %lf", &r->time_rms);
        sscanf(line, "samples %d", &S);
        sscanf(line, "frames %d", &frames);
    }
    if (!ok || strcmp(k, key) || S != sp->S || frames != sp->frames) {
        fprintf(stderr, "defsim bench: %s: not the reference of this scene, overrides, end time "
                        "and reference settings (remove it)\n", path);
        fclose(f);
        return -1;
    }
    const size_t n = traj_len(sp);
    r->traj = malloc(n * sizeof *r->traj);
    for (size_t i = 0; r->traj && i < n; ++i)
        if (fscanf(f, "%lf", &r->traj[i]) != 1) {
            /* NaN is written as "nan" (no probe), which %lf reads. */
            free(r->traj);
            r->traj = NULL;
        }
    fclose(f);
    if (!r->traj) {
        fprintf(stderr, "defsim bench: %s: truncated\n", path);
        return -1;
    }
    return 0;
}

/* Integrates the reference and its checks. Returns 0 or -1 (message printed). */
static int compute_reference(spatial *sp, sref *r, double h_req)
{
    char err[4400];
    sp_mesh m;
    const int cells[3] = {r->refine * sp->coarse[0], r->refine * sp->coarse[1],
                          r->refine * sp->coarse[2]};
    if (load_mesh(sp, 2, cells, &m, err, sizeof err) != 0) {
        fprintf(stderr, "defsim bench: reference: %s\n", err);
        return -1;
    }
    double h = h_req;
    if (!(h > 0.0)) {
        double hs = INFINITY;
        if (stable_step(sp, &m, r->backend, &hs) != DEFSIM_OK) {
            fprintf(stderr, "defsim bench: reference: %s\n", m.s.error);
            free_mesh(&m);
            return -1;
        }
        h = isfinite(hs) ? REF_FRACTION * hs : sp->frame_dt / 8.0;
    }
    r->h = frame_step(sp, h);
    printf("reference: quadratic tets, %dx%dx%d cells (%d vertices), %s at h = %.4g s ...\n",
           cells[0], cells[1], cells[2], (int)m.nv, r->backend, r->h);
    fflush(stdout);
    r->traj = malloc(traj_len(sp) * sizeof *r->traj);
    double *a = malloc(traj_len(sp) * sizeof *a), *b = malloc(traj_len(sp) * sizeof *b);
    int rc = -1;
    if (!r->traj || !a || !b) goto out;
    double cpu;
    if (run_traj(sp, &m, r->backend, 0, r->h, r->traj, &cpu, &r->wall, NULL, NULL, err,
                 sizeof err) != DEFSIM_OK) {
        fprintf(stderr, "defsim bench: reference: %s\n", err);
        goto out;
    }
    r->check_rms = r->check_tip = r->time_rms = NAN;
    r->check_refine = r->refine - 1;
    if (r->check_refine >= 1) {
        sp_mesh c;
        const int cc[3] = {r->check_refine * sp->coarse[0], r->check_refine * sp->coarse[1],
                           r->check_refine * sp->coarse[2]};
        if (load_mesh(sp, 2, cc, &c, err, sizeof err) != 0) {
            fprintf(stderr, "defsim bench: reference check: %s\n", err);
            goto out;
        }
        double wall, mx;
        /* Space: the next coarser quadratic box at the same step. Time: that box at twice the
         * step (fewer whole steps per frame). */
        const double h2 = sp->frame_dt / fmax(1.0, floor(sp->frame_dt / r->h / 2.0 + 0.5));
        if (run_traj(sp, &c, r->backend, 0, r->h, a, &cpu, &wall, NULL, NULL, err, sizeof err) !=
                DEFSIM_OK ||
            run_traj(sp, &c, r->backend, 0, h2, b, &cpu, &wall, NULL, NULL, err, sizeof err) !=
                DEFSIM_OK) {
            fprintf(stderr, "defsim bench: reference check: %s\n", err);
            free_mesh(&c);
            goto out;
        }
        traj_error(sp, a, r->traj, &r->check_rms, &mx, &r->check_tip);
        double tip2;
        if (h2 > 1.5 * r->h) traj_error(sp, b, a, &r->time_rms, &mx, &tip2);
        free_mesh(&c);
    }
    rc = 0;
out:
    if (rc != 0) {
        free(r->traj);
        r->traj = NULL;
    }
    free(a);
    free(b);
    free_mesh(&m);
    return rc;
}

/* The cheapest ok point at each error level, and the cheapest of the other element order. */
static const double levels[] = {1e-1, 5e-2, 2e-2, 1e-2, 5e-3, 2e-3, 1e-3, 5e-4, 2e-4, 1e-4};

static void describe(const point *p, const sp_mesh *meshes, const int *mesh_of, int i, char *buf,
                     size_t n)
{
    char s[64];
    bench_setting(&p[i], s, sizeof s);
    const sp_mesh *m = &meshes[mesh_of[i]];
    snprintf(buf, n, "%s %dx%dx%d, %s, %s", m->order == 2 ? "quadratic" : "linear", m->cells[0],
             m->cells[1], m->cells[2], p[i].backend, s);
}

static int write_front(const spatial *sp, const sref *r, const point *p, const double *tip,
                       const sp_mesh *meshes, const int *mesh_of, int n, const char *path)
{
    FILE *f = fopen(path, "w");
    if (!f) {
        fprintf(stderr, "defsim bench: cannot write %s: %s\n", path, strerror(errno));
        return -1;
    }
    /* The reference's own error, from its check (the box of K - 1) if the error falls as the
     * square of the cell size (quadratic tets measure 2.1 on the cantilever from 6x2x2 to
     * 12x4x4): e_K = check / ((K / (K - 1))^2 - 1). Levels below twice it are not resolved. */
    const double q = r->refine / (double)(r->refine - 1);
    const double ref_err = isfinite(r->check_rms) && r->refine >= 2
                               ? r->check_rms / (q * q - 1.0) : 0.0;
    const double floor_err = 2.0 * ref_err;
    fprintf(f, "# Work-precision against the continuum: %s, T = %g s\n\n", sp->scene_path, sp->T);
    fprintf(f, "Error = RMS over the %d frames up to T and the %d free vertices of the %dx%dx%d "
               "box of the position error against the reference, relative to the body size "
               "(%.4g m). Time = median over repeats of the process CPU time of the stepping loop "
               "(one thread). Reference: quadratic tets on %dx%dx%d cells, %s at h = %.4g s; "
               "against quadratic %dx%dx%d: %.2e (tip %.2e); against itself at twice the step "
               "(on %dx%dx%d): %.2e. The reference's own error, were the error to fall as the square "
               "of the cell size: %.2e; levels below twice it (%.2e) are not resolved.\n\n",
            sp->frames, sp->S, sp->coarse[0], sp->coarse[1], sp->coarse[2], sp->size,
            r->refine * sp->coarse[0], r->refine * sp->coarse[1], r->refine * sp->coarse[2],
            r->backend, r->h, r->check_refine * sp->coarse[0], r->check_refine * sp->coarse[1],
            r->check_refine * sp->coarse[2], r->check_rms, r->check_tip,
            r->check_refine * sp->coarse[0], r->check_refine * sp->coarse[1],
            r->check_refine * sp->coarse[2], r->time_rms, ref_err, floor_err);
    fprintf(f, "| error <= | cheapest | CPU (s) | error | tip error | cheapest of the other "
               "order | its CPU (s) |\n|---|---|---:|---:|---:|---|---:|\n");
    printf("\nFront (RMS position error over frames and points / body size):\n");
    printf("  %-8s  %-52s %10s %10s %9s   %s\n", "level", "cheapest", "cpu_s", "error",
           "tip_err", "cheapest of the other order");
    int owned[3] = {0, 0, 0};
    for (size_t k = 0; k < sizeof levels / sizeof *levels; ++k) {
        const double level = levels[k];
        int best = -1, other = -1;
        for (int i = 0; i < n; ++i)
            if (!strcmp(p[i].status, "ok") && p[i].rms <= level &&
                (best < 0 || p[i].wall < p[best].wall))
                best = i;
        if (best < 0) {
            fprintf(f, "| %.0e | none reached | | | | | |\n", level);
            printf("  %-8.0e  none reached\n", level);
            continue;
        }
        const int ob = meshes[mesh_of[best]].order;
        for (int i = 0; i < n; ++i)
            if (!strcmp(p[i].status, "ok") && p[i].rms <= level &&
                meshes[mesh_of[i]].order != ob && (other < 0 || p[i].wall < p[other].wall))
                other = i;
        const char *note = level < floor_err ? " (not resolved by the reference)" : "";
        if (!*note) owned[ob]++;
        char d1[160], d2[200] = "none";
        describe(p, meshes, mesh_of, best, d1, sizeof d1);
        if (other >= 0) describe(p, meshes, mesh_of, other, d2, sizeof d2);
        fprintf(f, "| %.0e%s | %s | %.4g | %.2e | %.2e | %s | ", level, note, d1, p[best].wall,
                p[best].rms, tip[best], d2);
        if (other >= 0) fprintf(f, "%.4g |\n", p[other].wall);
        else fprintf(f, "|\n");
        printf("  %-8.0e  %-52s %10.4g %10.2e %9.2e   %s", level, d1, p[best].wall, p[best].rms,
               tip[best], d2);
        if (other >= 0) printf(": %.4g s, %.1fx", p[other].wall, p[other].wall / p[best].wall);
        printf("%s\n", note);
    }
    printf("  the reference's own error (order 2 from its check): %.2e; levels owned at or above "
           "twice it: linear %d, quadratic %d\n", ref_err, owned[1], owned[2]);
    fprintf(f, "\nOwned levels (resolved by the reference): linear %d, quadratic %d.\n",
            owned[1], owned[2]);
    fprintf(f, "\nPareto-optimal points (no other point is both faster and more accurate):\n\n");
    for (int i = 0; i < n; ++i)
        if (p[i].pareto) {
            char d[160];
            describe(p, meshes, mesh_of, i, d, sizeof d);
            fprintf(f, "- %s: %.4g s, error %.2e, tip %.2e\n", d, p[i].wall, p[i].rms, tip[i]);
        }
    return fclose(f) == 0 ? 0 : -1;
}

static int write_csv(const point *p, const double *tip, const double *wall,
                     const sp_mesh *meshes, const int *mesh_of, int n, const char *path)
{
    FILE *f = fopen(path, "w");
    if (!f) {
        fprintf(stderr, "defsim bench: cannot write %s: %s\n", path, strerror(errno));
        return -1;
    }
    fprintf(f, "order,cells,vertices,backend,kind,value,cpu_s,wall_s,rms_err,max_err,tip_err,"
               "status,steps,newton_iterations,pareto\n");
    for (int i = 0; i < n; ++i) {
        const sp_mesh *m = &meshes[mesh_of[i]];
        fprintf(f, "%s,%dx%dx%d,%d,%s,%s,%.10g,%.6g,%.6g,%.6e,%.6e,%.6e,%s,%lld,%lld,%d\n",
                m->order == 2 ? "quadratic" : "linear", m->cells[0], m->cells[1], m->cells[2],
                (int)m->nv, p[i].backend, p[i].is_tol ? "tol" : "h", p[i].value, p[i].wall,
                wall[i],
                p[i].rms, p[i].max, tip[i], p[i].status, p[i].steps, p[i].newton, p[i].pareto);
    }
    return fclose(f) == 0 ? 0 : -1;
}

/* Runs one point (repeats, medians: p->wall gets the CPU time's, *wall_out the wall time's);
 * the error from the last repeat. */
static void run_point(const spatial *sp, sp_mesh *m, const sref *r, double *traj, point *p,
                      double *tip, double *wall_out)
{
    double cpus[64], walls[64];
    int nw = 0;
    char err[4400];
    snprintf(p->status, sizeof p->status, "ok");
    p->rms = p->max = p->energy = *tip = NAN;
    for (int k = 0; k < sp->repeats && k < 64; ++k) {
        double cpu, wall;
        const defsim_status st = run_traj(sp, m, p->backend, p->is_tol, p->value, traj, &cpu,
                                          &wall, &p->steps, &p->newton, err, sizeof err);
        if (st != DEFSIM_OK) {
            snprintf(p->status, sizeof p->status, "%s",
                     st == DEFSIM_ERR_UNSTABLE        ? "unstable"
                     : st == DEFSIM_ERR_NOT_CONVERGED ? "not_converged"
                                                      : defsim_status_string(st));
            p->wall = cpu;
            *wall_out = wall;
            return;
        }
        cpus[nw] = cpu;
        walls[nw++] = wall;
    }
    p->wall = bench_median(cpus, nw);
    *wall_out = bench_median(walls, nw);
    traj_error(sp, traj, r->traj, &p->rms, &p->max, tip);
    if (!isfinite(p->rms) || p->rms > DIVERGED_RMS) snprintf(p->status, sizeof p->status,
                                                             "diverged");
}

/* The cells of a generated box: one less than the distinct coordinates along each axis. */
static int box_cells(const defsim_mesh *g, int cells[3])
{
    double *v = malloc((size_t)g->vertex_count * sizeof *v);
    if (!v) return -1;
    for (int c = 0; c < 3; ++c) {
        for (int32_t i = 0; i < g->vertex_count; ++i) v[i] = g->positions[3 * i + c];
        bench_median(v, g->vertex_count);   /* sorts v */
        int d = 0;
        for (int32_t i = 0; i < g->vertex_count; ++i)
            if (i == 0 || v[i] > v[i - 1] + 1e-12 * (fabs(v[i]) + 1.0)) ++d;
        cells[c] = d > 1 ? d - 1 : 1;
    }
    free(v);
    return 0;
}

int defsim_tool_bench_spatial(int argc, char **argv)
{
    const char *out_dir = NULL, *python = getenv("DEFSIM_PYTHON");
    const char *script = DEFSIM_BENCH_PLOT_SCRIPT, *cells_s = NULL, *lin_s = "1,2,3,4";
    const char *quad_s = "1,2,3", *ref_backend = "velocity_verlet", *h_s = NULL, *tol_s = NULL;
    const char *backend_s = "velocity_verlet,newmark,newton_cholmod";
    double T = 0.0, ref_h = 0.0;
    int repeats = 3, threads = 1, no_plot = 0, ref_refine = 0, is_spatial = 0, implicit_max = 0;
    const char *sets[MAX_SETS];
    cli_list set_list = {sets, 0, MAX_SETS};
    const cli_opt opts[] = {
        {"spatial", CLI_FLAG, &is_spatial, 0, 0},
        {"cells", CLI_STRING, &cells_s, 0, 0},
        {"linear", CLI_STRING, &lin_s, 0, 0},
        {"quadratic", CLI_STRING, &quad_s, 0, 0},
        {"reference-refine", CLI_INT, &ref_refine, 1, 64},
        {"reference-backend", CLI_STRING, &ref_backend, 0, 0},
        {"reference-h", CLI_POSITIVE, &ref_h, 0, 0},
        {"backends", CLI_STRING, &backend_s, 0, 0},
        {"h", CLI_STRING, &h_s, 0, 0},
        {"implicit-max-vertices", CLI_INT, &implicit_max, 1, 1e9},
        {"tol", CLI_STRING, &tol_s, 0, 0},
        {"time", CLI_POSITIVE, &T, 0, 0},
        {"repeats", CLI_INT, &repeats, 1, 64},
        {"threads", CLI_INT, &threads, 0, 1024},
        {"set", CLI_LIST, &set_list, 0, 0},
        {"out", CLI_STRING, &out_dir, 0, 0},
        {"python", CLI_STRING, &python, 0, 0},
        {"plot-script", CLI_STRING, &script, 0, 0},
        {"no-plot", CLI_FLAG, &no_plot, 0, 0},
        {0}};
    static const cli_tool tool = {"defsim bench --spatial", usage, NULL, ""};
    int first;
    const int parsed = cli_parse(&tool, opts, argc, argv, &first);
    if (parsed >= 0) return parsed;
    if (first + 1 < argc) return cli_fail(&tool, "one scene file at a time");
    if (first >= argc) return cli_fail(&tool, "no scene file");
    if (!python || !python[0]) python = "python3";
    for (int i = 0; i < set_list.count; ++i)
        if (!strchr(sets[i], '=')) return cli_fail(&tool, "--set KEY=VALUE: %s", sets[i]);

    spatial sp;
    memset(&sp, 0, sizeof sp);
    sp.scene_path = argv[first];
    for (int i = 0; i < set_list.count; ++i) sp.sets[sp.nsets++] = sets[i];
    sp.repeats = repeats;
    sp.threads = threads;
    int lin[MAX_LIST], quad[MAX_LIST], nlin, nquad;
    if ((nlin = parse_refine(lin_s, lin)) < 0)
        return cli_fail(&tool, "--linear: whole numbers 1..64 or none: %s", lin_s);
    if ((nquad = parse_refine(quad_s, quad)) < 0)
        return cli_fail(&tool, "--quadratic: whole numbers 1..64 or none: %s", quad_s);
    if (nlin + nquad == 0) return cli_fail(&tool, "--linear and --quadratic are both none");
    double hs[MAX_VALUES], tols[MAX_VALUES] = {1e-3, 1e-4, 1e-5};
    int nh = 0, ntol = 3;
    if (h_s && (nh = bench_parse_list(h_s, hs, MAX_VALUES)) <= 0)
        return cli_fail(&tool, "--h: need up to %d positive numbers: %s", MAX_VALUES, h_s);
    if (tol_s && (ntol = bench_parse_list(tol_s, tols, MAX_VALUES)) <= 0)
        return cli_fail(&tool, "--tol: need up to %d positive numbers: %s", MAX_VALUES, tol_s);
    const char *backends[MAX_BACKENDS];
    char names[MAX_BACKENDS][64];
    int nb = 0;
    for (const char *q = backend_s; *q;) {
        const size_t len = strcspn(q, ",");
        if (len == 0 || len >= 64 || nb == MAX_BACKENDS)
            return cli_fail(&tool, "--backends: bad list: %s", backend_s);
        memcpy(names[nb], q, len);
        names[nb][len] = '\0';
        backends[nb] = names[nb];
        ++nb;
        q += len;
        if (*q == ',') ++q;
    }
    int finest = 0;
    for (int i = 0; i < nlin; ++i) finest = lin[i] > finest ? lin[i] : finest;
    for (int i = 0; i < nquad; ++i) finest = quad[i] > finest ? quad[i] : finest;
    if (ref_refine == 0) ref_refine = finest + 1;
    for (int i = 0; i < nquad; ++i)
        if (quad[i] >= ref_refine)
            return cli_fail(&tool, "--quadratic %d: the reference (quadratic, refinement %d) "
                            "must be finer than every quadratic mesh swept", quad[i],
                            ref_refine);

    int rc = 1;
    char err[4400];
    sp_mesh *meshes = NULL;
    point *pts = NULL;
    int *mesh_of = NULL;
    double *tip = NULL, *wall = NULL, *traj = NULL;
    sref ref;
    memset(&ref, 0, sizeof ref);
    int nmesh = 0, npts = 0;

    /* The scene as given: its frame interval, end time, body size and cells. */
    sp_mesh m0;
    {
        scene s0;
        if (scene_load(&s0, sp.scene_path, sp.sets, sp.nsets) != 0) {
            fprintf(stderr, "defsim bench: %s\n", s0.error);
            return 1;
        }
        sp.frame_dt = s0.h * s0.frame_steps;
        /* Default: the whole frames within min(0.5 s, the duration), at least one. */
        sp.T = T > 0.0 ? T
                       : sp.frame_dt * fmax(1.0, floor(fmin(0.5, s0.duration) / sp.frame_dt +
                                                       1e-9));
        scene_free(&s0);
    }
    sp.frames = (int)floor(sp.T / sp.frame_dt + 0.5);
    if (sp.frames < 1 || fabs(sp.frames * sp.frame_dt - sp.T) > 1e-9 * sp.T)
        return cli_fail(&tool, "--time %g: must be a whole number of frames (%g s)", sp.T,
                        sp.frame_dt);
    if (cells_s) {
        if (parse_cells(cells_s, sp.coarse) != 0)
            return cli_fail(&tool, "--cells: expected NXxNYxNZ (e.g. 6x2x2): %s", cells_s);
    } else {
        /* The scene's own box (loaded with its cells: sets that name none change nothing). */
        scene s1;
        if (scene_load(&s1, sp.scene_path, sp.sets, sp.nsets) != 0) {
            fprintf(stderr, "defsim bench: %s\n", s1.error);
            return 1;
        }
        const int bad = s1.nbodies != 1 || box_cells(&s1.bodies[0].mesh, sp.coarse) != 0;
        /* A quadratic box has a vertex at every edge's middle too. */
        if (!bad && s1.bodies[0].mesh.tet_nodes == 10)
            for (int c = 0; c < 3; ++c) sp.coarse[c] = sp.coarse[c] / 2 > 0 ? sp.coarse[c] / 2 : 1;
        scene_free(&s1);
        if (bad) {
            fprintf(stderr, "defsim bench: %s: --spatial needs a scene of one body on a "
                            "generated box\n", sp.scene_path);
            return 1;
        }
        if (sp.coarse[0] % 2 == 0 && sp.coarse[1] % 2 == 0 && sp.coarse[2] % 2 == 0)
            for (int c = 0; c < 3; ++c) sp.coarse[c] /= 2;
    }
    /* The coarse linear box: the body size and the sample points. */
    if (load_mesh(&sp, 1, sp.coarse, &m0, err, sizeof err) != 0) {
        fprintf(stderr, "defsim bench: %s\n", err);
        return 1;
    }
    {
        const defsim_mesh *g = &m0.s.bodies[0].mesh;
        double lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
        for (int32_t v = 0; v < g->vertex_count; ++v)
            for (int c = 0; c < 3; ++c) {
                lo[c] = fmin(lo[c], g->positions[3 * v + c]);
                hi[c] = fmax(hi[c], g->positions[3 * v + c]);
            }
        sp.size = sqrt((hi[0] - lo[0]) * (hi[0] - lo[0]) + (hi[1] - lo[1]) * (hi[1] - lo[1]) +
                       (hi[2] - lo[2]) * (hi[2] - lo[2]));
        unsigned char *pinned = calloc((size_t)g->vertex_count, 1);
        sp.rest = malloc(3 * ((size_t)g->vertex_count + 1) * sizeof *sp.rest);
        if (!pinned || !sp.rest) {
            free(pinned);
            free_mesh(&m0);
            fprintf(stderr, "defsim bench: out of memory\n");
            goto done;
        }
        for (int32_t k = 0; k < m0.s.bodies[0].npins; ++k) pinned[m0.s.bodies[0].pins[k]] = 1;
        for (int32_t v = 0; v < g->vertex_count; ++v)
            if (!pinned[v]) {
                memcpy(sp.rest + 3 * sp.S, g->positions + 3 * v, 3 * sizeof *sp.rest);
                ++sp.S;
            }
        const int32_t probe = m0.s.bodies[0].probe;
        sp.has_probe = probe >= 0;
        if (sp.has_probe) memcpy(sp.rest + 3 * sp.S, g->positions + 3 * probe, 3 * sizeof *sp.rest);
        else sp.rest[3 * sp.S] = sp.rest[3 * sp.S + 1] = sp.rest[3 * sp.S + 2] = NAN;
        free(pinned);
        free_mesh(&m0);
    }
    if (sp.S == 0) {
        fprintf(stderr, "defsim bench: the coarse box has no free vertex\n");
        goto done;
    }

    char dir[1024], path[1400], key[17];
    {
        scene s2;
        if (scene_load(&s2, sp.scene_path, sp.sets, sp.nsets) != 0) goto done;
        if (out_dir) snprintf(dir, sizeof dir, "%s", out_dir);
        else snprintf(dir, sizeof dir, "bench_%s", s2.name);
        snprintf(path, sizeof path, "%s/%s_spatial_reference_", dir, s2.name);
        scene_free(&s2);
    }
    if (tools_make_dirs(dir) != 0) {
        fprintf(stderr, "defsim bench: cannot create %s: %s\n", dir, strerror(errno));
        goto done;
    }
    if (reference_key(&sp, ref_refine, ref_backend, ref_h, key, err, sizeof err) != 0) {
        fprintf(stderr, "defsim bench: %s\n", err);
        goto done;
    }
    strncat(path, key, sizeof path - strlen(path) - 5);
    strcat(path, ".txt");
    printf("defsim bench --spatial: %s, T = %g s (%d frames), body size %.4g m, %d sample points "
           "(the free vertices of the %dx%dx%d box), %d repeat(s)\n", sp.scene_path, sp.T,
           sp.frames, sp.size, sp.S, sp.coarse[0], sp.coarse[1], sp.coarse[2], sp.repeats);
    ref.refine = ref_refine;
    snprintf(ref.backend, sizeof ref.backend, "%s", ref_backend);
    const int got = read_reference(&sp, path, key, &ref);
    if (got < 0) goto done;
    if (got == 1) {
        if (compute_reference(&sp, &ref, ref_h) != 0) goto done;
        if (write_reference(&sp, path, key, &ref) != 0) goto done;
        printf("reference: %.1f s, written to %s\n", ref.wall, path);
    } else {
        printf("reference: cached %s\n", path);
    }
    printf("reference check: quadratic %dx%dx%d against the reference: RMS %.3e of the body "
           "size, tip %.3e of its displacement; the same at twice the step: RMS %.3e\n",
           ref.check_refine * sp.coarse[0], ref.check_refine * sp.coarse[1],
           ref.check_refine * sp.coarse[2], ref.check_rms, ref.check_tip, ref.time_rms);

    /* The sweep: meshes, then backends, then steps. */
    const int nm = nlin + nquad;
    meshes = calloc((size_t)nm, sizeof *meshes);
    pts = calloc((size_t)nm * MAX_BACKENDS * MAX_VALUES, sizeof *pts);
    mesh_of = calloc((size_t)nm * MAX_BACKENDS * MAX_VALUES, sizeof *mesh_of);
    tip = calloc((size_t)nm * MAX_BACKENDS * MAX_VALUES, sizeof *tip);
    wall = calloc((size_t)nm * MAX_BACKENDS * MAX_VALUES, sizeof *wall);
    traj = malloc(traj_len(&sp) * sizeof *traj);
    if (!meshes || !pts || !mesh_of || !tip || !wall || !traj) {
        fprintf(stderr, "defsim bench: out of memory\n");
        goto done;
    }
    printf("\n%-9s %-8s %7s %-15s %-4s %10s %10s %10s %10s %8s  %s\n", "order", "cells", "verts",
           "backend", "kind", "value", "cpu_s", "rms_err", "max_err", "tip_err", "status");
    for (int mi = 0; mi < nm; ++mi) {
        const int order = mi < nlin ? 1 : 2, k = mi < nlin ? lin[mi] : quad[mi - nlin];
        const int cells[3] = {k * sp.coarse[0], k * sp.coarse[1], k * sp.coarse[2]};
        sp_mesh *m = &meshes[nmesh];
        if (load_mesh(&sp, order, cells, m, err, sizeof err) != 0) {
            fprintf(stderr, "defsim bench: %s\n", err);
            goto done;
        }
        ++nmesh;
        for (int bi = 0; bi < nb; ++bi) {
            const int is_tol = bench_swept_by_tolerance(backends[bi]);
            double vals[MAX_VALUES];
            int nv = 0;
            if (is_tol) {
                for (int j = 0; j < ntol; ++j) vals[nv++] = tols[j];
            } else {
                double hs_max = INFINITY;
                const defsim_status st = stable_step(&sp, m, backends[bi], &hs_max);
                if (st != DEFSIM_OK) {
                    printf("note: %s skipped: %s: %s\n", backends[bi], defsim_status_string(st),
                           m->s.error[0] ? m->s.error : defsim_last_error());
                    break;
                }
                const double lim = STABLE_FRACTION * hs_max;
                if (isfinite(lim)) {
                    /* Explicit: at the stable step, and at the listed steps below it. */
                    vals[nv++] = frame_step(&sp, fmin(lim, sp.frame_dt));
                    for (int j = 0; j < nh && nv < MAX_VALUES; ++j)
                        if (frame_step(&sp, fmin(hs[j], sp.frame_dt)) < 0.999 * vals[0])
                            vals[nv++] = frame_step(&sp, fmin(hs[j], sp.frame_dt));
                } else if (implicit_max > 0 && m->nv > implicit_max) {
                    printf("note: %s skipped on the %s %dx%dx%d box: %d vertices, above "
                           "--implicit-max-vertices %d\n", backends[bi],
                           order == 2 ? "quadratic" : "linear", cells[0], cells[1], cells[2],
                           (int)m->nv, implicit_max);
                } else if (nh > 0) {
                    for (int j = 0; j < nh; ++j)
                        vals[nv++] = frame_step(&sp, fmin(hs[j], sp.frame_dt));
                } else {
                    for (int j = 0; j < 4; ++j) vals[nv++] = sp.frame_dt / (double)(1 << j);
                }
            }
            for (int j = 0; j < nv; ++j) {
                point *p = &pts[npts];
                p->backend = backends[bi];
                p->is_tol = is_tol;
                p->value = vals[j];
                mesh_of[npts] = nmesh - 1;
                run_point(&sp, m, &ref, traj, p, &tip[npts], &wall[npts]);
                char cs[32];
                snprintf(cs, sizeof cs, "%dx%dx%d", cells[0], cells[1], cells[2]);
                printf("%-9s %-8s %7d %-15s %-4s %10.4g %10.4g %10.3e %10.3e %8.4f  %s\n",
                       order == 2 ? "quadratic" : "linear", cs, (int)m->nv, p->backend,
                       is_tol ? "tol" : "h", p->value, p->wall, p->rms, p->max, tip[npts],
                       p->status);
                fflush(stdout);
                ++npts;
            }
        }
        /* The mesh's scene is kept for the table's names; its world is gone. */
    }
    bench_mark_pareto(pts, npts);
    char csv[1500], png[1500], md[1500], title[512];
    {
        scene s3;
        if (scene_load(&s3, sp.scene_path, sp.sets, sp.nsets) != 0) goto done;
        snprintf(csv, sizeof csv, "%s/%s_spatial.csv", dir, s3.name);
        snprintf(png, sizeof png, "%s/%s_spatial.png", dir, s3.name);
        snprintf(md, sizeof md, "%s/%s_spatial_front.md", dir, s3.name);
        snprintf(title, sizeof title, "%s against the continuum (quadratic %dx%dx%d), T = %g s",
                 s3.name, ref.refine * sp.coarse[0], ref.refine * sp.coarse[1],
                 ref.refine * sp.coarse[2], sp.T);
        scene_free(&s3);
    }
    if (write_csv(pts, tip, wall, meshes, mesh_of, npts, csv) != 0 ||
        write_front(&sp, &ref, pts, tip, meshes, mesh_of, npts, md) != 0)
        goto done;
    printf("\nwrote %s, %s\n", csv, md);
    if (!no_plot) bench_plot(python, script, csv, png, title);
    rc = 0;
done:
    for (int i = 0; i < nmesh; ++i) free_mesh(&meshes[i]);
    free(meshes);
    free(pts);
    free(mesh_of);
    free(tip);
    free(wall);
    free(traj);
    free(ref.traj);
    free(sp.rest);
    return rc;
}
