/* SPDX-License-Identifier: MIT */
/* Explicit (forward) Euler: x' = x + h v, v' = v + h M^-1 f(x, v). Built in. */
#include "defsim/backend.h"

#include <math.h>

typedef struct ee_state {
    double *f;
} ee_state;

static defsim_status ee_init(const defsim_host *host, defsim_system *sys, void *state)
{
    ee_state *s = state;
    s->f = host->alloc((size_t)host->dof_count(sys) * sizeof(double));
    return s->f ? DEFSIM_OK : DEFSIM_ERR_OUT_OF_MEMORY;
}

static defsim_status ee_step(const defsim_host *host, defsim_system *sys, void *state, double h)
{
    ee_state *s = state;
    double *x = host->positions(sys), *v = host->velocities(sys);
    const double *m = host->mass(sys);
    const int64_t n = host->dof_count(sys);
    defsim_status st = host->forces(sys, x, v, DEFSIM_FORCE_ALL, s->f);
    if (st != DEFSIM_OK) {
        host->set_error(sys, "explicit_euler: non-finite forces");
        return st;
    }
    /* Pinned DOFs have zero force and zero velocity, so they stay put. */
    for (int64_t i = 0; i < n; ++i) {
        x[i] += h * v[i];
        v[i] += h * s->f[i] / m[i];
    }
    return DEFSIM_OK;
}

static void ee_fini(const defsim_host *host, defsim_system *sys, void *state)
{
    (void)sys;
    ee_state *s = state;
    host->release(s->f);
    s->f = 0;
}

/* Amplification |1 + h lambda| <= 1 for lambda = -c/2 +- i sqrt(omega^2 - c^2/4) gives
 * h <= c / omega^2 (underdamped); overdamped modes need h <= 2 / |lambda_max|. */
static double ee_stable_step(double omega, double c)
{
    if (!(omega > 0.0)) return c > 0.0 ? 2.0 / c : 1e300;
    if (c < 2.0 * omega) return c / (omega * omega);
    double lam = 0.5 * (c + sqrt(c * c - 4.0 * omega * omega));
    return 2.0 / lam;
}

const defsim_backend defsim__explicit_euler_backend = {
    .abi_version = DEFSIM_BACKEND_ABI_VERSION,
    .struct_size = sizeof(defsim_backend),
    .name = "explicit_euler",
    .flags = 0,
    .state_size = sizeof(ee_state),
    .init = ee_init,
    .step = ee_step,
    .fini = ee_fini,
    .reset = 0,
    .stable_step = ee_stable_step,
};
