/* SPDX-License-Identifier: MIT */
/*
 * The reference scene for the Python bit-for-bit test (test_bitmatch.py), run through the C API:
 * a co-rotated beam clamped at x = 0 with Rayleigh damping, plus a free spring chain with an
 * initial velocity, under gravity. Writes every position, then every velocity, then the total
 * energy, one C99 hex float (%a) per line, so that nothing is lost in printing.
 *
 *   defsim_bitmatch BACKEND STEPS H THREADS
 *
 * Keep the scene in sync with scene() in test_bitmatch.py.
 */
#include <defsim/defsim.h>

#include "mesh_body.h"

#include <stdio.h>
#include <stdlib.h>

static int fail(defsim_world *w, defsim_status st, const char *what)
{
    fprintf(stderr, "defsim_bitmatch: %s: %s: %s\n", what, defsim_status_string(st),
            w ? defsim_world_last_error(w) : defsim_last_error());
    return 1;
}

int main(int argc, char **argv)
{
    if (argc != 5) {
        fprintf(stderr, "usage: defsim_bitmatch BACKEND STEPS H THREADS\n");
        return 2;
    }
    const int steps = atoi(argv[2]);
    const double h = atof(argv[3]);
    defsim_world_def wd;
    defsim_world_def_init(&wd, sizeof wd);
    wd.backend = argv[1];
    wd.num_threads = atoi(argv[4]);
    wd.gravity[0] = 0.5;   /* slightly off-axis, so that every coordinate moves */
    defsim_world *w = NULL;
    defsim_status st = defsim_world_create(&wd, &w);
    if (st != DEFSIM_OK) return fail(NULL, st, "world_create");

    /* Body 1: a 3 x 1 x 1 cell co-rotated beam on [0, 0.6] x [0, 0.2] x [0, 0.2]. */
    defsim_mesh m = {sizeof m, NULL, 0, NULL, 0, NULL, 0, NULL, 0, NULL, 0};
    const double lo[3] = {0, 0, 0}, hi[3] = {0.6, 0.2, 0.2};
    if ((st = defsim_mesh_box(lo, hi, 3, 1, 1, &m)) != DEFSIM_OK) return fail(NULL, st, "mesh_box");
    defsim_body_def bd = test_mesh_body(&m, DEFSIM_MODEL_COROTATED);
    bd.material.youngs_modulus = 2e5;
    bd.material.poisson_ratio = 0.35;
    bd.material.density = 900;
    bd.material.mass_damping = 0.5;
    bd.material.stiffness_damping = 1e-4;
    defsim_body_id beam;
    if ((st = defsim_world_add_body(w, &bd, &beam)) != DEFSIM_OK) return fail(w, st, "add beam");
    int32_t clamp[64];
    int32_t nclamp = 0;
    for (int32_t i = 0; i < m.vertex_count; ++i)
        if (m.positions[3 * i] == 0.0) clamp[nclamp++] = i;
    if ((st = defsim_body_pin(w, beam, clamp, nclamp)) != DEFSIM_OK) return fail(w, st, "pin");

    /* Body 2: a chain of 4 vertices and 3 springs, moving. */
    const double chain[12] = {0, 1, 0, 0.1, 1, 0, 0.2, 1.05, 0, 0.3, 1, 0.02};
    const int32_t links[6] = {0, 1, 1, 2, 2, 3};
    double v0[12];
    for (int i = 0; i < 4; ++i) {
        v0[3 * i] = 0.1;
        v0[3 * i + 1] = 0.0;
        v0[3 * i + 2] = -0.2 * i;
    }
    defsim_body_def cd;
    defsim_body_def_init(&cd, sizeof cd);
    cd.rest_positions = chain;
    cd.vertex_count = 4;
    cd.springs = links;
    cd.spring_count = 3;
    cd.initial_velocities = v0;
    defsim_material_init(&cd.material, sizeof cd.material, DEFSIM_MODEL_SPRING);
    cd.material.stiffness = 500;
    cd.material.vertex_mass = 0.02;
    if ((st = defsim_world_add_body(w, &cd, NULL)) != DEFSIM_OK) return fail(w, st, "add chain");

    for (int s = 0; s < steps; ++s)
        if ((st = defsim_world_step(w, h)) != DEFSIM_OK) return fail(w, st, "step");

    const int32_t n = defsim_world_vertex_count(w);
    double *x = malloc(6 * (size_t)n * sizeof *x);
    if (!x) return 1;
    defsim_world_get_positions(w, x, n);
    defsim_world_get_velocities(w, x + 3 * n, n);
    defsim_energy e;
    defsim_world_energy(w, &e);
    for (int32_t i = 0; i < 6 * n; ++i) printf("%a\n", x[i]);
    printf("%a\n", e.total);
    free(x);
    defsim_mesh_free(&m);
    defsim_world_destroy(w);
    return 0;
}
