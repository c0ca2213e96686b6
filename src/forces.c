/* SPDX-License-Identifier: MIT */
/*
 * Forces f(x, v) of a compiled system: a loop over its terms (term.h) in list order, then the
 * pins. Each term forms its sums in a fixed order whatever the thread count (element groups
 * scatter colour by colour without atomics), so results are bit-identical for any number of
 * threads.
 */
#include "forces.h"

#include <math.h>
#include <string.h>

static int all_finite(const double *a, int64_t n)
{
    int ok = 1;
    for (int64_t i = 0; i < n; ++i) ok &= isfinite(a[i]);
    return ok;
}

defsim_status defsim__forces_at(const defsim__system *s, const double *x, const double *v,
                                double t, uint32_t which, double *f, uint32_t *passes)
{
    const int64_t ndof = 3 * (int64_t)s->nv;
    uint32_t used = 0;
    memset(f, 0, (size_t)ndof * sizeof *f);
    const defsim__eval ev = {x, v, t, which};
    for (int32_t k = 0; k < s->nterms; ++k) {
        const defsim__term *tm = &s->terms[k];
        if (!tm->ops->forces) continue;
        const defsim_status st = tm->ops->forces(tm, s, &ev, f, &used);
        if (st != DEFSIM_OK) return st;
    }
    if (s->has_pins && !(which & DEFSIM__FORCE_KEEP_PINNED)) {
        for (int32_t i = 0; i < s->nv; ++i)
            if (s->pinned[i]) f[3 * (int64_t)i] = f[3 * (int64_t)i + 1] = f[3 * (int64_t)i + 2] = 0.0;
        used |= DEFSIM_PASS_PINS;
    }
    if (passes) *passes |= used;
    return all_finite(f, ndof) ? DEFSIM_OK : DEFSIM_ERR_UNSTABLE;
}

defsim_status defsim__forces(const defsim__system *s, const double *x, const double *v,
                             uint32_t which, double *f, uint32_t *passes)
{
    return defsim__forces_at(s, x, v, 0.0, which, f, passes);
}
