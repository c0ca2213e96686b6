/* SPDX-License-Identifier: MIT */
/*
 * A custom backend: Heun's method (the explicit trapezoidal rule, second order), written by the
 * host against include/defsim/backend.h and registered with defsim_register_backend. A backend
 * sees only the host services (forces, masses, the state): never meshes or materials.
 *
 * The check: a mass on a spring oscillates as x(t) = A cos(omega t); the error at t = 1 s must
 * fall by about 4 when the step is halved (second order).
 *
 *   cc custom_backend.c -ldefsim -lm -o custom_backend && ./custom_backend
 */
#include <defsim/backend.h>

#include <math.h>
#include <stdio.h>
#include <string.h>

typedef struct heun_state {
    double *f0, *f1, *x1, *v1;   /* forces at the start and at the Euler predictor, predictor */
} heun_state;

static defsim_status heun_init(const defsim_host *host, defsim_system *sys, void *state)
{
    heun_state *s = state;
    const size_t bytes = (size_t)host->dof_count(sys) * sizeof(double);
    s->f0 = host->alloc(bytes);
    s->f1 = host->alloc(bytes);
    s->x1 = host->alloc(bytes);
    s->v1 = host->alloc(bytes);
    return s->f0 && s->f1 && s->x1 && s->v1 ? DEFSIM_OK : DEFSIM_ERR_OUT_OF_MEMORY;
}

/* Predictor (forward Euler): x1 = x + h v, v1 = v + h a(x, v). Corrector: the mean of the
 * slopes at both ends. Pinned DOFs get zero force and keep zero velocity. */
static defsim_status heun_step(const defsim_host *host, defsim_system *sys, void *state, double h)
{
    heun_state *s = state;
    double *x = host->positions(sys), *v = host->velocities(sys);
    const double *m = host->mass(sys);
    const int64_t n = host->dof_count(sys);
    defsim_status st = host->forces(sys, x, v, DEFSIM_FORCE_ALL, s->f0);
    if (st != DEFSIM_OK) return st;
    for (int64_t i = 0; i < n; ++i) {
        s->x1[i] = x[i] + h * v[i];
        s->v1[i] = v[i] + h * s->f0[i] / m[i];
    }
    if ((st = host->forces(sys, s->x1, s->v1, DEFSIM_FORCE_ALL, s->f1)) != DEFSIM_OK) return st;
    for (int64_t i = 0; i < n; ++i) {
        x[i] += 0.5 * h * (v[i] + s->v1[i]);
        v[i] += 0.5 * h * (s->f0[i] + s->f1[i]) / m[i];
    }
    return DEFSIM_OK;
}

static void heun_fini(const defsim_host *host, defsim_system *sys, void *state)
{
    (void)sys;
    heun_state *s = state;
    host->release(s->f0);
    host->release(s->f1);
    host->release(s->x1);
    host->release(s->v1);
    memset(s, 0, sizeof *s);
}

static const defsim_backend heun = {
    .abi_version = DEFSIM_BACKEND_ABI_VERSION,
    .struct_size = sizeof(defsim_backend),
    .name = "heun",
    .state_size = sizeof(heun_state),
    .init = heun_init,
    .step = heun_step,
    .fini = heun_fini,
};

/* Runs the oscillator to t = 1 s with step h; returns |x(1) - A cos(omega)| or -1 on error. */
static double run(double h)
{
    defsim_world_def wd;
    defsim_world_def_init(&wd, sizeof wd);
    wd.backend = "heun";
    wd.gravity[1] = 0.0;
    defsim_world *w;
    if (defsim_world_create(&wd, &w) != DEFSIM_OK) return -1.0;
    /* Vertex 0 pinned at the origin, vertex 1 of mass 1 kg on a spring of rest length 1 m and
     * k = 100 N/m (omega = 10 rad/s), started 0.1 m stretched at rest. */
    const double rest[6] = {0, 0, 0, 1, 0, 0}, start[6] = {0, 0, 0, 1.1, 0, 0};
    const int32_t spring[2] = {0, 1};
    const double mass[2] = {1.0, 1.0};
    defsim_body_def bd;
    defsim_body_def_init(&bd, sizeof bd);
    bd.rest_positions = rest;
    bd.initial_positions = start;
    bd.vertex_count = 2;
    bd.springs = spring;
    bd.spring_count = 1;
    bd.vertex_mass = mass;
    defsim_material_init(&bd.material, sizeof bd.material, DEFSIM_MODEL_SPRING);
    bd.material.stiffness = 100.0;
    defsim_body_id id;
    const int32_t pin = 0;
    double x[6], err = -1.0;
    if (defsim_world_add_body(w, &bd, &id) == DEFSIM_OK && defsim_body_pin(w, id, &pin, 1) == 0) {
        const int steps = (int)lround(1.0 / h);
        int i = 0;
        while (i < steps && defsim_world_step(w, h) == DEFSIM_OK) ++i;
        if (i == steps && defsim_world_get_positions(w, x, 2) == DEFSIM_OK)
            err = fabs((x[3] - 1.0) - 0.1 * cos(10.0));
    }
    defsim_world_destroy(w);
    return err;
}

int main(void)
{
    if (defsim_register_backend(&heun) != DEFSIM_OK) {
        fprintf(stderr, "register: %s\n", defsim_last_error());
        return 1;
    }
    double prev = 0.0, ratio = 0.0;
    for (double h = 1e-2; h >= 1.25e-3; h /= 2) {
        const double e = run(h);
        if (e < 0.0) {
            fprintf(stderr, "the run with h = %g failed: %s\n", h, defsim_last_error());
            return 1;
        }
        if (prev > 0.0) ratio = prev / e;
        printf("h = %-8g error at t = 1 s: %.3e m%s", h, e, prev > 0.0 ? "" : "\n");
        if (prev > 0.0) printf("  (ratio %.2f, observed order %.2f)\n", ratio, log2(ratio));
        prev = e;
    }
    /* Second order: halving h divides the error by 4 (3.5 to 4.5 allowed). */
    return ratio > 3.5 && ratio < 4.5 ? 0 : 1;
}
