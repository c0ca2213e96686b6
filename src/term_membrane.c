/* SPDX-License-Identifier: MIT */
/*
 * The membrane energy of the shells (shell.h; docs/shells.md): one term per membrane law that
 * the scene uses (its element group of triangles), with the law's scalar element kernel:
 * forces by the batched kernels of shell_batch.c when the plan chose a variant (core.simd),
 * else colour by colour with the scalar kernel (conflict-free parallel scatter), energy as
 * deterministic blocked sums, 9x9 element matrices k K with dP/dF projected per element as the tets' are, products element
 * by element. Shells take no stiffness damping (body.c refuses it), so kd adds nothing.
 */
#include "assembly.h"
#include "energy.h"
#include "shell.h"
#include "system.h"
#include "tet_forces.h"

#include <math.h>
#include <string.h>

static int compile(defsim__system *s, defsim__term *out)
{
    int n = 0;
    for (int m = 0; m < DEFSIM__SHELL_HINGES; ++m)
        if (s->shells[m].n > 0) {
            memset(&out[n], 0, sizeof out[n]);
            out[n].model = &s->shells[m];
            out[n].index = m;
            ++n;
        }
    return n;
}

static void gather(const double *x, const int32_t *id, double X[9])
{
    for (int a = 0; a < 3; ++a) memcpy(X + 3 * a, x + 3 * (int64_t)id[a], 3 * sizeof *X);
}

static double element(const defsim__group *g, const double *x, int32_t e, double *grad,
                      double *H, int proj)
{
    double X[9];
    gather(x, g->idx + 3 * (int64_t)e, X);
    return defsim__membrane_element(g->shell_law, g->shell + DEFSIM__MEMBRANE_WIDTH * (int64_t)e,
                                    g->vol[e], X, grad, H, proj);
}

static double element_energy(const defsim__group *g, const double *x, int32_t e)
{
    return element(g, x, e, NULL, NULL, DEFSIM_PROJECTION_NONE);
}

DEFSIM__GROUP_ENERGY_OP(element_energy)

static int element_gradient(const defsim__group *g, const double *x, int32_t e, double *grad)
{
    return element(g, x, e, grad, NULL, DEFSIM_PROJECTION_NONE) < INFINITY;
}

/* The batched kernel of the variant the plan chose (tet_forces.h), else the scalar one. */
static defsim_status forces(const defsim__term *t, const defsim__system *s, const defsim__eval *ev,
                            double *f, uint32_t *used)
{
    if (!(ev->which & DEFSIM_FORCE_ELASTIC)) return DEFSIM_OK;
    const defsim__group *g = t->model;
    if (s->tet_kernels) s->tet_kernels->shells[t->index](g, ev->x, f, s->nthreads);
    else defsim__group_gradient_forces(s, g, element_gradient, ev->x, f);
    *used |= g->pass;
    return DEFSIM_OK;
}

static int element_matrix(const defsim__system *s, const defsim__group *g, const double *x,
                          int32_t e, double sk, double sd, double *K)
{
    (void)sd;   /* beta is 0 on shells */
    if (!(element(g, x, e, NULL, K, s->projection) < INFINITY)) return 0;
    for (int i = 0; i < 81; ++i) K[i] *= sk;
    return 1;
}

static void element_apply(const defsim__group *g, const double *x, int32_t e, double sk,
                          double sd, int proj, const uint8_t *pinned, const double *dx,
                          double *out)
{
    (void)sd;
    double H[81];
    if (element(g, x, e, NULL, H, proj) < INFINITY)
        defsim__element_product(g->idx + 3 * (int64_t)e, 3, H, sk, pinned, dx, out);
}

DEFSIM__GROUP_MATRIX_OPS(element_matrix, element_apply)

const defsim__term_ops defsim__term_membrane = {
    .name = "membrane", .flags = DEFSIM__TERM_ELASTIC, .energy_rank = 1, .matrix_rank = 1,
    DEFSIM__TERM_FORCES, DEFSIM__TERM_MATRIX,
    .pairs = defsim__group_pairs, .ranks = defsim__group_ranks};
