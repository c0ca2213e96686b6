/* SPDX-License-Identifier: MIT */
/*
 * sundials_ida: adaptive variable-order BDF (SUNDIALS IDA) with a sparse KLU Newton solver.
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
 * a little less than quadratic). One defsim_world_step(h) is one IDASolve to exactly t + h
 * (IDASetStopTime), with as many internal steps as the tolerances need; IDA's history is kept
 * between calls and dropped (IDAReInit) when the host changes the state or a step fails.
 *
 * Tolerances are per second of simulated time (error per unit step): the local error of an
 * internal step of length h_i is held to (rtol |y| + atol) min(1, h_i / 1 s), through IDA's
 * error-weight function. IDA's own control (per step, whatever its length) lets the global error
 * grow with the number of steps, 10 to 500 times the tolerance on oscillators; per unit step,
 * the error after T seconds stays near T times the tolerance, and falls in proportion to it.
 */
#include "defsim/backend.h"

#include "sundials_common.h"

#include <ida/ida.h>
#include <sunmatrix/sunmatrix_sparse.h>

#include <float.h>
#include <math.h>
#include <stddef.h>
#include <stdlib.h>
#include <string.h>

/* Time unit of the tolerances (s), and the smallest effective relative tolerance, far enough
 * above roundoff that IDA never stops with IDA_TOO_MUCH_ACC. */
#define IDA_TOL_TIME 1.0
#define IDA_TOL_FLOOR (500.0 * DBL_EPSILON)

/* IDA's cumulative counters at the last read (reset to 0 by IDAReInit). */
typedef struct ida_counts {
    long steps, res, jac, etf, ncf, nni;
} ida_counts;

typedef struct ida_state {
    defsim__sun sun;
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
    double *x, *v, *f;         /* full DOF work arrays (pinned entries fixed) */
    double rtol, atol;
    double t;                  /* IDA's time at the last return */
    int need_reinit;
    ida_counts base;
    int coupled;               /* the host has the coupling services (forces_at, ...) */
    const double *pv;          /* this step's driven-pin velocities, or NULL */
    int drove;                 /* the last step drove pins */
} ida_state;

/* Forces at time t (the host's force callback sees it). */
static defsim_status ida_forces(ida_state *s, double t)
{
    if (!s->coupled) return s->host->forces(s->sys, s->x, s->v, DEFSIM_FORCE_ALL, s->f);
    return s->host->forces_at(s->sys, s->x, s->v, t, DEFSIM_FORCE_ALL, s->f);
}

/* Driven pins are not unknowns of IDA: the residual places them on their paths at its time t
 * (their velocities are in s->v from the restart). Their velocities change from step to step,
 * a kink in the residual's time dependence, so a step that drives pins, or follows one that
 * did, restarts IDA with y' consistent with the new velocities. Returns 1 for a restart. */
static int ida_drive_begin(ida_state *s)
{
    if (!s->coupled) return 0;
    s->pv = s->host->pin_velocities(s->sys);
    const int restart = s->pv != NULL || s->drove;
    s->drove = s->pv != NULL;
    return restart;
}

/* x, v (full) from y = [x_free, v_free]. */
static void scatter(ida_state *s, const double *y)
{
    for (int64_t i = 0; i < s->n; ++i) {
        const int64_t d = s->free_dofs[i];
        s->x[d] = y[i];
        s->v[d] = y[s->n + i];
    }
}

static int ida_residual(realtype t, N_Vector yy, N_Vector yp, N_Vector rr, void *user)
{
    ida_state *s = user;
    const double *y = N_VGetArrayPointer(yy), *yd = N_VGetArrayPointer(yp);
    double *r = N_VGetArrayPointer(rr);
    scatter(s, y);
    if (s->pv) s->host->pin_positions(s->sys, t, s->x);
    /* Non-finite forces (an inverted neo-Hookean element): recoverable, IDA cuts the step. */
    if (ida_forces(s, t) != DEFSIM_OK) return 1;
    const int64_t n = s->n;
    for (int64_t i = 0; i < n; ++i) {
        r[i] = yd[i] - y[n + i];
        r[n + i] = s->mf[i] * yd[n + i] - s->f[s->free_dofs[i]];
    }
    return 0;
}

static int ida_jacobian(realtype t, realtype cj, N_Vector yy, N_Vector yp, N_Vector rr,
                        SUNMatrix J, void *user, N_Vector t1, N_Vector t2, N_Vector t3)
{
    (void)t; (void)yp; (void)rr; (void)t1; (void)t2; (void)t3;
    ida_state *s = user;
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
    return 0;
}

