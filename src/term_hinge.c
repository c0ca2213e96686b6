/* SPDX-License-Identifier: MIT */
/*
 * The bending energy of the shells (shell.h; docs/shells.md): discrete shells' hinges, one
 * term over the hinge group, E = w/2 (theta - theta0)^2 per hinge with w = D |e|^2 / (A1 + A2)
 * from the rest shape: forces by shell_batch.c's batched kernel when the plan chose a variant
 * (core.simd), else colour by colour with the scalar kernel, energy as deterministic blocked
 * sums, 12x12 element matrices w (g g^T + delta H_theta) eigen-clamped per hinge when the
 * backend projects,
 * products element by element. Shells take no stiffness damping (body.c refuses it).
 */
#include "assembly.h"
#include "energy.h"
#include "shell.h"
#include "system.h"
#include "tet_forces.h"
#include "term_cache.h"

#include <string.h>

static int compile(defsim__system *s, defsim__term *out)
{
    const defsim__group *g = &s->shells[DEFSIM__SHELL_HINGES];
    return defsim__term_one(g->n > 0, g, NULL, DEFSIM__SHELL_HINGES, out);
}

static double hinge(const defsim__group *g, const double *x, int32_t e, double *grad, double *H,
                    int proj)
{
    double X[12];
    const int32_t *id = g->idx + 4 * (int64_t)e;
    for (int a = 0; a < 4; ++a) memcpy(X + 3 * a, x + 3 * (int64_t)id[a], 3 * sizeof *X);
    return defsim__hinge_element(g->k[e], g->l0[e], X, grad, H, proj);
}

static double element_energy(const defsim__group *g, const double *x, int32_t e)
{
    return hinge(g, x, e, NULL, NULL, DEFSIM_PROJECTION_NONE);
}

DEFSIM__GROUP_ENERGY_OP(element_energy)

static int element_gradient(const defsim__group *g, const double *x, int32_t e, double *grad)
{
    hinge(g, x, e, grad, NULL, DEFSIM_PROJECTION_NONE);
    return 1;
}

/* The batched kernel of the variant the plan chose (tet_forces.h), else the scalar one. */
static defsim_status forces(const defsim__term *t, const defsim__system *s, const defsim__eval *ev,
                            double *f, uint32_t *used)
{
    if (!(ev->which & DEFSIM_FORCE_ELASTIC)) return DEFSIM_OK;
    const defsim__group *g = t->model;
    if (s->tet_kernels) s->tet_kernels->shells[DEFSIM__SHELL_HINGES](g, ev->x, f, s->nthreads);
    else defsim__group_gradient_forces(s, g, element_gradient, ev->x, f);
    *used |= g->pass;
    return DEFSIM_OK;
}

static int element_matrix(const defsim__system *s, const defsim__group *g, const double *x,
                          int32_t e, double sk, double sd, double *K)
{
    (void)sd;   /* beta is 0 on shells */
    hinge(g, x, e, NULL, K, s->projection);
    for (int i = 0; i < 144; ++i) K[i] *= sk;
    return 1;
}

static void element_apply(const defsim__group *g, const double *x, int32_t e, double sk,
                          double sd, int proj, const uint8_t *pinned, const double *dx,
                          double *out)
{
    (void)sd;
    double H[144];
    hinge(g, x, e, NULL, H, proj);
    defsim__element_product(g->idx + 4 * (int64_t)e, 4, H, sk, pinned, dx, out);
}

DEFSIM__GROUP_MATRIX_OPS(element_matrix, element_apply)

const defsim__term_ops defsim__term_hinge = {
    .name = "hinge", .flags = DEFSIM__TERM_ELASTIC, .energy_rank = 1, .matrix_rank = 1,
    DEFSIM__TERM_FORCES, DEFSIM__TERM_MATRIX,
    .pairs = defsim__group_pairs, .ranks = defsim__group_ranks};
