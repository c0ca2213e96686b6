/* SPDX-License-Identifier: MIT */
/* What the term kinds share (term_cache.h): the one term a kind adds, and the linearisation
 * cache that contact terms keep their blocks in, its key (x, coefficients, epoch) and its
 * buffers. Apart from terms.c, so that the term files do not call the list that names them. */
#include "term_cache.h"

#include "system.h"

#include <stdlib.h>
#include <string.h>

int defsim__term_one(int on, const void *model, void *data, int32_t index, defsim__term *out)
{
    if (!on) return 0;
    memset(out, 0, sizeof *out);
    out->model = model;
    out->data = data;
    out->index = index;
    return 1;
}

int defsim__term_groups(defsim__system *s, int first, defsim__term *out)
{
    int n = 0;
    for (int m = first; m < first + DEFSIM__TET_MODELS; ++m)
        n += defsim__term_one(s->groups[m].n > 0, &s->groups[m], NULL, m, &out[n]);
    return n;
}

int defsim__term_contact(const struct defsim__system *s, int32_t nv, void *data,
                         defsim__term_cache *c, size_t bytes, defsim__term *out)
{
    if (!data) return 0;
    if (!defsim__cache_reserve(c, bytes, nv)) return -1;
    return defsim__term_one(1, s, data, 0, out);
}

int defsim__cache_hit(const defsim__term_cache *c, int32_t nv, const double *x,
                      const defsim_matrix_coeffs *k)
{
    return c->valid && c->nx >= nv && c->seen == c->epoch && c->k == k->k && c->kd == k->kd &&
           memcmp(c->x, x, 3 * (size_t)nv * sizeof *x) == 0;
}

void defsim__cache_store(defsim__term_cache *c, int32_t nv, const double *x,
                         const defsim_matrix_coeffs *k)
{
    memcpy(c->x, x, 3 * (size_t)nv * sizeof *x);
    c->k = k->k;
    c->kd = k->kd;
    c->seen = c->epoch;
    c->valid = 1;
    c->linearisations++;
}

int defsim__cache_reserve(defsim__term_cache *c, size_t bytes, int32_t nv)
{
    if (bytes > c->cap) {
        void *b = realloc(c->buf, bytes);
        if (!b) return 0;
        c->buf = b;
        c->cap = bytes;
    }
    if (nv > c->nx) {
        double *x = realloc(c->x, 3 * (size_t)nv * sizeof *x);
        if (!x) return 0;
        c->x = x;
        c->nx = nv;
    }
    return 1;
}
