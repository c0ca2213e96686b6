/* SPDX-License-Identifier: MIT */
/* Status text, the thread-local message behind defsim_last_error() and per-world messages. */
#ifndef DEFSIM_STATUS_H
#define DEFSIM_STATUS_H

#include "defsim/defsim.h"

#if defined(__GNUC__)
#  define DEFSIM_PRINTF(a, b) __attribute__((format(printf, a, b)))
#else
#  define DEFSIM_PRINTF(a, b)
#endif

/* Sets the message of defsim_last_error() for this thread (printf format). */
void defsim__set_last_error(const char *fmt, ...) DEFSIM_PRINTF(1, 2);
void defsim__clear_last_error(void);

/* The messages of one world: the text of its last failure and the host's log callback.
 * `locked` counts the host callbacks running now: the world refuses changes while it is not 0
 * (defsim__world_check_unlocked). Every call into a host function (log, force callback and its
 * Jacobian, and any later one such as a collider's SDF) increments it around the call. `in_log`: a message that the log
 * callback causes (a refused call from inside it) is recorded but not logged again. */
typedef struct defsim__messages {
    char error[512];
    void (*log)(void *user, int level, const char *message);
    void *log_user;
    int locked;
    int in_log;
} defsim__messages;

/* Sets the last error of m and logs it at level 0 (the log callback runs with the world locked;
 * m->error is restored after it, whatever the callback called). */
void defsim__error(defsim__messages *m, const char *fmt, ...) DEFSIM_PRINTF(2, 3);

/* Logs a message when the host gave a callback. */
void defsim__log(defsim__messages *m, int level, const char *fmt, ...) DEFSIM_PRINTF(3, 4);

#endif
