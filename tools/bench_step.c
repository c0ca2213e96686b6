/* SPDX-License-Identifier: MIT */
/*
 * defsim-bench-step: explicit-step throughput on the box beam of the peer benchmarks
 * (3n x n x n cells on [0,3] x [0,1] x [0,1] m, 6 tets per cell; n = 18 gives 104976 tets),
 * E = 1 MPa, nu = 0.3, rho = 1000, gravity, x = 0 clamped. Prints the median over repeats.
 *
 *   defsim-bench-step [--model snh|nh|corotated|stvk] [--n N] [--threads T] [--steps S]
 *                     [--repeats R] [--backend NAME] [--simd scalar|generic|avx2|avx512]
 *                     [--stream-gbs B]
 *
 * After the RESULT line, a ROOFLINE line estimates the memory traffic of a step: element data
 * streamed by the batched force kernel (vertex ids 16 B, Dm^-1 72 B, -vol 8 B, 2 or 3 model
 * parameters), plus every per-vertex pass of a symplectic step counted once as if it came from
 * memory (x gather, f clear and scatter, gravity, pins, finite check, the update, the saved
 * state), against B GB/s (default 18: STREAM triad, one thread, on the reference machine).
 * `forces_tet_steps_per_s` is the force evaluation alone (defsim_stats.time_forces).
 */
#include "bench_beam.h"
#include "clock.h"

#include <defsim/defsim.h>

#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

static int cmp(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

int main(int argc, char **argv)
{
    const char *model_name = "snh", *backend = "symplectic_euler";
    const char *simd = NULL;
    int n = 18, threads = 1, steps = 20, repeats = 5;
    double stream_gbs = 18.0;
    for (int i = 1; i + 1 < argc; i += 2) {
        if (!strcmp(argv[i], "--model")) model_name = argv[i + 1];
        else if (!strcmp(argv[i], "--n")) n = atoi(argv[i + 1]);
        else if (!strcmp(argv[i], "--threads")) threads = atoi(argv[i + 1]);
        else if (!strcmp(argv[i], "--steps")) steps = atoi(argv[i + 1]);
        else if (!strcmp(argv[i], "--repeats")) repeats = atoi(argv[i + 1]);
        else if (!strcmp(argv[i], "--backend")) backend = argv[i + 1];
        else if (!strcmp(argv[i], "--simd")) simd = argv[i + 1];
        else if (!strcmp(argv[i], "--stream-gbs")) stream_gbs = atof(argv[i + 1]);
        else { fprintf(stderr, "unknown option %s\n", argv[i]); return 2; }
    }
    const defsim_model model = bench_model_by_name(model_name);
    if (!model) { fprintf(stderr, "unknown model %s\n", model_name); return 2; }
    if (n < 1 || steps < 1 || repeats < 1 || repeats > 100 || threads < 0) return 2;

    /* The batched kernel variant is chosen when the world plans (DEFSIM_SIMD overrides it). */
    if (simd) setenv("DEFSIM_SIMD", simd, 1);
    defsim_world_def wd;
    defsim_world_def_init(&wd, sizeof wd);
    wd.backend = backend;
    wd.num_threads = threads;
    defsim_world *w;
    if (defsim_world_create(&wd, &w) != DEFSIM_OK) {
        fprintf(stderr, "%s\n", defsim_last_error());
        return 1;
    }
    defsim_mesh m;
    if (bench_beam_mesh(n, &m) != DEFSIM_OK) return 1;
    defsim_material mat;
    defsim_material_init(&mat, sizeof mat, model);
    defsim_body_id b;
    if (bench_add_beam(w, &m, &mat, 1, &b) != DEFSIM_OK) {
        fprintf(stderr, "%s\n", defsim_world_last_error(w));
        return 1;
    }
    const double h = 1e-5;   /* well under the stable step: timing does not depend on it */
    for (int i = 0; i < 2; ++i) defsim_world_step(w, h);   /* plan, init, warm caches */
    defsim_world_reset_stats(w);
    double t[100];
    for (int r = 0; r < repeats; ++r) {
        double t0 = tools_now();
        for (int i = 0; i < steps; ++i)
            if (defsim_world_step(w, h) != DEFSIM_OK) {
                fprintf(stderr, "step failed: %s\n", defsim_world_last_error(w));
                return 1;
            }
        t[r] = (tools_now() - t0) / steps;
    }
    qsort(t, (size_t)repeats, sizeof *t, cmp);
    double med = t[repeats / 2];
    defsim_stats s = {.size = sizeof s};
    defsim_world_stats(w, &s);
    printf("RESULT {\"lib\": \"defsim\", \"backend\": \"%s\", \"model\": \"%s\", \"tets\": %d, "
           "\"threads\": %d, \"s_per_step\": %.6g, \"tet_steps_per_s\": %.4g, "
           "\"min_s\": %.6g, \"max_s\": %.6g}\n",
           backend, model_name, m.tet_count, s.threads, med, m.tet_count / med, t[0],
           t[repeats - 1]);
    /* Element rows read: the stable neo-Hookean kernel reads mu', lambda', alpha; the others
     * mu, lambda. Per-vertex passes, bytes per vertex: x gather 24, f clear 24, f scatter 48,
     * gravity 56, pins 1, finite check 24, update 168 (f, m, v, x read; v, x written),
     * saved state 96. */
    const double elem = 16.0 + 8.0 * (10 + (model == DEFSIM_MODEL_STABLE_NEOHOOKEAN ? 3 : 2));
    const double vert = 441.0 * m.vertex_count / m.tet_count;
    const double rate = m.tet_count / med;
    const double fk = s.time_forces > 0.0 ? (double)m.tet_count * s.force_evals / s.time_forces : 0.0;
    printf("ROOFLINE {\"element_bytes\": %.0f, \"vertex_bytes\": %.1f, \"bytes_per_tet_step\": %.1f, "
           "\"gb_per_s\": %.3g, \"stream_gb_per_s\": %.3g, \"fraction_of_stream\": %.3f, "
           "\"forces_tet_steps_per_s\": %.4g, \"simd\": \"%s\"}\n",
           elem, vert, elem + vert, (elem + vert) * rate * 1e-9, stream_gbs,
           (elem + vert) * rate * 1e-9 / stream_gbs, fk, simd ? simd : "auto");
    defsim_mesh_free(&m);
    defsim_world_destroy(w);
    return 0;
}
