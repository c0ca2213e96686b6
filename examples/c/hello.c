/* SPDX-License-Identifier: MIT */
/*
 * Hello, defsim: a 1 m cantilever of stable neo-Hookean tets, clamped at x = 0, sags under
 * gravity. Creates a world, adds a body, pins it, steps at the largest stable step, reads the
 * positions back and checks the static tip deflection against Euler-Bernoulli beam theory.
 *
 *   cc hello.c -ldefsim -o hello && ./hello
 */
#include <defsim/defsim.h>

#include <math.h>
#include <stdio.h>
#include <stdlib.h>

#define CHECK(call)                                                                           \
    do {                                                                                      \
        defsim_status st_ = (call);                                                           \
        if (st_ != DEFSIM_OK) {                                                               \
            fprintf(stderr, "%s failed: %s: %s\n", #call, defsim_status_string(st_),          \
                    world ? defsim_world_last_error(world) : defsim_last_error());            \
            return 1;                                                                         \
        }                                                                                     \
    } while (0)

int main(void)
{
    defsim_world *world = NULL;

    /* A world: symplectic Euler by default, gravity -9.81 m/s^2 along y. */
    defsim_world_def wd;
    defsim_world_def_init(&wd, sizeof wd);
    CHECK(defsim_world_create(&wd, &world));

    /* A 1 m x 0.1 m x 0.1 m beam of 20 x 2 x 2 cells (480 tets). */
    const double L = 1.0, a = 0.1;
    defsim_mesh mesh = {.size = sizeof mesh};
    CHECK(defsim_mesh_box((double[3]){0, 0, 0}, (double[3]){L, a, a}, 20, 2, 2, &mesh));

    defsim_body_def body;
    defsim_body_def_init(&body, sizeof body);
    body.rest_positions = mesh.positions;     /* copied by add_body */
    body.vertex_count = mesh.vertex_count;
    body.tets = mesh.tets;
    body.tet_count = mesh.tet_count;
    body.material.youngs_modulus = 1e7;       /* Pa */
    body.material.poisson_ratio = 0.0;        /* as the beam theory below assumes */
    body.material.density = 1000.0;           /* kg/m^3 */
    body.material.mass_damping = 20.0;        /* 1/s */
    defsim_body_id id;
    CHECK(defsim_world_add_body(world, &body, &id));

    /* Clamp the end x = 0. */
    int32_t clamp[64], n = 0;
    for (int32_t i = 0; i < mesh.vertex_count; ++i)
        if (mesh.positions[3 * i] == 0.0) clamp[n++] = i;
    CHECK(defsim_body_pin(world, id, clamp, n));

    /* Step for 3 s at 90 % of the largest stable step. */
    double h;
    CHECK(defsim_world_stable_step(world, &h, NULL));
    h *= 0.9;
    const int steps = (int)ceil(3.0 / h);
    for (int i = 0; i < steps; ++i) CHECK(defsim_world_step(world, h));

    /* Read back: the mean vertical displacement of the tip face x = L. */
    const int32_t nv = defsim_world_vertex_count(world);
    double *x = malloc(3 * sizeof(double) * (size_t)nv);
    if (!x) return 1;
    CHECK(defsim_world_get_positions(world, x, nv));
    double tip = 0.0;
    int tips = 0;
    for (int32_t i = 0; i < nv; ++i)
        if (mesh.positions[3 * i] == L) {
            tip += x[3 * i + 1] - mesh.positions[3 * i + 1];
            ++tips;
        }
    tip /= tips;

    /* Euler-Bernoulli: w = q L^4 / (8 E I), q = rho g A, I = a^4 / 12. */
    const double q = 1000.0 * 9.81 * a * a, I = a * a * a * a / 12.0;
    const double w = q * L * L * L * L / (8.0 * 1e7 * I);
    printf("%d steps of %.3g ms: tip deflection %.4f m, beam theory %.4f m (%+.1f %%)\n", steps,
           1e3 * h, -tip, w, 100.0 * (-tip - w) / w);

    free(x);
    defsim_mesh_free(&mesh);
    defsim_world_destroy(world);
    /* Linear tets lock in bending: with 2 cells across this beam sags 45 % less than the
     * theory, with 3 cells 27 %, with 4 cells 18 % (measured). Refine, or use more cells across,
     * when the deflection matters. */
    return -tip > 0.4 * w && -tip < 1.05 * w ? 0 : 1;
}
