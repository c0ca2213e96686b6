/* SPDX-License-Identifier: MIT */
/*
 * What the two built-in Euler schemes share (explicit_euler, symplectic_euler): their state (one
 * force buffer), its init and fini, and the step, which differs only in the order of its two
 * updates, and the rows of their backend tables. Included by both backends' sources, each
 * compiled into libdefsim.
 */
#ifndef DEFSIM_EULER_COMMON_H
#define DEFSIM_EULER_COMMON_H

#include "defsim/backend.h"

typedef struct euler_state {
    double *f;
} euler_state;

static defsim_status euler_init(const defsim_host *host, defsim_system *sys, void *state)
{
    euler_state *s = state;
    s->f = host->alloc((size_t)host->dof_count(sys) * sizeof(double));
    return s->f ? DEFSIM_OK : DEFSIM_ERR_OUT_OF_MEMORY;
}

/* One step of h: the forces at (x, v), then x += h v and v += h M^-1 f, in that order (explicit)
 * or the other (symplectic: x moves with the new v). error: the message for non-finite forces. */
static defsim_status euler_step(const defsim_host *host, defsim_system *sys, void *state,
                                double h, int symplectic, const char *error)
{
    euler_state *s = state;
    double *x = host->positions(sys), *v = host->velocities(sys);
    const double *m = host->mass(sys);
    const int64_t n = host->dof_count(sys);
    defsim_status st = host->forces(sys, x, v, DEFSIM_FORCE_ALL, s->f);
    if (st != DEFSIM_OK) {
        host->set_error(sys, error);
        return st;
    }
    /* Pinned DOFs have zero force and zero velocity, so they stay put. */
    if (symplectic) {
        for (int64_t i = 0; i < n; ++i) {
            v[i] += h * s->f[i] / m[i];
            x[i] += h * v[i];
        }
    } else {
        for (int64_t i = 0; i < n; ++i) {
            x[i] += h * v[i];
            v[i] += h * s->f[i] / m[i];
        }
    }
    return DEFSIM_OK;
}

static void euler_fini(const defsim_host *host, defsim_system *sys, void *state)
{
    (void)sys;
    euler_state *s = state;
    host->release(s->f);
    s->f = 0;
}

/* The backend table of an Euler scheme: its name, flags, step and stable step. */
#define EULER_BACKEND(NAME, FLAGS, STEP, STABLE_STEP)                                           \
    {.abi_version = DEFSIM_BACKEND_ABI_VERSION, .struct_size = sizeof(defsim_backend),          \
     .name = NAME, .flags = FLAGS, .state_size = sizeof(euler_state), .init = euler_init,       \
     .step = STEP, .fini = euler_fini, .stable_step = STABLE_STEP}

#endif /* DEFSIM_EULER_COMMON_H */
