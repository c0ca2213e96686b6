/* SPDX-License-Identifier: MIT */
/*
 * sundials_kinsol: backward Euler, one nonlinear solve per step with SUNDIALS KINSOL (Newton
 * with a line search, KLU for the sparse Newton systems).
 *
 * Over the free DOFs, x = x_{n+1} solves G(x) = grad g(x) = 0 with
 *     G(x) = M (x - y) / h^2 - f_el(x) + (C + B(x_n)) (x - x_n) / h,
 *     y    = x_n + h v_n + h^2 M^-1 f_gravity,
 * C = diag(alpha m) and B(x_n) = sum_e beta_e K_e(x_n) (element Hessians clamped to PSD) the
 * Rayleigh damping matrices, frozen at the start of the step: the damping is linear in
 * v_{n+1} = (x - x_n) / h, symmetric and positive semi-definite, so g is an energy and the
 * damping only ever removes energy. The Newton matrix is
 *     dG/dx = M / h^2 + K(x) + (C + B(x_n)) / h,
 * refactorised at every iteration (full Newton). KINSOL's convergence test is on the max norm of
 * fscale * G, and fscale_i = h^2 / (m_i L) with L the scene's length scale, so the tolerance is
 * a position-like residual relative to the size of the scene: the same at any mesh size or unit.
 * Newton starts from the inertial position y; if that solve fails, once more from x_n.
 * Driven pins are Dirichlet values: pinned DOFs sit at their end-of-step positions in x, and the
 * damping of their motion on free DOFs, -B(x_n) v_pins, joins f_gravity as a load over the step.
 * The applied forces are evaluated once at x_n, unless the host says they depend on x (a force
 * callback with a Jacobian): then at every residual.
 */
#include "defsim/backend.h"

#include "sundials_common.h"

#include <kinsol/kinsol.h>
#include <sunmatrix/sunmatrix_sparse.h>

#include <float.h>
#include <math.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* Options, in the order of kin_options. */
enum { O_TOLERANCE, O_MAX_ITERATIONS, O_PROJECTION, O_COUNT };

static const defsim_option_spec kin_options[O_COUNT] = {
    /* Relative: below 1e-14 the rounding of the positions exceeds it (as rtol's bound). */
    {"tolerance", DEFSIM_OPTION_REAL, 1e-6, 1e-14, 1.0, NULL,
     "scaled residual: position error relative to the scene size, in [1e-14, 1]"},
    {"max_iterations", DEFSIM_OPTION_INT, 50, 1, 1e6, NULL,
     "Newton iterations per solve (from y, then from x_n)"},
    /* Read by the core: the projection its matrix services apply (backend.h). */
    {"projection", DEFSIM_OPTION_CHOICE, DEFSIM_PROJECTION_CLAMP, 0, 0, "none|clamp|abs",
     "element Hessians in the Newton matrix: exact (none), or made positive semi-definite "
     "(clamp: negative eigenvalues to 0, abs: to their absolute value)"},
};

/* Counters, in the order of kin_counters. */
enum { C_NNI, C_RES, C_JAC, C_BT, C_NCF, C_LINEAR_SOLVES, C_TIME_FACTOR, C_TIME_SOLVE,
       C_RESIDUAL, C_COUNT };

static const defsim_counter_spec kin_counters[C_COUNT] = {
    {"newton_iterations", "Newton iterations"},
    {"residual_evals", "residual evaluations"},
    {"jacobian_evals", "Newton matrix assemblies"},
    {"line_search_backtracks", "line-search backtracks"},
    {"convergence_failures", "failed KINSOL solves (a step that succeeds from x_n counts one)"},
    {"linear_solves", "KLU solves"},
    {"time_factor", "wall time of the KLU factorisations (s)"},
    {"time_solve", "wall time of the KLU solves (s)"},
    {"nonlinear_residual", "the scaled residual's max norm after the last step's solve (a level, "
                           "not a sum)"},
};

