/* SPDX-License-Identifier: MIT */
/*
 * defsim-bench-ida SCENE.json TOL REPEATS [NAME=VALUE ...]: the cost of one adaptive run as
 * `defsim bench` times it (calls of one frame to T = min(0.5 s, the scene's duration), rtol = TOL,
 * atol = TOL x body size, one thread, sundials_ida), with the counters that explain it. Prints one line: the
 * median wall time of REPEATS runs of the stepping loop, ms per internal step, internal steps,
 * Newton iterations, Jacobian evaluations (for sundials_ida: factorisations, one per set-up) and
 * a position checksum. The options (e.g. sundials_ida.linear_solver=klu) are set after the
 * scene's. Uses only the public API and the scene loader, so the same file builds against older
 * trees for before/after comparisons (backends/sundials_ida/README.md "Cost").
 */
#include "cli.h"
#include "clock.h"
#include "scene.h"
#include "stat.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static int cmp_double(const void *a, const void *b)
{
    const double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

static void usage(FILE *f)
{
    fprintf(f, "usage: defsim-bench-ida SCENE.json TOL REPEATS [NAME=VALUE ...]\n"
               "One adaptive sundials_ida run as defsim bench times it (rtol = TOL, atol = TOL x\n"
               "body size, one thread), REPEATS (1..64) times: median wall time, ms per internal\n"
               "step, internal steps, Newton iterations, Jacobian evaluations, a checksum.\n"
               "NAME=VALUE: options set after the scene's (sundials_ida.linear_solver=klu).\n"
               "  -h, --help   this text\n"
               "  --version    the library's version\n");
}

int main(int argc, char **argv)
{
    static const cli_tool tool = {"defsim-bench-ida", usage, NULL, ""};
    int first;
    const int parsed = cli_parse(&tool, NULL, argc, argv, &first);
    if (parsed >= 0) return parsed;
    char **arg = argv + first;
    const int nargs = argc - first;
    if (nargs < 3) return cli_fail(&tool, "need SCENE.json TOL REPEATS");
    char *end1 = NULL, *end2 = NULL;
    const double tol = strtod(arg[1], &end1);
    const long repeats = strtol(arg[2], &end2, 10);
    if (*end1 || end1 == arg[1] || !(tol > 0.0) || !isfinite(tol) || *end2 || end2 == arg[2] ||
        repeats < 1 || repeats > 64)
        return cli_fail(&tool, "TOL > 0 and REPEATS 1 to 64 (got %s and %s)", arg[1], arg[2]);
    for (int a = 3; a < nargs; ++a)
        if (!strchr(arg[a], '=') || arg[a][0] == '=')
            return cli_fail(&tool, "options are NAME=VALUE (got %s)", arg[a]);
    scene s;
    if (scene_load(&s, arg[0], NULL, 0) != 0) {
        fprintf(stderr, "defsim-bench-ida: %s\n", s.error);
        return 1;
    }
    /* Body size: the bounding-box diagonal of the rest shape, as defsim bench has it. */
    double lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
    for (int32_t i = 0; i < s.nbodies; ++i)
        for (int32_t v = 0; v < s.bodies[i].mesh.vertex_count; ++v)
            for (int k = 0; k < 3; ++k) {
                lo[k] = fmin(lo[k], s.bodies[i].mesh.positions[3 * v + k]);
                hi[k] = fmax(hi[k], s.bodies[i].mesh.positions[3 * v + k]);
            }
    const double size = sqrt((hi[0] - lo[0]) * (hi[0] - lo[0]) +
                             (hi[1] - lo[1]) * (hi[1] - lo[1]) + (hi[2] - lo[2]) * (hi[2] - lo[2]));
    double walls[64];
    double internal = 0.0, newton = 0.0, jacobians = 0.0;   /* sundials_ida's counters */
    double sum = 0.0;
    for (int r = 0; r < repeats; ++r) {
        s.def.backend = "sundials_ida";
        snprintf(s.backend, sizeof s.backend, "sundials_ida");
        s.def.num_threads = 1;
        scene_setting(&s, SCENE_RTOL, tol);
        scene_setting(&s, SCENE_ATOL, tol * size);
        scene_setting(&s, SCENE_MAX_INTERNAL_STEPS, 10000000);
        defsim_world *w = NULL;
        if (scene_build(&s, &w) != DEFSIM_OK) {
            fprintf(stderr, "defsim-bench-ida: %s\n", s.error);
            return 1;
        }
        const int32_t nv = defsim_world_vertex_count(w);
        double *x = malloc((size_t)nv * 3 * sizeof *x);
        defsim_status e = DEFSIM_OK;
        for (int a = 3; a < nargs && e == DEFSIM_OK; ++a) {
            char name[128];
            const char *eq = strchr(arg[a], '=');
            snprintf(name, sizeof name, "%.*s", (int)(eq - arg[a]), arg[a]);
            e = defsim_world_set_option(w, name, eq + 1);
        }
        if (e != DEFSIM_OK) {
            fprintf(stderr, "defsim-bench-ida: %s\n", defsim_world_last_error(w));
            return 1;
        }
        const double T = s.duration < 0.5 ? s.duration : 0.5, h = s.h * s.frame_steps;
        const long n = (long)ceil(T / h - 1e-9);
        const double t0 = tools_now();
        for (long i = 0; i < n && e == DEFSIM_OK; ++i)
            e = defsim_world_step(w, i == n - 1 ? T - defsim_world_time(w) : h);
        walls[r] = tools_now() - t0;
        if (e != DEFSIM_OK) {
            fprintf(stderr, "defsim-bench-ida: %s\n", defsim_world_last_error(w));
            return 1;
        }
        internal = tools_backend_stat(w, "internal_steps");
        newton = tools_backend_stat(w, "newton_iterations");
        jacobians = tools_backend_stat(w, "jacobian_evals");
        defsim_world_get_positions(w, x, nv);
        sum = 0.0;
        for (int32_t i = 0; i < 3 * nv; ++i) sum += x[i] * (double)(1 + i % 7);
        free(x);
        defsim_world_destroy(w);
    }
    qsort(walls, (size_t)repeats, sizeof *walls, cmp_double);
    const double med = walls[repeats / 2];
    printf("tol %.3g wall_s %.4f ms_per_step %.3f internal_steps %lld newton %lld jacobians %lld "
           "checksum %.15e\n",
           tol, med, 1e3 * med / internal, (long long)internal, (long long)newton,
           (long long)jacobians, sum);
    scene_free(&s);
    return 0;
}
