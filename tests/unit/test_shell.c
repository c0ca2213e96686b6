/* SPDX-License-Identifier: MIT */
/*
 * Cloth and shells (src/shell.c, term_membrane.c, term_hinge.c; docs/shells.md):
 *   - every new energy against finite differences: the membrane laws' P and dP/dF, the
 *     membrane elements' gradients and Hessians, the hinge angle's gradient and Hessian at
 *     near-flat, moderate and near-folded hinges, the hinge element's;
 *   - homogeneous uniaxial and biaxial stretch of a sheet through the world's forces against
 *     the analytic nominal stresses of each membrane (StVK, neo-Hookean, orthotropic along the
 *     warp, the weft and the bias);
 *   - a pre-bent strip at rest has no force, the same strip flattened has;
 *   - validation of the shell fields.
 * The cantilever (elastica, refinement, ASTM D1388) is tests/unit/test_shell_cantilever.c.
 */
#include "built_backends.h"
#include "mat3.h"
#include "shell.h"
#include "test_util.h"

#include <math.h>
#include <string.h>

#define M_PI 3.14159265358979323846

static double frand(unsigned long long *st) { return tu_rand(st); }

/* Relative error of a against b, scaled by the larger of |b|'s norm and floor. */
static double rel(const double *a, const double *b, int n, double floor)
{
    double d = 0.0, m = floor;
    for (int i = 0; i < n; ++i) {
        if (fabs(a[i] - b[i]) > d) d = fabs(a[i] - b[i]);
        if (fabs(b[i]) > m) m = fabs(b[i]);
    }
    return d / m;
}

/* ------------------------------------------------------------------------------------------ */
/* Finite differences */

static void law_fd(int law, const double prm[4], const double F0[6])
{
    double P[6], D[36], Pfd[6], Dfd[36];
    defsim__membrane_law(law, prm, F0, P, D);
    const double h = 1e-6;
    for (int k = 0; k < 6; ++k) {
        double Fp[6], Fm[6], Pp[6], Pm[6];
        memcpy(Fp, F0, sizeof Fp); memcpy(Fm, F0, sizeof Fm);
        Fp[k] += h; Fm[k] -= h;
        const double ep = defsim__membrane_law(law, prm, Fp, Pp, NULL);
        const double em = defsim__membrane_law(law, prm, Fm, Pm, NULL);
        Pfd[k] = (ep - em) / (2 * h);
        for (int i = 0; i < 6; ++i) Dfd[6 * i + k] = (Pp[i] - Pm[i]) / (2 * h);
    }
    assert_true(rel(P, Pfd, 6, 1e-3) < 1e-6);
    assert_true(rel(D, Dfd, 36, 1e-3) < 1e-6);
    for (int i = 0; i < 6; ++i)
        for (int j = 0; j < 6; ++j) assert_true(fabs(D[6 * i + j] - D[6 * j + i]) < 1e-9 * (1 + fabs(D[6 * i + j])));
}

static void test_membrane_law_fd(void **state)
{
    (void)state;
    unsigned long long st = 7;
    double iso[4], nh[4], ort[4];
    defsim__membrane_params(DEFSIM_SHELL_MEMBRANE_STVK, 2e6, 0.3, 1e-3, 0, 0, 0, 0, iso);
    defsim__membrane_params(DEFSIM_SHELL_MEMBRANE_NEOHOOKEAN, 2e6, 0.3, 1e-3, 0, 0, 0, 0, nh);
    defsim__membrane_params(DEFSIM_SHELL_MEMBRANE_ORTHOTROPIC_STVK, 0, 0, 0, 3e3, 1e3, 400, 0.2,
                            ort);
    for (int trial = 0; trial < 20; ++trial) {
        double F[6] = {1, 0, 0, 1, 0, 0};
        for (int i = 0; i < 6; ++i) F[i] += 0.4 * frand(&st);
        law_fd(DEFSIM__MEMBRANE_STVK, iso, F);
        law_fd(DEFSIM__MEMBRANE_STVK, ort, F);
        law_fd(DEFSIM__MEMBRANE_NEOHOOKEAN, nh, F);
    }
}

/* A membrane element's gradient and Hessian (exact, unprojected) against differences of its
 * energy and gradient; the clamped Hessian is PSD and equals the exact one where that is. */
static void element_fd(int law, const double prm[4], unsigned long long *st)
{
    double Xr[9] = {0, 0, 0, 0.1, 0.01, 0.0, 0.02, 0.09, 0.01}, row[DEFSIM__MEMBRANE_WIDTH], area;
    const double warp[3] = {1, 0.2, 0};
    assert_int_equal(defsim__shell_frame(Xr, Xr + 3, Xr + 6, warp, 1, row, &area, NULL), 0);
    memcpy(row + 4, prm, 4 * sizeof *prm);
    /* At rest: no energy, no force. */
    double g0[9];
    assert_true(fabs(defsim__membrane_element(law, row, area, Xr, g0, NULL, 0)) < 1e-20);
    for (int i = 0; i < 9; ++i) assert_true(fabs(g0[i]) < 1e-9);
    double X[9];
    for (int i = 0; i < 9; ++i) X[i] = Xr[i] + 0.03 * frand(st);
    double g[9], H[81], gfd[9], Hfd[81];
    defsim__membrane_element(law, row, area, X, g, H, DEFSIM_PROJECTION_NONE);
    const double h = 1e-7;
    for (int k = 0; k < 9; ++k) {
        double Xp[9], Xm[9], gp[9], gm[9];
        memcpy(Xp, X, sizeof Xp); memcpy(Xm, X, sizeof Xm);
        Xp[k] += h; Xm[k] -= h;
        const double ep = defsim__membrane_element(law, row, area, Xp, gp, NULL, 0);
        const double em = defsim__membrane_element(law, row, area, Xm, gm, NULL, 0);
        gfd[k] = (ep - em) / (2 * h);
        for (int i = 0; i < 9; ++i) Hfd[9 * i + k] = (gp[i] - gm[i]) / (2 * h);
    }
    assert_true(rel(g, gfd, 9, 1e-6) < 1e-5);
    assert_true(rel(H, Hfd, 81, 1e-3) < 1e-5);
    double Hc[81], ev[9], V[81];
    defsim__membrane_element(law, row, area, X, NULL, Hc, DEFSIM_PROJECTION_CLAMP);
    double Hcopy[81];
    memcpy(Hcopy, Hc, sizeof Hcopy);
    defsim__sym_eig(9, Hcopy, ev, V);
    double hmax = 0.0;
    for (int i = 0; i < 81; ++i) if (fabs(H[i]) > hmax) hmax = fabs(H[i]);
    for (int i = 0; i < 9; ++i) assert_true(ev[i] > -1e-9 * hmax);
}

