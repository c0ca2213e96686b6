/* SPDX-License-Identifier: MIT */
/* Gravity: forces m_i g, energy -sum m_i g . x_i. */
#include "adjoint.h"
#include "system.h"
#include "term_cache.h"

static int compile(defsim__system *s, defsim__term *out)
{
    return defsim__term_one(s->has_gravity, s, NULL, 0, out);
}

static double energy(const defsim__term *t, const defsim__system *s, defsim__work *wk,
                     const double *x, double e)
{
    (void)t;
    (void)wk;
    const double *gr = s->gravity;
    double sum = 0.0;
    for (int32_t i = 0; i < s->nv; ++i)
        sum -= s->mass[i] * (gr[0] * x[3 * (int64_t)i] + gr[1] * x[3 * (int64_t)i + 1] +
                             gr[2] * x[3 * (int64_t)i + 2]);
    return e + sum;
}

static defsim_status forces(const defsim__term *t, const defsim__system *s, const defsim__eval *ev,
                            double *f, uint32_t *used)
{
    (void)t;
    if (!(ev->which & DEFSIM_FORCE_GRAVITY)) return DEFSIM_OK;
    const double *gr = s->gravity;
    for (int32_t i = 0; i < s->nv; ++i) {
        f[3 * (int64_t)i + 0] += s->mass[i] * gr[0];
        f[3 * (int64_t)i + 1] += s->mass[i] * gr[1];
        f[3 * (int64_t)i + 2] += s->mass[i] * gr[2];
    }
    *used |= DEFSIM_PASS_GRAVITY;
    return DEFSIM_OK;
}

/* Reverse mode: m_i g does not depend on x or v; its mass-derivative is g. */
static defsim_status vjp(const defsim__term *t, const defsim__system *s, const defsim__eval *ev,
                         const double *w, double *gx, double *gv, defsim__grad *g)
{
    (void)t;
    (void)gx;
    (void)gv;
    if (!(ev->which & DEFSIM_FORCE_GRAVITY) || !g) return DEFSIM_OK;
    const double *gr = s->gravity;
    for (int32_t i = 0; i < s->nv; ++i)
        g->mass[i] += gr[0] * w[3 * (int64_t)i] + gr[1] * w[3 * (int64_t)i + 1] +
                      gr[2] * w[3 * (int64_t)i + 2];
    return DEFSIM_OK;
}

const defsim__term_ops defsim__term_gravity = {
    .name = "gravity", .energy_rank = 3, DEFSIM__TERM_FORCES, .vjp = vjp};
