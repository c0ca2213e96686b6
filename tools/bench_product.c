/* SPDX-License-Identifier: MIT */
/*
 * defsim-bench-product: what contact costs a matrix-vector product and the power iteration
 * (issue 24). Runs a shipped scene (default tests/scenes/cloth_fold.json and
 * tests/scenes/ground_box_sphere.json) for --steps steps with its backend, then attaches contact
 * at the state reached as a step does (colliders, and body contact where the scene turns it on),
 * grows the pattern with its pairs, and times, as medians over --repeat rounds of --products
 * products each:
 *  - the product A dx (A = M + K) with contact on, its terms reading the blocks they cached when
 *    they linearised at x (what the term interface does: no geometry in a product);
 *  - the same with the caches dropped before every product, so that contact evaluates its
 *    blocks again in each one (what products did before the term interface);
 *  - the product with contact off, over the same (grown) pattern: equal non-zeros;
 *  - the contact terms alone: their apply from the cache, and their linearise;
 * and the power iteration of the stable step (omega_max, up to 300 products at one x) with
 * contact on (cached), with the caches dropped before each of its products, and off.
 * Process CPU time (single thread; the machine may be loaded). Internal functions: links the
 * static library. A tool, not a test.
 *
 *   DEFSIM_BACKEND_PATH=build/modules defsim-bench-product [SCENE[:STEPS]]... [--products P]
 *                                                           [--repeat R]
 */
#include "cli.h"
#include "clock.h"
#include "scene.h"

#include "assembly.h"
#include "options.h"
#include "stability.h"
#include "terms.h"
#include "world.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#ifndef DEFSIM_BENCH_SCENES
#define DEFSIM_BENCH_SCENES "tests/scenes"
#endif

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

static void drop_caches(defsim__system *s)
{
    for (int k = 0; k < DEFSIM__TERM_KINDS; ++k) s->cache[k].valid = 0;
}

/* Microseconds per product, median of `repeat` rounds of `np` products. */
static double time_products(defsim__system *s, const double *x, const double *dx, double *out,
                            int np, int repeat, int drop)
{
    const defsim_matrix_coeffs c = {1.0, 0.0, 1.0, 0.0};
    double r[99] = {0};
    defsim__matrix_apply(s, x, &c, s->projection, dx, out);   /* linearise once, warm */
    for (int k = 0; k < repeat; ++k) {
        const double t0 = tools_cpu_now();
        for (int i = 0; i < np; ++i) {
            if (drop) drop_caches(s);
            defsim__matrix_apply(s, x, &c, s->projection, dx, out);
        }
        r[k] = 1e6 * (tools_cpu_now() - t0) / np;
    }
    return median(r, repeat);
}

/* Microseconds per call of the contact terms alone (those that linearise into a cache): their
 * apply from the cache (lin 0) or their linearise (lin 1); median of `repeat` rounds. */
static double time_contact(defsim__system *s, const double *x, const double *dx, double *out,
                           int np, int repeat, int lin)
{
    const defsim_matrix_coeffs c = {1.0, 0.0, 1.0, 0.0};
    double r[99] = {0};
    for (int k = 0; k < repeat; ++k) {
        const double t0 = tools_cpu_now();
        for (int i = 0; i < np; ++i)
            for (int32_t j = 0; j < s->nterms; ++j) {
                const defsim__term *t = &s->terms[j];
                if (!t->ops->linearise || !t->cache->buf) continue;   /* kinds that cache blocks */
                if (lin) t->ops->linearise(t, s, x, &c, DEFSIM__LIN_VALUES);
                else t->ops->apply(t, s, x, &c, s->projection, dx, out);
            }
        r[k] = 1e6 * (tools_cpu_now() - t0) / np;
    }
    return median(r, repeat);
}

/* The power iteration of defsim__omega_max (same start, stop and products), with the caches
 * dropped before each product when `drop`: returns its products. */