typedef struct kin_state {
    defsim__sun sun;
    const defsim_host *host;
    defsim_system *sys;
    void *mem;                 /* KINSOL memory */
    N_Vector u, uscale, fscale;
    int64_t n, ndof;
    const int64_t *free_dofs;
    defsim_csc kpat;           /* the core's FULL pattern (borrowed) */
    int damp_b;                /* any stiffness damping (beta > 0) */
    double *mf, *cf;           /* mass and alpha m per free DOF */
    double *du;                /* x - x_n per free DOF */
    double *xn, *vn, *x, *fel, *fg;   /* full DOF arrays */
    double *bval;              /* B(x_n) values on the pattern (damp_b only) */
    double h;
    double tolerance;
    int vary;                  /* this step: applied forces depend on x, evaluated per residual */
    double *fpd;               /* -B(x_n) v_pins on the free DOFs (full DOF array) */
} kin_state;

/* G at u (free DOFs). */
static int kin_residual(N_Vector uu, N_Vector ff, void *user)
{
    kin_state *s = user;
    const double *u = N_VGetArrayPointer(uu);
    double *g = N_VGetArrayPointer(ff);
    const double h = s->h, ih = 1.0 / h, ih2 = ih * ih;
    const int64_t n = s->n;
    for (int64_t i = 0; i < n; ++i) {
        const int64_t d = s->free_dofs[i];
        s->x[d] = u[i];
        s->du[i] = u[i] - s->xn[d];
    }
    /* Non-finite forces (an inverted neo-Hookean element): recoverable, the line search backs
     * off. */
    if (s->host->forces(s->sys, s->x, NULL, DEFSIM_FORCE_ELASTIC, s->fel) != DEFSIM_OK) return 1;
    if (s->vary) {
        if (s->host->forces(s->sys, s->x, NULL, DEFSIM_FORCE_GRAVITY, s->fg) != DEFSIM_OK) return 1;
        if (s->sun.pv && s->damp_b)
            for (int64_t i = 0; i < n; ++i) s->fg[s->free_dofs[i]] += s->fpd[s->free_dofs[i]];
    }
    for (int64_t i = 0; i < n; ++i) {
        const int64_t d = s->free_dofs[i];
        g[i] = s->mf[i] * (s->du[i] - h * s->vn[d]) * ih2 - s->fel[d] - s->fg[d] +
               s->cf[i] * s->du[i] * ih;
    }
    /* + B(x_n) (x - x_n) / h, column by column (B is symmetric). */
    if (s->damp_b) {
        const int64_t *cp = s->kpat.col_ptr, *ri = s->kpat.row_idx;
        for (int64_t j = 0; j < n; ++j) {
            const double a = s->du[j] * ih;
            if (a == 0.0) continue;
            for (int64_t k = cp[j]; k < cp[j + 1]; ++k) g[ri[k]] += s->bval[k] * a;
        }
    }
    return 0;
}

static int kin_jacobian(N_Vector uu, N_Vector fu, SUNMatrix J, void *user, N_Vector t1,
                        N_Vector t2)
{
    (void)fu; (void)t1; (void)t2;
    kin_state *s = user;
    const double *u = N_VGetArrayPointer(uu);
    for (int64_t i = 0; i < s->n; ++i) s->x[s->free_dofs[i]] = u[i];
    const double ih = 1.0 / s->h;
    const defsim_matrix_coeffs c = {1.0, 0.0, ih * ih, ih};
    /* KINSOL zeroes the whole matrix (pattern included) before calling: write both. */
    sunindextype *cp = SUNSparseMatrix_IndexPointers(J), *ri = SUNSparseMatrix_IndexValues(J);
    double *a = SUNSparseMatrix_Data(J);
    memcpy(cp, s->kpat.col_ptr, (size_t)(s->n + 1) * sizeof *cp);
    memcpy(ri, s->kpat.row_idx, (size_t)s->kpat.nnz * sizeof *ri);
    if (s->host->matrix_values(s->sys, s->x, &c, DEFSIM_TRIANGLE_FULL, a) != DEFSIM_OK) return 1;
    if (s->damp_b)
        for (int64_t k = 0; k < s->kpat.nnz; ++k) a[k] += ih * s->bval[k];
    return 0;
}

