/* SPDX-License-Identifier: MIT */
/*
 * Inertia in the matrices: (m + md alpha) M on the diagonal, mass damping's md alpha M with it
 * in one add per DOF (term_mass_damping.c has its forces).
 */
#include "system.h"
#include "term_cache.h"

#include <string.h>

static int compile(defsim__system *s, defsim__term *out)
{
    return defsim__term_one(s->nv > 0, s, NULL, 0, out);
}

static void values(const defsim__term *t, const defsim__system *s, const double *x,
                   const defsim_matrix_coeffs *c, int upper, const int64_t *cp, double *val,
                   uint32_t *passes)
{
    (void)t;
    (void)x;
    (void)upper;
    (void)passes;
    if (c->m == 0.0 && c->md == 0.0) return;
    const int32_t *rank0 = s->pattern.upper_rank0;
    for (int32_t fv = 0; fv < s->nfree_v; ++fv)
        for (int cc = 0; cc < 3; ++cc) {
            int64_t dof = s->free_dofs[3 * (int64_t)fv + cc];
            int64_t pos = cp[3 * (int64_t)fv + cc] + 3 * (int64_t)rank0[fv] + cc;
            val[pos] += (c->m + c->md * s->alpha3[dof]) * s->mass3[dof];
        }
}

static void apply(const defsim__term *t, const defsim__system *s, const double *x,
                  const defsim_matrix_coeffs *c, int proj, const double *dx, double *out)
{
    (void)t;
    (void)x;
    (void)proj;
    if (c->m == 0.0 && c->md == 0.0) return;
    for (int64_t i = 0; i < 3 * (int64_t)s->nv; ++i)
        if (!s->pinned[i / 3]) out[i] += (c->m + c->md * s->alpha3[i]) * s->mass3[i] * dx[i];
}

const defsim__term_ops defsim__term_inertia = {
    .name = "inertia", .matrix_rank = 6, .compile = compile, DEFSIM__TERM_MATRIX};
