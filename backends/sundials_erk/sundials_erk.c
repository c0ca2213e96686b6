/* SPDX-License-Identifier: MIT */
/*
 * sundials_erk: adaptive explicit Runge-Kutta (SUNDIALS ARKODE ERKStep) with an embedded pair.
 *
 * The equations of motion over the free DOFs as the first-order ODE y' = F(y), y = [x, v]:
 *     x' = v,    v' = M^-1 f(x, v)      (f: elastic + gravity + Rayleigh damping)
 * integrated by an explicit embedded Runge-Kutta pair (default Dormand-Prince 5(4)). One
 * defsim_world_step(h) is one ERKStepEvolve to t + h (ERKStepSetStopTime): as many internal steps
 * as the tolerances and the stability limit need; ERKStep's step-size history is kept between
 * calls and dropped (ERKStepReInit) when the host sets the state or a step fails.
 *
 * Tolerances are per second of simulated time, as in sundials_ida: the local error of an
 * internal step of length h_i is held to (rtol |y| + atol) min(1, h_i / 1 s) through ERKStep's
 * error-weight function, so the error after T seconds is about T times the tolerance and falls
 * in proportion to it.
 *
 * Stability: for the undamped linearisation the eigenvalues of dF/dy are +-i omega, omega^2 the
 * eigenvalues of M^-1 K; with Rayleigh damping c = alpha + beta omega^2 they are the roots of
 * lambda^2 + c lambda + omega^2 = 0. An explicit method is stable when h lambda lies in its
 * region |R(z)| <= 1, R(z) = 1 + z b^T (I - z A)^-1 1 the stability function of the table. The
 * module estimates omega_max and c at the current state through the host (power iteration on
 * M^-1 K(x), refreshed every STAB_REFRESH internal steps) and hands ERKStep the largest h whose
 * h lambda stays in the region (ERKStepSetStabilityFn), so that on stiff scenes the step sits
 * just under the stability limit instead of being found by rejected steps.
 *
 * Checkpoints: the module supplies ERKStep's PI controller (erk_adapt, ERKStep's own formula and
 * gains) so that the error history survives a restart, and a loaded world replays the saved last
 * internal step to bring ERKStep's internal state back (erk_load).
 *
 * Contents: constants and tables offered; options and counters; stability function and stable
 * step of a table; ERKStep callbacks (right-hand side, error weights, stability limit); set-up,
 * stepping and the backend table.
 */
#include "defsim/backend.h"

#include "sundials_common.h"

#include <arkode/arkode_erkstep.h>

#include <complex.h>
#include <float.h>
#include <math.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* Time unit of the tolerances (s), and the smallest effective relative tolerance (ERKStep stops
 * with ARK_TOO_MUCH_ACC near roundoff). */
#define ERK_TOL_TIME 1.0
#define ERK_TOL_FLOOR (500.0 * DBL_EPSILON)
/* Internal steps between two estimates of omega_max at most (each is a power iteration, which
 * costs as much as tens of internal steps). */
#define STAB_REFRESH 1024
/* Amplification per step allowed to the highest mode at the stability limit: |R(h lambda)| <=
 * 1 + STAB_GROWTH. Most pairs' regions touch the imaginary axis only briefly (Dormand-Prince 5:
 * up to |h omega| = 0.997) and then leave it slowly (|R| = 1.01 at 1.725), and the error test holds
 * such slow growth of an undamped mode: at 1.01 the internal steps are as long as the error
 * control alone would make them, without its rejected steps (README "Stability"). */
#define STAB_GROWTH 1e-2
/* ERKStep's PI controller, supplied by the module (erk_adapt) so that its error history can be
 * carried across a restart: the gains, error floor and largest growth per step of ERKStep 6.4's
 * default (erkStep_SetDefaults), so that the steps are those of ERKStep's own controller. */
#define PI_K1 0.8
#define PI_K2 0.31
#define PI_TINY 1e-10
#define ERK_GROWTH 25.0

/* The tables offered (ARKODE's embedded explicit pairs whose stability region contains a
 * segment of the imaginary axis: an undamped elastic body has its spectrum there, so a pair
 * without one, like Heun-Euler 2(1), is unstable at every step size). */
typedef struct erk_table {
    const char *name;
    ARKODE_ERKTableID id;
} erk_table;

static const erk_table tables[] = {
    {"dormand_prince_5", ARKODE_DORMAND_PRINCE_7_4_5},
    {"bogacki_shampine_3", ARKODE_BOGACKI_SHAMPINE_4_2_3},
    {"zonneveld_4", ARKODE_ZONNEVELD_5_3_4},
    {"cash_karp_5", ARKODE_CASH_KARP_6_4_5},
    {"verner_6", ARKODE_VERNER_8_5_6},
    {"fehlberg_8", ARKODE_FEHLBERG_13_7_8},
};
#define TABLE_COUNT ((int)(sizeof tables / sizeof *tables))

