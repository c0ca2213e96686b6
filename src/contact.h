/* SPDX-License-Identifier: MIT */
/*
 * Contact between the bodies' vertices and the world's colliders (contact.c; docs/contact.md).
 * Every vertex-collider pair is a term of the system: a log barrier (BARRIER mode, for backends
 * whose line search is filtered by contact_max_step) or a quadratic penalty (PENALTY mode, every
 * other backend) on the signed distance d to the collider at its end-of-step pose, active for
 * d < dhat, with Coulomb friction: lagged and smoothed in the potential (BARRIER, as in IPC) or a
 * regularised force on the tangential velocity among the damping forces (PENALTY). Each term
 * touches only its vertex's own 3x3 block of the matrices.
 *
 * A step begins with a broad phase: each free vertex gets a ball about its start position (the
 * motion it may make in the step) and pairs with the colliders whose bounds (grown by dhat) meet
 * it and whose distance allows contact in it. Evaluations at a point outside a vertex's ball grow
 * the ball and pair again, so no contact is missed whatever the backend's iterates do.
 *
 * Far colliders cost no per-vertex work: when every collider stays clear of a box (the safe box)
 * that holds all free vertices, a step pairs nothing and each evaluation only tests that the
 * free vertices are still in the box (a few compares per vertex); the first point outside it
 * runs the per-vertex broad phase after all. The box is kept from step to step while it holds
 * the vertices and the colliders keep clear of it.
 */
#ifndef DEFSIM_CONTACT_H
#define DEFSIM_CONTACT_H

#include "body.h"
#include "collider.h"
#include "system.h"

enum { DEFSIM__CONTACT_OFF = 0, DEFSIM__CONTACT_BARRIER = 1, DEFSIM__CONTACT_PENALTY = 2 };

/* Statistics by name ("contact.<name>", options.c lists them). */
enum {
    DEFSIM__CSTAT_ACTIVE = 0,      /* pairs with d < dhat at the end of the last step */
    DEFSIM__CSTAT_PAIRS,           /* candidate pairs of the last step (after the broad phase) */
    DEFSIM__CSTAT_MIN_DISTANCE,    /* smallest vertex-collider distance at the end of the last
                                      step over the candidate pairs (m; inf without any) */
    DEFSIM__CSTAT_TIME_BROAD,      /* broad phase, cumulative (s) */
    DEFSIM__CSTAT_TIME_CCD,        /* contact_max_step, cumulative (s) */
    DEFSIM__CSTAT_CCD_CALLS,       /* contact_max_step calls, cumulative */
    DEFSIM__CSTAT_TIME_EVAL,       /* contact's energy, forces and matrix blocks, cumulative (s) */
    /* body contact (body_contact.h) */
    DEFSIM__CSTAT_BODY_CANDIDATES, /* candidate primitive pairs of the last step */
    DEFSIM__CSTAT_BODY_ACTIVE,     /* body pairs with d < dhat at the end of the last step */
    DEFSIM__CSTAT_BODY_MIN_DISTANCE, /* smallest body pair distance then (m; inf without any) */
    DEFSIM__CSTAT_TIME_BODY_BROAD, /* body broad phase, cumulative (s) */
    DEFSIM__CSTAT_TIME_BODY_CCD,   /* body CCD, cumulative (s) */
    DEFSIM__CSTAT_TIME_BODY_EVAL,  /* body barrier and friction terms, cumulative (s) */
    DEFSIM__CSTAT_PATTERN_GROWTHS, /* times the matrix pattern grew, cumulative */
    DEFSIM__CSTAT_COUNT
};

