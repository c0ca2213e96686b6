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

/* A world's step through the kinds' step hooks and the terms' (term.h), in the step's order:
 * step_begin runs the begins (in list order, each while the last succeeded) and compiles the
 * list again when one changed what it is compiled from; restart begins again after a
 * rolled-back attempt; substep_before and _after bracket the backend's call i of n (the
 * kinds' before, then the terms' substep over the fraction [i/n, (i+1)/n] of c->h); finish
 * closes the backend's calls (the kinds' finish, then the terms' step_end) and returns the
 * step's status; work sums the terms' work over x0 -> x1 (and with start their energy at x0)
 * for the watchdog, returning 0 if no term has any; step_end detaches what the begins attached
 * (the list compiled again), runs the ends in reverse list order and the read-backs in list
 * order, and returns the step's status. detach only detaches (after a stable step's estimate or
 * a replay, which begin with h = 0). The hooks that take a status get the step's so far and
 * return it (or their own failure). */
defsim_status defsim__terms_step_begin(defsim__system *s, const defsim__step_ctx *c);
defsim_status defsim__terms_restart(defsim__system *s, const defsim__step_ctx *c);
void defsim__terms_substep_before(const defsim__system *s, const defsim__step_ctx *c, int64_t i,
                                  int64_t n);
void defsim__terms_substep_after(const defsim__step_ctx *c);
defsim_status defsim__terms_finish(defsim__system *s, const defsim__step_ctx *c, defsim_status st);
int defsim__terms_work(const defsim__system *s, const double *x0, const double *x1, int start,
                       double *e0, double *work);
defsim_status defsim__terms_step_end(defsim__system *s, const defsim__step_ctx *c,
                                     defsim_status st);
defsim_status defsim__terms_detach(defsim__system *s);

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
