/* SPDX-License-Identifier: MIT */
/* A body as the host gave it: validated, tets reordered to positive orientation (world.c); an
 * attachment as the host gave it. */
#ifndef DEFSIM_BODY_H
#define DEFSIM_BODY_H

#include "defsim/defsim.h"

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

/* An attachment as the host gave it (coupling.c): validated; its bodies are live while it is. */
typedef struct defsim__attachment {
    uint32_t generation;      /* odd while alive; bumped on removal */
    defsim_attachment_def def;
} defsim__attachment;

#endif /* DEFSIM_BODY_H */
