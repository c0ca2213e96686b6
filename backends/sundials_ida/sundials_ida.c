/* SPDX-License-Identifier: MIT */
/*
 * sundials_ida: adaptive variable-order BDF (SUNDIALS IDA); Newton systems solved either reduced
 * to the positions and factorised by CHOLMOD (linear_solver = cholmod, the default) or in full
 * by KLU (linear_solver = klu).
 *
 * The equations of motion over the free DOFs, as the implicit DAE F(t, y, y') = 0 with
 * y = [x, v]:
 *     F1 = x' - v                = 0
 *     F2 = M v' - f(x, v)        = 0      (f: elastic + gravity + Rayleigh damping)
 * Newton matrix J = dF/dy + cj dF/dy':
 *     [ cj I        -I                  ]
 *     [ K(x)        cj M + alpha M + B  ]
 * with K the elastic stiffness (projected as the world says), B = sum beta_e K_e (clamped), and
 * the derivative of the stiffness-damping force with respect to x left out (it only makes Newton
 * a little less than quadratic). One defsim_world_step(h) is one IDASolve to t + h with as many
 * internal steps as the tolerances need, stepping past t + h and handing the world IDA's
 * interpolation there (ida_step); IDA's history is kept between calls, ahead of the world, and
 * dropped (IDAReInit) when the host changes the state, pins or forces or a step fails.
 *
 * Tolerances are per second of simulated time, measured in positions (ida_weights): the local
 * position error of an internal step of length h_i is held to K (rtol |x| + atol) min(1, h_i/1 s)
 * and the local velocity error to K (rtol |v| + atol), which moves the positions by about
 * h_i times that over the next step; K = IDA_TOL_CALIBRATION. The position error after T seconds
 * is then near T times the tolerance and falls in proportion to it (README "Tolerances").
 *
 * Contents: constants, options and counters; the reduced Newton solver (CHOLMOD behind a
 * SUNLinearSolver); statistics; error weights; restart with consistent derivatives; the full
 * 2n x 2n Newton matrix and KLU; residual and Jacobian callbacks; set-up, stepping and the table.
 */
#include "defsim/backend.h"

#include "ida_private.h"
#include "sundials_common.h"

#include <ida/ida.h>
#include <sunlinsol/sunlinsol_klu.h>
#include <sunmatrix/sunmatrix_sparse.h>

#ifdef DEFSIM_IDA_CHOLMOD
#include "cholmod_solver.h"
#endif

#include <float.h>
#include <math.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* Time unit of the tolerances (s), and the smallest effective relative tolerance, far enough
 * above roundoff that IDA never stops with IDA_TOO_MUCH_ACC. */
#define IDA_TOL_TIME 1.0
#define IDA_TOL_FLOOR (500.0 * DBL_EPSILON)
/* Scale of the local tolerances, chosen so that the measured error sits within a factor of 10 of
 * the tolerance (README "Tolerances": 0.71 to 4.2 x T tol on the damped oscillators of
 * test_calibration at T = 0.5 and 5 s; at T = 0.5 s, 0.11 to 1.05 x T tol on the benchmark
 * cantilever, 0.36 to 2.7 on the rope, 0.06 to 1.3 on the stiff block, 21 tolerances from 1e-3
 * to 1e-8, 62 of the 63 points within a factor of 10). The last round's 10 was
 * measured with each call cutting IDA's step at its end; without the cuts it gave the
 * oscillators up to 23 x T tol. */
#define IDA_TOL_CALIBRATION 3.5
/* Calls that end exactly at t + h (IDASetStopTime) after the host changed the forces between
 * calls (README "One call"); the other calls let IDA step past t + h and interpolate. */
#define IDA_BOUND_CALLS 8
/* Reduced systems whose factorisation needs fewer flops are factorised simplicial. */
#define IDA_SUPERNODAL_FLOPS 1e8

/* Options, in the order of ida_options. */
enum { O_RTOL, O_ATOL, O_MAX_ORDER, O_MAX_STEPS, O_LINEAR_SOLVER, O_DELTA_CJ, O_PROJECTION, O_COUNT };
enum { LS_CHOLMOD = 0, LS_KLU = 1 };

#ifdef DEFSIM_IDA_CHOLMOD
#define LS_DEFAULT LS_CHOLMOD
#else
#define LS_DEFAULT LS_KLU
#endif

static const defsim_option_spec ida_options[O_COUNT] = {
    DEFSIM__SUN_OPTION_TOLERANCES,
    {"max_order", DEFSIM_OPTION_INT, 5, 1, 5, NULL, "highest BDF order"},
    {"max_internal_steps", DEFSIM_OPTION_INT, 100000, 1, 2e9, NULL,
     "internal steps allowed per defsim_world_step call"},
    {"linear_solver", DEFSIM_OPTION_CHOICE, LS_DEFAULT, 0, 0, "cholmod|klu",
     "Newton systems: cholmod (reduced n x n SPD system) or klu (full 2n x 2n system)"},
    /* IDA's default, 0.25, re-factorised at 39 of the cantilever's 81 steps at tol 1e-3.
     * 0.5 halved the cantilever's run times; 0.6 and more tripled the Newton iterations of the
     * conformance scenes and let Newton fail on the swinging beam (README "Cost"). */
    {"delta_cj", DEFSIM_OPTION_REAL, 0.5, 0.01, 0.99, NULL,
     "relative change of IDA's cj (1 / step size scale) that triggers a new Newton matrix "
     "(IDASetDeltaCjLSetup); larger: fewer factorisations, more Newton iterations"},
    /* Read by the core: the projection its matrix services apply (backend.h). */
    {"projection", DEFSIM_OPTION_CHOICE, DEFSIM_PROJECTION_CLAMP, 0, 0, "none|clamp|abs",
     "element Hessians in the Newton matrix: exact (none), or made positive semi-definite "
     "(clamp: negative eigenvalues to 0, abs: to their absolute value)"},
};

/* Counters, in the order of ida_counters. */
enum { C_STEPS, C_ORDER, C_RES, C_JAC, C_ETF, C_NCF, C_NNI, C_FACTOR, C_LINEAR_SOLVES,
       C_TIME_FACTOR, C_TIME_SOLVE, C_COUNT };

