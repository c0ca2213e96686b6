/* SPDX-License-Identifier: MIT */
/*
 * newmark: Newmark's average-acceleration method (beta = 1/4, gamma = 1/2, the trapezoidal rule
 * in x and v) as the minimisation of the incremental potential
 *
 *   g(x) = 2/h^2 |x - y|^2_M + E(x) + 1/h |x - z|^2_D,
 *   y = x_n + h v_n + h^2/4 a_n,   z = x_n + h/2 v_n,   D = alpha M + B(z),
 *
 * with M a_n = f(x_n) - D v_n from the equation of motion at the start of every step (so the
 * state is (x, v) alone), and v' = 2/h (x' - z). A scheme of the implicit-solver core
 * (backends/implicit_core); README.md beside this file derives it.
 */
#include "implicit_core.h"

static defsim_status nm_prepare(defsim__ic_solver *s, const defsim_host *host,
                                defsim_system *sys, double h, defsim__ic_targets *st)
{
    double *z = s->z, *y = s->y, *guess = s->work[0];
    for (int64_t i = 0; i < s->ndof; ++i) {
        z[i] = s->x0[i] + 0.5 * h * s->v0[i];
        y[i] = guess[i] = s->x0[i] + h * s->v0[i];
    }
    /* B at the predicted midpoint keeps the damping term second order. */
    defsim_status status = defsim__ic_damping_matrix(s, host, sys, z);
    if (status != DEFSIM_OK) return status;
    /* f(x_n) at t_n: the force callback, if any, sees the start of the step. */
    const int coupled = host->size >= offsetof(defsim_host, applied_forces_vary) +
                                          sizeof host->applied_forces_vary;
    const uint32_t which = DEFSIM_FORCE_ELASTIC | DEFSIM_FORCE_GRAVITY;
    status = coupled ? host->forces_at(sys, s->x0, NULL, host->time(sys), which, s->f)
                     : host->forces(sys, s->x0, NULL, which, s->f);
    if (status != DEFSIM_OK) return status;
    for (int64_t k = 0; k < s->n; ++k) s->e[k] = s->v0[s->fdof[k]];
    defsim__ic_damping_product(s, s->e, s->be);
    /* Driven pins damp the free DOFs too: -B(z) v_pins on the free rows. */
    double *fpin = s->work[1];
    const int pins = s->pin_vel && s->bval;
    if (pins && (status = host->forces(sys, z, s->pin_vel, DEFSIM_FORCE_DAMPING, fpin)) != DEFSIM_OK)
        return status;
    for (int64_t k = 0; k < s->n; ++k) {
        const int64_t i = s->fdof[k];
        double net = s->f[i] - s->alpha[i] * s->mass[i] * s->v0[i] - s->be[k];
        if (pins) net += fpin[i];
        const double a = net / s->mass[i];
        y[i] += 0.25 * h * h * a;
        guess[i] += 0.5 * h * h * a;
    }
    st->cm = 4.0;
    st->cd = 2.0;
    st->y = y;
    st->z = z;
    st->guess = guess;
    return DEFSIM_OK;
}

/* Without damping it conserves the energy of linear problems: CONSERVATIVE, not DISSIPATIVE. */
const defsim__ic_scheme defsim__ic_module_scheme = {
    .name = "newmark", .flags = DEFSIM_BACKEND_CONSERVATIVE | DEFSIM_BACKEND_CONTACT_CCD,
    .work_vectors = 2,
    .prepare = nm_prepare,
    .differentiable = 1, .adjoint_z = 0.5, .adjoint_a = 0.25, .adjoint_xb = 0.5};