typedef struct defsim__contact {
    int mode;                   /* DEFSIM__CONTACT_*; OFF: no live collider */
    int failed;                 /* this step's failure: CALLBACK (an SDF callback), UNSTABLE
                                   (a distance overflowed), OUT_OF_MEMORY; defsim__contact_failure */
    const defsim__collider *col;/* the world's collider slots (live ones: odd generation) */
    int32_t ncol;
    defsim__pose *pose0, *pose1;/* per slot: the pose at the start and end of the step */
    double *lo, *hi;            /* 3 per slot: bounds over the step, grown by dhat */
    uint8_t *near;              /* per slot: near the box of all vertex balls (broad phase) */
    int32_t cap_col;

    double dhat;                /* activation distance (m) */
    double khat;                /* barrier kappa / m_i or penalty k_i / m_i (1/s^2) */
    double eps_v;               /* friction's stick-slip velocity threshold (m/s) */
    double h;                   /* the world's step (s) */
    double omega_c;             /* penalty: sqrt(khat) (rad/s) */
    double mu_max;              /* largest friction coefficient of a live collider */
    double omega_elastic;       /* PENALTY's automatic omega_c: cached per plan, 0 when stale */
    int readback_set;           /* the world's contact-force read-back may hold non-zeros */

    int32_t nv;
    /* The contact thickness (docs/body-contact.md "Thickness"): per vertex half its body's
     * contact_thickness (m), the offset that the barrier, the penalty and CCD take off every
     * vertex-collider distance; NULL when every body has thickness 0 (no offset at all). */
    double *xi;                 /* nv, or NULL */
    double xi_max;              /* the largest offset (m), 0 without */
    int32_t cap_xi;
    const double *mass;         /* nv (the system's) */
    const uint8_t *pinned;      /* nv */
    const double *xn;           /* 3 nv: positions at the start of the step (the caller's, held
                                   unchanged until the step ends) */
    const double *vn;           /* 3 nv: velocities at the start of the step (likewise) */
    double g;                   /* |gravity| (m/s^2) */
    double hstep;               /* the world's step (s): the balls' horizon (h is a substep's) */
    double *radius;             /* nv: each vertex's ball about xn (m), when `balls` */
    int balls;                  /* radius and ball_lo/hi hold this step's balls */
    double ball_lo[3], ball_hi[3]; /* the box around this step's balls */
    int far;                    /* this step runs without balls: every point evaluated so far
                                   had its free vertices inside the safe box */
    int safe_set;               /* safe_lo/hi hold a box (kept from step to step) */
    double safe_lo[3], safe_hi[3]; /* the safe box: no collider comes within dhat of it */
    double *vel;                /* 3 nv: velocities of the latest damping evaluation (PENALTY) */
    double *blk;                /* 9 nv: scratch for the matrices' diagonal blocks */
    double *base, *dstart;      /* 3 nv each: contact_start's base positions and displacement */
    int32_t *carrier;           /* nv: contact_start's collider slot that carries the vertex, -1 */
    double *cpos;               /* 3 nv: contact_start's positions carried with one collider */
    uint8_t *hit;               /* nv: contact_start's vertices of primitives a witness sweeps */
    int32_t cap_v;
    /* BARRIER's guard against bodies passing around small colliders (docs/contact.md, "No
     * tunnelling"): the bodies' surface triangles and edges (global vertex indices), built
     * once per plan, which never sweep across a collider's witness (its core's corners, edges,
     * centre or axis). */
    int32_t nface, nedge;
    int32_t *face, *edge;       /* 3 nface, 2 nedge */
    int surf_planned;           /* face and edge hold this plan's surfaces */
    int32_t blocked;            /* BARRIER: no Newton start keeps the vertices clear of the
                                   colliders in this step (the energy is then +inf) */
    int32_t blocked_vertex;     /* the vertex that could not be kept clear, or -1 */

    /* Candidate pairs: vertex, collider slot, and per pair the lagged friction data (BARRIER):
     * the normal force lam (N) and normal n at the start of the step, the collider's surface
     * displacement uc over the step at the vertex (m); off = 1 for a vertex that starts the step
     * inside the collider (BARRIER leaves such pairs out). */
    int32_t npair, cap_pair;
    int32_t *pv, *pc;
    double *lam, *nrm, *uc;
    uint8_t *off;

    int exact;                  /* BARRIER: the blocks are the exact Hessian, unprojected (a
                                   backward pass's matrices; docs/gradients.md) */
    double stat[DEFSIM__CSTAT_COUNT];
} defsim__contact;

/* Checkpoints (checkpoint.c): the PENALTY friction blocks' velocities (`vel`, the latest damping
 * evaluation's, which a backend may never refresh within a step: sundials_kinsol's B(x_n)) are
 * part of what the next step depends on. defsim__contact_vel gives them for nv vertices (NULL
 * when none are held: the next step allocates them as zeros); defsim__contact_set_vel restores
 * them. Returns DEFSIM_OK or DEFSIM_ERR_OUT_OF_MEMORY. */
const double *defsim__contact_vel(const defsim__contact *c, int32_t nv);
defsim_status defsim__contact_set_vel(defsim__contact *c, int32_t nv, const double *vel);

