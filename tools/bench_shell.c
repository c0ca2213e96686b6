/* SPDX-License-Identifier: MIT */
/*
 * defsim-bench-shell: the cost per element of the shells' membrane, bending and strain-limit
 * kernels next to the tet kernels (docs/shells.md), one thread, CPU time, the median of ROUNDS
 * passes:
 *
 *   defsim-bench-shell [ROUNDS]   (default 11; DEFSIM_BACKEND_PATH must find newton_cholmod)
 *
 * Per element kind, its term alone (the kind's ops, as the backends reach them): the energy and
 * the forces, each with the batched kernels of the variant core.simd picks (auto: the fastest
 * this CPU runs) and with the scalar kernels (only the quadratic tets have a batched energy:
 * tet_batch.h's DEFSIM__BATCHED_QENERGY and DEFSIM__BATCHED_QMIXED; the other kinds' two energy
 * columns time the same scalar loop), and the stiffness matrix's values (the kind's element
 * matrices with the default clamp projection, scattered into the pattern; and without the
 * projection), each divided by the
 * element count: tets of a 20 x 20 x 20 box (StVK, stable neo-Hookean), quadratic (10-node) tets
 * of a 12 x 12 x 12 box (each model; batched: tet_batch.h's quadratic kernels), the same box's
 * mean-dilatation tets (volume_averaging: neo-Hookean, stable neo-Hookean), triangles of a
 * 100 x 100 sheet (StVK and neo-Hookean membranes, no bending), the hinges of the same sheet
 * (bending only), and its strain limit (10 %) with every triangle in the barrier's band (the
 * sheet stretched 1.095 times both ways; the limit has no batched kernel: its two force columns
 * are the scalar kernel). The state is perturbed by 1 % of a cell (the limit's: 0.01 %), so that
 * no kernel takes a shortcut at rest.
 */
#include "assembly.h"
#include "clock.h"
#include "terms.h"
#include "tet_forces.h"
#include "world.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static int cmp_double(const void *a, const void *b)
{
    const double x = *(const double *)a, y = *(const double *)b;
    return x < y ? -1 : x > y;
}

static double median(double *v, int n)
{
    qsort(v, (size_t)n, sizeof *v, cmp_double);
    return v[n / 2];
}

static defsim_world *make_world(void)
{
    defsim_world_def wd;
    defsim_world_def_init(&wd, sizeof wd);
    wd.backend = "newton_cholmod";
    wd.num_threads = 1;
    defsim_world *w = NULL;
    if (defsim_world_create(&wd, &w) != DEFSIM_OK) {
        fprintf(stderr, "defsim-bench-shell: %s\n", defsim_last_error());
        exit(1);
    }
    return w;
}

/* Times the term of `kind` in w (elements: n): energy, forces batched and scalar, matrix
 * values; prints one row. The state: x scaled by `scale` about the origin, perturbed by `amp`
 * cells. */
