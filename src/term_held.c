/* SPDX-License-Identifier: MIT */
/*
 * Held external forces (defsim_world_set_external_forces): forces f_ext, energy
 * -f_ext . (x - x_start) relative to the positions at the start of the world's step (the same
 * differences as -f_ext . x without its large terms, which would hide small decreases from line
 * searches; the origin without a host). Their reverse mode gives the gradients of the step's
 * held forces, the controls of docs/gradients.md.
 */
#include "adjoint.h"
#include "host.h"
#include "system.h"
#include "term_cache.h"

static int compile(defsim__system *s, defsim__term *out)
{
    return defsim__term_one(s->fext != NULL, s, NULL, 0, out);
}

static double energy(const defsim__term *t, const defsim__system *s, defsim__work *wk,
                     const double *x, double e)
{
    (void)t;
    (void)wk;
    const double *x0 = s->host ? s->host->x_start : NULL;
    double sum = 0.0;
    for (int64_t i = 0; i < 3 * (int64_t)s->nv; ++i)
        sum -= s->fext[i] * (x[i] - (x0 ? x0[i] : 0.0));
    return e + sum;
}

static defsim_status forces(const defsim__term *t, const defsim__system *s, const defsim__eval *ev,
                            double *f, uint32_t *used)
{
    (void)t;
    if (!(ev->which & DEFSIM_FORCE_GRAVITY)) return DEFSIM_OK;
    for (int64_t i = 0; i < 3 * (int64_t)s->nv; ++i) f[i] += s->fext[i];
    *used |= DEFSIM_PASS_EXTERNAL_FORCES;
    return DEFSIM_OK;
}

/* Reverse mode: f_ext depends on nothing of the state; its own derivative is the identity, so
 * the gradient of the step's held forces is w (also while they are zero: the kind is off). */
static defsim_status vjp(const defsim__term *t, const defsim__system *s, const defsim__eval *ev,
                         const double *w, double *gx, double *gv, defsim__grad *g)
{
    (void)t;
    (void)gx;
    (void)gv;
    if (!(ev->which & DEFSIM_FORCE_GRAVITY) || !g) return DEFSIM_OK;
    for (int64_t i = 0; i < 3 * (int64_t)s->nv; ++i) g->fext[i] += w[i];
    return DEFSIM_OK;
}

const defsim__term_ops defsim__term_held = {
    .name = "held", .flags = DEFSIM__TERM_GRAD_OFF, .energy_rank = 6, DEFSIM__TERM_FORCES,
    .vjp = vjp};
