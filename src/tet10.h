/* SPDX-License-Identifier: MIT */
/*
 * The 10-node quadratic tetrahedron (docs/elements.md): its node order (VTK_QUADRATIC_TETRA:
 * corners 0..3, then the mid-edge nodes of edges 01, 12, 02, 03, 13, 23), shape functions,
 * quadrature rules, rest data per quadrature point, validation and orientation of a rest
 * element, the HRZ lumped mass, F at a quadrature point and the scatter of P to the nodes.
 *
 * Reference coordinates xi = (L0, L1, L2) with L3 = 1 - L0 - L1 - L2, so that a straight
 * element's Jacobian dX/dxi is Dm = [X0 - X3, X1 - X3, X2 - X3] of the linear tet on its corners
 * (DESIGN.md section 4): the same orientation rule (det Dm > 0) and, for a field linear in X, the
 * same F.
 */
#ifndef DEFSIM_TET10_H
#define DEFSIM_TET10_H

#include <stdint.h>

enum {
    DEFSIM__TET10_NODES = 10,
    DEFSIM__TET10_QP = 4,                       /* quadrature points of the stiffness rule */
    DEFSIM__TET10_QSTRIDE = 3 * 10 + 1,         /* per point: gradients G[a][j], then weight */
    DEFSIM__TET10_REST = 4 * (3 * 10 + 1)       /* rest doubles per element */
};

/* A rest element whose Jacobian determinant, relative to that of its corners' straight tet,
 * is not above this at a check point (corners, mid-edge nodes, centroid, quadrature points) is
 * rejected as degenerate or inverted. */
#define DEFSIM__TET10_MIN_JACOBIAN 1e-3

/* The corners (a, b) of the mid-edge node 4 + k. */
extern const int defsim__tet10_edge[6][2];

/* Quadrature rules on the reference tet (weights sum to 1/6), points as barycentric
 * (L0, L1, L2, L3): degree 2 (4 points, Hammer-Marlowe-Stroud; the stiffness rule) or degree
 * 5 (14 points, Walkington's positive rule; the mass). Returns the number of points and
 * sets *pts (4 doubles each) and *w, or 0 for another degree. */
int defsim__tet10_rule(int degree, const double **pts, const double **w);

/* Shape functions N[10] at barycentric L, and their derivatives dN[10][3] by xi. */
void defsim__tet10_shape(const double L[4], double N[10], double dN[10][3]);

/* Turns a rest element of negative corner orientation (det Dm < 0) positive: swaps corners 0
 * and 1 with the mid-edge nodes that follow them (12 <-> 02, 03 <-> 13). */
void defsim__tet10_flip(int32_t tet[10]);

/* The smallest det(dX/dxi) / det Dm over the check points of element `tet` (10 indices into
 * pos, corners positively oriented). */
double defsim__tet10_min_jacobian(const double *pos, const int32_t tet[10]);

/* Rest data of a validated element: per quadrature point of the stiffness rule the gradients
 * G[a][j] = dN_a/dX_j (30 doubles) and the weight W_q det(dX/dxi) (m^3), into rest
 * (DEFSIM__TET10_REST doubles); returns the element's volume (the degree-5 rule: exact for
 * curved elements, whose Jacobian determinant is cubic). */
double defsim__tet10_rest(const double *pos, const int32_t tet[10], double *rest);

/* HRZ lumped masses of an element of density rho (kg per node, added to m[tet[a]]): the
 * diagonal of its consistent mass matrix (degree-5 rule) scaled to the element's mass
 * rho V. Positive for every node (row sums are not: the corners' shape functions integrate to
 * -V/20). */
void defsim__tet10_mass(const double *pos, const int32_t tet[10], double rho, double *m);

/* F = sum_a x_a G_a^T at one quadrature point (G: its 30 gradients). */
static inline void defsim__tet10_F(const double *x, const int32_t *id, const double *G,
                                   double F[9])
{
    for (int i = 0; i < 9; ++i) F[i] = 0.0;
    for (int a = 0; a < 10; ++a) {
        const double *p = x + 3 * (int64_t)id[a];
        const double *g = G + 3 * a;
        for (int i = 0; i < 3; ++i) {
            F[3 * i] += p[i] * g[0];
            F[3 * i + 1] += p[i] * g[1];
            F[3 * i + 2] += p[i] * g[2];
        }
    }
}

/* f_a += s P G_a for the ten nodes (s = -weight for elastic forces). */
static inline void defsim__tet10_scatter(double *f, const int32_t *id, const double *G,
                                         const double P[9], double s)
{
    for (int a = 0; a < 10; ++a) {
        const double *g = G + 3 * a;
        double *fa = f + 3 * (int64_t)id[a];
        for (int i = 0; i < 3; ++i)
            fa[i] += s * (P[3 * i] * g[0] + P[3 * i + 1] * g[1] + P[3 * i + 2] * g[2]);
    }
}

/* The element matrix K (30 x 30, row-major) = sum_q w_q G_q^T D_q G_q + c b b^T over the
 * points of rest data `rest` with their symmetric 9 x 9 tangents D (b: 30 doubles, or NULL for
 * none): the upper blocks summed point by point, the lower ones mirrored. */
void defsim__tet10_stiffness(const double *rest, const double D[DEFSIM__TET10_QP][81], double c,
                             const double *b, double *K);

struct defsim__group;

/* Group-level kernels that other files than the elastic term need (a group of quadratic tets,
 * system.h): */
/* Stiffness damping forces -beta K_e(x) v_e added into f (dP/dF clamped at each point). */
void defsim__tet10_damping_forces(const struct defsim__group *g, const double *x, const double *v,
                                  double *f, int nthreads);
/* The elastic forces of element e at x into fl (30 doubles, the element's node order; a mixed
 * group's: the mean-dilatation element's). */
void defsim__tet10_element_forces(const struct defsim__group *g, const double *x, int32_t e,
                                  double fl[30]);
/* The smallest det F over element e's quadrature points at x (the volume ratio). */
double defsim__tet10_min_det(const struct defsim__group *g, const double *x, int32_t e);
struct defsim__model;
/* The mean-dilatation element (docs/elements.md; a mixed group's, law with a split, material.h)
 * at x (rest data `rest`, nodes id into x): its energy relative to rest
 *     sum_q w_q psi_iso(F_q) + V U(Jbar) - V psi_rest,   Jbar = sum_q w_q J_q / V,  V = sum_q w_q,
 * returned; F_q into F, the stress dE/dF_q / w_q = P_iso(F_q) + U'(Jbar) cof F_q into P, and
 * U, U', U'' at Jbar into u. */
double defsim__tet10_mixed(const struct defsim__model *law, double mu, double la, const double *x,
                           const int32_t *id, const double *rest,
                           double F[DEFSIM__TET10_QP][9], double P[DEFSIM__TET10_QP][9],
                           double u[3]);
/* An element's volume-weighted means over its quadrature points (rest data `rest`, nodes id
 * into x) of the Cauchy stress (9, row major; NaN where det F = 0 or a needs_positive_det model
 * meets det F <= 0) and of the energy density relative to rest (J/m^3: the element's energy over
 * its volume); mixed: the mean-dilatation element's (its stress P_q at each point). */
void defsim__tet10_stress(const struct defsim__model *law, double mu, double la, int mixed,
                          const double *x, const int32_t *id, const double *rest, double sigma[9],
                          double *psi);

#endif /* DEFSIM_TET10_H */
