/* SPDX-License-Identifier: MIT */
/*
 * The host's coupling terms as the world holds them, a sub-object of the world: held external
 * forces, attachments, driven pins' targets, and the force callback with the workspaces of the
 * step under way (defsim__coupling, host.h, which backends reach through the host table).
 * The public API over it is coupling.c; the step hooks here are what the world's step calls.
 * Per-vertex arrays are NULL until first used and follow the state when bodies come or go.
 */
#ifndef DEFSIM_COUPLING_SET_H
#define DEFSIM_COUPLING_SET_H

#include "body.h"
#include "chunk.h"
#include "host.h"
#include "id_pool.h"
#include "status.h"
#include "system.h"

#include <stdint.h>

typedef struct defsim__coupling_set {
    double *fext;             /* 3 nv held external forces, or NULL */
    int fext_nonzero;         /* the system sees fext only when some force is not zero */
    defsim__attachment *att;  /* by id slot (an attachment's generation is its slot's) */
    int32_t natt, cap_att;
    defsim__id_pool att_ids;
    double *pin_target;       /* 3 nv: where driven pins end the next step */
    uint8_t *targeted;        /* nv: the vertex has a target */
    int32_t ntargeted;
    int drove;                /* the last step moved pins: their velocities go back to zero */
    defsim__coupling cpl;     /* callback and drive workspaces, sized by the plan */
} defsim__coupling_set;

/* Sizes the callback and drive workspaces for nv vertices (the drive's when the system has
 * pins). Returns DEFSIM_ERR_OUT_OF_MEMORY on failure. */
defsim_status defsim__coupling_reserve(defsim__coupling_set *cs, int32_t nv, int has_pins);

/* Frees the workspaces and the host's coupling terms (at destruction). */
void defsim__coupling_free(defsim__coupling_set *cs);

/* Removes the attachments that reference the body `id`, bumping their generations. */
void defsim__coupling_drop_body(defsim__coupling_set *cs, defsim_body_id id);

/* Step hooks (the attachments' kind calls them from the terms' step hooks, term_attach.c). begin
 * evaluates what a step of h from `state` holds: driven pins' velocities,
 * and for implicit backends the callback at the start (DEFSIM_PASS_* it uses go into *passes);
 * before/after bracket each backend call i of n; end closes the step (st: the step's status;
 * OK consumes the targets) and returns the step's status. */
defsim_status defsim__coupling_step_begin(defsim__coupling_set *cs, const defsim__system *sys,
                                          defsim__state *state, int implicit, double h,
                                          uint32_t *passes, defsim__messages *msg);
void defsim__coupling_substep_before(defsim__coupling_set *cs, defsim__state *state, int64_t i,
                                     int64_t n, double hsub);
void defsim__coupling_substep_after(defsim__coupling_set *cs, defsim__state *state);
defsim_status defsim__coupling_step_end(defsim__coupling_set *cs, defsim__system *sys,
                                        defsim_status st);

/* Checkpoints (docs/checkpoints.md): writes an ATCH chunk per live attachment (its bodies named
 * by their saved ids: id slot + 1 in `bodies`), the held forces (FEXT) and the driven pins'
 * targets (PTGT) of a world of nv vertices. */
void defsim__coupling_save(defsim__bw *b, const defsim__coupling_set *cs, int32_t nv,
                           const defsim__id_pool *bodies);
/* Reads an ATCH chunk into *d (initialised by defsim_attachment_def_init) with the saved ids of its body and target body (0, 0: none) for
 * the caller to map; DEFSIM_ERR_IO if malformed (the values are validated by
 * defsim_world_add_attachment). */
defsim_status defsim__attachment_read(defsim__br *r, defsim_attachment_def *d, uint32_t body[2],
                                      uint32_t target[2]);
/* Reads a PTGT chunk into the set: every vertex named must be pinned (pinned[v], nv vertices)
 * and named once, its target finite. DEFSIM_ERR_IO if not (*why says what),
 * DEFSIM_ERR_OUT_OF_MEMORY. */
defsim_status defsim__coupling_load_targets(defsim__coupling_set *cs, defsim__br *r,
                                            int32_t nv, const uint8_t *pinned, const char **why);

#endif