/* Options, in the order of erk_options. */
enum { O_RTOL, O_ATOL, O_TABLE, O_MAX_STEPS, O_STAB_LIMIT, O_STAB_SAFETY, O_COUNT };

static const defsim_option_spec erk_options[O_COUNT] = {
    DEFSIM__SUN_OPTION_TOLERANCES,
    {"table", DEFSIM_OPTION_CHOICE, 0, 0, 0,
     "dormand_prince_5|bogacki_shampine_3|zonneveld_4|cash_karp_5|verner_6|fehlberg_8",
     "embedded pair (method order in the name): Dormand-Prince 5(4) by default"},
    {"max_internal_steps", DEFSIM_OPTION_INT, 100000, 1, 2e9, NULL,
     "internal steps allowed per defsim_world_step call"},
    {"stability_limit", DEFSIM_OPTION_BOOL, 1, 0, 1, NULL,
     "limit internal steps to the stability region at the estimated omega_max"},
    {"stability_safety", DEFSIM_OPTION_REAL, 0.9, 0.01, 0.99, NULL,
     "fraction of the stability limit used for an internal step"},
};

/* Counters, in the order of erk_counters. */
enum { C_STEPS, C_ATTEMPTS, C_RHS, C_ETF, C_STAB_LIMITED, C_ACC_LIMITED, C_STAB_ESTIMATES,
       C_ORDER, C_COUNT };

static const defsim_counter_spec erk_counters[C_COUNT] = {
    {"internal_steps", "accepted internal steps"},
    {"step_attempts", "internal steps attempted (accepted + rejected)"},
    {"rhs_evals", "evaluations of the right-hand side (force evaluations)"},
    {"error_test_failures", "internal steps rejected by the error test"},
    {"stability_limited_steps", "internal steps whose length the stability limit set"},
    {"accuracy_limited_steps", "internal steps whose length the error estimate set"},
    {"stability_estimates", "estimates of omega_max (power iterations)"},
    {"order", "order of the table in use"},
};

typedef struct erk_counts {
    long steps, attempts, rhs, etf, stab, acc;
} erk_counts;

typedef struct erk_state {
    defsim__sun sun;           /* first: defsim__sun_reset reaches it through the state */
    const defsim_host *host;
    defsim_system *sys;
    void *mem;                 /* ERKStep memory */
    N_Vector y;
    int64_t n, ndof;
    const int64_t *free_dofs;
    double *minv;              /* 1 / mass per free DOF */
    double *x, *v, *f;         /* full DOF work arrays (pinned entries fixed) */
    double rtol, atol;
    long max_steps;            /* max_internal_steps: internal steps per call */
    int stab_on;               /* stability_limit */
    double stab_safety;        /* stability_safety: ERKStep's CFL fraction */
    int table;                 /* index into tables[] */
    int order;
    ARKodeButcherTable bt;     /* a copy of the table, for its stability function */
    double t;
    double h_stab;             /* last stability limit (s); 0: not estimated */
    double h_stab_pre;         /* the limit at y after a restart, estimated before ERKStepEvolve
                                  (erk_step); -1: none. ERKStep's first estimate takes it */
    long stab_step, stab_etf, stab_exp;   /* ERKStep's step, error-test failure and
                                             stability-limited step counts at that estimate */
    erk_counts base;
    /* What a checkpoint needs to replay the last internal step (README "Checkpoints"): the state
     * it started from (the last error-weight evaluation's y and time) and the step length those
     * weights used; the error history its controller used. */
    N_Vector y0;
    double t0, w_h;
    double prior_e;            /* error of the last step before the restart (ERKStep's 1) */
    double e_used;             /* the previous step's error the last controller call used */
    /* The derivative the last step's first stage used. With some tables (verner_6, fehlberg_8)
     * ERKStep reuses the previous step's last evaluation, made at the step's end time but not at
     * its result, so it is not f(t0, y0) and a replay must be handed it. */
    N_Vector f0, f0_next;      /* the last step's last stage: the next step's f0 if reused */
    const double *f_last;      /* the output of the last right-hand side call */
    int f0_next_valid;         /* f0_next holds a stage of a step since the restart */
    double t_end;              /* the last attempt's end time and state (ERKStep's ycur) */
    const double *y_end;
    int f0_valid;              /* f0 holds the previous step's last stage */
    int f0_called;             /* the right-hand side ran at (t0, y0) after the weights */
    int replay;                /* replaying a checkpoint's last step: the saved stability limit */
    int replay_f0;             /* the replay's first right-hand side call returns the saved f0 */
    double replay_wh;          /* and the saved weights' step length */
    int hin_set;               /* ERKStepSetInitStep holds a step length: cleared at a restart */
} erk_state;

/* ------------------------------------------------------------------------------------------ */
/* Stability function of a table and the stable step for a damped oscillator. */