/* Adds IDA's counters since the last read to the world's statistics. */
static void update_stats(ida_state *s)
{
    ida_counts c = {0, 0, 0, 0, 0, 0};
    int order = 0;
    IDAGetNumSteps(s->mem, &c.steps);
    IDAGetNumResEvals(s->mem, &c.res);
    IDAGetNumJacEvals(s->mem, &c.jac);
    IDAGetNumErrTestFails(s->mem, &c.etf);
    IDAGetNumNonlinSolvConvFails(s->mem, &c.ncf);
    IDAGetNumNonlinSolvIters(s->mem, &c.nni);
    IDAGetLastOrder(s->mem, &order);
    defsim_stats *st = s->host->stats(s->sys);
    st->internal_steps += c.steps - s->base.steps;
    st->residual_evals += c.res - s->base.res;
    st->jacobian_evals += c.jac - s->base.jac;
    st->error_test_failures += c.etf - s->base.etf;
    st->convergence_failures += c.ncf - s->base.ncf;
    st->newton_iterations += c.nni - s->base.nni;
    if (c.steps > 0) st->last_order = order;
    s->base = c;
}

/* Error weights 1 / ((rtol |y_i| + atol) s) with s = min(1, h / IDA_TOL_TIME) for the step of
 * length h about to be taken (IDA calls this before every step after the first; the first step,
 * whose length IDA has not chosen yet, gets s = 1). */
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
    const double *y = N_VGetArrayPointer(yv);
    double *w = N_VGetArrayPointer(ewt);
    for (int64_t i = 0; i < 2 * s->n; ++i) w[i] = 1.0 / (f * (s->rtol * fabs(y[i]) + s->atol));
    return 0;
}

static defsim_status ida_fail(ida_state *s, const char *call, int flag)
{
    char *name = IDAGetReturnFlagName(flag);
    realtype tcur = s->t;
    if (s->mem) IDAGetCurrentTime(s->mem, &tcur);
    defsim__sun_fail(&s->sun, "sundials_ida", call, name, flag, tcur);
    free(name);   /* IDAGetReturnFlagName returns a malloc'd string */
    s->need_reinit = 1;
    return DEFSIM_ERR_NOT_CONVERGED;
}

