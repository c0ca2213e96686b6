/* SPDX-License-Identifier: MIT */
/*
 * defsim-bench-implicit: implicit steps on the cantilever beam of the peer benchmarks
 * (3n x n x n cells on [0,3] x [0,1] x [0,1] m, 6 tets per cell; n = 18 gives 104976 tets,
 * n = 8 gives 9216), E = 1 MPa, nu = 0.3, rho = 1000 kg/m^3, gravity -9.81 m/s^2 along y,
 * the face x = 0 clamped, starting at rest. For every step it prints the Newton iterations,
 * line-search backtracks, and the time spent in force evaluation, Hessian assembly, numeric
 * factorisation and triangular solves, from defsim_world_stats. The first step also builds the
 * matrix pattern and the symbolic factorisation: its "other" column holds that set-up.
 *
 *   defsim-bench-implicit [--backend newton_cholmod] [--model snh|corotated|nh|stvk] [--n N]
 *                         [--threads T] [--h SECONDS] [--steps S] [--tolerance TOL]
 *                         [--max-iterations K] [--projection none|clamp|abs] [--verbose]
 *
 * --max-iterations 1 times exactly one Newton iteration per step (the step then reports
 * "not converged", which the benchmark expects and ignores).
 */
#include "bench_beam.h"
#include "cli.h"

#include <defsim/defsim.h>

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static void print_log(void *user, int level, const char *message)
{
    (void)user;
    fprintf(stderr, "[log %d] %s\n", level, message);
}

static void usage(FILE *f)
{
    fprintf(f, "usage: defsim-bench-implicit [options]\n"
               "Implicit steps on the 3n x n x n cantilever beam, timed per step.\n"
               "  --backend NAME       implicit backend (default newton_cholmod)\n"
               "  --model M            snh (default), corotated, nh or stvk\n"
               "  --n N                cells across (default 18: 104976 tets)\n"
               "  --threads T          OpenMP threads (default 0: OpenMP's default)\n"
               "  --h SECONDS          step size (default 1/60)\n"
               "  --steps S            steps (default 3)\n"
               "  --tolerance TOL      Newton tolerance (default 1e-6)\n"
               "  --max-iterations K   Newton iterations per step (default 50)\n"
               "  --projection P       none, clamp (default) or abs\n"
               "  --verbose            the library's log on stderr\n"
               "  -h, --help           this text\n"
               "  --version            the library's version\n");
}

