/* SPDX-License-Identifier: MIT */
/*
 * Reverse mode of the forces (adjoint.h): the terms' vjp ops in list order over w with its
 * pinned DOFs zeroed (forces.c zeroes the pinned DOFs' forces, so they carry no adjoint).
 * Serial and in a fixed order: a backward pass is bit-identical run to run.
 */
#include "adjoint.h"

#include "terms.h"

#include <math.h>
#include <string.h>

defsim_status defsim__forces_vjp(const defsim__system *s, const double *x, const double *v,
                                 uint32_t which, const double *w, double *gx, double *gv,
                                 defsim__grad *g, int acc)
{
    const int64_t ndof = 3 * (int64_t)s->nv;
    double *wm = g->wmask;
    memcpy(wm, w, (size_t)ndof * sizeof *wm);
    for (int32_t i = 0; i < s->nv; ++i)
        if (s->pinned[i]) memset(wm + 3 * (int64_t)i, 0, 3 * sizeof *wm);
    const defsim__eval ev = {x, v, 0.0, which};
    for (int32_t k = 0; k < s->nterms; ++k) {
        const defsim__term *tm = &s->terms[k];
        if (!tm->ops->vjp) continue;
        const defsim_status st = tm->ops->vjp(tm, s, &ev, wm, gx, gv, acc ? g : NULL);
        if (st != DEFSIM_OK) return st;
    }
    /* a kind that is off because its parameters are zero still has their gradients */
    for (int kind = 0; acc && kind < DEFSIM__TERM_KINDS; ++kind) {
        const defsim__term tm = defsim__terms_detached(s, kind, NULL);
        if (!(tm.ops->flags & DEFSIM__TERM_GRAD_OFF) || !tm.ops->vjp ||
            defsim__terms_find(s, kind))
            continue;
        const defsim_status st = tm.ops->vjp(&tm, s, &ev, wm, NULL, NULL, g);
        if (st != DEFSIM_OK) return st;
    }
    int ok = 1;
    for (int64_t i = 0; i < ndof; ++i) ok &= (!gx || isfinite(gx[i])) && (!gv || isfinite(gv[i]));
    return ok ? DEFSIM_OK : DEFSIM_ERR_UNSTABLE;
}

const char *defsim__forces_vjp_missing(const defsim__system *s)
{
    for (int32_t k = 0; k < s->nterms; ++k)
        if (s->terms[k].ops->forces && !s->terms[k].ops->vjp) return s->terms[k].ops->name;
    return NULL;
}
