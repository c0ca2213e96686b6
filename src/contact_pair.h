/* SPDX-License-Identifier: MIT */
/*
 * One body-contact constraint's barrier (contact_pair.c): the energy kappa b(d), its gradient
 * and its Hessian projected to positive semi-definite, for the contact types of IPC:
 * vertex-vertex (X = p, q), edge-vertex (X = p, e0, e1), face-vertex (X = p, t0, t1, t2; the
 * point-triangle distance with its closest-feature regions) and edge-edge (X = a0, a1, b0, b1;
 * the segment distance with IPC's mollifier for nearly parallel edges). body_contact.c builds the
 * constraints; this file is the per-constraint kernel that every phase (energy, gradient,
 * Hessian) calls.
 */
#ifndef DEFSIM_CONTACT_PAIR_H
#define DEFSIM_CONTACT_PAIR_H

/* Contact types, with their vertex counts 2, 3, 4, 4. */
enum { DEFSIM__C_VV = 0, DEFSIM__C_EV = 1, DEFSIM__C_FV = 2, DEFSIM__C_EE = 3 };

static inline int defsim__contact_nodes(int type)
{
    return type == DEFSIM__C_VV ? 2 : type == DEFSIM__C_EV ? 3 : 4;
}

/* The squared distance of a constraint of this type (g: 3n gradient, H: 3n x 3n row-major;
 * either may be NULL). */
double defsim__contact_dist2(int type, const double *X, double *g, double *H);

/* The barrier of one constraint at X (3n coordinates, n = defsim__contact_nodes(type)):
 * kappa b(d) with IPC's log barrier inside dhat, times the edge-edge mollifier for DEFSIM__C_EE
 * (eps_moll: its threshold, defsim__ee_mollifier_eps of the rest positions; ignored otherwise).
 * Returns 0 outside dhat (g and H left unwritten) and +inf at distance 0. g (3n) receives the
 * gradient and H (3n x 3n, row-major, exactly symmetric) the Hessian projected to PSD when not
 * NULL: the exact eigenvalue clamp of the whole 3n x 3n matrix (to rounding), in closed form for
 * point-point, point-plane and line-line regions (see contact_pair.c). Pure: no state, safe to
 * call from any number of threads. */
double defsim__contact_barrier(int type, const double *X, double dhat, double kappa,
                               double eps_moll, double *g, double *H);
/* The same with a thickness offset xi >= 0 (m): kappa b(d - xi) inside xi < d < xi + dhat
 * (the contact thickness, docs/body-contact.md "Thickness"), +inf at d <= xi; xi = 0 is
 * defsim__contact_barrier, bit for bit. The closed-form projections hold unchanged: they take
 * f'(d) and f''(d) of any f of the distance, here f(d) = kappa b(d - xi). exact != 0: H is the
 * exact Hessian, not projected (a backward pass's matrix and the reverse mode,
 * docs/gradients.md), from the distance's and the mollifier's derivatives for every type; the
 * energy and the gradient are the same either way. */
double defsim__contact_barrier_offset(int type, const double *X, double dhat, double xi,
                                      double kappa, double eps_moll, int exact, double *g,
                                      double *H);

#endif /* DEFSIM_CONTACT_PAIR_H */
