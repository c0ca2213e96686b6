/* SPDX-License-Identifier: MIT */
/* Stability of explicit steps: the highest frequency omega_max of a compiled system and its
 * damping coefficient, from which a backend's stable_step gives the largest stable h. */
#include "stability.h"

#include "assembly.h"
#include "contact.h"

#include <math.h>

/* The factor on the penalty's frequency in the stable step: measured on boxes resting on and
 * dropped onto a plane (docs/stability.md "Contact"), the heating stays slow up to
 * h sqrt(omega_el^2 + (1.9..2.45 omega_c)^2) = 2; 2.5 leaves room for a host's 0.9. */
#define PENALTY_KINK 2.5

/* Largest eigenvalue of M^-1/2 K(x) M^-1/2 over the free DOFs (exact Hessians) by power
 * iteration from a fixed start, to 1e-4 relative in the Rayleigh quotient. If the dominant
 * eigenvalue is negative (a strongly compressed, unstable configuration), the iteration is
 * repeated with that shift to find the largest positive one. */
defsim_status defsim__omega_max(const defsim__system *sys, defsim__work *wk, const double *x,
                                double *omega)
{
    /* The elastic part alone; contact's penalty is added below as a bound. */
    defsim__system elastic = *sys;
    elastic.contact = NULL;
    const defsim__system *s = &elastic;
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
            defsim__matrix_apply(s, x, &ck, DEFSIM_PROJECTION_NONE, u, y);
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
    /* Contact's penalty springs (diagonal, k_i = omega_c^2 m_i) raise the top of the spectrum by
     * at most omega_c^2 (Weyl), whether or not a contact is active at x. That bound is the
     * linear one; the penalty switches on and off at d = dhat, and an explicit step that lands
     * past the switch gains or loses energy: near the linear limit a body at rest on a collider
     * heats up and blows up within thousands of steps. The energy goes to the fastest modes,
     * the springs' or the body's own, so the term is PENALTY_KINK times the larger of omega_c
     * and omega_el (docs/stability.md "Contact"). */
    if (sys->contact && sys->contact->mode == DEFSIM__CONTACT_PENALTY) {
        const double el = lambda > 0.0 ? lambda : 0.0;
        lambda = el + PENALTY_KINK * PENALTY_KINK * fmax(sys->contact->khat, el);
    }
    *omega = lambda > 0.0 ? sqrt(lambda) : 0.0;
    return isfinite(*omega) ? DEFSIM_OK : DEFSIM_ERR_UNSTABLE;
}

double defsim__damping_coeff(const defsim__system *s, const double *x, double omega)
{
    double alpha = 0.0, beta = 0.0;
    for (int64_t i = 0; i < 3 * (int64_t)s->nv; ++i)
        if (!s->pinned[i / 3] && s->alpha3[i] > alpha) alpha = s->alpha3[i];
    for (int m = 0; m <= DEFSIM__TET_MODELS; ++m)
        for (int32_t e = 0; e < s->groups[m].n; ++e)
            if (s->groups[m].beta[e] > beta) beta = s->groups[m].beta[e];
    /* An attachment's damper acts on its nodes at a rate of at most c sum_j a_j^2 / min m. */
    const defsim__attachments *at = &s->att;
    for (int32_t e = 0; e < at->n; ++e) {
        if (at->c[e] == 0.0) continue;
        double a2 = 0.0, mmin = INFINITY;
        for (int j = 0; j < DEFSIM__ATTACH_NODES; ++j) {
            const int32_t v = at->node[DEFSIM__ATTACH_NODES * (int64_t)e + j];
            if (v < 0 || s->pinned[v]) continue;
            const double a = at->a[DEFSIM__ATTACH_NODES * (int64_t)e + j];
            a2 += a * a;
            if (s->mass[v] < mmin) mmin = s->mass[v];
        }
        if (a2 > 0.0 && at->c[e] * a2 / mmin > alpha) alpha = at->c[e] * a2 / mmin;
    }
    if (s->contact && x) alpha += defsim__contact_damping_rate(s->contact, x, s->gravity);
    return alpha + beta * omega * omega;
}