static double complex stability_R(const ARKodeButcherTable B, double complex z)
{
    double complex k[16];
    double complex r = 1.0;
    for (int i = 0; i < B->stages && i < 16; ++i) {
        double complex s = 1.0;
        for (int j = 0; j < i; ++j) s += B->A[i][j] * k[j];
        k[i] = z * s;   /* stage derivative of y' = y, scaled by h */
        r += B->b[i] * k[i];
    }
    return r;
}

/* Largest h > 0 such that |R(s lambda)| <= 1 + STAB_GROWTH for every s in (0, h]: scanned in
 * steps of 1/512 of |lambda|^-1, then bisected. */
static double ray_limit(const ARKodeButcherTable B, double complex lambda)
{
    const double mag = cabs(lambda);
    if (!(mag > 0.0)) return INFINITY;
    const double ds = 1.0 / 512.0, tol = STAB_GROWTH;
    double lo = 0.0, hi = 0.0;
    for (double s = ds; s <= 64.0; s += ds) {
        if (cabs(stability_R(B, s * lambda / mag)) > 1.0 + tol) {
            hi = s;
            break;
        }
        lo = s;
    }
    if (hi == 0.0) return INFINITY;   /* stable along the whole ray scanned */
    for (int it = 0; it < 50; ++it) {
        const double mid = 0.5 * (lo + hi);
        if (cabs(stability_R(B, mid * lambda / mag)) > 1.0 + tol) hi = mid;
        else lo = mid;
    }
    return lo / mag;
}

/* Stable step of table B for x'' = -omega^2 x - c x': both eigenvalues inside the region. */
static double table_stable_step(const ARKodeButcherTable B, double omega, double c)
{
    if (!(omega > 0.0) && !(c > 0.0)) return INFINITY;
    const double complex disc = csqrt((double complex)(c * c - 4.0 * omega * omega));
    const double complex l1 = 0.5 * (-c + disc), l2 = 0.5 * (-c - disc);
    return fmin(ray_limit(B, l1), ray_limit(B, l2));
}

/* Index into tables[] of the option values o (the default table for NULL). */
static int table_index(const double *o)
{
    const int t = o ? (int)o[O_TABLE] : 0;
    return t >= 0 && t < TABLE_COUNT ? t : 0;
}

/* Stable step of the option's table: what defsim_world_stable_step and auto_substep use. */
static double erk_stable_step_options(const double *option_values, double omega, double c)
{
    ARKodeButcherTable B = ARKodeButcherTable_LoadERK(tables[table_index(option_values)].id);
    if (!B) return 0.0;
    const double h = table_stable_step(B, omega, c);
    ARKodeButcherTable_Free(B);
    return h;
}

/* For cores that predate stable_step_options: the default table (Dormand-Prince 5(4)). */
static double erk_stable_step(double omega, double c)
{
    return erk_stable_step_options(NULL, omega, c);
}

/* ------------------------------------------------------------------------------------------ */
/* ERKStep callbacks */

static void count(erk_state *s, int which, double value)
{
    defsim__sun_count(s->host, s->sys, which, value);
}

static void scatter(erk_state *s, const double *y)
{
    defsim__sun_scatter(s->free_dofs, s->n, y, s->x, s->v);
}

static int erk_rhs(realtype t, N_Vector yy, N_Vector yd, void *user)
{
    erk_state *s = user;
    const double *y = N_VGetArrayPointer(yy);
    double *d = N_VGetArrayPointer(yd);
    s->f_last = d;
    if (s->replay_f0) {
        s->replay_f0 = 0;
        N_VScale(1.0, s->f0, yd);
        return 0;
    }
    const size_t bytes = 2 * (size_t)s->n * sizeof *y;
    if (t == s->t0 && memcmp(y, N_VGetArrayPointer(s->y0), bytes) == 0)
        s->f0_called = 1;   /* (t0, y0) itself, not a stage at c = 0 (Fehlberg's 12th) */
    if (t == s->t_end && s->y_end && memcmp(y, s->y_end, bytes) == 0)
        s->f0_next_valid = 0;   /* f at the step's result: the next f0 is computed, not reused */
    scatter(s, y);
    /* Driven pins are not unknowns: on their paths at the stage time (their velocities are in
     * s->v from the restart, which each step that drives pins makes). */
    if (s->sun.pv) s->host->pin_positions(s->sys, t, s->x);
    /* Non-finite forces: recoverable, ERKStep retries with a shorter step. */
    if (defsim__sun_forces(&s->sun, s->x, s->v, t, DEFSIM_FORCE_ALL, s->f) != DEFSIM_OK) return 1;
    const int64_t n = s->n;
    for (int64_t i = 0; i < n; ++i) {
        d[i] = y[n + i];
        d[n + i] = s->f[s->free_dofs[i]] * s->minv[i];
    }
    return 0;
}

/* The stability limit at y: omega_max and the damping rate from the host. The spectrum of an
 * elastic body changes slowly with its shape, so the estimate is kept until STAB_REFRESH steps
 * later, or until a step fails the error test while the limit is what sets the steps (the body
 * stiffened under it). */
