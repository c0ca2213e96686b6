/* SPDX-License-Identifier: MIT */
/*
 * The implicit backends' contact stop (backends/implicit_core, option contact_tolerance; issue
 * 30): what it promises, and what it buys.
 *
 *   test_newton_stop SCENES_DIR
 *       The promise: along a trajectory of the new stop, every step is restarted from the same
 *       state in a world converged far tighter (tolerance 1e-10 x L, contact stop off), and the
 *       two end positions may differ by at most the documented accuracy, 2 contact_tolerance
 *       dhat per coordinate (README.md of implicit_core, "Newton's method", 5). The stop must
 *       fire (contact_stops > 0), save iterations against the old stop, and be off with
 *       contact_tolerance = 0 (no contact stop). Scenes: cloth_fold (12 x 12, 30 steps: the
 *       landing and the first folds) and ground_box_sphere (newton_cholmod, 120 steps: the block
 *       lands on the sphere and tips off). The old stop's own deviation is measured only with
 *       --measure (printed as 0 here). Exit 0 on success, 1 on a failed check.
 *
 *   test_newton_stop SCENES_DIR --measure SCENE STEPS [--cells N] [--contact-tolerance C]
 *                    [--no-reference] [--set KEY=VALUE]...
 *       The figures of docs/contact.md ("Newton's stop"): the scene (SCENES_DIR/SCENE.json,
 *       run with newton_cholmod, max_iterations 500) with the old stop (contact_tolerance 0) and
 *       the new (the default), STEPS steps each: Newton iterations per step and the worst step's;
 *       the largest one-step deviation of the new stop from the tight reference restarted at its
 *       states (as above); the largest deviation of the new stop's trajectory from the old one's
 *       over the run and after the last step. Deviations in m, relative to dhat and to L.
 *       --no-reference leaves out the reference (its restarts by defsim_world_set_state run
 *       body contact's check that surfaces start apart, which a folded cloth can fail: see
 *       docs/contact.md, "Newton's stop"); its deviations then print as 0.
 *
 * L is the diagonal of the bounding box of the initial positions (the rest positions in these
 * scenes), dhat = core.contact_dhat x L.
 */
#include "scene.h"

#include <defsim/defsim.h>

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

enum { MAX_SETS = 12 };

/* A world built from a scene, with the stop's options. */
typedef struct run {
    scene sc;
    defsim_world *w;
    int32_t nv;
    double *x, *v;
} run;

static double stat(const defsim_world *w, const char *name)
{
    double value = 0.0;
    if (defsim_world_stat(w, name, &value) != DEFSIM_OK) {
        fprintf(stderr, "statistic %s: %s\n", name, defsim_world_last_error(w));
        exit(1);
    }
    return value;
}

static void set_option(defsim_world *w, const char *name, const char *value)
{
    if (defsim_world_set_option(w, name, value) != DEFSIM_OK) {
        fprintf(stderr, "option %s=%s: %s\n", name, value, defsim_world_last_error(w));
        exit(1);
    }
}

/* Loads SCENES_DIR/name.json with newton_cholmod and the overrides; tolerance NULL keeps the
 * default, contact_tolerance likewise. */
static void open_run(run *r, const char *dir, const char *name, const char *const *sets,
                     int nsets, const char *tolerance, const char *contact_tolerance)
{
    char path[1024];
    snprintf(path, sizeof path, "%s/%s.json", dir, name);
    const char *all[MAX_SETS + 1];
    int n = 0;
    all[n++] = "world.backend=\"newton_cholmod\"";
    for (int k = 0; k < nsets && n < MAX_SETS + 1; ++k) all[n++] = sets[k];
    if (scene_load(&r->sc, path, all, n) != 0 || scene_build(&r->sc, &r->w) != DEFSIM_OK) {
        fprintf(stderr, "%s: %s\n", path, r->sc.error);
        exit(1);
    }
    set_option(r->w, "newton_cholmod.max_iterations", "500");
    if (tolerance) set_option(r->w, "newton_cholmod.tolerance", tolerance);
    if (contact_tolerance) set_option(r->w, "newton_cholmod.contact_tolerance", contact_tolerance);
    r->nv = defsim_world_vertex_count(r->w);
    r->x = malloc(3 * (size_t)r->nv * sizeof *r->x);
    r->v = malloc(3 * (size_t)r->nv * sizeof *r->v);
    if (!r->x || !r->v) exit(1);
}

