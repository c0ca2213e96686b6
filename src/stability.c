/* SPDX-License-Identifier: MIT */
/* Stability of explicit steps: the highest frequency omega_max of a compiled system and its
 * damping coefficient, from which a backend's stable_step gives the largest stable h. */
#include "stability.h"

#include "assembly.h"

#include <math.h>

/* Largest eigenvalue of M^-1/2 K(x) M^-1/2 over the free DOFs (exact Hessians) by power
 * iteration from a fixed start, to 1e-4 relative in the Rayleigh quotient. If the dominant
 * eigenvalue is negative (a strongly compressed, unstable configuration), the iteration is
 * repeated with that shift to find the largest positive one. */
defsim_status defsim__omega_max(const defsim__system *sys, defsim__work *wk, const double *x,
                                double *omega)
{
    /* Without the terms that bound their share instead (contact's penalty, added below); terms
     * that cache their blocks linearise once, at the first product. */
    const defsim__system *s = sys;
    const int64_t ndof = 3 * (int64_t)s->nv;
    double *z = wk->pz, *y = wk->py, *u = wk->pu;
    const defsim_matrix_coeffs ck = {1.0, 0.0, 0.0, 0.0};
    double shift = 0.0, lambda = 0.0;
    for (int pass = 0; pass < 2; ++pass) {
        unsigned long long seed = 0x9E3779B97F4A7C15ULL;
        double nrm = 0.0;
        for (int64_t i = 0; i < ndof; ++i) {
            seed = seed * 6364136223846793005ULL + 1442695040888963407ULL;
            z[i] = s->pinned[i / 3] ? 0.0 : (double)(seed >> 11) / 9007199254740992.0 + 0.5;
            nrm += z[i] * z[i];
        }
        if (!(nrm > 0.0)) break;
        for (int64_t i = 0; i < ndof; ++i) z[i] /= sqrt(nrm);
        double prev = 0.0;
        for (int it = 0; it < 300; ++it) {
            for (int64_t i = 0; i < ndof; ++i) u[i] = z[i] / sqrt(s->mass3[i]);
            defsim__matrix_apply_skip(s, x, &ck, DEFSIM_PROJECTION_NONE, DEFSIM__TERM_BOUNDED, u,
                                      y);
            double q = 0.0, yn = 0.0;
            for (int64_t i = 0; i < ndof; ++i) {
                y[i] = y[i] / sqrt(s->mass3[i]) + shift * z[i];
                q += z[i] * y[i];
                yn += y[i] * y[i];
            }
            lambda = q;
            if (!(yn > 0.0)) break;
            for (int64_t i = 0; i < ndof; ++i) z[i] = y[i] / sqrt(yn);
            if (it > 5 && fabs(lambda - prev) <= 1e-4 * fabs(lambda)) break;
            prev = lambda;
        }
        lambda -= shift;
        if (lambda >= 0.0 || pass == 1) break;
        shift = -lambda;   /* dominant eigenvalue negative: shift the spectrum up */
    }
    /* A bounded term raises the top of the spectrum by at most its bound. */
    for (int32_t k = 0; k < s->nterms; ++k) {
        const defsim__term *t = &s->terms[k];
        if (t->ops->lambda_bound) lambda = t->ops->lambda_bound(t, s, lambda);
    }
    *omega = lambda > 0.0 ? sqrt(lambda) : 0.0;
    return isfinite(*omega) ? DEFSIM_OK : DEFSIM_ERR_UNSTABLE;
}

double defsim__damping_coeff(const defsim__system *s, const double *x, double omega)
{
    defsim__rates r = {0.0, 0.0, 0.0};
    for (int32_t k = 0; k < s->nterms; ++k) {
        const defsim__term *t = &s->terms[k];
        if (t->ops->rates) t->ops->rates(t, s, x, &r);
    }
    return (r.alpha + r.alpha_add) + r.beta * omega * omega;
}
