/* SPDX-License-Identifier: MIT */
/*
 * defsim-bench-body-contact: what body-body and self-contact (issue 13) cost where they work.
 * Runs a shipped scene with body contact on (default tests/scenes/cloth_fold.json, a cloth
 * crumpling onto itself on the ground) with each backend named and prints, per run, the time
 * per step and per Newton iteration and the share of the step spent in the body-contact broad
 * phase, CCD and evaluation (the statistics contact.time_body_broad, contact.time_body_ccd,
 * contact.time_body_eval over time_step), the matrix pattern growths
 * (contact.pattern_growths) and the candidate and active pairs of the last step.
 *
 *   defsim-bench-body-contact [SCENE] [--cells N | --cells-list N1,N2,... [--fit]]
 *                             [--backends a,b] [--threads T] [--repeat R] [--steps S] [--cpu]
 *                             [--check] [--rest KE] [--per-step FILE] [--set KEY=VALUE]...
 *
 * --cells N sets the first body's mesh cells to N x N (a cloth) before loading; --repeat R runs
 * each backend R times (default 3) and reports the run of median time per step; --cpu times the
 * steps with process CPU time (a loaded machine) instead of the monotonic clock. The shares are
 * the library's own timings (monotonic clock) over its time_step. --set overrides a scene key as
 * `defsim run --set` does (e.g. world.h=0.002), at most 8. --steps S runs the first S steps
 * only (default: the scene's length). --per-step FILE writes a CSV row per step (cells,
 * vertices, step, Newton iterations, ms), so the worst steps can be found. The last column is
 * the process's peak resident memory (getrusage) after the size's runs: with sizes in rising
 * order, the peak of the largest so far.
 *
 * Scaling (issue 30): --cells-list 12,16,24 runs each size in turn (same physical cloth; d_hat
 * follows the world's length scale as in every run) and --fit adds the exponent p of a least
 * squares fit of log(ms/step) = p log(vertices) + c over the sizes (and the same for ms per
 * Newton iteration); a size that fails is reported in the table and left out of the fit, and
 * the run exits 1.
 *
 * --check tests, after every step, every pair of surface primitives of the bodies that share no
 * vertex (whatever self_contact and collision groups say: a scene that lets surfaces pass
 * through each other fails, which is how the check is seen to work) for an exact
 * intersection, independently of the solver: the surfaces are taken from the scene's meshes (a
 * cloth's triangles, the faces of tets that belong to one tet only, a rope's stretch springs as
 * segments), the broad phase is a uniform grid of the primitives' boxes written here, a pair
 * whose triangles are separated by the plane of either (orientation in floating point with
 * Shewchuk's static error bound, so a sign is only trusted when it is certain) is dismissed, and
 * every other pair goes to the exact triangle-triangle test of tests/common/exact_geom.c
 * (orient3d in expansion arithmetic; a segment is the triangle (a, b, b)). On an intersection
 * the run fails (exit 1) naming the step and the two primitives by world vertex index. The
 * check's time is not counted in the step times. --rest KE fails the run (exit 1) when the
 * kinetic energy at its end exceeds KE (J). Both are reported in the table.
 */
#include "cli.h"
#include "clock.h"
#include "exact_geom.h"
#include "scene.h"
#include "stat.h"

#include <defsim/defsim.h>

#include <math.h>
#include <stdint.h>
#include <sys/resource.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#ifndef DEFSIM_BENCH_SCENES
#define DEFSIM_BENCH_SCENES "tests/scenes"
#endif

typedef struct result {
    double ms_step, its, ms_it, broad, ccd, eval, growths, candidates, active, min_d;
    double kinetic;            /* J, at the end */
    long long exact_tests;     /* --check: pairs that reached the exact test, all steps */
    int steps, nv;
} result;

static int use_cpu;        /* --cpu */
static int max_steps;      /* --steps (0: the scene's) */
static int check;          /* --check */
static FILE *per_step;     /* --per-step FILE: one row per step */

static double now(void)
{
    return use_cpu ? tools_cpu_now() : tools_now();
}

static double stat(const defsim_world *w, const char *name)
{
    double v = 0.0;
    if (defsim_world_stat(w, name, &v) != DEFSIM_OK) {
        fprintf(stderr, "statistic %s: %s\n", name, defsim_world_last_error(w));
        exit(1);
    }
    return v;
}