static void test_membrane_element_fd(void **state)
{
    (void)state;
    unsigned long long st = 11;
    double iso[4], nh[4], ort[4];
    defsim__membrane_params(DEFSIM_SHELL_MEMBRANE_STVK, 2e6, 0.3, 1e-3, 0, 0, 0, 0, iso);
    defsim__membrane_params(DEFSIM_SHELL_MEMBRANE_NEOHOOKEAN, 2e6, 0.3, 1e-3, 0, 0, 0, 0, nh);
    defsim__membrane_params(DEFSIM_SHELL_MEMBRANE_ORTHOTROPIC_STVK, 0, 0, 0, 3e3, 1e3, 400, 0.2,
                            ort);
    for (int trial = 0; trial < 10; ++trial) {
        element_fd(DEFSIM__MEMBRANE_STVK, iso, &st);
        element_fd(DEFSIM__MEMBRANE_STVK, ort, &st);
        element_fd(DEFSIM__MEMBRANE_NEOHOOKEAN, nh, &st);
    }
}

/* A hinge with its edge along x and the wings at +-angle: vertex 3's wing is turned by
 * `theta` about the edge from the flat configuration; small random perturbations. */
static void hinge_at(double theta, unsigned long long *st, double X[12])
{
    const double X0[12] = {0, 0, 0, 1, 0, 0, 0.4, 0.8, 0};
    memcpy(X, X0, 9 * sizeof *X);
    /* Vertex 3 opposite: flat at (0.6, -0.7, 0); folded by theta about the x axis. */
    X[9] = 0.6;
    X[10] = -0.7 * cos(theta);
    X[11] = -0.7 * sin(theta);
    for (int i = 0; i < 12; ++i) X[i] += 1e-3 * frand(st);
}

static void hinge_fd_at(double theta, unsigned long long *st)
{
    double X[12], g[12], H[144], gfd[12], Hfd[144];
    hinge_at(theta, st, X);
    const double th = defsim__hinge_angle(X, g, H);
    assert_true(fabs(fabs(th) - fabs(theta)) < 0.01 || fabs(fabs(th) - (2 * M_PI - fabs(theta))) < 0.01);
    const double h = 1e-6;
    for (int k = 0; k < 12; ++k) {
        double Xp[12], Xm[12], gp[12], gm[12];
        memcpy(Xp, X, sizeof Xp); memcpy(Xm, X, sizeof Xm);
        Xp[k] += h; Xm[k] -= h;
        const double tp = defsim__hinge_angle(Xp, gp, NULL), tm = defsim__hinge_angle(Xm, gm, NULL);
        gfd[k] = defsim__hinge_delta(tp, tm) / (2 * h);
        for (int i = 0; i < 12; ++i) Hfd[12 * i + k] = (gp[i] - gm[i]) / (2 * h);
    }
    assert_true(rel(g, gfd, 12, 1e-3) < 1e-6);
    assert_true(rel(H, Hfd, 144, 1e-3) < 1e-5);
    /* Rigid motions: translations and rotations leave theta unchanged (g orthogonal to them). */
    double tx = 0, ty = 0, tz = 0;
    for (int a = 0; a < 4; ++a) tx += g[3 * a], ty += g[3 * a + 1], tz += g[3 * a + 2];
    assert_true(fabs(tx) + fabs(ty) + fabs(tz) < 1e-9);
    /* The hinge element: energy, gradient and Hessian against differences, rest angle apart. */
    const double w = 2.5, th0 = theta > 0 ? theta - 0.3 : theta + 0.3;
    double ge[12], He[144], gefd[12], Hefd[144];
    defsim__hinge_element(w, th0, X, ge, He, DEFSIM_PROJECTION_NONE);
    for (int k = 0; k < 12; ++k) {
        double Xp[12], Xm[12], gp[12], gm[12];
        memcpy(Xp, X, sizeof Xp); memcpy(Xm, X, sizeof Xm);
        Xp[k] += h; Xm[k] -= h;
        gefd[k] = (defsim__hinge_element(w, th0, Xp, gp, NULL, 0) -
                   defsim__hinge_element(w, th0, Xm, gm, NULL, 0)) / (2 * h);
        for (int i = 0; i < 12; ++i) Hefd[12 * i + k] = (gp[i] - gm[i]) / (2 * h);
    }
    assert_true(rel(ge, gefd, 12, 1e-3) < 1e-6);
    assert_true(rel(He, Hefd, 144, 1e-3) < 1e-5);
    /* Projected: PSD. */
    double Hp[144], ev[12], V[144];
    defsim__hinge_element(w, th0, X, NULL, Hp, DEFSIM_PROJECTION_CLAMP);
    defsim__sym_eig(12, Hp, ev, V);
    for (int i = 0; i < 12; ++i) assert_true(ev[i] > -1e-9 * w);
}