static const defsim_counter_spec ida_counters[C_COUNT] = {
    {"internal_steps", "internal (BDF) steps"},
    {"order", "BDF order of the last internal step"},
    {"residual_evals", "residual evaluations (force evaluations)"},
    {"jacobian_evals", "Newton matrix assemblies"},
    {"error_test_failures", "internal steps rejected by the error test"},
    {"convergence_failures", "Newton failures (IDA cut the step, or failed)"},
    {"newton_iterations", "Newton iterations"},
    {"factorizations", "numeric factorisations of the Newton matrix"},
    {"linear_solves", "Newton systems solved"},
    {"time_factor", "wall time of the factorisations (s)"},
    {"time_solve", "wall time of the triangular solves (s)"},
};

/* IDA's cumulative counters at the last read (reset to 0 by IDAReInit). */
typedef struct ida_counts {
    long steps, res, jac, etf, ncf, nni, setups;
} ida_counts;

typedef struct ida_chol ida_chol;

typedef struct ida_state {
    defsim__sun sun;           /* first: defsim__sun_reset reaches it through the state */
    const defsim_host *host;
    defsim_system *sys;
    void *mem;                 /* IDA memory */
    N_Vector y, yp;
    int64_t n;                 /* free DOFs; IDA integrates 2n unknowns */
    int64_t ndof;
    int damp_b;                /* stiffness damping: the (2,2) block has K's pattern */
    const int64_t *free_dofs;
    defsim_csc kpat;           /* the core's FULL pattern over free DOFs (borrowed) */
    sunindextype *jcp, *jri;   /* the 2n x 2n pattern */
    int64_t jnnz;
    double *kval, *bval;       /* K values; cj M + C + B values (damp_b only) */
    double *mf, *af;           /* mass and alpha per free DOF */
    double *x, *v, *f;         /* full DOF work arrays (pinned entries fixed); f has n more */
    double rtol, atol;
    int solver;                /* LS_CHOLMOD or LS_KLU */
    ida_chol *chol;            /* the reduced solver (LS_CHOLMOD) */
    SUNLinearSolver cls;       /* its SUNLinearSolver */
    SUNMatrix token;           /* the matrix IDA sees (no storage) */
    double t;                  /* the world's time at the last return (IDA's tn may be ahead) */
    ida_counts base;
    /* The forces of the free DOFs at IDA's last internal point (tn, phi[0]) as the last call
     * saw them: the next call evaluates them again, and a difference means the host changed its
     * inputs (external forces, callback, attachments, gravity) between the calls. */
    double *fcheck;
    double fcheck_t;           /* tn of fcheck */
    int fcheck_valid;
    int bound;                 /* calls left that end exactly at t + h (IDA_BOUND_CALLS) */
    /* KLU keeps the pivots of its last fresh factorisation (the first after a restart, or one
     * its condition estimate forced) through later refactorisations: the matrix values that
     * chose them, the values of the last set-up, and how that set-up factorised. */
    double *jpiv, *jlast;
    int klu_first;             /* the last set-up was the solver's first since its init */
    int klu_setups;            /* set-ups since the restart (0: jlast holds nothing) */
} ida_state;

static void scatter(ida_state *s, const double *y)
{
    defsim__sun_scatter(s->free_dofs, s->n, y, s->x, s->v);
}

static int ida_residual(realtype t, N_Vector yy, N_Vector yp, N_Vector rr, void *user)
{
    ida_state *s = user;
    const double *y = N_VGetArrayPointer(yy), *yd = N_VGetArrayPointer(yp);
    double *r = N_VGetArrayPointer(rr);
    scatter(s, y);
    /* Driven pins are not unknowns: on their paths at time t (their velocities are in s->v
     * from the restart, which each step that drives pins makes). */
    if (s->sun.pv) s->host->pin_positions(s->sys, t, s->x);
    /* Non-finite forces (an inverted neo-Hookean element): recoverable, IDA cuts the step. */
    if (defsim__sun_forces(&s->sun, s->x, s->v, t, DEFSIM_FORCE_ALL, s->f) != DEFSIM_OK) return 1;
    const int64_t n = s->n;
    for (int64_t i = 0; i < n; ++i) {
        r[i] = yd[i] - y[n + i];
        r[n + i] = s->mf[i] * yd[n + i] - s->f[s->free_dofs[i]];
    }
    return 0;
}

/* Whether KLU's last set-up factorised afresh (chose pivots): its first after an init, or a
 * refactorisation whose condition estimates sent it to a new factorisation (SUNLinSol_KLU 6.4:
 * rcond below eps^(2/3), then condest above its inverse). */
static int klu_last_fresh(const ida_state *s)
{
    if (s->klu_first) return 1;
    const sun_klu_common *c = SUNLinSol_KLUGetCommon(s->sun.LS);
    const double u23 = pow(DBL_EPSILON, 2.0 / 3.0);
    return c->rcond < u23 && c->condest > 1.0 / u23;
}

static int ida_jacobian(realtype t, realtype cj, N_Vector yy, N_Vector yp, N_Vector rr,
                        SUNMatrix J, void *user, N_Vector t1, N_Vector t2, N_Vector t3)
{
    (void)t; (void)yp; (void)rr; (void)t1; (void)t2; (void)t3;
    ida_state *s = user;
    /* The set-up before this one chose pivots: its matrix is what a checkpoint must save. */
    if (s->klu_setups > 0 && !s->klu_first && klu_last_fresh(s)) {
        double *tmp = s->jpiv;
        s->jpiv = s->jlast;
        s->jlast = tmp;
    }
    const int64_t n = s->n;
    scatter(s, N_VGetArrayPointer(yy));
    const defsim_matrix_coeffs ck = {1.0, 0.0, 0.0, 0.0};
    if (s->host->matrix_values(s->sys, s->x, &ck, DEFSIM_TRIANGLE_FULL, s->kval) != DEFSIM_OK)
        return 1;
    if (s->damp_b) {
        const defsim_matrix_coeffs cd = {0.0, 1.0, cj, 1.0};
        if (s->host->matrix_values(s->sys, s->x, &cd, DEFSIM_TRIANGLE_FULL, s->bval) != DEFSIM_OK)
            return 1;
    }
    /* IDA zeroes the whole matrix (pattern included) before calling: write both. */
    sunindextype *cp = SUNSparseMatrix_IndexPointers(J), *ri = SUNSparseMatrix_IndexValues(J);
    double *a = SUNSparseMatrix_Data(J);
    memcpy(cp, s->jcp, (size_t)(2 * n + 1) * sizeof *cp);
    memcpy(ri, s->jri, (size_t)s->jnnz * sizeof *ri);
    const int64_t *kcp = s->kpat.col_ptr;
    int64_t p = 0;
    for (int64_t j = 0; j < n; ++j) {
        a[p++] = cj;
        for (int64_t k = kcp[j]; k < kcp[j + 1]; ++k) a[p++] = s->kval[k];
    }
    for (int64_t j = 0; j < n; ++j) {
        a[p++] = -1.0;
        if (s->damp_b)
            for (int64_t k = kcp[j]; k < kcp[j + 1]; ++k) a[p++] = s->bval[k];
        else
            a[p++] = (cj + s->af[j]) * s->mf[j];
    }
    /* IDA calls the set-up next, with these values. */
    memcpy(s->jlast, a, (size_t)s->jnnz * sizeof *a);
    s->klu_first = ((SUNLinearSolverContent_KLU)s->sun.LS->content)->first_factorize != 0;
    if (s->klu_first) memcpy(s->jpiv, a, (size_t)s->jnnz * sizeof *a);
    ++s->klu_setups;
    return 0;
}

