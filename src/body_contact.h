/* SPDX-License-Identifier: MIT */
/*
 * Body-body and self-contact (body_contact.c; the method is in docs/body-contact.md): the
 * bodies' surfaces (cloth triangles, tet bodies' boundary triangles, rope edges) repel through
 * IPC's log barrier on point-triangle, edge-edge (mollified) and point-edge (rope) distances
 * inside dhat, with lagged, smoothed Coulomb friction; contact_max_step runs additive CCD on
 * every candidate pair, so no iterate of a line search crosses a surface. Only for backends with
 * DEFSIM_BACKEND_CONTACT_CCD (the world refuses to step the others).
 *
 * Surfaces are extracted once per plan. A step begins with a broad phase: each surface vertex
 * gets a ball about its start position (its motion in the step, grown by evaluations that go
 * beyond it), primitives get the boxes of their vertices' balls grown by dhat, and a sorted
 * spatial hash (broad_phase.h) pairs them in one deterministic order. Candidate pairs whose
 * vertices are not yet coupled in the sparse pattern are collected and merged into it when the
 * backend asks (matrix_pattern_version).
 */
#ifndef DEFSIM_BODY_CONTACT_H
#define DEFSIM_BODY_CONTACT_H

#include "body.h"
#include "broad_phase.h"
#include "status.h"
#include "system.h"

enum { DEFSIM__BC_PT = 0, DEFSIM__BC_EE = 1, DEFSIM__BC_PE = 2 };

/* A lagged friction pair: its vertices (-1: unused), the weights of the relative displacement
 * of its closest points, the normal at the step's start, and mu lambda (N). */
typedef struct defsim__bc_friction {
    int32_t node[4];
    double w[4];
    double nrm[3];
    double mul;
} defsim__bc_friction;

typedef struct defsim__body_contact {
    /* Surfaces (per plan; global vertex indices). */
    int planned;
    int32_t nv;
    int32_t nface, nedge, nvert, nrope;
    int32_t *face;            /* 3 nface */
    int32_t *edge;            /* 2 nedge */
    int32_t *vert;            /* nvert: the surface vertices */
    int32_t *rope;            /* nrope: the edges of ropes (indices into edge) */
    int32_t *face_body, *edge_body, *vert_body;   /* dense body index of each primitive */
    double *edge_len2;        /* nedge: squared rest length (the EE mollifier's scale) */
    int32_t nbody;
    int32_t *self_contact;    /* per body, read at each step's start */
    uint32_t *group, *mask;
    double *mu;

    /* The step under way. */
    int active;               /* set by begin, cleared by the world at the step's end */
    int failed;               /* DEFSIM_ERR_OUT_OF_MEMORY during an evaluation */
    double dhat, khat, eps_v, h;
    const double *mass;       /* nv (the system's) */
    const uint8_t *pinned;    /* nv */
    const int32_t *vfree;     /* nv: free vertex index or -1 */
    const double *xn;         /* 3 nv: the step's start (borrowed) */
    double *center, *radius;  /* 3 nv, nv: the balls the candidates were found for (m); the
                                 centers are the start of the step that found them */
    int have_pairs;           /* the candidates match the balls (a broad phase ran) */
    double *lo, *hi;          /* 3 (nvert + nface + nedge + nrope): boxes */
    double *scratch;          /* 3 nv: contact_start's displacement, end's forces */
    double *clo, *chi;        /* the boxes of the primitives of bodies that take part */
    int32_t *cmap;            /* their indices in the full lists */
    double *blo, *bhi;        /* 3 nbody: bodies' boxes */
    uint8_t *bactive;         /* nbody: the body can meet something in this step */
    defsim__hash hash;

    /* Candidate pairs, in the hash's order: kind (DEFSIM__BC_*), a, b (vertex, face, edge
     * indices into the lists above). */
    int32_t npair, cap_pair;
    uint8_t *kind;
    int32_t *pa, *pb;

    /* Lagged friction (IPC): pairs active at the step's start, with their nodes, the weights of
     * the relative displacement of the closest points, the normal at the start, and mu lam. */
    int32_t nfric, cap_fric;
    struct defsim__bc_friction *fric;

    /* Free-vertex pairs (fa << 32 | fb, fa < fb) that candidates couple but the pattern lacks:
     * the host's matrix_pattern_version merges them (host.c). */
    int64_t *pend;
    int64_t npend, cap_pend;

    double *stat;             /* the world's contact statistics (contact.h DEFSIM__CSTAT_*) */
    const defsim__system *sys;/* the system of the step under way */
    int fresh;                /* check the start for intersecting surfaces (after a plan) */
} defsim__body_contact;

