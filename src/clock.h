/* SPDX-License-Identifier: MIT */
/* The one clock of the library (clock.c). */
#ifndef DEFSIM_CLOCK_H
#define DEFSIM_CLOCK_H

/* Monotonic wall time in seconds (for timings only; never for numerics). */
double defsim__now(void);

#endif /* DEFSIM_CLOCK_H */
