/* SPDX-License-Identifier: MIT */
/* Energies of a compiled system (energy.c). */
#ifndef DEFSIM_ENERGY_H
#define DEFSIM_ENERGY_H

#include "system.h"
#include "tet_forces.h"

/* Deterministic reductions sum fixed blocks of elements, then the blocks in order; the planner
 * sizes defsim__work.partial for the largest group. */
enum { DEFSIM__REDUCE_BLOCK = 2048 };

/* An element's energy at x (J). */
typedef double (*defsim__element_energy_fn)(const defsim__group *g, const double *x, int32_t e);

/* total plus group g's energy at x, summed as the reductions above (wk->partial holds the
 * blocks' sums). */
double defsim__group_energy(const defsim__system *s, defsim__work *wk, const defsim__group *g,
                            defsim__element_energy_fn energy, const double *x, double total);

/* total plus group g's energy at x by a batched kernel (tet_forces.h), as deterministic blocked
 * sums of DEFSIM__REDUCE_BLOCK / DEFSIM__BATCH batches each, then the blocks in order (the
 * planner sizes wk->partial for them, padding lanes counted). */
double defsim__group_batched_energy(const defsim__system *s, defsim__work *wk,
                                    const defsim__group *g, defsim__tet_energy_fn energy,
                                    const double *x, double total);

/* The energy op of an element group's kind (the term's model is its group), over the kind's
 * element energy: what the elastic and spring terms share. */
#define DEFSIM__GROUP_ENERGY_OP(element_energy)                                                    \
    static double energy(const defsim__term *t, const defsim__system *s, defsim__work *wk,        \
                         const double *x, double total)                                           \
    {                                                                                              \
        return defsim__group_energy(s, wk, t->model, element_energy, x, total);                    \
    }

/* An element's energy gradient dE/dX at x into grad (3 nodes values); returns 0 where it has
 * none (an undefined energy). */
typedef int (*defsim__element_gradient_fn)(const defsim__group *g, const double *x, int32_t e,
                                           double *grad);

/* f -= each element's gradient, colour by colour (elements of a colour share no vertex, so the
 * scatter needs no atomics): the force loop of kinds with a scalar element kernel (shells). */
void defsim__group_gradient_forces(const defsim__system *s, const defsim__group *g,
                                   defsim__element_gradient_fn gradient, const double *x,
                                   double *f);

/* The forces op of such a kind (the term's model is its group): elastic forces only. */
#define DEFSIM__GROUP_GRADIENT_FORCES_OP(element_gradient)                                       \
    static defsim_status forces(const defsim__term *t, const defsim__system *s,                   \
                                const defsim__eval *ev, double *f, uint32_t *used)                \
    {                                                                                             \
        if (!(ev->which & DEFSIM_FORCE_ELASTIC)) return DEFSIM_OK;                                \
        const defsim__group *g = t->model;                                                        \
        defsim__group_gradient_forces(s, g, element_gradient, ev->x, f);                          \
        *used |= g->pass;                                                                         \
        return DEFSIM_OK;                                                                         \
    }

/* Elastic energy at x (J), relative to rest; +INFINITY where undefined (an inverted
 * neo-Hookean element). */
double defsim__elastic_energy(const defsim__system *s, defsim__work *wk, const double *x);

/* Elastic plus every other term's energy at x (J): gravity, contact, held forces (relative to
 * the step's start), the callback's model in implicit steps. */
double defsim__potential_energy(const defsim__system *s, defsim__work *wk, const double *x);

#endif /* DEFSIM_ENERGY_H */
