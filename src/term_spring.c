/* SPDX-License-Identifier: MIT */
/*
 * The elastic energy of the springs group (material_spring.c's law, E = k/2 (l - l0)^2):
 * forces by its kernel, energy as deterministic blocked sums, 6x6 element matrices k K + kd beta
 * B (the springs' stiffness damping B shares the element matrix) and products element by
 * element. Springs are sorted by colour like tets (conflict-free parallel scatter).
 */
#include "adjoint.h"
#include "assembly.h"
#include "energy.h"
#include "material.h"
#include "system.h"
#include "term_cache.h"

#include <stdlib.h>
#include <string.h>

static const defsim__group *group(const defsim__term *t) { return t->model; }

static int compile(defsim__system *s, defsim__term *out)
{
    return defsim__term_one(s->groups[DEFSIM__TET_MODELS].n > 0, &s->groups[DEFSIM__TET_MODELS],
                           NULL, DEFSIM__TET_MODELS, out);
}

static double element_energy(const defsim__group *g, const double *x, int32_t e)
{
    return defsim__model_spring.energy(x + 3 * (int64_t)g->idx[2 * (int64_t)e],
                                       x + 3 * (int64_t)g->idx[2 * (int64_t)e + 1], g->k[e],
                                       g->l0[e]);
}

DEFSIM__GROUP_ENERGY_OP(element_energy)

static defsim_status forces(const defsim__term *t, const defsim__system *s, const defsim__eval *ev,
                            double *f, uint32_t *used)
{
    if (!(ev->which & DEFSIM_FORCE_ELASTIC)) return DEFSIM_OK;
    defsim__model_spring.forces(group(t), ev->x, f, s->nthreads);
    *used |= group(t)->pass;
    return DEFSIM_OK;
}

/* Element matrix K[(a c),(b d)], 6x6, scaled by k + kd beta (kd part clamped). Returns 0 if
 * the element adds nothing. */
static int element_matrix(const defsim__system *s, const defsim__group *g, const double *x,
                          int32_t e, double sk, double sd, double *K)
{
    const int nd = 6;
    const double *xa = x + 3 * (int64_t)g->idx[2 * (int64_t)e];
    const double *xb = x + 3 * (int64_t)g->idx[2 * (int64_t)e + 1];
    double Kb[9], Kd[9];
    defsim__model_spring.block(xa, xb, g->k[e], g->l0[e], s->projection, Kb);
    if (sd != 0.0)
        defsim__model_spring.block(xa, xb, g->k[e], g->l0[e], DEFSIM_PROJECTION_CLAMP, Kd);
    for (int i = 0; i < 9; ++i) Kb[i] = sk * Kb[i] + (sd != 0.0 ? sd * Kd[i] : 0.0);
    for (int a = 0; a < 2; ++a)
        for (int b = 0; b < 2; ++b)
            for (int i = 0; i < 3; ++i)
                for (int j = 0; j < 3; ++j)
                    K[(3 * a + i) * nd + 3 * b + j] = (a == b ? 1.0 : -1.0) * Kb[3 * i + j];
    return 1;
}

static void element_apply(const defsim__group *g, const double *x, int32_t e, double sk,
                          double sd, int proj, const uint8_t *pinned, const double *dx,
                          double *out)
{
    const int32_t a = g->idx[2 * (int64_t)e], b = g->idx[2 * (int64_t)e + 1];
    const double *xa = x + 3 * (int64_t)a, *xb = x + 3 * (int64_t)b;
    double Kb[9], Kd[9], d[3];
    defsim__model_spring.block(xa, xb, g->k[e], g->l0[e], proj, Kb);
    if (sd != 0.0)
        defsim__model_spring.block(xa, xb, g->k[e], g->l0[e], DEFSIM_PROJECTION_CLAMP, Kd);
    for (int i = 0; i < 3; ++i) {
        double ua = pinned[a] ? 0.0 : dx[3 * (int64_t)a + i];
        double ub = pinned[b] ? 0.0 : dx[3 * (int64_t)b + i];
        d[i] = ua - ub;
    }
    for (int i = 0; i < 3; ++i) {
        double s = 0.0;
        for (int j = 0; j < 3; ++j)
            s += (sk * Kb[3 * i + j] + (sd != 0.0 ? sd * Kd[3 * i + j] : 0.0)) * d[j];
        if (!pinned[a]) out[3 * (int64_t)a + i] += s;
        if (!pinned[b]) out[3 * (int64_t)b + i] -= s;
    }
}

DEFSIM__GROUP_MATRIX_OPS(element_matrix, element_apply)

/* Reverse mode: f_a = -f_b with d(f_a)/dx_a = -Kb (exact block, unprojected), so
 * (df/dx)^T w adds -Kb (w_a - w_b) at a and the opposite at b. The springs' stiffness is no
 * parameter of the gradients (yet): nothing goes into g. */
static defsim_status vjp(const defsim__term *t, const defsim__system *s, const defsim__eval *ev,
                         const double *w, double *gx, double *gv, defsim__grad *g)
{
    (void)s;
    (void)gv;
    (void)g;
    if (!(ev->which & DEFSIM_FORCE_ELASTIC) || !gx) return DEFSIM_OK;
    const defsim__group *gr = group(t);
    for (int32_t e = 0; e < gr->n; ++e) {
        const int32_t a = gr->idx[2 * (int64_t)e], b = gr->idx[2 * (int64_t)e + 1];
        double Kb[9];
        defsim__model_spring.block(ev->x + 3 * (int64_t)a, ev->x + 3 * (int64_t)b, gr->k[e],
                                   gr->l0[e], DEFSIM_PROJECTION_NONE, Kb);
        const double *wa = w + 3 * (int64_t)a, *wb = w + 3 * (int64_t)b;
        const double dw[3] = {wa[0] - wb[0], wa[1] - wb[1], wa[2] - wb[2]};
        for (int i = 0; i < 3; ++i) {
            const double r = Kb[3 * i] * dw[0] + Kb[3 * i + 1] * dw[1] + Kb[3 * i + 2] * dw[2];
            gx[3 * (int64_t)a + i] -= r;
            gx[3 * (int64_t)b + i] += r;
        }
    }
    return DEFSIM_OK;
}

const defsim__term_ops defsim__term_spring = {
    .name = "spring", .flags = DEFSIM__TERM_ELASTIC, .energy_rank = 1, .matrix_rank = 1,
    DEFSIM__TERM_FORCES, DEFSIM__TERM_MATRIX,
    .pairs = defsim__group_pairs, .ranks = defsim__group_ranks, .vjp = vjp};
