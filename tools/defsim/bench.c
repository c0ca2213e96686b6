/* SPDX-License-Identifier: MIT */
/*
 * `defsim bench SCENE.json`: work-precision benchmark. For each backend it sweeps the step size h
 * (fixed-step backends) or the tolerance (sundials_ida, sundials_erk), runs the scene to a fixed
 * end time T,
 * and measures the wall time of the stepping loop (median of repeats) and the error at T against
 * a reference solution: sundials_erk at rtol 1e-10 on the same scene, computed once and cached in
 * the output folder under a hash of the scene file, the overrides and T. Writes a CSV, a Pareto
 * table (the fastest backend and setting for each error level) and, through tools/plot_wp.py, a
 * log-log plot of error against time. tools/README.md documents the definitions.
 *
 * Contents: backends and options; the reference solution; running one point (build, advance,
 * errors); the Pareto table, CSV rows and observed orders; --rows input; argument parsing and
 * the default sweeps; bench_main.
 */
#include "bench.h"

#include "cli.h"
#include "clock.h"
#include "refsol.h"
#include "scene.h"
#include "stat.h"

#include "fileio.h"

#include <errno.h>
#include <limits.h>
#include <math.h>
#include <spawn.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

extern char **environ;

#ifndef DEFSIM_BENCH_PLOT_SCRIPT
#define DEFSIM_BENCH_PLOT_SCRIPT ""
#endif

/* The reference: REF_BACKEND at this rtol (atol = rtol times the body size), checked against a
 * second run at REF_CHECK_RTOL. Bump REF_FORMAT when the way it is computed changes, so that old
 * cached files are not reused. */
#define REF_BACKEND "sundials_erk"
#define REF_RTOL 1e-10
#define REF_CHECK_RTOL 1e-9
#define REF_FORMAT "bench-reference-3"
/* A run whose RMS position error exceeds the body's size has left the solution entirely. */
#define DIVERGED_RMS 1.0
/* ... and one whose energy error exceeds the energy scale is on its way to blowing up. */
#define DIVERGED_ENERGY 1.0

#define MAX_BACKENDS 12
#define MAX_VALUES 32
#define MAX_SETS 64

static const char *all_backends[] = {"explicit_euler", "symplectic_euler", "velocity_verlet",
                                     "newton_cholmod", "newmark", "bdf2", "sundials_kinsol",
                                     "sundials_ida", "sundials_erk"};

/* Backends swept by tolerance (adaptive) rather than by step size. */
int bench_swept_by_tolerance(const char *backend)
{
    return !strcmp(backend, "sundials_ida") || !strcmp(backend, "sundials_erk");
}


typedef struct bench {
    scene s;
    const char *scene_path;
    const char *sets[MAX_SETS];
    int nsets;
    const char *opts[MAX_SETS];  /* --option NAME=VALUE, for the swept runs (not the reference) */
    int nopts;
    double T, frame_dt;
    int repeats;
    int threads;           /* world.num_threads of every run */
    double size;           /* bounding-box diagonal of the rest shape, m */
    double energy_scale;   /* J */
    unsigned char *pinned; /* per world vertex */
    int32_t nv;
    double *x, *v;         /* scratch, 3 nv */
} bench;

static void usage(FILE *f)
{
    fprintf(f,
        "usage: defsim bench SCENE.json [options]\n"
        "       defsim bench --spatial SCENE.json [options]  (error against the continuum over\n"
        "                      meshes and element orders: defsim bench --spatial --help)\n"
        "  --backends A,B,...  backends to compare (default: all nine; unavailable ones are\n"
        "                      skipped with a note)\n"
        "  --h LIST            step sizes for fixed-step backends, s (default: the scene's h\n"
        "                      doubled up to 1/30 s)\n"
        "  --tol LIST          sundials_ida and sundials_erk tolerances, rtol = tol,\n"
        "                      atol = tol x body size\n"
        "                      (default 1e-3 to 1e-8 in half decades: 1e-3, 3.16e-4, ...)\n"
        "  --time T            end time, s (default: min(0.5, the scene's duration))\n"
        "  --repeats R         timed repeats per point, median reported (default 5)\n"
        "  --threads N         assembly threads (default 1, for timings that compare the\n"
        "                      methods; 0: OpenMP's default)\n"
        "  --set KEY=VALUE     override a scene value, as in defsim run; repeatable\n"
        "  --option NAME=VALUE set an option by name (\"sundials_ida.linear_solver=klu\") in\n"
        "                      the runs of the backend it names (not in the reference);\n"
        "                      repeatable\n"
        "  --out DIR           output folder (default bench_<scene>)\n"
        "  --reference FILE    reference file to use, or to write if it does not exist\n"
        "                      (default DIR/<scene>_reference_<hash>.txt)\n"
        "  --python PATH       interpreter for tools/plot_wp.py (default $DEFSIM_PYTHON or\n"
        "                      python3)\n"
        "  --plot-script PATH  the plotting script (default: tools/plot_wp.py of the source)\n"
        "  --no-plot           do not call the plotting script\n"
        "  --list-variants     compute or load the reference, then print the runs as JSON\n"
        "                      lines (index, backend, kind, value) and stop\n"
        "  --variant K         run only run K (the reference must be cached: --list-variants\n"
        "                      first); print the CSV header and its row\n"
        "  --rows FILE         take the runs' rows from FILE (the --variant K outputs, in\n"
        "                      order) instead of running them; write the CSV, table and plot\n"
        "  -h, --help          this text\n"
        "  --version           the library's version\n"
        "Exit status: 0 done (also when no plot could be made), 1 error, 2 usage error.\n");
}

/* Comma-separated positive numbers. Returns the count, or -1. */
int bench_parse_list(const char *s, double *out, int max)
{
    int n = 0;
    while (*s) {
        char *end = NULL;
        const double v = strtod(s, &end);
        if (end == s || !(v > 0.0) || !isfinite(v) || n == max) return -1;
        out[n++] = v;
        s = end;
        if (*s == ',') ++s;
        else if (*s) return -1;
    }
    return n;
}