static defsim_status kin_fail(kin_state *s, const char *call, int flag)
{
    char *name = KINGetReturnFlagName(flag);   /* malloc'd by KINSOL */
    defsim__sun_fail(&s->sun, "sundials_kinsol", call, name, flag, s->host->time(s->sys));
    free(name);
    return DEFSIM_ERR_NOT_CONVERGED;
}

/* KIN_STEP_LT_STPTOL (steps at roundoff, residual above the tolerance) counts as a failure. */
static int kin_failed(int flag) { return flag < 0 || flag == KIN_STEP_LT_STPTOL; }

/* One KINSol call from the guess in s->u; adds its counters (which count this call only) to
 * the backend's counters. */
static int kin_solve(kin_state *s)
{
    int flag = KINSol(s->mem, s->u, KIN_LINESEARCH, s->uscale, s->fscale);
    long nni = 0, nfe = 0, nje = 0, nbt = 0;
    KINGetNumNonlinSolvIters(s->mem, &nni);
    KINGetNumFuncEvals(s->mem, &nfe);
    KINGetNumJacEvals(s->mem, &nje);
    KINGetNumBacktrackOps(s->mem, &nbt);
    defsim__sun_count(s->host, s->sys, C_NNI, (double)nni);
    defsim__sun_count(s->host, s->sys, C_RES, (double)nfe);
    defsim__sun_count(s->host, s->sys, C_JAC, (double)nje);
    defsim__sun_count(s->host, s->sys, C_BT, (double)nbt);
    return flag;
}

static void kin_fini(const defsim_host *host, defsim_system *sys, void *state)
{
    (void)sys;
    kin_state *s = state;
    N_Vector *vectors[] = {&s->u, &s->uscale, &s->fscale};
    defsim__sun_fini(&s->sun, &s->mem, KINFree, vectors, 3);
    host->release(s->mf); host->release(s->cf); host->release(s->du);
    host->release(s->xn); host->release(s->vn); host->release(s->x);
    host->release(s->fel); host->release(s->fg);
    host->release(s->bval); host->release(s->fpd);
    s->mf = s->cf = s->du = s->xn = s->vn = s->x = s->fel = s->fg = s->bval = s->fpd = NULL;
}

#define SET(call) DEFSIM__SUN_SET(s, kin_fail, KIN_MEM_FAIL, #call, call)

