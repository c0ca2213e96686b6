/* SPDX-License-Identifier: MIT */
/* The table of host services that every backend receives (backend.h): the compiled system's
 * physics (loops over its terms, term.h), the calls of the host's force callback (its term,
 * term_callback.c, makes them) and driven pins, plus the counting and timing of statistics. */
#include "host.h"

#include "adjoint.h"

#include "assembly.h"
#include "body_contact.h"
#include "clock.h"
#include "contact.h"
#include "energy.h"
#include "forces.h"
#include "mat3.h"
#include "stability.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

/* ------------------------------------------------------------------------------------------ */
/* Services */

static int64_t dof_count(const defsim_system *s) { return 3 * (int64_t)s->sys->nv; }
static int64_t free_dof_count(const defsim_system *s) { return s->sys->nfree; }
static const int64_t *free_dofs(const defsim_system *s) { return s->sys->free_dofs; }
static const int64_t *dof_to_free(const defsim_system *s) { return s->sys->dof_to_free; }
static double *positions(defsim_system *s) { return s->state->x; }
static double *velocities(defsim_system *s) { return s->state->v; }
/* The start of the backend's step: with auto_substep, of the substep. */
static double sys_time(const defsim_system *s)
{
    return s->cpl->in_step ? s->cpl->t0 : s->state->t;
}
static const double *mass(const defsim_system *s) { return s->sys->mass3; }
static const double *mass_damping(const defsim_system *s) { return s->sys->alpha3; }
static int has_stiffness_damping(const defsim_system *s)
{
    return s->sys->has_stiffness_damping || s->sys->has_attachment_damping;
}

defsim_status defsim__host_forces(defsim_system *s, const double *x, const double *v, double t,
                                  uint32_t which, double *f)
{
    const uint32_t keep = which & DEFSIM__FORCE_KEEP_PINNED;
    return defsim__forces_at(s->sys, x, v, t, (which & DEFSIM_FORCE_ALL) | keep, f, s->passes);
}

static defsim_status forces_at(defsim_system *s, const double *x, const double *v, double t,
                               uint32_t which, double *f)
{
    if (!x || !f || ((which & DEFSIM_FORCE_DAMPING) && !v)) return DEFSIM_ERR_INVALID_ARGUMENT;
    const double t0 = defsim__now();
    defsim_status st = defsim__host_forces(s, x, v, t, which & DEFSIM_FORCE_ALL, f);
    s->stats->force_evals++;
    s->stats->time_forces += defsim__now() - t0;
    return st;
}

/* Without a time, the callback sees the time that the backend's kind evaluates forces at:
 * the start of the step (explicit), its end (implicit). */
static defsim_status forces(defsim_system *s, const double *x, const double *v, uint32_t which,
                            double *f)
{
    const defsim__coupling *c = s->cpl;
    const double t = c->in_step ? c->t0 + (c->implicit ? c->h : 0.0) : s->state->t;
    return forces_at(s, x, v, t, which, f);
}

static double potential_energy(defsim_system *s, const double *x)
{
    const double e = defsim__potential_energy(s->sys, s->work, x);
    s->stats->energy_evals++;
    *s->passes |= DEFSIM_PASS_ENERGY;
    return e;
}

static void pin_positions(const defsim_system *s, double t, double *x)
{
    const defsim__coupling *c = s->cpl;
    if (c->ndrv == 0) return;
    if (t >= c->t0 + c->h) {
        for (int64_t k = 0; k < c->ndrv; ++k) x[c->drv[k]] = c->drv_x1[k];
        return;
    }
    const double r = t > c->t0 ? (t - c->t0) / c->h : 0.0;
    for (int64_t k = 0; k < c->ndrv; ++k)
        x[c->drv[k]] = c->drv_x0[k] + r * (c->drv_x1[k] - c->drv_x0[k]);
}

static const double *pin_velocities(const defsim_system *s)
{
    return s->cpl->ndrv > 0 ? s->cpl->pin_vel : NULL;
}

static int applied_forces_vary(const defsim_system *s)
{
    const defsim__coupling *c = s->cpl;
    return c->jac != NULL && c->in_step && c->implicit;
}

/* Backends that do not declare DEFSIM_BACKEND_NEEDS_MATRIX get the pattern on first use. */
static defsim_status ensure_pattern(defsim_system *s)
{
    defsim_status st = defsim__pattern_build(s->sys);
    if (st != DEFSIM_OK) defsim__error(s->msg, "out of memory building the matrix pattern");
    return st;
}

static defsim_status matrix_pattern(defsim_system *s, defsim_triangle tri, defsim_csc *out)
{
    defsim_status st = ensure_pattern(s);
    return st != DEFSIM_OK ? st : defsim__matrix_pattern(s->sys, tri, out);
}