/* Restarts IDA from the world's state with consistent derivatives y' = [v, M^-1 f(x, v)]. */
static defsim_status ida_restart(ida_state *s)
{
    const defsim_host *host = s->host;
    memcpy(s->x, host->positions(s->sys), (size_t)s->ndof * sizeof *s->x);
    memcpy(s->v, host->velocities(s->sys), (size_t)s->ndof * sizeof *s->v);
    if (ida_forces(s, host->time(s->sys)) != DEFSIM_OK) {
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
    s->need_reinit = 0;
    return DEFSIM_OK;
}

static void ida_fini(const defsim_host *host, defsim_system *sys, void *state)
{
    (void)sys;
    ida_state *s = state;
    if (s->mem) IDAFree(&s->mem);
    s->mem = NULL;
    if (s->y) N_VDestroy(s->y);
    if (s->yp) N_VDestroy(s->yp);
    s->y = s->yp = NULL;
    defsim__sun_close(&s->sun);
    host->release(s->jcp); host->release(s->jri);
    host->release(s->kval); host->release(s->bval);
    host->release(s->mf); host->release(s->af);
    host->release(s->x); host->release(s->v); host->release(s->f);
    s->jcp = s->jri = NULL;
    s->kval = s->bval = s->mf = s->af = s->x = s->v = s->f = NULL;
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

#define SET(call)                                                                             \
    do {                                                                                      \
        int flag_ = (call);                                                                   \
        if (flag_ < 0) {                                                                      \
            ida_fail(s, #call, flag_);                                                        \
            return flag_ == IDA_MEM_FAIL ? DEFSIM_ERR_OUT_OF_MEMORY : DEFSIM_ERR_INVALID_ARGUMENT; \
        }                                                                                     \
    } while (0)

static defsim_status ida_init(const defsim_host *host, defsim_system *sys, void *state)
{
    ida_state *s = state;
    s->host = host;
    s->coupled = host->size >= offsetof(defsim_host, applied_forces_vary) +
                                   sizeof host->applied_forces_vary;
    s->sys = sys;
    s->n = host->free_dof_count(sys);
    s->ndof = host->dof_count(sys);
    s->free_dofs = host->free_dofs(sys);
    s->need_reinit = 1;
    if (s->n == 0) return DEFSIM_OK;   /* everything pinned: nothing moves */
    const defsim_world_def *opt = host->options(sys);
    defsim_status st = host->matrix_pattern(sys, DEFSIM_TRIANGLE_FULL, &s->kpat);
    if (st != DEFSIM_OK) return st;
    const int64_t n = s->n, knnz = s->kpat.nnz;
    s->damp_b = host->has_stiffness_damping(sys) != 0;
    s->jnnz = 2 * n + knnz + (s->damp_b ? knnz : n);
    s->jcp = defsim__sun_calloc(host, (size_t)(2 * n + 1), sizeof *s->jcp);
    s->jri = defsim__sun_calloc(host, (size_t)s->jnnz, sizeof *s->jri);
    s->kval = defsim__sun_calloc(host, (size_t)knnz, sizeof *s->kval);
    s->bval = s->damp_b ? defsim__sun_calloc(host, (size_t)knnz, sizeof *s->bval) : NULL;
    s->mf = defsim__sun_calloc(host, (size_t)n, sizeof *s->mf);
    s->af = defsim__sun_calloc(host, (size_t)n, sizeof *s->af);
    s->x = defsim__sun_calloc(host, (size_t)s->ndof, sizeof *s->x);
    s->v = defsim__sun_calloc(host, (size_t)s->ndof, sizeof *s->v);
    s->f = defsim__sun_calloc(host, (size_t)s->ndof, sizeof *s->f);
    if (!s->jcp || !s->jri || !s->kval || (s->damp_b && !s->bval) || !s->mf || !s->af || !s->x ||
        !s->v || !s->f) {
        host->set_error(sys, "sundials_ida: out of memory");
        return DEFSIM_ERR_OUT_OF_MEMORY;
    }
    const double *m = host->mass(sys), *alpha = host->mass_damping(sys);
    for (int64_t i = 0; i < n; ++i) {
        s->mf[i] = m[s->free_dofs[i]];
        s->af[i] = alpha[s->free_dofs[i]];
    }
    build_pattern(s);

    st = defsim__sun_open(&s->sun, host, sys);
    if (st != DEFSIM_OK) return st;
    s->y = N_VNew_Serial((sunindextype)(2 * n), s->sun.ctx);
    s->yp = s->y ? N_VClone(s->y) : NULL;
    if (!s->y || !s->yp) {
        host->set_error(sys, "sundials_ida: out of memory");
        return DEFSIM_ERR_OUT_OF_MEMORY;
    }
    N_VConst(0.0, s->y);
    N_VConst(0.0, s->yp);
    st = defsim__sun_klu(&s->sun, s->y, 2 * n, s->jnnz);
    if (st != DEFSIM_OK) return st;
    s->mem = IDACreate(s->sun.ctx);
    if (!s->mem) {
        host->set_error(sys, "sundials_ida: IDACreate failed (out of memory)");
        return DEFSIM_ERR_OUT_OF_MEMORY;
    }
    SET(IDASetErrHandlerFn(s->mem, defsim__sun_error_handler, &s->sun));
    SET(IDAInit(s->mem, ida_residual, host->time(sys), s->y, s->yp));
    /* atol is the same number for x (m) and v (m/s): see README "Tolerances". */
    s->rtol = opt->rtol;
    s->atol = opt->atol;
    SET(IDAWFtolerances(s->mem, ida_weights));
    SET(IDASetUserData(s->mem, s));
    SET(IDASetMaxOrd(s->mem, opt->max_order));
    SET(IDASetMaxNumSteps(s->mem, opt->max_internal_steps));
    SET(IDASetLinearSolver(s->mem, s->sun.LS, s->sun.J));
    SET(IDASetJacFn(s->mem, ida_jacobian));
    return DEFSIM_OK;
}

static defsim_status ida_step(const defsim_host *host, defsim_system *sys, void *state, double h)
{
    ida_state *s = state;
    if (s->n == 0) return DEFSIM_OK;
    if (ida_drive_begin(s)) s->need_reinit = 1;
    if (s->need_reinit) {
        defsim_status st = ida_restart(s);
        if (st != DEFSIM_OK) return st;
    }
    const double tout = s->t + h;
    int flag = IDASetStopTime(s->mem, tout);
    if (flag < 0) return ida_fail(s, "IDASetStopTime", flag);
    realtype tret = s->t;
    flag = IDASolve(s->mem, tout, &tret, s->y, s->yp, IDA_NORMAL);
    update_stats(s);
    if (flag < 0) return ida_fail(s, "IDASolve", flag);
    double *x = host->positions(sys), *v = host->velocities(sys);
    const double *y = N_VGetArrayPointer(s->y);
    for (int64_t i = 0; i < s->n; ++i) {
        const int64_t d = s->free_dofs[i];
        x[d] = y[i];
        v[d] = y[s->n + i];
    }
    s->t = tout;
    return DEFSIM_OK;
}

static defsim_status ida_reset(const defsim_host *host, defsim_system *sys, void *state)
{
    (void)host;
    (void)sys;
    ((ida_state *)state)->need_reinit = 1;
    return DEFSIM_OK;
}

static const defsim_backend ida_backend = {
    .abi_version = DEFSIM_BACKEND_ABI_VERSION,
    .struct_size = sizeof(defsim_backend),
    .name = "sundials_ida",
    /* Not DISSIPATIVE: BDF of order 3 to 5 is not A-stable and need not lose energy. */
    .flags = DEFSIM_BACKEND_NEEDS_MATRIX | DEFSIM_BACKEND_ADAPTIVE | DEFSIM_BACKEND_IMPLICIT,
    .state_size = sizeof(ida_state),
    .init = ida_init,
    .step = ida_step,
    .fini = ida_fini,
    .reset = ida_reset,
};

__attribute__((visibility("default"))) defsim_status defsim_module_init(
    const defsim_host *host, const defsim_backend **out)
{
    /* Every host service used here is of ABI version 1. */
    if (!host || !out || host->abi_version < 1 ||
        host->size < offsetof(defsim_host, release) + sizeof host->release)
        return DEFSIM_ERR_BACKEND_UNAVAILABLE;
    *out = &ida_backend;
    return DEFSIM_OK;
}
