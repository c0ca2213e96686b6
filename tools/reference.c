/* SPDX-License-Identifier: MIT */
/*
 * defsim-reference: the reference solution of the work-precision benchmark. A nonlinear tet
 * cantilever (box [0,3] x [0,1] x [0,1] m of 3n x n x n cells, 6 tets per cell, clamped at x = 0,
 * under gravity, from rest) is integrated with sundials_erk (default; or sundials_ida) at a tight
 * tolerance to time T, and
 * the state at T is written as text with 17 significant digits.
 *
 *   defsim-reference [--model snh|nh|corotated|stvk] [--n N] [--T SECONDS] [--rtol R]
 *                    [--atol A] [--E PA] [--nu NU] [--rho KG_M3] [--alpha 1_S] [--beta S]
 *                    [--threads T] [--backend sundials_erk|sundials_ida] [--out PATH]
 *                    [--quiet]
 *
 * Defaults: snh, n = 3 (9 x 3 x 3 cells, 486 tets, 160 vertices), T = 1 s, rtol = atol = 1e-10,
 * E = 1 MPa, nu = 0.3, rho = 1000 kg/m^3, no damping, out = reference_<model>_n<n>.txt.
 *
 * File format (version 1): line-oriented, "key value..." lines in this order, then the vertices.
 *     defsim-reference 1
 *     model snh                          snh | nh | corotated | stvk
 *     cells 9 3 3                        box cells along x, y, z (defsim_mesh_box)
 *     box 0 0 0 3 1 1                    lo and hi corners (m)
 *     youngs_modulus 1000000             Pa
 *     poisson_ratio 0.3
 *     density 1000                       kg/m^3
 *     mass_damping 0                     Rayleigh alpha (1/s)
 *     stiffness_damping 0                Rayleigh beta (s)
 *     gravity 0 -9.81 0                  m/s^2
 *     clamp x 0                          vertices with x <= 0 are pinned
 *     start rest                         rest positions, zero velocity, t = 0
 *     end_time 1                         s
 *     backend sundials_erk
 *     rtol 1e-10
 *     atol 1e-10                         m and m/s, per second of simulated time
 *     internal_steps 12345               the integrator's internal steps
 *     wall_seconds 12.3
 *     energy 1.2 3.4 -5.6 -1.0           kinetic, elastic, gravitational, total (J) at T
 *     vertices 160
 *     x y z vx vy vz                     one line per vertex (m, m/s), in defsim_mesh_box order
 *                                        (vertex i + (nx+1)(j + (ny+1) k))
 * Numbers are printed with %.17g, so they read back exactly.
 */
#include "bench_beam.h"
#include "cli.h"
#include "refsol.h"
#include "stat.h"

#include <defsim/defsim.h>

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static void usage(FILE *f)
{
    fprintf(f,
            "usage: defsim-reference [--model snh|nh|corotated|stvk] [--n N] [--T SECONDS]\n"
            "                        [--rtol R] [--atol A] [--E PA] [--nu NU] [--rho KG_M3]\n"
            "                        [--alpha 1_S] [--beta S] [--threads T]\n"
            "                        [--backend sundials_erk|sundials_ida] [--out PATH] [--quiet]\n"
            "The work-precision benchmark's reference solution of the tet cantilever at time T.\n"
            "Defaults: snh, n = 3 (1..64), T = 1 s, rtol = atol = 1e-10, E = 1 MPa, nu = 0.3,\n"
            "rho = 1000 kg/m^3, no damping, 1 thread, out = reference_<model>_n<n>.txt.\n"
            "  -h, --help   this text\n"
            "  --version    the library's version\n");
}

