/* SPDX-License-Identifier: MIT */
/* Material parameters: Lame conversion and validation (private). */
#ifndef DEFSIM_MATERIAL_H
#define DEFSIM_MATERIAL_H

#include <stddef.h>

#include "defsim/defsim.h"

/* Lame parameters of Young's modulus E and Poisson ratio nu (DESIGN.md section 4):
 * mu = E/(2(1+nu)), lambda = E nu/((1+nu)(1-2nu)). */
void defsim__lame(double E, double nu, double *mu, double *lambda);

/* Validates a material for a body that has tets and/or springs. Returns DEFSIM_OK,
 * DEFSIM_ERR_INVALID_ARGUMENT (NULL, size smaller than sizeof(defsim_material)) or
 * DEFSIM_ERR_INVALID_MATERIAL (unknown model, tets with the spring model, or a field out of
 * range; tet-model fields are checked whenever the model is a tet model, the stiffness when the
 * body has springs or the model is the spring model). On error, writes a message naming the field
 * and its value into msg (msg may be NULL or msg_size 0); on success writes "". Sets no error
 * state of its own. Thread-safe. */
defsim_status defsim__material_check(const defsim_material *m, int has_tets, int has_springs,
                                     char *msg, size_t msg_size);

#endif /* DEFSIM_MATERIAL_H */