int main(int argc, char **argv)
{
    const char *model_name = "snh", *backend = "newton_cholmod", *proj = "clamp";
    int n = 18, threads = 0, steps = 3, max_it = 50, verbose = 0;
    double h = 1.0 / 60.0, tol = 1e-6;
    static const cli_tool tool = {"defsim-bench-implicit", usage, NULL, ""};
    const cli_opt opts[] = {
        {"model", CLI_STRING, &model_name, 0, 0}, {"backend", CLI_STRING, &backend, 0, 0},
        {"n", CLI_INT, &n, 1, 1000}, {"threads", CLI_INT, &threads, 0, 4096},
        {"h", CLI_POSITIVE, &h, 0, 0}, {"steps", CLI_INT, &steps, 1, 1e9},
        {"tolerance", CLI_POSITIVE, &tol, 0, 0}, {"max-iterations", CLI_INT, &max_it, 1, 1e6},
        {"projection", CLI_STRING, &proj, 0, 0}, {"verbose", CLI_FLAG, &verbose, 0, 0}, {0}};
    int first;
    const int parsed = cli_parse(&tool, opts, argc, argv, &first);
    if (parsed >= 0) return parsed;
    if (first < argc) return cli_fail(&tool, "no operands expected (got %s)", argv[first]);
    const defsim_model model = bench_model_by_name(model_name);
    if (!model) return cli_fail(&tool, "unknown model %s", model_name);
    defsim_projection projection;
    if (!strcmp(proj, "none")) projection = DEFSIM_PROJECTION_NONE;
    else if (!strcmp(proj, "clamp")) projection = DEFSIM_PROJECTION_CLAMP;
    else if (!strcmp(proj, "abs")) projection = DEFSIM_PROJECTION_ABS;
    else return cli_fail(&tool, "--projection must be none, clamp or abs (got %s)", proj);

    defsim_world_def wd;
    defsim_world_def_init(&wd, sizeof wd);
    wd.backend = backend;
    wd.num_threads = threads;
    if (verbose) wd.log = print_log;
    defsim_world *w;
    if (defsim_world_create(&wd, &w) != DEFSIM_OK) {
        fprintf(stderr, "%s\n", defsim_last_error());
        return 1;
    }
    if (bench_backend_option(w, backend, "tolerance", tol) != DEFSIM_OK ||
        bench_backend_option(w, backend, "max_iterations", max_it) != DEFSIM_OK ||
        bench_backend_option(w, backend, "projection", projection) != DEFSIM_OK) {
        fprintf(stderr, "%s\n", defsim_world_last_error(w));
        return 1;
    }
    defsim_mesh m;
    if (bench_beam_mesh(n, &m) != DEFSIM_OK) {
        fprintf(stderr, "%s\n", defsim_last_error());
        return 1;
    }
    defsim_material mat;
    defsim_material_init(&mat, sizeof mat, model);
    mat.youngs_modulus = 1e6;
    mat.poisson_ratio = 0.3;
    mat.density = 1000.0;
    defsim_body_id b;
    if (bench_add_beam(w, &m, &mat, 1, &b) != DEFSIM_OK) {
        fprintf(stderr, "%s\n", defsim_world_last_error(w));
        return 1;
    }
    const int np = (n + 1) * (n + 1);   /* the x = 0 face */

    defsim_stats s0 = {.size = sizeof s0};
    defsim_world_stats(w, &s0);
    printf("beam %dx%dx%d cells, %d tets, %d vertices (%d clamped), model %s, h = %.6g s, "
           "%d threads, projection %s, tolerance %.3g\n",
           3 * n, n, n, m.tet_count, m.vertex_count, np, model_name, h, s0.threads, proj, tol);
    printf("%4s %5s %5s %9s %9s %9s %9s %9s %9s\n", "step", "newton", "backtr", "forces_s",
           "assembly_s", "factor_s", "solve_s", "other_s", "step_s");
    /* Sums over the counted steps: the core's timings and the backend's counters by name. */
    struct { double newton, time_hessian, time_factor, time_solve, time_forces, time_step; } tot;
    memset(&tot, 0, sizeof tot);
    int counted = 0;
    for (int k = 0; k < steps; ++k) {
        defsim_world_reset_stats(w);
        defsim_status st = defsim_world_step(w, h);
        defsim_stats s = {.size = sizeof s};
        defsim_world_stats(w, &s);
        const double newton = bench_backend_stat(w, backend, "newton_iterations");
        const double factor = bench_backend_stat(w, backend, "time_factor");
        const double solve = bench_backend_stat(w, backend, "time_solve");
        /* A step cut off by --max-iterations is expected; any other failure is not. */
        if (st != DEFSIM_OK && !(st == DEFSIM_ERR_NOT_CONVERGED && newton == max_it)) {
            fprintf(stderr, "step %d: %s: %s\n", k, defsim_status_string(st),
                    defsim_world_last_error(w));
            return 1;
        }
        double other = s.time_step - s.time_forces - s.time_hessian - factor - solve;
        printf("%4d %5.0f %5.0f %9.4f %9.4f %9.4f %9.4f %9.4f %9.4f%s\n", k, newton,
               bench_backend_stat(w, backend, "line_search_backtracks"), s.time_forces,
               s.time_hessian, factor, solve, other, s.time_step,
               k == 0 ? "  (includes set-up)" : "");
        if (k > 0 || steps == 1) {
            tot.newton += newton;
            tot.time_hessian += s.time_hessian;
            tot.time_factor += factor;
            tot.time_solve += solve;
            tot.time_forces += s.time_forces;
            tot.time_step += s.time_step;
            counted++;
        }
        if (st != DEFSIM_OK) {
            /* One timed iteration per step: restart from rest so every step times the same. */
            defsim_world_set_state(w, m.positions, NULL);
        }
    }
    if (tot.newton > 0) {
        double it = tot.newton;
        double per = (tot.time_hessian + tot.time_factor + tot.time_solve) / it;
        printf("per Newton iteration (steps %s): assembly %.4f s, factorisation %.4f s, solve "
               "%.4f s, assembly+factorisation+solve %.4f s (assembly %.1f %%); forces %.4f s\n",
               steps == 1 ? "0" : "1..", tot.time_hessian / it, tot.time_factor / it,
               tot.time_solve / it, per, 100.0 * tot.time_hessian / it / per,
               tot.time_forces / it);
        printf("per step: %.2f Newton iterations, %.4f s\n", it / counted,
               tot.time_step / counted);
    }
    defsim_mesh_free(&m);
    defsim_world_destroy(w);
    return 0;
}