/* ------------------------------------------------------------------------------------------ */
/* The intersection check (--check): surfaces from the scene, a grid, exact tests */

/* The bodies' surface primitives as triangles of world vertex indices (a rope segment (a, b) is
 * (a, b, b)), with their body. */
typedef struct surface {
    int32_t n, cap;
    int32_t *tri;              /* 3 n */
    int32_t *body;             /* n: scene body index */
    double *lo, *hi;           /* 3 n: boxes at the positions checked */
    int64_t *cell;             /* scratch: (cell key, primitive) entries */
    int64_t ncell, cap_cell;
} surface;

static int surface_add(surface *sf, int32_t a, int32_t b, int32_t c, int32_t body)
{
    if (sf->n == sf->cap) {
        const int32_t cap = sf->cap ? 2 * sf->cap : 256;
        int32_t *t = realloc(sf->tri, 3 * (size_t)cap * sizeof *t);
        if (!t) return -1;
        sf->tri = t;
        int32_t *bd = realloc(sf->body, (size_t)cap * sizeof *bd);
        if (!bd) return -1;
        sf->body = bd;
        sf->cap = cap;
    }
    sf->tri[3 * sf->n] = a;
    sf->tri[3 * sf->n + 1] = b;
    sf->tri[3 * sf->n + 2] = c;
    sf->body[sf->n++] = body;
    return 0;
}

static int cmp_face(const void *pa, const void *pb)
{
    const int32_t *a = pa, *b = pb;
    for (int k = 0; k < 3; ++k)
        if (a[k] != b[k]) return (a[k] > b[k]) - (a[k] < b[k]);
    return 0;
}

/* The faces of a body's tets that belong to one tet only (sorted vertex triples). */
static int tet_boundary(surface *sf, const defsim_mesh *m, int32_t off, int32_t body)
{
    const int64_t nf = 4 * (int64_t)m->tet_count;
    int32_t *f = malloc((size_t)(3 * nf + 1) * sizeof *f);
    if (!f) return -1;
    static const int face[4][3] = {{0, 1, 2}, {0, 1, 3}, {0, 2, 3}, {1, 2, 3}};
    for (int64_t t = 0; t < m->tet_count; ++t)
        for (int k = 0; k < 4; ++k) {
            int32_t *g = f + 3 * (4 * t + k);
            for (int i = 0; i < 3; ++i) g[i] = m->tets[4 * t + face[k][i]];
            for (int i = 1; i < 3; ++i)   /* sort the triple */
                for (int j = i; j > 0 && g[j] < g[j - 1]; --j) {
                    const int32_t u = g[j];
                    g[j] = g[j - 1];
                    g[j - 1] = u;
                }
        }
    qsort(f, (size_t)nf, 3 * sizeof *f, cmp_face);
    int rc = 0;
    for (int64_t i = 0; i < nf && rc == 0;) {
        int64_t j = i + 1;
        while (j < nf && cmp_face(f + 3 * i, f + 3 * j) == 0) ++j;
        if (j - i == 1)
            rc = surface_add(sf, off + f[3 * i], off + f[3 * i + 1], off + f[3 * i + 2], body);
        i = j;
    }
    free(f);
    return rc;
}

static int surface_build(surface *sf, const scene *s)
{
    memset(sf, 0, sizeof *sf);
    for (int32_t b = 0; b < s->nbodies; ++b) {
        const defsim_mesh *m = &s->bodies[b].mesh;
        const int32_t off = s->bodies[b].offset;
        if (m->tet_count > 0) {
            if (tet_boundary(sf, m, off, b) != 0) return -1;
        } else if (m->triangle_count > 0) {
            for (int32_t t = 0; t < m->triangle_count; ++t)
                if (surface_add(sf, off + m->triangles[3 * t], off + m->triangles[3 * t + 1],
                                off + m->triangles[3 * t + 2], b) != 0)
                    return -1;
        } else {
            for (int32_t k = 0; k < m->spring_count; ++k)
                if ((!m->spring_kinds || m->spring_kinds[k] == DEFSIM_SPRING_STRETCH) &&
                    surface_add(sf, off + m->springs[2 * k], off + m->springs[2 * k + 1],
                                off + m->springs[2 * k + 1], b) != 0)
                    return -1;
        }
    }
    sf->lo = malloc(3 * (size_t)(sf->n + 1) * sizeof *sf->lo);
    sf->hi = malloc(3 * (size_t)(sf->n + 1) * sizeof *sf->hi);
    return sf->lo && sf->hi ? 0 : -1;
}

