/* SPDX-License-Identifier: MIT */
/*
 * Body-body and self-contact (body_contact.c; the method is in docs/body-contact.md): the
 * bodies' surfaces (cloth triangles, tet bodies' boundary triangles, rope edges) repel through
 * IPC's log barrier on point-triangle, edge-edge (mollified) and point-edge (rope) distances
 * inside dhat, with lagged, smoothed Coulomb friction; contact_max_step runs additive CCD on
 * every candidate pair, so no iterate of a line search crosses a surface. Only for backends with
 * DEFSIM_BACKEND_CONTACT_CCD (the world refuses to step the others).
 *
 * Surfaces are extracted once per plan. Each evaluation point x has its constraint set
 * (IPC's): the primitive pairs within dhat at x, merged into vertex-vertex, edge-vertex,
 * face-vertex and edge-edge contacts (contact_pair.h), built once per x and reused by the energy,
 * forces, Hessians and pattern at that x. Its candidates come from a sorted spatial hash
 * (broad_phase.h) of primitive boxes grown by dhat / 2: at x for the barrier, swept over
 * x -> x + dx for CCD (so they also cover every point of the line search). Candidates stay valid
 * while every surface vertex lies in the box they were built for; the phases rebuild them
 * otherwise. Free-vertex pairs of contacts that the sparse pattern lacks are collected and merged
 * into it when the backend asks (matrix_pattern_version).
 */
#ifndef DEFSIM_BODY_CONTACT_H
#define DEFSIM_BODY_CONTACT_H

#include "body.h"
#include "broad_phase.h"
#include "contact_pair.h"
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

/* One contact of the constraint set: its type (DEFSIM__C_VV, _EV, _FV, _EE of contact_pair.h),
 * its vertices in the kernel's order (VV: p, q; EV: p, e0, e1; FV: p, t0, t1, t2; EE: a0, a1, b0,
 * b1; -1 unused), its barrier stiffness kappa and, for EE, the mollifier threshold eps; the
 * dense indices of the two bodies it joins (friction's mu). */
typedef struct defsim__bc_contact {
    int32_t v[4];
    int32_t type;
    int32_t body[2];
    double kappa, eps;
    double xi;                /* the thickness offset: the bodies' half-thicknesses summed (m) */
} defsim__bc_contact;

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
    double *half;             /* per body: half its contact thickness (m), read at each step's
                                 start; a pair's offset xi is the sum of its bodies' */

    /* The step under way. */
    int active;               /* set by begin, cleared by the world at the step's end */
    int failed;               /* DEFSIM_ERR_OUT_OF_MEMORY during an evaluation */
    double dhat, khat, eps_v, h;
    const double *mass;       /* nv (the system's) */
    const uint8_t *pinned;    /* nv */
    const int32_t *vfree;     /* nv: free vertex index or -1 */
    const double *xn;         /* 3 nv: the step's start (borrowed) */
    double *vlo, *vhi;        /* 3 nv: the box each surface vertex had when the candidates
                                 were built (a point, or its segment for CCD) */
    int have_pairs;           /* the candidates match vlo, vhi (a broad phase ran) */
    double cand_dhat;         /* the dhat they were built for (m) */
    int32_t nthreads;         /* the system's (OpenMP loops over contacts and candidates) */
    const double *bx, *bdx;   /* during a broad phase: the point and update (or NULL) it covers */
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

    /* The constraint set at conx (valid while con_valid): ncon contacts in canonical order
     * (type, then vertices), ncon_type[DEFSIM__C_*] of each type. ctmp: one slot per candidate
     * while it is built. sv, sg, sh: per-contact energy, gradient (12) and Hessian (144) slots
     * that the parallel loops fill and the serial sums read in contact order. */
    int32_t ncon, cap_con, cap_tmp;
    int32_t *act, nact;       /* the candidates within dhat at conx (their primitives' vertex
                                 pairs join the pattern) */
    struct defsim__bc_contact *con, *ctmp;
    int32_t ncon_type[4];
    double *conx;             /* 3 nv */
    int con_valid;
    double *sv, *sg, *sh;
    int64_t builds;           /* constraint sets built, cumulative */
    int64_t broads;           /* broad phases run, cumulative */

    /* Lagged friction (IPC): pairs active at the step's start, with their nodes, the weights of
     * the relative displacement of the closest points, the normal at the start, and mu lam. */
    int32_t nfric, cap_fric;
    struct defsim__bc_friction *fric;

    /* Free-vertex pairs (fa << 32 | fb, fa < fb) that candidates couple but the pattern lacks:
     * the host's matrix_pattern_version merges them (host.c). */
    int64_t *pend;
    int64_t npend, cap_pend;
    int64_t *keep;            /* scratch of defsim__body_contact_end's retention: the set's pairs */
    int64_t cap_keep;

    double *stat;             /* the world's contact statistics (contact.h DEFSIM__CSTAT_*) */
    const defsim__system *sys;/* the system of the step under way */
    int exact;                /* Hessians exact, unprojected (a backward pass's matrix) */
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

