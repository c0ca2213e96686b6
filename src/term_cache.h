/* SPDX-License-Identifier: MIT */
/* The linearisation cache of a term (defsim__term_cache, term.h): whether it holds the blocks at
 * x, storing its key, growing its buffers (term_cache.c). */
#ifndef DEFSIM_TERM_CACHE_H
#define DEFSIM_TERM_CACHE_H

#include "term.h"

/* Whether the cache holds the blocks at x for the coefficients' k and kd and its epoch. */
int defsim__cache_hit(const defsim__term_cache *c, int32_t nv, const double *x,
                      const defsim_matrix_coeffs *k);
/* Makes (x, k, kd, epoch) the cache's key (valid); the x buffer is the one compile reserved. */
void defsim__cache_store(defsim__term_cache *c, int32_t nv, const double *x,
                         const defsim_matrix_coeffs *k);
/* Grows c->buf to at least `bytes` and c->x to nv vertices; 0 when out of memory. */
int defsim__cache_reserve(defsim__term_cache *c, size_t bytes, int32_t nv);

#endif /* DEFSIM_TERM_CACHE_H */
