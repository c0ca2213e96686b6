/* SPDX-License-Identifier: MIT */
/*
 * The scalar functions that collider contact (contact.c) and body contact (body_contact.c)
 * share: IPC's log barrier on a distance and its derivatives, and IPC's smoothed friction with
 * its positive semi-definite Hessian block.
 */
#ifndef DEFSIM_CONTACT_BARRIER_H
#define DEFSIM_CONTACT_BARRIER_H

#include <math.h>

/* IPC's barrier b(d) = -(d - dhat)^2 ln(d / dhat) for 0 < d < dhat, and its derivatives. */
static inline double barrier(double d, double dh)
{
    const double r = d - dh;
    return -r * r * log(d / dh);
}

static inline double barrier_d1(double d, double dh)
{
    const double r = d - dh;
    return -2.0 * r * log(d / dh) - r * r / d;
}

static inline double barrier_d2(double d, double dh)
{
    const double r = d - dh;
    return -2.0 * log(d / dh) - 4.0 * r / d + r * r / (d * d);
}

/* IPC's smoothed friction magnitude f0(y) (f0' = f1: 2y/eps - y^2/eps^2 below eps, then 1). */
static inline double friction_f0(double y, double eps)
{
    return y >= eps ? y : -y * y * y / (3.0 * eps * eps) + y * y / eps + eps / 3.0;
}

/* f1(y) / y, finite at y = 0. */
static inline double friction_f1_over_y(double y, double eps)
{
    return y >= eps ? 1.0 / y : 2.0 / eps - y / (eps * eps);
}

/* Adds s * Hessian of f0(|P u|) with respect to u (P = I - n n^T, ut = P u, y = |ut|) into B:
 * (f1/y) P + (f1/y)' ut ut^T / y, positive semi-definite for every y. */
static inline void friction_block(double s, const double n[3], const double ut[3], double y,
                                  double eps, double B[9])
{
    const double a = friction_f1_over_y(y, eps);
    const double b = y >= eps ? -1.0 / (y * y * y) : (y > 0.0 ? -1.0 / (eps * eps * y) : 0.0);
    for (int r = 0; r < 3; ++r)
        for (int q = 0; q < 3; ++q)
            B[3 * r + q] += s * (a * ((r == q) - n[r] * n[q]) + b * ut[r] * ut[q]);
}

#endif /* DEFSIM_CONTACT_BARRIER_H */