/* Parameters of a step, read from the world's options by the caller. */
typedef struct defsim__contact_params {
    int mode;
    double dhat_rel;            /* dhat / length scale */
    double kappa;               /* khat (1/s^2) or 0 for automatic */
    double frequency;           /* PENALTY omega_c (rad/s) or 0 for automatic */
    double omega_elastic;       /* PENALTY automatic omega_c: the system's omega_max */
    double eps_v;
} defsim__contact_params;

void defsim__contact_free(defsim__contact *c);

/* BARRIER: the bodies' surfaces for the witness guard (tet boundaries, a body's triangles, a
 * rope's edges), once per plan (surf_planned). Returns DEFSIM_OK or OUT_OF_MEMORY. */
defsim_status defsim__contact_surfaces(defsim__contact *c, const defsim__body *bodies,
                                       int32_t nbodies);

/* The vertices' thickness offsets (half their body's contact_thickness) from the bodies of a
 * world of nv vertices, before defsim__contact_begin: c->xi stays NULL (and costs nothing) while
 * every body has thickness 0. Returns DEFSIM_OK or DEFSIM_ERR_OUT_OF_MEMORY. */
defsim_status defsim__contact_offsets(defsim__contact *c, const defsim__body *bodies,
                                      int32_t nbodies, int32_t nv);

/* Begins a step of size h from positions x and velocities v: poses, parameters, the broad phase
 * and (BARRIER) the lagged friction. col/ncol are the world's slots. x and v are borrowed until
 * the step ends and must not change meanwhile (the world passes its copies of the step's start).
 * Returns DEFSIM_OK, DEFSIM_ERR_OUT_OF_MEMORY, DEFSIM_ERR_CALLBACK (an SDF callback) or
 * DEFSIM_ERR_UNSTABLE (a distance overflowed), with the message in msg. */
defsim_status defsim__contact_begin(defsim__contact *c, const defsim__system *s,
                                    const defsim__collider *col, int32_t ncol,
                                    const defsim__contact_params *p, const double *x,
                                    const double *v, double h, defsim__messages *msg);

/* PENALTY: the backend step under way covers the fraction [s0, s1] of the world's step, of
 * length hsub: colliders sit at their pose at s1 and move at their velocity over [s0, s1]. */
void defsim__contact_substep(defsim__contact *c, double s0, double s1, double hsub);

/* The automatic barrier and penalty stiffness per unit mass (1/s^2) for these parameters. */
double defsim__contact_khat(const defsim__contact_params *p, double dhat, double h,
                            const double gravity[3]);

/* Contact energy at x (J): barrier or penalty, plus BARRIER's friction potential; +inf where a
 * barrier pair has d <= 0 or a distance failed. */
double defsim__contact_energy(defsim__contact *c, const double *x);

/* Adds the contact forces at x (and v) to f: which & DEFSIM_FORCE_ELASTIC: -grad of the energy;
 * which & DEFSIM_FORCE_DAMPING (PENALTY, v not NULL): friction. Pinned vertices get nothing.
 * Returns DEFSIM_ERR_UNSTABLE for an infeasible barrier point or a distance that overflowed,
 * DEFSIM_ERR_CALLBACK for an SDF callback's failure. */
defsim_status defsim__contact_forces(defsim__contact *c, const double *x, const double *v,
                                     uint32_t which, double *f);

/* The 3x3 block (row-major, PSD) that contact adds to vertex i's diagonal block of
 * k K + kd B at x, accumulated over i's pairs into blk (9 nv, zeroed first). Returns 1 if any
 * block is not zero. */
int defsim__contact_blocks(defsim__contact *c, const double *x, double k, double kd,
                           double *blk);

/* Reverse mode of the BARRIER forces at x (docs/gradients.md), with the lagged friction's
 * normal force, normal and collider motion functions of the step's start x_n as begin made them
 * (held within the step, differentiated in x_n): for the adjoint w (3 nv) of the forces,
 * gx += (df/dx)^T w (may be NULL), gxn += (df/dx_n)^T w (3 nv, may be NULL), and the parameter
 * gradients w^T df/dm_i into gmass (nv) and w^T df/dmu_j into gmu (per collider slot), and into
 * gpose (12 per collider slot: the step's start pose, then its end pose, each as dp (3) and
 * dtheta (3), the small rotation (I + [dtheta]) R about the collider's origin, world frame),
 * each may be NULL. Pairs whose vertex starts inside its collider stay left out, as the forces
 * leave them. Returns DEFSIM_ERR_UNSUPPORTED in PENALTY mode, DEFSIM_ERR_UNSTABLE at an
 * infeasible x, the geometry's failures as defsim__contact_forces. */
