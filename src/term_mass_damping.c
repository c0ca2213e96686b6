/* SPDX-License-Identifier: MIT */
/*
 * Mass damping, forces -alpha M v. Its matrix md alpha M joins the inertia's diagonal
 * (term_inertia.c adds (m + md alpha) M in one add per DOF).
 */
#include "adjoint.h"
#include "system.h"
#include "term_cache.h"

static int compile(defsim__system *s, defsim__term *out)
{
    return defsim__term_one(s->has_mass_damping, s, NULL, 0, out);
}

static defsim_status forces(const defsim__term *t, const defsim__system *s, const defsim__eval *ev,
                            double *f, uint32_t *used)
{
    (void)t;
    if (!(ev->which & DEFSIM_FORCE_DAMPING) || !ev->v) return DEFSIM_OK;
    const int64_t ndof = 3 * (int64_t)s->nv;
    for (int64_t i = 0; i < ndof; ++i) f[i] -= s->alpha3[i] * s->mass3[i] * ev->v[i];
    *used |= DEFSIM_PASS_MASS_DAMPING;
    return DEFSIM_OK;
}

/* The largest mass damping of a free DOF. */
static void rates(const defsim__term *t, const defsim__system *s, const double *x,
                  defsim__rates *r)
{
    (void)t;
    (void)x;
    for (int64_t i = 0; i < 3 * (int64_t)s->nv; ++i)
        if (!s->pinned[i / 3] && s->alpha3[i] > r->alpha) r->alpha = s->alpha3[i];
}

/* Reverse mode of -alpha_i m_i v_i: -alpha m w in v, -m v w in alpha, -alpha v w in m. */
static defsim_status vjp(const defsim__term *t, const defsim__system *s, const defsim__eval *ev,
                         const double *w, double *gx, double *gv, defsim__grad *g)
{
    (void)t;
    (void)gx;
    if (!(ev->which & DEFSIM_FORCE_DAMPING) || !ev->v) return DEFSIM_OK;
    const int64_t ndof = 3 * (int64_t)s->nv;
    for (int64_t i = 0; i < ndof; ++i) {
        if (gv) gv[i] -= s->alpha3[i] * s->mass3[i] * w[i];
        if (g) {
            g->alpha3[i] -= s->mass3[i] * ev->v[i] * w[i];
            g->mass[i / 3] -= s->alpha3[i] * ev->v[i] * w[i];
        }
    }
    return DEFSIM_OK;
}

const defsim__term_ops defsim__term_mass_damping = {
    .name = "mass_damping", .flags = DEFSIM__TERM_GRAD_OFF, .compile = compile,
    .forces = forces, .rates = rates, .vjp = vjp};