static int power_iteration(defsim__system *s, defsim__work *wk, const double *x, int drop,
                           double *lambda_out)
{
    const int64_t ndof = 3 * (int64_t)s->nv;
    double *z = wk->pz, *y = wk->py, *u = wk->pu;
    const defsim_matrix_coeffs ck = {1.0, 0.0, 0.0, 0.0};
    unsigned long long seed = 0x9E3779B97F4A7C15ULL;
    double nrm = 0.0, lambda = 0.0, prev = 0.0;
    int products = 0;
    for (int64_t i = 0; i < ndof; ++i) {
        seed = seed * 6364136223846793005ULL + 1442695040888963407ULL;
        z[i] = s->pinned[i / 3] ? 0.0 : (double)(seed >> 11) / 9007199254740992.0 + 0.5;
        nrm += z[i] * z[i];
    }
    for (int64_t i = 0; i < ndof; ++i) z[i] /= sqrt(nrm);
    for (int it = 0; it < 300; ++it) {
        for (int64_t i = 0; i < ndof; ++i) u[i] = z[i] / sqrt(s->mass3[i]);
        if (drop) drop_caches(s);
        defsim__matrix_apply_skip(s, x, &ck, DEFSIM_PROJECTION_NONE, DEFSIM__TERM_BOUNDED, u, y);
        ++products;
        double q = 0.0, yn = 0.0;
        for (int64_t i = 0; i < ndof; ++i) {
            y[i] = y[i] / sqrt(s->mass3[i]);
            q += z[i] * y[i];
            yn += y[i] * y[i];
        }
        lambda = q;
        if (!(yn > 0.0)) break;
        for (int64_t i = 0; i < ndof; ++i) z[i] = y[i] / sqrt(yn);
        if (it > 5 && fabs(lambda - prev) <= 1e-4 * fabs(lambda)) break;
        prev = lambda;
    }
    *lambda_out = lambda;
    return products;
}

static double time_power(defsim__system *s, defsim__work *wk, const double *x, int repeat,
                         int drop, int *products)
{
    double r[99] = {0}, lambda = 0.0;
    for (int k = 0; k < repeat; ++k) {
        drop_caches(s);
        const double t0 = tools_cpu_now();
        *products = power_iteration(s, wk, x, drop, &lambda);
        r[k] = 1e3 * (tools_cpu_now() - t0);
    }
    return median(r, repeat);
}

static int64_t linearisations(const defsim__system *s)
{
    int64_t n = 0;
    for (int k = 0; k < DEFSIM__TERM_KINDS; ++k) n += s->cache[k].linearisations;
    return n;
}

/* Attaches contact at the world's state as a step of its backend does (world.c contact_begin,
 * body_begin), and grows the pattern with the pairs it couples. */
static int attach(defsim_world *w, double h)
{
    const defsim__settings *o = &w->set;
    const size_t bytes = 3 * (size_t)w->nv * sizeof(double);
    memcpy(w->step.x_save, w->state.x, bytes);
    memcpy(w->step.v_save, w->state.v, bytes);
    if (defsim_world_collider_count(w) > 0) {
        const defsim__contact_params p = {
            .mode = (w->backend.table->flags & DEFSIM_BACKEND_CONTACT_CCD) ? DEFSIM__CONTACT_BARRIER
                                                                     : DEFSIM__CONTACT_PENALTY,
            .dhat_rel = o->contact_dhat,
            .kappa = o->contact_kappa,
            .frequency = o->contact_frequency,
            .omega_elastic = 1.0,
            .eps_v = o->friction_eps_v};
        if (defsim__contact_begin(&w->contact, &w->sys, w->colliders.col, w->colliders.ncol, &p,
                                  w->step.x_save, w->step.v_save, h, w->msg) != DEFSIM_OK)
            return -1;
        w->sys.contact = &w->contact;
    }
    if (o->body_contact) {
        if (defsim__body_contact_begin(&w->body_contact, &w->sys, w->bodies.b, w->bodies.n,
                                       o->contact_dhat,
                                       o->contact_kappa,
                                       o->friction_eps_v,
                                       w->step.x_save, w->step.v_save, h, w->contact.stat,
                                       w->msg) != DEFSIM_OK)
            return -1;
        w->sys.body_contact = &w->body_contact;
    }
    if (defsim__terms_compile(&w->sys) != DEFSIM_OK || defsim__pattern_build(&w->sys) != DEFSIM_OK)
        return -1;
    const defsim_matrix_coeffs c = {1.0, 0.0, 1.0, 0.0};
    for (int grew = 1; grew;) {
        defsim_csc p;
        defsim__matrix_pattern(&w->sys, DEFSIM_TRIANGLE_FULL, &p);
        double *val = malloc((size_t)(p.nnz > 0 ? p.nnz : 1) * sizeof *val);
        if (!val || defsim__matrix_values(&w->sys, w->state.x, &c, DEFSIM_TRIANGLE_FULL, val,
                                          NULL) != DEFSIM_OK)
            return -1;
        free(val);
        grew = 0;
        for (int32_t k = 0; k < w->sys.nterms; ++k) {
            const defsim__term *t = &w->sys.terms[k];
            int g = 0;
            if (t->ops->pattern_update && t->ops->pattern_update(t, &w->sys, &g) != DEFSIM_OK)
                return -1;
            grew |= g;
        }
    }
    return 0;
}

