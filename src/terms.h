/* SPDX-License-Identifier: MIT */
/* The list of terms of a system (terms.c; the term interface is term.h): its compilation, the
 * step hooks over it, and the keys of the terms' linearisation caches. */
#ifndef DEFSIM_TERMS_H
#define DEFSIM_TERMS_H

#include "system.h"
#include "term_cache.h"

/* Recompiles s's list from what the scene uses (after a plan, and whenever the world attaches
 * or detaches contact, held forces or the callback) and invalidates the caches. */
defsim_status defsim__terms_compile(defsim__system *s);

/* Frees the caches (defsim__unplan). */
void defsim__terms_free(defsim__system *s);

/* The step hooks over the list (a step begins when the world attaches its contact state and
 * recompiles). */
void defsim__terms_substep(const defsim__system *s, double s0, double s1, double h);
void defsim__terms_step_end(const defsim__system *s);

/* The kinds' counters (term.h), in list order: how many there are (the same for every system),
 * and counter i's full name "<kind>.<counter>" and value, read from the kind's cache whether or
 * not its term is in s's list now. Either output may be NULL; 0 if i is out of range. */
int32_t defsim__terms_counter_count(void);
int defsim__terms_counter(const defsim__system *s, int32_t i, const char **name, double *value);

/* Zeroes the kinds' cumulative counters (defsim_world_reset_stats). */
void defsim__terms_reset_counters(defsim__system *s);

/* The options the kinds declare (term.h), in list order: writes up to cap pointers into out and
 * returns how many there are. */
int32_t defsim__terms_options(const defsim_option_spec **out, int32_t cap);

/* A term of kind `kind` outside the list, over s with mutable data `data` (NULL for kinds that
 * have none): what counters and checkpoints call a kind's ops with. */
defsim__term defsim__terms_detached(const defsim__system *s, int kind, void *data);

/* The first term of a kind, or NULL. */
const defsim__term *defsim__terms_find(const defsim__system *s, int kind);

#endif /* DEFSIM_TERMS_H */
