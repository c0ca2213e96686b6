/* SPDX-License-Identifier: MIT */
/*
 * Terms (DESIGN.md section 7; PolyFEM's Form, MuJoCo's mj_passive): every force family of a
 * system is a term, a const ops table plus a const model (built at plan time: an element group,
 * the attachments, the system itself) and mutable data (contact state, cached Hessian blocks).
 * forces.c, energy.c, assembly.c, stability.c and host.c loop over the system's list of terms
 * and name none; terms.c compiles the list from term_list.h, with only the terms the scene uses
 * (terms.h).
 *
 * The sums keep the order they had before terms (trajectories are bit-identical): forces in list
 * order, energies and matrices in each kind's energy_rank and matrix_rank. Where two families
 * shared one element matrix or one diagonal add before, they still do: a group's stiffness
 * damping matrix B is assembled by its elastic term (one element matrix k K + kd beta B), mass
 * damping's alpha M by the inertia term (one add of (m + md alpha) M per DOF).
 *
 * Linearisation: `linearise` evaluates and caches a term's Hessian blocks at x, `values` and
 * `apply` read what it cached. assembly.c calls it before matrix values (DEFSIM__LIN_VALUES:
 * evaluate, once per Newton iteration) and before products (DEFSIM__LIN_PRODUCT from the host's
 * service, DEFSIM__LIN_LAZY from internal loops such as the power iteration: evaluate only if x
 * or the coefficients differ from the cached ones), so a product does no geometry.
 *
 * Every op but compile is optional (NULL: nothing to do; a kind without counters or options
 * leaves their tables NULL), so kinds to come (cloth membranes and
 * hinges, rigid bodies) and ops to come (derivatives with respect to a term's parameters, for
 * gradients) are appended without touching the kinds that have no use for them.
 */
#ifndef DEFSIM_TERM_H
#define DEFSIM_TERM_H

#include "defsim/backend.h"
#include "term_list.h"

#include <stddef.h>
#include <stdint.h>

struct defsim__system;
struct defsim__work;
struct defsim__term_ops;
struct defsim__state;
struct defsim__settings;
struct defsim__body;
struct defsim__coupling_set;
struct defsim__collider_set;
struct defsim__contact;
struct defsim__body_contact;
struct defsim__messages;
struct defsim__grad;

/* Term kinds in list order (term_list.h). */
#define DEFSIM__TERM_ENUM(name) DEFSIM__TERM_KIND_##name,
enum { DEFSIM__TERM_LIST(DEFSIM__TERM_ENUM) DEFSIM__TERM_KINDS };
#undef DEFSIM__TERM_ENUM

/* At most one term per kind, except one elastic term per tet model and element (linear,
 * quadratic, mean-dilatation quadratic: 3 x 3 more for 4 models) and one membrane term per law. */
enum { DEFSIM__TERM_MAX = DEFSIM__TERM_KINDS + 12 };

/* Linearisation modes (above). */
enum { DEFSIM__LIN_VALUES = 0, DEFSIM__LIN_PRODUCT = 1, DEFSIM__LIN_LAZY = 2 };

/* What a start op did (host.c's contact_start runs the terms again while one asks). */
enum {
    DEFSIM__START_MOVED = 1,  /* it changed x */
    DEFSIM__START_AGAIN = 2   /* a later term's move may undo what it guaranteed: run it again */
};

/* Flags of a kind. */
enum {
    DEFSIM__TERM_ELASTIC = 1u << 0,   /* its energy is elastic (defsim__elastic_energy) */
    DEFSIM__TERM_BOUNDED = 1u << 1,   /* the power iteration leaves it out: lambda_bound bounds
                                         its share of the top eigenvalue */
    DEFSIM__TERM_GRAD_OFF = 1u << 2   /* off (not in the list: its parameters are all zero), a
                                         backward pass still calls its vjp, with gx and gv NULL,
                                         for the gradients of those parameters (damping rates) */
};

/* A linearisation cache a kind may use (the system keeps one per kind, so its buffers outlive
 * the list's recompilation and are freed with the plan). */
typedef struct defsim__term_cache {
    void *buf;                /* the kind's blocks */
    size_t cap;               /* bytes of buf */
    double *x;                /* 3 nv: the x they were evaluated at */
    int32_t nx;               /* vertices x was allocated for */
    int valid;                /* buf holds the blocks at x for k, kd and epoch */
    int any;                  /* some block is not zero */
    int64_t count;            /* blocks in buf */
    double k, kd;             /* the coefficients they were evaluated for */
    uint64_t epoch;           /* bumped when something besides x changes the blocks (a substep,
                                 friction's velocities) */
    uint64_t seen;            /* the epoch the blocks were evaluated at */
    int64_t linearisations;   /* evaluations, cumulative (statistic term.<kind>.linearisations) */
} defsim__term_cache;

