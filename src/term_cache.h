/* SPDX-License-Identifier: MIT */
/* What the term kinds share below the list that names them (term_cache.c): the one term a kind
 * adds, and the linearisation cache (defsim__term_cache, term.h): whether it holds the blocks at
 * x, storing its key, growing its buffers. */
#ifndef DEFSIM_TERM_CACHE_H
#define DEFSIM_TERM_CACHE_H

#include "term.h"

/* A kind's compile for the common case, one term or none: when `on`, writes the term with its
 * model, data and index into out and returns 1; else returns 0. */
int defsim__term_one(int on, const void *model, void *data, int32_t index, defsim__term *out);

/* The compile of a tet-model kind (elastic, elastic_quadratic, quadratic_mixed): one term per
 * non-empty group among s->groups[first .. first + DEFSIM__TET_MODELS), model the group and
 * index its place in s->groups; returns how many. */
int defsim__term_groups(struct defsim__system *s, int first, defsim__term *out);

/* The compile of a contact kind (collider, body contact): the one term over the system s
 * (nv vertices) with the contact state that a step's begin attached, `data`, and the kind's
 * cache c made room for `bytes` of blocks; 0 when nothing is attached, -1 when out of memory. */
int defsim__term_contact(const struct defsim__system *s, int32_t nv, void *data,
                         defsim__term_cache *c, size_t bytes, defsim__term *out);

/* Whether the cache holds the blocks at x for the coefficients' k and kd and its epoch. */
int defsim__cache_hit(const defsim__term_cache *c, int32_t nv, const double *x,
                      const defsim_matrix_coeffs *k);
/* Makes (x, k, kd, epoch) the cache's key (valid); the x buffer is the one compile reserved. */
void defsim__cache_store(defsim__term_cache *c, int32_t nv, const double *x,
                         const defsim_matrix_coeffs *k);
/* Grows c->buf to at least `bytes` and c->x to nv vertices; 0 when out of memory. */
int defsim__cache_reserve(defsim__term_cache *c, size_t bytes, int32_t nv);

#endif /* DEFSIM_TERM_CACHE_H */