static void test_hinge_fd(void **state)
{
    (void)state;
    unsigned long long st = 5;
    const double angles[] = {1e-4, -1e-4, 0.05, 1.0, -1.0, 2.0, 3.1, -3.1, 3.14};
    for (size_t i = 0; i < sizeof angles / sizeof *angles; ++i)
        for (int r = 0; r < 5; ++r) hinge_fd_at(angles[i], &st);
    /* Exactly flat and exactly at rest: theta 0, no force. */
    const double X[12] = {0, 0, 0, 1, 0, 0, 0.4, 0.8, 0, 0.6, -0.7, 0};
    double g[12];
    assert_true(fabs(defsim__hinge_angle(X, NULL, NULL)) < 1e-15);
    defsim__hinge_element(1.0, 0.0, X, g, NULL, 0);
    for (int i = 0; i < 12; ++i) assert_true(fabs(g[i]) < 1e-15);
    /* The sign: vertex 3 lifted along +z gives theta = +0.5. */
    double Xs[12];
    memcpy(Xs, X, sizeof Xs);
    Xs[10] = -0.7 * cos(0.5); Xs[11] = -0.7 * sin(0.5);
    const double ts = defsim__hinge_angle(Xs, NULL, NULL);
    assert_true(fabs(fabs(ts) - 0.5) < 1e-12);
}

/* ------------------------------------------------------------------------------------------ */
/* Homogeneous stretch of a sheet through the world's forces */

enum { SX = 8, SY = 6 };
static const double SL = 0.4, SW = 0.3;

/* A sheet [0, SL] x [0, SW] in the xy plane with the given membrane. */
static defsim_world *sheet(int32_t membrane, const double warp[3], defsim_mesh *m)
{
    defsim_world *w = tu_world("symplectic_euler", 0.0, 1);
    const double o[3] = {0, 0, 0}, u[3] = {SL, 0, 0}, v[3] = {0, SW, 0};
    memset(m, 0, sizeof *m);
    m->size = sizeof *m;
    assert_int_equal(defsim_mesh_cloth(o, u, v, SX, SY, m), DEFSIM_OK);
    defsim_body_def d = test_shell_body(m);
    d.shell_membrane = membrane;
    d.shell_youngs_modulus = 2e6;
    d.shell_poisson_ratio = 0.3;
    d.shell_thickness = 1e-3;
    d.shell_warp_modulus = 3000;
    d.shell_weft_modulus = 1000;
    d.shell_shear_modulus = 400;
    d.shell_warp_poisson = 0.2;
    memcpy(d.shell_warp_direction, warp, sizeof d.shell_warp_direction);
    d.shell_bending_rigidity = 0.0;
    assert_int_equal(defsim_world_add_body(w, &d, NULL), DEFSIM_OK);
    return w;
}

/* Forces on the sheet stretched by x' = diag(l1, l2) x; sums over the right edge (x = SL) and
 * the top edge (y = SW) of the force components, and the largest interior force. */
static void stretch(defsim_world *w, const defsim_mesh *m, double l1, double l2, double right[3],
                    double top[3], double *interior)
{
    const int nv = m->vertex_count;
    double x[3 * (SX + 1) * (SY + 1)], f[3 * (SX + 1) * (SY + 1)];
    for (int i = 0; i < nv; ++i) {
        x[3 * i] = l1 * m->positions[3 * i];
        x[3 * i + 1] = l2 * m->positions[3 * i + 1];
        x[3 * i + 2] = 0.0;
    }
    assert_int_equal(defsim_world_forces(w, x, f), DEFSIM_OK);
    memset(right, 0, 3 * sizeof *right);
    memset(top, 0, 3 * sizeof *top);
    *interior = 0.0;
    for (int j = 0; j <= SY; ++j)
        for (int i = 0; i <= SX; ++i) {
            const int v = i + (SX + 1) * j;
            if (i == SX && j > 0 && j < SY)
                for (int c = 0; c < 3; ++c) right[c] += f[3 * v + c];
            if (j == SY && i > 0 && i < SX)
                for (int c = 0; c < 3; ++c) top[c] += f[3 * v + c];
            if (i > 0 && i < SX && j > 0 && j < SY)
                for (int c = 0; c < 3; ++c)
                    if (fabs(f[3 * v + c]) > *interior) *interior = fabs(f[3 * v + c]);
        }
    /* The right edge's corners: the top and bottom edges' tractions on them cancel. */
    const int c1 = SX, c2 = SX + (SX + 1) * SY;
    for (int c = 0; c < 3; ++c) right[c] += f[3 * c1 + c] + f[3 * c2 + c];
}

/* Analytic nominal stresses of the laws for F = diag(l1, l2): P11, P22 (N/m). */
static void nominal(int law, const double prm[4], double l1, double l2, double *P11, double *P22)
{
    if (law == DEFSIM__MEMBRANE_NEOHOOKEAN) {
        const double mu = prm[0], la = prm[1], lj = log(l1 * l2);
        *P11 = mu * l1 + (la * lj - mu) / l1;
        *P22 = mu * l2 + (la * lj - mu) / l2;
    } else {
        const double E1 = 0.5 * (l1 * l1 - 1), E2 = 0.5 * (l2 * l2 - 1);
        *P11 = l1 * (prm[0] * E1 + prm[1] * E2);
        *P22 = l2 * (prm[1] * E1 + prm[2] * E2);
    }
}

