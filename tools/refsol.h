/* SPDX-License-Identifier: MIT */
/*
 * Reference solutions of the work-precision benchmark: integrating a world with sundials_ida to a
 * time T, and the text file that holds the result (format in tools/reference.c). Shared by
 * defsim-reference (the built-in cantilever) and `defsim bench` (any scene).
 */
#ifndef DEFSIM_TOOLS_REFSOL_H
#define DEFSIM_TOOLS_REFSOL_H

#include <defsim/defsim.h>

#include <stdint.h>
#include <stdio.h>

/* The state at T and how it was obtained. */
typedef struct refsol {
    double end_time;          /* s */
    double rtol, atol;
    int64_t internal_steps;
    double wall_seconds;      /* of the integration only */
    defsim_energy energy;     /* at end_time */
    int32_t vertex_count;
    double *x, *v;            /* 3 vertex_count each (m, m/s); owned, freed by refsol_free */
} refsol;

/* Advances `w` (whose backend is normally sundials_ida) from its current time to exactly T in
 * `calls` calls of defsim_world_step (IDA keeps its history across them), then fills *out
 * (end time, statistics, energy, state). With `tag` non-NULL, progress goes to stderr every
 * tenth of the calls, prefixed with it. Returns DEFSIM_OK or the failing step's status (message
 * on stderr); *out is then empty. */
defsim_status refsol_integrate(defsim_world *w, double T, int calls, double rtol, double atol,
                               const char *tag, refsol *out);

/* Writes the common part of the file (end_time .. the vertex lines) to f. The caller writes the
 * first line ("defsim-reference 1") and its own description lines before it. Returns 0, or -1
 * on a write error. */
int refsol_write_tail(FILE *f, const refsol *r);

/* Reads a reference file: the common keys above, any other "key value" line before "vertices"
 * is skipped. Returns 0, or -1 with a message in err (size errlen). */
int refsol_read(const char *path, refsol *out, char *err, size_t errlen);

void refsol_free(refsol *r);

#endif
