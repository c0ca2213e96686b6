/* SPDX-License-Identifier: MIT */
/*
 * defsim-bench-gradients: the cost of gradients through a run (docs/gradients.md). The cantilever
 * of tests/scenes/cantilever.json (3n x n x n cells on [0,3] x [0,1] x [0,1] m, n = 4 as the
 * scene; stable neo-Hookean, E = 1 MPa, nu = 0.3, rho = 1000 kg/m^3, mass damping 1/s, gravity
 * -9.81 m/s^2 along y, clamped at x = 0) is stepped S times under a recording (after one
 * unrecorded step that does the backend's set-up), then run backward for the loss "mean height
 * of the tip corner (3, 1, 1) over the run", filling every gradient. Prints the forward and
 * backward wall times, their ratio, what the backward pass recomputed, the tape's memory, and the
 * gradients.
 *
 *   defsim-bench-gradients [--backend newton_cholmod] [--n N] [--h SECONDS] [--steps S]
 *                          [--interval K] [--threads T] [--tolerance TOL] [--repeat R]
 *                          [--params all|state] [--contact]
 *
 * --interval 1 stores every state (nothing recomputed); K > 1 every K-th; 0 (the default)
 * automatic (every state within 256 MiB). --repeat R runs the backward pass R times and reports
 * the fastest. --params state asks only for the initial state's gradients (the materials' cost
 * more: dP/dmu, dP/dlambda per element, and the clamped dP/dF for d/dbeta).
 */
#include "bench_beam.h"
#include "cli.h"

#include <defsim/defsim.h>

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

