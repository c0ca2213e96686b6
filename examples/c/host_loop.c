/* SPDX-License-Identifier: MIT */
/*
 * Embedding defsim in a host's frame loop (a game or an editor): the host renders at 60 frames
 * per second and advances the physics by fixed steps with an accumulator, so the simulation
 * does not depend on the frame rate. Each frame it applies a gust of wind to a cloth as external
 * forces, drags one corner with a driven pin, and reads the positions back for drawing.
 *
 * The check at the end: the dragged corner followed its path, and once the wind and the drag
 * have stopped (t >= 2 s) no work is done on the cloth, so its total energy must not grow.
 *
 *   cc host_loop.c -ldefsim -lm -o host_loop && ./host_loop
 */
#include <defsim/defsim.h>

#include <math.h>
#include <stdio.h>
#include <stdlib.h>

static int fail(defsim_world *w, const char *what, defsim_status st)
{
    fprintf(stderr, "%s: %s: %s\n", what, defsim_status_string(st),
            w ? defsim_world_last_error(w) : defsim_last_error());
    return 1;
}

int main(void)
{
    defsim_world *w = NULL;
    defsim_world_def wd;
    defsim_world_def_init(&wd, sizeof wd);
    wd.backend = "symplectic_euler";
    defsim_status st = defsim_world_create(&wd, &w);
    if (st != DEFSIM_OK) return fail(w, "create", st);

    /* A 1 m cloth of 16 x 16 cells hanging from two corners. */
    defsim_mesh cloth = {.size = sizeof cloth};
    st = defsim_mesh_cloth((double[3]){0, 1, 0}, (double[3]){1, 0, 0}, (double[3]){0, 0, 1}, 16,
                           16, &cloth);
    if (st != DEFSIM_OK) return fail(w, "mesh", st);
    defsim_body_def bd;
    defsim_body_def_init(&bd, sizeof bd);
    bd.rest_positions = cloth.positions;
    bd.vertex_count = cloth.vertex_count;
    bd.springs = cloth.springs;
    bd.spring_count = cloth.spring_count;
    defsim_material_init(&bd.material, sizeof bd.material, DEFSIM_MODEL_SPRING);
    bd.material.stiffness = 2e3;       /* N/m per spring */
    bd.material.vertex_mass = 1e-3;    /* kg */
    bd.material.mass_damping = 0.5;    /* 1/s */
    defsim_body_id id;
    if ((st = defsim_world_add_body(w, &bd, &id)) != DEFSIM_OK) return fail(w, "add", st);
    const int32_t corners[2] = {0, 16};
    if ((st = defsim_body_pin(w, id, corners, 2)) != DEFSIM_OK) return fail(w, "pin", st);

    /* The physics step: 80 % of the stable step, at most 1 ms. */
    double h;
    if ((st = defsim_world_stable_step(w, &h, NULL)) != DEFSIM_OK) return fail(w, "stable", st);
    h = fmin(0.8 * h, 1e-3);

    const int32_t nv = defsim_world_vertex_count(w);
    double *x = malloc(3 * sizeof(double) * (size_t)nv);
    double *wind = calloc(3 * (size_t)nv, sizeof(double));
    if (!x || !wind) return 1;

    const double frame = 1.0 / 60.0;
    double accumulator = 0.0, e_2s = NAN, e_end = NAN;
    int64_t steps = 0;
    for (int f = 0; f < 180; ++f) {                  /* 3 s of frames */
        const double t = f * frame;
        /* Input: a gust along +z for the first second, applied to every vertex. */
        for (int32_t i = 0; i < nv; ++i) wind[3 * i + 2] = t < 1.0 ? 2e-3 : 0.0;
        if ((st = defsim_world_set_external_forces(w, wind, nv)) != DEFSIM_OK)
            return fail(w, "wind", st);
        accumulator += frame;
        while (accumulator >= h) {
            /* Drag corner 16 along x to 1.2 m over the first 2 s (a driven pin: the target is
             * where it is at the end of this step). */
            const double te = defsim_world_time(w) + h;
            const double target[3] = {1.0 + 0.2 * fmin(te / 2.0, 1.0), 1.0, 0.0};
            if ((st = defsim_body_set_pin_targets(w, id, &corners[1], 1, target)) != DEFSIM_OK)
                return fail(w, "drag", st);
            if ((st = defsim_world_step(w, h)) != DEFSIM_OK) return fail(w, "step", st);
            accumulator -= h;
            ++steps;
        }
        /* Draw: here, read the positions and print a line every half second. */
        if ((st = defsim_world_get_positions(w, x, nv)) != DEFSIM_OK) return fail(w, "get", st);
        defsim_energy e;
        defsim_world_energy(w, &e);
        const double total = e.total;
        if (f == 119) e_2s = total;
        e_end = total;
        if (f % 30 == 29)
            printf("t = %.2f s  steps %lld  corner x = %.3f m  lowest y = %.3f m  energy %.4f J\n",
                   defsim_world_time(w), (long long)steps, x[3 * 16], x[1 + 3 * (nv - 1)], total);
    }
    const double corner_err = fabs(x[3 * 16] - 1.2);
    printf("corner error %.2e m, energy at 2 s %.4f J, at 3 s %.4f J\n", corner_err, e_2s, e_end);
    free(x);
    free(wind);
    defsim_mesh_free(&cloth);
    defsim_world_destroy(w);
    /* Symplectic Euler's energy oscillates by O(h) about a damped value: allow 1 %. */
    return corner_err < 1e-12 && e_end <= e_2s + 0.01 * fabs(e_2s) ? 0 : 1;
}