/* The lateral stretch of uniaxial tension (P22 = 0) for stretch l1, by Newton on P22. */
static double lateral(int law, const double prm[4], double l1)
{
    double l2 = 1.0;
    for (int it = 0; it < 50; ++it) {
        double a, b, c, d;
        nominal(law, prm, l1, l2, &a, &b);
        nominal(law, prm, l1, l2 + 1e-7, &c, &d);
        l2 -= b / ((d - b) / 1e-7);
    }
    return l2;
}

static void check_stretch(int32_t model, int law, const double prm[4])
{
    const double warp[3] = {1, 0, 0};
    defsim_mesh m;
    defsim_world *w = sheet(model, warp, &m);
    const double l1s[] = {1.05, 1.3, 0.9};
    for (int k = 0; k < 3; ++k) {
        const double l1 = l1s[k];
        /* Biaxial: both stretches prescribed. */
        const double l2b = 1.1;
        double right[3], top[3], in, P11, P22;
        stretch(w, &m, l1, l2b, right, top, &in);
        nominal(law, prm, l1, l2b, &P11, &P22);
        assert_true(fabs(right[0] + P11 * SW) < 1e-9 * fabs(P11 * SW) + 1e-12);
        assert_true(fabs(top[1] + P22 * SL * (SX - 1.0) / SX) < 1e-9 * fabs(P22 * SL) + 1e-12);
        assert_true(in < 1e-9 * fabs(P11 * SW));
        /* Uniaxial: the lateral stretch that frees the top edge. */
        const double l2u = lateral(law, prm, l1);
        stretch(w, &m, l1, l2u, right, top, &in);
        nominal(law, prm, l1, l2u, &P11, &P22);
        assert_true(fabs(P22) < 1e-9 * fabs(P11));
        assert_true(fabs(right[0] + P11 * SW) < 1e-9 * fabs(P11 * SW));
        assert_true(fabs(top[1]) < 1e-9 * fabs(P11 * SW));
        assert_true(in < 1e-9 * fabs(P11 * SW));
    }
    defsim_world_destroy(w);
    defsim_mesh_free(&m);
}

static void test_stretch_isotropic(void **state)
{
    (void)state;
    double iso[4], nh[4];
    defsim__membrane_params(DEFSIM_SHELL_MEMBRANE_STVK, 2e6, 0.3, 1e-3, 0, 0, 0, 0, iso);
    defsim__membrane_params(DEFSIM_SHELL_MEMBRANE_NEOHOOKEAN, 2e6, 0.3, 1e-3, 0, 0, 0, 0, nh);
    /* The 2D Lame parameters of plane stress: mu = E t / (2 (1 + nu)), lambda = E t nu / (1 - nu^2). */
    assert_true(fabs(iso[3] - 2e3 / 2.6) < 1e-9);
    assert_true(fabs(iso[1] - 2e3 * 0.3 / 0.91) < 1e-9);
    check_stretch(DEFSIM_SHELL_MEMBRANE_STVK, DEFSIM__MEMBRANE_STVK, iso);
    check_stretch(DEFSIM_SHELL_MEMBRANE_NEOHOOKEAN, DEFSIM__MEMBRANE_NEOHOOKEAN, nh);
    /* Small strain: the uniaxial tangent modulus P11 / (l1 - 1) -> E t of both laws. */
    const double l1 = 1.0 + 1e-6;
    double P11, P22;
    nominal(DEFSIM__MEMBRANE_STVK, iso, l1, lateral(DEFSIM__MEMBRANE_STVK, iso, l1), &P11, &P22);
    assert_true(fabs(P11 / 1e-6 - 2e3) < 1e-2);
    nominal(DEFSIM__MEMBRANE_NEOHOOKEAN, nh, l1, lateral(DEFSIM__MEMBRANE_NEOHOOKEAN, nh, l1), &P11,
            &P22);
    assert_true(fabs(P11 / 1e-6 - 2e3) < 1e-2);
}

/* Orthotropic: along the warp the warp modulus, along the weft the weft modulus (uniaxial,
 * small strain), and at 45 degrees (the bias) the rotated law, with its shear coupling. */
