/* SPDX-License-Identifier: MIT */
#ifndef DEFSIM_TOOLS_BENCH_H
#define DEFSIM_TOOLS_BENCH_H

/* `defsim bench SCENE.json [options]`: the work-precision benchmark (tools/defsim/bench.c). argv[0]
 * is the subcommand name. Returns the process exit status: 0 done, 1 error, 2 usage. */
int defsim_tool_bench(int argc, char **argv);

/* `defsim bench --spatial SCENE.json [options]`: total (spatial and temporal) error against wall
 * time over meshes, element orders, backends and steps (tools/defsim/bench_spatial.c). */
int defsim_tool_bench_spatial(int argc, char **argv);

/* Shared by both modes (tools/defsim/bench.c). */
#include "scene.h"

#include <stddef.h>

typedef struct point {
    const char *backend;
    int is_tol;            /* 0: value is h (s); 1: value is the tolerance */
    double value;
    double wall;           /* median over repeats of the stepping loop, s */
    double rms, max, energy;
    char status[32];       /* ok, unstable, diverged, not_converged, or the status name */
    long long steps, newton, internal;
    int pareto;            /* not dominated in (wall, rms) by another ok point */
} point;

/* Builds s's world with `backend` and `threads` assembly threads; rtol > 0 also sets rtol, atol =
 * rtol x size and a high internal step limit (the adaptive backends). */
defsim_status bench_build(scene *s, const char *backend, int threads, double rtol, double size,
                          defsim_world **w);
/* 1 for the backends swept by tolerance (sundials_ida, sundials_erk) rather than by step. */
int bench_swept_by_tolerance(const char *backend);
/* Comma-separated positive numbers into out (at most max). Returns the count, or -1. */
int bench_parse_list(const char *s, double *out, int max);
/* The median of v[0..n-1], n >= 1 (sorts v). */
double bench_median(double *v, int n);
/* Sets each point's pareto: ok and not dominated in (wall, rms) by another ok point. */
void bench_mark_pareto(point *p, int n);
/* "h = 0.001 s" or "tol = 1e-05". */
void bench_setting(const point *p, char *buf, size_t n);
/* Runs the plotting script on csv, writing png; never fails (says how to make it by hand). */
void bench_plot(const char *python, const char *script, const char *csv, const char *png,
                const char *title);

#endif