/* ------------------------------------------------------------------------------------------ */
/* The reduced Newton solver (linear_solver = cholmod).
 *
 * IDA's Newton system J d = b with d = [dx, dv], b = [b1, b2] reads
 *     cj dx - dv                  = b1
 *     K dx + (cj M + C + B) dv    = b2
 * Eliminating dv = cj dx - b1 leaves the symmetric n x n system
 *     S dx = b2 + (cj M + C + B) b1,    S = cj^2 M + cj (C + B) + K,
 * positive definite when K is projected (K, B positive semi-definite, M positive). CHOLMOD
 * analyses S's pattern (upper triangle) once. For IDA this is a direct solver with a token
 * matrix: IDA's Jacobian call (chol_jacobian, which receives cj and the iterate) assembles S,
 * the solver's setup factorises it, and each solve is two triangular solves plus the recovery of
 * dv. IDA itself scales the correction when it solves with a factorisation made for another cj,
 * as for any matrix-based solver. */
#ifdef DEFSIM_IDA_CHOLMOD
struct ida_chol {
    defsim__chol ch;           /* A wraps upat and sval */
    defsim_csc upat;           /* the core's UPPER pattern over free DOFs (borrowed) */
    double *sval, *bval;       /* S values; B values (damp_b only), on upat */
    double cj;                 /* cj of the current factorisation */
};

static SUNLinearSolver_Type chol_type(SUNLinearSolver S)
{
    (void)S;
    return SUNLINEARSOLVER_DIRECT;
}

/* The token matrix IDA zeroes and hands to the Jacobian call: the values live in ida_chol. */
static SUNMatrix_ID token_id(SUNMatrix A)
{
    (void)A;
    return SUNMATRIX_CUSTOM;
}

static int token_zero(SUNMatrix A)
{
    (void)A;
    return 0;
}

static int chol_jacobian(realtype t, realtype cj, N_Vector yy, N_Vector yp, N_Vector rr,
                         SUNMatrix J, void *user, N_Vector t1, N_Vector t2, N_Vector t3)
{
    (void)t; (void)yp; (void)rr; (void)J; (void)t1; (void)t2; (void)t3;
    ida_state *s = user;
    ida_chol *c = s->chol;
    scatter(s, N_VGetArrayPointer(yy));
    const defsim_matrix_coeffs cs = {1.0, cj, cj * cj, cj};
    if (s->host->matrix_values(s->sys, s->x, &cs, DEFSIM_TRIANGLE_UPPER, c->sval) != DEFSIM_OK)
        return 1;
    if (s->damp_b) {
        const defsim_matrix_coeffs cb = {0.0, 1.0, 0.0, 0.0};
        if (s->host->matrix_values(s->sys, s->x, &cb, DEFSIM_TRIANGLE_UPPER, c->bval) !=
            DEFSIM_OK)
            return 1;
    }
    c->cj = cj;
    return 0;
}

static SUNLinearSolver_ID chol_id(SUNLinearSolver S)
{
    (void)S;
    return SUNLINEARSOLVER_CUSTOM;
}

static int chol_setup(SUNLinearSolver LS, SUNMatrix A)
{
    (void)A;
    ida_state *s = LS->content;
    ida_chol *c = s->chol;
    const double t0 = s->host->wall_time();
    cholmod_l_factorize(&c->ch.A, c->ch.L, &c->ch.cc);
    defsim__sun_count(s->host, s->sys, C_TIME_FACTOR, s->host->wall_time() - t0);
    if (c->ch.cc.status < CHOLMOD_OK) return SUNLS_MEM_FAIL;
    /* Not positive definite (an unprojected K): IDA cuts the step, which raises cj^2 M. */
    if (c->ch.cc.status != CHOLMOD_OK) return SUNLS_PACKAGE_FAIL_REC;
    return SUNLS_SUCCESS;
}

/* out += B in over free DOFs, B given by its upper triangle. */
static void sym_upper_add(const defsim_csc *p, const double *val, const double *in, double *out)
{
    for (int64_t j = 0; j < p->n; ++j)
        for (int64_t k = p->col_ptr[j]; k < p->col_ptr[j + 1]; ++k) {
            const int64_t i = p->row_idx[k];
            out[i] += val[k] * in[j];
            if (i != j) out[j] += val[k] * in[i];
        }
}

static int chol_solve(SUNLinearSolver LS, SUNMatrix A, N_Vector xv, N_Vector bv, realtype tol)
{
    (void)A;
    (void)tol;
    ida_state *s = LS->content;
    ida_chol *c = s->chol;
    const int64_t n = s->n;
    const double *b = N_VGetArrayPointer(bv);
    double *d = N_VGetArrayPointer(xv);
    double *r = c->ch.rhs->x;
    const double cj = c->cj;
    const double t0 = s->host->wall_time();
    for (int64_t i = 0; i < n; ++i) r[i] = b[n + i] + (cj + s->af[i]) * s->mf[i] * b[i];
    if (s->damp_b) sym_upper_add(&c->upat, c->bval, b, r);
    if (!cholmod_l_solve2(CHOLMOD_A, c->ch.L, c->ch.rhs, NULL, &c->ch.sol, NULL, &c->ch.ywork,
                          &c->ch.ework, &c->ch.cc))
        return SUNLS_MEM_FAIL;
    const double *dx = c->ch.sol->x;
    for (int64_t i = 0; i < n; ++i) {
        const double dxi = dx[i];
        d[n + i] = cj * dxi - b[i];
        d[i] = dxi;
    }
    defsim__sun_count(s->host, s->sys, C_TIME_SOLVE, s->host->wall_time() - t0);
    defsim__sun_count(s->host, s->sys, C_LINEAR_SOLVES, 1.0);
    return SUNLS_SUCCESS;
}

