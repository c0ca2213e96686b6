/* SPDX-License-Identifier: MIT */
/*
 * sundials_kinsol and newton_cholmod solve the same backward-Euler step, so on a nonlinear tet
 * scene they must produce the same trajectory (1e-8 relative), and both must match the
 * independent dense Newton solution of be_reference.c.
 *
 * Usage: test_kinsol_vs_newton [BACKEND]   compares sundials_kinsol with BACKEND
 *                                          (default newton_cholmod).
 */
#include "be_reference.h"
#include "test_util.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static const char *other = "newton_cholmod";

typedef struct scene {
    defsim_model model;
    double alpha;
    const char *label;
} scene;

/* Undamped, and with mass damping (Rayleigh alpha: the damping term (alpha M)(x - x_n)/h that
 * both backends treat implicitly). */
static const scene scenes[2] = {
    {DEFSIM_MODEL_STABLE_NEOHOOKEAN, 0.0, "stable neo-Hookean, undamped"},
    {DEFSIM_MODEL_NEOHOOKEAN, 0.5, "neo-Hookean, alpha = 0.5 1/s"},
};

static void test_same_trajectory(void **state)
{
    (void)state;
    const double h = 0.02;
    const int steps = 20;
    for (int c = 0; c < 2; ++c) {
        defsim_world *wk = be_cantilever("sundials_kinsol", 1e-11, 100, scenes[c].model,
                                         scenes[c].alpha, 0.0, DEFSIM_PROJECTION_CLAMP, 1.0);
        defsim_world *wn = be_cantilever(other, 1e-11, 100, scenes[c].model, scenes[c].alpha,
                                         0.0, DEFSIM_PROJECTION_CLAMP, 1.0);
        const int n = defsim_world_vertex_count(wk);
        double *xr = tu_positions(wk), *vr = tu_velocities(wk);
        double *x1 = malloc(3 * (size_t)n * sizeof *x1), *v1 = malloc(3 * (size_t)n * sizeof *v1);
        double kx = 0, kv = 0, nx = 0, nv = 0, knx = 0, knv = 0;
        for (int s = 0; s < steps; ++s) {
            be_reference_step(wk, xr, vr, h, x1, v1);
            memcpy(xr, x1, 3 * (size_t)n * sizeof *xr);
            memcpy(vr, v1, 3 * (size_t)n * sizeof *vr);
            TU_OK(defsim_world_step(wk, h));
            if (defsim_world_step(wn, h) != DEFSIM_OK)
                fail_msg("%s: %s", other, defsim_world_last_error(wn));
            double *xk = tu_positions(wk), *vk = tu_velocities(wk);
            double *xn = tu_positions(wn), *vn = tu_velocities(wn);
            kx = fmax(kx, tu_rel_diff(xk, xr, 3 * n, 1e-300));
            kv = fmax(kv, tu_rel_diff(vk, vr, 3 * n, 1e-300));
            nx = fmax(nx, tu_rel_diff(xn, xr, 3 * n, 1e-300));
            nv = fmax(nv, tu_rel_diff(vn, vr, 3 * n, 1e-300));
            knx = fmax(knx, tu_rel_diff(xk, xn, 3 * n, 1e-300));
            knv = fmax(knv, tu_rel_diff(vk, vn, 3 * n, 1e-300));
            free(xk); free(vk); free(xn); free(vn);
        }
        printf("%s: sundials_kinsol vs %s: rel. diff x %.2e, v %.2e; vs dense reference: "
               "kinsol x %.2e v %.2e, %s x %.2e v %.2e\n", scenes[c].label, other, knx, knv, kx,
               kv, other, nx, nv);
        assert_true(kx < 1e-9 && kv < 1e-8);
        assert_true(nx < 1e-8 && nv < 1e-8);
        assert_true(knx < 1e-8 && knv < 1e-8);
        free(xr); free(vr); free(x1); free(v1);
        defsim_world_destroy(wk);
        defsim_world_destroy(wn);
    }
}

int main(int argc, char **argv)
{
    if (argc > 1) other = argv[1];
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_same_trajectory),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
