/* SPDX-License-Identifier: MIT */
/*
 * defsim-bench-contact-phases: each body-contact phase timed alone on saved states (issue 30),
 * so that the same states can be timed by IPC Toolkit (../shared/peers/contact/ipc_probe.py) and
 * the two compared phase by phase (tools/contact_vs_ipctk.sh, docs/contact-scale.md).
 *
 *   defsim-bench-contact-phases --out DIR [SCENE] [--cells N] [--steps S] [--repeat R]
 *                               [--no-time]
 *   defsim-bench-contact-phases --time DIR --step K [--repeat R] [--only KEY]
 *
 * The first form runs SCENE (default tests/scenes/cloth_fold.json; --cells N makes its first body
 * an N x N cloth, as defsim-bench-body-contact does) for S steps (default the scene's length) with
 * its backend on one thread, and writes into DIR, in ipc_probe's format (its README):
 *  - mesh.txt: `nv nf ne dhat kappa`, the contact surface's triangles and edges (world vertex
 *    indices), dhat (m) as the barrier uses it, and kappa = khat times the mean mass of the
 *    surface's vertices (our barrier's stiffness is khat times the mean mass of each pair's
 *    vertices: for a cloth of equal masses the two agree but at the border);
 *  - x_0.bin, the rest shape; x_<n>.bin, the positions at the start of step n (raw float64) and
 *    v_<n>.bin the velocities, for the "impact" state (the first step that starts with a pair of
 *    the bodies' surfaces within dhat) and the "settled" one (the last step of the run), each
 *    with x_<n+1>.bin for CCD along x_n -> x_n+1;
 *  - run.txt: the scene, cells and the two steps;
 * then times both states as the second form does (unless --no-time).
 *
 * The second form builds the world of DIR/run.txt again, steps it once (the plan), loads x_K and
 * v_K and times, one thread, process CPU time, median of R rounds (default 5) of an inner loop of
 * at least 2 ms (as ipc_probe.py does):
 *  - cand: the broad phase for the barrier (defsim__body_contact_candidates at x_K);
 *  - collisions_from_cand: the constraint set from those candidates (defsim__body_contact_build:
 *    contacts merged into vertex-vertex, edge-vertex, face-vertex, edge-edge);
 *  - energy, gradient (the forces), hessian_psd (every contact's PSD-projected Hessian handed to
 *    a callback that copies it into a triplet buffer: no global assembly) at x_K, on that set
 *    (as ipctk's potentials take a built collision set);
 *  - ccd_accd_narrow: defsim__body_contact_max_step along x_K -> x_K+1 on candidates that cover
 *    the swept boxes (it also builds the constraint set at the step's end, as in a solve);
 *    ccd_accd_full: the same with its swept broad phase run first;
 * with friction off (a barrier alone, as ipctk's BarrierPotential), and prints one JSON line with
 * the same keys as ipc_probe's where the phase is the same: counts (candidates by kind, the
 * constraint set's contacts by type, and the candidates within dhat before merging),
 * alpha_accd, and peak_rss_mb (getrusage ru_maxrss of the whole process). --only KEY times that
 * phase alone (the others print 0), for a profiler.
 *
 * Internal functions: links the static library. A tool, not a test.
 */
#include "cli.h"
#include "clock.h"
#include "scene.h"

#include "body_contact.h"
#include "contact_pair.h"
#include "world.h"

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <unistd.h>

#ifndef DEFSIM_BENCH_SCENES
#define DEFSIM_BENCH_SCENES "tests/scenes"
#endif

/* A run's description (DIR/run.txt). */
typedef struct run_info {
    char scene[1024];
    int cells, impact, settled;
} run_info;