static double now(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

static void usage(FILE *f)
{
    fprintf(f, "usage: defsim-bench-gradients [options]\n"
               "Forward run and backward pass (gradients) on the cantilever, timed.\n"
               "  --backend NAME       differentiable backend (default newton_cholmod)\n"
               "  --n N                cells across (default 4: the scene's 12 x 4 x 4)\n"
               "  --h SECONDS          step size (default 1/120; explicit backends need less)\n"
               "  --steps S            recorded steps (default 60)\n"
               "  --interval K         store every K-th state (default 0: automatic)\n"
               "  --threads T          OpenMP threads (default 1)\n"
               "  --tolerance TOL      Newton tolerance (default 1e-10)\n"
               "  --repeat R           backward passes; the fastest is reported (default 3)\n"
               "  --params P           all (default) or state (x0 and v0 only)\n"
               "  --contact            a ground plane (mu 0.3) 5 cm under the beam: its tip lands\n"
               "                       and slides (collider contact's gradients)\n"
               "  -h, --help           this text\n"
               "  --version            the library's version\n");
}

static int fail(defsim_world *w, const char *what)
{
    fprintf(stderr, "defsim-bench-gradients: %s: %s\n", what,
            w ? defsim_world_last_error(w) : defsim_last_error());
    return 1;
}

int main(int argc, char **argv)
{
    const char *backend = "newton_cholmod", *params = "all";
    int n = 4, steps = 60, interval = 0, threads = 1, repeat = 3, contact = 0;
    double h = 1.0 / 120.0, tol = 1e-10;
    static const cli_tool tool = {"defsim-bench-gradients", usage, NULL, ""};
    const cli_opt opts[] = {
        {"backend", CLI_STRING, &backend, 0, 0}, {"n", CLI_INT, &n, 1, 1000},
        {"h", CLI_POSITIVE, &h, 0, 0}, {"steps", CLI_INT, &steps, 1, 1e8},
        {"interval", CLI_INT, &interval, 0, 1e8}, {"threads", CLI_INT, &threads, 0, 4096},
        {"tolerance", CLI_POSITIVE, &tol, 0, 0}, {"repeat", CLI_INT, &repeat, 1, 1000},
        {"params", CLI_STRING, &params, 0, 0}, {"contact", CLI_FLAG, &contact, 0, 0}, {0}};
    int first;
    const int parsed = cli_parse(&tool, opts, argc, argv, &first);
    if (parsed >= 0) return parsed;
    if (first < argc) return cli_fail(&tool, "no operands expected (got %s)", argv[first]);
    const int state_only = strcmp(params, "state") == 0;
    if (!state_only && strcmp(params, "all") != 0)
        return cli_fail(&tool, "--params must be all or state (got %s)", params);

    defsim_world_def wd;
    defsim_world_def_init(&wd, sizeof wd);
    wd.backend = backend;
    wd.num_threads = threads;
    defsim_world *w;
    if (defsim_world_create(&wd, &w) != DEFSIM_OK) return fail(NULL, "world");
    if (bench_backend_option(w, backend, "tolerance", tol) != DEFSIM_OK) return fail(w, "option");
    defsim_mesh m;
    if (bench_beam_mesh(n, &m) != DEFSIM_OK) return fail(NULL, "mesh");
    defsim_material mat;
    defsim_material_init(&mat, sizeof mat, DEFSIM_MODEL_STABLE_NEOHOOKEAN);
    mat.youngs_modulus = 1e6;
    mat.poisson_ratio = 0.3;
    mat.density = 1000.0;
    mat.mass_damping = 1.0;
    defsim_body_id b;
    if (bench_add_beam(w, &m, &mat, 1, &b) != DEFSIM_OK) return fail(w, "beam");
    if (contact) {
        defsim_collider_def cd;
        defsim_collider_def_init(&cd, sizeof cd);
        cd.position[1] = -0.05;
        cd.friction = 0.3;
        if (defsim_world_add_collider(w, &cd, NULL) != DEFSIM_OK) return fail(w, "collider");
    }
    const int nv = m.vertex_count;
    int tip = 0;
    for (int i = 0; i < nv; ++i) {
        const double *p = m.positions + 3 * i;
        if (fabs(p[0] - 3.0) + fabs(p[1] - 1.0) + fabs(p[2] - 1.0) < 1e-9) tip = i;
    }
    /* the backend's set-up (pattern, symbolic analysis) outside the timed run */
    if (defsim_world_step(w, h) != DEFSIM_OK) return fail(w, "step");
    defsim_tape_def td;
    defsim_tape_def_init(&td, sizeof td);
    td.interval = interval;
    defsim_tape *t;
    if (defsim_world_record(w, &td, &t) != DEFSIM_OK) return fail(w, "record");
    const double t0 = now();
    for (int s = 0; s < steps; ++s)
        if (defsim_world_step(w, h) != DEFSIM_OK) return fail(w, "step");
    const double forward = now() - t0;

    const size_t n3 = 3 * (size_t)nv, all = n3 * (size_t)(steps + 1);
    double *dl = calloc(all, sizeof *dl), *gx = malloc(n3 * sizeof *gx);
    double *gv = malloc(n3 * sizeof *gv);
    if (!dl || !gx || !gv) return fail(NULL, "out of memory");
    for (int s = 0; s <= steps; ++s) dl[n3 * (size_t)s + 3 * (size_t)tip + 1] = 1.0 / (steps + 1);
    double gb[5] = {0, 0, 0, 0, 0};
    const char *names[5] = {"youngs_modulus", "poisson_ratio", "density", "mass_damping",
                            "stiffness_damping"};
    defsim_gradient g[7];
    for (int k = 0; k < 5; ++k) g[k] = (defsim_gradient){names[k], &gb[k], 1};
    g[5] = (defsim_gradient){"initial_positions", gx, (int64_t)n3};
    g[6] = (defsim_gradient){"initial_velocities", gv, (int64_t)n3};
    double best = INFINITY;
    defsim_tape_stats ts = {.size = sizeof ts};
    for (int r = 0; r < repeat; ++r) {
        const double b0 = now();
        const defsim_gradient *gs = state_only ? g + 5 : g;
        if (defsim_tape_backward(t, dl, NULL, (int64_t)all, gs, state_only ? 2 : 7) != DEFSIM_OK)
            return fail(w, "backward");
        const double bt = now() - b0;
        if (bt < best) {
            best = bt;
            defsim_tape_get_stats(t, &ts);
        }
    }
    printf("cantilever %dx%dx%d cells, %d tets, %d vertices, backend %s, h = %.6g s, %d steps, "
           "%d thread(s), gradients: %s%s\n",
           3 * n, n, n, m.tet_count, nv, backend, h, steps, threads,
           state_only ? "x0, v0" : "all", contact ? ", on a ground plane (contact)" : "");
    if (contact) {
        double active = 0.0;
        (void)defsim_world_stat(w, "contact.active", &active);
        printf("contact: %.0f vertices within dhat of the plane at the end\n", active);
    }
    printf("forward %.4f s, backward %.4f s (fastest of %d; recomputation %.4f s, %lld steps): "
           "ratio %.3f\n",
           forward, best, repeat, ts.time_recompute, (long long)ts.recomputed_steps,
           best / forward);
    printf("tape: interval %d, %lld stored states, %lld bytes (%.1f KiB); the backward pass "
           "held %lld bytes more\n",
           (int)ts.interval, (long long)ts.stored_states, (long long)ts.bytes, ts.bytes / 1024.0,
           (long long)ts.backward_bytes);
    double nx = 0.0, nvv = 0.0;
    for (size_t i = 0; i < n3; ++i) {
        nx += gx[i] * gx[i];
        nvv += gv[i] * gv[i];
    }
    printf("dL/dE %.6e 1/Pa  dL/dnu %.6e  dL/drho %.6e m^3/kg  dL/dalpha %.6e s  "
           "dL/dbeta %.6e 1/s  |dL/dx0| %.6e  |dL/dv0| %.6e s\n",
           gb[0], gb[1], gb[2], gb[3], gb[4], sqrt(nx), sqrt(nvv));
    free(dl);
    free(gx);
    free(gv);
    defsim_tape_destroy(t);
    defsim_mesh_free(&m);
    defsim_world_destroy(w);
    return 0;
}