static int chol_free(SUNLinearSolver LS)
{
    SUNLinSolFreeEmpty(LS);
    return SUNLS_SUCCESS;
}

static void chol_destroy(ida_state *s)
{
    ida_chol *c = s->chol;
    if (!c) return;
    defsim__chol_finish(&c->ch);
    s->host->release(c->sval);
    s->host->release(c->bval);
    s->host->release(c);
    s->chol = NULL;
}

/* The reduced solver: pattern, symbolic analysis (AMD, once), and its SUNLinearSolver. */
static defsim_status chol_create(ida_state *s)
{
    const defsim_host *host = s->host;
    ida_chol *c = defsim__sun_calloc(host, 1, sizeof *c);
    if (!c) goto oom;
    s->chol = c;
    defsim_status st = host->matrix_pattern(s->sys, DEFSIM_TRIANGLE_UPPER, &c->upat);
    if (st != DEFSIM_OK) return st;
    c->sval = defsim__sun_calloc(host, (size_t)c->upat.nnz, sizeof *c->sval);
    c->bval = s->damp_b ? defsim__sun_calloc(host, (size_t)c->upat.nnz, sizeof *c->bval) : NULL;
    if (!c->sval || (s->damp_b && !c->bval)) goto oom;
    defsim__chol_start(&c->ch);
    /* AMD only: METIS keeps global random state, and these systems are small. */
    c->ch.cc.nmethods = 1;
    c->ch.cc.method[0].ordering = CHOLMOD_AMD;
    c->ch.cc.postorder = 1;
    c->ch.cc.quick_return_if_not_posdef = 1;
    c->ch.cc.print = 0;
    defsim__chol_wrap(&c->ch, &c->upat, c->sval);
    c->ch.L = cholmod_l_analyze(&c->ch.A, &c->ch.cc);
    /* Small factorisations go simplicial: no BLAS and no OpenMP teams, which on a loaded
     * machine made the supernodal one of the cantilever (6 Mflop) up to 5x slower. */
    if (c->ch.L && c->ch.L->is_super && c->ch.cc.fl < IDA_SUPERNODAL_FLOPS) {
        cholmod_l_free_factor(&c->ch.L, &c->ch.cc);
        c->ch.cc.supernodal = CHOLMOD_SIMPLICIAL;
        c->ch.L = cholmod_l_analyze(&c->ch.A, &c->ch.cc);
    }
    c->ch.rhs = cholmod_l_zeros((size_t)s->n, 1, CHOLMOD_REAL, &c->ch.cc);
    if (!c->ch.L || !c->ch.rhs) {
        host->set_error(s->sys, "sundials_ida: CHOLMOD analysis failed (out of memory)");
        return DEFSIM_ERR_OUT_OF_MEMORY;
    }
    char msg[200];
    snprintf(msg, sizeof msg,
             "sundials_ida: reduced system of %lld free DOFs, nnz(S upper) %lld, nnz(L) %.0f, "
             "%.3g Mflop per factorisation, %s",
             (long long)s->n, (long long)c->upat.nnz, c->ch.cc.lnz, c->ch.cc.fl * 1e-6,
             c->ch.L->is_super ? "supernodal" : "simplicial");
    host->log(s->sys, 2, msg);
    s->cls = SUNLinSolNewEmpty(s->sun.ctx);
    s->token = SUNMatNewEmpty(s->sun.ctx);
    if (!s->cls || !s->token) goto oom;
    s->token->ops->getid = token_id;
    s->token->ops->zero = token_zero;
    s->cls->content = s;
    s->cls->ops->gettype = chol_type;
    s->cls->ops->getid = chol_id;
    s->cls->ops->setup = chol_setup;
    s->cls->ops->solve = chol_solve;
    s->cls->ops->free = chol_free;
    return DEFSIM_OK;
oom:
    host->set_error(s->sys, "sundials_ida: out of memory");
    return DEFSIM_ERR_OUT_OF_MEMORY;
}
#endif

/* Adds IDA's counters since the last read to the world's statistics. */
static void update_stats(ida_state *s)
{
    ida_counts c = {0, 0, 0, 0, 0, 0, 0};
    int order = 0;
    IDAGetNumLinSolvSetups(s->mem, &c.setups);
    IDAGetNumSteps(s->mem, &c.steps);
    IDAGetNumResEvals(s->mem, &c.res);
    IDAGetNumJacEvals(s->mem, &c.jac);
    IDAGetNumErrTestFails(s->mem, &c.etf);
    IDAGetNumNonlinSolvConvFails(s->mem, &c.ncf);
    IDAGetNumNonlinSolvIters(s->mem, &c.nni);
    IDAGetLastOrder(s->mem, &order);
    const defsim_host *h = s->host;
    defsim__sun_count(h, s->sys, C_STEPS, (double)(c.steps - s->base.steps));
    defsim__sun_count(h, s->sys, C_RES, (double)(c.res - s->base.res));
    defsim__sun_count(h, s->sys, C_ETF, (double)(c.etf - s->base.etf));
    defsim__sun_count(h, s->sys, C_NCF, (double)(c.ncf - s->base.ncf));
    defsim__sun_count(h, s->sys, C_NNI, (double)(c.nni - s->base.nni));
    defsim__sun_count(h, s->sys, C_JAC, (double)(c.jac - s->base.jac));
    defsim__sun_count(h, s->sys, C_FACTOR, (double)(c.setups - s->base.setups));
    double *cs = defsim__sun_counters(h, s->sys);
    if (cs && c.steps > 0) cs[C_ORDER] = order;   /* a level, not a sum */
    s->base = c;
}

/* Error weights (README "Tolerances"): positions 1 / (K (rtol |x_i| + atol) s) with
 * s = min(1, h / IDA_TOL_TIME) for the step of length h about to be taken (IDA calls this before
 * every step after the first; the first step, whose length IDA has not chosen yet, gets s = 1);
 * velocities 1 / (K (rtol |v_i| + atol)). A velocity error dv made in a step of length h moves
 * the positions by h dv over the next step, so both kinds of local error add at most about
 * K tol h of position error per step: K tol per second of simulated time. K = IDA_TOL_CALIBRATION. */