static defsim_status matrix_values(defsim_system *s, const double *x,
                                   const defsim_matrix_coeffs *c, defsim_triangle tri,
                                   double *values)
{
    defsim_status st = ensure_pattern(s);
    if (st != DEFSIM_OK) return st;
    const double t0 = defsim__now();
    st = defsim__matrix_values(s->sys, x, c, tri, values, s->passes);
    if (st != DEFSIM_OK) return st;
    s->stats->hessian_evals++;
    s->stats->time_hessian += defsim__now() - t0;
    return DEFSIM_OK;
}

/* matrix_values with the element Hessians under `projection` instead of the world's (the
 * system's setting is swapped for the call: a world is stepped by one thread at a time). */
static defsim_status matrix_values_projected(defsim_system *s, const double *x,
                                             const defsim_matrix_coeffs *c, defsim_triangle tri,
                                             int32_t projection, double *values)
{
    if (projection < DEFSIM_PROJECTION_NONE || projection > DEFSIM_PROJECTION_ABS)
        return DEFSIM_ERR_INVALID_ARGUMENT;
    const int world = s->sys->projection;
    /* A backward pass's exact matrix (docs/gradients.md) holds contact's exact Hessians too;
     * the contact caches then hold them, and are dropped after. */
    const int exact = projection == DEFSIM_PROJECTION_NONE && s->grad;
    s->sys->projection = projection;
    s->sys->exact_contact = exact;
    const defsim_status st = matrix_values(s, x, c, tri, values);
    s->sys->projection = world;
    s->sys->exact_contact = 0;
    for (int k = 0; exact && k < DEFSIM__TERM_KINDS; ++k) s->sys->cache[k].valid = 0;
    return st;
}

static defsim_status matrix_product(defsim_system *s, const double *x,
                                    const defsim_matrix_coeffs *c, const double *dx, double *out)
{
    return defsim__matrix_product(s->sys, x, c, dx, out);
}

static void gravity(const defsim_system *s, double g[3])
{
    for (int k = 0; k < 3; ++k) g[k] = s->gravity[k];
}
static int32_t num_threads(const defsim_system *s) { return s->sys->nthreads; }
static double length_scale(const defsim_system *s) { return s->sys->length_scale; }
static defsim_stats *stats(defsim_system *s) { return s->stats; }

static void log_message(defsim_system *s, int level, const char *message)
{
    defsim__log(s->msg, level, "%s", message ? message : "");
}

static void set_error(defsim_system *s, const char *message)
{
    defsim__error(s->msg, "%s", message ? message : "");
}

static const double *option_values(const defsim_system *s)
{
    return defsim__options_values(s->options);
}
static double *counters(defsim_system *s) { return defsim__options_counters(s->options); }

static int32_t option_is_set(const defsim_system *s, int32_t index)
{
    return defsim__options_is_set(s->options, index);
}

static defsim_status omega_max(defsim_system *s, const double *x, double *omega, double *damping)
{
    if (!x || !omega || !damping) return DEFSIM_ERR_INVALID_ARGUMENT;
    const defsim_status st = defsim__omega_max(s->sys, s->work, x, omega);
    *damping = st == DEFSIM_OK ? defsim__damping_coeff(s->sys, x, *omega) : 0.0;
    return st;
}

/* The terms' CCD and feasible start (contact's, for barrier steps; elsewhere they change
 * nothing). */
static double contact_max_step(defsim_system *s, const double *x, const double *dx)
{
    if (!x || !dx) return 1.0;
    const defsim__system *sys = s->sys;
    double alpha = 1.0;
    for (int32_t k = 0; k < sys->nterms && alpha > 0.0; ++k) {
        const defsim__term *t = &sys->terms[k];
        if (!t->ops->max_step) continue;
        const double a = t->ops->max_step(t, x, dx);
        if (a < alpha) alpha = a;
    }
    return alpha;
}

/* In list order: body contact's start comes last, feasible for the bodies whatever the
 * colliders moved. */
static void contact_start(defsim_system *s, double *x)
{
    if (!x) return;
    const defsim__system *sys = s->sys;
    const defsim__term *st[DEFSIM__TERM_MAX];
    int n = 0;
    for (int32_t k = 0; k < sys->nterms; ++k)
        if (sys->terms[k].ops->start) st[n++] = &sys->terms[k];
    /* A term's start keeps the path from the step's start clear for it, which a later term's
     * cut back towards that start keeps too, except where the term asks to run again (a
     * collider carried a vertex): then the terms run in turn until one leaves x as the one
     * before it left it (every term has then accepted x), at most three rounds. */
    int again = 0, redo = 0;
    for (int i = 0; i < n; ++i) {
        const int r = st[i]->ops->start(st[i], x);
        if (again && (r & DEFSIM__START_MOVED)) redo = 1;
        again |= r & DEFSIM__START_AGAIN;
    }
    if (!redo) return;
    int quiet = 0;
    for (int round = 0; round < 3; ++round)
        for (int i = 0; i < n; ++i) {
            quiet = st[i]->ops->start(st[i], x) & DEFSIM__START_MOVED ? 0 : quiet + 1;
            if (quiet >= n - 1) return;
        }
    for (int i = 0; i < n; ++i)
        if (st[i]->ops->block) st[i]->ops->block(st[i]);
}

