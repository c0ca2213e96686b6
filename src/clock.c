/* SPDX-License-Identifier: MIT */
/* The one clock of the library: timings of stats and the host's wall_time service. */
#include "clock.h"

#include <time.h>

double defsim__now(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}
