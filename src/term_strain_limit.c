/* SPDX-License-Identifier: MIT */
/*
 * The shells' strain limit (shell.h; docs/shells.md): one term over the triangles of the bodies
 * with defsim_body_def.shell_strain_limit, a barrier on each singular value of a triangle's F
 * that is zero outside a band below the cap and +inf at it: forces colour by colour, energy as
 * deterministic blocked sums, 9x9 element matrices with dP/dF projected per element, products
 * element by element, all of them skipping the triangles outside the band (so that a run that
 * stays out of it has the bits of one without the limit); and the line-search filter, the
 * largest step along dx that keeps every triangle below its cap (add_body takes the limit
 * only on backends that use it).
 */
#include "assembly.h"
#include "energy.h"
#include "shell.h"
#include "system.h"
#include "term_cache.h"

#include <math.h>
#include <string.h>

static int compile(defsim__system *s, defsim__term *out)
{
    const defsim__group *g = &s->shells[DEFSIM__SHELL_LIMITS];
    return defsim__term_one(g->n > 0, g, NULL, DEFSIM__SHELL_LIMITS, out);
}

static void gather(const double *x, const int32_t *id, double X[9])
{
    for (int a = 0; a < 3; ++a) memcpy(X + 3 * a, x + 3 * (int64_t)id[a], 3 * sizeof *X);
}

static double element(const defsim__group *g, const double *x, int32_t e, double *grad,
                      double *H, int proj, int *active)
{
    double X[9];
    gather(x, g->idx + 3 * (int64_t)e, X);
    return defsim__strain_limit_element(g->shell + DEFSIM__MEMBRANE_WIDTH * (int64_t)e, g->vol[e],
                                        X, grad, H, proj, active);
}

static double element_energy(const defsim__group *g, const double *x, int32_t e)
{
    int active;
    return element(g, x, e, NULL, NULL, DEFSIM_PROJECTION_NONE, &active);
}

DEFSIM__GROUP_ENERGY_OP(element_energy)

static int element_gradient(const defsim__group *g, const double *x, int32_t e, double *grad)
{
    int active;
    return element(g, x, e, grad, NULL, DEFSIM_PROJECTION_NONE, &active) < INFINITY && active;
}

DEFSIM__GROUP_GRADIENT_FORCES_OP(element_gradient)

static int element_matrix(const defsim__system *s, const defsim__group *g, const double *x,
                          int32_t e, double sk, double sd, double *K)
{
    (void)sd;   /* no stiffness damping on shells */
    int active;
    if (!(element(g, x, e, NULL, K, s->projection, &active) < INFINITY) || !active) return 0;
    for (int i = 0; i < 81; ++i) K[i] *= sk;
    return 1;
}

static void element_apply(const defsim__group *g, const double *x, int32_t e, double sk,
                          double sd, int proj, const uint8_t *pinned, const double *dx,
                          double *out)
{
    (void)sd;
    double H[81];
    int active;
    if (element(g, x, e, NULL, H, proj, &active) < INFINITY && active)
        defsim__element_product(g->idx + 3 * (int64_t)e, 3, H, sk, pinned, dx, out);
}

DEFSIM__GROUP_MATRIX_OPS(element_matrix, element_apply)

/* The smallest of the triangles' steps (a minimum: the same for any order). */
static double max_step(const defsim__term *t, const double *x, const double *dx)
{
    const defsim__group *g = t->model;
    double alpha = 1.0;
    for (int32_t e = 0; e < g->n && alpha > 0.0; ++e) {
        double X[9], dX[9];
        gather(x, g->idx + 3 * (int64_t)e, X);
        gather(dx, g->idx + 3 * (int64_t)e, dX);
        const double a = defsim__strain_limit_step(g->shell + DEFSIM__MEMBRANE_WIDTH * (int64_t)e,
                                                   X, dX);
        if (a < alpha) alpha = a;
    }
    return alpha;
}

const defsim__term_ops defsim__term_strain_limit = {
    .name = "strain_limit", .flags = DEFSIM__TERM_ELASTIC, .energy_rank = 1, .matrix_rank = 1,
    DEFSIM__TERM_FORCES, DEFSIM__TERM_MATRIX,
    .pairs = defsim__group_pairs, .ranks = defsim__group_ranks, .max_step = max_step};
