/* SPDX-License-Identifier: MIT */
/* The table of host services that every backend receives (backend.h): the compiled system's
 * physics, the host's force callback and driven pins, plus the counting and timing of
 * statistics. */
#include "host.h"

#include "assembly.h"
#include "clock.h"
#include "body_contact.h"
#include "contact.h"
#include "energy.h"
#include "forces.h"
#include "mat3.h"
#include "stability.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

/* ------------------------------------------------------------------------------------------ */
/* The host's force callback */

static int64_t first_non_finite(const double *a, int64_t n)
{
    for (int64_t i = 0; i < n; ++i)
        if (!isfinite(a[i])) return i;
    return -1;
}

/* Calls the callback (jac: the Jacobian, writing `width` doubles per vertex into out; else the
 * forces, adding 3 per vertex) with the world locked, and checks what it returned and wrote. */
static defsim_status call_host(defsim__coupling *c, defsim__messages *msg, int32_t nv, int jac,
                               const double *x, const double *v, double t, double *out)
{
    const char *what = jac ? "force Jacobian callback" : "force callback";
    const int width = jac ? 9 : 3;
    msg->locked++;
    const int rc = jac ? c->jac(c->user, x, v, t, nv, out) : c->fn(c->user, x, v, t, nv, out);
    msg->locked--;
    const int64_t bad = rc != 0 ? -1 : first_non_finite(out, width * (int64_t)nv);
    if (rc == 0 && bad < 0) return DEFSIM_OK;
    c->failed = 1;
    if (rc != 0) defsim__error(msg, "%s failed (returned %d at t = %g)", what, rc, t);
    else defsim__error(msg, "%s gave a non-finite value at vertex %lld (t = %g)", what,
                       (long long)(bad / width), t);
    return DEFSIM_ERR_CALLBACK;
}

defsim_status defsim__callback_forces(defsim__coupling *c, defsim__messages *msg, int32_t nv,
                                      const double *x, const double *v, double t, double *f)
{
    return call_host(c, msg, nv, 0, x, v, t, f);
}

defsim_status defsim__callback_stiffness(defsim__coupling *c, defsim__messages *msg, int32_t nv,
                                         int projection, const double *x, const double *v,
                                         double t, double *K)
{
    memset(K, 0, 9 * (size_t)nv * sizeof *K);
    defsim_status st = call_host(c, msg, nv, 1, x, v, t, K);
    if (st != DEFSIM_OK) return st;
    for (int32_t i = 0; i < nv; ++i) {
        double *B = K + 9 * (int64_t)i;
        for (int r = 0; r < 3; ++r)
            for (int s = r; s < 3; ++s) {
                const double m = -0.5 * (B[3 * r + s] + B[3 * s + r]);
                B[3 * r + s] = B[3 * s + r] = m;
            }
        if (projection != DEFSIM_PROJECTION_NONE) defsim__project_psd(3, B, projection);
    }
    return DEFSIM_OK;
}

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
    defsim__coupling *c = s->cpl;
    const uint32_t keep = which & DEFSIM__FORCE_KEEP_PINNED;
    which &= DEFSIM_FORCE_ALL;
    if (!c->fn || !(which & DEFSIM_FORCE_GRAVITY))
        return defsim__forces(s->sys, x, v, which | keep, f, s->passes);
    /* The callback belongs to the applied forces (DEFSIM_FORCE_GRAVITY): added before pinned
     * DOFs are cleared, so that it counts in pin forces like every other term. */
    defsim_status st = defsim__forces(s->sys, x, v, which | DEFSIM__FORCE_KEEP_PINNED, f,
                                      s->passes);
    if (st != DEFSIM_OK) return st;
    const int32_t nv = s->sys->nv;
    const int64_t ndof = 3 * (int64_t)nv;
    if (c->hold && c->in_step) {
        for (int64_t i = 0; i < ndof; ++i) f[i] += c->f0[i];
    } else {
        if (!v) v = s->state->v;
        if (c->in_step && c->rec_first) {
            /* Recorded for the watchdog's bound on the callback's work (watchdog.h). */
            double *r = c->nrec == 0 ? c->rec_first : c->rec_last;
            memset(r, 0, (size_t)ndof * sizeof *r);
            st = defsim__callback_forces(c, s->msg, nv, x, v, t, r);
            if (st != DEFSIM_OK) return st;
            for (int64_t i = 0; i < ndof; ++i) f[i] += r[i];
            c->nrec++;
        } else {
            st = defsim__callback_forces(c, s->msg, nv, x, v, t, f);
            if (st != DEFSIM_OK) return st;
        }
        if (c->jac && c->in_step) {
            memcpy(c->veval, v, (size_t)ndof * sizeof *v);
            c->teval = t;
        }
    }
    *s->passes |= DEFSIM_PASS_FORCE_CALLBACK;
    if (s->sys->has_pins && !keep) {
        for (int32_t i = 0; i < nv; ++i)
            if (s->sys->pinned[i]) f[3 * (int64_t)i] = f[3 * (int64_t)i + 1] = f[3 * (int64_t)i + 2] = 0.0;
        *s->passes |= DEFSIM_PASS_PINS;
    }
    return DEFSIM_OK;
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
    double e = defsim__potential_energy(s->sys, s->work, x);
    /* Held forces contribute -f . (x - x_start): the same differences as -f . x without its
     * large terms, which would hide small decreases from line searches. */
    if (s->sys->fext) {
        double sum = 0.0;
        for (int64_t i = 0; i < 3 * (int64_t)s->sys->nv; ++i)
            sum -= s->sys->fext[i] * (x[i] - s->x_start[i]);
        e += sum;
    }
    /* An implicit step's line search sees the callback through its model from the step's
     * start: -f0 . d held, plus d^T K0 d / 2 with a Jacobian (d = x - x0). */
    const defsim__coupling *c = s->cpl;
    if (c->fn && c->in_step && c->implicit) {
        double lin = 0.0, quad = 0.0;
        for (int32_t i = 0; i < s->sys->nv; ++i) {
            if (s->sys->pinned[i]) continue;
            double d[3];
            for (int k = 0; k < 3; ++k) {
                d[k] = x[3 * (int64_t)i + k] - c->x0[3 * (int64_t)i + k];
                lin += c->f0[3 * (int64_t)i + k] * d[k];
            }
            if (c->jac) {
                const double *K = c->K0 + 9 * (int64_t)i;
                for (int r = 0; r < 3; ++r)
                    quad += d[r] * (K[3 * r] * d[0] + K[3 * r + 1] * d[1] + K[3 * r + 2] * d[2]);
            }
        }
        e += 0.5 * quad - lin;
    }
    s->stats->energy_evals++;
    *s->passes |= DEFSIM_PASS_ENERGY;
    return e;
}