static void close_run(run *r)
{
    defsim_world_destroy(r->w);
    scene_free(&r->sc);
    free(r->x);
    free(r->v);
}

/* One step; reads the state back into r->x, r->v. Returns the step's Newton iterations. */
static double step(run *r, const char *label, int k)
{
    const double before = stat(r->w, "newton_cholmod.newton_iterations");
    if (scene_step(&r->sc, r->w, r->sc.h) != DEFSIM_OK) {
        fprintf(stderr, "%s: step %d: %s\n", label, k, defsim_world_last_error(r->w));
        exit(1);
    }
    defsim_world_get_positions(r->w, r->x, r->nv);
    defsim_world_get_velocities(r->w, r->v, r->nv);
    return stat(r->w, "newton_cholmod.newton_iterations") - before;
}

static double max_diff(const double *a, const double *b, int64_t n)
{
    double d = 0.0;
    for (int64_t i = 0; i < n; ++i) d = fmax(d, fabs(a[i] - b[i]));
    return d;
}

/* L (bounding box diagonal of the current positions) and dhat of a freshly built run. */
static void scales(run *r, double *L, double *dhat)
{
    defsim_world_get_positions(r->w, r->x, r->nv);
    double lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
    for (int32_t i = 0; i < r->nv; ++i)
        for (int c = 0; c < 3; ++c) {
            lo[c] = fmin(lo[c], r->x[3 * i + c]);
            hi[c] = fmax(hi[c], r->x[3 * i + c]);
        }
    *L = sqrt((hi[0] - lo[0]) * (hi[0] - lo[0]) + (hi[1] - lo[1]) * (hi[1] - lo[1]) +
              (hi[2] - lo[2]) * (hi[2] - lo[2]));
    double rel = 0.0;
    if (defsim_world_get_option(r->w, "core.contact_dhat", &rel) != DEFSIM_OK) exit(1);
    *dhat = rel * *L;
}

typedef struct figures {
    double its_old, its_new, worst_old, worst_new;   /* per step */
    double local_new;       /* largest one-step deviation of the new stop from the reference */
    double local_old;       /* the same for the old stop */
    double traj_max, traj_end;   /* new against old trajectory */
    double stops;           /* contact_stops of the new run */
    double L, dhat;
} figures;

/* Runs old, new and (with_reference 1) the reference restarted at each state of new, (2) and
 * of old; 0: no reference. */
static void compare(const char *dir, const char *name, const char *const *sets, int nsets,
                    int steps, const char *contact_tolerance, int with_reference, figures *f)
{
    run old, neu, ref;
    open_run(&old, dir, name, sets, nsets, NULL, "0");
    open_run(&neu, dir, name, sets, nsets, NULL, contact_tolerance);
    if (with_reference) open_run(&ref, dir, name, sets, nsets, "1e-10", "0");
    memset(f, 0, sizeof *f);
    scales(&neu, &f->L, &f->dhat);
    const int64_t n = 3 * (int64_t)neu.nv;
    double *x0 = malloc((size_t)n * sizeof *x0), *v0 = malloc((size_t)n * sizeof *v0);
    if (!x0 || !v0) exit(1);
    for (int k = 0; k < steps; ++k) {
        /* the reference from the new run's state */
        if (with_reference) {
            defsim_world_get_positions(neu.w, x0, neu.nv);
            defsim_world_get_velocities(neu.w, v0, neu.nv);
            if (defsim_world_set_state(ref.w, x0, v0) != DEFSIM_OK) exit(1);
            step(&ref, "reference", k);
        }
        const double in = step(&neu, "new", k);
        if (with_reference) f->local_new = fmax(f->local_new, max_diff(neu.x, ref.x, n));
        /* and from the old run's */
        if (with_reference > 1) {
            defsim_world_get_positions(old.w, x0, old.nv);
            defsim_world_get_velocities(old.w, v0, old.nv);
            if (defsim_world_set_state(ref.w, x0, v0) != DEFSIM_OK) exit(1);
            step(&ref, "reference", k);
        }
        const double io = step(&old, "old", k);
        if (with_reference > 1) f->local_old = fmax(f->local_old, max_diff(old.x, ref.x, n));
        f->its_old += io;
        f->its_new += in;
        f->worst_old = fmax(f->worst_old, io);
        f->worst_new = fmax(f->worst_new, in);
        f->traj_end = max_diff(neu.x, old.x, n);
        f->traj_max = fmax(f->traj_max, f->traj_end);
    }
    f->its_old /= steps;
    f->its_new /= steps;
    f->stops = stat(neu.w, "newton_cholmod.contact_stops");
    if (stat(old.w, "newton_cholmod.contact_stops") != 0.0) {
        fprintf(stderr, "%s: contact_tolerance 0 still stopped on contact\n", name);
        exit(1);
    }
    free(x0);
    free(v0);
    close_run(&old);
    close_run(&neu);
    if (with_reference) close_run(&ref);
}