/* Drops the surfaces (the world's plan changed); the next begin extracts them again. */
void defsim__body_contact_unplan(defsim__body_contact *bc);
void defsim__body_contact_free(defsim__body_contact *bc);

/* Begins a step of size h from x (borrowed until the step ends: the world's copy of the start)
 * with velocities v: surfaces (once per plan), the broad phase, the lagged friction and the
 * pattern's pending pairs. A pair of surfaces that touch (distance 0) or, in the first step
 * after a plan, cross at the start fails with DEFSIM_ERR_INVALID_ARGUMENT and a message that
 * names them. Also DEFSIM_ERR_OUT_OF_MEMORY. */
defsim_status defsim__body_contact_begin(defsim__body_contact *bc, const defsim__system *s,
                                         const defsim__body *bodies, int32_t nbodies,
                                         double dhat_rel, double kappa, double eps_v,
                                         const double *x, const double *v, double h,
                                         double *stat, defsim__messages *msg);

/* Energy at x (J): barriers plus friction; +inf where a pair has distance 0. */
double defsim__body_contact_energy(defsim__body_contact *bc, const double *x);
/* Adds the contact forces (-gradient) at x to f (pinned vertices get nothing). Returns
 * DEFSIM_ERR_UNSTABLE for an infeasible point, DEFSIM_ERR_OUT_OF_MEMORY. */
defsim_status defsim__body_contact_forces(defsim__body_contact *bc, const double *x, double *f);
/* Calls fn with every nonzero pair Hessian at x (projected to PSD per pair; 3n x 3n over the
 * vertices idx, -1: unused): barriers within dhat, then the lagged friction pairs. */
typedef void (*defsim__bc_hessian_fn)(void *ctx, const int32_t *idx, int n, const double *H);
void defsim__body_contact_hessians(defsim__body_contact *bc, const double *x,
                                   defsim__bc_hessian_fn fn, void *ctx);
/* Adds k H (3n x 3n over idx) into values of the pattern (upper or full, column pointers cp),
 * with its off-diagonal vertex blocks where the pattern has them (a missing pair is queued for
 * matrix_pattern_version). */
void defsim__body_contact_scatter(defsim__body_contact *bc, const defsim__system *s,
                                  const int32_t *idx, int n, const double *H, double k, int upper,
                                  const int64_t *cp, double *values);
/* Largest alpha in (0, 1] such that no candidate pair comes closer than 0.2 times its distance
 * at x along x + t dx, t <= alpha (additive CCD); 0 when x is not feasible. */
double defsim__body_contact_max_step(defsim__body_contact *bc, const double *x, const double *dx);
/* Makes a Newton start x feasible: moves its free vertices back along the segment from the
 * step's start as far as CCD requires (to the start itself if needed). Returns 1 if it moved
 * them. */
int defsim__body_contact_start(defsim__body_contact *bc, double *x);
/* Ends a successful step at x: the body contact force per vertex into f (3 nv, overwritten) and
 * the statistics; returns the smallest pair distance (m; inf without candidates). */
double defsim__body_contact_end(defsim__body_contact *bc, const double *x, double *f);

#endif /* DEFSIM_BODY_CONTACT_H */