static defsim_status kin_init(const defsim_host *host, defsim_system *sys, void *state)
{
    kin_state *s = state;
    double o[O_COUNT];
    DEFSIM__SUN_INIT_PROLOGUE(s, host, sys, kin_options, O_COUNT, o);
    s->tolerance = o[O_TOLERANCE];
    defsim_status st = host->matrix_pattern(sys, DEFSIM_TRIANGLE_FULL, &s->kpat);
    if (st != DEFSIM_OK) return st;
    const int64_t n = s->n;
    const size_t nd = (size_t)s->ndof;
    s->damp_b = host->has_stiffness_damping(sys) != 0;
    s->mf = defsim__sun_calloc(host, (size_t)n, sizeof *s->mf);
    s->cf = defsim__sun_calloc(host, (size_t)n, sizeof *s->cf);
    s->du = defsim__sun_calloc(host, (size_t)n, sizeof *s->du);
    s->xn = defsim__sun_calloc(host, nd, sizeof *s->xn);
    s->vn = defsim__sun_calloc(host, nd, sizeof *s->vn);
    s->x = defsim__sun_calloc(host, nd, sizeof *s->x);
    s->fel = defsim__sun_calloc(host, nd, sizeof *s->fel);
    s->fg = defsim__sun_calloc(host, nd, sizeof *s->fg);
    s->bval = s->damp_b ? defsim__sun_calloc(host, (size_t)s->kpat.nnz, sizeof *s->bval) : NULL;
    s->fpd = s->damp_b ? defsim__sun_calloc(host, nd, sizeof *s->fpd) : NULL;
    if (!s->mf || !s->cf || !s->du || !s->xn || !s->vn || !s->x || !s->fel || !s->fg ||
        (s->damp_b && (!s->bval || !s->fpd))) {
        host->set_error(sys, "sundials_kinsol: out of memory");
        return DEFSIM_ERR_OUT_OF_MEMORY;
    }
    const double *m = host->mass(sys), *alpha = host->mass_damping(sys);
    for (int64_t i = 0; i < n; ++i) {
        s->mf[i] = m[s->free_dofs[i]];
        s->cf[i] = alpha[s->free_dofs[i]] * s->mf[i];
    }

    st = defsim__sun_open(&s->sun, host, sys);
    if (st != DEFSIM_OK) return st;
    s->u = N_VNew_Serial((sunindextype)n, s->sun.ctx);
    s->uscale = s->u ? N_VClone(s->u) : NULL;
    s->fscale = s->u ? N_VClone(s->u) : NULL;
    if (!s->u || !s->uscale || !s->fscale) {
        host->set_error(sys, "sundials_kinsol: out of memory");
        return DEFSIM_ERR_OUT_OF_MEMORY;
    }
    N_VConst(0.0, s->u);
    N_VConst(1.0 / host->length_scale(sys), s->uscale);
    N_VConst(1.0, s->fscale);
    st = defsim__sun_klu(&s->sun, s->u, n, s->kpat.nnz, C_LINEAR_SOLVES);
    if (st != DEFSIM_OK) return st;
    s->mem = KINCreate(s->sun.ctx);
    if (!s->mem) {
        host->set_error(sys, "sundials_kinsol: KINCreate failed (out of memory)");
        return DEFSIM_ERR_OUT_OF_MEMORY;
    }
    SET(KINSetErrHandlerFn(s->mem, defsim__sun_error_handler, &s->sun));
    SET(KINInit(s->mem, kin_residual, s->u));
    SET(KINSetUserData(s->mem, s));
    SET(KINSetLinearSolver(s->mem, s->sun.LS, s->sun.J));
    SET(KINSetJacFn(s->mem, kin_jacobian));
    /* Full Newton: a fresh Jacobian and factorisation at every iteration. */
    SET(KINSetMaxSetupCalls(s->mem, 1));
    SET(KINSetNumMaxIters(s->mem, (long)o[O_MAX_ITERATIONS]));
    SET(KINSetFuncNormTol(s->mem, s->tolerance));
    /* KINSOL measures steps relative to max(|x_i|, L): stop only when they are at roundoff. */
    SET(KINSetScaledStepTol(s->mem, 16.0 * DBL_EPSILON));
    return DEFSIM_OK;
}

