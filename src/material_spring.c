/* SPDX-License-Identifier: MIT */
/* Springs: E = k/2 (l - l0)^2 between two vertices, with l0 the rest length. */
#include "material.h"

#include <math.h>

enum { PAR_MIN = 1024 };

/* Spring direction, length and the 3x3 block Kb = k (n n^T + s (I - n n^T)), s = 1 - l0/l,
 * with s projected as the element's Hessian would be (its eigenvalues are k and k s). */
static void spring_block(const double *xa, const double *xb, double k, double l0,
                         int projection,
                         double Kb[9])
{
    double d[3] = {xb[0] - xa[0], xb[1] - xa[1], xb[2] - xa[2]};
    double l = sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
    double n[3] = {0, 0, 0};
    double s = 0.0;
    if (l > 0.0) {
        n[0] = d[0] / l; n[1] = d[1] / l; n[2] = d[2] / l;
        s = 1.0 - l0 / l;
    }
    if (projection == DEFSIM_PROJECTION_CLAMP && s < 0.0) s = 0.0;
    if (projection == DEFSIM_PROJECTION_ABS) s = fabs(s);
    for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j)
            Kb[3 * i + j] = k * ((1.0 - s) * n[i] * n[j] + (i == j ? s : 0.0));
}

static double spring_energy(const double *xa, const double *xb, double k, double l0)
{
    double d0 = xb[0] - xa[0], d1 = xb[1] - xa[1], d2 = xb[2] - xa[2];
    double dl = sqrt(d0 * d0 + d1 * d1 + d2 * d2) - l0;
    return 0.5 * k * dl * dl;
}

static void forces_springs(const defsim__group *g, const double *x, double *f, int nthreads)
{
    (void)nthreads;   /* used by OpenMP pragmas only */
    for (int32_t c = 0; c < g->ncolors; ++c) {
        const int32_t e0 = g->color_ptr[c], e1 = g->color_ptr[c + 1];
#pragma omp parallel for schedule(static) num_threads(nthreads) if (e1 - e0 > PAR_MIN)
        for (int32_t e = e0; e < e1; ++e) {
            const int32_t a = g->idx[2 * (int64_t)e], b = g->idx[2 * (int64_t)e + 1];
            const double *xa = x + 3 * (int64_t)a, *xb = x + 3 * (int64_t)b;
            double d[3] = {xb[0] - xa[0], xb[1] - xa[1], xb[2] - xa[2]};
            double l = sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
            /* f_a = k (l - l0) d / l; a spring of zero current length exerts no force. */
            double s = l > 0.0 ? g->k[e] * (l - g->l0[e]) / l : 0.0;
            for (int i = 0; i < 3; ++i) {
                f[3 * (int64_t)a + i] += s * d[i];
                f[3 * (int64_t)b + i] -= s * d[i];
            }
        }
    }
}

const defsim__spring_model defsim__model_spring = {
    .name = "spring", .id = DEFSIM_MODEL_SPRING, .pass = DEFSIM_PASS_SPRINGS,
    .energy = spring_energy, .block = spring_block, .forces = forces_springs};
