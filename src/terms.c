/* SPDX-License-Identifier: MIT */
/* The list of terms of a system (terms.h; term.h): compiled from term_list.h, with the orders of the
 * energy and matrix sums, the step hooks over it (the kinds' and the terms'), and the
 * linearisation caches' keys. */
#include "terms.h"

#include <stdlib.h>
#include <string.h>

#define DEFSIM__TERM_DECLARE(name) extern const defsim__term_ops defsim__term_##name;
DEFSIM__TERM_LIST(DEFSIM__TERM_DECLARE)
#undef DEFSIM__TERM_DECLARE

#define DEFSIM__TERM_ENTRY(name) &defsim__term_##name,
static const defsim__term_ops *const kinds[DEFSIM__TERM_KINDS] = {
    DEFSIM__TERM_LIST(DEFSIM__TERM_ENTRY)};
#undef DEFSIM__TERM_ENTRY

/* Indices of the terms that have an op, by rank then list position (a stable order). */
static int32_t order(const defsim__system *s, int matrix, uint8_t *out)
{
    int32_t n = 0;
    for (int r = 0; r < 128; ++r)
        for (int32_t i = 0; i < s->nterms; ++i) {
            const defsim__term_ops *o = s->terms[i].ops;
            const int has = matrix ? (o->values || o->apply) : o->energy != NULL;
            if (has && (matrix ? o->matrix_rank : o->energy_rank) == r) out[n++] = (uint8_t)i;
        }
    return n;
}

defsim_status defsim__terms_compile(defsim__system *s)
{
    s->nterms = 0;
    for (int k = 0; k < DEFSIM__TERM_KINDS; ++k) {
        defsim__term *out = s->terms + s->nterms;
        const int n = kinds[k]->compile(s, out);
        if (n < 0) {
            s->nterms = s->nenergy = s->nmatrix = 0;
            return DEFSIM_ERR_OUT_OF_MEMORY;
        }
        for (int i = 0; i < n; ++i) {
            out[i].ops = kinds[k];
            out[i].cache = &s->cache[k];
        }
        s->nterms += n;
    }
    s->nenergy = order(s, 0, s->energy_order);
    s->nmatrix = order(s, 1, s->matrix_order);
    for (int k = 0; k < DEFSIM__TERM_KINDS; ++k) s->cache[k].valid = s->cache[k].any = 0;
    return DEFSIM_OK;
}

void defsim__terms_free(defsim__system *s)
{
    for (int k = 0; k < DEFSIM__TERM_KINDS; ++k) {
        free(s->cache[k].buf);
        free(s->cache[k].x);
        memset(&s->cache[k], 0, sizeof s->cache[k]);
    }
    s->nterms = s->nenergy = s->nmatrix = 0;
}

/* The list compiled again for what the kinds' hooks attached or detached (a failed hook's
 * status wins over the compilation's). */
static defsim_status relist(defsim__system *s, int changed, defsim_status st)
{
    if (!changed) return st;
    const defsim_status ct = defsim__terms_compile(s);
    return st == DEFSIM_OK ? ct : st;
}

/* What kind k attached to s (NULL: nothing, or a kind that attaches nothing). */
static void *attached(const defsim__system *s, int k)
{
    return kinds[k]->attached ? kinds[k]->attached(s) : NULL;
}

defsim_status defsim__terms_step_begin(defsim__system *s, const defsim__step_ctx *c)
{
    defsim_status st = DEFSIM_OK;
    int changed = 0;
    for (int k = 0; k < DEFSIM__TERM_KINDS && st == DEFSIM_OK; ++k) {
        if (!kinds[k]->begin) continue;
        const void *was = attached(s, k);
        st = kinds[k]->begin(s, c);
        changed |= attached(s, k) != was;
    }
    return relist(s, changed, st);
}

defsim_status defsim__terms_restart(defsim__system *s, const defsim__step_ctx *c)
{
    defsim_status st = DEFSIM_OK;
    for (int k = 0; k < DEFSIM__TERM_KINDS && st == DEFSIM_OK; ++k)
        if (kinds[k]->restart) st = kinds[k]->restart(s, c);
    return st;
}

