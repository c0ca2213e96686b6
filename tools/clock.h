/* SPDX-License-Identifier: MIT */
/* The tools' one clock (the library's is defsim__now in src/clock.c, not exported). */
#ifndef DEFSIM_TOOLS_CLOCK_H
#define DEFSIM_TOOLS_CLOCK_H

#include <time.h>

/* Seconds on the monotonic clock: for durations only, not wall time. */
static inline double tools_now(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

/* Seconds of CPU time used by this process (all threads): for benchmarks on a loaded machine,
 * where time spent waiting for a core should not count. */
static inline double tools_cpu_now(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

#endif
