/* SPDX-License-Identifier: MIT */
/* The tools' read of a backend counter by name (the library lists them as "<backend>.<name>"
 * after the fields of defsim_stats; issue 24 took them out of the struct). */
#ifndef DEFSIM_TOOLS_STAT_H
#define DEFSIM_TOOLS_STAT_H

#include <defsim/defsim.h>

#include <string.h>

/* The counter `leaf` of w's backend ("newton_iterations", "internal_steps"): the first
 * statistic named "<prefix>.<leaf>" in the listing, where the backend's counters precede
 * contact's and the term kinds'; 0 when the backend counts no such thing. */
static inline double tools_backend_stat(const defsim_world *w, const char *leaf)
{
    for (int32_t i = 0; i < defsim_world_stat_count(w); ++i) {
        const char *name = NULL;
        double v = 0.0;
        if (defsim_world_stat_info(w, i, &name, &v) != DEFSIM_OK) continue;
        const char *dot = strchr(name, '.');
        if (dot && strcmp(dot + 1, leaf) == 0) return v;
    }
    return 0.0;
}

#endif
