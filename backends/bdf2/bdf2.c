/* SPDX-License-Identifier: MIT */
/*
 * bdf2: the two-step backward differentiation formula, with variable steps, as the minimisation
 * of the incremental potential
 *
 *   g(x) = 1/(2 b^2 h^2) |x - y|^2_M + E(x) + 1/(2 b h) |x - z|^2_D,
 *   z = a1 x_n - a2 x_{n-1},   y = z + b h (a1 v_n - a2 v_{n-1}),   D = alpha M + B(x_n + h v_n),
 *
 * with w = h_n / h_{n-1}, a1 = (1+w)^2/(1+2w), a2 = w^2/(1+2w), b = (1+w)/(1+2w) (4/3, 1/3, 2/3
 * for equal steps) and v' = (x' - z)/(b h). Without history (the first step, after set_state,
 * pins, a failed step, or a step more than 1 + sqrt 2 times the previous one) it takes one
 * backward-Euler step (a1 = b = 1, a2 = 0). A scheme of the implicit-solver core
 * (backends/implicit_core); README.md beside this file derives it.
 */
#include "implicit_core.h"

#include <math.h>
#include <string.h>

/* Variable-step BDF2 is zero-stable for step ratios below 1 + sqrt(2). */
#define BDF2_MAX_RATIO 2.414

/* The step's coefficients (a1, a2, b) from the history and h; 0: a backward-Euler restart. */
static int bdf2_coefficients(const defsim__ic_solver *s, double h, double *a1, double *a2,
                             double *b)
{
    *a1 = 1.0;
    *a2 = 0.0;
    *b = 1.0;
    const double w = s->history_valid ? h / s->history_h : INFINITY;
    if (!(w <= BDF2_MAX_RATIO)) return 0;
    *a1 = (1.0 + w) * (1.0 + w) / (1.0 + 2.0 * w);
    *a2 = w * w / (1.0 + 2.0 * w);
    *b = (1.0 + w) / (1.0 + 2.0 * w);
    return 1;
}

static defsim_status bdf2_prepare(defsim__ic_solver *s, const defsim_host *host,
                                  defsim_system *sys, double h, defsim__ic_targets *st)
{
    const double *xp = s->work[0], *vp = s->work[1];
    double *xb = s->work[2], *z = s->z, *y = s->y;
    double a1, a2, b;
    if (!bdf2_coefficients(s, h, &a1, &a2, &b)) s->counters[DEFSIM__IC_COUNTERS] += 1.0;
    const size_t bytes = (size_t)s->ndof * sizeof(double);
    memcpy(z, s->x0, bytes);   /* pinned DOFs stay exactly at x_n */
    memcpy(y, s->x0, bytes);
    for (int64_t k = 0; k < s->n; ++k) {
        const int64_t i = s->fdof[k];
        const double vh = a2 > 0.0 ? a1 * s->v0[i] - a2 * vp[i] : s->v0[i];
        if (a2 > 0.0) z[i] = a1 * s->x0[i] - a2 * xp[i];
        y[i] = z[i] + b * h * vh;
    }
    for (int64_t i = 0; i < s->ndof; ++i) xb[i] = s->x0[i] + h * s->v0[i];
    st->cm = 1.0 / (b * b);
    st->cd = 1.0 / b;
    st->y = y;
    st->z = z;
    st->guess = y;
    /* With history, Newton starts from x_n + h v_n + h^2/2 a, a = (v_n - v_{n-1}) / h_{n-1}: third
     * order accurate, where y is off by b^2 h^2 a'. */
    if (a2 > 0.0) {
        double *guess = s->work[3];
        memcpy(guess, xb, bytes);
        for (int64_t k = 0; k < s->n; ++k) {
            const int64_t i = s->fdof[k];
            guess[i] += 0.5 * h * h * (s->v0[i] - vp[i]) / s->history_h;
        }
        st->guess = guess;
    }
    /* B at the predicted end of the step keeps the damping term second order. */
    return defsim__ic_damping_matrix(s, host, sys, xb);
}

static void bdf2_accept(defsim__ic_solver *s, double h)
{
    const size_t bytes = (size_t)s->ndof * sizeof(double);
    memcpy(s->work[0], s->x0, bytes);
    memcpy(s->work[1], s->v0, bytes);
    s->history_h = h;
    s->history_valid = 1;
}

/* The adjoint through the targets (docs/gradients.md): z = a1 x_n - a2 x_{n-1} and
 * y = z + b h (a1 v_n - a2 v_{n-1}) on the free DOFs, x_b = x_n + h v_n. The adjoints of
 * x_{n-1} and v_{n-1} wait in work[4], work[5] for the next call (the previous step's), whose
 * start they are. */
static void bdf2_adjoint(defsim__ic_solver *s, double h, const defsim_adjoint_step *a,
                         const double *ay, const double *az, const double *axb)
{
    double *cx = s->work[4], *cv = s->work[5];
    if (a->first) {
        memset(cx, 0, (size_t)s->ndof * sizeof *cx);
        memset(cv, 0, (size_t)s->ndof * sizeof *cv);
    }
    double a1, a2, b;
    bdf2_coefficients(s, h, &a1, &a2, &b);
    for (int64_t k = 0; k < s->n; ++k) {
        const int64_t i = s->fdof[k];
        const double azt = az[i] + ay[i];
        a->ax0[i] = a1 * azt + axb[i] + cx[i];
        a->av0[i] = b * h * a1 * ay[i] + h * axb[i] + cv[i];
        cx[i] = -a2 * azt;
        cv[i] = -b * h * a2 * ay[i];
    }
}

static const defsim_counter_spec bdf2_counters[1] = {
    {"restarts", "backward-Euler steps taken for want of history: the first step, after "
                 "set_state, pins or a failed step, or after a step ratio above 2.414"},
};

const defsim__ic_scheme defsim__ic_module_scheme = {
    .name = "bdf2",
    .flags = DEFSIM_BACKEND_DISSIPATIVE | DEFSIM_BACKEND_CONTACT_CCD |
             DEFSIM_BACKEND_ADJOINT_HISTORY,
    .work_vectors = 6, .history_vectors = 2,
    .prepare = bdf2_prepare, .accept = bdf2_accept, .counters = bdf2_counters, .counter_count = 1,
    .differentiable = 1, .adjoint_xb = 1.0, .adjoint_history = bdf2_adjoint};