static void detach(defsim_world *w)
{
    w->sys.contact = NULL;
    w->sys.body_contact = NULL;
    w->body_contact.active = 0;
    defsim__terms_compile(&w->sys);
}

static int bench(const char *path, int steps, int np, int repeat)
{
    scene s;
    if (scene_load(&s, path, NULL, 0) != 0) {
        fprintf(stderr, "%s\n", s.error);
        return -1;
    }
    defsim_world *w = NULL;
    if (scene_build(&s, &w) != DEFSIM_OK) {
        fprintf(stderr, "%s\n", s.error);
        scene_free(&s);
        return -1;
    }
    for (int k = 0; k < steps; ++k)
        if (scene_step(&s, w, s.h) != DEFSIM_OK) {
            fprintf(stderr, "step %d: %s\n", k, defsim_world_last_error(w));
            return -1;
        }
    if (attach(w, s.h) != 0) {
        fprintf(stderr, "attaching contact: %s\n", defsim_world_last_error(w));
        return -1;
    }
    defsim__system *sys = &w->sys;
    const int64_t n = 3 * (int64_t)w->nv;
    double *dx = malloc((size_t)n * sizeof *dx), *out = malloc((size_t)n * sizeof *out);
    for (int64_t i = 0; i < n; ++i) dx[i] = sin(0.1 * (double)i);
    const double *x = w->state.x;
    defsim_csc pat;
    defsim__matrix_pattern(sys, DEFSIM_TRIANGLE_FULL, &pat);
    const int64_t nnz = pat.nnz;
    const int collider_pairs = sys->contact ? sys->contact->npair : 0;
    const int body_pairs = sys->body_contact ? sys->body_contact->npair : 0;
    const double on = time_products(sys, x, dx, out, np, repeat, 0);
    const double again = time_products(sys, x, dx, out, np, repeat, 1);
    const double c_lin = time_contact(sys, x, dx, out, np, repeat, 1);
    const double c_apply = time_contact(sys, x, dx, out, np, repeat, 0);
    int pp_on = 0, pp_again = 0;
    const int64_t l0 = linearisations(sys);
    drop_caches(sys);
    double lam;
    power_iteration(sys, &w->work, x, 0, &lam);
    const int64_t lin_power = linearisations(sys) - l0;
    const double pw_on = time_power(sys, &w->work, x, repeat, 0, &pp_on);
    const double pw_again = time_power(sys, &w->work, x, repeat, 1, &pp_again);
    double om_t[99] = {0}, om = 0.0;
    for (int k = 0; k < repeat; ++k) {
        drop_caches(sys);
        const double t0 = tools_cpu_now();
        defsim__omega_max(sys, &w->work, x, &om);
        om_t[k] = 1e3 * (tools_cpu_now() - t0);
    }
    const double om_ms = median(om_t, repeat);
    detach(w);
    defsim__matrix_pattern(sys, DEFSIM_TRIANGLE_FULL, &pat);
    const double off = time_products(sys, x, dx, out, np, repeat, 0);
    int pp_off = 0;
    const double pw_off = time_power(sys, &w->work, x, repeat, 0, &pp_off);
    const char *name = strrchr(path, '/') ? strrchr(path, '/') + 1 : path;
    printf("| %s | %d | %lld | %lld | %d | %d | %.1f | %.1f | %.1f | %.2f | %.1f | %.2f | %d | "
           "%lld | %.2f | %.2f | %d | %.2f | %d | %.2f |\n", name, steps, (long long)w->nv,
           (long long)nnz, collider_pairs, body_pairs, on, again, off, c_apply, c_lin, pw_on,
           pp_on, (long long)lin_power, om_ms, pw_again, pp_again, pw_off, pp_off, om);
    (void)pat;
    free(dx);
    free(out);
    defsim_world_destroy(w);
    scene_free(&s);
    return 0;
}

