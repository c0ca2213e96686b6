/* SPDX-License-Identifier: MIT */
/* Stability of explicit steps (stability.c). */
#ifndef DEFSIM_STABILITY_H
#define DEFSIM_STABILITY_H

#include "system.h"

/* omega_max = sqrt(largest eigenvalue of M^-1 K(x)) over the free DOFs (rad/s), by power
 * iteration in the planner's workspace (no allocation); with penalty contact (a collider, active
 * or not), sqrt(omega_el^2 + (2.5 max(omega_c, omega_el))^2): Weyl's bound, with room for the
 * energy the penalty's switch feeds an explicit step. DEFSIM_ERR_UNSTABLE if not finite. */
defsim_status defsim__omega_max(const defsim__system *s, defsim__work *wk, const double *x,
                                double *omega);

/* The damping coefficient c = alpha + beta omega^2 of the stiffest mode (1/s): the largest
 * mass damping of a free DOF (or damping rate of an attachment's damper, or of penalty
 * contact's friction at positions x) and stiffness damping of an element. */
double defsim__damping_coeff(const defsim__system *s, const double *x, double omega);

#endif /* DEFSIM_STABILITY_H */