static int erk_stability(N_Vector yy, realtype t, realtype *hstab, void *user)
{
    (void)t;
    erk_state *s = user;
    if (s->replay) {
        *hstab = isfinite(s->h_stab) ? s->h_stab : 0.0;
        return 0;
    }
    long nst = 0, netf = 0, nexp = 0;
    ERKStepGetNumSteps(s->mem, &nst);
    ERKStepGetNumErrTestFails(s->mem, &netf);
    ERKStepGetNumExpSteps(s->mem, &nexp);
    const int stiffened = netf > s->stab_etf && nexp > s->stab_exp;
    if (s->h_stab <= 0.0 || nst - s->stab_step >= STAB_REFRESH || stiffened) {
        const double *y = N_VGetArrayPointer(yy);
        if (s->h_stab_pre >= 0.0 && nst == 0 &&
            memcmp(y, N_VGetArrayPointer(s->y), 2 * (size_t)s->n * sizeof *y) == 0) {
            s->h_stab = s->h_stab_pre;   /* made at this very state by erk_step */
        } else {
            scatter(s, y);
            double omega = 0.0, c = 0.0;
            if (s->host->omega_max(s->sys, s->x, &omega, &c) != DEFSIM_OK) {
                *hstab = 0.0;   /* no estimate: no limit; the error test still holds */
                return 0;
            }
            s->h_stab = table_stable_step(s->bt, omega, c);
            count(s, C_STAB_ESTIMATES, 1.0);
        }
        s->h_stab_pre = -1.0;
        s->stab_step = nst;
        s->stab_etf = netf;
        s->stab_exp = nexp;
        s->host->stats(s->sys)->stable_step = s->h_stab;
    }
    *hstab = isfinite(s->h_stab) ? s->h_stab : 0.0;
    return 0;
}

/* Error weights 1 / ((rtol |y_i| + atol) s), s = min(1, h / ERK_TOL_TIME) with h the last
 * internal step (ERKStep sets the weights before each step; the next step is close to the last
 * one) or, before the first step, the stability limit. */
static int erk_weights(N_Vector yv, N_Vector ewt, void *user)
{
    erk_state *s = user;
    long nst = 0;
    realtype h = 0.0;
    ERKStepGetNumSteps(s->mem, &nst);
    if (nst == 0 && s->replay_wh > 0.0) h = s->replay_wh;
    else if (nst > 0) ERKStepGetLastStep(s->mem, &h);
    else if (s->h_stab > 0.0 && isfinite(s->h_stab)) h = s->h_stab;
    /* ERKStep evaluates the weights at the start of every internal step: remember that start. */
    s->w_h = h;
    N_VScale(1.0, yv, s->y0);
    ERKStepGetCurrentTime(s->mem, &s->t0);
    if (s->f0_next_valid) {
        N_Vector tmp = s->f0;
        s->f0 = s->f0_next;
        s->f0_next = tmp;
        s->f0_valid = 1;
    } else if (nst > 0) {
        s->f0_valid = 0;
    }
    s->f0_next_valid = 0;
    s->f0_called = 0;
    double f = h > 0.0 ? fabs(h) / ERK_TOL_TIME : 1.0;
    if (f > 1.0) f = 1.0;
    if (f * s->rtol < ERK_TOL_FLOOR) f = ERK_TOL_FLOOR / s->rtol;
    const double *y = N_VGetArrayPointer(yv);
    double *w = N_VGetArrayPointer(ewt);
    for (int64_t i = 0; i < 2 * s->n; ++i) w[i] = 1.0 / (f * (s->rtol * fabs(y[i]) + s->atol));
    return 0;
}

/* ERKStep's PI controller (its formula and gains), with the error history continued across a
 * restart: ERKStepReInit resets ERKStep's history to 1, and the error from before the restart
 * (prior_e) stands in until the new run has accepted a step. e1 is the biased error estimate of
 * this attempt, e2 that of the last accepted step. */
static int erk_adapt(N_Vector y, realtype t, realtype h1, realtype h2, realtype h3, realtype e1,
                     realtype e2, realtype e3, int q, int p, realtype *hnew, void *user)
{
    (void)h2; (void)h3; (void)e3; (void)q;
    erk_state *s = user;
    long nst = 0;
    ERKStepGetNumSteps(s->mem, &nst);
    /* The attempt's last stage (before any interpolation at the stop time calls the right-hand
     * side): what a table whose last stage is at the step's end hands the next step as f0. */
    if (s->f_last) {
        memcpy(N_VGetArrayPointer(s->f0_next), s->f_last, 2 * (size_t)s->n * sizeof(double));
        s->f0_next_valid = 1;
    }
    s->t_end = t;
    s->y_end = N_VGetArrayPointer(y);
    const double ea = nst >= 1 ? e2 : s->prior_e;
    s->e_used = ea;
    const double k1 = -PI_K1 / p, k2 = PI_K2 / p;
    *hnew = h1 * pow(e1 > PI_TINY ? e1 : PI_TINY, k1) * pow(ea > PI_TINY ? ea : PI_TINY, k2);
    return 0;
}

