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
