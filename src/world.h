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
#include "body_contact.h"
#include "collider.h"
#include "contact.h"
#include "host.h"
#include "status.h"
#include "system.h"
#include "options.h"
#include "watchdog.h"

#include <stdint.h>

/* A world starts with a magic number: a best-effort check of the pointer, SQLite's way. Ids
 * carry the world's tag (body.h). */
#define DEFSIM__WORLD_MAGIC 0x64736d77u      /* "dsmw" */
#define DEFSIM__WORLD_DEAD 0x64656164u       /* "dead": set by defsim_world_destroy */

struct defsim_world {
    uint32_t magic;           /* DEFSIM__WORLD_MAGIC while the world lives */
    uint32_t id_tag;          /* 1 .. 4095, in the index of every id the world hands out */
    defsim_world_def def;
    char backend_name[64];
    const defsim_backend *backend;
    void *bstate;
    defsim__options options;  /* options and counters by name (options.c) */
    int backend_ready;        /* init succeeded for the current plan */
    int planned;              /* sys and work match the bodies */
    defsim__messages *msg;    /* allocated: const getters may report errors */

    defsim__body *bodies;     /* live bodies in vertex order (and, during a removal, the one
                                 going, with an even generation) */
    int32_t nbodies, cap_bodies;
    uint32_t *body_gen;       /* per id slot: generation, odd while the slot's body lives */
    int32_t *body_dense;      /* per id slot: index into bodies, -1 when free */
    int32_t nslots, cap_slots;

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

    /* The host's coupling terms (coupling.c). Per-vertex arrays are NULL until first used and
     * are carried over like the state when bodies are added or removed. */
    double *fext;             /* 3 nv held external forces, or NULL */
    int fext_nonzero;         /* the system sees fext only when some force is not zero */
    defsim__attachment *att;
    int32_t natt, cap_att;
    double *pin_target;       /* 3 nv: where driven pins end the next step */
    uint8_t *targeted;        /* nv: the vertex has a target */
    int32_t ntargeted;
    int drove;                /* the last step moved pins: their velocities go back to zero */
    defsim__coupling cpl;     /* callback and drive workspaces, sized by the plan */

    /* Colliders (collider.c): slots in creation order, live ones with odd generations. */
    defsim__collider *col;
    int32_t ncol, cap_col;
    int colliders_changed;    /* a collider was added or removed since the last step */
    int colliders_came;       /* a collider came or went since the last successful step */
    double *contact_force;    /* 3 contact_nv: contact forces of the last step, or NULL */
    int32_t contact_nv;
    int contact_zero;         /* contact_force is known to be all zero */
    defsim__watchdog wd;      /* the stability watchdog's reference (watchdog.c) */
    defsim__contact contact;  /* contact.h: pairs and parameters of the step under way */
    defsim__body_contact body_contact;  /* body_contact.h: surfaces (per plan) and pairs */
    int body_contact_last;    /* the last step had body contact on */
};

/* Plans the world if it is not planned (a cache of the bodies, not a change of state).
 * Returns DEFSIM_OK or DEFSIM_ERR_OUT_OF_MEMORY (with the world's error set). */
defsim_status defsim__world_plan(defsim_world *w);
/* Initialises the backend for the current plan (backend_ready); on failure finalises what init
 * made, sets the world's error and returns the status. Stop finalises it (history dropped). */
defsim_status defsim__world_backend_start(defsim_world *w);
void defsim__world_backend_stop(defsim_world *w);
/* Checkpoint loads: contact for a backend that replays its last internal step in load_state
 * (sundials_erk), as a step's end saw it: every collider still at its current pose (a pending
 * set_pose target is kept but not used); none while an SDF collider has no function yet. End
 * clears it. Begin returns DEFSIM_OK,
 * DEFSIM_ERR_OUT_OF_MEMORY or DEFSIM_ERR_CALLBACK (world's error set). */
defsim_status defsim__world_replay_contact_begin(defsim_world *w);
void defsim__world_replay_contact_end(defsim_world *w);
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

/* Sizes the coupling workspaces (w->cpl) for the current plan and features (coupling.c).
 * Returns DEFSIM_ERR_OUT_OF_MEMORY on failure. */
defsim_status defsim__coupling_reserve(defsim_world *w);

/* Frees the coupling workspaces and the host's coupling terms (at destruction). */
void defsim__coupling_free(defsim_world *w);

/* Removes the attachments that reference the body `id`, bumping their generations. */
void defsim__coupling_drop_body(defsim_world *w, defsim_body_id id);

/* Step hooks (coupling.c): begin evaluates what the step holds (callback at the start for
 * implicit backends; driven pins' velocities); before/after bracket each backend call i of n;
 * end closes the step (ok: it succeeded, consume the targets). */
defsim_status defsim__coupling_step_begin(defsim_world *w, double h);
void defsim__coupling_substep_before(defsim_world *w, int64_t i, int64_t n, double hsub);
void defsim__coupling_substep_after(defsim_world *w);
defsim_status defsim__coupling_step_end(defsim_world *w, defsim_status st);

/* Frees the colliders and the contact read-back (at destruction; collider.c). */
void defsim__colliders_free(defsim_world *w);

#endif