void defsim__terms_substep_before(const defsim__system *s, const defsim__step_ctx *c, int64_t i,
                                  int64_t n)
{
    for (int k = 0; k < DEFSIM__TERM_KINDS; ++k)
        if (kinds[k]->before) kinds[k]->before(c, i, n);
    const double s0 = (double)i / (double)n, s1 = (double)(i + 1) / (double)n;
    for (int32_t j = 0; j < s->nterms; ++j)
        if (s->terms[j].ops->substep)
            s->terms[j].ops->substep(&s->terms[j], s0, s1, c->h / (double)n);
}

void defsim__terms_substep_after(const defsim__step_ctx *c)
{
    for (int k = 0; k < DEFSIM__TERM_KINDS; ++k)
        if (kinds[k]->after) kinds[k]->after(c);
}

defsim_status defsim__terms_finish(defsim__system *s, const defsim__step_ctx *c, defsim_status st)
{
    for (int k = 0; k < DEFSIM__TERM_KINDS; ++k)
        if (kinds[k]->finish) st = kinds[k]->finish(s, c, st);
    for (int32_t i = 0; i < s->nterms; ++i)
        if (s->terms[i].ops->step_end) s->terms[i].ops->step_end(&s->terms[i]);
    return st;
}

int defsim__terms_work(const defsim__system *s, const double *x0, const double *x1, int start,
                       double *e0, double *work)
{
    int any = 0;
    for (int32_t i = 0; i < s->nterms; ++i)
        if (s->terms[i].ops->work)
            any |= s->terms[i].ops->work(&s->terms[i], x0, x1, start, e0, work);
    return any;
}

/* Takes back what the kinds' begins attached into was[] and compiles the list again if any. */
static int detach(defsim__system *s, void *was[DEFSIM__TERM_KINDS])
{
    int any = 0;
    for (int k = 0; k < DEFSIM__TERM_KINDS; ++k) {
        was[k] = attached(s, k);
        if (was[k]) kinds[k]->detach(s);
        any |= was[k] != NULL;
    }
    return any;
}

defsim_status defsim__terms_detach(defsim__system *s)
{
    void *was[DEFSIM__TERM_KINDS];
    return relist(s, detach(s, was), DEFSIM_OK);
}

defsim_status defsim__terms_step_end(defsim__system *s, const defsim__step_ctx *c, defsim_status st)
{
    void *was[DEFSIM__TERM_KINDS];
    st = relist(s, detach(s, was), st);
    for (int k = DEFSIM__TERM_KINDS - 1; k >= 0; --k)
        if (kinds[k]->end) st = kinds[k]->end(s, c, was[k], st);
    for (int k = 0; k < DEFSIM__TERM_KINDS; ++k)
        if (kinds[k]->readback) st = kinds[k]->readback(s, c, was[k], st);
    return st;
}

int32_t defsim__terms_counter_count(void)
{
    int32_t n = 0;
    for (int k = 0; k < DEFSIM__TERM_KINDS; ++k) n += kinds[k]->counter_count;
    return n;
}

int defsim__terms_counter(const defsim__system *s, int32_t i, const char **name, double *value)
{
    for (int k = 0; k < DEFSIM__TERM_KINDS && i >= 0; ++k) {
        if (i >= kinds[k]->counter_count) {
            i -= kinds[k]->counter_count;
            continue;
        }
        if (name) *name = kinds[k]->counters[i];
        /* the kind's counters live in its cache, which outlives its term */
        const defsim__term t = defsim__terms_detached(s, k, NULL);
        if (value) *value = kinds[k]->counter(&t, i);
        return 1;
    }
    return 0;
}

void defsim__terms_reset_counters(defsim__system *s)
{
    for (int k = 0; k < DEFSIM__TERM_KINDS; ++k) s->cache[k].linearisations = 0;
}

int32_t defsim__terms_options(const defsim_option_spec **out, int32_t cap)
{
    int32_t n = 0;
    for (int k = 0; k < DEFSIM__TERM_KINDS; ++k)
        for (int32_t i = 0; i < kinds[k]->option_count; ++i, ++n)
            if (n < cap) out[n] = &kinds[k]->options[i];
    return n;
}

defsim__term defsim__terms_detached(const defsim__system *s, int kind, void *data)
{
    /* the cache belongs to the system, which is const to its readers but not to a kind's ops */
    return (defsim__term){kinds[kind], s, data, (defsim__term_cache *)&s->cache[kind], 0};
}

const defsim__term *defsim__terms_find(const defsim__system *s, int kind)
{
    for (int32_t i = 0; i < s->nterms; ++i)
        if (s->terms[i].ops == kinds[kind]) return &s->terms[i];
    return NULL;
}
