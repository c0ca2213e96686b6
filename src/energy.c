/* SPDX-License-Identifier: MIT */
/* Energies of a compiled system as loops over its terms (term.h) in the order of the energy
 * sums: the elastic terms' (element groups, springs, attachments), then the others' (gravity,
 * contact, held forces, the callback's model). Each term adds its deterministic blocked sums. */
#include "energy.h"

#include <math.h>

double defsim__elastic_energy(const defsim__system *s, defsim__work *wk, const double *x)
{
    double total = 0.0;
    for (int32_t k = 0; k < s->nenergy; ++k) {
        const defsim__term *t = &s->terms[s->energy_order[k]];
        if (t->ops->flags & DEFSIM__TERM_ELASTIC) total = t->ops->energy(t, s, wk, x, total);
    }
    return isnan(total) ? INFINITY : total;
}

double defsim__potential_energy(const defsim__system *s, defsim__work *wk, const double *x)
{
    double e = defsim__elastic_energy(s, wk, x);
    for (int32_t k = 0; k < s->nenergy; ++k) {
        const defsim__term *t = &s->terms[s->energy_order[k]];
        if (!(t->ops->flags & DEFSIM__TERM_ELASTIC)) e = t->ops->energy(t, s, wk, x, e);
    }
    return e;
}

double defsim__group_energy(const defsim__system *s, defsim__work *wk, const defsim__group *g,
                            defsim__element_energy_fn energy, const double *x, double total)
{
    const int32_t nb = (g->n + DEFSIM__REDUCE_BLOCK - 1) / DEFSIM__REDUCE_BLOCK;
    double *part = wk->partial;
    (void)s;   /* its thread count, for OpenMP only */
#pragma omp parallel for schedule(static) num_threads(s->nthreads) if (nb > 1)
    for (int32_t b = 0; b < nb; ++b) {
        int32_t e1 = (b + 1) * DEFSIM__REDUCE_BLOCK < g->n ? (b + 1) * DEFSIM__REDUCE_BLOCK : g->n;
        double sum = 0.0;
        for (int32_t e = b * DEFSIM__REDUCE_BLOCK; e < e1; ++e) sum += energy(g, x, e);
        part[b] = sum;
    }
    for (int32_t b = 0; b < nb; ++b) total += part[b];
    return total;
}

double defsim__group_batched_energy(const defsim__system *s, defsim__work *wk,
                                    const defsim__group *g, defsim__tet_energy_fn energy,
                                    const double *x, double total)
{
    const int32_t per = DEFSIM__REDUCE_BLOCK / DEFSIM__BATCH;
    const int32_t nb = (g->nbatch + per - 1) / per;
    double *part = wk->partial;
    (void)s;   /* its thread count, for OpenMP only */
#pragma omp parallel for schedule(static) num_threads(s->nthreads) if (nb > 1)
    for (int32_t b = 0; b < nb; ++b)
        part[b] = energy(g, x, b * per, (b + 1) * per < g->nbatch ? (b + 1) * per : g->nbatch);
    for (int32_t b = 0; b < nb; ++b) total += part[b];
    return total;
}

void defsim__group_gradient_forces(const defsim__system *s, const defsim__group *g,
                                   defsim__element_gradient_fn gradient, const double *x,
                                   double *f)
{
    const int nn = g->nodes;
    (void)s;   /* its thread count, for OpenMP only */
    for (int32_t c = 0; c < g->ncolors; ++c) {
        const int32_t e0 = g->color_ptr[c], e1 = g->color_ptr[c + 1];
#pragma omp parallel for schedule(static) num_threads(s->nthreads) if (e1 - e0 > 512)
        for (int32_t e = e0; e < e1; ++e) {
            double gr[12];
            if (!gradient(g, x, e, gr)) continue;
            const int32_t *id = g->idx + nn * (int64_t)e;
            for (int a = 0; a < nn; ++a)
                for (int i = 0; i < 3; ++i) f[3 * (int64_t)id[a] + i] -= gr[3 * a + i];
        }
    }
}
