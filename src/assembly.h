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

/* Drops the extra pairs (those body contact added) that are not among `keep` (same encoding,
 * sorted and unique), and rebuilds the pattern, when more than `stale` of the extras would go
 * (a fraction in [0, 1]); *pruned is set when it rebuilt. Bounds the pattern by the contacts of
 * the present instead of every contact of the run. */
defsim_status defsim__pattern_retain(defsim__system *s, const int64_t *keep, int64_t n,
                                     double stale, int *pruned);

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
 * `proj` (a defsim_projection). Terms that cache their blocks (contact) linearise first only if
 * x or the coefficients changed since they last did. */
void defsim__matrix_apply(const defsim__system *s, const double *x,
                          const defsim_matrix_coeffs *c, int proj, const double *dx, double *out);

/* defsim__matrix_apply without the terms whose kind has a flag in `skip` (DEFSIM__TERM_*). */
void defsim__matrix_apply_skip(const defsim__system *s, const double *x,
                               const defsim_matrix_coeffs *c, int proj, uint32_t skip,
                               const double *dx, double *out);

/* defsim__matrix_apply with the system's projection, after every term linearised at x as a
 * product asks (DEFSIM__LIN_PRODUCT: the force callback's Jacobian is evaluated again). */
defsim_status defsim__matrix_product(const defsim__system *s, const double *x,
                                     const defsim_matrix_coeffs *c, const double *dx,
                                     double *out);

/* Helpers of the terms' pattern and values. */

/* Visits the free-vertex pairs of n elements of `nodes` vertices each (idx, -1: unused node):
 * counts pair (fa, fb) in pos[fa + 1] (list NULL) or appends fb to fa's list at pos[fa]. */
void defsim__element_pairs(const defsim__system *s, const int32_t *idx, int nodes, int64_t n,
                           int64_t *pos, int32_t *list);

/* The rank of node a's free vertex in node b's neighbour list, per element and node pair
 * ((nodes e + a) nodes + b; -1: unused or pinned), in a new array (NULL: out of memory). */
int32_t *defsim__element_ranks(const defsim__system *s, const int32_t *idx, int nodes,
                               int64_t n);

/* The pattern ops of an element group's term (elastic, spring: model the group, index its place
 * in s->groups): its elements' pairs, and their ranks into the group's blk (replacing what it
 * held; DEFSIM_ERR_OUT_OF_MEMORY when they do not fit). */
void defsim__group_pairs(const defsim__term *t, const defsim__system *s, int64_t *pos,
                         int32_t *list);
defsim_status defsim__group_ranks(const defsim__term *t, defsim__system *s);

/* Adds the element matrix K (3 nn x 3 nn, row-major) of the element with vertices id and
 * ranks blk into the values. */
void defsim__element_scatter(const defsim__system *s, const int32_t *id, const int32_t *blk,
                             int nn, const double *K, int upper, const int64_t *cp,
                             double *values);

/* The most DOFs of an element matrix (a quadratic tet's 30). */
enum { DEFSIM__ELEMENT_DOFS_MAX = 30 };

/* The element matrix k K + kd B of element e of group g at x into K (3 nn x 3 nn), with its
 * coefficients sk = k and sd = kd beta_e, not both zero (the group's loops skip those); returns
 * 0 when the element adds nothing. */
typedef int (*defsim__element_matrix_fn)(const defsim__system *s, const defsim__group *g,
                                         const double *x, int32_t e, double sk, double sd,
                                         double *K);

/* Adds the element matrices of group g (at most 10 nodes per element) into the values, colour by
 * colour (elements of a colour share no vertex, so no two threads write one entry), and
 * DEFSIM_PASS_HESSIAN into *passes (may be NULL); nothing when k and kd are both zero. */
void defsim__group_values(const defsim__system *s, const defsim__group *g,
                          defsim__element_matrix_fn matrix, const double *x,
                          const defsim_matrix_coeffs *c, int upper, const int64_t *cp,
                          double *values, uint32_t *passes);

/* out += an element's share of (k K + kd B) dx at x, with sk and sd as above (pinned rows and
 * columns zero; element Hessians projected with proj). */
typedef void (*defsim__element_apply_fn)(const defsim__group *g, const double *x, int32_t e,
                                         double sk, double sd, int proj, const uint8_t *pinned,
                                         const double *dx, double *out);

/* out += sk H u for one element of nn nodes (ids id) with its dense matrix H (3 nn x 3 nn),
 * u = dx on its free nodes (pinned rows and columns zero). */
void defsim__element_product(const int32_t *id, int nn, const double *H, double sk,
                             const uint8_t *pinned, const double *dx, double *out);

/* The matrix-free product of group g's elements, colour by colour as defsim__group_values:
 * nothing when k and kd are both zero. */
void defsim__group_apply(const defsim__system *s, const defsim__group *g,
                         defsim__element_apply_fn apply, const double *x,
                         const defsim_matrix_coeffs *c, int proj, const double *dx, double *out);

/* The values and apply ops of an element group's kind (the term's model is its group): the
 * group's loops over the kind's element kernels, which the elastic and spring terms share. */
#define DEFSIM__GROUP_MATRIX_OPS(element_matrix, element_apply)                                    \
    static void values(const defsim__term *t, const defsim__system *s, const double *x,            \
                       const defsim_matrix_coeffs *c, int upper, const int64_t *cp, double *val,  \
                       uint32_t *passes)                                                          \
    {                                                                                              \
        defsim__group_values(s, t->model, element_matrix, x, c, upper, cp, val, passes);           \
    }                                                                                              \
    static void apply(const defsim__term *t, const defsim__system *s, const double *x,             \
                      const defsim_matrix_coeffs *c, int proj, const double *dx, double *out)      \
    {                                                                                              \
        defsim__group_apply(s, t->model, element_apply, x, c, proj, dx, out);                      \
    }

/* The values and apply ops of a kind with a diagonal op (term.h), its symmetric 3x3 blocks B
 * per vertex times their factor f: values adds f B to the diagonal blocks of the values, apply
 * adds f B dx to out (pinned vertices none). DEFSIM__TERM_DIAGONAL fills the three ops, for
 * kind files that name their diagonal op `diagonal`. */
void defsim__diagonal_values(const defsim__term *t, const defsim__system *s, const double *x,
                             const defsim_matrix_coeffs *c, int upper, const int64_t *cp,
                             double *values, uint32_t *passes);
void defsim__diagonal_apply(const defsim__term *t, const defsim__system *s, const double *x,
                            const defsim_matrix_coeffs *c, int proj, const double *dx,
                            double *out);
#define DEFSIM__TERM_DIAGONAL                                                                  \
    .values = defsim__diagonal_values, .apply = defsim__diagonal_apply, .diagonal = diagonal

#endif /* DEFSIM_ASSEMBLY_H */