/* ------------------------------------------------------------------------------------------ */
/* Set-up, stepping */

/* Adds ERKStep's counters since the last read to the backend's counters. */
static void update_stats(erk_state *s)
{
    erk_counts c = {0, 0, 0, 0, 0, 0};
    long nfe = 0;
    ERKStepGetNumSteps(s->mem, &c.steps);
    ERKStepGetNumStepAttempts(s->mem, &c.attempts);
    ERKStepGetNumRhsEvals(s->mem, &nfe);
    ERKStepGetNumErrTestFails(s->mem, &c.etf);
    ERKStepGetNumExpSteps(s->mem, &c.stab);
    ERKStepGetNumAccSteps(s->mem, &c.acc);
    c.rhs = nfe;
    count(s, C_STEPS, (double)(c.steps - s->base.steps));
    count(s, C_ATTEMPTS, (double)(c.attempts - s->base.attempts));
    count(s, C_RHS, (double)(c.rhs - s->base.rhs));
    count(s, C_ETF, (double)(c.etf - s->base.etf));
    count(s, C_STAB_LIMITED, (double)(c.stab - s->base.stab));
    count(s, C_ACC_LIMITED, (double)(c.acc - s->base.acc));
    double *cs = defsim__sun_counters(s->host, s->sys);
    if (cs) cs[C_ORDER] = s->order;   /* a level, not a sum */
    s->base = c;
}

static defsim_status erk_fail(erk_state *s, const char *call, int flag)
{
    char *name = ERKStepGetReturnFlagName(flag);   /* malloc'd by ARKODE */
    realtype tcur = s->t;
    if (s->mem) ERKStepGetCurrentTime(s->mem, &tcur);
    defsim__sun_fail(&s->sun, "sundials_erk", call, name, flag, tcur);
    free(name);
    s->sun.need_reinit = 1;
    return DEFSIM_ERR_NOT_CONVERGED;
}

/* Restarts ERKStep at (t0, y0) with a fresh step-size history. */
static defsim_status erk_reinit(erk_state *s, double t0, N_Vector y0)
{
    int flag = 0;
    if (s->hin_set) flag = ERKStepSetInitStep(s->mem, 0.0);   /* estimate the first step again */
    s->hin_set = 0;
    if (flag >= 0) flag = ERKStepReInit(s->mem, erk_rhs, t0, y0);
    if (flag < 0) return erk_fail(s, "ERKStepReInit", flag);
    memset(&s->base, 0, sizeof s->base);
    s->h_stab = 0.0;
    s->h_stab_pre = -1.0;
    s->prior_e = 1.0;
    s->replay = 0;
    s->replay_f0 = 0;
    s->replay_wh = 0.0;
    s->f_last = NULL;
    s->f0_next_valid = s->f0_valid = 0;
    s->y_end = NULL;
    s->sun.need_reinit = 0;
    return DEFSIM_OK;
}

/* Restarts ERKStep from the world's state (a fresh step-size history). */
static defsim_status erk_restart(erk_state *s)
{
    const size_t bytes = (size_t)s->ndof * sizeof(double);
    memcpy(s->x, s->host->positions(s->sys), bytes);
    memcpy(s->v, s->host->velocities(s->sys), bytes);
    defsim__sun_gather(s->free_dofs, s->n, s->x, s->v, N_VGetArrayPointer(s->y));
    s->t = s->host->time(s->sys);
    return erk_reinit(s, s->t, s->y);
}

static void erk_fini(const defsim_host *host, defsim_system *sys, void *state)
{
    (void)sys;
    erk_state *s = state;
    if (s->bt) ARKodeButcherTable_Free(s->bt);
    s->bt = NULL;
    N_Vector *vectors[] = {&s->y, &s->y0, &s->f0, &s->f0_next};
    defsim__sun_fini(&s->sun, &s->mem, ERKStepFree, vectors, 4);
    host->release(s->minv); host->release(s->x); host->release(s->v); host->release(s->f);
    s->minv = s->x = s->v = s->f = NULL;
}

#define SET(call) DEFSIM__SUN_SET(s, erk_fail, ARK_MEM_FAIL, #call, call)