/* One term of a system: what its ops evaluate. */
typedef struct defsim__term {
    const struct defsim__term_ops *ops;
    const void *model;        /* the kind's const model: an element group, the attachments, ... */
    void *data;               /* the kind's mutable data (contact state), or NULL */
    defsim__term_cache *cache;/* the kind's linearisation cache */
    int32_t index;            /* the kind's own index (the element group of an elastic term) */
} defsim__term;

/* What a force evaluation asks for. */
typedef struct defsim__eval {
    const double *x, *v;      /* v may be NULL without DEFSIM_FORCE_DAMPING */
    double t;                 /* time (s): the host's callback reads it */
    uint32_t which;           /* DEFSIM_FORCE_* */
} defsim__eval;

/* Damping rates of explicit stability (stability.c): the largest rates over the terms and the
 * additive rates. */
typedef struct defsim__rates {
    double alpha;             /* largest mass-like damping rate (1/s) */
    double beta;              /* largest stiffness damping (s) */
    double alpha_add;         /* rates that add to alpha (1/s) */
} defsim__rates;

typedef const struct defsim__system defsim__csys;

/* What a world's step hands its kinds' step hooks (step.c fills it from the world's sub-objects,
 * which the kinds see only through it). h = 0: no step, only collider contact begins (a stable
 * step's estimate, a checkpoint's replay of contact). */
typedef struct defsim__step_ctx {
    double h;                 /* the step (s), or 0 */
    const double *x0, *v0;    /* the state at the step's start (the world's copies) */
    struct defsim__state *state;
    const struct defsim__settings *set;
    const defsim_host *host;  /* the backend's table and what its calls take (a reset) */
    const defsim_backend *backend;
    defsim_system *handle;
    void *backend_state;
    int backend_ready;
    const struct defsim__body *bodies;
    int32_t nbodies;
    struct defsim__work *work;
    struct defsim__coupling_set *coupling;
    struct defsim__collider_set *colliders;
    struct defsim__contact *contact;            /* the world's collider contact state */
    struct defsim__body_contact *body_contact;  /* the world's body contact state */
    int *body_contact_last;   /* the last step had body contact on */
    uint32_t *passes;         /* DEFSIM_PASS_* of the step under way */
    int64_t *watchdog_trips;  /* the world's statistic */
    struct defsim__messages *msg;
} defsim__step_ctx;

