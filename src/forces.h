/* SPDX-License-Identifier: MIT */
/* Forces of a compiled system (forces.c). */
#ifndef DEFSIM_FORCES_H
#define DEFSIM_FORCES_H

#include "system.h"

/* Internal force flag: leave pinned DOFs their force (defsim_world_forces). */
#define DEFSIM__FORCE_KEEP_PINNED (1u << 8)

/* f = the forces at (x, v) and time t of the terms (term.h), selected by `which` (DEFSIM_FORCE_*
 * bits, DEFSIM__FORCE_KEEP_PINNED); v may be NULL without DEFSIM_FORCE_DAMPING (the force
 * callback then sees the state's). ORs the passes that ran into *passes (may be NULL). Returns
 * DEFSIM_ERR_UNSTABLE if f is not finite, or the failure of a term (contact, the callback). */
defsim_status defsim__forces_at(const defsim__system *s, const double *x, const double *v,
                                double t, uint32_t which, double *f, uint32_t *passes);

/* defsim__forces_at at time 0 (for what a force callback does not see: DEFSIM_FORCE_ELASTIC,
 * DEFSIM_FORCE_DAMPING, or a system without one). */
defsim_status defsim__forces(const defsim__system *s, const double *x, const double *v,
                             uint32_t which, double *f, uint32_t *passes);

#endif /* DEFSIM_FORCES_H */
