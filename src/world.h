/* SPDX-License-Identifier: MIT */
/*
 * Private layout of a world, as the sub-objects it owns (Box2D v3's world): the backend slot
 * (table and host-allocated state), the body set (bodies, their ids, per-vertex masses and
 * pins), the state x, v, t and the step's own (roll-back copy, auto_substep cache), the compiled
 * system (system.h, rebuilt by plan.c after a change) with its workspaces and the handle
 * backends receive, the coupling set, the collider set, the watchdog, collider and body contact,
 * and the options with their resolved settings. The world keeps MuJoCo's split: bodies hold
 * what is constant during simulation as the host gave it, the system is what they compile to.
 */
#ifndef DEFSIM_WORLD_H
#define DEFSIM_WORLD_H

#include "body.h"
#include "body_contact.h"
#include "collider.h"
#include "contact.h"
#include "coupling_set.h"
#include "host.h"
#include "id_pool.h"
#include "status.h"
#include "system.h"
#include "options.h"
#include "watchdog.h"

#include <stdint.h>

/* A world starts with a magic number: a best-effort check of the pointer, SQLite's way. Ids
 * carry the world's tag (body.h), the same in each of its id pools. */
#define DEFSIM__WORLD_MAGIC 0x64736d77u      /* "dsmw" */
#define DEFSIM__WORLD_DEAD 0x64656164u       /* "dead": set by defsim_world_destroy */

/* The backend slot: the backend's table, the state the host allocates for it (state_size
 * bytes), and whether its init ran for the current plan. */
typedef struct defsim__backend_slot {
    char name[64];
    const defsim_backend *table;
    void *state;
    int ready;                /* init succeeded for the current plan */
    uint64_t drops;           /* inits and resets: the backend's history dropped (tape.c) */
} defsim__backend_slot;

/* The bodies, a sub-object of the world: the bodies in vertex order with their ids, and their
 * per-vertex data in world order (rebuilt on add and remove). */
typedef struct defsim__body_set {
    defsim__body *b;          /* live bodies in vertex order (and, during a removal, the one
                                 going, with an even generation) */
    int32_t n, cap;
    defsim__id_pool ids;      /* the bodies' ids (id_pool.h): slot -> index into b */
    double *mass;             /* nv */
    uint8_t *pinned;          /* nv */
} defsim__body_set;

/* What a step keeps beside the state: the state at its start (for roll-back), auto_substep's
 * cached stable step, the passes that ran, whether body contact was on. */
typedef struct defsim__step_state {
    double *x_save, *v_save;  /* 3 nv */
    double h_stable;          /* auto_substep: cached estimate, 0 when stale */
    int32_t since_estimate;   /* steps since h_stable was estimated */
    uint32_t passes;          /* DEFSIM_PASS_* of the step under way */
    int body_contact_last;    /* the last step had body contact on */
} defsim__step_state;

/* A recording of the world's steps (tape.c) as the world sees it: the tape begins with this,
 * the world calls `step` after each successful step and clears `world` when it is destroyed
 * (through the pointer, so that the world's files call nothing of the tape's). */
typedef struct defsim__tape_link {
    struct defsim_world *world;
    void (*step)(struct defsim__tape_link *link, double h);
} defsim__tape_link;

struct defsim_world {
    uint32_t magic;           /* DEFSIM__WORLD_MAGIC while the world lives */
    defsim_world_def def;
    defsim__backend_slot backend;
    defsim__options options;  /* options and counters by name (options.c) */
    defsim__settings set;     /* the options resolved, as the step and plan read them */
    int planned;              /* sys and work match the bodies */
    defsim__messages *msg;    /* allocated: const getters may report errors */
    int32_t nthreads;         /* resolved from def.num_threads */

    defsim__body_set bodies;
    int32_t nv;               /* vertices of all bodies */
    defsim__state state;      /* x, v: 3 nv; t */
    defsim__step_state step;

    defsim__system sys;
    defsim__work work;
    defsim_system handle;     /* what backends receive: points at sys, work, state, stats */
    defsim_stats stats;

    defsim__coupling_set coupling;    /* the host's coupling terms (coupling_set.h) */
    defsim__collider_set colliders;   /* colliders and the contact read-back (collider.h) */
    defsim__watchdog wd;      /* the stability watchdog's reference (watchdog.c) */
    defsim__contact contact;  /* contact.h: pairs and parameters of the step under way */
    defsim__body_contact body_contact;  /* body_contact.h: surfaces (per plan) and pairs */
    uint64_t plan_serial;     /* counts the plans (a recording follows one) */
    defsim__tape_link *tape;  /* the recording under way, or NULL */
};

/* Plans the world if it is not planned (a cache of the bodies, not a change of state).
 * Returns DEFSIM_OK or DEFSIM_ERR_OUT_OF_MEMORY (with the world's error set). */
defsim_status defsim__world_plan(defsim_world *w);
/* Initialises the backend for the current plan (backend_ready); on failure finalises what init
 * made, sets the world's error and returns the status. Stop finalises it (history dropped). */
defsim_status defsim__world_backend_start(defsim_world *w);
void defsim__world_backend_stop(defsim_world *w);
/* The backend ready for a step: stopped first when an option changed since its init (with
 * auto_substep's cached stable step, which may depend on it), started when it is not. Returns
 * what start returns. */
defsim_status defsim__world_backend_prepare(defsim_world *w);
/* Drops the compiled system; the next step or query plans again. */
void defsim__world_unplan(defsim_world *w);

/* Looks up a live body (NULL if stale) and sets the world's error if it is not. */
defsim__body *defsim__world_body(const defsim_world *w, defsim_body_id id);
/* The same without an error: for ids the world holds (attachments). */
defsim__body *defsim__world_find_body(const defsim_world *w, defsim_body_id id);

/* Best-effort check of a world pointer on entry of a public function: 0 for NULL, destroyed or
 * foreign pointers (defsim_last_error() then says so), 1 for a live world. */
int defsim__world_live(const defsim_world *w);

/* An id's slot (0-based) if its index carries this world's tag, else -1. */
int64_t defsim__world_id_slot(const defsim_world *w, uint32_t index);
/* The index of slot `slot` in an id of this world. */
uint32_t defsim__world_id_index(const defsim_world *w, int32_t slot);
/* What is wrong with an id that names nothing live: "null", "not of this world" or "stale". */
const char *defsim__world_id_problem(const defsim_world *w, uint32_t index, uint32_t generation);

/* On entry of a public function that changes the world: DEFSIM_ERR_INVALID_ARGUMENT for a
 * pointer that is not a live world, DEFSIM_ERR_LOCKED inside a host callback, else OK. */
defsim_status defsim__world_enter(defsim_world *w);

/* Discards the plan and the backend's set-up (after a change of bodies, pins, attachments). */
void defsim__world_invalidate(defsim_world *w);

/* Returns DEFSIM_ERR_LOCKED with the world's error set while a host callback (log, force
 * callback or its Jacobian) runs, else OK. */
defsim_status defsim__world_check_unlocked(defsim_world *w);

#endif