static defsim_status erk_init(const defsim_host *host, defsim_system *sys, void *state)
{
    erk_state *s = state;
    s->h_stab_pre = -1.0;   /* before the prologue, which returns early when all is pinned */
    double o[O_COUNT];
    DEFSIM__SUN_INIT_PROLOGUE(s, host, sys, erk_options, O_COUNT, o);
    s->rtol = o[O_RTOL];
    s->atol = o[O_ATOL];
    s->max_steps = (long)o[O_MAX_STEPS];
    s->stab_on = o[O_STAB_LIMIT] != 0.0;
    s->stab_safety = o[O_STAB_SAFETY];
    s->table = table_index(o);
    const size_t n = (size_t)s->n, nd = (size_t)s->ndof;
    s->minv = defsim__sun_calloc(host, n, sizeof *s->minv);
    s->x = defsim__sun_calloc(host, nd, sizeof *s->x);
    s->v = defsim__sun_calloc(host, nd, sizeof *s->v);
    s->f = defsim__sun_calloc(host, nd, sizeof *s->f);
    s->bt = ARKodeButcherTable_LoadERK(tables[s->table].id);
    if (!s->minv || !s->x || !s->v || !s->f || !s->bt) {
        host->set_error(sys, "sundials_erk: out of memory");
        return DEFSIM_ERR_OUT_OF_MEMORY;
    }
    s->order = s->bt->q;
    const double *m = host->mass(sys);
    for (int64_t i = 0; i < s->n; ++i) s->minv[i] = 1.0 / m[s->free_dofs[i]];

    defsim_status st = defsim__sun_open(&s->sun, host, sys);
    if (st != DEFSIM_OK) return st;
    s->y = N_VNew_Serial((sunindextype)(2 * s->n), s->sun.ctx);
    s->y0 = s->y ? N_VClone(s->y) : NULL;
    s->f0 = s->y ? N_VClone(s->y) : NULL;
    s->f0_next = s->y ? N_VClone(s->y) : NULL;
    if (!s->y || !s->y0 || !s->f0 || !s->f0_next) {
        host->set_error(sys, "sundials_erk: out of memory");
        return DEFSIM_ERR_OUT_OF_MEMORY;
    }
    N_VConst(0.0, s->y);
    N_VConst(0.0, s->y0);
    N_VConst(0.0, s->f0);
    N_VConst(0.0, s->f0_next);
    s->mem = ERKStepCreate(erk_rhs, host->time(sys), s->y, s->sun.ctx);
    if (!s->mem) {
        host->set_error(sys, "sundials_erk: ERKStepCreate failed (out of memory)");
        return DEFSIM_ERR_OUT_OF_MEMORY;
    }
    SET(ERKStepSetErrHandlerFn(s->mem, defsim__sun_error_handler, &s->sun));
    SET(ERKStepSetUserData(s->mem, s));
    SET(ERKStepWFtolerances(s->mem, erk_weights));
    SET(ERKStepSetTableNum(s->mem, tables[s->table].id));
    SET(ERKStepSetMaxNumSteps(s->mem, (long)o[O_MAX_STEPS]));
    SET(ERKStepSetAdaptivityFn(s->mem, erk_adapt, s));
    SET(ERKStepSetMaxGrowth(s->mem, ERK_GROWTH));
    if (o[O_STAB_LIMIT] != 0.0) {
        SET(ERKStepSetStabilityFn(s->mem, erk_stability, s));
        SET(ERKStepSetCFLFraction(s->mem, o[O_STAB_SAFETY]));
    }
    return DEFSIM_OK;
}

static defsim_status erk_step(const defsim_host *host, defsim_system *sys, void *state, double h)
{
    erk_state *s = state;
    if (s->n == 0) return DEFSIM_OK;
    defsim__sun_drive_begin(&s->sun, 1);
    if (s->sun.need_reinit) {
        defsim_status st = erk_restart(s);
        if (st != DEFSIM_OK) return st;
    }
    /* A call that cannot finish: at the stability limit it needs more internal steps than it may
     * take. ERKStep would take them all and fail (h = 1000 s on a 48-tet box: 12 s; minutes on
     * a large body), so it is refused before any work, the state untouched (README "Work per
     * call"). The limit is the one ERKStep's next step uses: the last estimate or, after a
     * restart, the first one, made here at the same state and handed to ERKStep's first call
     * of erk_stability (not to the error weights before it: the steps stay bit for bit). */
    if (s->stab_on) {
        double hs = s->h_stab;
        if (!(hs > 0.0) && s->h_stab_pre < 0.0) {
            double omega = 0.0, c = 0.0;
            scatter(s, N_VGetArrayPointer(s->y));
            if (s->host->omega_max(s->sys, s->x, &omega, &c) == DEFSIM_OK) {
                s->h_stab_pre = table_stable_step(s->bt, omega, c);
                count(s, C_STAB_ESTIMATES, 1.0);
            }
        }
        if (!(hs > 0.0) && s->h_stab_pre >= 0.0) hs = s->h_stab_pre;
        hs = isfinite(hs) ? hs : 0.0;   /* no estimate, or no limit: nothing to refuse */
        const double need = hs > 0.0 ? h / (s->stab_safety * hs) : 0.0;
        if (need > (double)s->max_steps) {
            char msg[400];
            snprintf(msg, sizeof msg, "sundials_erk: h = %g s needs at least %.3g internal steps "
                     "at the stability limit (%.3g s x stability_safety %g), more than "
                     "sundials_erk.max_internal_steps (%ld) allows in one call: take shorter "
                     "steps or raise max_internal_steps", h, need, hs, s->stab_safety,
                     s->max_steps);
            host->set_error(sys, msg);
            return DEFSIM_ERR_NOT_CONVERGED;
        }
    }
    const double tout = s->t + h;
    int flag = ERKStepSetStopTime(s->mem, tout);
    if (flag < 0) return erk_fail(s, "ERKStepSetStopTime", flag);
    realtype tret = s->t;
    s->sun.msg[0] = '\0';
    flag = ERKStepEvolve(s->mem, tout, s->y, &tret, ARK_NORMAL);
    update_stats(s);
    if (flag < 0) return erk_fail(s, "ERKStepEvolve", flag);
    defsim__sun_scatter(s->free_dofs, s->n, N_VGetArrayPointer(s->y), host->positions(sys),
                        host->velocities(sys));
    s->t = tout;
    return DEFSIM_OK;
}

