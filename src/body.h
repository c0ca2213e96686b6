/* SPDX-License-Identifier: MIT */
/* A body as the host gave it: validated, tets reordered to positive orientation (world.c); an
 * attachment as the host gave it. */
#ifndef DEFSIM_BODY_H
#define DEFSIM_BODY_H

#include "defsim/defsim.h"

#include <stdint.h>

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
} defsim__body;

/* An attachment as the host gave it (coupling.c): validated; its bodies are live while it is. */
typedef struct defsim__attachment {
    uint32_t generation;      /* odd while alive; bumped on removal */
    defsim_attachment_def def;
} defsim__attachment;

#endif /* DEFSIM_BODY_H */
