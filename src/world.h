/* SPDX-License-Identifier: MIT */
/*
 * Private layout of a world: what the host made (bodies, ids, the state x, v, t), the compiled
 * system (system.h, rebuilt by plan.c after a change) with its workspaces, and the backend with
 * its host-allocated state. The world keeps MuJoCo's split: bodies hold what is constant during
 * simulation as the host gave it, the system is what they compile to.
 */
#ifndef DEFSIM_WORLD_H
#define DEFSIM_WORLD_H

#include "body.h"
#include "host.h"
#include "status.h"
#include "system.h"
#include "options.h"

#include <stdint.h>

struct defsim_world {
    defsim_world_def def;
    char backend_name[64];
    const defsim_backend *backend;
    void *bstate;
    defsim__options options;  /* options and counters by name (options.c) */
    int backend_ready;        /* init succeeded for the current plan */
    int planned;              /* sys and work match the bodies */
    defsim__messages *msg;    /* allocated: const getters may report errors */

    defsim__body *bodies;
    int32_t nbodies, cap_bodies;

    /* state and per-vertex data (rebuilt on add/remove; state carried over) */
    int32_t nv;
    defsim__state state;      /* x, v: 3 nv; t */
    double *mass;             /* nv */
    uint8_t *pinned;          /* nv */
    double *x_save, *v_save;  /* 3 nv: the state at the start of a step, for roll-back */

    defsim__system sys;
    defsim__work work;
    defsim_system handle;     /* what backends receive: points at sys, work, state, stats */

    int32_t nthreads;
    double h_stable;          /* auto_substep: cached estimate, 0 when stale */
    int32_t steps_since_estimate;
    defsim_stats stats;
    uint32_t step_passes;
};

/* Plans the world if it is not planned (a cache of the bodies, not a change of state).
 * Returns DEFSIM_OK or DEFSIM_ERR_OUT_OF_MEMORY (with the world's error set). */
defsim_status defsim__world_plan(defsim_world *w);
/* Drops the compiled system; the next step or query plans again. */
void defsim__world_unplan(defsim_world *w);

#endif