static defsim_status kin_step(const defsim_host *host, defsim_system *sys, void *state, double h)
{
    kin_state *s = state;
    if (s->n == 0) return DEFSIM_OK;
    const size_t bytes = (size_t)s->ndof * sizeof(double);
    memcpy(s->xn, host->positions(sys), bytes);
    memcpy(s->vn, host->velocities(sys), bytes);
    memcpy(s->x, s->xn, bytes);
    s->h = h;
    defsim__sun_drive_begin(&s->sun, 0);
    const double *pv = s->sun.pv;
    s->vary = s->sun.coupled && host->applied_forces_vary(sys);
    if (pv) host->pin_positions(sys, host->time(sys) + h, s->x);
    if (host->forces(sys, s->xn, NULL, DEFSIM_FORCE_GRAVITY, s->fg) != DEFSIM_OK) {
        host->set_error(sys, "sundials_kinsol: non-finite external forces");
        return DEFSIM_ERR_UNSTABLE;
    }
    if (pv && s->damp_b) {
        if (host->forces(sys, s->xn, pv, DEFSIM_FORCE_DAMPING, s->fpd) != DEFSIM_OK) {
            host->set_error(sys, "sundials_kinsol: non-finite damping of the driven pins");
            return DEFSIM_ERR_UNSTABLE;
        }
        for (int64_t i = 0; i < s->n && !s->vary; ++i)
            s->fg[s->free_dofs[i]] += s->fpd[s->free_dofs[i]];
    }
    if (s->damp_b) {
        const defsim_matrix_coeffs cb = {0.0, 1.0, 0.0, 0.0};
        defsim_status st = host->matrix_values(sys, s->xn, &cb, DEFSIM_TRIANGLE_FULL, s->bval);
        if (st != DEFSIM_OK) return st;
    }
    /* Initial guess: the inertial position y; residual scale h^2 / (m L). */
    const double L = host->length_scale(sys);
    double *u = N_VGetArrayPointer(s->u), *fs = N_VGetArrayPointer(s->fscale);
    for (int64_t i = 0; i < s->n; ++i) {
        const int64_t d = s->free_dofs[i];
        u[i] = s->xn[d] + h * s->vn[d] + h * h * s->fg[d] / s->mf[i];
        fs[i] = h * h / (s->mf[i] * L);
    }
    s->sun.msg[0] = '\0';
    int flag = kin_solve(s), first = 0;
    if (kin_failed(flag)) {
        /* From the inertial guess the forces may be undefined (an inverted neo-Hookean element)
         * or Newton may stall on a non-convex energy: try once more from x_n. */
        defsim__sun_count(host, sys, C_NCF, 1.0);
        first = flag;
        for (int64_t i = 0; i < s->n; ++i) u[i] = s->xn[s->free_dofs[i]];
        s->sun.msg[0] = '\0';
        flag = kin_solve(s);
    }
    double fnorm_last = 0.0;
    double *cs = defsim__sun_counters(host, sys);
    if (cs && KINGetFuncNorm(s->mem, &fnorm_last) == KIN_SUCCESS) cs[C_RESIDUAL] = fnorm_last;
    if (kin_failed(flag)) {
        defsim__sun_count(host, sys, C_NCF, 1.0);
        if (flag == KIN_STEP_LT_STPTOL) {
            /* Stalled at roundoff above the tolerance: not a solution to the asked accuracy. */
            double fnorm = 0.0;
            KINGetFuncNorm(s->mem, &fnorm);
            snprintf(s->sun.msg, sizeof s->sun.msg,
                     "steps at roundoff but the scaled residual %.3g is above the tolerance %.3g",
                     fnorm, s->tolerance);
        }
        char *owned = KINGetReturnFlagName(first);   /* malloc'd by KINSOL */
        char call[96];
        snprintf(call, sizeof call, "KINSol (from y: %s; from x_n)", owned ? owned : "?");
        free(owned);
        return kin_fail(s, call, flag);
    }
    double *x = host->positions(sys), *v = host->velocities(sys);
    for (int64_t i = 0; i < s->n; ++i) {
        const int64_t d = s->free_dofs[i];
        x[d] = u[i];
        v[d] = (u[i] - s->xn[d]) / h;
    }
    return DEFSIM_OK;
}

/* No reset: without history, every step starts from the world's state. */
static const defsim_backend kin_backend = {
    DEFSIM__SUN_TABLE(kin, "sundials_kinsol",
                      DEFSIM_BACKEND_NEEDS_MATRIX | DEFSIM_BACKEND_IMPLICIT |
                          DEFSIM_BACKEND_DISSIPATIVE)};

DEFSIM__SUN_MODULE_INIT(kin_backend)