static void run(defsim_world *w, int kind, const char *what, int64_t n, double cell,
                double scale, double amp, int rounds)
{
    if (defsim__world_plan(w) != DEFSIM_OK) {
        fprintf(stderr, "defsim-bench-shell: %s: plan failed\n", what);
        exit(1);
    }
    const defsim__term *t = defsim__terms_find(&w->sys, kind);
    if (!t) {
        fprintf(stderr, "defsim-bench-shell: %s: no term\n", what);
        exit(1);
    }
    const int nv = defsim_world_vertex_count(w);
    double *x = malloc(3 * (size_t)nv * sizeof *x), *f = malloc(3 * (size_t)nv * sizeof *f);
    double *tm[6];
    for (int k = 0; k < 6; ++k) tm[k] = malloc((size_t)rounds * sizeof *tm[k]);
    defsim_world_get_positions(w, x, nv);
    unsigned long long s = 12345;
    for (int i = 0; i < 3 * nv; ++i) {
        s = s * 6364136223846793005ULL + 1442695040888963407ULL;
        x[i] = scale * x[i] + amp * cell * ((double)(s >> 11) / 9007199254740992.0 - 0.5);
    }
    defsim_csc csc;
    if (defsim__pattern_build(&w->sys) != DEFSIM_OK ||
        defsim__matrix_pattern(&w->sys, DEFSIM_TRIANGLE_UPPER, &csc) != DEFSIM_OK) {
        fprintf(stderr, "defsim-bench-shell: %s: no pattern\n", what);
        exit(1);
    }
    double *val = malloc((size_t)csc.nnz * sizeof *val);
    const defsim_matrix_coeffs c = {1.0, 0.0, 0.0, 0.0};
    const defsim__eval ev = {x, NULL, 0.0, DEFSIM_FORCE_ELASTIC};
    const defsim__tet_kernels *batched = w->sys.tet_kernels;
    double e[2] = {0.0, 0.0};
    for (int r = 0; r < rounds; ++r) {
        uint32_t used = 0;
        double t0;
        for (int k = 0; k < 2; ++k) {
            w->sys.tet_kernels = k == 0 ? batched : NULL;
            t0 = tools_cpu_now();
            e[k] += t->ops->energy(t, &w->sys, &w->work, x, 0.0);
            tm[k][r] = tools_cpu_now() - t0;
        }
        for (int k = 0; k < 2; ++k) {
            w->sys.tet_kernels = k == 0 ? batched : NULL;
            memset(f, 0, 3 * (size_t)nv * sizeof *f);
            t0 = tools_cpu_now();
            t->ops->forces(t, &w->sys, &ev, f, &used);
            tm[2 + k][r] = tools_cpu_now() - t0;
        }
        w->sys.tet_kernels = batched;
        memset(val, 0, (size_t)csc.nnz * sizeof *val);
        t0 = tools_cpu_now();
        t->ops->values(t, &w->sys, x, &c, 1, csc.col_ptr, val, NULL);
        tm[4][r] = tools_cpu_now() - t0;
        const int proj = w->sys.projection;
        w->sys.projection = DEFSIM_PROJECTION_NONE;
        t0 = tools_cpu_now();
        t->ops->values(t, &w->sys, x, &c, 1, csc.col_ptr, val, NULL);
        tm[5][r] = tools_cpu_now() - t0;
        w->sys.projection = proj;
    }
    if (!(e[1] > 0.0) || !(e[1] < INFINITY) || !(fabs(e[0] - e[1]) <= 1e-10 * e[1])) {
        fprintf(stderr, "defsim-bench-shell: %s: energy %g, batched %g (not in the state meant)\n",
                what, e[1], e[0]);
        exit(1);
    }
    printf("| %-26s | %6lld | %7.1f | %7.1f | %7.1f | %7.1f | %8.1f | %8.1f |\n", what,
           (long long)n, 1e9 * median(tm[0], rounds) / (double)n,
           1e9 * median(tm[1], rounds) / (double)n, 1e9 * median(tm[2], rounds) / (double)n,
           1e9 * median(tm[3], rounds) / (double)n, 1e9 * median(tm[4], rounds) / (double)n,
           1e9 * median(tm[5], rounds) / (double)n);
    free(x); free(f); free(val);
    for (int k = 0; k < 6; ++k) free(tm[k]);
}

/* Tets of an n^3 box (quad: 10-node ones, defsim_mesh_make_quadratic; 2: mean-dilatation ones,
 * volume_averaging). */
static void tets(defsim_model model, int quad, int n, const char *what, int rounds)
{
    defsim_world *w = make_world();
    const double lo[3] = {0, 0, 0}, hi[3] = {1, 1, 1};
    defsim_mesh m;
    memset(&m, 0, sizeof m);
    m.size = sizeof m;
    defsim_mesh_box(lo, hi, n, n, n, &m);
    if (quad) defsim_mesh_make_quadratic(&m);
    defsim_body_def d;
    defsim_body_def_init(&d, sizeof d);
    defsim_material_init(&d.material, sizeof d.material, model);
    d.rest_positions = m.positions;
    d.vertex_count = m.vertex_count;
    d.tets = m.tets;
    d.tet_count = m.tet_count;
    d.tet_nodes = m.tet_nodes;
    d.volume_averaging = quad == 2;
    defsim_world_add_body(w, &d, NULL);
    run(w, quad == 2 ? DEFSIM__TERM_KIND_quadratic_mixed
           : quad    ? DEFSIM__TERM_KIND_elastic_quadratic
                     : DEFSIM__TERM_KIND_elastic,
        what, m.tet_count, 1.0 / n, 1.0, 0.01, rounds);
    defsim_mesh_free(&m);
    defsim_world_destroy(w);
}