static int cmp_double(const void *a, const void *b)
{
    const double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

double bench_median(double *v, int n)
{
    qsort(v, (size_t)n, sizeof *v, cmp_double);
    return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

defsim_status bench_build(scene *s, const char *backend, int threads, double rtol, double size,
                          defsim_world **w)
{
    s->def.backend = backend;
    s->def.num_threads = threads;
    if (rtol > 0.0) {
        scene_setting(s, SCENE_RTOL, rtol);
        scene_setting(s, SCENE_ATOL, rtol * size);
        scene_setting(s, SCENE_MAX_INTERNAL_STEPS, 10000000);
    }
    snprintf(s->backend, sizeof s->backend, "%s", backend);
    return scene_build(s, w);
}

static defsim_status build(bench *b, const char *backend, double rtol, defsim_world **w)
{
    return bench_build(&b->s, backend, b->threads, rtol, b->size, w);
}

/* Sets the --option values that name `backend` (or "core.") on w. */
static defsim_status apply_options(const bench *b, const char *backend, defsim_world *w)
{
    const size_t bl = strlen(backend);
    for (int i = 0; i < b->nopts; ++i) {
        const char *o = b->opts[i], *eq = strchr(o, '=');
        if (strncmp(o, "core.", 5) && (strncmp(o, backend, bl) || o[bl] != '.')) continue;
        char name[128];
        snprintf(name, sizeof name, "%.*s", (int)(eq - o), o);
        const defsim_status st = defsim_world_set_option(w, name, eq + 1);
        if (st != DEFSIM_OK) {
            fprintf(stderr, "defsim bench: --option %s: %s\n", o, defsim_world_last_error(w));
            return st;
        }
    }
    return DEFSIM_OK;
}

/* Steps `w` to T: fixed steps of h (is_tol 0) or calls of one frame each (adaptive). */
static defsim_status advance(bench *b, defsim_world *w, int is_tol, double h, long long n)
{
    for (long long i = 0; i < n; ++i) {
        const double step = (is_tol && i == n - 1) ? b->T - defsim_world_time(w) : h;
        const defsim_status st = defsim_world_step(w, step);
        if (st != DEFSIM_OK) return st;
    }
    return DEFSIM_OK;
}

/* Position errors (over free vertices, relative to the body size) of x against the reference. */
static void position_error(const bench *b, const double *x, const double *xr, double *rms,
                           double *max)
{
    double sum = 0.0, mx = 0.0;
    int32_t n = 0;
    for (int32_t i = 0; i < b->nv; ++i) {
        if (b->pinned[i]) continue;
        const double dx = x[3 * i] - xr[3 * i], dy = x[3 * i + 1] - xr[3 * i + 1],
                     dz = x[3 * i + 2] - xr[3 * i + 2];
        const double d2 = dx * dx + dy * dy + dz * dz;
        sum += d2;
        if (d2 > mx) mx = d2;
        ++n;
    }
    *rms = n ? sqrt(sum / n) / b->size : 0.0;
    *max = sqrt(mx) / b->size;
}

static void run_point(bench *b, const refsol *ref, point *p)
{
    double h = p->value;
    long long n;
    if (p->is_tol) {
        h = b->frame_dt;
        n = (long long)ceil(b->T / h - 1e-9);
    } else {
        /* Whole steps that end exactly on T: h is shortened slightly if T/h is not whole. */
        n = (long long)ceil(b->T / h - 1e-9);
        if (n < 1) n = 1;
        h = b->T / (double)n;
        p->value = h;
    }
    double walls[64];
    int nw = 0;
    snprintf(p->status, sizeof p->status, "ok");
    for (int r = 0; r < b->repeats && r < 64; ++r) {
        defsim_world *w = NULL;
        defsim_status st = build(b, p->backend, p->is_tol ? p->value : 0.0, &w);
        if (st != DEFSIM_OK) {
            snprintf(p->status, sizeof p->status, "%s", defsim_status_string(st));
            fprintf(stderr, "defsim bench: %s\n", b->s.error);
            return;
        }
        if ((st = apply_options(b, p->backend, w)) != DEFSIM_OK) {
            snprintf(p->status, sizeof p->status, "%s", defsim_status_string(st));
            defsim_world_destroy(w);
            return;
        }
        const double t0 = tools_now();
        st = advance(b, w, p->is_tol, h, n);
        const double t1 = tools_now();
        defsim_stats stats = {.size = sizeof stats};
        defsim_world_stats(w, &stats);
        p->steps = stats.steps;
        p->newton = (int64_t)tools_backend_stat(w, "newton_iterations");
        p->internal = (int64_t)tools_backend_stat(w, "internal_steps");
        if (st != DEFSIM_OK) {
            /* A failed run is not timed again: its failure is the result. */
            snprintf(p->status, sizeof p->status, "%s",
                     st == DEFSIM_ERR_UNSTABLE        ? "unstable"
                     : st == DEFSIM_ERR_NOT_CONVERGED ? "not_converged"
                                                      : defsim_status_string(st));
            p->wall = t1 - t0;
            p->rms = p->max = p->energy = NAN;
            defsim_world_destroy(w);
            return;
        }
        walls[nw++] = t1 - t0;
        if (r == b->repeats - 1 || r == 63) {
            defsim_energy e;
            defsim_world_get_positions(w, b->x, b->nv);
            defsim_world_energy(w, &e);
            position_error(b, b->x, ref->x, &p->rms, &p->max);
            p->energy = fabs(e.total - ref->energy.total) / b->energy_scale;
            if (!isfinite(p->rms) || !isfinite(p->energy) || p->rms > DIVERGED_RMS ||
                p->energy > DIVERGED_ENERGY)
                snprintf(p->status, sizeof p->status, "diverged");
        }
        defsim_world_destroy(w);
    }
    p->wall = bench_median(walls, nw);
}

/* The reference cache key, as 16 hex digits. */
static int reference_key(const bench *b, char key[17], char *err, size_t errlen)
{
    FILE *f = fopen(b->scene_path, "rb");
    if (!f) {
        snprintf(err, errlen, "%s: %s", b->scene_path, strerror(errno));
        return -1;
    }
    uint64_t h = 14695981039346656037ULL;
    h = tools_fnv1a(h, REF_FORMAT, sizeof REF_FORMAT);
    char buf[4096];
    size_t n;
    while ((n = fread(buf, 1, sizeof buf, f)) > 0) h = tools_fnv1a(h, buf, n);
    fclose(f);
    for (int i = 0; i < b->nsets; ++i) h = tools_fnv1a(h, b->sets[i], strlen(b->sets[i]) + 1);
    snprintf(buf, sizeof buf, "T=%.17g", b->T);
    h = tools_fnv1a(h, buf, strlen(buf) + 1);
    snprintf(key, 17, "%016llx", (unsigned long long)h);
    return 0;
}

/* The "key" line of a reference file, or "" if it has none; *check_err (if not NULL) gets its
 * "check_rms_err" value, or 0 if it has none. */
static void read_key(const char *path, char key[64], double *check_err)
{
    key[0] = '\0';
    if (check_err) *check_err = 0.0;
    FILE *f = fopen(path, "r");
    if (!f) return;
    char line[1024];
    while (fgets(line, sizeof line, f) && strncmp(line, "vertices", 8) != 0)
        if (sscanf(line, "key %63s", key) != 1 && check_err)
            sscanf(line, "check_rms_err %lf", check_err);
    fclose(f);
}

static defsim_status integrate_reference(bench *b, double rtol, refsol *out)
{
    defsim_world *w = NULL;
    defsim_status st = build(b, REF_BACKEND, rtol, &w);
    if (st != DEFSIM_OK) {
        fprintf(stderr, "defsim bench: reference: %s\n", b->s.error);
        return st;
    }
    const int calls = (int)ceil(b->T / b->frame_dt - 1e-9);
    char tag[64];
    snprintf(tag, sizeof tag, "  reference rtol %g", rtol);
    st = refsol_integrate(w, b->T, calls < 1 ? 1 : calls, rtol, rtol * b->size,
                          isatty(STDERR_FILENO) ? tag : NULL, out);
    out->backend = REF_BACKEND;
    defsim_world_destroy(w);
    return st;
}

/* Loads the cached reference or computes, checks and writes it. *cached tells which. */
static int get_reference(bench *b, const char *path, const char *key, refsol *ref, int *cached)
{
    char err[1200], file_key[64];
    *cached = 0;
    if (access(path, R_OK) == 0) {
        read_key(path, file_key, NULL);
        if (file_key[0] && strcmp(file_key, key) != 0) {
            fprintf(stderr, "defsim bench: %s was computed for another scene, overrides or end "
                            "time (key %s, here %s); remove it or name another file\n",
                    path, file_key, key);
            return -1;
        }
        if (refsol_read(path, ref, err, sizeof err) != 0) {
            fprintf(stderr, "defsim bench: %s\n", err);
            return -1;
        }
        if (ref->vertex_count != b->nv || fabs(ref->end_time - b->T) > 1e-9 * b->T) {
            fprintf(stderr, "defsim bench: %s has %d vertices at t = %g s; the scene has %d, "
                            "T = %g s\n", path, (int)ref->vertex_count, ref->end_time,
                    (int)b->nv, b->T);
            refsol_free(ref);
            return -1;
        }
        *cached = 1;
        printf("reference: cached %s (rtol %g, %lld internal steps, took %.1f s "
               "when computed)%s\n", path, ref->rtol, (long long)ref->internal_steps,
               ref->wall_seconds, file_key[0] ? "" : " [no key: trusted as given]");
        return 0;
    }
    printf("reference: computing %s at rtol %g (check at %g) to T = %g s ...\n", REF_BACKEND,
           REF_RTOL, REF_CHECK_RTOL, b->T);
    fflush(stdout);
    refsol check;
    if (integrate_reference(b, REF_RTOL, ref) != DEFSIM_OK) return -1;
    if (integrate_reference(b, REF_CHECK_RTOL, &check) != DEFSIM_OK) {
        refsol_free(ref);
        return -1;
    }
    double rms, max;
    position_error(b, check.x, ref->x, &rms, &max);
    const double de = fabs(check.energy.total - ref->energy.total) / b->energy_scale;
    printf("reference: %.1f s, %lld internal steps; rtol %g against %g: position error RMS %.2e "
           "max %.2e (of the body size), energy %.2e\n", ref->wall_seconds,
           (long long)ref->internal_steps, REF_CHECK_RTOL, REF_RTOL, rms, max, de);
    FILE *f = fopen(path, "w");
    if (!f) {
        fprintf(stderr, "defsim bench: cannot write %s: %s\n", path, strerror(errno));
        refsol_free(ref);
        refsol_free(&check);
        return -1;
    }
    fprintf(f, "defsim-reference 1\nscene %s\nscene_name %s\nkey %s\nformat %s\n",
            b->scene_path, b->s.name, key, REF_FORMAT);
    for (int i = 0; i < b->nsets; ++i) fprintf(f, "set %s\n", b->sets[i]);
    fprintf(f, "size %.17g\nenergy_scale %.17g\n", b->size, b->energy_scale);
    fprintf(f, "check_rtol %.17g\ncheck_rms_err %.17g\ncheck_max_err %.17g\n"
               "check_energy_err %.17g\ncheck_wall_seconds %.3f\n",
            REF_CHECK_RTOL, rms, max, de, check.wall_seconds);
    const int wrote = refsol_write_tail(f, ref);
    refsol_free(&check);
    if (fclose(f) != 0 || wrote != 0) {
        fprintf(stderr, "defsim bench: error writing %s\n", path);
        refsol_free(ref);
        return -1;
    }
    return 0;
}

void bench_mark_pareto(point *p, int n)
{
    for (int i = 0; i < n; ++i) {
        p[i].pareto = 0;
        if (strcmp(p[i].status, "ok")) continue;
        int dominated = 0;
        for (int j = 0; j < n && !dominated; ++j)
            if (j != i && !strcmp(p[j].status, "ok") && p[j].wall <= p[i].wall &&
                p[j].rms <= p[i].rms && (p[j].wall < p[i].wall || p[j].rms < p[i].rms))
                dominated = 1;
        p[i].pareto = !dominated;
    }
}

void bench_setting(const point *p, char *buf, size_t n)
{
    snprintf(buf, n, "%s = %.3g%s", p->is_tol ? "tol" : "h", p->value, p->is_tol ? "" : " s");
}

/* Pareto table: for each error level 1e-1 .. 1e-8 the fastest point reaching it, and the
 * fastest point of any other backend (to show the margin), then the front's ratios t(1e-5) /
 * t(1e-3) and t(1e-8) / t(1e-3) (t(e): the fastest wall time reaching e; no cliff in the front
 * keeps them small). Printed and written as markdown. */
static int write_pareto(const bench *b, const point *p, int n, const char *path)
{
    FILE *f = fopen(path, "w");
    if (!f) {
        fprintf(stderr, "defsim bench: cannot write %s: %s\n", path, strerror(errno));
        return -1;
    }
    fprintf(f, "# Work-precision: %s, T = %g s\n\n", b->s.name, b->T);
    fprintf(f, "Error = RMS position error at T over the free vertices, relative to the "
               "bounding-box diagonal of the rest shape (%.4g m). Time = median wall time of "
               "the stepping loop.\n\n", b->size);
    fprintf(f, "| RMS error <= | fastest | setting | wall (s) | RMS error | next other backend "
               "| its wall (s) |\n|---|---|---|---|---|---|---|\n");
    printf("\nPareto table (RMS position error / body size at T = %g s):\n", b->T);
    printf("  %-8s  %-17s %-16s %10s %10s   %s\n", "level", "fastest", "setting", "wall_s",
           "rms_err", "next other backend");
    double t_level[9] = {0};   /* t(1e-k), 0: not reached */
    for (int k = 1; k <= 8; ++k) {
        const double level = pow(10.0, -k);
        int best = -1, other = -1;
        for (int i = 0; i < n; ++i)
            if (!strcmp(p[i].status, "ok") && p[i].rms <= level &&
                (best < 0 || p[i].wall < p[best].wall))
                best = i;
        if (best >= 0)
            for (int i = 0; i < n; ++i)
                if (!strcmp(p[i].status, "ok") && p[i].rms <= level &&
                    strcmp(p[i].backend, p[best].backend) &&
                    (other < 0 || p[i].wall < p[other].wall))
                    other = i;
        char s1[64], s2[160] = "none";
        if (best < 0) {
            fprintf(f, "| 1e-%d | none reached | | | | | |\n", k);
            printf("  1e-%-5d  none reached\n", k);
            continue;
        }
        t_level[k] = p[best].wall;
        bench_setting(&p[best], s1, sizeof s1);
        if (other >= 0) {
            char so[64];
            bench_setting(&p[other], so, sizeof so);
            snprintf(s2, sizeof s2, "%s (%s): %.3g s, %.1fx slower", p[other].backend, so,
                     p[other].wall, p[other].wall / p[best].wall);
            fprintf(f, "| 1e-%d | %s | %s | %.4g | %.2e | %s (%s) | %.4g |\n", k, p[best].backend,
                    s1, p[best].wall, p[best].rms, p[other].backend, so, p[other].wall);
        } else {
            fprintf(f, "| 1e-%d | %s | %s | %.4g | %.2e | none | |\n", k, p[best].backend, s1,
                    p[best].wall, p[best].rms);
        }
        printf("  1e-%-5d  %-17s %-16s %10.4g %10.2e   %s\n", k, p[best].backend, s1,
               p[best].wall, p[best].rms, s2);
    }
    if (t_level[3] > 0.0) {
        char r5[32] = "not reached", r8[32] = "not reached";
        if (t_level[5] > 0.0) snprintf(r5, sizeof r5, "%.2f", t_level[5] / t_level[3]);
        if (t_level[8] > 0.0) snprintf(r8, sizeof r8, "%.1f", t_level[8] / t_level[3]);
        printf("  front: t(1e-5) / t(1e-3) = %s, t(1e-8) / t(1e-3) = %s\n", r5, r8);
        fprintf(f, "\nFront: t(1e-5) / t(1e-3) = %s, t(1e-8) / t(1e-3) = %s (t(e): the fastest "
                   "wall time reaching RMS error e).\n", r5, r8);
    }
    fprintf(f, "\nPareto-optimal points (no other point is both faster and more accurate):\n\n");
    for (int i = 0; i < n; ++i)
        if (p[i].pareto) {
            char s1[64];
            bench_setting(&p[i], s1, sizeof s1);
            fprintf(f, "- %s, %s: %.4g s, RMS %.2e\n", p[i].backend, s1, p[i].wall, p[i].rms);
        }
    return fclose(f) == 0 ? 0 : -1;
}

#define CSV_HEADER "backend,kind,value,wall_s,rms_err,max_err,energy_err,status,steps," \
                   "newton_iterations,internal_steps,pareto"

static void write_rows(FILE *f, const point *p, int n)
{
    fprintf(f, CSV_HEADER "\n");
    for (int i = 0; i < n; ++i)
        fprintf(f, "%s,%s,%.10g,%.6g,%.6e,%.6e,%.6e,%s,%lld,%lld,%lld,%d\n", p[i].backend,
                p[i].is_tol ? "tol" : "h", p[i].value, p[i].wall, p[i].rms, p[i].max,
                p[i].energy, p[i].status, p[i].steps, p[i].newton, p[i].internal, p[i].pareto);
}

/* Observed order of each backend: the least-squares slope of log(RMS error) against log(mean
 * step), mean step = h (fixed-step) or T / internal steps (adaptive), over the `ORDER_POINTS`
 * finest ok points whose error is above 100 times the reference's own (so that the reference does
 * not set it) and below 1e-2 (the asymptotic range); none where those steps span less than 1.5x
 * (an adaptive backend held at its stability limit, or changing its order instead of its
 * step). Printed and appended to the Pareto file. */
#define ORDER_POINTS 3
static void write_orders(const bench *b, const point *p, int n, double ref_err, const char *path)
{
    FILE *f = fopen(path, "a");
    if (f) fprintf(f, "\nObserved orders (slope of log RMS error against log mean step over the "
                      "%d finest points with error in [%.1e, 1e-2]):\n\n", ORDER_POINTS,
                   100.0 * ref_err);
    printf("\nObserved orders (%d finest points with RMS error in [%.1e, 1e-2]):\n", ORDER_POINTS,
           100.0 * ref_err);
    for (int i = 0; i < n; ++i) {
        int seen = 0;
        for (int j = 0; j < i; ++j) seen |= !strcmp(p[j].backend, p[i].backend);
        if (seen) continue;
        double hs[MAX_VALUES], es[MAX_VALUES];
        int m = 0;
        for (int j = i; j < n && m < MAX_VALUES; ++j) {
            const point *q = &p[j];
            if (strcmp(q->backend, p[i].backend) || strcmp(q->status, "ok") ||
                !(q->rms >= 100.0 * ref_err && q->rms <= 1e-2))
                continue;
            const double h = q->is_tol ? (q->internal > 0 ? b->T / (double)q->internal : 0.0)
                                       : q->value;
            if (!(h > 0.0)) continue;
            hs[m] = h;
            es[m++] = q->rms;
        }
        /* The finest ORDER_POINTS by mean step (insertion sort, ascending h). */
        for (int a = 1; a < m; ++a)
            for (int c = a; c > 0 && hs[c] < hs[c - 1]; --c) {
                double t = hs[c]; hs[c] = hs[c - 1]; hs[c - 1] = t;
                t = es[c]; es[c] = es[c - 1]; es[c - 1] = t;
            }
        const int k = m < ORDER_POINTS ? m : ORDER_POINTS;
        double sx = 0, sy = 0, sxx = 0, sxy = 0;
        for (int a = 0; a < k; ++a) {
            const double x = log(hs[a]), y = log(es[a]);
            sx += x; sy += y; sxx += x * x; sxy += x * y;
        }
        const double den = k * sxx - sx * sx;
        if (k < 2 || !(fabs(den) > 1e-12)) {
            printf("  %-17s  too few points\n", p[i].backend);
            if (f) fprintf(f, "- %s: too few points\n", p[i].backend);
            continue;
        }
        if (hs[k - 1] < 1.5 * hs[0]) {
            /* An adaptive backend whose mean step hardly changes with its tolerance (sundials_erk
             * held at its stability limit, sundials_ida changing its order): no order in h. */
            printf("  %-17s  none: mean steps %.3g .. %.3g s, too close for a slope\n",
                   p[i].backend, hs[0], hs[k - 1]);
            if (f) fprintf(f, "- %s: none (mean steps %.3g to %.3g s, too close for a slope)\n",
                           p[i].backend, hs[0], hs[k - 1]);
            continue;
        }
        const double order = (k * sxy - sx * sy) / den;
        printf("  %-17s  %.2f  (mean steps %.3g .. %.3g s)\n", p[i].backend, order, hs[0],
               hs[k - 1]);
        if (f) fprintf(f, "- %s: %.2f (mean steps %.3g to %.3g s)\n", p[i].backend, order, hs[0],
                       hs[k - 1]);
    }
    if (f) fclose(f);
}

static int write_csv(const point *p, int n, const char *path)
{
    FILE *f = fopen(path, "w");
    if (!f) {
        fprintf(stderr, "defsim bench: cannot write %s: %s\n", path, strerror(errno));
        return -1;
    }
    write_rows(f, p, n);
    return fclose(f) == 0 ? 0 : -1;
}

/* The next row of a --rows file into p, whose backend and kind the run order fixes: the
 * numbers parse back to what the run printed (the CSV's formats, printed again, give the same
 * text). Header lines are skipped. Returns 0, or -1 with a message. */
static int read_row(FILE *f, point *p)
{
    char line[1024], *save = NULL;
    do {
        if (!fgets(line, sizeof line, f)) {
            fprintf(stderr, "defsim bench: --rows: fewer rows than runs\n");
            return -1;
        }
    } while (!strncmp(line, "backend,", 8) || line[0] == '\n');
    line[strcspn(line, "\r\n")] = '\0';
    char *fld[12];
    int n = 0;
    for (char *t = strtok_r(line, ",", &save); t && n < 12; t = strtok_r(NULL, ",", &save))
        fld[n++] = t;
    if (n != 12 || strcmp(fld[0], p->backend) || strcmp(fld[1], p->is_tol ? "tol" : "h")) {
        fprintf(stderr, "defsim bench: --rows: a row does not match run %s %s (wrong order or "
                        "other arguments)\n", p->backend, p->is_tol ? "tol" : "h");
        return -1;
    }
    p->value = strtod(fld[2], NULL);
    p->wall = strtod(fld[3], NULL);
    p->rms = strtod(fld[4], NULL);
    p->max = strtod(fld[5], NULL);
    p->energy = strtod(fld[6], NULL);
    snprintf(p->status, sizeof p->status, "%s", fld[7]);
    p->steps = strtoll(fld[8], NULL, 10);
    p->newton = strtoll(fld[9], NULL, 10);
    p->internal = strtoll(fld[10], NULL, 10);
    return 0;
}

/* Runs the plotting script. Never fails the bench: says how to make the plot by hand. */
void bench_plot(const char *python, const char *script, const char *csv, const char *png,
                const char *title)
{
    if (!script[0] || access(script, R_OK) != 0) {
        printf("plot: no plotting script found (pass --plot-script tools/plot_wp.py); make the "
               "plot with\n  python3 tools/plot_wp.py %s --out %s\n", csv, png);
        return;
    }
    char *argv[] = {(char *)python, (char *)script, (char *)csv, "--out", (char *)png,
                    "--title", (char *)title, NULL};
    pid_t pid;
    int status = 0;
    fflush(stdout);
    if (posix_spawnp(&pid, python, NULL, NULL, argv, environ) != 0 ||
        waitpid(pid, &status, 0) < 0 || !WIFEXITED(status) || WEXITSTATUS(status) != 0) {
        printf("plot: %s %s did not make the plot (%s); with matplotlib installed, run\n"
               "  %s %s %s --out %s\n", python, script,
               WIFEXITED(status) && WEXITSTATUS(status) == 3 ? "matplotlib is missing"
                                                             : "interpreter or script failed",
               python, script, csv, png);
        return;
    }
    printf("plot: %s\n", png);
}

int defsim_tool_bench(int argc, char **argv)
{
    for (int i = 1; i < argc; ++i)
        if (!strcmp(argv[i], "--spatial")) return defsim_tool_bench_spatial(argc, argv);
        else if (!strcmp(argv[i], "--")) break;
    const char *scene_path = NULL, *out_dir = NULL, *ref_path = NULL, *rows_path = NULL;
    int list_variants = 0;
    long variant = -1;   /* >= 0: run only this one (defsim-sweep --tool bench) */
    const char *python = getenv("DEFSIM_PYTHON"), *script = DEFSIM_BENCH_PLOT_SCRIPT;
    const char *backend_list = NULL;
    double hs[MAX_VALUES], tols[MAX_VALUES], T = 0.0;
    int nh = 0, ntol = 0, repeats = 5, threads = 1, no_plot = 0;
    bench b;
    memset(&b, 0, sizeof b);
    if (!python || !python[0]) python = "python3";
    enum { O_BACKENDS = CLI_OPT, O_H, O_TOL, O_TIME, O_REPEATS, O_THREADS, O_SET, O_OPTION,
           O_OUT, O_REFERENCE, O_PYTHON, O_PLOT_SCRIPT, O_ROWS, O_VARIANT, O_NO_PLOT,
           O_LIST_VARIANTS };
    static const struct option options[] = {
        {"backends", required_argument, NULL, O_BACKENDS}, {"h", required_argument, NULL, O_H},
        {"tol", required_argument, NULL, O_TOL}, {"time", required_argument, NULL, O_TIME},
        {"repeats", required_argument, NULL, O_REPEATS},
        {"threads", required_argument, NULL, O_THREADS},
        {"set", required_argument, NULL, O_SET}, {"option", required_argument, NULL, O_OPTION},
        {"out", required_argument, NULL, O_OUT},
        {"reference", required_argument, NULL, O_REFERENCE},
        {"python", required_argument, NULL, O_PYTHON},
        {"plot-script", required_argument, NULL, O_PLOT_SCRIPT},
        {"rows", required_argument, NULL, O_ROWS}, {"variant", required_argument, NULL, O_VARIANT},
        {"no-plot", no_argument, NULL, O_NO_PLOT},
        {"list-variants", no_argument, NULL, O_LIST_VARIANTS}, {0}};
    static const cli_tool tool = {"defsim bench", usage, options, ""};
    cli c;
    cli_begin(&c, &tool, argc, argv);
    for (int o; (o = cli_next(&c)) != CLI_END;) {
        const char *v = c.arg;
        switch (o) {
        case CLI_EXIT: return c.status;
        case O_NO_PLOT: no_plot = 1; break;
        case O_LIST_VARIANTS: list_variants = 1; break;
        case O_BACKENDS: backend_list = v; break;
        case O_H:
            if ((nh = bench_parse_list(v, hs, MAX_VALUES)) <= 0)
                return cli_error(&c, "--h: need up to %d positive numbers: %s", MAX_VALUES, v);
            break;
        case O_TOL:
            if ((ntol = bench_parse_list(v, tols, MAX_VALUES)) <= 0)
                return cli_error(&c, "--tol: need up to %d positive numbers: %s", MAX_VALUES, v);
            break;
        case O_TIME:
            if (!cli_positive(&c, &T)) return c.status;
            break;
        case O_REPEATS:
            if (!cli_int(&c, 1, 64, &repeats)) return c.status;
            break;
        case O_THREADS:
            if (!cli_int(&c, 0, 1024, &threads)) return c.status;
            break;
        case O_SET:
            if (b.nsets == MAX_SETS || !strchr(v, '='))
                return cli_error(&c, "--set KEY=VALUE (at most %d): %s", MAX_SETS, v);
            b.sets[b.nsets++] = v;
            break;
        case O_OPTION:
            if (b.nopts == MAX_SETS || !strchr(v, '=') || strchr(v, '=') == v)
                return cli_error(&c, "--option NAME=VALUE (at most %d): %s", MAX_SETS, v);
            b.opts[b.nopts++] = v;
            break;
        case O_OUT: out_dir = v; break;
        case O_REFERENCE: ref_path = v; break;
        case O_PYTHON: python = v; break;
        case O_PLOT_SCRIPT: script = v; break;
        case O_ROWS: rows_path = v; break;
        case O_VARIANT:
            if (!cli_long(&c, 0, LONG_MAX, &variant)) return c.status;
            break;
        }
    }
    if (c.optind + 1 < argc) return cli_error(&c, "one scene file at a time");
    if (c.optind < argc) scene_path = argv[c.optind];
    if (!scene_path) return cli_error(&c, "no scene file");

    /* Backends: the list, in order, without duplicates. */
    const char *backends[MAX_BACKENDS];
    char names[MAX_BACKENDS][64];
    int nb = 0;
    if (backend_list) {
        const char *p = backend_list;
        while (*p) {
            const size_t len = strcspn(p, ",");
            if (len == 0 || len >= 64 || nb == MAX_BACKENDS) {
                fprintf(stderr, "defsim bench: --backends: bad list: %s\n", backend_list);
                return 2;
            }
            memcpy(names[nb], p, len);
            names[nb][len] = '\0';
            int dup = 0;
            for (int k = 0; k < nb; ++k) dup |= !strcmp(names[k], names[nb]);
            if (!dup) {
                backends[nb] = names[nb];
                ++nb;
            }
            p += len;
            if (*p == ',') ++p;
        }
    } else {
        for (size_t k = 0; k < sizeof all_backends / sizeof *all_backends; ++k)
            backends[nb++] = all_backends[k];
    }
    if (scene_load(&b.s, scene_path, b.sets, b.nsets) != 0) {
        fprintf(stderr, "defsim bench: %s\n", b.s.error);
        return 1;
    }
    /* The reference integrator takes whole frames: a path would move only at frame ends. */
    if (scene_has_paths(&b.s)) {
        fprintf(stderr, "defsim bench: %s: driven pins and keyframed attachments (\"drive\", "
                "\"target.keys\") are not supported by the work-precision benchmark\n", scene_path);
        scene_free(&b.s);
        return 1;
    }
    b.scene_path = scene_path;
    b.repeats = repeats;
    b.threads = threads;
    b.T = T > 0.0 ? T : fmin(0.5, b.s.duration);
    b.frame_dt = b.s.h * b.s.frame_steps;
    int rc = 1;
    refsol ref = {0};
    point *pts = NULL;

    /* Body size: the bounding-box diagonal of the rest shape of all bodies. */
    double lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
    double mass = 0.0;
    for (int32_t i = 0; i < b.s.nbodies; ++i)
        for (int32_t v = 0; v < b.s.bodies[i].mesh.vertex_count; ++v)
            for (int k = 0; k < 3; ++k) {
                lo[k] = fmin(lo[k], b.s.bodies[i].mesh.positions[3 * v + k]);
                hi[k] = fmax(hi[k], b.s.bodies[i].mesh.positions[3 * v + k]);
            }
    b.size = sqrt((hi[0] - lo[0]) * (hi[0] - lo[0]) + (hi[1] - lo[1]) * (hi[1] - lo[1]) +
                  (hi[2] - lo[2]) * (hi[2] - lo[2]));

    /* A symplectic world gives the initial state, masses, energies and pins. */
    defsim_world *w0 = NULL;
    if (build(&b, "symplectic_euler", 0.0, &w0) != DEFSIM_OK) {
        fprintf(stderr, "defsim bench: %s\n", b.s.error);
        goto done;
    }
    b.nv = defsim_world_vertex_count(w0);
    b.x = malloc(3 * (size_t)b.nv * sizeof *b.x);
    b.v = malloc(3 * (size_t)b.nv * sizeof *b.v);
    b.pinned = calloc((size_t)b.nv, 1);
    double *m = malloc((size_t)b.nv * sizeof *m);
    if (!b.x || !b.v || !b.pinned || !m) {
        free(m);
        defsim_world_destroy(w0);
        fprintf(stderr, "defsim bench: out of memory\n");
        goto done;
    }
    defsim_world_get_masses(w0, m, b.nv);
    for (int32_t i = 0; i < b.nv; ++i) mass += m[i];
    free(m);
    for (int32_t i = 0; i < b.s.nbodies; ++i)
        for (int32_t k = 0; k < b.s.bodies[i].npins; ++k)
            b.pinned[b.s.bodies[i].offset + b.s.bodies[i].pins[k]] = 1;
    /* Energy scale: the initial kinetic and elastic energy plus the potential energy of the
     * whole mass lifted by one body size in the scene's gravity. */
    defsim_energy e0;
    defsim_world_energy(w0, &e0);
    const double *g = b.s.def.gravity;
    b.energy_scale = fabs(e0.kinetic) + fabs(e0.elastic) +
                     mass * sqrt(g[0] * g[0] + g[1] * g[1] + g[2] * g[2]) * b.size;
    if (!(b.energy_scale > 0.0)) b.energy_scale = 1.0;
    defsim_world_destroy(w0);

    /* Default sweeps. */
    /* h: geometric from the scene's h to 1/30 s, ratio about 2 (both ends included). */
    if (nh == 0) {
        const double top = 1.0 / 30.0;
        if (b.s.h >= top) {
            hs[nh++] = b.s.h;
        } else {
            int steps = (int)ceil(log2(top / b.s.h) - 1e-9);
            if (steps > MAX_VALUES - 1) steps = MAX_VALUES - 1;
            for (int k = 0; k <= steps; ++k)
                hs[nh++] = b.s.h * pow(top / b.s.h, (double)k / steps);
        }
    }
    /* Tolerances in half decades: the adaptive backends' errors are not tied one to one to
     * their tolerance, so a decade grid can miss the cheapest setting for an error level. */
    if (ntol == 0)
        for (int k = 6; k <= 16; ++k) tols[ntol++] = pow(10.0, -0.5 * k);

    /* Which backends exist here. */
    const char *use[MAX_BACKENDS];
    int nuse = 0, have_ref = 0;
    for (int k = 0; k < nb; ++k) {
        defsim_world_def wd;
        defsim_world_def_init(&wd, sizeof wd);
        wd.backend = backends[k];
        defsim_world *w = NULL;
        const defsim_status st = defsim_world_create(&wd, &w);
        defsim_world_destroy(w);
        if (st != DEFSIM_OK) {
            printf("note: backend %s skipped: %s: %s\n", backends[k], defsim_status_string(st),
                   defsim_last_error());
            continue;
        }
        use[nuse++] = backends[k];
    }
    {
        defsim_world_def wd;
        defsim_world_def_init(&wd, sizeof wd);
        wd.backend = REF_BACKEND;
        defsim_world *w = NULL;
        have_ref = defsim_world_create(&wd, &w) == DEFSIM_OK;
        defsim_world_destroy(w);
    }
    if (nuse == 0) {
        fprintf(stderr, "defsim bench: none of the backends is available\n");
        goto done;
    }

    char dir[1024], path[1400], key[17], err[1200];
    if (out_dir) snprintf(dir, sizeof dir, "%s", out_dir);
    else snprintf(dir, sizeof dir, "bench_%s", b.s.name);
    if (tools_make_dirs(dir) != 0) {
        fprintf(stderr, "defsim bench: cannot create %s: %s\n", dir, strerror(errno));
        goto done;
    }
    if (reference_key(&b, key, err, sizeof err) != 0) {
        fprintf(stderr, "defsim bench: %s\n", err);
        goto done;
    }
    if (ref_path) snprintf(path, sizeof path, "%s", ref_path);
    else snprintf(path, sizeof path, "%s/%s_reference_%s.txt", dir, b.s.name, key);
    printf("defsim bench: %s, %d vertices, T = %g s, body size %.4g m, energy scale %.4g J, "
           "%d repeat(s)\n", b.s.name, (int)b.nv, b.T, b.size, b.energy_scale, b.repeats);
    int cached = 0;
    if (!have_ref && access(path, R_OK) != 0) {
        fprintf(stderr, "defsim bench: the reference needs the " REF_BACKEND " backend, which is "
                        "not available, and %s does not exist\n", path);
        goto done;
    }
    /* Runs of a distributed sweep must not compute the reference each (nor race writing it). */
    if (variant >= 0 && access(path, R_OK) != 0) {
        fprintf(stderr, "defsim bench: --variant: no cached reference %s (run --list-variants "
                        "with the same arguments first)\n", path);
        goto done;
    }
    if (get_reference(&b, path, key, &ref, &cached) != 0) goto done;

    /* The sweep. */
    int npts = 0;
    long index = -1;
    const int one = list_variants || variant >= 0;
    FILE *rows = rows_path ? fopen(rows_path, "r") : NULL;
    if (rows_path && !rows) {
        fprintf(stderr, "defsim bench: --rows: cannot read %s: %s\n", rows_path, strerror(errno));
        goto done;
    }
    pts = calloc((size_t)nuse * MAX_VALUES, sizeof *pts);
    if (!pts) goto done;
    if (!one)
        printf("\n%-17s %-5s %10s %10s %10s %10s %10s  %s\n", "backend", "kind", "value",
               "wall_s", "rms_err", "max_err", "energy_err", "status");
    for (int k = 0; k < nuse; ++k) {
        const int is_tol = bench_swept_by_tolerance(use[k]);
        const int nval = is_tol ? ntol : nh;
        for (int j = 0; j < nval; ++j) {
            ++index;
            if (list_variants) {
                printf("{\"index\": %ld, \"backend\": \"%s\", \"kind\": \"%s\", "
                       "\"value\": %.17g}\n", index, use[k], is_tol ? "tol" : "h",
                       is_tol ? tols[j] : hs[j]);
                continue;
            }
            if (variant >= 0 && index != variant) continue;
            point *p = &pts[npts++];
            p->backend = use[k];
            p->is_tol = is_tol;
            p->value = is_tol ? tols[j] : hs[j];
            if (rows && read_row(rows, p) != 0) {
                fclose(rows);
                goto done;
            }
            if (!rows) run_point(&b, &ref, p);
            if (!one) printf("%-17s %-5s %10.4g %10.4g %10.3e %10.3e %10.3e  %s\n", p->backend,
                   is_tol ? "tol" : "h", p->value, p->wall, p->rms, p->max, p->energy,
                   p->status);
            fflush(stdout);
        }
    }
    if (rows) fclose(rows);
    if (one) {
        if (variant >= 0 && npts == 1) write_rows(stdout, pts, 1);
        else if (variant >= 0) {
            fprintf(stderr, "defsim bench: --variant %ld: there are %ld runs\n", variant,
                    index + 1);
            rc = 2;
            goto done;
        }
        rc = 0;
        goto done;
    }
    bench_mark_pareto(pts, npts);
    char csv[1500], png[1500], md[1500], title[512];
    snprintf(csv, sizeof csv, "%s/%s.csv", dir, b.s.name);
    snprintf(png, sizeof png, "%s/%s.png", dir, b.s.name);
    snprintf(md, sizeof md, "%s/%s_pareto.md", dir, b.s.name);
    if (write_csv(pts, npts, csv) != 0 || write_pareto(&b, pts, npts, md) != 0) goto done;
    double ref_err = 0.0;
    char file_key[64];
    read_key(path, file_key, &ref_err);
    write_orders(&b, pts, npts, ref_err, md);
    printf("\nwrote %s, %s\n", csv, md);
    snprintf(title, sizeof title, "%s: %d vertices, T = %g s", b.s.name, (int)b.nv, b.T);
    if (!no_plot) bench_plot(python, script, csv, png, title);
    rc = 0;
done:
    free(pts);
    refsol_free(&ref);
    free(b.x);
    free(b.v);
    free(b.pinned);
    scene_free(&b.s);
    return rc;
}
