/* SPDX-License-Identifier: MIT */
/* Sparse matrices of a compiled system (assembly.c). */
#ifndef DEFSIM_ASSEMBLY_H
#define DEFSIM_ASSEMBLY_H

#include "system.h"

/* Builds the sparse pattern and the element node-pair ranks (idempotent). Returns
 * DEFSIM_ERR_OUT_OF_MEMORY on failure (what was built is freed with the plan). */
defsim_status defsim__pattern_build(defsim__system *s);

/* Adds the free-vertex pairs (fa << 32 | fb, fa < fb) that are not in the pattern yet (body
 * contact) and rebuilds it if any was new (*grew = 1; the version grows, every pointer into the
 * pattern and the element ranks changes). Returns DEFSIM_ERR_OUT_OF_MEMORY on failure (then
 * the pattern is not built: the plan must be dropped). */
defsim_status defsim__pattern_grow(defsim__system *s, const int64_t *pairs, int64_t n,
                                   int *grew);

/* The pattern in compressed sparse columns (borrowed from s). DEFSIM_ERR_INVALID_ARGUMENT
 * for a bad triangle or before defsim__pattern_build. */
defsim_status defsim__matrix_pattern(const defsim__system *s, defsim_triangle tri,
                                     defsim_csc *out);

/* Values of A = m M + md alpha M + k K(x) + kd B(x) in the pattern of `tri`; ORs
 * DEFSIM_PASS_HESSIAN into *passes (may be NULL) when elements contributed. */
defsim_status defsim__matrix_values(const defsim__system *s, const double *x,
                                    const defsim_matrix_coeffs *c, defsim_triangle tri,
                                    double *values, uint32_t *passes);

/* out = A dx over all DOFs (pinned rows and columns zero), element Hessians projected with
 * `proj` (a defsim_projection). */
void defsim__matrix_apply(const defsim__system *s, const double *x,
                          const defsim_matrix_coeffs *c, int proj, const double *dx, double *out);

/* defsim__matrix_apply with the system's projection. */
defsim_status defsim__matrix_product(const defsim__system *s, const double *x,
                                     const defsim_matrix_coeffs *c, const double *dx,
                                     double *out);

#endif /* DEFSIM_ASSEMBLY_H */