static void sheet(int32_t membrane, double D, double cap, const char *what, int kind,
                  int rounds)
{
    defsim_world *w = make_world();
    const int n = 100;
    const double o[3] = {0, 0, 0}, u[3] = {1, 0, 0}, v[3] = {0, 0, 1};
    defsim_mesh m;
    memset(&m, 0, sizeof m);
    m.size = sizeof m;
    defsim_mesh_cloth(o, u, v, n, n, &m);
    defsim_body_def d;
    defsim_body_def_init(&d, sizeof d);
    d.rest_positions = m.positions;
    d.vertex_count = m.vertex_count;
    d.triangles = m.triangles;
    d.triangle_count = m.triangle_count;
    d.shell_membrane = membrane;
    d.shell_bending_rigidity = D;
    d.shell_strain_limit = cap;
    if (defsim_world_add_body(w, &d, NULL) != DEFSIM_OK) {
        fprintf(stderr, "defsim-bench-shell: %s\n", defsim_world_last_error(w));
        exit(1);
    }
    /* Interior edges of the grid: 3 n^2 - 2 n. */
    const int64_t count = kind == DEFSIM__TERM_KIND_hinge ? 3 * (int64_t)n * n - 2 * n
                                                          : m.triangle_count;
    if (cap > 0.0) run(w, kind, what, count, 1.0 / n, 1.0 + 0.95 * cap, 1e-4, rounds);
    else run(w, kind, what, count, 1.0 / n, 1.0, 0.01, rounds);
    defsim_mesh_free(&m);
    defsim_world_destroy(w);
}

int main(int argc, char **argv)
{
    const int rounds = argc > 1 ? atoi(argv[1]) : 11;
    if (rounds < 1) {
        fprintf(stderr, "usage: defsim-bench-shell [ROUNDS]\n");
        return 2;
    }
    const defsim__tet_kernels *k = defsim__tet_kernels_best();
    printf("batched variant: %s (core.simd auto)\n\n", k ? k->name : "none");
    printf("| elements                   |  count | energy ns/el, batched | energy ns/el, scalar | "
           "forces ns/el, batched | forces ns/el, scalar | matrix ns/el | "
           "matrix ns/el, unprojected |\n");
    printf("|---|---|---|---|---|---|---|---|\n");
    tets(DEFSIM_MODEL_STVK, 0, 20, "tets, StVK", rounds);
    tets(DEFSIM_MODEL_STABLE_NEOHOOKEAN, 0, 20, "tets, stable neo-Hookean", rounds);
    tets(DEFSIM_MODEL_STVK, 1, 12, "10-node tets, StVK", rounds);
    tets(DEFSIM_MODEL_COROTATED, 1, 12, "10-node tets, co-rotated", rounds);
    tets(DEFSIM_MODEL_NEOHOOKEAN, 1, 12, "10-node tets, neo-Hookean", rounds);
    tets(DEFSIM_MODEL_STABLE_NEOHOOKEAN, 1, 12, "10-node tets, stable NH", rounds);
    tets(DEFSIM_MODEL_NEOHOOKEAN, 2, 12, "mean-dilatation, NH", rounds);
    tets(DEFSIM_MODEL_STABLE_NEOHOOKEAN, 2, 12, "mean-dilatation, stable NH", rounds);
    sheet(DEFSIM_SHELL_MEMBRANE_STVK, 0.0, 0.0, "triangles, StVK membrane",
          DEFSIM__TERM_KIND_membrane, rounds);
    sheet(DEFSIM_SHELL_MEMBRANE_NEOHOOKEAN, 0.0, 0.0, "triangles, neo-Hookean",
          DEFSIM__TERM_KIND_membrane, rounds);
    sheet(DEFSIM_SHELL_MEMBRANE_NONE, 1e-3, 0.0, "hinges (bending)", DEFSIM__TERM_KIND_hinge,
          rounds);
    sheet(DEFSIM_SHELL_MEMBRANE_STVK, 0.0, 0.1, "triangles, strain limit",
          DEFSIM__TERM_KIND_strain_limit, rounds);
    return 0;
}
