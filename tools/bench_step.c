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
#include "cli.h"
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

static void usage(FILE *f)
{
    fprintf(f, "usage: defsim-bench-step [options]\n"
               "Explicit-step throughput on the 3n x n x n box beam (median over repeats).\n"
               "  --model M         snh (default), nh, corotated or stvk\n"
               "  --n N             cells across (default 18: 104976 tets)\n"
               "  --threads T       OpenMP threads (default 1; 0: OpenMP's default)\n"
               "  --steps S         steps per repeat (default 20)\n"
               "  --repeats R       repeats, 1..100 (default 5)\n"
               "  --backend NAME    explicit backend (default symplectic_euler)\n"
               "  --simd ISA        scalar, generic, avx2 or avx512 (default: the CPU's best)\n"
               "  --stream-gbs B    memory bandwidth of the roofline estimate, GB/s (default 18)\n"
               "  -h, --help        this text\n"
               "  --version         the library's version\n");
}

int main(int argc, char **argv)
{
    const char *model_name = "snh", *backend = "symplectic_euler";
    const char *simd = NULL;
    int n = 18, threads = 1, steps = 20, repeats = 5;
    double stream_gbs = 18.0;
    static const cli_tool tool = {"defsim-bench-step", usage, NULL, ""};
    const cli_opt opts[] = {
        {"model", CLI_STRING, &model_name, 0, 0}, {"n", CLI_INT, &n, 1, 1000},
        {"threads", CLI_INT, &threads, 0, 4096}, {"steps", CLI_INT, &steps, 1, 1e9},
        {"repeats", CLI_INT, &repeats, 1, 100}, {"backend", CLI_STRING, &backend, 0, 0},
        {"simd", CLI_STRING, &simd, 0, 0}, {"stream-gbs", CLI_POSITIVE, &stream_gbs, 0, 0}, {0}};
    int first;
    const int parsed = cli_parse(&tool, opts, argc, argv, &first);
    if (parsed >= 0) return parsed;
    if (first < argc) return cli_fail(&tool, "no operands expected (got %s)", argv[first]);
    const defsim_model model = bench_model_by_name(model_name);
    if (!model) return cli_fail(&tool, "unknown model %s", model_name);

    defsim_world_def wd;
    defsim_world_def_init(&wd, sizeof wd);
    wd.backend = backend;
    wd.num_threads = threads;
    defsim_world *w;
    if (defsim_world_create(&wd, &w) != DEFSIM_OK) {
        fprintf(stderr, "%s\n", defsim_last_error());
        return 1;
    }
    /* The batched kernel variant (DEFSIM_SIMD, when set, still overrides the option). */
    if (simd && defsim_world_set_option(w, "core.simd", simd) != DEFSIM_OK) {
        fprintf(stderr, "--simd: %s\n", defsim_world_last_error(w));
        return 2;
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
