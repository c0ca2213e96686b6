/* SPDX-License-Identifier: MIT */
/*
 * Cloth and shells (shell.c; docs/shells.md): the element laws of the membrane and bending
 * terms (term_membrane.c, term_hinge.c) and the rest-shape rules that body.c validates with and
 * plan.c builds from. Membrane: a triangle's 3x2 deformation gradient F = Ds Dm^-1 over its rest
 * plane (Dm: the rest edges in an orthonormal frame whose first axis is the warp), StVK (plane-
 * stress orthotropic moduli c11 c12 c22 g, isotropic as the special case) and neo-Hookean laws.
 * Bending: discrete shells' hinge, E = w/2 (theta - theta0)^2 with the signed dihedral angle
 * theta = atan2(y, x) of y = -|e| e . (a x b), x = (e . a)(e . b) - |e|^2 (a . b) (e = x1 - x0,
 * a = x2 - x0, b = x3 - x0), whose derivatives are polynomial: exact gradient and Hessian.
 */
#ifndef DEFSIM_SHELL_H
#define DEFSIM_SHELL_H

#include <stdint.h>

/* A triangle's formulas over any element type (double in shell.c, SIMD lanes in shell_batch.c),
 * as mat3.h's are: the shape gradients g[3][2] from Dm^-1 m[4] (g_1, g_2 its rows, g_0 =
 * -(g_1 + g_2)); F (3x2) = sum_a x_a g_a^T with XA(a, i) coordinate i of vertex a; C = F^T F
 * (2x2; C[1] = C[2]); out (3x2) = F M (M 2x2). */
#define DEFSIM__TRI_SHAPE(m, g)                                                               \
    do {                                                                                      \
        (g)[0][0] = -((m)[0] + (m)[2]);                                                       \
        (g)[0][1] = -((m)[1] + (m)[3]);                                                       \
        (g)[1][0] = (m)[0];                                                                   \
        (g)[1][1] = (m)[1];                                                                   \
        (g)[2][0] = (m)[2];                                                                   \
        (g)[2][1] = (m)[3];                                                                   \
    } while (0)
#define DEFSIM__TRI_F(XA, g, F)                                                               \
    for (int i_ = 0; i_ < 3; ++i_)                                                            \
        for (int j_ = 0; j_ < 2; ++j_)                                                        \
    (F)[2 * i_ + j_] = XA(0, i_) * (g)[0][j_] + XA(1, i_) * (g)[1][j_] + XA(2, i_) * (g)[2][j_]
#define DEFSIM__TRI_CAUCHY(F, C)                                                              \
    do {                                                                                      \
        (C)[0] = (F)[0] * (F)[0] + (F)[2] * (F)[2] + (F)[4] * (F)[4];                         \
        (C)[1] = (C)[2] = (F)[0] * (F)[1] + (F)[2] * (F)[3] + (F)[4] * (F)[5];                \
        (C)[3] = (F)[1] * (F)[1] + (F)[3] * (F)[3] + (F)[5] * (F)[5];                         \
    } while (0)
#define DEFSIM__TRI_FTIMES(F, M, out)                                                         \
    for (int i_ = 0; i_ < 3; ++i_)                                                            \
        for (int j_ = 0; j_ < 2; ++j_)                                                        \
    (out)[2 * i_ + j_] = (F)[2 * i_] * (M)[j_] + (F)[2 * i_ + 1] * (M)[2 + j_]

/* The membrane laws (one element group each); the hinges are a third group. */
enum {
    DEFSIM__MEMBRANE_STVK = 0,        /* isotropic and orthotropic StVK */
    DEFSIM__MEMBRANE_NEOHOOKEAN = 1,
    DEFSIM__SHELL_HINGES = 2,
    DEFSIM__SHELL_LIMITS = 3,         /* the strain limit's triangles (term_strain_limit.c) */
    DEFSIM__SHELL_GROUPS = 4
};

/* Doubles per membrane element in its group's `shell` array: Dm^-1 (2x2 row-major), then the
 * law's parameters (StVK: c11 c12 c22 g in N/m; neo-Hookean: mu lambda 0 0). */
enum { DEFSIM__MEMBRANE_WIDTH = 8 };

/* A rest triangle's frame: area A, Dm^-1 into dminv (Dm = [p1 - p0, p2 - p0] in the frame
 * (t1, t2), t1 the warp projected onto the triangle's plane, t2 = n x t1). When the warp is
 * within 1e-3 of the normal, t1 is the first edge's direction unless need_warp. Returns 0, 1
 * for a degenerate triangle (area <= 1e-12 of its longest edge squared), 2 for a warp normal to
 * it with need_warp. frame (may be NULL) receives t1, t2. */
int defsim__shell_frame(const double *p0, const double *p1, const double *p2,
                        const double warp[3], int need_warp, double dminv[4], double *area,
                        double frame[6]);

/* The law's four parameters (StVK c11 c12 c22 g, or neo-Hookean mu lambda 0 0), from the
 * public membrane model and its moduli: isotropic from E (Pa), nu and t (m) by plane stress,
 * orthotropic from the warp and weft moduli y1, y2, shear g (N/m) and nu12. Returns the group
 * (DEFSIM__MEMBRANE_*) or -1 for DEFSIM_SHELL_MEMBRANE_NONE. */