/* Checkpoints. ERKStep's public API cannot set its internal state (the step-size history, the
 * growth factor, the next step length, the state it continues from, which is not the
 * interpolated one it returns at the stop time), so a checkpoint holds what lets a loaded world
 * replay the last internal step: the state it started from (and its first-stage derivative where
 * ERKStep reused one), its length, the length its error weights used, the controller's error
 * history, and the stability limit and its age. The
 * replayed step leaves ERKStep exactly where the saved run's was, and the next step continues bit
 * for bit (README "Checkpoints"). Layout 2; layout 1 (the next step length only) still loads. */
enum { ERK_LAYOUT = 2, ERK_INTS = 5, ERK_REALS = 6 };

static defsim_status erk_save(const defsim_host *host, defsim_system *sys, const void *state,
                              const defsim_state_writer *wr)
{
    (void)host;
    (void)sys;
    erk_state *s = (erk_state *)state;   /* ERKStep's getters take a non-const memory */
    long nst = 0;
    if (s->mem) ERKStepGetNumSteps(s->mem, &nst);
    /* No step since the restart: the next step restarts from the world's state anyway. */
    const int history = defsim__sun_has_history(&s->sun, s->mem, s->n) && nst > 0;
    defsim_status st = defsim__sun_save_flags(&s->sun, history, wr);
    if (st != DEFSIM_OK || !history) return st;
    long netf = 0, nexp = 0;
    realtype h = 0.0;
    ERKStepGetNumErrTestFails(s->mem, &netf);
    ERKStepGetNumExpSteps(s->mem, &nexp);
    ERKStepGetLastStep(s->mem, &h);
    const int64_t ints[ERK_INTS] = {ERK_LAYOUT, nst - s->stab_step, netf - s->stab_etf,
                                    nexp - s->stab_exp, s->f0_valid && !s->f0_called};
    const double reals[ERK_REALS] = {s->t, s->t0, h, s->w_h, s->h_stab, s->e_used};
    if ((st = wr->i64(wr->ctx, ints, ERK_INTS)) != DEFSIM_OK) return st;
    if ((st = wr->f64(wr->ctx, reals, ERK_REALS)) != DEFSIM_OK) return st;
    if ((st = wr->f64(wr->ctx, N_VGetArrayPointer(s->y0), 2 * s->n)) != DEFSIM_OK) return st;
    return wr->f64(wr->ctx, N_VGetArrayPointer(s->f0), 2 * s->n);
}

/* Layout 1 (before the replay): the next step length, the time, the stability limit. The world
 * restarts from its state with that step length: close to the saved run, not bit for bit. */
static defsim_status erk_load_layout1(erk_state *s, const defsim_state_reader *rd)
{
    double reals[3];
    if (rd->f64(rd->ctx, reals, 3) != DEFSIM_OK) return DEFSIM_ERR_IO;
    if (!(reals[0] > 0.0) || !isfinite(reals[0]) || !(reals[2] >= 0.0)) return DEFSIM_ERR_IO;
    defsim_status st = erk_restart(s);
    if (st != DEFSIM_OK) return st;
    int flag = ERKStepSetInitStep(s->mem, reals[0]);
    if (flag < 0) return erk_fail(s, "ERKStepSetInitStep", flag);
    s->hin_set = 1;
    s->t = reals[1];
    s->h_stab = reals[2];
    return DEFSIM_OK;
}

