/* SPDX-License-Identifier: MIT */
/*
 * newton_cholmod: implicit (backward) Euler as the minimisation of the incremental potential
 *
 *   g(x) = 1/(2h^2) (x - y)^T M (x - y) + E(x) + 1/(2h) (x - x_n)^T (alpha M + beta K_n) (x - x_n)
 *
 * with y = x_n + h v_n and K_n the (clamped) stiffness-damping matrix at x_n; v' = (x' - x_n)/h.
 * The scheme of the implicit-solver core (backends/implicit_core): c_m = c_d = 1, z = x_n.
 * README.md beside this file documents the method, its parameters and its statistics.
 */
#include "implicit_core.h"

static defsim_status be_prepare(defsim__ic_solver *s, const defsim_host *host,
                                defsim_system *sys, double h, defsim__ic_targets *st)
{
    for (int64_t i = 0; i < s->ndof; ++i) s->y[i] = s->x0[i] + h * s->v0[i];
    st->cm = 1.0;
    st->cd = 1.0;
    st->y = s->y;
    st->z = s->x0;
    st->guess = s->y;
    return defsim__ic_damping_matrix(s, host, sys, s->x0);
}

const defsim__ic_scheme defsim__ic_module_scheme = {
    .name = "newton_cholmod", .flags = DEFSIM_BACKEND_DISSIPATIVE | DEFSIM_BACKEND_CONTACT_CCD,
    .work_vectors = 0,
    .prepare = be_prepare,
    .differentiable = 1};
