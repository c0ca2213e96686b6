/* SPDX-License-Identifier: MIT */
/*
 * What the two built-in Euler schemes share (explicit_euler, symplectic_euler): their state (one
 * force buffer), its init and fini, and the step, which differs only in the order of its two
 * updates, its reverse mode (adjoint step), and the rows of their backend tables. Included by
 * both backends' sources, each compiled into libdefsim.
 */
#ifndef DEFSIM_EULER_COMMON_H
#define DEFSIM_EULER_COMMON_H

#include "defsim/backend.h"

typedef struct euler_state {
    double *f;
    double *adj;    /* 3 DOF-long vectors of the adjoint step, made on its first call */
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

/* The reverse mode of euler_step (docs/gradients.md). With f = f(x0, v0) and a = av1 + h ax1
 * (symplectic: x1 = x0 + h v1) or a = av1 (explicit: x1 = x0 + h v0), v1 = v0 + h M^-1 f gives
 * the forces' adjoint w = h M^-1 a, and ax0 = ax1 + (df/dx)^T w, av0 = a + (df/dv)^T w (explicit:
 * + h ax1); the masses' through v1 - v0 = h M^-1 f: dL/dm_i = -a_i (v1 - v0)_i / m_i. At pinned
 * DOFs (defsim_adjoint_step) the forces see x0 and the pins' velocity v0: ax0 and av0 are what
 * their neighbours' forces carry, and the end position passes ax1 on (ap1). */
static defsim_status euler_adjoint_step(const defsim_host *host, defsim_system *sys, void *state,
                                        double h, const defsim_adjoint_step *ad, int symplectic)
{
    euler_state *s = state;
    const int64_t n = host->dof_count(sys);
    if (!s->adj && !(s->adj = host->alloc(3 * (size_t)(n > 0 ? n : 1) * sizeof(double))))
        return DEFSIM_ERR_OUT_OF_MEMORY;
    double *w = s->adj, *gx = s->adj + n, *gv = s->adj + 2 * n;
    const double *m = host->mass(sys);
    const int64_t *free = host->dof_to_free(sys);
    for (int64_t i = 0; i < n; ++i) {
        const double a = ad->av1[i] + (symplectic ? h * ad->ax1[i] : 0.0);
        w[i] = free[i] >= 0 ? h * a / m[i] : 0.0;
        gx[i] = gv[i] = 0.0;
        s->f[i] = free[i] >= 0 ? -a * (ad->v1[i] - ad->v0[i]) / m[i] : 0.0;
    }
    defsim_status st = host->forces_vjp(sys, ad->x0, ad->v0, DEFSIM_FORCE_ALL, w, gx, gv, 1);
    if (st != DEFSIM_OK) return st;
    host->mass_vjp(sys, s->f);
    for (int64_t i = 0; i < n; ++i) {
        if (free[i] < 0) {
            ad->ax0[i] = gx[i];
            ad->av0[i] = gv[i];
            ad->ap1[i] = ad->ax1[i];
            continue;
        }
        ad->ax0[i] = ad->ax1[i] + gx[i];
        const double a = ad->av1[i] + (symplectic ? h * ad->ax1[i] : 0.0);
        ad->av0[i] = a + gv[i] + (symplectic ? 0.0 : h * ad->ax1[i]);
    }
    return DEFSIM_OK;
}

static void euler_fini(const defsim_host *host, defsim_system *sys, void *state)
{
    (void)sys;
    euler_state *s = state;
    host->release(s->f);
    host->release(s->adj);
    s->f = 0;
    s->adj = 0;
}

/* The backend table of an Euler scheme: its name, flags, step and stable step. */
#define EULER_BACKEND(NAME, FLAGS, STEP, STABLE_STEP, ADJOINT)                                  \
    {.abi_version = DEFSIM_BACKEND_ABI_VERSION, .struct_size = sizeof(defsim_backend),          \
     .name = NAME, .flags = FLAGS, .state_size = sizeof(euler_state), .init = euler_init,       \
     .step = STEP, .fini = euler_fini, .stable_step = STABLE_STEP, .adjoint_step = ADJOINT}

#endif /* DEFSIM_EULER_COMMON_H */