static void usage(FILE *f)
{
    fprintf(f, "usage: defsim-bench-product [SCENE[:STEPS]]... [--products P] [--repeat R]\n"
               "What contact costs a matrix-vector product and the power iteration, after\n"
               "STEPS steps of each scene (at most 8; default cloth_fold:60 and\n"
               "ground_box_sphere:100; STEPS default 50).\n"
               "  --products P   products per round (default 200)\n"
               "  --repeat R     rounds, 1..99 (default 5)\n"
               "  -h, --help     this text\n"
               "  --version      the library's version\n");
}

int main(int argc, char **argv)
{
    const char *paths[8];
    int steps[8], np = 200, repeat = 5, nscene = 0;
    static const cli_tool tool = {"defsim-bench-product", usage, NULL, ""};
    const cli_opt opts[] = {{"products", CLI_INT, &np, 1, 1e8}, {"repeat", CLI_INT, &repeat, 1, 99},
                            {0}};
    int first;
    const int parsed = cli_parse(&tool, opts, argc, argv, &first);
    if (parsed >= 0) return parsed;
    if (argc - first > 8) return cli_fail(&tool, "at most 8 scenes");
    for (int i = first; i < argc; ++i) {
        char *colon = strrchr(argv[i], ':'), *end = NULL;
        steps[nscene] = 50;
        if (colon) {
            const long v = strtol(colon + 1, &end, 10);
            if (end == colon + 1 || *end || v < 0 || v > 100000000)
                return cli_fail(&tool, "SCENE:STEPS with STEPS >= 0 (got %s)", argv[i]);
            steps[nscene] = (int)v;
            *colon = '\0';
        }
        paths[nscene++] = argv[i];
    }
    if (nscene == 0) {
        paths[0] = DEFSIM_BENCH_SCENES "/cloth_fold.json";
        steps[0] = 60;
        paths[1] = DEFSIM_BENCH_SCENES "/ground_box_sphere.json";
        steps[1] = 100;
        nscene = 2;
    }
    printf("Medians of %d rounds; products of A = M + K over all DOFs (us), power iteration "
           "(ms) at the state after the steps.\n\n", repeat);
    printf("| scene | steps | vertices | non-zeros | collider pairs | body pairs | product, "
           "contact on, cached (us) | product, contact re-linearised each time (us) | product, "
           "contact off (us) | contact terms' apply from the cache (us) | contact terms' linearise "
           "(us) | power iteration, cached (ms) | its products | linearisations "
           "in it | omega_max (ms) | power iteration, re-linearised each product (ms) | its "
           "products | power iteration, contact off (ms) | its products | omega_max (rad/s) |\n"
           "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|"
           "---:|---:|---:|\n");
    for (int k = 0; k < nscene; ++k)
        if (bench(paths[k], steps[k], np, repeat) != 0) return 1;
    return 0;
}