static void surface_free(surface *sf)
{
    free(sf->tri);
    free(sf->body);
    free(sf->lo);
    free(sf->hi);
    free(sf->cell);
}

/* Sign of orient3d(a, b, c, d) in floating point when it is certain (Shewchuk's error bound
 * for the plain evaluation, (7 + 56 eps) eps times the permanent, taken as 1e-15), else 0. */
static int orient_filtered(const double *a, const double *b, const double *c, const double *d)
{
    const double adx = a[0] - d[0], ady = a[1] - d[1], adz = a[2] - d[2];
    const double bdx = b[0] - d[0], bdy = b[1] - d[1], bdz = b[2] - d[2];
    const double cdx = c[0] - d[0], cdy = c[1] - d[1], cdz = c[2] - d[2];
    const double m1 = bdy * cdz, m2 = bdz * cdy, m3 = cdy * adz, m4 = cdz * ady;
    const double m5 = ady * bdz, m6 = adz * bdy;
    const double det = adx * (m1 - m2) + bdx * (m3 - m4) + cdx * (m5 - m6);
    const double perm = fabs(adx) * (fabs(m1) + fabs(m2)) + fabs(bdx) * (fabs(m3) + fabs(m4)) +
                        fabs(cdx) * (fabs(m5) + fabs(m6));
    const double bound = 1e-15 * perm;
    return det > bound ? 1 : det < -bound ? -1 : 0;
}

/* 1 if the points q0..q2 lie certainly strictly on one side of the plane of (p0, p1, p2). */
static int separated(const double *p0, const double *p1, const double *p2, const double *q0,
                     const double *q1, const double *q2)
{
    const int s0 = orient_filtered(p0, p1, p2, q0);
    return s0 != 0 && orient_filtered(p0, p1, p2, q1) == s0 &&
           orient_filtered(p0, p1, p2, q2) == s0;
}

static int cmp_i64(const void *pa, const void *pb)
{
    const int64_t a = *(const int64_t *)pa, b = *(const int64_t *)pb;
    return (a > b) - (a < b);
}

/* Cell coordinate of c along an axis, and a cell's key (21 bits an axis, from the grid's
 * corner: a grid of at most 2^21 cells an axis, which the cell size below guarantees). */
static int64_t cell_key(int64_t i, int64_t j, int64_t k)
{
    return (i << 42) | (j << 21) | k;
}

/* Every pair of primitives that share no vertex, at x (whatever self_contact and the collision
 * groups say: a scene that lets surfaces pass through each other fails): 0 if none intersects,
 * 1 with the pair in *pa, *pb, -1 out of memory. *tests counts the exact tests. */