defsim_status defsim__contact_vjp(defsim__contact *c, const double *x, const double *w,
                                  double *gx, double *gxn, double *gmass, double *gmu,
                                  double *gpose);

/* Largest alpha in (0, 1] such that no vertex comes closer to a collider than `fraction` of
 * its distance at x along x + t dx, t <= alpha (all DOFs). 0 on a callback failure. */
double defsim__contact_max_step(defsim__contact *c, const double *x, const double *dx,
                                double fraction);

/* Makes the guess x (all DOFs; pinned ones already at their end-of-step values) a Newton start
 * whose path from the step's start crosses no collider, relative to the collider's motion over
 * the step (position linear, rotation slerp; see docs/contact.md, "No tunnelling"):
 * 1. a base per free vertex: x_n, or x_n carried rigidly with a moving collider whose motion
 *    relative to the vertex standing still would come closer than DEFSIM__CONTACT_FRACTION of
 *    min(d_0, dhat) (d_0 at the start pose); the straight path, in each other collider's frame,
 *    from where x_n sits in it to the base must keep that clearance too, or the vertex is
 *    blocked (the energy is +inf for the rest of the step, so the step fails cleanly);
 * 2. x unchanged if defsim__contact_max_step from the base to x with fraction 0 allows the
 *    whole way (no vertex reaches a collider, no surface sweeps across a witness), else x =
 *    the base for every free vertex (so that a body keeps its shape).
 * Returns 1 if a vertex was carried (then a later cut of x back towards x_n, body contact's,
 * may cross a collider, and x must come back here), plus 2 if x was moved to the base. */
int defsim__contact_start(defsim__contact *c, double *x);

/* Marks the step's start infeasible (the energy is +inf until the next step begins): vertex
 * `vertex` (or -1: unknown) cannot be kept clear of every collider and body. */
void defsim__contact_block(defsim__contact *c, int32_t vertex);

/* The fraction of its distance that no CCD-limited step lets a vertex give up (0.2: a step
 * ends at least at 0.2 of the distance it started from). */
#define DEFSIM__CONTACT_FRACTION 0.2

/* Whether no pair can be active at x (a point no evaluation may have seen: the end of a step):
 * the broad phase's check at x, then no candidate pair. */
int defsim__contact_none(defsim__contact *c, const double *x);

/* Ends a successful step at (x, v): the total contact force per vertex into f (3 nv) and the
 * statistics. */
void defsim__contact_end(defsim__contact *c, const double *x, const double *v, double *f);

/* The watchdog's view of the colliders' work (docs/watchdog.md). Both take the poses of the
 * world's whole step (pos and pos1 of each collider), not those of a substep.
 * energy_start: the barrier or penalty energy (J, no friction) of the pairs at x with the
 * colliders at their pose at the start of the step; a barrier pair at d <= 0 there (its vertex
 * starts inside) counts 0, as the step leaves it out.
 * work: a bound on the work (J) that the colliders' motion over the step does on the vertices
 * of the pairs: per pair, the largest f . u of the contact force f at (x0, start pose),
 * (x0, end pose) and (x1, end pose), u the collider's surface displacement at the vertex, plus
 * friction's mu max |f| |u|; 0 when no collider moves. Pairs of the vertices at x1 join first. */
double defsim__contact_energy_start(defsim__contact *c, const double *x);
double defsim__contact_work(defsim__contact *c, const double *x0, const double *x1);

/* What c->failed means, for the error message (static text). */
const char *defsim__contact_failure(const defsim__contact *c);

/* The damping rate (1/s) that PENALTY friction adds at x: 2 mu lam / (eps_v m_i) at the deepest
 * contact, lam / m_i = khat (dhat - d), and at least that of a contact at d = 0 or carrying the
 * vertex's weight, whichever is deeper (contact that becomes active later, resting). */
double defsim__contact_damping_rate(defsim__contact *c, const double *x, const double gravity[3]);

#endif /* DEFSIM_CONTACT_H */
