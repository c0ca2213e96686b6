/* SPDX-License-Identifier: MIT */
/* Symplectic (semi-implicit) Euler: v' = v + h M^-1 f(x, v), then x' = x + h v'. Built in. */
#include "../euler_common/euler_common.h"

#include <math.h>

static defsim_status se_step(const defsim_host *host, defsim_system *sys, void *state, double h)
{
    return euler_step(host, sys, state, h, 1, "symplectic_euler: non-finite forces");
}

/* For x'' = -omega^2 x - c x' the step matrix has determinant 1 - h c and trace
 * 2 - h c - h^2 omega^2; both roots lie in the unit disc iff h c <= 2 and
 * h^2 omega^2 + 2 h c <= 4. */
static defsim_status se_adjoint_step(const defsim_host *host, defsim_system *sys, void *state,
                                     double h, const defsim_adjoint_step *a)
{
    return euler_adjoint_step(host, sys, state, h, a, 1);
}

static double se_stable_step(double omega, double c)
{
    if (!(omega > 0.0)) return c > 0.0 ? 2.0 / c : 1e300;
    double h = (-c + sqrt(c * c + 4.0 * omega * omega)) / (omega * omega);
    return c > 0.0 && 2.0 / c < h ? 2.0 / c : h;
}

const defsim_backend defsim__symplectic_euler_backend =
    EULER_BACKEND("symplectic_euler", DEFSIM_BACKEND_CONSERVATIVE, se_step, se_stable_step,
                  se_adjoint_step);
