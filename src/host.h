/* SPDX-License-Identifier: MIT */
/*
 * What a backend's `defsim_system *` points to (backend.h keeps the type opaque): the compiled
 * system and, beside it, the mutable things the host services hand out or update (state,
 * workspaces, statistics, messages). The world embeds one and points it at its own parts.
 */
#ifndef DEFSIM_HOST_H
#define DEFSIM_HOST_H

#include "options.h"
#include "status.h"
#include "system.h"

/* The state a backend advances. */
typedef struct defsim__state {
    double *x, *v;            /* 3 nv */
    double t;                 /* s */
} defsim__state;

struct defsim_system {
    defsim__system *sys;      /* built by plan.c; host services build its pattern on demand */
    defsim__work *work;
    defsim__state *state;
    const defsim_world_def *def;
    defsim_stats *stats;
    uint32_t *passes;         /* DEFSIM_PASS_* of the current step */
    defsim__messages *msg;
    defsim__options *options; /* option values and counters by name */
};

/* The host service table handed to backends. */
extern const defsim_host defsim__host;

#endif /* DEFSIM_HOST_H */