static void test_stretch_orthotropic(void **state)
{
    (void)state;
    double ort[4];
    defsim__membrane_params(DEFSIM_SHELL_MEMBRANE_ORTHOTROPIC_STVK, 0, 0, 0, 3e3, 1e3, 400, 0.2,
                            ort);
    check_stretch(DEFSIM_SHELL_MEMBRANE_ORTHOTROPIC_STVK, DEFSIM__MEMBRANE_STVK, ort);
    const double e = 1e-6;
    double P11, P22;
    nominal(DEFSIM__MEMBRANE_STVK, ort, 1 + e, lateral(DEFSIM__MEMBRANE_STVK, ort, 1 + e), &P11,
            &P22);
    assert_true(fabs(P11 / e - 3e3) < 1e-2);   /* warp modulus */
    /* Weft: warp along y, the sheet stretched along x. */
    const double wy[3] = {0, 1, 0};
    defsim_mesh m;
    defsim_world *w = sheet(DEFSIM_SHELL_MEMBRANE_ORTHOTROPIC_STVK, wy, &m);
    double right[3], top[3], in;
    /* Uniaxial along the weft: lateral (warp) stretch from the law with its axes swapped. */
    const double swapped[4] = {ort[2], ort[1], ort[0], ort[3]};
    for (int k = 0; k < 2; ++k) {
        const double l1 = k == 0 ? 1 + e : 1.2;
        const double l2 = lateral(DEFSIM__MEMBRANE_STVK, swapped, l1);
        stretch(w, &m, l1, l2, right, top, &in);
        nominal(DEFSIM__MEMBRANE_STVK, swapped, l1, l2, &P11, &P22);
        const double tol = k == 0 ? 1e-6 : 1e-9;   /* at strain 1e-6, E = (C - I)/2 rounds */
        assert_true(fabs(right[0] + P11 * SW) < tol * fabs(P11 * SW));
        assert_true(fabs(top[1]) < tol * fabs(P11 * SW));
        if (k == 0) assert_true(fabs(-right[0] / SW / e - 1e3) < 1e-2);   /* weft modulus */
    }
    defsim_world_destroy(w);
    defsim_mesh_free(&m);
    /* Bias: warp at 45 degrees, stretch l1 along x with l2 = 1: E = diag(E11, 0) in the sheet's
     * axes is E' = R^T E R in the warp frame, S = R S' R^T, P = F S; the right edge carries
     * P11 SW along x and P21 SW along y. */
    const double wb[3] = {1, 1, 0};
    w = sheet(DEFSIM_SHELL_MEMBRANE_ORTHOTROPIC_STVK, wb, &m);
    const double l1 = 1.15, E11 = 0.5 * (l1 * l1 - 1), c = sqrt(0.5);
    /* Warp frame axes t1 = (c, c), t2 = (-c, c): E'_ab = t_a . E t_b. */
    const double Ea = E11 * c * c, Eb = E11 * -c * c, Ed = E11 * c * c;   /* E'11, E'12, E'22 */
    const double S11 = ort[0] * Ea + ort[1] * Ed, S22 = ort[1] * Ea + ort[2] * Ed, S12 = 2 * ort[3] * Eb;
    /* Back to the sheet's axes: S = sum S'_ab t_a t_b^T. */
    const double t[2][2] = {{c, c}, {-c, c}};
    const double Sp[2][2] = {{S11, S12}, {S12, S22}};
    double S[2][2] = {{0, 0}, {0, 0}};
    for (int i = 0; i < 2; ++i)
        for (int j = 0; j < 2; ++j)
            for (int a = 0; a < 2; ++a)
                for (int b = 0; b < 2; ++b) S[i][j] += Sp[a][b] * t[a][i] * t[b][j];
    stretch(w, &m, l1, 1.0, right, top, &in);
    assert_true(fabs(right[0] + l1 * S[0][0] * SW) < 1e-9 * fabs(l1 * S[0][0] * SW));
    assert_true(fabs(right[1] + S[1][0] * SW) < 1e-9 * fabs(l1 * S[0][0] * SW));
    assert_true(fabs(S[1][0]) > 0.05 * fabs(S[0][0]));   /* the bias couples shear */
    defsim_world_destroy(w);
    defsim_mesh_free(&m);
}

/* ------------------------------------------------------------------------------------------ */
/* A pre-bent strip stays at rest; validation */

/* A strip bent into a quarter circle of radius R about the z axis (nx x 2 cells). */
static void arc_strip(double R, int nx, defsim_mesh *m)
{
    const double o[3] = {0, 0, 0}, u[3] = {1, 0, 0}, v[3] = {0, 0, 0.05};
    memset(m, 0, sizeof *m);
    m->size = sizeof *m;
    assert_int_equal(defsim_mesh_cloth(o, u, v, nx, 2, m), DEFSIM_OK);
    for (int i = 0; i < m->vertex_count; ++i) {
        const double s = m->positions[3 * i] * 0.5 * M_PI;
        m->positions[3 * i] = R * sin(s);
        m->positions[3 * i + 1] = R * (1 - cos(s));
    }
}

static defsim_body_def strip_def(const defsim_mesh *m, double D)
{
    defsim_body_def d = test_shell_body(m);
    d.shell_membrane = DEFSIM_SHELL_MEMBRANE_STVK;
    d.shell_youngs_modulus = 1e7;
    d.shell_thickness = 1e-3;
    d.shell_bending_rigidity = D;
    return d;
}

static void test_prebent_rest(void **state)
{
    (void)state;
    defsim_mesh m;
    arc_strip(0.2, 12, &m);
    defsim_world *w = tu_world("symplectic_euler", 0.0, 1);
    defsim_body_def d = strip_def(&m, 1e-3);
    assert_int_equal(defsim_world_add_body(w, &d, NULL), DEFSIM_OK);
    const int nv = m.vertex_count;
    double f[3 * 39], flat[3 * 39];
    assert_int_equal(defsim_world_forces(w, m.positions, f), DEFSIM_OK);
    double fmax = 0.0;
    for (int i = 0; i < 3 * nv; ++i) fmax = fmax > fabs(f[i]) ? fmax : fabs(f[i]);
    defsim_energy en;
    assert_int_equal(defsim_world_energy(w, &en), DEFSIM_OK);
    assert_true(fabs(en.elastic) < 1e-18);
    /* The same strip flattened (lengths kept): bending forces of the order D kappa / h. */
    for (int i = 0; i < nv; ++i) {
        const double s = atan2(m.positions[3 * i], 0.2 - m.positions[3 * i + 1]);
        flat[3 * i] = 0.2 * s;
        flat[3 * i + 1] = 0.0;
        flat[3 * i + 2] = m.positions[3 * i + 2];
    }
    double g[3 * 39], gmax = 0.0;
    assert_int_equal(defsim_world_forces(w, flat, g), DEFSIM_OK);
    for (int i = 0; i < 3 * nv; ++i) gmax = gmax > fabs(g[i]) ? gmax : fabs(g[i]);
    print_message("pre-bent strip: max |f| at rest %.3g N, flattened %.3g N\n", fmax, gmax);
    assert_true(fmax < 1e-12 * gmax);
    assert_true(gmax > 1e-3);
    defsim_world_destroy(w);
    defsim_mesh_free(&m);
}

