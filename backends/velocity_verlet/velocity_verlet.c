/* SPDX-License-Identifier: MIT */
/*
 * Velocity Verlet (kick-drift-kick leapfrog) with one force evaluation per step. Built in.
 *
 *   v+ = v_n + h/2 M^-1 F_n,   x_{n+1} = x_n + h v+,
 *   w  = v_n + h M^-1 F_n      (velocity prediction, O(h^2) accurate),
 *   F_{n+1} = f(x_{n+1}, w),   v_{n+1} = v+ + h/2 M^-1 F_{n+1}.
 *
 * F is carried from one step to the next; set_state, pins and bodies (init), and failed steps
 * (reset) invalidate it, and the next step evaluates f(x_n, v_n) first. Damping forces, linear in
 * v, see the prediction w instead of the unknown v_{n+1}: the error is O(h^2) in a force that is
 * multiplied by h, so the method stays second order. README.md beside this file has the analysis.
 * Driven pins: F_{n+1} is evaluated with them at their end-of-step positions and at time
 * t_n + h; a carried F is not reused when their velocities change (it damped with the old ones).
 */
#include "defsim/backend.h"

#include <math.h>

typedef struct vv_state {
    double *f;      /* F_n = f(x_n, w_n), valid if `carried` */
    double *w;      /* velocity prediction */
    int carried;
    int coupled;    /* the host has the coupling services (forces_at, pin_positions, ...) */
    int drove;      /* the last step drove pins */
} vv_state;

static defsim_status vv_init(const defsim_host *host, defsim_system *sys, void *state)
{
    vv_state *s = state;
    const size_t bytes = (size_t)host->dof_count(sys) * sizeof(double);
    s->f = host->alloc(bytes);
    s->w = host->alloc(bytes);
    s->carried = 0;
    s->coupled = host->size >= offsetof(defsim_host, applied_forces_vary) +
                                   sizeof host->applied_forces_vary;
    return s->f && s->w ? DEFSIM_OK : DEFSIM_ERR_OUT_OF_MEMORY;
}

static defsim_status vv_reset(const defsim_host *host, defsim_system *sys, void *state)
{
    (void)host;
    (void)sys;
    ((vv_state *)state)->carried = 0;
    return DEFSIM_OK;
}

static defsim_status vv_step(const defsim_host *host, defsim_system *sys, void *state, double h)
{
    vv_state *s = state;
    double *x = host->positions(sys), *v = host->velocities(sys);
    const double *m = host->mass(sys);
    const int64_t n = host->dof_count(sys);
    defsim_status st = DEFSIM_OK;
    const double *pv = s->coupled ? host->pin_velocities(sys) : NULL;
    if (pv || s->drove) s->carried = 0;
    s->drove = pv != NULL;
    if (!s->carried) {
        st = host->forces(sys, x, v, DEFSIM_FORCE_ALL, s->f);
        host->counters(sys)[0] += 1.0;
    }
    s->carried = 0;   /* until this step has evaluated F_{n+1} */
    if (st != DEFSIM_OK) {
        host->set_error(sys, "velocity_verlet: non-finite forces");
        return st;
    }
    /* Pinned DOFs have zero force: they move with their velocity (zero unless driven). */
    for (int64_t i = 0; i < n; ++i) {
        const double a = s->f[i] / m[i];
        s->w[i] = v[i] + h * a;
        v[i] += 0.5 * h * a;
        x[i] += h * v[i];
    }
    if (s->coupled) {
        const double t1 = host->time(sys) + h;
        if (pv) host->pin_positions(sys, t1, x);
        st = host->forces_at(sys, x, s->w, t1, DEFSIM_FORCE_ALL, s->f);
    } else {
        st = host->forces(sys, x, s->w, DEFSIM_FORCE_ALL, s->f);
    }
    if (st != DEFSIM_OK) {
        host->set_error(sys, "velocity_verlet: non-finite forces");
        return st;
    }
    for (int64_t i = 0; i < n; ++i) v[i] += 0.5 * h * s->f[i] / m[i];
    s->carried = 1;
    return DEFSIM_OK;
}

static void vv_fini(const defsim_host *host, defsim_system *sys, void *state)
{
    (void)sys;
    vv_state *s = state;
    host->release(s->f);
    host->release(s->w);
    s->f = s->w = 0;
    s->carried = 0;
}

/* History: the carried force F_n (when valid) and whether the last step drove pins. */
static defsim_status vv_save(const defsim_host *host, defsim_system *sys, const void *state,
                             const defsim_state_writer *wr)
{
    const vv_state *s = state;
    const int64_t flags[2] = {s->carried, s->drove};
    defsim_status st = wr->i64(wr->ctx, flags, 2);
    if (st == DEFSIM_OK && s->carried) st = wr->f64(wr->ctx, s->f, host->dof_count(sys));
    return st;
}

static defsim_status vv_load(const defsim_host *host, defsim_system *sys, void *state,
                             const defsim_state_reader *rd)
{
    vv_state *s = state;
    int64_t flags[2];
    defsim_status st = rd->i64(rd->ctx, flags, 2);
    if (st != DEFSIM_OK) return st;
    if ((flags[0] != 0 && flags[0] != 1) || (flags[1] != 0 && flags[1] != 1)) return DEFSIM_ERR_IO;
    if (flags[0] && (st = rd->f64(rd->ctx, s->f, host->dof_count(sys))) != DEFSIM_OK) return st;
    s->carried = (int)flags[0];
    s->drove = (int)flags[1];
    return DEFSIM_OK;
}

/* For x'' = -omega^2 x - c x' the step is linear in (x, v, w) with characteristic polynomial
 * z^3 + (h^2 omega^2 + 3/2 c h - 2) z^2 + (1 - 2 c h) z + c h / 2; by Jury's test all roots lie
 * in the unit disc iff h^2 omega^2 + 4 c h < 4, i.e. h < 2 / (c + sqrt(c^2 + omega^2)). */
static double vv_stable_step(double omega, double c)
{
    const double d = c + sqrt(c * c + omega * omega);
    return d > 0.0 ? 2.0 / d : 1e300;
}

static const defsim_counter_spec vv_counters[1] = {
    {"force_restarts", "steps that evaluated f(x_n, v_n) first because no carried force was "
                       "valid (the first step, after set_state, pins, bodies or a failed step)"},
};

const defsim_backend defsim__velocity_verlet_backend = {
    .abi_version = DEFSIM_BACKEND_ABI_VERSION, .struct_size = sizeof(defsim_backend),
    .name = "velocity_verlet", .flags = DEFSIM_BACKEND_CONSERVATIVE,
    .state_size = sizeof(vv_state), .init = vv_init, .step = vv_step, .fini = vv_fini,
    .reset = vv_reset, .stable_step = vv_stable_step, .counters = vv_counters, .counter_count = 1,
    .save_state = vv_save, .load_state = vv_load};