static int ida_weights(N_Vector yv, N_Vector ewt, void *user)
{
    ida_state *s = user;
    long nst = 0;
    realtype h = 0.0;
    IDAGetNumSteps(s->mem, &nst);
    IDAGetCurrentStep(s->mem, &h);
    double f = (nst > 0 && h > 0.0) ? fabs(h) / IDA_TOL_TIME : 1.0;
    if (f > 1.0) f = 1.0;
    if (f * s->rtol < IDA_TOL_FLOOR) f = IDA_TOL_FLOOR / s->rtol;
    const double kx = IDA_TOL_CALIBRATION * f, kv = IDA_TOL_CALIBRATION;
    const double *y = N_VGetArrayPointer(yv);
    double *w = N_VGetArrayPointer(ewt);
    const int64_t n = s->n;
    for (int64_t i = 0; i < n; ++i) w[i] = 1.0 / (kx * (s->rtol * fabs(y[i]) + s->atol));
    for (int64_t i = n; i < 2 * n; ++i) w[i] = 1.0 / (kv * (s->rtol * fabs(y[i]) + s->atol));
    return 0;
}

static defsim_status ida_fail(ida_state *s, const char *call, int flag)
{
    char *name = IDAGetReturnFlagName(flag);
    realtype tcur = s->t;
    if (s->mem) IDAGetCurrentTime(s->mem, &tcur);
    defsim__sun_fail(&s->sun, "sundials_ida", call, name, flag, tcur);
    free(name);   /* IDAGetReturnFlagName returns a malloc'd string */
    s->sun.need_reinit = 1;
    return DEFSIM_ERR_NOT_CONVERGED;
}

/* Restarts IDA from the world's state with consistent derivatives y' = [v, M^-1 f(x, v)]. */
static defsim_status ida_restart(ida_state *s)
{
    const defsim_host *host = s->host;
    memcpy(s->x, host->positions(s->sys), (size_t)s->ndof * sizeof *s->x);
    memcpy(s->v, host->velocities(s->sys), (size_t)s->ndof * sizeof *s->v);
    if (defsim__sun_forces(&s->sun, s->x, s->v, host->time(s->sys), DEFSIM_FORCE_ALL, s->f) !=
        DEFSIM_OK) {
        host->set_error(s->sys, "sundials_ida: the forces at the initial state are not finite");
        return DEFSIM_ERR_UNSTABLE;
    }
    double *y = N_VGetArrayPointer(s->y), *yp = N_VGetArrayPointer(s->yp);
    const int64_t n = s->n;
    for (int64_t i = 0; i < n; ++i) {
        const int64_t d = s->free_dofs[i];
        y[i] = s->x[d];
        y[n + i] = s->v[d];
        yp[i] = s->v[d];
        yp[n + i] = s->f[d] / s->mf[i];
    }
    s->t = host->time(s->sys);
    int flag = IDAReInit(s->mem, s->t, s->y, s->yp);
    if (flag < 0) return ida_fail(s, "IDAReInit", flag);
    memset(&s->base, 0, sizeof s->base);
    s->klu_setups = 0;
    s->klu_first = 0;
    s->sun.need_reinit = 0;
    s->fcheck_valid = 0;
    s->bound = 0;
    return DEFSIM_OK;
}

static void ida_fini(const defsim_host *host, defsim_system *sys, void *state)
{
    (void)sys;
    ida_state *s = state;
    if (s->cls) SUNLinSolFree(s->cls);
    if (s->token) SUNMatFreeEmpty(s->token);
    s->cls = NULL;
    s->token = NULL;
#ifdef DEFSIM_IDA_CHOLMOD
    chol_destroy(s);
#endif
    N_Vector *vectors[] = {&s->y, &s->yp};
    defsim__sun_fini(&s->sun, &s->mem, IDAFree, vectors, 2);
    host->release(s->jcp); host->release(s->jri);
    host->release(s->kval); host->release(s->bval);
    host->release(s->jpiv); host->release(s->jlast);
    s->jpiv = s->jlast = NULL;
    host->release(s->mf); host->release(s->af);
    host->release(s->x); host->release(s->v); host->release(s->f);
    host->release(s->fcheck);
    s->jcp = s->jri = NULL;
    s->kval = s->bval = s->mf = s->af = s->x = s->v = s->f = s->fcheck = NULL;
}

/* The 2n x 2n pattern: column j < n holds row j (cj I) then rows n + K's rows of column j;
 * column n + j holds row j (-I) then rows n + K's rows (with stiffness damping) or row n + j. */
static void build_pattern(ida_state *s)
{
    const int64_t n = s->n, *kcp = s->kpat.col_ptr, *kri = s->kpat.row_idx;
    int64_t p = 0;
    s->jcp[0] = 0;
    for (int64_t j = 0; j < n; ++j) {
        s->jri[p++] = j;
        for (int64_t k = kcp[j]; k < kcp[j + 1]; ++k) s->jri[p++] = n + kri[k];
        s->jcp[j + 1] = p;
    }
    for (int64_t j = 0; j < n; ++j) {
        s->jri[p++] = j;
        if (s->damp_b)
            for (int64_t k = kcp[j]; k < kcp[j + 1]; ++k) s->jri[p++] = n + kri[k];
        else
            s->jri[p++] = n + j;
        s->jcp[n + j + 1] = p;
    }
}

#define SET(call) DEFSIM__SUN_SET(s, ida_fail, IDA_MEM_FAIL, #call, call)

/* The full 2n x 2n Newton matrix and KLU (linear_solver = klu). */
static defsim_status klu_create(ida_state *s)
{
    const defsim_host *host = s->host;
    defsim_status st = host->matrix_pattern(s->sys, DEFSIM_TRIANGLE_FULL, &s->kpat);
    if (st != DEFSIM_OK) return st;
    const int64_t n = s->n, knnz = s->kpat.nnz;
    s->jnnz = 2 * n + knnz + (s->damp_b ? knnz : n);
    s->jcp = defsim__sun_calloc(host, (size_t)(2 * n + 1), sizeof *s->jcp);
    s->jri = defsim__sun_calloc(host, (size_t)s->jnnz, sizeof *s->jri);
    s->kval = defsim__sun_calloc(host, (size_t)knnz, sizeof *s->kval);
    s->bval = s->damp_b ? defsim__sun_calloc(host, (size_t)knnz, sizeof *s->bval) : NULL;
    s->jpiv = defsim__sun_calloc(host, (size_t)s->jnnz, sizeof *s->jpiv);
    s->jlast = defsim__sun_calloc(host, (size_t)s->jnnz, sizeof *s->jlast);
    if (!s->jcp || !s->jri || !s->kval || (s->damp_b && !s->bval) || !s->jpiv || !s->jlast) {
        host->set_error(s->sys, "sundials_ida: out of memory");
        return DEFSIM_ERR_OUT_OF_MEMORY;
    }
    build_pattern(s);
    return defsim__sun_klu(&s->sun, s->y, 2 * n, s->jnnz, C_LINEAR_SOLVES);
}

