/* SPDX-License-Identifier: MIT */
/* Energies of a compiled system: elastic (with attachment springs) and potential (with
 * gravity and contact), as deterministic blocked sums. */
#include "energy.h"

#include "body_contact.h"
#include "contact.h"
#include "element.h"
#include "material.h"

#include <math.h>

static double element_energy(const defsim__group *g, const double *x, int32_t e)
{
    if (g->nodes == 2)
        return defsim__model_spring.energy(x + 3 * (int64_t)g->idx[2 * (int64_t)e],
                                           x + 3 * (int64_t)g->idx[2 * (int64_t)e + 1], g->k[e],
                                           g->l0[e]);
    double F[9];
    tet_deformation(x, g->idx + 4 * (int64_t)e, g->dminv + 9 * (int64_t)e, F);
    const double mu = g->mu[e], la = g->lambda[e];
    double psi = g->law->psi(mu, la, F);
    if (g->law->psi_rest) psi -= g->law->psi_rest(mu, la);
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
    if (s->contact) e += defsim__contact_energy(s->contact, x);
    if (s->body_contact) e += defsim__body_contact_energy(s->body_contact, x);
    return e;
}
