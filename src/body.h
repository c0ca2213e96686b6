/* SPDX-License-Identifier: MIT */
/* A body as the host gave it: validated, tets reordered to positive orientation (body.c); an
 * attachment as the host gave it. */
#ifndef DEFSIM_BODY_H
#define DEFSIM_BODY_H

#include "defsim/defsim.h"
#include "status.h"

#include <stdint.h>

/* Body and attachment ids: the index holds the slot + 1 in its low DEFSIM__ID_SLOT_BITS and the
 * tag of the world that made it above them, so that an id of another world is stale here. */
#define DEFSIM__ID_SLOT_BITS 20
#define DEFSIM__ID_SLOT_MASK ((1u << DEFSIM__ID_SLOT_BITS) - 1u)
#define DEFSIM__ID_MAX_SLOTS ((int32_t)DEFSIM__ID_SLOT_MASK)
#define DEFSIM__ID_TAGS ((1u << (32 - DEFSIM__ID_SLOT_BITS)) - 1u)
#define DEFSIM__ID_SLOT(index) ((int64_t)((index) & DEFSIM__ID_SLOT_MASK) - 1)

typedef struct defsim__body {
    uint32_t generation;      /* odd while alive; bumped on removal */
    int32_t nv, nt, ns;
    double *rest;             /* 3 nv */
    double *mass;             /* nv */
    int32_t *tets;            /* 4 nt, body-local */
    int32_t *springs;         /* 2 ns, body-local */
    double *k;                /* ns */
    uint8_t *pinned;          /* nv */
    defsim_material mat;
    double mu, lambda;
    int32_t offset;           /* first vertex in the world arrays */
    /* Body contact (body_contact.h): the host's triangles (a cloth's surface), or NULL; for a
     * body of springs only without triangles, the springs that are its contact edges (a rope:
     * the stretch springs), else NULL. Filter and friction as in defsim_body_def. */
    int32_t ntri, nedge;
    int32_t *tris;            /* 3 ntri, body-local */
    int32_t *edges;           /* 2 nedge, body-local */
    int32_t self_contact;
    uint32_t group, mask;
    double friction;
} defsim__body;

/* Validates the host's def (a world of world_nv vertices receives it) and builds *out from
 * it; *d receives the def with defaults for the fields an older def lacks (its arrays are the
 * host's, for the initial state), *reordered the number of tets turned to positive
 * orientation. On failure *out holds nothing to free and msg says why: INVALID_ARGUMENT,
 * INVALID_MESH, INVALID_MATERIAL or OUT_OF_MEMORY. */
defsim_status defsim__body_build(defsim__messages *msg, const defsim_body_def *def,
                                 int32_t world_nv, defsim_body_def *d, defsim__body *out,
                                 int32_t *reordered);
/* Frees a body's arrays (their pointers become NULL). */
void defsim__body_free(defsim__body *b);

/* An attachment as the host gave it (coupling.c): validated; its bodies are live while it is. */
typedef struct defsim__attachment {
    uint32_t generation;      /* odd while alive; bumped on removal */
    defsim_attachment_def def;
} defsim__attachment;

#endif /* DEFSIM_BODY_H */