/* The barrier candidates at x (the phase benchmark's broad phase; always runs it): primitive
 * pairs whose boxes at x (each vertex's with dhat / 4 of room), grown by dhat / 2, overlap and
 * that could come within dhat inside them, after the collision filter. They cover every point
 * whose surface vertices stay in those boxes. Returns DEFSIM_OK or DEFSIM_ERR_OUT_OF_MEMORY.
 * Count in bc->npair. */
defsim_status defsim__body_contact_candidates(defsim__body_contact *bc, const double *x);
/* Builds the constraint set at x from the current candidates (after a broad phase at x if they do
 * not cover x): bc->ncon contacts, bc->ncon_type[DEFSIM__C_*] per type; the energy, forces and
 * Hessians at the same x reuse it. Returns DEFSIM_OK or DEFSIM_ERR_OUT_OF_MEMORY. */
defsim_status defsim__body_contact_build(defsim__body_contact *bc, const double *x);

/* Energy at x (J): barriers plus friction; +inf where a pair has distance 0. */
double defsim__body_contact_energy(defsim__body_contact *bc, const double *x);
/* Adds the contact forces (-gradient) at x to f (pinned vertices get nothing). Returns
 * DEFSIM_ERR_UNSTABLE for an infeasible point, DEFSIM_ERR_OUT_OF_MEMORY. */
defsim_status defsim__body_contact_forces(defsim__body_contact *bc, const double *x, double *f);
/* Calls fn with every nonzero contact Hessian at x (projected to PSD per contact; 3n x 3n over
 * the vertices idx, -1: unused), in the constraint set's order, then the lagged friction pairs;
 * queues the free-vertex pairs of the contacts that the pattern lacks. */
typedef void (*defsim__bc_hessian_fn)(void *ctx, const int32_t *idx, int n, const double *H);
void defsim__body_contact_hessians(defsim__body_contact *bc, const double *x,
                                   defsim__bc_hessian_fn fn, void *ctx);
/* Adds k H (3n x 3n over idx) into values of the pattern (upper or full, column pointers cp),
 * with its off-diagonal vertex blocks where the pattern has them (a missing pair is queued for
 * matrix_pattern_version). */
void defsim__body_contact_scatter(defsim__body_contact *bc, const defsim__system *s,
                                  const int32_t *idx, int n, const double *H, double k, int upper,
                                  const int64_t *cp, double *values);
/* Reverse mode of the forces at x (docs/gradients.md): for the adjoint w (3 nv) of the forces,
 * gx += (df/dx)^T w with the barriers' exact Hessians; gxn += (df/dx_n)^T w (3 nv) through the
 * lagged friction (its normal force, closest points' weights and normal: functions of the
 * step's start, held within the step); w^T df/dm into gmass (nv: the barrier stiffness is khat
 * times the candidates' mean vertex mass) and w^T df/dmu into gmu (per body slot). Each output
 * may be NULL but gx. Returns DEFSIM_ERR_UNSTABLE at an infeasible x, OUT_OF_MEMORY. */
defsim_status defsim__body_contact_vjp(defsim__body_contact *bc, const double *x, const double *w,
                                       double *gx, double *gxn, double *gmass, double *gmu);

/* Largest alpha in (0, 1] such that no primitive pair comes closer than a gap along x + t dx,
 * t <= alpha: 0.1 times its distance d at x (IPC Toolkit's additive CCD), and 0.2 times d or
 * dhat, whichever is less, if that is more (pairs within 2 dhat, where the barrier acts) (additive CCD over the candidates of the swept boxes, which it
 * builds when the current ones do not cover the segment); 0 when x is not feasible. Builds the
 * constraint set at x + alpha dx (the line search's first trial) and queues its pattern pairs. */
double defsim__body_contact_max_step(defsim__body_contact *bc, const double *x, const double *dx);
/* Makes a Newton start x feasible: moves its free vertices back along the segment from the
 * step's start as far as CCD requires (to the start itself if needed). Returns 1 if it moved
 * them. */
int defsim__body_contact_start(defsim__body_contact *bc, double *x);
/* Ends a successful step at x: the body contact force per vertex into f (3 nv, overwritten) and
 * the statistics; returns the smallest pair distance (m; inf without candidates). Then s's
 * pattern keeps, of the pairs body contact added to it, those that the constraint set at x
 * queues, when more than a quarter of them are stale (it is rebuilt then): the pattern, and its
 * factorisation's fill, are bounded by the contacts of the present, not of the whole run. Out
 * of memory there sets bc->failed. */
double defsim__body_contact_end(defsim__body_contact *bc, defsim__system *s, const double *x,
                                double *f);

#endif /* DEFSIM_BODY_CONTACT_H */
