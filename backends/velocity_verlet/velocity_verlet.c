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
#include <string.h>

typedef struct vv_state {
    double *f;      /* F_n = f(x_n, w_n), valid if `carried` */
    double *w;      /* velocity prediction */
    int carried;
    int coupled;    /* the host has the coupling services (forces_at, pin_positions, ...) */
    int drove;      /* the last step drove pins */
    double *adj;    /* the adjoint step's 6 DOF-long vectors, made on its first call */
} vv_state;

static defsim_status vv_init(const defsim_host *host, defsim_system *sys, void *state)
{
    vv_state *s = state;
    const size_t bytes = (size_t)host->dof_count(sys) * sizeof(double);
    s->f = host->alloc(bytes);
    s->w = host->alloc(bytes);
    s->carried = 0;
    s->adj = NULL;
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
    host->release(s->adj);
    s->f = s->w = s->adj = 0;
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

/* The discrete adjoint of vv_step (docs/gradients.md). The step maps (x0, v0, F0) to (x1, v1,
 * F1), with a0 = F0/m, w = v0 + h a0, x1 = x0 + h (v0 + h/2 a0), F1 = f(x1, w) and
 * v1 = v0 + h/2 (a0 + F1/m); F0 = f(x0, v0) when the step started without a carried force (the
 * first recorded step, after a failed step, or when this or the previous step drove pins),
 * else the previous step's F1. Pinned DOFs: F1 sees their end positions (ap1) and w their
 * velocity (av0), F0 at a restart their start (ax0) and velocity. a0, w and F1/m come back
 * from the states: a0 = 2 (x1 - x0 - h v0) / h^2, w = v0 + h a0, F1/m = 2 (v1 - v0)/h - a0
 * (free DOFs). With the adjoint aF1 of F1 that
 * the next step carried back (0 on the first call), g = aF1 + h/2 av1/m weighs the forces at
 * (x1, w): ax1' = ax1 + (df/dx)^T g, and then ax0 = ax1', av0 = av1 + h ax1' + (df/dv)^T g and
 * the adjoint of F0, (h/2 (av1 + h ax1') + h (df/dv)^T g)/m, which goes to the previous call or,
 * at a restart, through the forces at (x0, v0). The masses': -aF0 a0 - h/2 av1 F1/m^2. */
static defsim_status vv_adjoint_step(const defsim_host *host, defsim_system *sys, void *state,
                                     double h, const defsim_adjoint_step *ad)
{
    vv_state *s = state;
    const int64_t n = host->dof_count(sys);
    if (!s->adj && !(s->adj = host->alloc(6 * (size_t)(n > 0 ? n : 1) * sizeof(double))))
        return DEFSIM_ERR_OUT_OF_MEMORY;
    double *carry = s->adj, *g = carry + n, *gx = g + n, *gw = gx + n, *w = gw + n, *mw = w + n;
    const double *m = host->mass(sys);
    const int64_t *free = host->dof_to_free(sys);
    const int restart = !ad->x_prev || ad->drives || ad->prev_drove;
    if (ad->first) memset(carry, 0, (size_t)n * sizeof *carry);
    for (int64_t i = 0; i < n; ++i) {
        gx[i] = gw[i] = 0.0;
        if (free[i] < 0) {
            g[i] = mw[i] = 0.0;
            w[i] = ad->v0[i];
            continue;
        }
        const double a0 = 2.0 * (ad->x1[i] - ad->x0[i] - h * ad->v0[i]) / (h * h);
        const double a1 = 2.0 * (ad->v1[i] - ad->v0[i]) / h - a0;
        w[i] = ad->v0[i] + h * a0;
        g[i] = carry[i] + 0.5 * h * ad->av1[i] / m[i];
        mw[i] = -0.5 * h * ad->av1[i] * a1 / m[i];
    }
    defsim_status st = host->forces_vjp(sys, ad->x1, w, DEFSIM_FORCE_ALL, g, gx, gw, 1);
    if (st != DEFSIM_OK) return st;
    for (int64_t i = 0; i < n; ++i) {
        const double ax = ad->ax1[i] + gx[i];
        if (free[i] < 0) {
            /* a pin: the forces at x1 see its end position, w its velocity */
            ad->ap1[i] = ax;
            ad->ax0[i] = 0.0;
            ad->av0[i] = gw[i];
            carry[i] = 0.0;
            continue;
        }
        ad->ax0[i] = ax;
        const double avh = ad->av1[i] + h * ax;
        const double a0 = 2.0 * (ad->x1[i] - ad->x0[i] - h * ad->v0[i]) / (h * h);
        ad->av0[i] = avh + gw[i];
        carry[i] = (0.5 * h * avh + h * gw[i]) / m[i];   /* the adjoint of F0 */
        mw[i] -= carry[i] * a0;
    }
    host->mass_vjp(sys, mw);
    if (!restart) return DEFSIM_OK;   /* F0 was the previous step's F1: its adjoint waits */
    memset(gx, 0, (size_t)n * sizeof *gx);
    memset(gw, 0, (size_t)n * sizeof *gw);
    st = host->forces_vjp(sys, ad->x0, ad->v0, DEFSIM_FORCE_ALL, carry, gx, gw, 1);
    if (st != DEFSIM_OK) return st;
    for (int64_t i = 0; i < n; ++i) {
        ad->ax0[i] += gx[i];
        ad->av0[i] += gw[i];
        carry[i] = 0.0;
    }
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
    .name = "velocity_verlet",
    .flags = DEFSIM_BACKEND_CONSERVATIVE | DEFSIM_BACKEND_ADJOINT_HISTORY,
    .state_size = sizeof(vv_state), .init = vv_init, .step = vv_step, .fini = vv_fini,
    .reset = vv_reset, .stable_step = vv_stable_step, .counters = vv_counters, .counter_count = 1,
    .save_state = vv_save, .load_state = vv_load, .adjoint_step = vv_adjoint_step};