static int surface_check(surface *sf, const double *x, int32_t *pa, int32_t *pb,
                         long long *tests)
{
    const int32_t n = sf->n;
    if (n < 2) return 0;
    double glo[3] = {INFINITY, INFINITY, INFINITY}, ext = 0.0;
    for (int32_t p = 0; p < n; ++p) {
        double *lo = sf->lo + 3 * (int64_t)p, *hi = sf->hi + 3 * (int64_t)p;
        for (int k = 0; k < 3; ++k) {
            lo[k] = INFINITY;
            hi[k] = -INFINITY;
        }
        for (int i = 0; i < 3; ++i) {
            const double *v = x + 3 * (int64_t)sf->tri[3 * p + i];
            for (int k = 0; k < 3; ++k) {
                lo[k] = fmin(lo[k], v[k]);
                hi[k] = fmax(hi[k], v[k]);
            }
        }
        for (int k = 0; k < 3; ++k) {
            glo[k] = fmin(glo[k], lo[k]);
            ext = fmax(ext, hi[k] - lo[k]);
        }
    }
    /* Cells as large as the largest box: a box covers at most 2 cells an axis. The grid is
     * grown past 2^20 cells an axis by taking larger cells. */
    double ghi = -INFINITY;
    for (int32_t p = 0; p < n; ++p)
        for (int k = 0; k < 3; ++k) ghi = fmax(ghi, sf->hi[3 * (int64_t)p + k] - glo[k]);
    double size = fmax(ext, ghi / (double)(1 << 20));
    if (!(size > 0.0)) size = 1.0;
    const int64_t need = 8 * (int64_t)n;
    if (need > sf->cap_cell) {
        int64_t *c = realloc(sf->cell, 2 * (size_t)need * sizeof *c);
        if (!c) return -1;
        sf->cell = c;
        sf->cap_cell = need;
    }
    /* (key, primitive) entries, 2 int64 each, sorted by key then primitive */
    int64_t m = 0;
    for (int32_t p = 0; p < n; ++p) {
        int64_t a[3], b[3];
        for (int k = 0; k < 3; ++k) {
            a[k] = (int64_t)((sf->lo[3 * (int64_t)p + k] - glo[k]) / size);
            b[k] = (int64_t)((sf->hi[3 * (int64_t)p + k] - glo[k]) / size);
        }
        for (int64_t i = a[0]; i <= b[0]; ++i)
            for (int64_t j = a[1]; j <= b[1]; ++j)
                for (int64_t k = a[2]; k <= b[2]; ++k) {
                    if (m == sf->cap_cell) {
                        int64_t *c = realloc(sf->cell, 4 * (size_t)sf->cap_cell * sizeof *c);
                        if (!c) return -1;
                        sf->cell = c;
                        sf->cap_cell *= 2;
                    }
                    sf->cell[2 * m] = cell_key(i, j, k);
                    sf->cell[2 * m + 1] = p;
                    ++m;
                }
    }
    qsort(sf->cell, (size_t)m, 2 * sizeof *sf->cell, cmp_i64);
    for (int64_t g = 0; g < m;) {
        int64_t e = g + 1;
        while (e < m && sf->cell[2 * e] == sf->cell[2 * g]) ++e;
        const int64_t key = sf->cell[2 * g];
        const int64_t ci[3] = {key >> 42, (key >> 21) & 0x1FFFFF, key & 0x1FFFFF};
        for (int64_t u = g; u < e; ++u)
            for (int64_t w = u + 1; w < e; ++w) {
                const int32_t p = (int32_t)sf->cell[2 * u + 1], q = (int32_t)sf->cell[2 * w + 1];
                const double *plo = sf->lo + 3 * (int64_t)p, *phi = sf->hi + 3 * (int64_t)p;
                const double *qlo = sf->lo + 3 * (int64_t)q, *qhi = sf->hi + 3 * (int64_t)q;
                int overlap = 1, home = 1;
                for (int k = 0; k < 3 && overlap; ++k) {
                    overlap = plo[k] <= qhi[k] && qlo[k] <= phi[k];
                    /* the pair is tested in the cell of its boxes' overlap's low corner only */
                    home &= (int64_t)((fmax(plo[k], qlo[k]) - glo[k]) / size) == ci[k];
                }
                if (!overlap || !home) continue;
                const int32_t *tp = sf->tri + 3 * (int64_t)p, *tq = sf->tri + 3 * (int64_t)q;
                int shared = 0;
                for (int i = 0; i < 3; ++i)
                    for (int j = 0; j < 3; ++j) shared |= tp[i] == tq[j];
                if (shared) continue;
                const double *p0 = x + 3 * (int64_t)tp[0], *p1 = x + 3 * (int64_t)tp[1];
                const double *p2 = x + 3 * (int64_t)tp[2], *q0 = x + 3 * (int64_t)tq[0];
                const double *q1 = x + 3 * (int64_t)tq[1], *q2 = x + 3 * (int64_t)tq[2];
                if (separated(p0, p1, p2, q0, q1, q2) || separated(q0, q1, q2, p0, p1, p2))
                    continue;
                ++*tests;
                if (eg_tri_tri_intersect(p0, p1, p2, q0, q1, q2)) {
                    *pa = p;
                    *pb = q;
                    return 1;
                }
            }
        g = e;
    }
    return 0;
}

