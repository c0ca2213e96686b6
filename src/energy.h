/* SPDX-License-Identifier: MIT */
/* Energies of a compiled system (energy.c). */
#ifndef DEFSIM_ENERGY_H
#define DEFSIM_ENERGY_H

#include "system.h"

/* Deterministic reductions sum fixed blocks of elements, then the blocks in order; the planner
 * sizes defsim__work.partial for the largest group. */
enum { DEFSIM__REDUCE_BLOCK = 2048 };

/* Elastic energy at x (J), relative to rest; +INFINITY where undefined (an inverted
 * neo-Hookean element). */
double defsim__elastic_energy(const defsim__system *s, defsim__work *wk, const double *x);

/* Elastic plus every other term's energy at x (J): gravity, contact, held forces (relative to
 * the step's start), the callback's model in implicit steps. */
double defsim__potential_energy(const defsim__system *s, defsim__work *wk, const double *x);

#endif /* DEFSIM_ENERGY_H */
