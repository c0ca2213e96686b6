/* SPDX-License-Identifier: MIT */
/*
 * Reverse mode of the forces (docs/gradients.md): the vector-Jacobian products of f(x, v) with
 * respect to x, v and the system's parameters, as a loop over the terms' vjp ops (term.h), and
 * the parameter gradients they accumulate during a backward pass (tape.c owns them).
 */
#ifndef DEFSIM_ADJOINT_H
#define DEFSIM_ADJOINT_H

#include "system.h"

/* Gradients of a loss with respect to the compiled system's parameters, per element or DOF as
 * the system holds them (tape.c maps them to the bodies' material fields). */
typedef struct defsim__grad {
    double *mu[DEFSIM__TET_MODELS], *lambda[DEFSIM__TET_MODELS];  /* per element of a group */
    double *beta[DEFSIM__TET_MODELS + 1];   /* per element (springs last) */
    double *alpha3;                         /* per DOF: mass damping */
    double *mass;                           /* per vertex: lumped mass */
    double *fext;                           /* 3 nv: held external forces (of the step) */
    double *att_k, *att_c;                  /* per attachment: stiffness, damping */
    double *att_p;                          /* 3 per attachment: world target (of the step) */
    double *wmask;                          /* 3 nv scratch: w with pinned DOFs zeroed */
    double *xn;                             /* 3 nv: the step's start positions' adjoint through
                                               what contact lags from them (of the step) */
    double *mu_col;                         /* per collider slot: friction coefficient */
    double *pose_col;                       /* 12 per collider slot: its start and end poses
                                               (dp, dtheta each) of the step (contact.h) */
    double *mu_body;                        /* per body slot: body contact's friction */
    uint32_t want;                          /* DEFSIM__WANT_*: the costly ones the host asked for */
} defsim__grad;

/* Parameter gradients that cost more than a product each (the rest are always accumulated):
 * the Lame parameters (dP/dmu, dP/dlambda per element), and stiffness damping's beta (with its
 * clamped dP/dF per element also where beta is 0). */
enum { DEFSIM__WANT_LAME = 1u << 0, DEFSIM__WANT_BETA = 1u << 1 };

/* gx += (df/dx)^T w, gv += (df/dv)^T w (gx, gv may be NULL) at (x, v), parts `which`, over all
 * DOFs, w read with its pinned DOFs zeroed (into g->wmask); with acc set, the parameter
 * gradients into g too. Returns DEFSIM_ERR_UNSTABLE when a result is not finite. */
defsim_status defsim__forces_vjp(const defsim__system *s, const double *x, const double *v,
                                 uint32_t which, const double *w, double *gx, double *gv,
                                 defsim__grad *g, int acc);

/* The name of the first term of s whose forces cannot be differentiated, or NULL. */
const char *defsim__forces_vjp_missing(const defsim__system *s);

/* Central differences of a smooth scalar function of a few variables, for the third
 * derivatives that stiffness damping's forces -beta K(x) v need (the x-derivative of K(x) v,
 * and of K's clamp): the relative step of a variable of magnitude |u| is DEFSIM__VJP_FD_STEP
 * (1 + |u|). */
#define DEFSIM__VJP_FD_STEP 1e-5

#endif /* DEFSIM_ADJOINT_H */