static defsim_status ida_init(const defsim_host *host, defsim_system *sys, void *state)
{
    ida_state *s = state;
    double o[O_COUNT];
    DEFSIM__SUN_INIT_PROLOGUE(s, host, sys, ida_options, O_COUNT, o);
    s->solver = (int)o[O_LINEAR_SOLVER];
#ifndef DEFSIM_IDA_CHOLMOD
    if (s->solver == LS_CHOLMOD) {
        host->set_error(sys, "sundials_ida: linear_solver cholmod: this build has no CHOLMOD "
                             "(use klu)");
        return DEFSIM_ERR_BACKEND_UNAVAILABLE;
    }
#endif
    const int64_t n = s->n;
    s->damp_b = host->has_stiffness_damping(sys) != 0;
    s->mf = defsim__sun_calloc(host, (size_t)n, sizeof *s->mf);
    s->af = defsim__sun_calloc(host, (size_t)n, sizeof *s->af);
    s->x = defsim__sun_calloc(host, (size_t)s->ndof, sizeof *s->x);
    s->v = defsim__sun_calloc(host, (size_t)s->ndof, sizeof *s->v);
    s->f = defsim__sun_calloc(host, (size_t)(s->ndof + n), sizeof *s->f);
    s->fcheck = defsim__sun_calloc(host, (size_t)n, sizeof *s->fcheck);
    if (!s->mf || !s->af || !s->x || !s->v || !s->f || !s->fcheck) {
        host->set_error(sys, "sundials_ida: out of memory");
        return DEFSIM_ERR_OUT_OF_MEMORY;
    }
    const double *m = host->mass(sys), *alpha = host->mass_damping(sys);
    for (int64_t i = 0; i < n; ++i) {
        s->mf[i] = m[s->free_dofs[i]];
        s->af[i] = alpha[s->free_dofs[i]];
    }

    defsim_status st = defsim__sun_open(&s->sun, host, sys);
    if (st != DEFSIM_OK) return st;
    s->y = N_VNew_Serial((sunindextype)(2 * n), s->sun.ctx);
    if (s->y) defsim__sun_fast_ops(s->y);   /* before IDA clones it */
    s->yp = s->y ? N_VClone(s->y) : NULL;
    if (!s->y || !s->yp) {
        host->set_error(sys, "sundials_ida: out of memory");
        return DEFSIM_ERR_OUT_OF_MEMORY;
    }
    N_VConst(0.0, s->y);
    N_VConst(0.0, s->yp);
#ifdef DEFSIM_IDA_CHOLMOD
    st = s->solver == LS_CHOLMOD ? chol_create(s) : klu_create(s);
#else
    st = klu_create(s);
#endif
    if (st != DEFSIM_OK) return st;
    s->mem = IDACreate(s->sun.ctx);
    if (!s->mem) {
        host->set_error(sys, "sundials_ida: IDACreate failed (out of memory)");
        return DEFSIM_ERR_OUT_OF_MEMORY;
    }
    SET(IDASetErrHandlerFn(s->mem, defsim__sun_error_handler, &s->sun));
    SET(IDAInit(s->mem, ida_residual, host->time(sys), s->y, s->yp));
    /* atol is the same number for x (m) and v (m/s): see README "Tolerances". */
    s->rtol = o[O_RTOL];
    s->atol = o[O_ATOL];
    SET(IDAWFtolerances(s->mem, ida_weights));
    SET(IDASetUserData(s->mem, s));
    SET(IDASetMaxOrd(s->mem, (int)o[O_MAX_ORDER]));
    SET(IDASetMaxNumSteps(s->mem, (long)o[O_MAX_STEPS]));
    SET(IDASetDeltaCjLSetup(s->mem, o[O_DELTA_CJ]));
    if (s->solver == LS_KLU) {
        SET(IDASetLinearSolver(s->mem, s->sun.LS, s->sun.J));
        SET(IDASetJacFn(s->mem, ida_jacobian));
    } else {
        SET(IDASetLinearSolver(s->mem, s->cls, s->token));
        SET(IDASetJacFn(s->mem, chol_jacobian));
    }
    return DEFSIM_OK;
}

/* The forces of the free DOFs at IDA's last internal point (tn, y_n = phi[0]) into out. */
static defsim_status point_forces(ida_state *s, double *out)
{
    scatter(s, N_VGetArrayPointer(defsim__ida_yn(s->mem)));
    if (defsim__sun_forces(&s->sun, s->x, s->v, defsim__ida_tn(s->mem), DEFSIM_FORCE_ALL, s->f) !=
        DEFSIM_OK)
        return DEFSIM_ERR_UNSTABLE;
    for (int64_t i = 0; i < s->n; ++i) out[i] = s->f[s->free_dofs[i]];
    return DEFSIM_OK;
}

/* Whether the host changed the forces since the last call: those at IDA's last internal point
 * differ from what the last call saw there (bit for bit; a point whose forces cannot be
 * evaluated counts as changed). */
static int forces_changed(ida_state *s)
{
    if (point_forces(s, s->f + s->ndof) != DEFSIM_OK) return 1;
    return memcmp(s->f + s->ndof, s->fcheck, (size_t)s->n * sizeof *s->fcheck) != 0;
}

/* One call (README "One call"): IDA_NORMAL to t + h. IDA steps past t + h and the world gets the
 * interpolated state, IDA's history staying ahead of it; the next call continues from there
 * (or only interpolates) unless the host changed what IDA integrated. A change of the state,
 * pins, bodies, options or colliders arrives as a restart (reset or init); one of the forces is
 * found here (forces_changed), and then IDA restarts from the world's state if it is ahead, and
 * this call and the next IDA_BOUND_CALLS - 1 end exactly at t + h (IDASetStopTime), keeping
 * the history through further changes as before. Driven pins restart at each call and always
 * end exactly at t + h (their paths are defined only within the call). */