enum { MAX_SETS = 8 };
static const char *user_sets[MAX_SETS];   /* --set KEY=VALUE */
static cli_list sets_given = {user_sets, 0, MAX_SETS};

/* One run of the scene with `backend`; 0 or -1 (message printed). */
static int run(const char *path, const char *backend, int cells, int threads, result *r)
{
    char cell_set[64], backend_set[96], threads_set[64];
    const char *sets[3 + MAX_SETS];
    int nsets = 0;
    snprintf(backend_set, sizeof backend_set, "world.backend=\"%s\"", backend);
    sets[nsets++] = backend_set;
    if (cells > 0) {
        snprintf(cell_set, sizeof cell_set, "bodies.0.mesh.cells=[%d,%d]", cells, cells);
        sets[nsets++] = cell_set;
    }
    snprintf(threads_set, sizeof threads_set, "world.threads=%d", threads);
    sets[nsets++] = threads_set;
    for (int k = 0; k < sets_given.count; ++k) sets[nsets++] = user_sets[k];
    scene s;
    if (scene_load(&s, path, sets, nsets) != 0) {
        fprintf(stderr, "%s\n", s.error);
        return -1;
    }
    defsim_world *w = NULL;
    if (scene_build(&s, &w) != DEFSIM_OK) {
        fprintf(stderr, "%s\n", s.error);
        scene_free(&s);
        return -1;
    }
    /* the scene's iteration limit is written for its own backend */
    char opt[96];
    snprintf(opt, sizeof opt, "%s.max_iterations", backend);
    defsim_world_set_option(w, opt, "200");
    int steps = s.frames * s.frame_steps;
    if (max_steps > 0 && max_steps < steps) steps = max_steps;
    surface sf;
    double *x = NULL;
    int failed = 0;
    r->exact_tests = 0;
    if (check && (surface_build(&sf, &s) != 0 ||
                  !(x = malloc(3 * (size_t)s.vertex_count * sizeof *x)))) {
        fprintf(stderr, "--check: out of memory\n");
        failed = 1;
    }
    double wall = 0.0, its_before = 0.0;
    for (int k = 0; k < steps && !failed; ++k) {
        const double t0 = now();
        const defsim_status st = scene_step(&s, w, s.h);
        const double dt = now() - t0;
        wall += dt;
        if (per_step) {
            const double its = st == DEFSIM_OK ? tools_backend_stat(w, "newton_iterations") : 0;
            fprintf(per_step, "%d,%d,%d,%.0f,%.3f\n", cells, s.vertex_count, k, its - its_before,
                    1e3 * dt);
            its_before = its;
        }
        if (st != DEFSIM_OK) {
            fprintf(stderr, "%s: step %d: %s\n", backend, k, defsim_world_last_error(w));
            failed = 1;
        } else if (check) {
            int32_t pa, pb;
            defsim_world_get_positions(w, x, s.vertex_count);
            const int hit = surface_check(&sf, x, &pa, &pb, &r->exact_tests);
            if (hit != 0) {
                if (hit < 0) fprintf(stderr, "--check: out of memory\n");
                else
                    fprintf(stderr, "--check: after step %d (t = %g s), primitive (%d, %d, %d) "
                                    "of body %d and (%d, %d, %d) of body %d intersect (world "
                                    "vertex indices; a segment repeats its last vertex)\n", k,
                            (k + 1) * s.h, (int)sf.tri[3 * pa], (int)sf.tri[3 * pa + 1],
                            (int)sf.tri[3 * pa + 2], (int)sf.body[pa], (int)sf.tri[3 * pb],
                            (int)sf.tri[3 * pb + 1], (int)sf.tri[3 * pb + 2], (int)sf.body[pb]);
                failed = 1;
            }
        }
    }
    if (check) {
        surface_free(&sf);
        free(x);
    }
    if (failed) {
        defsim_world_destroy(w);
        scene_free(&s);
        return -1;
    }
    defsim_energy en;
    r->kinetic = defsim_world_energy(w, &en) == DEFSIM_OK ? en.kinetic : NAN;
    r->nv = s.vertex_count;
    const double t = stat(w, "time_step");
    r->steps = steps;
    r->ms_step = 1e3 * wall / steps;
    r->its = tools_backend_stat(w, "newton_iterations");
    r->ms_it = r->its > 0 ? 1e3 * wall / r->its : 0.0;
    r->its /= steps;
    r->broad = 100.0 * stat(w, "contact.time_body_broad") / t;
    r->ccd = 100.0 * stat(w, "contact.time_body_ccd") / t;
    r->eval = 100.0 * stat(w, "contact.time_body_eval") / t;
    r->growths = stat(w, "contact.pattern_growths");
    r->candidates = stat(w, "contact.body_candidates");
    r->active = stat(w, "contact.body_active");
    r->min_d = stat(w, "contact.body_min_distance");
    defsim_world_destroy(w);
    scene_free(&s);
    return 0;
}