/* Implicit steps with a Jacobian callback: its stiffness at x, with the velocities and time
 * of the latest force evaluation, joins K. */
static defsim_status callback_stiffness(defsim_system *s, const double *x)
{
    defsim__coupling *c = s->cpl;
    if (!(c->jac && c->in_step && c->implicit)) {
        s->sys->cb_stiffness = NULL;
        return DEFSIM_OK;
    }
    defsim_status st = defsim__callback_stiffness(c, s->msg, s->sys->nv, s->sys->projection, x,
                                                  c->veval, c->teval, c->kcb);
    s->sys->cb_stiffness = st == DEFSIM_OK ? c->kcb : NULL;
    return st;
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
    if (c && c->k != 0.0 && (st = callback_stiffness(s, x)) != DEFSIM_OK) return st;
    st = defsim__matrix_values(s->sys, x, c, tri, values, s->passes);
    if (st != DEFSIM_OK) return st;
    s->stats->hessian_evals++;
    s->stats->time_hessian += defsim__now() - t0;
    return DEFSIM_OK;
}

static defsim_status matrix_product(defsim_system *s, const double *x,
                                    const defsim_matrix_coeffs *c, const double *dx, double *out)
{
    defsim_status st;
    if (x && c && c->k != 0.0 && (st = callback_stiffness(s, x)) != DEFSIM_OK) return st;
    return defsim__matrix_product(s->sys, x, c, dx, out);
}

static const defsim_world_def *options(const defsim_system *s) { return s->def; }
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

/* Contact's services serve only barrier steps (contact.h, body_contact.h); elsewhere they
 * change nothing. */
static double contact_max_step(defsim_system *s, const double *x, const double *dx)
{
    defsim__contact *c = s->sys->contact;
    defsim__body_contact *bc = s->sys->body_contact;
    if (!x || !dx) return 1.0;
    double alpha = 1.0;
    if (c && c->mode == DEFSIM__CONTACT_BARRIER) alpha = defsim__contact_max_step(c, x, dx, 0.2);
    if (bc && alpha > 0.0) {
        const double a = defsim__body_contact_max_step(bc, x, dx);
        if (a < alpha) alpha = a;
    }
    return alpha;
}

static void contact_start(defsim_system *s, double *x)
{
    defsim__contact *c = s->sys->contact;
    defsim__body_contact *bc = s->sys->body_contact;
    if (!x) return;
    if (c && c->mode != DEFSIM__CONTACT_BARRIER) c = NULL;
    const int carried = c ? defsim__contact_start(c, x) & 1 : 0;
    if (!bc) return;
    /* Body contact cuts the start back towards x_n, which keeps every collider's path clear
     * (a part of a clear segment from x_n) except for vertices that a moving collider carries:
     * then the colliders' cut runs again on the result, until neither cuts it. */
    if (!defsim__body_contact_start(bc, x) || !carried) return;
    for (int round = 0; round < 3; ++round)
        if (!(defsim__contact_start(c, x) & 2) || !defsim__body_contact_start(bc, x)) return;
    defsim__contact_block(c, -1);
}

static uint64_t matrix_pattern_version(defsim_system *s)
{
    defsim__body_contact *bc = s->sys->body_contact;
    if (bc && bc->npend > 0) {
        int grew = 0;
        const defsim_status st = defsim__pattern_grow(s->sys, bc->pend, bc->npend, &grew);
        bc->npend = 0;
        if (st != DEFSIM_OK) {
            defsim__error(s->msg, "out of memory growing the matrix pattern for body contact");
            return 0;
        }
        if (grew) bc->stat[DEFSIM__CSTAT_PATTERN_GROWTHS] += 1.0;
    }
    return s->sys->pattern.version;
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
    .options = options,
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
};