static defsim_status ida_step(const defsim_host *host, defsim_system *sys, void *state, double h)
{
    ida_state *s = state;
    if (s->n == 0) return DEFSIM_OK;
    defsim__sun_drive_begin(&s->sun, 1);
    const int changed = !s->sun.need_reinit && s->fcheck_valid && forces_changed(s);
    if (changed && defsim__ida_tn(s->mem) != s->t) s->sun.need_reinit = 1;
    if (s->sun.need_reinit) {
        defsim_status st = ida_restart(s);
        if (st != DEFSIM_OK) return st;
    }
    if (changed) s->bound = IDA_BOUND_CALLS;
    const double tout = s->t + h;
    if (s->bound > 0 || s->sun.pv) {
        int flag = IDASetStopTime(s->mem, tout);
        if (flag < 0) return ida_fail(s, "IDASetStopTime", flag);
    } else {
        defsim__ida_clear_stop_time(s->mem);
    }
    if (s->bound > 0) --s->bound;
    realtype tret = s->t;
    int flag = IDASolve(s->mem, tout, &tret, s->y, s->yp, IDA_NORMAL);
    update_stats(s);
    if (flag < 0) return ida_fail(s, "IDASolve", flag);
    defsim__sun_scatter(s->free_dofs, s->n, N_VGetArrayPointer(s->y), host->positions(sys),
                        host->velocities(sys));
    s->t = tout;
    /* What this call's inputs give at IDA's new internal point, for the next call to compare
     * (an unchanged point was compared at the start of this call). */
    const double tn = defsim__ida_tn(s->mem);
    if (!s->fcheck_valid || tn != s->fcheck_t) {
        s->fcheck_valid = point_forces(s, s->fcheck) == DEFSIM_OK;
        s->fcheck_t = tn;
        if (!s->fcheck_valid && tn != s->t) s->sun.need_reinit = 1;
    }
    return DEFSIM_OK;
}

/* ------------------------------------------------------------------------------------------ */
/* Checkpoints: IDA's whole step history (the divided differences phi, the coefficients, step
 * size, order and the counters its heuristics read), and the Newton matrix of the last set-up,
 * which is factorised again on load. CHOLMOD factorises the same values into the same bits.
 * KLU's first factorisation after a restart chooses pivots that later refactorisations keep: a
 * KLU checkpoint also holds the matrix that chose them (unless the last set-up did), which the
 * load factorises before refactorising the last one (README "Checkpoints"). */

/* The history's scalars, then the world's time: the scalars of a checkpoint. */
enum { IDA_HIST_INTS = DEFSIM__IDA_HIST_INTS, IDA_HIST_REALS = DEFSIM__IDA_HIST_REALS + 1 };

/* IDA's counters now and at the last read (s->base), as arrays in ida_counts' order. */
static void ida_counts_now(ida_state *s, long c[7], long b[7])
{
    IDAGetNumSteps(s->mem, &c[0]);
    IDAGetNumResEvals(s->mem, &c[1]);
    IDAGetNumJacEvals(s->mem, &c[2]);
    IDAGetNumErrTestFails(s->mem, &c[3]);
    IDAGetNumNonlinSolvConvFails(s->mem, &c[4]);
    IDAGetNumNonlinSolvIters(s->mem, &c[5]);
    IDAGetNumLinSolvSetups(s->mem, &c[6]);
    const ida_counts *o = &s->base;
    const long base[7] = {o->steps, o->res, o->jac, o->etf, o->ncf, o->nni, o->setups};
    memcpy(b, base, sizeof base);
}

static defsim_status ida_save(const defsim_host *host, defsim_system *sys, const void *state,
                              const defsim_state_writer *wr)
{
    (void)host;
    (void)sys;
    ida_state *s = (ida_state *)state;   /* IDA's getters take a non-const memory */
    const int history = defsim__sun_has_history(&s->sun, s->mem, s->n);
    defsim_status st = defsim__sun_save_flags(&s->sun, history, wr);
    if (st != DEFSIM_OK || !history) return st;
    const int64_t solver = s->solver;
    if ((st = wr->i64(wr->ctx, &solver, 1)) != DEFSIM_OK) return st;
    int64_t ints[IDA_HIST_INTS];
    double reals[IDA_HIST_REALS];
    defsim__ida_history_get(s->mem, ints, reals);
    reals[IDA_HIST_REALS - 1] = s->t;
    if ((st = wr->i64(wr->ctx, ints, IDA_HIST_INTS)) != DEFSIM_OK) return st;
    if ((st = wr->f64(wr->ctx, reals, IDA_HIST_REALS)) != DEFSIM_OK) return st;
    long c[7], b[7];
    int64_t since[7];
    ida_counts_now(s, c, b);
    for (int k = 0; k < 7; ++k) since[k] = c[k] - b[k];
    if ((st = wr->i64(wr->ctx, since, 7)) != DEFSIM_OK) return st;
    N_Vector vs[DEFSIM__IDA_HIST_VECTORS];
    const int nv = defsim__ida_history_vectors(s->mem, vs);
    for (int k = 0; k < nv && st == DEFSIM_OK; ++k)
        st = wr->f64(wr->ctx, N_VGetArrayPointer(vs[k]), 2 * s->n);
    if (st != DEFSIM_OK) return st;
#ifdef DEFSIM_IDA_CHOLMOD
    if (s->solver == LS_CHOLMOD) {
        const ida_chol *ch = s->chol;
        st = wr->f64(wr->ctx, &ch->cj, 1);
        if (st == DEFSIM_OK) st = wr->f64(wr->ctx, ch->sval, ch->upat.nnz);
        if (st == DEFSIM_OK && s->damp_b) st = wr->f64(wr->ctx, ch->bval, ch->upat.nnz);
    }
#endif
    if (st != DEFSIM_OK) return st;
    if (s->solver == LS_KLU) {
        if ((st = wr->f64(wr->ctx, SUNSparseMatrix_Data(s->sun.J), s->jnnz)) != DEFSIM_OK)
            return st;
        /* Whether that set-up chose its pivots, and if not, the matrix that did. */
        const int64_t fresh = klu_last_fresh(s);
        if ((st = wr->i64(wr->ctx, &fresh, 1)) != DEFSIM_OK) return st;
        if (!fresh && (st = wr->f64(wr->ctx, s->jpiv, s->jnnz)) != DEFSIM_OK) return st;
    }
    /* Appended last (payloads written before IDA stepped past the world's time end here): the
     * forces the next call compares (forces_changed) and the exact-end calls left. */
    const int64_t check[2] = {s->fcheck_valid, s->bound};
    if ((st = wr->i64(wr->ctx, check, 2)) != DEFSIM_OK) return st;
    if ((st = wr->f64(wr->ctx, &s->fcheck_t, 1)) != DEFSIM_OK) return st;
    return wr->f64(wr->ctx, s->fcheck, s->n);
}