int defsim__membrane_params(int32_t model, double E, double nu, double t, double y1, double y2,
                            double g, double nu12, double prm[4]);

/* A law at F (3x2 row-major, F[2 i + j]): energy density (J/m^2), P = dpsi/dF (3x2, may be
 * NULL) and dP/dF (6x6, D[6 (2 i + j) + 2 k + l], may be NULL). Neo-Hookean: +INFINITY (P and
 * D untouched) where det C <= 0 (a collapsed triangle). */
double defsim__membrane_law(int law, const double prm[4], const double F[6], double P[6],
                            double D[36]);

/* A membrane element (its `shell` row: dminv and prm, rest area `area`) at its vertices X (3x3:
 * x0 x1 x2): energy (J), gradient dE/dX (9, may be NULL), Hessian (9x9 row-major, may be NULL)
 * with dP/dF projected by proj (defsim_projection: NONE, CLAMP, ABS) before it is mapped. */
double defsim__membrane_element(int law, const double row[DEFSIM__MEMBRANE_WIDTH], double area,
                                const double X[9], double grad[9], double H[81], int proj);

/* The strain limit (docs/shells.md): a cap c = 1 + cap on the largest principal stretch
 * sigma_1 of a triangle's F, enforced by a barrier on each singular value sigma_i,
 * psi = kappa sum_i b(c - sigma_i), b(d) = -(d - delta)^2 log(d / delta) on 0 < d < delta and 0
 * for d >= delta (C2 there: the energy is untouched outside the band), +inf at sigma_1 >= c.
 * Summed over both singular values it is a symmetric function of them, smooth where they meet.
 * The band delta is DEFSIM__STRAIN_LIMIT_BAND cap; kappa (N/m) the membrane's tensile modulus
 * (max(c11, c22) of StVK, lambda + 2 mu of neo-Hookean). The line-search filter returns
 * DEFSIM__STRAIN_LIMIT_STEP of the step to the cap. Its rows (DEFSIM__MEMBRANE_WIDTH doubles):
 * Dm^-1, then c, delta, kappa, 0. */
#define DEFSIM__STRAIN_LIMIT_BAND 0.1
#define DEFSIM__STRAIN_LIMIT_STEP 0.8

/* A triangle's strain-limit row from its membrane row (law DEFSIM__MEMBRANE_*) and the cap. */
void defsim__strain_limit_row(int law, const double mrow[DEFSIM__MEMBRANE_WIDTH], double cap,
                              double out[DEFSIM__MEMBRANE_WIDTH]);

/* The largest singular value of a 3x2 F (the largest principal stretch). */
double defsim__membrane_stretch(const double F[6]);

/* The barrier's density at F (prm: c, delta, kappa): +INFINITY where sigma_1 >= c (P, D
 * untouched); 0 with *active = 0 outside the band (P, D untouched); else *active = 1, P (may be
 * NULL) and dP/dF (6x6 as the laws', may be NULL). */
double defsim__strain_limit_law(const double prm[3], const double F[6], double P[6],
                                double D[36], int *active);

/* A triangle's barrier (its row, rest area) at X as defsim__membrane_element (grad, H written
 * only when *active). */
double defsim__strain_limit_element(const double row[DEFSIM__MEMBRANE_WIDTH], double area,
                                    const double X[9], double grad[9], double H[81], int proj,
                                    int *active);

/* The line-search filter: the largest a in [0, 1] such that the triangle at X + a' dX stays
 * below the cap for all a' <= a, 1 when X + dX is below it, else DEFSIM__STRAIN_LIMIT_STEP of
 * the crossing (0 when X is not below it). */
double defsim__strain_limit_step(const double row[DEFSIM__MEMBRANE_WIDTH], const double X[9],
                                 const double dX[9]);

/* The hinge's signed dihedral angle at X (x0 x1: the edge; x2, x3: the opposite vertices of its
 * two triangles): 0 flat, +-pi folded; its gradient (12) and Hessian (12x12) where not NULL. */
double defsim__hinge_angle(const double X[12], double g[12], double H[144]);

/* theta - theta0 wrapped into (-pi, pi]. */
double defsim__hinge_delta(double theta, double theta0);

/* A hinge of weight w (N m) and rest angle theta0: E = w/2 delta^2 (J), its gradient and
 * Hessian w (g g^T + delta H_theta), the latter projected by proj (a 12x12 eigen-clamp) where
 * not NULL. */
double defsim__hinge_element(double w, double theta0, const double X[12], double grad[12],
                             double H[144], int proj);

/* A hinge's weight w = D |e|^2 / (A1 + A2) (so that a shell bent to curvature kappa on a
 * regular mesh stores D/2 kappa^2 per area) and rest angle, from its rest vertices; D from the
 * warp and weft rigidities by the angle between the hinge's bending direction (in its rest
 * plane, across the edge) and the warp: D = d_warp cos^2 + d_weft sin^2. Returns 0, 1 for a
 * degenerate hinge, 2 for a warp normal to it when d_warp != d_weft. */
int defsim__hinge_rest(const double X[12], const double warp[3], double d_warp, double d_weft,
                       double *w, double *theta0);

#endif /* DEFSIM_SHELL_H */