static void test_validation(void **state)
{
    (void)state;
    defsim_mesh m;
    arc_strip(0.2, 4, &m);
    defsim_world *w = tu_world("symplectic_euler", 0.0, 1);
    defsim_body_def d = strip_def(&m, 1e-3);
    defsim_body_def bad = d;
    bad.shell_membrane = 9;
    assert_int_equal(defsim_world_add_body(w, &bad, NULL), DEFSIM_ERR_INVALID_MATERIAL);
    bad = d; bad.shell_youngs_modulus = -1;
    assert_int_equal(defsim_world_add_body(w, &bad, NULL), DEFSIM_ERR_INVALID_MATERIAL);
    bad = d; bad.shell_poisson_ratio = 0.5;
    assert_int_equal(defsim_world_add_body(w, &bad, NULL), DEFSIM_ERR_INVALID_MATERIAL);
    bad = d; bad.shell_thickness = 0;
    assert_int_equal(defsim_world_add_body(w, &bad, NULL), DEFSIM_ERR_INVALID_MATERIAL);
    bad = d; bad.shell_areal_density = NAN;
    assert_int_equal(defsim_world_add_body(w, &bad, NULL), DEFSIM_ERR_INVALID_MATERIAL);
    bad = d; bad.shell_bending_rigidity = INFINITY;
    assert_int_equal(defsim_world_add_body(w, &bad, NULL), DEFSIM_ERR_INVALID_MATERIAL);
    bad = d; bad.shell_membrane = DEFSIM_SHELL_MEMBRANE_ORTHOTROPIC_STVK; bad.shell_shear_modulus = 0;
    assert_int_equal(defsim_world_add_body(w, &bad, NULL), DEFSIM_ERR_INVALID_MATERIAL);
    bad = d; bad.shell_membrane = DEFSIM_SHELL_MEMBRANE_ORTHOTROPIC_STVK; bad.shell_warp_poisson = 2;
    assert_int_equal(defsim_world_add_body(w, &bad, NULL), DEFSIM_ERR_INVALID_MATERIAL);
    bad = d; bad.material.stiffness_damping = 0.1;
    assert_int_equal(defsim_world_add_body(w, &bad, NULL), DEFSIM_ERR_INVALID_MATERIAL);
    bad = d; bad.triangle_count = 0; bad.triangles = NULL;
    assert_int_equal(defsim_world_add_body(w, &bad, NULL), DEFSIM_ERR_INVALID_MESH);
    /* An edge of three triangles. */
    const double p[15] = {0, 0, 0, 1, 0, 0, 0, 1, 0, 0, -1, 0, 0, 0, 1};
    const int32_t tri[9] = {0, 1, 2, 0, 1, 3, 0, 1, 4};
    bad = d; bad.rest_positions = p; bad.vertex_count = 5; bad.triangles = tri; bad.triangle_count = 3;
    assert_int_equal(defsim_world_add_body(w, &bad, NULL), DEFSIM_ERR_INVALID_MESH);
    /* A zero-area triangle. */
    const double q[9] = {0, 0, 0, 1, 0, 0, 2, 0, 0};
    bad = d; bad.rest_positions = q; bad.vertex_count = 3; bad.triangles = tri; bad.triangle_count = 1;
    assert_int_equal(defsim_world_add_body(w, &bad, NULL), DEFSIM_ERR_INVALID_MESH);
    /* Lumped masses: one third of each triangle's rho_A A per vertex. */
    const double sq[12] = {0, 0, 0, 2, 0, 0, 2, 3, 0, 0, 3, 0};
    const int32_t st[6] = {0, 1, 2, 0, 2, 3};
    defsim_body_def ok = d;
    ok.rest_positions = sq; ok.vertex_count = 4; ok.triangles = st; ok.triangle_count = 2;
    ok.shell_areal_density = 0.3;
    /* A warp normal to the sheet: orthotropy has no frame. */
    bad = ok; bad.shell_membrane = DEFSIM_SHELL_MEMBRANE_ORTHOTROPIC_STVK;
    bad.shell_warp_direction[0] = 0; bad.shell_warp_direction[2] = 1;
    assert_int_equal(defsim_world_add_body(w, &bad, NULL), DEFSIM_ERR_INVALID_MESH);
    /* Warp/weft bending needs it too; equal rigidities do not. */
    bad = ok; bad.shell_warp_direction[0] = 0; bad.shell_warp_direction[2] = 1;
    bad.shell_bending_rigidity_weft = 2e-3;
    assert_int_equal(defsim_world_add_body(w, &bad, NULL), DEFSIM_ERR_INVALID_MESH);
    bad.shell_bending_rigidity_weft = -1;
    defsim_body_id id;
    assert_int_equal(defsim_world_add_body(w, &bad, &id), DEFSIM_OK);
    assert_int_equal(defsim_world_remove_body(w, id), DEFSIM_OK);
    assert_int_equal(defsim_world_add_body(w, &ok, &id), DEFSIM_OK);
    defsim_world_destroy(w);
    w = tu_world("symplectic_euler", -9.81, 1);
    assert_int_equal(defsim_world_add_body(w, &ok, &id), DEFSIM_OK);
    assert_int_equal(defsim_world_step(w, 1e-3), DEFSIM_OK);
    double v[12];
    assert_int_equal(defsim_world_get_velocities(w, v, 4), DEFSIM_OK);
    /* Gravity alone accelerates a free body uniformly whatever its masses; the masses show in
     * the kinetic energy: sum m v^2 / 2 with total mass rho_A * area = 0.3 * 6. */
    defsim_energy en;
    assert_int_equal(defsim_world_energy(w, &en), DEFSIM_OK);
    const double vy = v[1];
    assert_true(fabs(en.kinetic - 0.5 * 0.3 * 6.0 * vy * vy) < 1e-12 * en.kinetic);
    defsim_world_destroy(w);
    defsim_mesh_free(&m);
}

