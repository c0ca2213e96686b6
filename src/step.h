/* SPDX-License-Identifier: MIT */
/*
 * The world's step (step.c): defsim_world_step and defsim_world_stable_step, and the replay of
 * a step's contact set-up that a checkpoint's load needs. Above world.c: it calls the world's
 * plan and backend, and nothing below calls it.
 */
#ifndef DEFSIM_STEP_H
#define DEFSIM_STEP_H

#include "world.h"

/* Checkpoint loads: contact for a backend that replays its last internal step in load_state
 * (sundials_erk), as a step's end saw it: every collider still at its current pose (a pending
 * set_pose target is kept but not used); none while an SDF collider has no function yet. End
 * clears it. Begin returns DEFSIM_OK,
 * DEFSIM_ERR_OUT_OF_MEMORY or DEFSIM_ERR_CALLBACK (world's error set). */
defsim_status defsim__world_replay_contact_begin(defsim_world *w);
void defsim__world_replay_contact_end(defsim_world *w);

/* A backward pass (tape.c) over a recorded step of h from (x0, v0): the kinds' begins as the
 * step had them (collider and body contact's pairs and lagged friction at x0; nothing without
 * a live collider or body contact), so that the adjoint step evaluates the step's contact. End detaches it and drops
 * the terms' linearisation caches. Begin returns what defsim__terms_step_begin returns (the
 * world's error set). */
defsim_status defsim__world_adjoint_begin(defsim_world *w, const double *x0, const double *v0,
                                          double h);
void defsim__world_adjoint_end(defsim_world *w);

/* The state that a step attaches to the term of `kind` and that carries from one step to the
 * next, for checkpoints to save and load through the kind's ops; NULL for kinds that keep none
 * (term_list.h). */
void *defsim__world_term_state(defsim_world *w, int kind);

#endif
