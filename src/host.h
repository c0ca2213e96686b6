/* SPDX-License-Identifier: MIT */
/*
 * What a backend's `defsim_system *` points to (backend.h keeps the type opaque): the compiled
 * system and, beside it, the mutable things the host services hand out or update (state,
 * workspaces, statistics, messages). The world embeds one and points it at its own parts.
 */
#ifndef DEFSIM_HOST_H
#define DEFSIM_HOST_H

#include "options.h"
#include "status.h"
#include "system.h"

/* The state a backend advances. */
typedef struct defsim__state {
    double *x, *v;            /* 3 nv */
    double t;                 /* s */
} defsim__state;

/* What the host services need of the host's coupling terms during a step (coupling.c): the
 * force callback and the driven pins of the backend step under way. Owned by the world. */
typedef struct defsim__coupling {
    defsim_force_fn fn;       /* NULL: no callback */
    defsim_force_jacobian_fn jac;
    void *user;
    int implicit;             /* the backend is DEFSIM_BACKEND_IMPLICIT */
    int hold;                 /* implicit without jac: f0 is held over the step */
    int failed;               /* the callback failed in this step */
    int in_step;              /* f0, K0, x0 hold the start of the current step */
    double *f0, *K0, *x0;     /* 3 nv, 9 nv, 3 nv: callback force, stiffness, positions at the
                                 start of an implicit step */
    double *kcb;              /* 9 nv: stiffness blocks -sym(dF/dx) of the latest Jacobian */
    double *veval;            /* 3 nv: velocities of the latest callback evaluation */
    double teval;
    int32_t nv;               /* the size the arrays were made for */

    /* the backend step under way covers [t0, t0 + h]; driven DOFs go from drv_x0 to drv_x1 */
    double t0, h;
    int64_t ndrv;
    int64_t ndrv_done;        /* ndrv of the last successful step (drv, drv_target kept) */
    int64_t *drv;             /* DOFs */
    double *drv_start, *drv_target;   /* at the start and end of the world's step */
    double *drv_x0, *drv_x1;  /* at the start and end of the backend step */
    double *pin_vel;          /* 3 nv: velocity of the driven DOFs over the step, 0 elsewhere */

    /* The callback's forces as the backend evaluated them in a step (for the watchdog's bound
     * on its work): the first and the last evaluation of the step under way (nrec of them so
     * far), and the last of the step before, which ended at time rec_prev_t (NaN: none). */
    double *rec_first, *rec_last, *rec_prev;
    int64_t nrec;
    double rec_prev_t;
} defsim__coupling;

struct defsim_system {
    defsim__system *sys;      /* built by plan.c; host services build its pattern on demand */
    defsim__work *work;
    defsim__state *state;
    const double *gravity;    /* the world's (m/s^2), for the host's gravity service */
    defsim_stats *stats;
    uint32_t *passes;         /* DEFSIM_PASS_* of the current step */
    defsim__messages *msg;
    defsim__options *options; /* option values and counters by name */
    defsim__coupling *cpl;
    const double *x_start;    /* 3 nv: positions at the start of the world's step */
    struct defsim__grad *grad;/* the parameter gradients of a backward pass under way (tape.c),
                                 else NULL: the reverse-mode services refuse */
};

/* The host's force callback (defined in term_callback.c, with its term). Adds the callback's
 * forces at (x, v, t) into f (3 nv). On a failure or a non-finite force,
 * sets c->failed and the error in msg and returns DEFSIM_ERR_CALLBACK (f is then undefined). */
defsim_status defsim__callback_forces(defsim__coupling *c, defsim__messages *msg, int32_t nv,
                                      const double *x, const double *v, double t, double *f);

/* The callback's stiffness blocks -sym(dF_i/dx_i), projected as `projection` says, at
 * (x, v, t) into K (9 nv). Same failure rules as defsim__callback_forces. */
defsim_status defsim__callback_stiffness(defsim__coupling *c, defsim__messages *msg, int32_t nv,
                                         int projection, const double *x, const double *v,
                                         double t, double *K);

/* Forces at (x, v, t) as the `forces` service gives them (v may be NULL: the step's start
 * velocities go to the callback), with the force callback as the coupling says. */
defsim_status defsim__host_forces(defsim_system *s, const double *x, const double *v, double t,
                                  uint32_t which, double *f);

/* The host service table handed to backends. */
extern const defsim_host defsim__host;

#endif /* DEFSIM_HOST_H */
