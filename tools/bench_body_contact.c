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
 *   defsim-bench-body-contact [SCENE] [--cells N] [--backends a,b] [--threads T] [--repeat R]
 *                             [--cpu] [--set KEY=VALUE]...
 *
 * --cells N sets the first body's mesh cells to N x N (a cloth) before loading; --repeat R runs
 * each backend R times (default 3) and reports the run of median time per step; --cpu times the
 * steps with process CPU time (a loaded machine) instead of the monotonic clock. The shares are
 * the library's own timings (monotonic clock) over its time_step. --set overrides a scene key as
 * `defsim run --set` does (e.g. world.h=0.002), at most 8.
 */
#include "clock.h"
#include "scene.h"
#include "stat.h"

#include <defsim/defsim.h>

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#ifndef DEFSIM_BENCH_SCENES
#define DEFSIM_BENCH_SCENES "tests/scenes"
#endif

typedef struct result {
    double ms_step, its, ms_it, broad, ccd, eval, growths, candidates, active, min_d;
    int steps;
} result;

static int use_cpu;   /* --cpu */

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

enum { MAX_SETS = 8 };
static const char *user_sets[MAX_SETS];   /* --set KEY=VALUE */
static int nuser_sets;

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
    for (int k = 0; k < nuser_sets; ++k) sets[nsets++] = user_sets[k];
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
    const int steps = s.frames * s.frame_steps;
    const double t0 = now();
    for (int k = 0; k < steps; ++k)
        if (scene_step(&s, w, s.h) != DEFSIM_OK) {
            fprintf(stderr, "%s: step %d: %s\n", backend, k, defsim_world_last_error(w));
            defsim_world_destroy(w);
            scene_free(&s);
            return -1;
        }
    const double wall = now() - t0, t = stat(w, "time_step");
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

int main(int argc, char **argv)
{
    const char *path = DEFSIM_BENCH_SCENES "/cloth_fold.json";
    char backends[256] = "newton_cholmod";
    int cells = 0, threads = 1, repeat = 3;
    for (int i = 1; i < argc; ++i) {
        const int has = i + 1 < argc;
        if (!strcmp(argv[i], "--cells") && has) cells = atoi(argv[++i]);
        else if (!strcmp(argv[i], "--threads") && has) threads = atoi(argv[++i]);
        else if (!strcmp(argv[i], "--repeat") && has) repeat = atoi(argv[++i]);
        else if (!strcmp(argv[i], "--cpu")) use_cpu = 1;
        else if (!strcmp(argv[i], "--set") && has && nuser_sets < MAX_SETS)
            user_sets[nuser_sets++] = argv[++i];
        else if (!strcmp(argv[i], "--backends") && has)
            snprintf(backends, sizeof backends, "%s", argv[++i]);
        else if (argv[i][0] != '-') path = argv[i];
        else {
            fprintf(stderr, "usage: defsim-bench-body-contact [SCENE] [--cells N] "
                            "[--backends a,b] [--threads T] [--repeat R] [--cpu] [--set KEY=VALUE]...\n");
            return 2;
        }
    }
    if (cells < 0 || threads < 0 || repeat < 1 || repeat > 99) return 2;
    printf("%s%s, %d threads, median of %d runs (by time per step), %s\n\n", path,
           cells > 0 ? " (cells overridden)" : "", threads, repeat,
           use_cpu ? "process CPU time" : "monotonic clock");
    printf("| backend | cells | steps | ms/step | Newton its/step | ms/iteration | broad | CCD | "
           "eval | contact total | pattern growths | candidates (last step) | active (last) | "
           "min distance (m) |\n|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|"
           "---:|---:|\n");
    for (char *b = strtok(backends, ","); b; b = strtok(NULL, ",")) {
        result r[99];
        for (int k = 0; k < repeat; ++k)
            if (run(path, b, cells, threads, &r[k]) != 0) return 1;
        qsort(r, (size_t)repeat, sizeof *r, by_ms);
        const result *m = &r[repeat / 2];
        char cl[32] = "scene's";
        if (cells > 0) snprintf(cl, sizeof cl, "%d x %d", cells, cells);
        printf("| %s | %s | %d | %.2f | %.2f | %.2f | %.1f %% | %.1f %% | %.1f %% | %.1f %% | "
               "%.0f | %.0f | %.0f | %.3g |\n", b, cl, m->steps, m->ms_step, m->its,
               m->ms_it, m->broad, m->ccd, m->eval, m->broad + m->ccd + m->eval, m->growths,
               m->candidates, m->active, m->min_d);
    }
    return 0;
}
