/* SPDX-License-Identifier: MIT */
/* A tiny loadable backend for the module tests: symplectic Euler written against the host
 * table only (it links nothing of defsim), plus a reset counter. */
#include <defsim/backend.h>

typedef struct tm_state {
    double *f;
    int resets;
} tm_state;

static const defsim_host *host_seen;

static defsim_status tm_init(const defsim_host *host, defsim_system *sys, void *state)
{
    tm_state *s = state;
    s->f = host->alloc((size_t)host->dof_count(sys) * sizeof(double));
    return s->f ? DEFSIM_OK : DEFSIM_ERR_OUT_OF_MEMORY;
}

static defsim_status tm_step(const defsim_host *host, defsim_system *sys, void *state, double h)
{
    tm_state *s = state;
    double *x = host->positions(sys), *v = host->velocities(sys);
    const double *m = host->mass(sys);
    defsim_status st = host->forces(sys, x, v, DEFSIM_FORCE_ALL, s->f);
    if (st != DEFSIM_OK) return st;
    for (int64_t i = 0; i < host->dof_count(sys); ++i) {
        v[i] += h * s->f[i] / m[i];
        x[i] += h * v[i];
    }
    host->stats(sys)->internal_steps += 1;
    return DEFSIM_OK;
}

static void tm_fini(const defsim_host *host, defsim_system *sys, void *state)
{
    (void)sys;
    tm_state *s = state;
    host->release(s->f);
    s->f = 0;
}

static defsim_status tm_reset(const defsim_host *host, defsim_system *sys, void *state)
{
    (void)host;
    (void)sys;
    ((tm_state *)state)->resets++;
    return DEFSIM_OK;
}

static const defsim_backend tm_backend = {
    .abi_version = DEFSIM_BACKEND_ABI_VERSION,
    .struct_size = sizeof(defsim_backend),
    .name = "testmod",
    .flags = 0,
    .state_size = sizeof(tm_state),
    .init = tm_init,
    .step = tm_step,
    .fini = tm_fini,
    .reset = tm_reset,
};

__attribute__((visibility("default"))) defsim_status defsim_module_init(
    const defsim_host *host, const defsim_backend **out)
{
    if (!host || host->abi_version < 1) return DEFSIM_ERR_BACKEND_UNAVAILABLE;
    host_seen = host;
    *out = &tm_backend;
    return DEFSIM_OK;
}
