/* SPDX-License-Identifier: MIT */
/* Symplectic (semi-implicit) Euler: v' = v + h M^-1 f(x, v), then x' = x + h v'. Built in. */
#include "defsim/backend.h"

#include <math.h>

typedef struct se_state {
    double *f;
} se_state;

static defsim_status se_init(const defsim_host *host, defsim_system *sys, void *state)
{
    se_state *s = state;
    s->f = host->alloc((size_t)host->dof_count(sys) * sizeof(double));
    return s->f ? DEFSIM_OK : DEFSIM_ERR_OUT_OF_MEMORY;
}

static defsim_status se_step(const defsim_host *host, defsim_system *sys, void *state, double h)
{
    se_state *s = state;
    double *x = host->positions(sys), *v = host->velocities(sys);
    const double *m = host->mass(sys);
    const int64_t n = host->dof_count(sys);
    defsim_status st = host->forces(sys, x, v, DEFSIM_FORCE_ALL, s->f);
    if (st != DEFSIM_OK) {
        host->set_error(sys, "symplectic_euler: non-finite forces");
        return st;
    }
    /* Pinned DOFs have zero force and zero velocity, so they stay put. */
    for (int64_t i = 0; i < n; ++i) {
        v[i] += h * s->f[i] / m[i];
        x[i] += h * v[i];
    }
    return DEFSIM_OK;
}

static void se_fini(const defsim_host *host, defsim_system *sys, void *state)
{
    (void)sys;
    se_state *s = state;
    host->release(s->f);
    s->f = 0;
}

/* For x'' = -omega^2 x - c x' the step matrix has determinant 1 - h c and trace
 * 2 - h c - h^2 omega^2; both roots lie in the unit disc iff h c <= 2 and
 * h^2 omega^2 + 2 h c <= 4. */
static double se_stable_step(double omega, double c)
{
    if (!(omega > 0.0)) return c > 0.0 ? 2.0 / c : 1e300;
    double h = (-c + sqrt(c * c + 4.0 * omega * omega)) / (omega * omega);
    return c > 0.0 && 2.0 / c < h ? 2.0 / c : h;
}

const defsim_backend defsim__symplectic_euler_backend = {
    .abi_version = DEFSIM_BACKEND_ABI_VERSION,
    .struct_size = sizeof(defsim_backend),
    .name = "symplectic_euler",
    .flags = DEFSIM_BACKEND_CONSERVATIVE,
    .state_size = sizeof(se_state),
    .init = se_init,
    .step = se_step,
    .fini = se_fini,
    .reset = 0,
    .stable_step = se_stable_step,
};
