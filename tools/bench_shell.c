/* SPDX-License-Identifier: MIT */
/*
 * defsim-bench-shell: the cost per element of the shells' membrane and bending kernels next to
 * the tet kernels (docs/shells.md), one thread, CPU time, the median of ROUNDS passes:
 *
 *   defsim-bench-shell [ROUNDS]   (default 11; DEFSIM_BACKEND_PATH must find newton_cholmod)
 *
 * Per element kind, the world's forces (defsim_world_forces: the kind's force kernel, batched
 * for tets where the CPU has a variant) and the stiffness matrix's values (the kind's element
 * matrices with the default clamp projection, scattered into the pattern), each divided by the
 * element count: tets of a 20 x 20 x 20 box (StVK, stable neo-Hookean), triangles of a 100 x 100
 * sheet (StVK and neo-Hookean membranes, no bending) and the hinges of the same sheet (bending
 * only). The state is the rest shape perturbed by 1 % of a cell, so that no kernel takes a
 * shortcut at rest.
 */
#include "assembly.h"
#include "clock.h"
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

/* Times forces and matrix values of w (elements: n), prints one row. */
static void run(defsim_world *w, const char *what, int64_t n, double cell, int rounds)
{
    if (defsim__world_plan(w) != DEFSIM_OK) {
        fprintf(stderr, "defsim-bench-shell: %s: plan failed\n", what);
        exit(1);
    }
    const int nv = defsim_world_vertex_count(w);
    double *x = malloc(3 * (size_t)nv * sizeof *x), *f = malloc(3 * (size_t)nv * sizeof *f);
    double *tf = malloc((size_t)rounds * sizeof *tf), *tk = malloc((size_t)rounds * sizeof *tk);
    defsim_world_get_positions(w, x, nv);
    unsigned long long s = 12345;
    for (int i = 0; i < 3 * nv; ++i) {
        s = s * 6364136223846793005ULL + 1442695040888963407ULL;
        x[i] += 0.01 * cell * ((double)(s >> 11) / 9007199254740992.0 - 0.5);
    }
    defsim_csc csc;
    if (defsim__pattern_build(&w->sys) != DEFSIM_OK ||
        defsim__matrix_pattern(&w->sys, DEFSIM_TRIANGLE_UPPER, &csc) != DEFSIM_OK) {
        fprintf(stderr, "defsim-bench-shell: %s: no pattern\n", what);
        exit(1);
    }
    double *val = malloc((size_t)csc.nnz * sizeof *val);
    const defsim_matrix_coeffs c = {1.0, 0.0, 0.0, 0.0};
    for (int r = 0; r < rounds; ++r) {
        double t0 = tools_cpu_now();
        defsim_world_forces(w, x, f);
        tf[r] = tools_cpu_now() - t0;
        t0 = tools_cpu_now();
        defsim__matrix_values(&w->sys, x, &c, DEFSIM_TRIANGLE_UPPER, val, NULL);
        tk[r] = tools_cpu_now() - t0;
    }
    printf("| %-26s | %9lld | %8.1f | %8.1f |\n", what, (long long)n,
           1e9 * median(tf, rounds) / (double)n, 1e9 * median(tk, rounds) / (double)n);
    free(x); free(f); free(tf); free(tk); free(val);
}

static void tets(defsim_model model, const char *what, int rounds)
{
    defsim_world *w = make_world();
    const int n = 20;
    const double lo[3] = {0, 0, 0}, hi[3] = {1, 1, 1};
    defsim_mesh m;
    memset(&m, 0, sizeof m);
    m.size = sizeof m;
    defsim_mesh_box(lo, hi, n, n, n, &m);
    defsim_body_def d;
    defsim_body_def_init(&d, sizeof d);
    defsim_material_init(&d.material, sizeof d.material, model);
    d.rest_positions = m.positions;
    d.vertex_count = m.vertex_count;
    d.tets = m.tets;
    d.tet_count = m.tet_count;
    defsim_world_add_body(w, &d, NULL);
    run(w, what, m.tet_count, 1.0 / n, rounds);
    defsim_mesh_free(&m);
    defsim_world_destroy(w);
}

static void sheet(int32_t membrane, double D, const char *what, int hinges, int rounds)
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
    if (defsim_world_add_body(w, &d, NULL) != DEFSIM_OK) {
        fprintf(stderr, "defsim-bench-shell: %s\n", defsim_world_last_error(w));
        exit(1);
    }
    /* Interior edges of the grid: 3 n^2 - 2 n. */
    run(w, what, hinges ? 3 * (int64_t)n * n - 2 * n : m.triangle_count, 1.0 / n, rounds);
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
    printf("| elements                   |     count | forces ns/el | matrix ns/el |\n");
    printf("|---|---|---|---|\n");
    tets(DEFSIM_MODEL_STVK, "tets, StVK", rounds);
    tets(DEFSIM_MODEL_STABLE_NEOHOOKEAN, "tets, stable neo-Hookean", rounds);
    sheet(DEFSIM_SHELL_MEMBRANE_STVK, 0.0, "triangles, StVK membrane", 0, rounds);
    sheet(DEFSIM_SHELL_MEMBRANE_NEOHOOKEAN, 0.0, "triangles, neo-Hookean", 0, rounds);
    sheet(DEFSIM_SHELL_MEMBRANE_NONE, 1e-3, "hinges (bending)", 1, rounds);
    return 0;
}