int main(int argc, char **argv)
{
    const char *model_name = "snh", *out_path = NULL;
    double T = 1.0, rtol = 1e-10, atol = 1e-10, E = 1e6, nu = 0.3, rho = 1000.0;
    double alpha = 0.0, beta = 0.0;
    int n = 3, threads = 1, quiet = 0;
    const char *backend = "sundials_erk";
    static const cli_tool tool = {"defsim-reference", usage, NULL, ""};
    const cli_opt opts[] = {
        {"model", CLI_STRING, &model_name, 0, 0}, {"out", CLI_STRING, &out_path, 0, 0},
        {"backend", CLI_STRING, &backend, 0, 0}, {"n", CLI_INT, &n, 1, 64},
        {"T", CLI_POSITIVE, &T, 0, 0}, {"rtol", CLI_POSITIVE, &rtol, 0, 0},
        {"atol", CLI_POSITIVE, &atol, 0, 0}, {"E", CLI_POSITIVE, &E, 0, 0},
        {"nu", CLI_DOUBLE, &nu, -1.0, 0.5}, {"rho", CLI_POSITIVE, &rho, 0, 0},
        {"alpha", CLI_DOUBLE, &alpha, 0.0, 1e300}, {"beta", CLI_DOUBLE, &beta, 0.0, 1e300},
        {"threads", CLI_INT, &threads, 0, 1024}, {"quiet", CLI_FLAG, &quiet, 0, 0}, {0}};
    int first;
    const int parsed = cli_parse(&tool, opts, argc, argv, &first);
    if (parsed >= 0) return parsed;
    if (first < argc) return cli_fail(&tool, "no operands expected (got %s)", argv[first]);
    const defsim_model model = bench_model_by_name(model_name);
    if (!model) return cli_fail(&tool, "unknown model %s", model_name);
    char default_out[64];
    snprintf(default_out, sizeof default_out, "reference_%s_n%d.txt", model_name, n);
    if (!out_path) out_path = default_out;
    defsim_world_def wd;
    defsim_world_def_init(&wd, sizeof wd);
    wd.backend = backend;
    wd.num_threads = (int32_t)threads;
    defsim_world *w = NULL;
    if (defsim_world_create(&wd, &w) != DEFSIM_OK) {
        fprintf(stderr, "defsim-reference: %s\n", defsim_last_error());
        return 1;
    }
    if (bench_backend_option(w, backend, "rtol", rtol) != DEFSIM_OK ||
        bench_backend_option(w, backend, "atol", atol) != DEFSIM_OK ||
        bench_backend_option(w, backend, "max_internal_steps", 10000000) != DEFSIM_OK) {
        fprintf(stderr, "defsim-reference: %s\n", defsim_world_last_error(w));
        defsim_world_destroy(w);
        return 1;
    }
    defsim_mesh m = {.size = sizeof m};
    if (bench_beam_mesh(n, &m) != DEFSIM_OK) {
        fprintf(stderr, "defsim-reference: %s\n", defsim_last_error());
        defsim_world_destroy(w);
        return 1;
    }
    defsim_material mat;
    defsim_material_init(&mat, sizeof mat, model);
    mat.youngs_modulus = E;
    mat.poisson_ratio = nu;
    mat.density = rho;
    mat.mass_damping = alpha;
    mat.stiffness_damping = beta;
    defsim_body_id b;
    int rc = 1;
    int32_t *pins = malloc((size_t)m.vertex_count * sizeof *pins);
    FILE *f = NULL;
    if (!pins) {
        fprintf(stderr, "defsim-reference: out of memory\n");
        goto done;
    }
    if (bench_add_beam(w, &m, &mat, 1, &b) != DEFSIM_OK) {
        fprintf(stderr, "defsim-reference: %s\n", defsim_world_last_error(w));
        goto done;
    }
    const int32_t np = bench_clamp_list(&m, pins);
    if (!quiet)
        fprintf(stderr, "defsim-reference: %s cantilever, %d tets, %d vertices (%d clamped), to "
                        "T = %g s with %s at rtol %g, atol %g\n",
                model_name, m.tet_count, m.vertex_count, (int)np, T, backend, rtol, atol);

    /* One hundred calls, so that progress can be shown; IDA keeps its history across them. */
    refsol ref;
    if (refsol_integrate(w, T, 100, rtol, atol, quiet ? NULL : "  defsim-reference", &ref) !=
        DEFSIM_OK)
        goto done;
    f = fopen(out_path, "w");
    if (!f) {
        fprintf(stderr, "defsim-reference: cannot write %s\n", out_path);
        refsol_free(&ref);
        goto done;
    }
    /* The beam of bench_beam.h: 3n x n x n cells on [0,3] x [0,1] x [0,1]. */
    fprintf(f, "defsim-reference 1\nmodel %s\ncells %d %d %d\nbox 0 0 0 3 1 1\n", model_name,
            3 * n, n, n);
    fprintf(f, "youngs_modulus %.17g\npoisson_ratio %.17g\ndensity %.17g\n", E, nu, rho);
    fprintf(f, "mass_damping %.17g\nstiffness_damping %.17g\n", alpha, beta);
    fprintf(f, "gravity %.17g %.17g %.17g\nclamp x 0\nstart rest\n", wd.gravity[0],
            wd.gravity[1], wd.gravity[2]);
    ref.backend = backend;
    const int wrote = refsol_write_tail(f, &ref);
    const double wall = ref.wall_seconds;
    refsol_free(&ref);
    if (fclose(f) != 0 || wrote != 0) {
        f = NULL;
        fprintf(stderr, "defsim-reference: error writing %s\n", out_path);
        goto done;
    }
    f = NULL;
    if (!quiet)
        fprintf(stderr, "defsim-reference: wrote %s (%.0f internal steps, %.0f Newton iterations, "
                        "%.0f Jacobians, %.1f s)\n",
                out_path, tools_backend_stat(w, "internal_steps"),
                tools_backend_stat(w, "newton_iterations"), tools_backend_stat(w, "jacobian_evals"),
                wall);
    rc = 0;
done:
    if (f) fclose(f);
    free(pins);
    defsim_mesh_free(&m);
    defsim_world_destroy(w);
    return rc;
}
