/* SPDX-License-Identifier: MIT */
/* A tiny loadable backend for the module tests: symplectic Euler written against the host
 * table only (it links nothing of defsim), plus a reset counter, and one option and one counter
 * by name (ABI version 2): velocities are divided by 1 + h damping after each step. */
#include <defsim/backend.h>

typedef struct tm_state {
    double *f;
    int resets;
    double damping;   /* 1/s, the option read at init */
} tm_state;

static const defsim_option_spec tm_options[1] = {
    {"damping", DEFSIM_OPTION_REAL, 0.0, 0.0, 1e6, NULL,
     "velocity damping rate (1/s): v /= 1 + h damping after each step"}};
static const defsim_counter_spec tm_counters[1] = {{"steps", "steps taken"}};

static const defsim_host *host_seen;

static defsim_status tm_init(const defsim_host *host, defsim_system *sys, void *state)
{
    tm_state *s = state;
    s->damping = host->option_values(sys)[0];
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
    if (s->damping > 0.0)
        for (int64_t i = 0; i < host->dof_count(sys); ++i) v[i] /= 1.0 + h * s->damping;
    host->counters(sys)[0] += 1.0;
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
    .options = tm_options,
    .option_count = 1,
    .counters = tm_counters,
    .counter_count = 1,
};

__attribute__((visibility("default"))) defsim_status defsim_module_init(
    const defsim_host *host, const defsim_backend **out)
{
    if (!host || host->abi_version < 2) return DEFSIM_ERR_BACKEND_UNAVAILABLE;
    host_seen = host;
    *out = &tm_backend;
    return DEFSIM_OK;
}
