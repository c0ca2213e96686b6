/* SPDX-License-Identifier: MIT */
/* The planner (plan.c): bodies in, a compiled system and its workspaces out. */
#ifndef DEFSIM_PLAN_H
#define DEFSIM_PLAN_H

#include "body.h"
#include "system.h"

/* What the planner compiles: the world's bodies and per-vertex data, and the settings the
 * physics needs. Read only during defsim__plan; nothing is kept. */
typedef struct defsim__plan_input {
    const defsim__body *bodies;   /* live bodies have an odd generation */
    int32_t nbodies;
    int32_t nv;
    const double *mass;           /* nv */
    const uint8_t *pinned;        /* nv */
    const double *gravity;        /* 3 */
    int projection;               /* defsim_projection */
    const struct defsim__tet_kernels *tet_kernels;  /* batched force kernels; NULL: scalar */
    int32_t nthreads;
    int need_matrix;              /* build the sparse pattern now */
    const defsim__attachment *attachments;   /* live ones have an odd generation */
    int32_t nattachments;
    const int32_t *body_dense;    /* id slot -> index into bodies (attachments' body ids) */
} defsim__plan_input;

/* Compiles `in` into s and sizes wk (freeing what they held). On failure both are left empty
 * and DEFSIM_ERR_OUT_OF_MEMORY is returned. */
defsim_status defsim__plan(defsim__system *s, defsim__work *wk, const defsim__plan_input *in);

/* Frees what s and wk hold and zeroes them. */
void defsim__unplan(defsim__system *s, defsim__work *wk);

#endif /* DEFSIM_PLAN_H */