/* Every backend steps a shell: a 6 x 6 sheet of 0.3 m held at two corners falls under gravity
 * for 50 ms (explicit backends at 0.9 of the stable step, the others at 5 ms). Each run's
 * passes include the membrane and bending kernels; its far corner falls by more than half of
 * free fall (at 50 ms the sheet has not caught it); the total energy (kinetic, elastic,
 * gravitational) does not grow by more than 2 % of the gravitational energy released (the
 * implicit backends dissipate; the explicit ones keep it), and the implicit runs' fall agrees
 * with the fine explicit run's within 10 %. */
static double sheet_fall(const char *backend, int expl, double alpha)
{
    defsim_world *w = tu_implicit_world(backend, -9.81, 1, 1e-9, 50, DEFSIM_PROJECTION_CLAMP);
    defsim_mesh m;
    const double o[3] = {0, 0, 0}, u[3] = {0.3, 0, 0}, v[3] = {0, 0, 0.3};
    memset(&m, 0, sizeof m);
    m.size = sizeof m;
    assert_int_equal(defsim_mesh_cloth(o, u, v, 6, 6, &m), DEFSIM_OK);
    defsim_body_def d = test_shell_body(&m);
    d.shell_membrane = DEFSIM_SHELL_MEMBRANE_NEOHOOKEAN;
    d.shell_youngs_modulus = 2e5;
    d.shell_thickness = 1e-3;
    d.shell_areal_density = 0.1;
    d.shell_bending_rigidity = 1e-5;
    d.material.mass_damping = alpha;
    defsim_body_id id;
    assert_int_equal(defsim_world_add_body(w, &d, &id), DEFSIM_OK);
    const int32_t pins[2] = {0, 6};
    assert_int_equal(defsim_body_pin(w, id, pins, 2), DEFSIM_OK);
    defsim_energy e0, e1;
    assert_int_equal(defsim_world_energy(w, &e0), DEFSIM_OK);
    double h = 5e-3;
    if (expl) {
        assert_int_equal(defsim_world_stable_step(w, &h, NULL), DEFSIM_OK);
        h *= 0.9;
    }
    const int n = (int)ceil(0.05 / h);
    h = 0.05 / n;
    for (int i = 0; i < n; ++i) assert_int_equal(defsim_world_step(w, h), DEFSIM_OK);
    defsim_stats st;
    st.size = sizeof st;
    assert_int_equal(defsim_world_stats(w, &st), DEFSIM_OK);
    /* (A backend that reports no passes, explicit_euler today, reports not even gravity's.) */
    if (st.passes & DEFSIM_PASS_GRAVITY) {
        assert_true(st.passes & DEFSIM_PASS_MEMBRANE);
        assert_true(st.passes & DEFSIM_PASS_BENDING);
    }
    double x[3 * 49];
    assert_int_equal(defsim_world_get_positions(w, x, 49), DEFSIM_OK);
    for (int i = 0; i < 3 * 49; ++i) assert_true(isfinite(x[i]));
    const double fall = -x[3 * 48 + 1], free_fall = 0.5 * 9.81 * 0.05 * 0.05;
    print_message("%-18s h %.3g ms, %d steps: far corner fell %.5f m (free fall %.5f)\n", backend,
                  1e3 * h, n, fall, free_fall);
    assert_int_equal(defsim_world_energy(w, &e1), DEFSIM_OK);
    const double released = e0.gravitational - e1.gravitational;
    print_message("%-18s energy: released %.4g J, total change %+.3g J\n", backend, released,
                  e1.total - e0.total);
    assert_true(fall > 0.5 * free_fall);
    assert_true(released > 0.0 && e1.total - e0.total < 0.02 * released);
    defsim_mesh_free(&m);
    defsim_world_destroy(w);
    return fall;
}

static void test_backends(void **state)
{
    (void)state;
    const char *explicit_ones[] = {"symplectic_euler", "explicit_euler", "velocity_verlet"};
    /* The implicit ones and the adaptive explicit one, at 5 ms. */
    const char *implicit_ones[] = {"newton_cholmod", "bdf2", "newmark", "sundials_ida",
                                   "sundials_kinsol", "sundials_erk"};
    const double ref = sheet_fall("symplectic_euler", 1, 0.0);
    /* explicit Euler's stable step needs damping (its rule c / omega^2, docs/stability.md). */
    for (size_t i = 1; i < sizeof explicit_ones / sizeof *explicit_ones; ++i)
        if (built_backend(explicit_ones[i]))
            sheet_fall(explicit_ones[i], 1, strcmp(explicit_ones[i], "explicit_euler") ? 0.0 : 10.0);
    for (size_t i = 0; i < sizeof implicit_ones / sizeof *implicit_ones; ++i)
        if (built_backend(implicit_ones[i])) {
            const double f = sheet_fall(implicit_ones[i], 0, 0.0);
            assert_true(fabs(f - ref) < 0.1 * ref);
        }
}

/* Two cloth sheets (6 x 6 cells of 0.3 m, pinned along one edge) on `backend`: an orthotropic
 * StVK membrane with its warp at an angle, warp and weft bending apart, mass damping and two
 * diagonal springs; an isotropic StVK one with the plate rigidity (D < 0: E t^3 / 12 (1 - nu^2)),
 * 0.1 m below it. */
