/* SPDX-License-Identifier: MIT */
/* Status text and the thread-local message behind defsim_last_error(). */
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

#endif