static int by_ms(const void *a, const void *b)
{
    const double x = ((const result *)a)->ms_step, y = ((const result *)b)->ms_step;
    return (x > y) - (x < y);
}

/* Least squares slope of log(y) against log(x) over n points. */
static double loglog_slope(const double *x, const double *y, int n)
{
    double sx = 0.0, sy = 0.0, sxx = 0.0, sxy = 0.0;
    for (int i = 0; i < n; ++i) {
        const double u = log(x[i]), v = log(y[i]);
        sx += u;
        sy += v;
        sxx += u * u;
        sxy += u * v;
    }
    return (n * sxy - sx * sy) / (n * sxx - sx * sx);
}

static void usage(FILE *f)
{
    fprintf(f, "usage: defsim-bench-body-contact [SCENE] [--cells N | --cells-list N1,N2,...\n"
               "                                 [--fit]] [--backends a,b] [--threads T]\n"
               "                                 [--repeat R] [--steps S] [--cpu] [--check]\n"
               "                                 [--rest KE] [--per-step FILE]\n"
               "                                 [--set KEY=VALUE]...\n"
               "Body contact's cost on a shipped scene (default the cloth fold): time per step\n"
               "and per Newton iteration, the shares of its broad phase, CCD and evaluation.\n"
               "  --cells N          the first body's mesh cells, N x N\n"
               "  --cells-list L     run each size in turn; --fit: the scaling exponent\n"
               "  --backends LIST    backends to run (default newton_cholmod)\n"
               "  --threads T        OpenMP threads (default 1)\n"
               "  --repeat R         runs per backend and size, 1..99 (default 3)\n"
               "  --steps S          the first S steps only (default: the scene's length)\n"
               "  --cpu              time with process CPU time\n"
               "  --check            exact intersection check after every step (exit 1 on one)\n"
               "  --rest KE          exit 1 unless the kinetic energy at the end is below KE\n"
               "  --per-step FILE    a CSV row per step\n"
               "  --set KEY=VALUE    override a scene value, as in defsim run (at most 8)\n"
               "  -h, --help         this text\n"
               "  --version          the library's version\n");
}