/* A kind's ops. Every op but compile is optional (NULL: the term adds nothing there). */
typedef struct defsim__term_ops {
    const char *name;
    uint32_t flags;           /* DEFSIM__TERM_* */
    int8_t energy_rank;       /* place in the energy sums */
    int8_t matrix_rank;       /* place in the matrix sums (values and products) */

    /* Appends this kind's terms for s to out (room for DEFSIM__TERM_MAX); returns how many, or
     * -1 when out of memory (for its cache). */
    int (*compile)(struct defsim__system *s, defsim__term *out);

    /* Energy at x (J) added to e, in the term's own order of partial sums. */
    double (*energy)(const defsim__term *t, defsim__csys *s, struct defsim__work *wk,
                     const double *x, double e);
    /* Adds its forces to f; ORs the passes that ran into *used. */
    defsim_status (*forces)(const defsim__term *t, defsim__csys *s, const defsim__eval *ev,
                            double *f, uint32_t *used);

    /* The free-vertex pairs its blocks couple (sparse pattern): counts pair (fa, fb) in
     * pos[fa + 1] (list NULL) or appends fb to fa's list at pos[fa]. */
    void (*pairs)(const defsim__term *t, defsim__csys *s, int64_t *pos, int32_t *list);
    /* The pattern was built: the ranks of its node pairs in it. */
    defsim_status (*ranks)(const defsim__term *t, struct defsim__system *s);
    /* Merges pairs it found since (contact) into the pattern; *grew = 1 if it changed. */
    defsim_status (*pattern_update)(const defsim__term *t, struct defsim__system *s, int *grew);

    /* Evaluates and caches its blocks of k K + kd B at x (mode DEFSIM__LIN_*). */
    defsim_status (*linearise)(const defsim__term *t, defsim__csys *s, const double *x,
                               const defsim_matrix_coeffs *c, int mode);
    /* Adds its share of m M + md alpha M + k K + kd B into the pattern's values (upper or full,
     * column pointers cp); ORs DEFSIM_PASS_* into *passes (may be NULL). */
    void (*values)(const defsim__term *t, defsim__csys *s, const double *x,
                   const defsim_matrix_coeffs *c, int upper, const int64_t *cp, double *values,
                   uint32_t *passes);
    /* out += its share of A dx (pinned rows and columns zero); element Hessians projected with
     * proj. Contact terms read only what linearise cached. */
    void (*apply)(const defsim__term *t, defsim__csys *s, const double *x,
                  const defsim_matrix_coeffs *c, int proj, const double *dx, double *out);
    /* A kind whose blocks are one 3x3 per vertex (collider contact, the callback's Jacobian)
     * fills values and apply with assembly.c's defsim__diagonal_values and _apply, which read
     * its blocks from this: the 9 nv doubles B that linearise left and their factor *f for the
     * coefficients c (the ops add f B), or NULL when it adds nothing. */
    const double *(*diagonal)(const defsim__term *t, const defsim_matrix_coeffs *c, double *f);

    /* Largest alpha in (0, 1] along x + alpha dx that it allows (CCD). */
    double (*max_step)(const defsim__term *t, const double *x, const double *dx);
    /* Makes a Newton start x feasible for it, its path from the step's start clear; returns
     * DEFSIM__START_* bits. block: no start could be made so (the energy is +inf for the rest
     * of the step). */
    int (*start)(const defsim__term *t, double *x);
    void (*block)(const defsim__term *t);

    /* Explicit stability: the bound on the top eigenvalue of M^-1 K (1/s^2) with its share,
     * given lambda without it (BOUNDED kinds: the power iteration leaves them out), and its
     * damping rates at x into *r. */
    double (*lambda_bound)(const defsim__term *t, defsim__csys *s, double lambda);
    void (*rates)(const defsim__term *t, defsim__csys *s, const double *x, defsim__rates *r);

    /* The term's step hooks (terms.c calls them over the list from the kinds' hooks below): the
     * backend step under way covers the fraction [s0, s1] of the world's step with length h;
     * the backend's calls of the step ended. */
    void (*substep)(const defsim__term *t, double s0, double s1, double h);
    void (*step_end)(const defsim__term *t);
    /* The work its forces did over x0 -> x1 (J) into *work and, when start, its energy at x0
     * into *e0, for the watchdog; returns 0 (outputs untouched) when it has none. */
    int (*work)(const defsim__term *t, const double *x0, const double *x1, int start,
                double *e0, double *work);

    /* The kind's step hooks, called whether or not its term is in the list (terms.c: in list
     * order, end in the reverse), with what the step hands them: begin attaches what the kind's
     * term needs to the system (the list is compiled again when what attached, the kind's
     * state that the system points at, changed), restart begins again after a rolled-back
     * attempt, before and after bracket the backend's call i of n, finish closes the backend's
     * calls (st: their status; returns the step's), detach takes back what begin attached, end
     * closes the kind's part of the step with what was attached (its read-back, its checks),
     * readback adds to the host's read-back once every end ran. */
    defsim_status (*begin)(struct defsim__system *s, const defsim__step_ctx *c);
    defsim_status (*restart)(struct defsim__system *s, const defsim__step_ctx *c);
    void (*before)(const defsim__step_ctx *c, int64_t i, int64_t n);
    void (*after)(const defsim__step_ctx *c);
    defsim_status (*finish)(struct defsim__system *s, const defsim__step_ctx *c,
                            defsim_status st);
    void *(*attached)(const struct defsim__system *s);
    void (*detach)(struct defsim__system *s);
    defsim_status (*end)(struct defsim__system *s, const defsim__step_ctx *c, void *was,
                         defsim_status st);
    defsim_status (*readback)(struct defsim__system *s, const defsim__step_ctx *c, void *was,
                              defsim_status st);

    /* Its counters: their full names "<kind>.<counter>" (static; the world's statistics by name
     * list them after the core's and the backend's), and the value of counter i (0 <= i <
     * counter_count), read from the kind's cache (t->cache), which outlives the term: terms.c
     * calls it with a term that has only ops and cache when the kind is not in the list. */
    const char *const *counters;
    int32_t counter_count;
    double (*counter)(const defsim__term *t, int32_t i);

    /* Options it declares, the world's "core.<name>" (options.c lists them after the core's own,
     * in list order; their values reach the term through the resolved settings). */
    const defsim_option_spec *options;
    int32_t option_count;

    /* Its checkpoint chunk: save writes its state into buf when cap allows and returns the
     * bytes it needs; load reads what save wrote (DEFSIM_ERR_INVALID_ARGUMENT if it cannot). */
    size_t (*save)(const defsim__term *t, unsigned char *buf, size_t cap);
    defsim_status (*load)(const defsim__term *t, const unsigned char *buf, size_t n);

    /* Reverse mode (adjoint.h, docs/gradients.md): gx += (df/dx)^T w, gv += (df/dv)^T w of its
     * forces at ev (the parts ev->which; gx or gv NULL: not wanted), over every DOF, pinned ones
     * included (w is zero there); when g is not NULL, also w^T df/dp into g's parameter
     * gradients. A kind with forces and without vjp cannot be differentiated (a recording
     * refuses its scenes, naming it). */
    defsim_status (*vjp)(const defsim__term *t, defsim__csys *s, const defsim__eval *ev,
                         const double *w, double *gx, double *gv, struct defsim__grad *g);
} defsim__term_ops;

/* An ops table's usual groups of ops, for kind files that name their static functions after the
 * ops they fill (every kind does): compile, energy and forces; the matrix values and products. */
#define DEFSIM__TERM_FORCES .compile = compile, .energy = energy, .forces = forces
#define DEFSIM__TERM_MATRIX .values = values, .apply = apply

#endif /* DEFSIM_TERM_H */