static defsim_status erk_load(const defsim_host *host, defsim_system *sys, void *state,
                              const defsim_state_reader *rd)
{
    erk_state *s = state;
    int history = 0;
    defsim_status st = defsim__sun_load_flags(&s->sun, rd, &history);
    if (st != DEFSIM_OK || !history) return st;   /* without one, the next step restarts */
    if (s->n == 0) return DEFSIM_ERR_IO;
    if (rd->remaining(rd->ctx) == 3) return erk_load_layout1(s, rd);
    int64_t ints[ERK_INTS];
    double reals[ERK_REALS];
    if (rd->i64(rd->ctx, ints, ERK_INTS) != DEFSIM_OK || ints[0] != ERK_LAYOUT ||
        rd->f64(rd->ctx, reals, ERK_REALS) != DEFSIM_OK ||
        rd->f64(rd->ctx, N_VGetArrayPointer(s->y0), 2 * s->n) != DEFSIM_OK ||
        rd->f64(rd->ctx, N_VGetArrayPointer(s->f0), 2 * s->n) != DEFSIM_OK)
        return DEFSIM_ERR_IO;
    const double tout = reals[0], t0 = reals[1], h = reals[2];
    if (!isfinite(tout) || !isfinite(t0) || !(t0 < tout) || !(h > 0.0) || !isfinite(h) ||
        !(reals[3] >= 0.0) || !(reals[4] >= 0.0) || !(reals[5] >= 0.0) ||
        (ints[4] != 0 && ints[4] != 1))
        return DEFSIM_ERR_IO;
    /* A run that drove pins in its last step restarts at the next one anyway. */
    if (s->sun.drove) return erk_restart(s);
    /* Replay the last internal step from where it started, with what decided its length (the
     * pinned entries of x and v are the world's: they do not move without a drive). */
    const size_t bytes = (size_t)s->ndof * sizeof(double);
    memcpy(s->x, host->positions(sys), bytes);
    memcpy(s->v, host->velocities(sys), bytes);
    N_VScale(1.0, s->y0, s->y);
    if ((st = erk_reinit(s, t0, s->y)) != DEFSIM_OK) return st;
    s->h_stab = reals[4];
    s->prior_e = reals[5];
    s->replay = 1;
    s->replay_f0 = (int)ints[4];
    s->replay_wh = reals[3];
    /* The saved step grew by at most ERKStep's growth factor, not its first-step one. (Never by
     * the cap of 1 that follows a rejected attempt: the last step of a call lands on the stop
     * time, and a retry is no longer than the rejected attempt, which did not pass the stop time
     * and failed, so a retried step is never the last one.) */
    int flag = ERKStepSetInitStep(s->mem, h);
    s->hin_set = 1;
    if (flag >= 0) flag = ERKStepSetMaxFirstGrowth(s->mem, ERK_GROWTH);
    if (flag >= 0) flag = ERKStepSetStopTime(s->mem, tout);
    realtype tret = t0;
    if (flag >= 0) flag = ERKStepEvolve(s->mem, tout, s->y, &tret, ARK_NORMAL);
    s->replay = 0;
    s->replay_f0 = 0;
    s->replay_wh = 0.0;
    /* A replay that fails (forces that the saved step did not meet: another build, or a
     * collider that moved in the saved step, which the replay sees still) is one that does not
     * land: a file the world can continue from all the same. */
    long nst = 0;
    if (flag >= 0) ERKStepGetNumSteps(s->mem, &nst);
    /* Back to ERKStep's first-step growth for later restarts. The initial step stays set until
     * the next restart clears it (erk_reinit): ERKStepSetInitStep on a running integrator also
     * resets its error history. */
    ERKStepSetMaxFirstGrowth(s->mem, 0.0);
    /* The replay must land on the saved state in one step; otherwise the file does not belong to
     * this build (another SUNDIALS, another machine) or the saved step saw a moving collider:
     * continue from the world's state. */
    const double *x = host->positions(sys), *v = host->velocities(sys);
    const double *y = N_VGetArrayPointer(s->y);
    int same = flag >= 0 && nst == 1;
    for (int64_t i = 0; i < s->n && same; ++i)
        same = memcmp(&x[s->free_dofs[i]], &y[i], sizeof *y) == 0 &&
               memcmp(&v[s->free_dofs[i]], &y[s->n + i], sizeof *y) == 0;
    if (!same) {
        if ((st = erk_restart(s)) != DEFSIM_OK) return st;
        s->h_stab = reals[4];
        return DEFSIM_OK;
    }
    long netf = 0, nexp = 0;
    ERKStepGetNumErrTestFails(s->mem, &netf);
    ERKStepGetNumExpSteps(s->mem, &nexp);
    s->f0_valid = 1;   /* what the replayed step started from, as saved */
    s->f0_called = !ints[4];
    s->stab_step = nst - ints[1];
    s->stab_etf = netf - ints[2];
    s->stab_exp = nexp - ints[3];
    s->t = tout;
    /* The replayed step is in the saved statistics already. */
    ERKStepGetNumSteps(s->mem, &s->base.steps);
    ERKStepGetNumStepAttempts(s->mem, &s->base.attempts);
    ERKStepGetNumRhsEvals(s->mem, &s->base.rhs);
    ERKStepGetNumErrTestFails(s->mem, &s->base.etf);
    ERKStepGetNumExpSteps(s->mem, &s->base.stab);
    ERKStepGetNumAccSteps(s->mem, &s->base.acc);
    return DEFSIM_OK;
}

static const defsim_backend erk_backend = {
    DEFSIM__SUN_TABLE(erk, "sundials_erk", DEFSIM_BACKEND_ADAPTIVE),
    .reset = defsim__sun_reset, .save_state = erk_save, .load_state = erk_load,
    .stable_step = erk_stable_step, .stable_step_options = erk_stable_step_options};

DEFSIM__SUN_MODULE_INIT(erk_backend)
