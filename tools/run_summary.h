/* SPDX-License-Identifier: MIT */
/* `defsim run --summary-json FILE`: one machine-readable record of how a run ended, for sweeps
 * (bindings/python/src/defsim/sweep.py) and scripts. The fields are listed in tools/README.md. */
#ifndef DEFSIM_TOOLS_RUN_SUMMARY_H
#define DEFSIM_TOOLS_RUN_SUMMARY_H

#include "scene.h"

#include <defsim/defsim.h>

#include <stddef.h>

typedef struct run_summary {
    const char *status;      /* "ok", "interrupted", or the failing step's status name */
    defsim_status step_status;   /* DEFSIM_OK unless a step failed */
    const char *message;     /* the library's detail of the failure, or "" */
    int frames;              /* frames completed after the initial state */
    double wall;             /* s, from the first step to the end (output included) */
    double stable_step;      /* s, estimated at the initial state; 0 if not estimated */
    defsim_energy start, end;
    const double *x;         /* final positions, 3 * vertex count */
} run_summary;

/* Writes the summary as JSON to `path`, at the end of the run (readers wait for the process to
 * exit). Numbers are printed with 17 significant digits: they parse back to the same doubles.
 * Returns 0, or -1 with `err` set. */
int run_summary_write(const char *path, const scene *s, const defsim_world *w,
                      const run_summary *r, char *err, size_t errsz);

#endif
