/* SPDX-License-Identifier: MIT */
/* An independent backward-Euler step for tests of implicit backends: dense Newton on the
 * residual of the step, with a central-difference Jacobian and Gaussian elimination, solved to
 * roundoff. It shares only the core's physics (forces) with the backends under test. */
#ifndef DEFSIM_BE_REFERENCE_H
#define DEFSIM_BE_REFERENCE_H

#include <defsim/defsim.h>

/* One step of h from (xn, vn) (3 n doubles each) of world w's scene, into (x1, v1):
 *     M (x - xn - h vn) / h^2 - f_el(x) - M g + (C + B(xn)) (x - xn) / h = 0 on free DOFs
 * (C, B the core's Rayleigh damping matrices, applied with defsim__matrix_product),
 * v1 = (x1 - xn) / h; pinned vertices keep xn and get zero velocity. Returns the number of
 * Newton iterations; fails the test if Newton does not converge. The world is not changed. */
int be_reference_step(defsim_world *w, const double *xn, const double *vn, double h, double *x1,
                      double *v1);

/* A soft cantilever [0, 1.5] x [0, 0.5]^2 (3 x 1 x 1 cells, 18 tets, E = 50 kPa, nu = 0.35,
 * 1000 kg/m^3) clamped at x = 0, under gravity, with the velocity field v_y = x * 1/s that
 * swings it up, so backward-Euler steps are large and nonlinear. Lengths are scaled by `unit`
 * (1: metres, 1000: millimetres, with modulus, density and gravity in matching units). */
defsim_world *be_cantilever(const char *backend, double tol, int max_iter, defsim_model model,
                           double alpha, double beta, defsim_projection proj, double unit);

#endif