static uint64_t matrix_pattern_version(defsim_system *s)
{
    for (int32_t k = 0; k < s->sys->nterms; ++k) {
        const defsim__term *t = &s->sys->terms[k];
        if (!t->ops->pattern_update) continue;
        int grew = 0;
        if (t->ops->pattern_update(t, s->sys, &grew) != DEFSIM_OK) {
            defsim__error(s->msg, "out of memory growing the matrix pattern for %s",
                          t->ops->name);
            return 0;
        }
    }
    return s->sys->pattern.version;
}

/* Contact at the latest Hessian: only contact kinds fill a linearisation cache, so a valid cache
 * that holds a non-zero block is a contact constraint active there. Reads the caches and the
 * contact states' dhat; evaluates nothing. */
static double contact_active_dhat(defsim_system *s)
{
    const defsim__system *sys = s->sys;
    int active = 0;
    for (int32_t k = 0; k < sys->nterms; ++k) {
        const defsim__term_cache *c = sys->terms[k].cache;
        if (c && c->valid && c->any) active = 1;
    }
    if (!active) return 0.0;
    double dhat = INFINITY;
    if (sys->contact && sys->contact->mode == DEFSIM__CONTACT_BARRIER) dhat = sys->contact->dhat;
    if (sys->body_contact && sys->body_contact->active) dhat = fmin(dhat, sys->body_contact->dhat);
    return isfinite(dhat) && dhat > 0.0 ? dhat : 0.0;
}

/* Reverse mode (tape.c sets s->grad for a backward pass). */
static defsim_status forces_vjp(defsim_system *s, const double *x, const double *v,
                                uint32_t which, const double *w, double *gx, double *gv,
                                int32_t accumulate)
{
    if (!s->grad || !x || !w || ((which & DEFSIM_FORCE_DAMPING) && !v)) {
        defsim__error(s->msg, "forces_vjp: %s", !s->grad ? "called outside a backward pass"
                                                         : "x, w or v is NULL");
        return DEFSIM_ERR_INVALID_ARGUMENT;
    }
    const defsim_status st = defsim__forces_vjp(s->sys, x, v, which, w, gx, gv, s->grad,
                                                accumulate != 0);
    if (st != DEFSIM_OK) defsim__error(s->msg, "forces_vjp: a result is not finite");
    return st;
}

static void mass_vjp(defsim_system *s, const double *mw)
{
    if (!s->grad || !mw) return;
    for (int64_t i = 0; i < 3 * (int64_t)s->sys->nv; ++i) s->grad->mass[i / 3] += mw[i];
}

static void *alloc(size_t bytes) { return malloc(bytes); }
static void release(void *p) { free(p); }

const defsim_host defsim__host = {
    .abi_version = DEFSIM_BACKEND_ABI_VERSION,
    .size = sizeof(defsim_host),
    .dof_count = dof_count,
    .free_dof_count = free_dof_count,
    .free_dofs = free_dofs,
    .dof_to_free = dof_to_free,
    .positions = positions,
    .velocities = velocities,
    .time = sys_time,
    .mass = mass,
    .mass_damping = mass_damping,
    .has_stiffness_damping = has_stiffness_damping,
    .forces = forces,
    .potential_energy = potential_energy,
    .matrix_pattern = matrix_pattern,
    .matrix_values = matrix_values,
    .matrix_product = matrix_product,
    .gravity = gravity,
    .num_threads = num_threads,
    .length_scale = length_scale,
    .stats = stats,
    .wall_time = defsim__now,
    .log = log_message,
    .set_error = set_error,
    .alloc = alloc,
    .release = release,
    .option_values = option_values,
    .counters = counters,
    .omega_max = omega_max,
    .forces_at = forces_at,
    .pin_positions = pin_positions,
    .pin_velocities = pin_velocities,
    .applied_forces_vary = applied_forces_vary,
    .contact_max_step = contact_max_step,
    .contact_start = contact_start,
    .matrix_pattern_version = matrix_pattern_version,
    .option_is_set = option_is_set,
    .contact_active_dhat = contact_active_dhat,
    .matrix_values_projected = matrix_values_projected,
    .forces_vjp = forces_vjp,
    .mass_vjp = mass_vjp,
};