static defsim_status ida_load(const defsim_host *host, defsim_system *sys, void *state,
                              const defsim_state_reader *rd)
{
    (void)host;
    (void)sys;
    ida_state *s = state;
    int history = 0;
    int64_t solver = -1;
    defsim_status st = defsim__sun_load_flags(&s->sun, rd, &history);
    if (st != DEFSIM_OK || !history) return st;   /* without one, the next step restarts */
    if ((st = rd->i64(rd->ctx, &solver, 1)) != DEFSIM_OK) return st;
    if (s->n == 0 || solver != s->solver) return DEFSIM_ERR_IO;
    if ((st = ida_restart(s)) != DEFSIM_OK) return st;
    int64_t ints[IDA_HIST_INTS];
    double reals[IDA_HIST_REALS];
    int64_t since[7];
    if ((st = rd->i64(rd->ctx, ints, IDA_HIST_INTS)) != DEFSIM_OK ||
        (st = rd->f64(rd->ctx, reals, IDA_HIST_REALS)) != DEFSIM_OK ||
        (st = rd->i64(rd->ctx, since, 7)) != DEFSIM_OK)
        return st;
    if (!defsim__ida_history_set(s->mem, ints, reals)) return DEFSIM_ERR_IO;
    s->t = reals[IDA_HIST_REALS - 1];
    N_Vector vs[DEFSIM__IDA_HIST_VECTORS];
    const int nv = defsim__ida_history_vectors(s->mem, vs);
    for (int k = 0; k < nv && st == DEFSIM_OK; ++k)
        st = rd->f64(rd->ctx, N_VGetArrayPointer(vs[k]), 2 * s->n);
    if (st != DEFSIM_OK) return st;
    /* The part of IDASolve's first-call set-up that a restored history needs, then the saved
     * Newton matrix factorised again. */
    if (defsim__ida_resume_setup(s->mem) != 0) {
        host->set_error(sys, "sundials_ida: IDA's solvers did not initialise");
        return DEFSIM_ERR_OUT_OF_MEMORY;
    }
#ifdef DEFSIM_IDA_CHOLMOD
    if (s->solver == LS_CHOLMOD) {
        ida_chol *ch = s->chol;
        if ((st = rd->f64(rd->ctx, &ch->cj, 1)) != DEFSIM_OK ||
            (st = rd->f64(rd->ctx, ch->sval, ch->upat.nnz)) != DEFSIM_OK ||
            (s->damp_b && (st = rd->f64(rd->ctx, ch->bval, ch->upat.nnz)) != DEFSIM_OK))
            return st;
        if (chol_setup(s->cls, s->token) != SUNLS_SUCCESS) {
            host->set_error(sys, "sundials_ida: the saved Newton matrix does not factorise");
            return DEFSIM_ERR_IO;
        }
    }
#endif
    if (s->solver == LS_KLU) {
        SUNMatrix J = s->sun.J;
        memcpy(SUNSparseMatrix_IndexPointers(J), s->jcp, (size_t)(2 * s->n + 1) * sizeof *s->jcp);
        memcpy(SUNSparseMatrix_IndexValues(J), s->jri, (size_t)s->jnnz * sizeof *s->jri);
        double *a = SUNSparseMatrix_Data(J);
        if ((st = rd->f64(rd->ctx, a, s->jnnz)) != DEFSIM_OK) return st;
        memcpy(s->jlast, a, (size_t)s->jnnz * sizeof *a);
        /* Files before the pivot matrix was saved end here: pivots from the saved matrix. */
        int64_t fresh = 1;
        if (rd->remaining(rd->ctx) > 0 && (st = rd->i64(rd->ctx, &fresh, 1)) != DEFSIM_OK)
            return st;
        if (fresh != 0 && fresh != 1) return DEFSIM_ERR_IO;
        /* The same pivots as the saved run: factorise the matrix that chose them, then
         * refactorise the last set-up's values with them, as the saved run did. */
        if (!fresh) {
            if ((st = rd->f64(rd->ctx, s->jpiv, s->jnnz)) != DEFSIM_OK) return st;
            memcpy(a, s->jpiv, (size_t)s->jnnz * sizeof *a);
            if (SUNLinSolSetup(s->sun.LS, J) != SUNLS_SUCCESS) {
                host->set_error(sys, "sundials_ida: the saved pivot matrix does not factorise");
                return DEFSIM_ERR_IO;
            }
            memcpy(a, s->jlast, (size_t)s->jnnz * sizeof *a);
        }
        if (SUNLinSolSetup(s->sun.LS, J) != SUNLS_SUCCESS) {
            host->set_error(sys, "sundials_ida: the saved Newton matrix does not factorise");
            return DEFSIM_ERR_IO;
        }
        if (fresh) memcpy(s->jpiv, a, (size_t)s->jnnz * sizeof *a);
        s->klu_first = (int)fresh;
        s->klu_setups = 1;
    }
    if (rd->remaining(rd->ctx) > 0) {
        int64_t check[2];
        if ((st = rd->i64(rd->ctx, check, 2)) != DEFSIM_OK ||
            (st = rd->f64(rd->ctx, &s->fcheck_t, 1)) != DEFSIM_OK ||
            (st = rd->f64(rd->ctx, s->fcheck, s->n)) != DEFSIM_OK)
            return st;
        if ((check[0] != 0 && check[0] != 1) || check[1] < 0 || check[1] > IDA_BOUND_CALLS)
            return DEFSIM_ERR_IO;
        s->fcheck_valid = (int)check[0];
        s->bound = (int)check[1];
    }
    /* Counters restart from IDA's restored ones, less what the saved world had not yet read. */
    long c[7], b[7];
    ida_counts_now(s, c, b);
    for (int k = 0; k < 7; ++k) b[k] = c[k] - (long)since[k];
    s->base = (ida_counts){b[0], b[1], b[2], b[3], b[4], b[5], b[6]};
    return DEFSIM_OK;
}

/* Not DISSIPATIVE: BDF of order 3 to 5 is not A-stable and need not lose energy. */
static const defsim_backend ida_backend = {
    DEFSIM__SUN_TABLE(ida, "sundials_ida",
                      DEFSIM_BACKEND_NEEDS_MATRIX | DEFSIM_BACKEND_ADAPTIVE |
                          DEFSIM_BACKEND_IMPLICIT),
    .reset = defsim__sun_reset, .save_state = ida_save, .load_state = ida_load};

DEFSIM__SUN_MODULE_INIT(ida_backend)
