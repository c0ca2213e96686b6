/* SPDX-License-Identifier: MIT */
/* A body as the host gave it: validated, tets reordered to positive orientation (body.c); an
 * attachment as the host gave it. */
#ifndef DEFSIM_BODY_H
#define DEFSIM_BODY_H

#include "chunk.h"
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

#define DEFSIM__SHELL_FIELDS 13   /* the shell_* doubles of defsim_body_def */

typedef struct defsim__body {
    uint32_t generation;      /* odd while alive; bumped on removal */
    int32_t nv, nt, ns;
    double *rest;             /* 3 nv */
    double *mass;             /* nv */
    int32_t tet_nodes;        /* indices per tet: 4, or 10 (quadratic, tet10.h) */
    int32_t *tets;            /* tet_nodes nt, body-local */
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
    double thickness;         /* defsim_body_def.contact_thickness (m) */
    int32_t volume_averaging; /* defsim_body_def.volume_averaging: 0 or 1 */
    int mass_given;           /* the host gave vertex_mass: the density does not set the masses */
    /* Shells (shell.h; docs/shells.md), when `shell`: the membrane's group (DEFSIM__MEMBRANE_*,
     * or -1 for none) with per triangle its row (DEFSIM__MEMBRANE_WIDTH doubles: Dm^-1 and the
     * law's parameters) and rest area; the hinges (interior edges of the triangles: 4 body-local
     * vertices each, the edge first), their weights (N m) and rest angles. */
    int shell;
    int32_t membrane;
    double *mrow, *marea;     /* DEFSIM__MEMBRANE_WIDTH ntri, ntri */
    int32_t nhinge;
    int32_t *hinges;          /* 4 nhinge */
    double *hw, *htheta0;     /* nhinge */
    /* The def's shell_* fields as given (defaults unresolved), which checkpoints save (version
     * 9): shell_membrane, then DEFSIM__SHELL_FIELDS doubles in defsim__body_shell_fields' order. */
    int32_t shell_membrane;
    double shell_fields[DEFSIM__SHELL_FIELDS];
    double strain_limit;      /* defsim_body_def.shell_strain_limit (version 10); 0: none */
} defsim__body;

/* A def's shell_* doubles into p (set: 0) or p into the def (set: 1), in the BODY chunk's order
 * (inline: tools/scene_export.c reads the chunk too):
 * youngs_modulus, poisson_ratio, thickness, warp_modulus, weft_modulus, shear_modulus,
 * warp_poisson, warp_direction[3], areal_density, bending_rigidity, bending_rigidity_weft. */
static inline void defsim__body_shell_fields(defsim_body_def *d, double p[DEFSIM__SHELL_FIELDS],
                                             int set)
{
    double *const f[DEFSIM__SHELL_FIELDS] = {
        &d->shell_youngs_modulus, &d->shell_poisson_ratio, &d->shell_thickness,
        &d->shell_warp_modulus, &d->shell_weft_modulus, &d->shell_shear_modulus,
        &d->shell_warp_poisson, &d->shell_warp_direction[0], &d->shell_warp_direction[1],
        &d->shell_warp_direction[2], &d->shell_areal_density, &d->shell_bending_rigidity,
        &d->shell_bending_rigidity_weft};
    for (int i = 0; i < DEFSIM__SHELL_FIELDS; ++i) {
        if (set) *f[i] = p[i];
        else p[i] = *f[i];
    }
}

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

/* Checkpoints: writes the body's BODY chunk (docs/checkpoints.md); `saved` is its id as a
 * checkpoint keeps it (id slot + 1, without the world's tag, so that a world saves the same bytes
 * whatever world it was loaded into). */
void defsim__body_save(defsim__bw *b, const defsim__body *body, uint32_t saved);

/* A BODY chunk read back, as the def that builds the body again through the public API (its
 * arrays point into the buffers here: masses and stiffnesses as saved, so that the compiled
 * system has the same bits), with the pins, and the contact edges restored as saved (a rope's
 * springs come back without their kinds). */
typedef struct defsim__body_saved {
    uint32_t id, generation;  /* as saved */
    defsim_body_def def;
    double *rest, *mass, *k;
    int32_t *tets, *springs, *tris;
    int32_t *pins, npin;      /* the pinned vertices */
    int32_t *edges, nedge;    /* the contact edges (version 4 on) */
} defsim__body_saved;

/* Reads a BODY chunk of format `version` (its payload in r) into *out, whose buffers are the
 * caller's to free with defsim__body_saved_free, also on failure. Returns DEFSIM_ERR_IO with
 * *why saying what is malformed, or DEFSIM_ERR_OUT_OF_MEMORY; the values themselves are
 * validated by defsim_world_add_body. */
defsim_status defsim__body_read(defsim__br *r, uint32_t version, defsim__body_saved *out,
                                const char **why);
void defsim__body_saved_free(defsim__body_saved *s);

/* An attachment as the host gave it (coupling.c): validated; its bodies are live while it is. */
typedef struct defsim__attachment {
    uint32_t generation;      /* odd while alive; bumped on removal */
    defsim_attachment_def def;
} defsim__attachment;

#endif /* DEFSIM_BODY_H */