int main(int argc, char **argv)
{
    const char *path = DEFSIM_BENCH_SCENES "/cloth_fold.json", *per_step_path = NULL;
    const char *backends_arg = "newton_cholmod", *list_arg = "";
    int cells = 0, threads = 1, repeat = 3, fit = 0;
    double rest = -1.0;
    static const cli_tool tool = {"defsim-bench-body-contact", usage, NULL, ""};
    const cli_opt opts[] = {
        {"cells", CLI_INT, &cells, 1, 100000}, {"cells-list", CLI_STRING, &list_arg, 0, 0},
        {"fit", CLI_FLAG, &fit, 0, 0}, {"threads", CLI_INT, &threads, 0, 4096},
        {"repeat", CLI_INT, &repeat, 1, 99}, {"steps", CLI_INT, &max_steps, 0, 1e9},
        {"cpu", CLI_FLAG, &use_cpu, 0, 0}, {"check", CLI_FLAG, &check, 0, 0},
        {"per-step", CLI_STRING, &per_step_path, 0, 0}, {"rest", CLI_DOUBLE, &rest, 0.0, 1e300},
        {"set", CLI_LIST, &sets_given, 0, 0}, {"backends", CLI_STRING, &backends_arg, 0, 0}, {0}};
    int first;
    const int parsed = cli_parse(&tool, opts, argc, argv, &first);
    if (parsed >= 0) return parsed;
    char backends[256], list[256];
    snprintf(backends, sizeof backends, "%s", backends_arg);
    snprintf(list, sizeof list, "%s", list_arg);
    if (first + 1 < argc) return cli_fail(&tool, "one scene file at a time");
    if (first < argc) path = argv[first];
    if (per_step_path) {
        if (!(per_step = fopen(per_step_path, "w"))) {
            perror(per_step_path);
            return 2;
        }
        fprintf(per_step, "cells,vertices,step,newton_iterations,ms\n");
    }
    int sizes[32], nsizes = 0;
    if (list[0]) {
        for (char *tok = strtok(list, ","); tok && nsizes < 32; tok = strtok(NULL, ","))
            if ((sizes[nsizes++] = atoi(tok)) < 1) {
                fprintf(stderr, "defsim-bench-body-contact: --cells-list: sizes >= 1\n");
                return 2;
            }
    } else {
        sizes[nsizes++] = cells;
    }
    printf("%s%s, %d threads, median of %d runs (by time per step), %s%s\n\n", path,
           (list[0] || cells > 0) ? " (cells overridden)" : "", threads, repeat,
           use_cpu ? "process CPU time" : "monotonic clock",
           check ? "; exact intersection check after every step (not timed)" : "");
    printf("| backend | cells | vertices | steps | ms/step | Newton its/step | ms/iteration | "
           "broad | CCD | eval | contact total | pattern growths | candidates (last step) | "
           "active (last) | min distance (m) | kinetic energy at the end (J) | exact tests | "
           "peak RSS (MB) |\n"
           "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|"
           "---:|---:|\n");
    char *save = NULL;
    int status = 0;
    for (char *b = strtok_r(backends, ",", &save); b; b = strtok_r(NULL, ",", &save)) {
        double nvs[32], ms[32], msi[32];
        int nfit = 0;
        for (int z = 0; z < nsizes; ++z) {
            result r[99];
            int ok = 1;
            for (int k = 0; k < repeat && ok; ++k) ok = run(path, b, sizes[z], threads, &r[k]) == 0;
            if (!ok) {
                /* a size that fails (message above) is reported and left out of the fit */
                printf("| %s | %d x %d | failed (see the message) |\n", b, sizes[z], sizes[z]);
                fflush(stdout);
                status = 1;
                continue;
            }
            qsort(r, (size_t)repeat, sizeof *r, by_ms);
            const result *m = &r[repeat / 2];
            char cl[32] = "scene's";
            if (sizes[z] > 0) snprintf(cl, sizeof cl, "%d x %d", sizes[z], sizes[z]);
            struct rusage ru;
            getrusage(RUSAGE_SELF, &ru);
            printf("| %s | %s | %d | %d | %.2f | %.2f | %.2f | %.1f %% | %.1f %% | %.1f %% | "
                   "%.1f %% | %.0f | %.0f | %.0f | %.3g | %.3g | %s%lld | %.1f |\n", b, cl,
                   m->nv, m->steps, m->ms_step, m->its, m->ms_it, m->broad, m->ccd, m->eval,
                   m->broad + m->ccd + m->eval, m->growths, m->candidates, m->active, m->min_d,
                   m->kinetic, check ? "" : "(off) ", m->exact_tests,
                   (double)ru.ru_maxrss / 1024.0);
            fflush(stdout);
            nvs[nfit] = m->nv;
            ms[nfit] = m->ms_step;
            msi[nfit++] = m->ms_it;
            for (int k = 0; k < repeat; ++k)
                if (rest >= 0.0 && !(r[k].kinetic <= rest)) {
                    fprintf(stderr, "--rest: kinetic energy %g J at the end, above %g J\n",
                            r[k].kinetic, rest);
                    status = 1;
                }
        }
        if (fit && nfit >= 2)
            printf("\n%s: least squares on log-log over %d sizes: ms/step ~ vertices^%.2f, "
                   "ms/iteration ~ vertices^%.2f\n\n", b, nfit, loglog_slope(nvs, ms, nfit),
                   loglog_slope(nvs, msi, nfit));
    }
    return status;
}
