/* SPDX-License-Identifier: MIT */
/* Explicit (forward) Euler: x' = x + h v, v' = v + h M^-1 f(x, v). Built in. */
#include "../euler_common/euler_common.h"

#include <math.h>

static defsim_status ee_step(const defsim_host *host, defsim_system *sys, void *state, double h)
{
    return euler_step(host, sys, state, h, 0, "explicit_euler: non-finite forces");
}

/* Amplification |1 + h lambda| <= 1 for lambda = -c/2 +- i sqrt(omega^2 - c^2/4) gives
 * h <= c / omega^2 (underdamped); overdamped modes need h <= 2 / |lambda_max|. */
static defsim_status ee_adjoint_step(const defsim_host *host, defsim_system *sys, void *state,
                                     double h, const defsim_adjoint_step *a)
{
    return euler_adjoint_step(host, sys, state, h, a, 0);
}

static double ee_stable_step(double omega, double c)
{
    if (!(omega > 0.0)) return c > 0.0 ? 2.0 / c : 1e300;
    if (c < 2.0 * omega) return c / (omega * omega);
    double lam = 0.5 * (c + sqrt(c * c - 4.0 * omega * omega));
    return 2.0 / lam;
}

const defsim_backend defsim__explicit_euler_backend =
    EULER_BACKEND("explicit_euler", 0, ee_step, ee_stable_step,
                  ee_adjoint_step);