static void print(const char *name, int steps, const figures *f)
{
    printf("%s, %d steps: L %.4g m, dhat %.4g m\n", name, steps, f->L, f->dhat);
    printf("  Newton iterations per step: old %.2f, new %.2f; worst step: old %.0f, new %.0f; "
           "contact stops %.0f\n", f->its_old, f->its_new, f->worst_old, f->worst_new, f->stops);
    printf("  one-step deviation from the tight reference: new %.3g m (%.3g dhat, %.3g L), "
           "old %.3g m (%.3g dhat, %.3g L)\n", f->local_new, f->local_new / f->dhat,
           f->local_new / f->L, f->local_old, f->local_old / f->dhat, f->local_old / f->L);
    printf("  new trajectory against old: largest %.3g m (%.3g dhat, %.3g L), after the last "
           "step %.3g m (%.3g dhat, %.3g L)\n", f->traj_max, f->traj_max / f->dhat,
           f->traj_max / f->L, f->traj_end, f->traj_end / f->dhat, f->traj_end / f->L);
}

/* The promise on one scene; returns the number of failed checks. */
static int check(const char *dir, const char *name, const char *const *sets, int nsets,
                 int steps)
{
    figures f;
    compare(dir, name, sets, nsets, steps, NULL, 1, &f);   /* old's deviation: not measured */
    print(name, steps, &f);
    const double bound = 2.0 * 1e-2 * f.dhat;   /* 2 contact_tolerance dhat, the default */
    int failed = 0;
    if (!(f.local_new <= bound)) {
        printf("FAIL %s: one-step deviation %.3g m above 2 contact_tolerance dhat = %.3g m\n",
               name, f.local_new, bound);
        failed++;
    }
    if (!(f.stops > 0.0)) {
        printf("FAIL %s: the contact stop never fired\n", name);
        failed++;
    }
    if (!(f.its_new < f.its_old) || !(f.worst_new <= f.worst_old)) {
        printf("FAIL %s: no iterations saved (%.2f against %.2f per step, worst %.0f against "
               "%.0f)\n", name, f.its_new, f.its_old, f.worst_new, f.worst_old);
        failed++;
    }
    return failed;
}

int main(int argc, char **argv)
{
    if (argc < 2) {
        fprintf(stderr, "usage: test_newton_stop SCENES_DIR [--measure SCENE STEPS "
                        "[--cells N] [--contact-tolerance C] [--no-reference] "
                        "[--set KEY=VALUE]...]\n");
        return 2;
    }
    const char *dir = argv[1];
    if (argc >= 5 && !strcmp(argv[2], "--measure")) {
        const char *sets[MAX_SETS];
        char cells[64];
        int nsets = 0;
        const char *ctol = NULL;
        int with_reference = 2;
        for (int i = 5; i < argc; ++i) {
            if (!strcmp(argv[i], "--cells") && i + 1 < argc && nsets < MAX_SETS) {
                const int c = atoi(argv[++i]);
                snprintf(cells, sizeof cells, "bodies.0.mesh.cells=[%d,%d]", c, c);
                sets[nsets++] = cells;
            } else if (!strcmp(argv[i], "--no-reference")) {
                with_reference = 0;
            } else if (!strcmp(argv[i], "--contact-tolerance") && i + 1 < argc) {
                ctol = argv[++i];
            } else if (!strcmp(argv[i], "--set") && i + 1 < argc && nsets < MAX_SETS) {
                sets[nsets++] = argv[++i];
            } else {
                fprintf(stderr, "unknown argument %s\n", argv[i]);
                return 2;
            }
        }
        figures f;
        const int steps = atoi(argv[4]);
        if (steps < 1) return 2;
        compare(dir, argv[3], sets, nsets, steps, ctol, with_reference, &f);
        print(argv[3], steps, &f);
        return 0;
    }
    int failed = check(dir, "cloth_fold", NULL, 0, 30);
    failed += check(dir, "ground_box_sphere", NULL, 0, 120);
    return failed ? 1 : 0;
}