static double median(double *v, int n)
{
    for (int i = 1; i < n; ++i)
        for (int j = i; j > 0 && v[j] < v[j - 1]; --j) {
            const double t = v[j];
            v[j] = v[j - 1];
            v[j - 1] = t;
        }
    return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

/* Loads and builds the scene with cells N (0: the scene's) on one thread, with the scene's
 * iteration limit raised as defsim-bench-body-contact does. */
static int open_world(scene *s, defsim_world **w, const char *path, int cells)
{
    char cell_set[64];
    const char *sets[2] = {"world.threads=1", cell_set};
    int nsets = 1;
    if (cells > 0) {
        snprintf(cell_set, sizeof cell_set, "bodies.0.mesh.cells=[%d,%d]", cells, cells);
        nsets = 2;
    }
    if (scene_load(s, path, sets, nsets) != 0) {
        fprintf(stderr, "%s\n", s->error);
        return -1;
    }
    if (scene_build(s, w) != DEFSIM_OK) {
        fprintf(stderr, "%s\n", s->error);
        scene_free(s);
        return -1;
    }
    char opt[96];
    snprintf(opt, sizeof opt, "%s.max_iterations", (*w)->backend.name);
    defsim_world_set_option(*w, opt, "200");
    return 0;
}

static int write_vec(const char *dir, const char *what, int n, const double *x, int64_t count)
{
    char path[1200];
    snprintf(path, sizeof path, "%s/%s_%d.bin", dir, what, n);
    FILE *f = fopen(path, "wb");
    if (!f || fwrite(x, sizeof *x, (size_t)count, f) != (size_t)count) {
        fprintf(stderr, "%s: %s\n", path, strerror(errno));
        if (f) fclose(f);
        return -1;
    }
    return fclose(f) == 0 ? 0 : -1;
}

static int read_vec(const char *dir, const char *what, int n, double *x, int64_t count)
{
    char path[1200];
    snprintf(path, sizeof path, "%s/%s_%d.bin", dir, what, n);
    FILE *f = fopen(path, "rb");
    if (!f || fread(x, sizeof *x, (size_t)count, f) != (size_t)count) {
        fprintf(stderr, "%s: missing or short\n", path);
        if (f) fclose(f);
        return -1;
    }
    fclose(f);
    return 0;
}

/* mesh.txt from the body contact's surfaces (planned by the world's steps). */
static int write_mesh(const char *dir, const defsim_world *w)
{
    const defsim__body_contact *bc = &w->body_contact;
    double m = 0.0;
    for (int32_t k = 0; k < bc->nvert; ++k) m += w->sys.mass[bc->vert[k]];
    const double kappa = bc->nvert > 0 ? bc->khat * m / bc->nvert : 0.0;
    char path[1200];
    snprintf(path, sizeof path, "%s/mesh.txt", dir);
    FILE *f = fopen(path, "w");
    if (!f) {
        fprintf(stderr, "%s: %s\n", path, strerror(errno));
        return -1;
    }
    fprintf(f, "%d %d %d %.17g %.17g\n", (int)w->nv, (int)bc->nface, (int)bc->nedge, bc->dhat,
            kappa);
    for (int32_t i = 0; i < bc->nface; ++i)
        fprintf(f, "%d %d %d\n", (int)bc->face[3 * i], (int)bc->face[3 * i + 1],
                (int)bc->face[3 * i + 2]);
    for (int32_t i = 0; i < bc->nedge; ++i)
        fprintf(f, "%d %d\n", (int)bc->edge[2 * i], (int)bc->edge[2 * i + 1]);
    return fclose(f) == 0 ? 0 : -1;
}

static int read_run(const char *dir, run_info *r)
{
    char path[1200];
    snprintf(path, sizeof path, "%s/run.txt", dir);
    FILE *f = fopen(path, "r");
    if (!f) {
        fprintf(stderr, "%s: %s\n", path, strerror(errno));
        return -1;
    }
    const int n = fscanf(f, "scene %1023s cells %d impact %d settled %d", r->scene, &r->cells,
                         &r->impact, &r->settled);
    fclose(f);
    if (n != 4) {
        fprintf(stderr, "%s: unreadable\n", path);
        return -1;
    }
    return 0;
}

/* ------------------------------------------------------------------------------------------ */
/* Timing one state */

/* What the phases share: the world (planned), its body contact, the state and its step. */
typedef struct phase_ctx {
    defsim_world *w;
    defsim__body_contact *bc;
    const double *x, *v, *dx;
    double h;
    double *f;                  /* 3 nv: forces */
    double *trip;               /* the Hessian's blocks (triplet buffer) */
    int64_t ntrip, cap_trip;
    double sink;                /* keeps the results live */
    defsim_status st;
} phase_ctx;

/* The broad phase: the step's begin with its candidate reuse defeated (as a step that moved). */
static void phase_begin(phase_ctx *c)
{
    defsim_world *w = c->w;
    c->bc->have_pairs = 0;
    const defsim__settings *o = &w->set;
    const defsim_status st = defsim__body_contact_begin(
        c->bc, &w->sys, w->bodies.b, w->bodies.n, o->contact_dhat, o->contact_kappa,
        o->friction_eps_v, c->x, c->v, c->h, w->contact.stat, w->msg);
    if (st != DEFSIM_OK) c->st = st;
    c->bc->npend = 0;
}

/* The barrier's broad phase at x. */
static void phase_cand(phase_ctx *c)
{
    const defsim_status st = defsim__body_contact_candidates(c->bc, c->x);
    if (st != DEFSIM_OK) c->st = st;
}

/* The constraint set at x from the candidates. */
static void phase_build(phase_ctx *c)
{
    const defsim_status st = defsim__body_contact_build(c->bc, c->x);
    if (st != DEFSIM_OK) c->st = st;
}

static void phase_energy(phase_ctx *c)
{
    c->sink += defsim__body_contact_energy(c->bc, c->x);
}

static void phase_gradient(phase_ctx *c)
{
    memset(c->f, 0, 3 * (size_t)c->w->nv * sizeof *c->f);
    const defsim_status st = defsim__body_contact_forces(c->bc, c->x, c->f);
    if (st != DEFSIM_OK) c->st = st;
    c->sink += c->f[0];
}

/* The Hessian callback: copies the block (and its vertices) into the triplet buffer. */
static void keep_block(void *ctx, const int32_t *idx, int n, const double *H)
{
    phase_ctx *c = ctx;
    const int64_t need = c->ntrip + 9 * (int64_t)n * n + n;
    if (need > c->cap_trip) {
        c->st = DEFSIM_ERR_OUT_OF_MEMORY;   /* sized before timing: not reached */
        return;
    }
    for (int i = 0; i < n; ++i) c->trip[c->ntrip++] = (double)idx[i];
    memcpy(c->trip + c->ntrip, H, 9 * (size_t)n * n * sizeof *H);
    c->ntrip += 9 * (int64_t)n * n;
}

static void phase_hessian(phase_ctx *c)
{
    c->ntrip = 0;
    defsim__body_contact_hessians(c->bc, c->x, keep_block, c);
    c->sink += (double)c->ntrip;
}

static void phase_ccd(phase_ctx *c)
{
    c->sink += defsim__body_contact_max_step(c->bc, c->x, c->dx);
    c->bc->npend = 0;
}

static void phase_ccd_full(phase_ctx *c)
{
    c->bc->have_pairs = 0;
    phase_ccd(c);
}

/* --only KEY: the one phase to time (for a profiler); the others print 0. */
static const char *only_phase;

/* Median ms of `repeat` rounds of an inner loop of at least 2 ms (ipc_probe.py's harness). */
static double time_phase(phase_ctx *c, void (*fn)(phase_ctx *), int repeat, const char *key)
{
    if (only_phase && strcmp(only_phase, key)) return 0.0;
    fn(c);
    int inner = 1;
    for (;;) {
        const double t0 = tools_cpu_now();
        for (int i = 0; i < inner; ++i) fn(c);
        if (tools_cpu_now() - t0 > 2e-3 || inner > 100000) break;
        inner *= 2;
    }
    double r[99];
    for (int k = 0; k < repeat; ++k) {
        const double t0 = tools_cpu_now();
        for (int i = 0; i < inner; ++i) fn(c);
        r[k] = 1e3 * (tools_cpu_now() - t0) / inner;
    }
    return median(r, repeat);
}

/* The global vertices of candidate q (body_contact.c's order: the vertex or first edge first). */
static int pair_nodes(const defsim__body_contact *bc, int32_t q, int32_t idx[4])
{
    const int32_t a = bc->pa[q], b = bc->pb[q];
    if (bc->kind[q] == DEFSIM__BC_PT) {
        idx[0] = bc->vert[a];
        for (int k = 0; k < 3; ++k) idx[1 + k] = bc->face[3 * (int64_t)b + k];
        return 4;
    }
    if (bc->kind[q] == DEFSIM__BC_EE) {
        for (int k = 0; k < 2; ++k) {
            idx[k] = bc->edge[2 * (int64_t)a + k];
            idx[2 + k] = bc->edge[2 * (int64_t)b + k];
        }
        return 4;
    }
    idx[0] = bc->vert[a];
    idx[1] = bc->edge[2 * (int64_t)b];
    idx[2] = bc->edge[2 * (int64_t)b + 1];
    return 3;
}

/* Candidates by kind (vertex-triangle, edge-edge, vertex-edge), and those within dhat at x. */
static void count_pairs(const defsim__body_contact *bc, const double *x, int64_t cand[3],
                        int64_t near[3])
{
    for (int k = 0; k < 3; ++k) cand[k] = near[k] = 0;
    for (int32_t q = 0; q < bc->npair; ++q) {
        int32_t idx[4];
        const int n = pair_nodes(bc, q, idx);
        double X[12];
        for (int i = 0; i < n; ++i) memcpy(X + 3 * i, x + 3 * (int64_t)idx[i], 3 * sizeof *X);
        const int kind = bc->kind[q];
        const int type = kind == DEFSIM__BC_PT ? DEFSIM__C_FV
                         : kind == DEFSIM__BC_EE ? DEFSIM__C_EE : DEFSIM__C_EV;
        ++cand[kind];
        near[kind] += defsim__contact_dist2(type, X, NULL, NULL) < bc->dhat * bc->dhat;
    }
}

/* Times the phases on state `step` of DIR and prints one JSON line; 0 or -1. */
static int time_state(const char *dir, int step, int repeat)
{
    run_info ri;
    if (read_run(dir, &ri) != 0) return -1;
    scene s;
    defsim_world *w = NULL;
    if (open_world(&s, &w, ri.scene, ri.cells) != 0) return -1;
    /* one step plans the world (system, pattern, surfaces) */
    if (scene_step(&s, w, s.h) != DEFSIM_OK) {
        fprintf(stderr, "planning step: %s\n", defsim_world_last_error(w));
        return -1;
    }
    const int64_t n3 = 3 * (int64_t)w->nv;
    double *x = malloc((size_t)n3 * sizeof *x), *x1 = malloc((size_t)n3 * sizeof *x1);
    double *v = malloc((size_t)n3 * sizeof *v), *dx = malloc((size_t)n3 * sizeof *dx);
    double *f = malloc((size_t)n3 * sizeof *f);
    if (!x || !x1 || !v || !dx || !f) return -1;
    if (read_vec(dir, "x", step, x, n3) || read_vec(dir, "x", step + 1, x1, n3) ||
        read_vec(dir, "v", step, v, n3))
        return -1;
    for (int64_t i = 0; i < n3; ++i) dx[i] = x1[i] - x[i];
    /* a barrier alone, as ipctk's BarrierPotential: no lagged friction pairs */
    for (int32_t b = 0; b < w->bodies.n; ++b) w->bodies.b[b].friction = 0.0;
    memcpy(w->state.x, x, (size_t)n3 * sizeof *x);
    memcpy(w->state.v, v, (size_t)n3 * sizeof *v);
    phase_ctx c = {.w = w, .bc = &w->body_contact, .x = x, .v = v, .dx = dx, .h = s.h, .f = f};
    phase_begin(&c);
    if (c.st != DEFSIM_OK) {
        fprintf(stderr, "state %d: %s\n", step, defsim_world_last_error(w));
        return -1;
    }
    defsim__body_contact *bc = c.bc;
    int64_t cand[3], near[3];
    if (defsim__body_contact_candidates(bc, x) != DEFSIM_OK) return -1;
    c.cap_trip = (int64_t)bc->npair * (144 + 4) + 1;
    c.trip = malloc((size_t)c.cap_trip * sizeof *c.trip);
    if (!c.trip) return -1;
    const double t_cand = time_phase(&c, phase_cand, repeat, "cand");
    count_pairs(bc, x, cand, near);
    const double t_build = time_phase(&c, phase_build, repeat, "collisions_from_cand");
    const int64_t ncon = bc->ncon;
    int64_t ctype[4];
    for (int k = 0; k < 4; ++k) ctype[k] = bc->ncon_type[k];
    const double t_energy = time_phase(&c, phase_energy, repeat, "energy");
    const double t_grad = time_phase(&c, phase_gradient, repeat, "gradient");
    const double t_hess = time_phase(&c, phase_hessian, repeat, "hessian_psd");
    const double energy = defsim__body_contact_energy(bc, x);
    c.bc->have_pairs = 0;
    const double alpha = defsim__body_contact_max_step(bc, x, dx);
    bc->npend = 0;
    const int64_t ccd_cand = bc->npair;
    const double t_ccd = time_phase(&c, phase_ccd, repeat, "ccd_accd_narrow");
    const double t_ccd_full = time_phase(&c, phase_ccd_full, repeat, "ccd_accd_full");
    if (c.st != DEFSIM_OK) {
        fprintf(stderr, "state %d: a phase failed: %s\n", step, defsim_status_string(c.st));
        return -1;
    }
    struct rusage ru;
    getrusage(RUSAGE_SELF, &ru);
    printf("{\"tool\": \"defsim\", \"nv\": %d, \"cells\": %d, \"step\": %d, \"threads\": 1, "
           "\"dhat\": %.6g, \"cand\": %.6g, \"collisions_from_cand\": %.6g, \"energy\": %.6g, "
           "\"gradient\": %.6g, \"hessian_psd\": %.6g, \"ccd_accd_full\": %.6g, "
           "\"ccd_accd_narrow\": %.6g, \"alpha_accd\": %.6g, \"candidates\": %lld, "
           "\"candidates_fv_ee_ev\": [%lld, %lld, %lld], \"collisions\": %lld, "
           "\"vv_ev_ee_fv\": [%lld, %lld, %lld, %lld], \"pairs_within_dhat\": %lld, "
           "\"ccd_candidates\": %lld, "
           "\"energy_J\": %.9g, \"peak_rss_mb\": %.1f, \"repeat\": %d}\n",
           (int)w->nv, ri.cells, step, bc->dhat, t_cand, t_build, t_energy, t_grad, t_hess,
           t_ccd_full, t_ccd, alpha, (long long)(cand[0] + cand[1] + cand[2]),
           (long long)cand[0], (long long)cand[1], (long long)cand[2], (long long)ncon,
           (long long)ctype[DEFSIM__C_VV], (long long)ctype[DEFSIM__C_EV],
           (long long)ctype[DEFSIM__C_EE], (long long)ctype[DEFSIM__C_FV],
           (long long)(near[0] + near[1] + near[2]), (long long)ccd_cand,
           energy, (double)ru.ru_maxrss / 1024.0, repeat);
    fflush(stdout);
    free(c.trip);
    free(x);
    free(x1);
    free(v);
    free(dx);
    free(f);
    defsim_world_destroy(w);
    scene_free(&s);
    return 0;
}

/* ------------------------------------------------------------------------------------------ */
/* The run that writes the states */

static int write_states(const char *dir, const char *path, int cells, int steps, run_info *ri)
{
    scene s;
    defsim_world *w = NULL;
    if (open_world(&s, &w, path, cells) != 0) return -1;
    if (steps <= 0) steps = s.frames * s.frame_steps;
    if (steps < 2) {
        fprintf(stderr, "--steps: at least 2\n");
        return -1;
    }
    const int64_t n3 = 3 * (int64_t)w->nv;
    double *xs = malloc((size_t)n3 * sizeof *xs), *vs = malloc((size_t)n3 * sizeof *vs);
    double *rest = malloc((size_t)n3 * sizeof *rest);
    if (!xs || !vs || !rest) return -1;
    for (int32_t b = 0; b < w->bodies.n; ++b)
        memcpy(rest + 3 * (int64_t)w->bodies.b[b].offset, w->bodies.b[b].rest,
               3 * (size_t)w->bodies.b[b].nv * sizeof *rest);
    if (write_vec(dir, "x", 0, rest, n3) != 0) return -1;
    int impact = -1;
    const int settled = steps - 1;
    for (int k = 0; k < steps; ++k) {
        defsim_world_get_positions(w, xs, w->nv);
        defsim_world_get_velocities(w, vs, w->nv);
        if (k == impact || k == settled) {
            if (write_vec(dir, "x", k, xs, n3) || write_vec(dir, "v", k, vs, n3)) return -1;
        }
        if (k > 0 && k - 1 == impact) {   /* x_(impact+1) (impact + 1 may be settled too) */
            if (write_vec(dir, "x", k, xs, n3)) return -1;
        }
        if (scene_step(&s, w, s.h) != DEFSIM_OK) {
            fprintf(stderr, "step %d: %s\n", k, defsim_world_last_error(w));
            return -1;
        }
        double active = 0.0;
        defsim_world_stat(w, "contact.body_active", &active);
        if (impact < 0 && active > 0.0 && k + 1 < settled) impact = k + 1;
        if (k == 0 && write_mesh(dir, w) != 0) return -1;
        if (isatty(2)) fprintf(stderr, "\rstep %d / %d", k + 1, steps);
    }
    if (isatty(2)) fprintf(stderr, "\n");
    defsim_world_get_positions(w, xs, w->nv);
    if (write_vec(dir, "x", steps, xs, n3)) return -1;
    if (impact < 0) {
        fprintf(stderr, "no body contact before the last step: no impact state\n");
        return -1;
    }
    char rp[1200];
    snprintf(rp, sizeof rp, "%s/run.txt", dir);
    FILE *f = fopen(rp, "w");
    if (!f) return -1;
    fprintf(f, "scene %s\ncells %d\nimpact %d\nsettled %d\n", path, cells, impact, settled);
    fclose(f);
    snprintf(ri->scene, sizeof ri->scene, "%s", path);
    ri->cells = cells;
    ri->impact = impact;
    ri->settled = settled;
    free(xs);
    free(vs);
    free(rest);
    defsim_world_destroy(w);
    scene_free(&s);
    return 0;
}

static void usage(FILE *f)
{
    fprintf(f, "usage: defsim-bench-contact-phases --out DIR [SCENE] [--cells N] [--steps S]\n"
               "                                   [--repeat R] [--no-time]\n"
               "       defsim-bench-contact-phases --time DIR --step K [--repeat R] [--only KEY]\n"
               "Body contact's phases timed alone on saved states of a scene (default the cloth\n"
               "fold), written in the format of IPC Toolkit's probe.\n"
               "  --out DIR     write the impact and settled states into DIR, then time them\n"
               "  --cells N     the first body's mesh cells, N x N\n"
               "  --steps S     run at most S steps (default: the scene's length)\n"
               "  --repeat R    timed repeats, 1..99 (default 5)\n"
               "  --no-time     write the states only\n"
               "  --time DIR    time the saved state --step K of DIR\n"
               "  --only KEY    time only the phase KEY\n"
               "  -h, --help    this text\n"
               "  --version     the library's version\n");
}

int main(int argc, char **argv)
{
    const char *path = DEFSIM_BENCH_SCENES "/cloth_fold.json", *out = NULL, *tdir = NULL;
    int cells = 0, steps = 0, repeat = 5, step = -1, no_time = 0;
    static const cli_tool tool = {"defsim-bench-contact-phases", usage, NULL, ""};
    const cli_opt opts[] = {
        {"cells", CLI_INT, &cells, 1, 100000}, {"steps", CLI_INT, &steps, 0, 1e9},
        {"repeat", CLI_INT, &repeat, 1, 99}, {"out", CLI_STRING, &out, 0, 0},
        {"time", CLI_STRING, &tdir, 0, 0}, {"step", CLI_INT, &step, 0, 1e9},
        {"no-time", CLI_FLAG, &no_time, 0, 0}, {"only", CLI_STRING, &only_phase, 0, 0}, {0}};
    int first;
    const int parsed = cli_parse(&tool, opts, argc, argv, &first);
    if (parsed >= 0) return parsed;
    if (first + 1 < argc) return cli_fail(&tool, "one scene file at a time");
    if (first < argc) path = argv[first];
    if (!out && !tdir) return cli_fail(&tool, "--out DIR or --time DIR --step K");
    if (tdir && step < 0) return cli_fail(&tool, "--time needs --step K");
    if (tdir) {
        return time_state(tdir, step, repeat) == 0 ? 0 : 1;
    }
    if (mkdir(out, 0777) != 0 && errno != EEXIST) {
        fprintf(stderr, "%s: %s\n", out, strerror(errno));
        return 1;
    }
    run_info ri;
    if (write_states(out, path, cells, steps, &ri) != 0) return 1;
    printf("%s: impact state %d, settled state %d\n", out, ri.impact, ri.settled);
    fflush(stdout);
    if (no_time) return 0;
    if (time_state(out, ri.impact, repeat) != 0 || time_state(out, ri.settled, repeat) != 0)
        return 1;
    return 0;
}
