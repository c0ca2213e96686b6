/* SPDX-License-Identifier: MIT */
/* Energies of a compiled system: elastic (with attachment springs) and potential (with
 * gravity), as deterministic blocked sums. */
#include "energy.h"

#include "element.h"

#include <math.h>

static double element_energy(const defsim__group *g, const double *x, int32_t e)
{
    if (g->nodes == 2) {
        const double *xa = x + 3 * (int64_t)g->idx[2 * (int64_t)e];
        const double *xb = x + 3 * (int64_t)g->idx[2 * (int64_t)e + 1];
        double d0 = xb[0] - xa[0], d1 = xb[1] - xa[1], d2 = xb[2] - xa[2];
        double dl = sqrt(d0 * d0 + d1 * d1 + d2 * d2) - g->l0[e];
        return 0.5 * g->k[e] * dl * dl;
    }
    double F[9], psi;
    tet_deformation(x, g->idx + 4 * (int64_t)e, g->dminv + 9 * (int64_t)e, F);
    const double mu = g->mu[e], la = g->lambda[e];
    switch (g->model) {
    case DEFSIM_MODEL_STVK: psi = defsim__stvk_psi(mu, la, F); break;
    case DEFSIM_MODEL_COROTATED: psi = defsim__corotated_psi(mu, la, F); break;
    case DEFSIM_MODEL_NEOHOOKEAN: psi = defsim__neohookean_psi(mu, la, F); break;
    default: psi = defsim__snh_psi(mu, la, F) - defsim__snh_psi_rest(mu, la); break;
    }
    return g->vol[e] * psi;
}

double defsim__elastic_energy(const defsim__system *s, defsim__work *wk, const double *x)
{
    double total = 0.0;
    for (int m = 0; m <= DEFSIM__TET_MODELS; ++m) {
        const defsim__group *g = &s->groups[m];
        if (g->n == 0) continue;
        const int32_t nb = (g->n + DEFSIM__REDUCE_BLOCK - 1) / DEFSIM__REDUCE_BLOCK;
        double *part = wk->partial;
#pragma omp parallel for schedule(static) num_threads(s->nthreads) if (nb > 1)
        for (int32_t b = 0; b < nb; ++b) {
            int32_t e1 = (b + 1) * DEFSIM__REDUCE_BLOCK < g->n ? (b + 1) * DEFSIM__REDUCE_BLOCK
                                                               : g->n;
            double sum = 0.0;
            for (int32_t e = b * DEFSIM__REDUCE_BLOCK; e < e1; ++e)
                sum += element_energy(g, x, e);
            part[b] = sum;
        }
        for (int32_t b = 0; b < nb; ++b) total += part[b];
    }
    const defsim__attachments *at = &s->att;
    for (int32_t e = 0; e < at->n; ++e) {
        double d[3];
        attach_combine(at, e, x, 1, d);
        total += 0.5 * at->k[e] * (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
    }
    return isnan(total) ? INFINITY : total;
}

double defsim__potential_energy(const defsim__system *s, defsim__work *wk, const double *x)
{
    double e = defsim__elastic_energy(s, wk, x);
    if (s->has_gravity) {
        const double *gr = s->gravity;
        double sum = 0.0;
        for (int32_t i = 0; i < s->nv; ++i)
            sum -= s->mass[i] * (gr[0] * x[3 * (int64_t)i] + gr[1] * x[3 * (int64_t)i + 1] +
                                 gr[2] * x[3 * (int64_t)i + 2]);
        e += sum;
    }
    return e;
}
