/* SPDX-License-Identifier: MIT */
/*
 * The implicit-solver core shared by newton_cholmod (backward Euler), newmark (average
 * acceleration) and bdf2. Each step minimises an incremental potential
 *
 *   g(x) = c_m/(2h^2) |x - y|^2_M + E(x) + c_d/(2h) |x - z|^2_D,   D = alpha M + B(x_b),
 *
 * by Newton's method with CHOLMOD, and sets v' = c_d/h (x' - z). A scheme chooses the numbers
 * c_m, c_d, the vectors y (inertial target), z (damping centre), the Newton start and the position
 * x_b at which the stiffness-damping matrix B is frozen, and keeps its own history; the core owns
 * the Newton loop, projection, line search, factorisation, pinned-DOF elimination and statistics.
 * README.md beside this file derives g for each scheme.
 *
 * Compiled into every implicit module (never into libdefsim); its symbols stay hidden.
 */
#ifndef DEFSIM_IMPLICIT_CORE_H
#define DEFSIM_IMPLICIT_CORE_H

#include "defsim/backend.h"

/* Vectors over all DOFs that a scheme may keep between steps (history) or use in prepare. */
#define DEFSIM__IC_MAX_WORK 6

typedef struct defsim__ic_solver defsim__ic_solver;

/* What a scheme sets in prepare, for the step from (x0, v0) with step h. */
typedef struct defsim__ic_targets {
    double cm, cd;             /* coefficients of the inertia and damping terms of g */
    const double *y, *z;       /* targets (all DOFs; pinned DOFs equal x0) */
    const double *guess;       /* first Newton iterate (all DOFs) */
} defsim__ic_targets;

typedef struct defsim__ic_scheme {
    const char *name;          /* the backend's name */
    uint32_t flags;            /* DEFSIM_BACKEND_* beyond NEEDS_MATRIX | IMPLICIT */
    int work_vectors;          /* DOF-long vectors in defsim__ic_solver.work (<= MAX_WORK) */
    /* Fills st from x0, v0 and h (y, z and guess may point at x0, v0, the solver's y, z or its
     * work vectors), and assembles the stiffness-damping matrix with defsim__ic_damping_matrix. */
    defsim_status (*prepare)(defsim__ic_solver *s, const defsim_host *host, defsim_system *sys,
                             double h, defsim__ic_targets *st);
    /* Optional: after a converged step (x0, v0 still hold the start of the step). */
    void (*accept)(defsim__ic_solver *s, double h);
    /* The first history_vectors of the work vectors hold the scheme's history while
     * history_valid is set (checkpoints save them with history_h). */
    int history_vectors;
    /* The scheme's own counters, after the core's (DEFSIM__IC_COUNTERS of them). */
    const defsim_counter_spec *counters;
    int32_t counter_count;
    /* The core's adjoint step serves the scheme (docs/gradients.md) when it keeps no history
     * and its targets are z = x0 + adjoint_z h v0 and y = x0 + h v0 + adjoint_a h^2 a0 with
     * M a0 = f_EG(x0) + f_D(z, v0) on the free DOFs (backward Euler: 0, 0; Newmark: 1/2, 1/4),
     * B frozen at z. 0: the backend is not differentiable. */
    int differentiable;
    double adjoint_z, adjoint_a;
    /* Where B is frozen at the pinned DOFs: x_b = x0 + adjoint_xb h v0 there (backward Euler 0,
     * Newmark 1/2, bdf2 1); a pinned DOF's z is x0 + adjoint_z h v0 in every scheme. */
    double adjoint_xb;
    /* Optional, for a differentiable scheme with history (bdf2; adjoint_z and adjoint_a are then
     * unused): maps the adjoints of the step's targets on the free DOFs, ay (of y), az (of z
     * through v' = c_d (x' - z)/h and the damping's velocity) and axb (of the position x_b at
     * which B was frozen, all DOFs), to ax0 and av0 on the free DOFs, adding the adjoints that
     * the next recorded step's history carried to this step's start and keeping those of this
     * step's history (the previous state) for the call that follows (a->first: none carried
     * yet). Called by the adjoint step after prepare, which saw the history from a->x_prev,
     * a->v_prev and a->h_prev in the first history_vectors work vectors (x then v) and
     * history_h, history_valid. */
    void (*adjoint_history)(defsim__ic_solver *s, double h, const defsim_adjoint_step *a,
                            const double *ay, const double *az, const double *axb);
} defsim__ic_scheme;

/* The core's counters ("<backend>.<name>": shifted_factorisations, contact_stops,
 * newton_iterations, line_search_backtracks, linear_solves, convergence_failures, time_factor,
 * time_solve, nonlinear_residual, clamped_iterations, extrapolations); a scheme's come after them in the backend's table. */
enum {
    DEFSIM__IC_SHIFTED = 0, DEFSIM__IC_CONTACT_STOPS, DEFSIM__IC_NEWTON, DEFSIM__IC_BACKTRACKS,
    DEFSIM__IC_LINEAR_SOLVES, DEFSIM__IC_CONVERGENCE_FAILURES, DEFSIM__IC_TIME_FACTOR,
    DEFSIM__IC_TIME_SOLVE, DEFSIM__IC_RESIDUAL, DEFSIM__IC_CLAMPED,
    DEFSIM__IC_EXTRAPOLATED, DEFSIM__IC_COUNTERS
};
#define DEFSIM__IC_MAX_SCHEME_COUNTERS 4

/* The per-world solver as schemes see it (the core's struct begins with it). */
struct defsim__ic_solver {
    const defsim__ic_scheme *scheme;
    int64_t ndof, n;           /* all DOFs, free DOFs */
    const int64_t *fdof;       /* free index -> DOF */
    const double *mass, *alpha;
    double *x0, *v0;           /* state at the start of the step (all DOFs) */
    double *y, *z;             /* buffers for defsim__ic_targets.y and z (all DOFs) */
    double *f;                 /* force scratch (all DOFs) */
    double *e, *be;            /* free-DOF scratch, free in prepare */
    double *bval;              /* B(x_b), pattern's nnz (NULL without stiffness damping) */
    double *work[DEFSIM__IC_MAX_WORK];
    const double *pin_vel;     /* driven pins' velocities over this step (all DOFs, zero on the
                                  free ones), or NULL: set by the core before prepare */
    const double *xb;          /* where defsim__ic_damping_matrix last froze B */
    double history_h;          /* scheme history: step of the last accepted step */
    int history_valid;         /* cleared by init, reset and failed steps */
    double *counters;          /* the backend's counters (core's, then the scheme's) */
};

/* The scheme of this module: each module defines exactly one, and the core builds the module's
 * backend table (name, flags | NEEDS_MATRIX | IMPLICIT, the core's ops) and entry point from it. */
extern const defsim__ic_scheme defsim__ic_module_scheme;

/* Assembles B at positions xb into s->bval (no-op without stiffness damping). */
defsim_status defsim__ic_damping_matrix(defsim__ic_solver *s, const defsim_host *host,
                                        defsim_system *sys, const double *xb);
/* out = B in over the free DOFs (free-DOF vectors); zero without stiffness damping. */
void defsim__ic_damping_product(const defsim__ic_solver *s, const double *in, double *out);

#endif /* DEFSIM_IMPLICIT_CORE_H */
