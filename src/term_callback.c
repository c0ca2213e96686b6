/* SPDX-License-Identifier: MIT */
/*
 * The host's force callback (defsim_world_set_force_callback; host.c calls it): among the
 * applied forces (DEFSIM_FORCE_GRAVITY), before pinned DOFs are cleared so that it counts in pin
 * forces like every other term. Implicit steps see it through its model from the step's start:
 * held f0 without a Jacobian; with one, -f0 . d + d^T K0 d / 2 in the energy and the Jacobian's
 * stiffness -sym(dF/dx) in the matrices, evaluated when matrix values or a product are asked
 * (the Jacobian reads v and t, which no cache key sees).
 */
#include "assembly.h"
#include "host.h"
#include "mat3.h"
#include "system.h"
#include "term_cache.h"

#include <math.h>
#include <string.h>

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

static defsim_system *host(const defsim__term *t) { return t->data; }

static int compile(defsim__system *s, defsim__term *out)
{
    return defsim__term_one(s->host && s->host->cpl && s->host->cpl->fn, s, s->host, 0, out);
}

static defsim_status forces(const defsim__term *t, const defsim__system *s, const defsim__eval *ev,
                            double *f, uint32_t *used)
{
    if (!(ev->which & DEFSIM_FORCE_GRAVITY)) return DEFSIM_OK;
    defsim_system *h = host(t);
    defsim__coupling *c = h->cpl;
    const int64_t ndof = 3 * (int64_t)s->nv;
    if (c->hold && c->in_step) {
        for (int64_t i = 0; i < ndof; ++i) f[i] += c->f0[i];
    } else {
        const double *v = ev->v ? ev->v : h->state->v;
        if (c->in_step && c->rec_first) {
            /* Recorded for the watchdog's bound on the callback's work (watchdog.h). */
            double *r = c->nrec == 0 ? c->rec_first : c->rec_last;
            memset(r, 0, (size_t)ndof * sizeof *r);
            const defsim_status st = defsim__callback_forces(c, h->msg, s->nv, ev->x, v, ev->t, r);
            if (st != DEFSIM_OK) return st;
            for (int64_t i = 0; i < ndof; ++i) f[i] += r[i];
            c->nrec++;
        } else {
            const defsim_status st = defsim__callback_forces(c, h->msg, s->nv, ev->x, v, ev->t, f);
            if (st != DEFSIM_OK) return st;
        }
        if (c->jac && c->in_step) {
            memcpy(c->veval, v, (size_t)ndof * sizeof *v);
            c->teval = ev->t;
        }
    }
    *used |= DEFSIM_PASS_FORCE_CALLBACK;
    return DEFSIM_OK;
}

static double energy(const defsim__term *t, const defsim__system *s, defsim__work *wk,
                     const double *x, double e)
{
    (void)wk;
    const defsim__coupling *c = host(t)->cpl;
    if (!(c->in_step && c->implicit)) return e;
    double lin = 0.0, quad = 0.0;
    for (int32_t i = 0; i < s->nv; ++i) {
        if (s->pinned[i]) continue;
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
    return e + (0.5 * quad - lin);
}

/* Implicit steps with a Jacobian: its stiffness at x, with the velocities and time of the latest
 * force evaluation, joins K (cache->any: c->kcb holds it). Internal products (LAZY) use what the
 * last evaluation left. */
static defsim_status linearise(const defsim__term *t, const defsim__system *s, const double *x,
                               const defsim_matrix_coeffs *k, int mode)
{
    if (mode == DEFSIM__LIN_LAZY || k->k == 0.0) return DEFSIM_OK;
    defsim_system *h = host(t);
    defsim__coupling *c = h->cpl;
    t->cache->any = 0;
    if (!(c->jac && c->in_step && c->implicit)) return DEFSIM_OK;
    const defsim_status st = defsim__callback_stiffness(c, h->msg, s->nv, s->projection, x,
                                                        c->veval, c->teval, c->kcb);
    t->cache->any = st == DEFSIM_OK;
    t->cache->linearisations++;
    return st;
}

/* The stiffness linearise left, times k. */
static const double *diagonal(const defsim__term *t, const defsim_matrix_coeffs *c, double *f)
{
    *f = c->k;
    return c->k != 0.0 && t->cache->any ? host(t)->cpl->kcb : NULL;
}

static void step_end(const defsim__term *t) { t->cache->any = 0; }

const defsim__term_ops defsim__term_callback = {
    .name = "callback", .energy_rank = 7, .matrix_rank = 3,
    DEFSIM__TERM_FORCES, .linearise = linearise, DEFSIM__TERM_DIAGONAL, .step_end = step_end};