static defsim_world *pinned_sheets(const char *backend, defsim_mesh *m)
{
    defsim_world *w = tu_implicit_world(backend, -9.81, 1, 1e-10, 50, DEFSIM_PROJECTION_CLAMP);
    const double o[3] = {0, 0, 0}, u[3] = {0.3, 0, 0}, v[3] = {0, 0, 0.3};
    memset(m, 0, sizeof *m);
    m->size = sizeof *m;
    assert_int_equal(defsim_mesh_cloth(o, u, v, 6, 6, m), DEFSIM_OK);
    const int32_t edge[7] = {0, 1, 2, 3, 4, 5, 6}, springs[4] = {0, 48, 6, 42};
    for (int b = 0; b < 2; ++b) {
        double rest[3 * 49];
        memcpy(rest, m->positions, sizeof rest);
        for (int i = 0; i < 49; ++i) rest[3 * i + 1] -= 0.1 * b;
        defsim_body_def d = test_shell_body(m);
        d.rest_positions = rest;
        d.shell_areal_density = 0.15;
        if (b == 0) {
            d.shell_membrane = DEFSIM_SHELL_MEMBRANE_ORTHOTROPIC_STVK;
            d.shell_warp_modulus = 3000;
            d.shell_weft_modulus = 1200;
            d.shell_shear_modulus = 300;
            d.shell_warp_poisson = 0.25;
            d.shell_warp_direction[1] = 0.2;   /* its projection on the sheet is along x */
            d.shell_warp_direction[2] = 0.5;
            d.shell_bending_rigidity = 2e-5;
            d.shell_bending_rigidity_weft = 5e-6;
            d.material.mass_damping = 0.3;
            d.material.stiffness = 50.0;
            d.springs = springs;
            d.spring_count = 2;
        } else {
            d.shell_membrane = DEFSIM_SHELL_MEMBRANE_STVK;
            d.shell_youngs_modulus = 3e5;
            d.shell_poisson_ratio = 0.35;
            d.shell_thickness = 8e-4;
        }
        defsim_body_id id;
        assert_int_equal(defsim_world_add_body(w, &d, &id), DEFSIM_OK);
        assert_int_equal(defsim_body_pin(w, id, edge, 7), DEFSIM_OK);
    }
    return w;
}

/* Checkpoints hold shells (format 9): the sheets above, saved after 30 steps and loaded, step 30
 * more with the bits of the uninterrupted run, on newton_cholmod (5 ms) and symplectic_euler
 * (0.9 of the stable step); the loaded world saves the same bytes as the one it came from, and
 * the sheets have moved (the far edge fell by > 1 mm). */
static void test_checkpoint(void **state)
{
    (void)state;
    const char *backends[] = {"newton_cholmod", "symplectic_euler"};
    for (int k = 0; k < 2; ++k) {
        if (!built_backend(backends[k])) continue;
        defsim_mesh m;
        defsim_world *a = pinned_sheets(backends[k], &m);
        double h = 5e-3;
        if (k == 1) {
            assert_int_equal(defsim_world_stable_step(a, &h, NULL), DEFSIM_OK);
            h *= 0.9;
        }
        for (int i = 0; i < 30; ++i) assert_int_equal(defsim_world_step(a, h), DEFSIM_OK);
        void *buf = NULL, *again = NULL;
        size_t n = 0, n2 = 0;
        assert_int_equal(defsim_world_save_buffer(a, &buf, &n), DEFSIM_OK);
        defsim_world *b = NULL;
        assert_int_equal(defsim_world_load_buffer(buf, n, NULL, NULL, &b), DEFSIM_OK);
        assert_int_equal(defsim_world_save_buffer(b, &again, &n2), DEFSIM_OK);
        assert_int_equal(n2, n);
        assert_memory_equal(again, buf, n);
        defsim_buffer_free(buf);
        defsim_buffer_free(again);
        for (int i = 0; i < 30; ++i) {
            assert_int_equal(defsim_world_step(a, h), DEFSIM_OK);
            assert_int_equal(defsim_world_step(b, h), DEFSIM_OK);
        }
        double xa[3 * 98], xb[3 * 98], va[3 * 98], vb[3 * 98];
        assert_int_equal(defsim_world_get_positions(a, xa, 98), DEFSIM_OK);
        assert_int_equal(defsim_world_get_positions(b, xb, 98), DEFSIM_OK);
        assert_int_equal(defsim_world_get_velocities(a, va, 98), DEFSIM_OK);
        assert_int_equal(defsim_world_get_velocities(b, vb, 98), DEFSIM_OK);
        assert_memory_equal(xa, xb, sizeof xa);
        assert_memory_equal(va, vb, sizeof va);
        const double fall0 = -xa[3 * 48 + 1], fall1 = -(xa[3 * 97 + 1] + 0.1);
        print_message("%-16s h %.3g ms: far corners fell %.4f m and %.4f m in 60 steps; "
                      "continued bit for bit after the load\n", backends[k], 1e3 * h, fall0,
                      fall1);
        assert_true(fall0 > 1e-3 && fall1 > 1e-3);
        defsim_world_destroy(a);
        defsim_world_destroy(b);
        defsim_mesh_free(&m);
    }
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_membrane_law_fd),
        cmocka_unit_test(test_membrane_element_fd),
        cmocka_unit_test(test_hinge_fd),
        cmocka_unit_test(test_stretch_isotropic),
        cmocka_unit_test(test_stretch_orthotropic),
        cmocka_unit_test(test_prebent_rest),
        cmocka_unit_test(test_validation),
        cmocka_unit_test(test_backends),
        cmocka_unit_test(test_checkpoint),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
