/* SPDX-License-Identifier: MIT */
/*
 * The shells' strain limit (src/shell.c's barrier, src/term_strain_limit.c; docs/shells.md):
 *   - the barrier's P and dP/dF against finite differences near the cap, inside the band, with
 *     near-equal and equal singular values; the element's gradient and Hessian; zero outside the
 *     band, and C1 at its edge;
 *   - the line-search filter against a dense sampling of the path;
 *   - a sheet pinned along one edge under an edge load that stretches it 30 % without the limit:
 *     with a 10 % cap no triangle's largest principal stretch, computed here from the positions,
 *     exceeds 1.1 after any step, the limit is reached (> 1.09), and the static force balance
 *     holds (free vertices: elastic + load = 0; pins: the reactions sum to minus the load);
 *   - a run that stays out of the band has the bits of the same run without the limit;
 *   - bad input; checkpoints (the limit since format 10) continue bit for bit.
 */
#include "built_backends.h"
#include "mat3.h"
#include "mesh_body.h"
#include "shell.h"
#include "test_util.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* ------------------------------------------------------------------------------------------ */
/* The law and the element against finite differences */

/* A 3x2 F = U diag(s1, s2) V^T with random orthonormal U (3x2) and rotation V. */
static void f_with(double s1, double s2, unsigned long long *st, double F[6])
{
    double a[3], b[3];
    for (int i = 0; i < 3; ++i) a[i] = tu_rand(st) - 0.5, b[i] = tu_rand(st) - 0.5;
    double na = sqrt(a[0] * a[0] + a[1] * a[1] + a[2] * a[2]);
    for (int i = 0; i < 3; ++i) a[i] /= na;
    const double ab = a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
    for (int i = 0; i < 3; ++i) b[i] -= ab * a[i];
    const double nb = sqrt(b[0] * b[0] + b[1] * b[1] + b[2] * b[2]);
    for (int i = 0; i < 3; ++i) b[i] /= nb;
    const double phi = 6.283185307179586 * tu_rand(st), c = cos(phi), s = sin(phi);
    const double V[4] = {c, -s, s, c};
    for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 2; ++j) F[2 * i + j] = s1 * a[i] * V[2 * j] + s2 * b[i] * V[2 * j + 1];
}

static double maxabs(const double *a, int n)
{
    double m = 0.0;
    for (int i = 0; i < n; ++i) m = fmax(m, fabs(a[i]));
    return m;
}

/* Central differences of psi -> P and P -> dP/dF at F0 with step h; returns the larger of the
 * two relative errors (to the largest entry). */
static double law_fd(const double prm[3], const double F0[6], double h)
{
    double P[6], D[36], Pfd[6], Dfd[36];
    int act;
    defsim__strain_limit_law(prm, F0, P, D, &act);
    assert_int_equal(act, 1);
    for (int k = 0; k < 6; ++k) {
        double Fp[6], Fm[6], Pp[6], Pm[6];
        memcpy(Fp, F0, sizeof Fp);
        memcpy(Fm, F0, sizeof Fm);
        Fp[k] += h;
        Fm[k] -= h;
        int ap, am;
        const double ep = defsim__strain_limit_law(prm, Fp, Pp, NULL, &ap);
        const double em = defsim__strain_limit_law(prm, Fm, Pm, NULL, &am);
        assert_true(isfinite(ep) && isfinite(em));
        Pfd[k] = (ep - em) / (2 * h);
        for (int i = 0; i < 6; ++i) Dfd[6 * i + k] = (Pp[i] - Pm[i]) / (2 * h);
    }
    double dp = 0.0, dd = 0.0;
    for (int i = 0; i < 6; ++i) dp = fmax(dp, fabs(P[i] - Pfd[i]));
    for (int i = 0; i < 36; ++i) dd = fmax(dd, fabs(D[i] - Dfd[i]));
    for (int i = 0; i < 6; ++i)
        for (int j = 0; j < 6; ++j)
            assert_true(fabs(D[6 * i + j] - D[6 * j + i]) <= 1e-10 * maxabs(D, 36));
    return fmax(dp / maxabs(P, 6), dd / maxabs(D, 36));
}

/* The cap 1.1 with the band 0.01 (a cap of 10 %), kappa 1000 N/m: at distances d = c - s1 from
 * the cap of 0.9, 0.5, 0.1, 1e-2, 1e-3 of the band, with s2 far below (1.0), in the band too,
 * 1e-4 and 1e-7 below s1, and equal to it. */
static void test_barrier_fd(void **state)
{
    (void)state;
    const double c = 1.1, delta = 0.01, prm[3] = {c, delta, 1000.0};
    const double ds[] = {0.9, 0.5, 0.1, 1e-2, 1e-3};
    const double gaps[] = {-1.0, 0.3, 1e-4 / 0.01, 1e-7 / 0.01, 0.0};
    unsigned long long st = 77;
    double worst = 0.0;
    for (size_t a = 0; a < sizeof ds / sizeof *ds; ++a)
        for (size_t b = 0; b < sizeof gaps / sizeof *gaps; ++b)
            for (int rep = 0; rep < 4; ++rep) {
                const double d = ds[a] * delta, s1 = c - d;
                /* s2: 1.0 (outside the band), or s1 - gap * delta */
                const double s2 = gaps[b] < 0.0 ? 1.0 : s1 - gaps[b] * delta;
                double F[6];
                f_with(s1, s2, &st, F);
                const double e = law_fd(prm, F, 1e-4 * fmin(d, delta));
                worst = fmax(worst, e);
                if (!(e < 2e-6))
                    print_message("d/delta %g, s1 - s2 %g: FD error %.3g\n", ds[a],
                                  s1 - s2, e);
                assert_true(e < 2e-6);
            }
    print_message("barrier P and dP/dF against central differences: worst relative error "
                  "%.3g over %d points (d/delta 0.9 .. 1e-3, s1 - s2 from 0.1 to 0)\n", worst,
                  4 * 5 * 5);
}

/* Outside the band the law is zero and says so; at the band's edge P and dP/dF go to zero (the
 * barrier is C2 there); at and over the cap +inf. */
static void test_barrier_band(void **state)
{
    (void)state;
    const double prm[3] = {1.1, 0.01, 1000.0};
    unsigned long long st = 5;
    double F[6], P[6], D[36];
    int act = -1;
    f_with(1.1 - 0.0100001, 1.0, &st, F);
    assert_true(defsim__strain_limit_law(prm, F, P, D, &act) == 0.0);
    assert_int_equal(act, 0);
    f_with(1.1 - 0.01 * (1 - 1e-6), 1.0, &st, F);
    const double e = defsim__strain_limit_law(prm, F, P, D, &act);
    assert_int_equal(act, 1);
    /* b ~ (d - delta)^2 (d - delta)/delta: 1e-18 kappa delta^2 / ... */
    print_message("at 1e-6 of the band inside its edge: psi %.3g J/m^2, |P| %.3g N/m, "
                  "|dP/dF| %.3g N/m (kappa 1000)\n", e, maxabs(P, 6), maxabs(D, 36));
    assert_true(e >= 0.0 && e < 1e-12 && maxabs(P, 6) < 1e-6 && maxabs(D, 36) < 1e-2);
    f_with(1.1, 1.0, &st, F);
    assert_true(isinf(defsim__strain_limit_law(prm, F, P, D, &act)));
    f_with(1.2, 1.15, &st, F);
    assert_true(isinf(defsim__strain_limit_law(prm, F, P, D, &act)));
}

/* A triangle's element (its rest in a random frame): gradient and Hessian against central
 * differences of the energy and the gradient, unprojected; the clamped Hessian is PSD. */
static void test_element_fd(void **state)
{
    (void)state;
    unsigned long long st = 11;
    const double rest[9] = {0, 0, 0, 0.1, 0.01, 0, 0.03, 0.08, 0};
    double mrow[DEFSIM__MEMBRANE_WIDTH], row[DEFSIM__MEMBRANE_WIDTH], area;
    const double warp[3] = {1, 0, 0};
    assert_int_equal(defsim__shell_frame(rest, rest + 3, rest + 6, warp, 0, mrow, &area, NULL), 0);
    const double mprm[4] = {1200, 400, 1200, 400};
    memcpy(mrow + 4, mprm, sizeof mprm);
    defsim__strain_limit_row(DEFSIM__MEMBRANE_STVK, mrow, 0.05, row);
    assert_true(row[4] == 1.05 && fabs(row[5] - 0.005) < 1e-18 && row[6] == 1200);
    double worst_g = 0.0, worst_h = 0.0;
    for (int rep = 0; rep < 12; ++rep) {
        /* X = R F X_rest-ish: stretch the rest triangle to s1 in the band, s2 by rep */
        const double s1 = 1.05 - 0.005 * (rep % 2 ? 0.3 : 0.02);
        const double s2 = rep % 3 == 0 ? s1 : (rep % 3 == 1 ? s1 - 1e-9 : 1.0);
        double F[6], X[9];
        f_with(s1, s2, &st, F);
        /* X_a = F p_a in the rest frame (the frame's p of the rest vertices from Dm) */
        const double m00 = mrow[3], m01 = -mrow[1], m10 = -mrow[2], m11 = mrow[0];
        const double det = 1.0 / (mrow[0] * mrow[3] - mrow[1] * mrow[2]);
        const double p[3][2] = {{0, 0}, {m00 * det, m10 * det}, {m01 * det, m11 * det}};
        for (int a = 0; a < 3; ++a)
            for (int i = 0; i < 3; ++i)
                X[3 * a + i] = 0.2 * i + F[2 * i] * p[a][0] + F[2 * i + 1] * p[a][1];
        double g[9], H[81], gfd[9], Hfd[81];
        int act;
        defsim__strain_limit_element(row, area, X, g, H, DEFSIM_PROJECTION_NONE, &act);
        assert_int_equal(act, 1);
        const double h = 1e-4 * 0.005 * 0.02 * 0.1;
        for (int k = 0; k < 9; ++k) {
            double Xp[9], Xm[9], gp[9], gm[9];
            memcpy(Xp, X, sizeof Xp);
            memcpy(Xm, X, sizeof Xm);
            Xp[k] += h;
            Xm[k] -= h;
            int a1, a2;
            const double ep = defsim__strain_limit_element(row, area, Xp, gp, NULL, 0, &a1);
            const double em = defsim__strain_limit_element(row, area, Xm, gm, NULL, 0, &a2);
            gfd[k] = (ep - em) / (2 * h);
            for (int i = 0; i < 9; ++i) Hfd[9 * i + k] = (gp[i] - gm[i]) / (2 * h);
        }
        double dg = 0.0, dh = 0.0;
        for (int i = 0; i < 9; ++i) dg = fmax(dg, fabs(g[i] - gfd[i]));
        for (int i = 0; i < 81; ++i) dh = fmax(dh, fabs(H[i] - Hfd[i]));
        worst_g = fmax(worst_g, dg / maxabs(g, 9));
        worst_h = fmax(worst_h, dh / maxabs(H, 81));
        /* translations: the gradient sums to zero per axis */
        for (int i = 0; i < 3; ++i)
            assert_true(fabs(g[i] + g[3 + i] + g[6 + i]) <= 1e-9 * maxabs(g, 9));
        /* the clamped Hessian is PSD: its smallest eigenvalue by the mat3 helpers' projection
         * (clamping again changes nothing beyond rounding) */
        double Hc[81], Hc2[81];
        defsim__strain_limit_element(row, area, X, NULL, Hc, DEFSIM_PROJECTION_CLAMP, &act);
        memcpy(Hc2, Hc, sizeof Hc);
        defsim__project_psd(9, Hc2, DEFSIM_PROJECTION_CLAMP);
        for (int i = 0; i < 81; ++i) assert_true(fabs(Hc2[i] - Hc[i]) <= 1e-9 * maxabs(Hc, 81));
    }
    print_message("barrier element: gradient %.3g, Hessian %.3g relative to central differences "
                  "(12 triangles at 0.02 and 0.3 of the band from a 5 %% cap, s2 = s1, s1 - 1e-9, "
                  "1)\n", worst_g, worst_h);
    assert_true(worst_g < 1e-6 && worst_h < 1e-5);
}

/* The filter: for random triangles and directions, the step it allows keeps the triangle below
 * the cap along 2000 samples of the path, and 1 / 0.8 of it reaches the cap (the crossing)
 * within 1e-9 of the stretch; a step that stays below the cap is taken whole. */
static void test_filter(void **state)
{
    (void)state;
    unsigned long long st = 3;
    const double rest[9] = {0, 0, 0, 0.1, 0, 0, 0, 0.1, 0};
    const double warp[3] = {1, 0, 0};
    double mrow[DEFSIM__MEMBRANE_WIDTH], row[DEFSIM__MEMBRANE_WIDTH], area;
    assert_int_equal(defsim__shell_frame(rest, rest + 3, rest + 6, warp, 0, mrow, &area, NULL), 0);
    mrow[4] = mrow[5] = mrow[6] = mrow[7] = 100.0;
    defsim__strain_limit_row(DEFSIM__MEMBRANE_STVK, mrow, 0.1, row);
    int cut = 0, whole = 0;
    for (int rep = 0; rep < 200; ++rep) {
        double X[9], dX[9];
        for (int i = 0; i < 9; ++i) X[i] = rest[i] * (1.0 + 0.03 * (tu_rand(&st) - 0.5));
        for (int i = 0; i < 9; ++i) dX[i] = 0.05 * (tu_rand(&st) - 0.5);
        const double a = defsim__strain_limit_step(row, X, dX);
        assert_true(a > 0.0 && a <= 1.0);
        double smax = 0.0;
        for (int k = 0; k <= 2000; ++k) {
            double Y[9], F[6];
            for (int i = 0; i < 9; ++i) Y[i] = X[i] + a * k / 2000.0 * dX[i];
            /* F = [y1 - y0, y2 - y0] / 0.1 (the rest triangle's legs along x and y) */
            for (int i = 0; i < 3; ++i) {
                F[2 * i] = (Y[3 + i] - Y[i]) / 0.1;
                F[2 * i + 1] = (Y[6 + i] - Y[i]) / 0.1;
            }
            smax = fmax(smax, defsim__membrane_stretch(F));
        }
        assert_true(smax < 1.1);
        if (a < 1.0) {
            ++cut;
            double Y[9], F[6];
            for (int i = 0; i < 9; ++i) Y[i] = X[i] + a / DEFSIM__STRAIN_LIMIT_STEP * dX[i];
            for (int i = 0; i < 3; ++i) {
                F[2 * i] = (Y[3 + i] - Y[i]) / 0.1;
                F[2 * i + 1] = (Y[6 + i] - Y[i]) / 0.1;
            }
            assert_true(fabs(defsim__membrane_stretch(F) - 1.1) < 1e-9);
        } else {
            ++whole;
        }
    }
    print_message("filter: %d of 200 random steps cut (each kept below the cap along 2000 "
                  "samples, the crossing at 1/0.8 of the step within 1e-9), %d taken whole\n",
                  cut, whole);
    assert_true(cut > 20 && whole > 20);
}

/* ------------------------------------------------------------------------------------------ */
/* The pinned sheet */

enum { NX = 16, NY = 8 };
static const double SL = 0.4, SW = 0.2, ET = 1000.0;   /* m, m, N/m (E t) */

/* The largest principal stretch of any triangle, from the positions and the flat rest sheet
 * (the rest in the xy plane: Dm the rest legs' x and y), by the 2x2 C's eigenvalue. */
static double max_stretch(const defsim_mesh *m, const double *x, double *mean_x)
{
    double smax = 0.0;
    for (int32_t t = 0; t < m->triangle_count; ++t) {
        const int32_t *v = m->triangles + 3 * t;
        const double *r0 = m->positions + 3 * v[0], *r1 = m->positions + 3 * v[1],
                     *r2 = m->positions + 3 * v[2];
        const double a = r1[0] - r0[0], b = r2[0] - r0[0], c = r1[1] - r0[1], d = r2[1] - r0[1];
        const double det = a * d - b * c;
        const double Mi[4] = {d / det, -b / det, -c / det, a / det};
        double F[6];
        for (int i = 0; i < 3; ++i) {
            const double e1 = x[3 * v[1] + i] - x[3 * v[0] + i];
            const double e2 = x[3 * v[2] + i] - x[3 * v[0] + i];
            F[2 * i] = e1 * Mi[0] + e2 * Mi[2];
            F[2 * i + 1] = e1 * Mi[1] + e2 * Mi[3];
        }
        double C00 = 0, C01 = 0, C11 = 0;
        for (int i = 0; i < 3; ++i) {
            C00 += F[2 * i] * F[2 * i];
            C01 += F[2 * i] * F[2 * i + 1];
            C11 += F[2 * i + 1] * F[2 * i + 1];
        }
        const double lmax = 0.5 * (C00 + C11) + sqrt(0.25 * (C00 - C11) * (C00 - C11) + C01 * C01);
        smax = fmax(smax, sqrt(lmax));
    }
    if (mean_x) {
        /* the right edge's mean x over SL */
        double s = 0.0;
        for (int j = 0; j <= NY; ++j) s += x[3 * (j * (NX + 1) + NX)];
        *mean_x = s / (NY + 1) / SL;
    }
    return smax;
}

/* The sheet [0, SL] x [0, SW], StVK (E t = 1000 N/m, nu 0.3), pinned along x = 0, on
 * `backend`; cap 0: none. The load: total force fx on the right edge (tributary shares). */
static defsim_world *pinned_sheet_on(const char *backend, double cap, double fx, defsim_mesh *m,
                                     double *fext)
{
    defsim_world *w = tu_implicit_world(backend, 0.0, 1, 1e-10, 200, DEFSIM_PROJECTION_CLAMP);
    const double o[3] = {0, 0, 0}, u[3] = {SL, 0, 0}, v[3] = {0, SW, 0};
    memset(m, 0, sizeof *m);
    m->size = sizeof *m;
    assert_int_equal(defsim_mesh_cloth(o, u, v, NX, NY, m), DEFSIM_OK);
    defsim_body_def d = test_shell_body(m);
    d.shell_membrane = DEFSIM_SHELL_MEMBRANE_STVK;
    d.shell_youngs_modulus = 1e6;
    d.shell_poisson_ratio = 0.3;
    d.shell_thickness = 1e-3;
    d.shell_bending_rigidity = 0.0;
    d.shell_areal_density = 0.1;
    d.material.mass_damping = 1.0;
    d.shell_strain_limit = cap;
    defsim_body_id id;
    assert_int_equal(defsim_world_add_body(w, &d, &id), DEFSIM_OK);
    int32_t pins[NY + 1];
    for (int j = 0; j <= NY; ++j) pins[j] = j * (NX + 1);
    assert_int_equal(defsim_body_pin(w, id, pins, NY + 1), DEFSIM_OK);
    const int32_t nv = m->vertex_count;
    memset(fext, 0, 3 * (size_t)nv * sizeof *fext);
    for (int j = 0; j <= NY; ++j)
        fext[3 * (j * (NX + 1) + NX)] = fx / NY * (j == 0 || j == NY ? 0.5 : 1.0);
    assert_int_equal(defsim_world_set_external_forces(w, fext, nv), DEFSIM_OK);
    return w;
}

static defsim_world *pinned_sheet(double cap, double fx, defsim_mesh *m, double *fext)
{
    return pinned_sheet_on("newton_cholmod", cap, fx, m, fext);
}

/* The load that stretches a free strip 30 % uniaxially under StVK: P11 = l (l^2 - 1)/2 E t. */
static double load_30(void) { return SW * ET * 1.3 * (1.3 * 1.3 - 1.0) / 2.0; }

/* Steps of 0.5 s (quasi-static: M / h^2 is 1e-4 of the membrane's stiffness); after each, the
 * largest stretch from the positions. Returns the last; *worst the largest over the steps. */
static double run_sheet_on(const char *backend, defsim_world *w, const defsim_mesh *m,
                           int steps, double *worst, double *mean, double *iters)
{
    const int32_t nv = m->vertex_count;
    double x[3 * (NX + 1) * (NY + 1)];
    *worst = 0.0;
    double s = 0.0;
    for (int k = 0; k < steps; ++k) {
        assert_int_equal(defsim_world_step(w, 0.5), DEFSIM_OK);
        assert_int_equal(defsim_world_get_positions(w, x, nv), DEFSIM_OK);
        s = max_stretch(m, x, mean);
        *worst = fmax(*worst, s);
    }
    char stat[64];
    snprintf(stat, sizeof stat, "%s.newton_iterations", backend);
    *iters = tu_stat(w, stat);
    return s;
}

static double run_sheet(defsim_world *w, const defsim_mesh *m, int steps, double *worst,
                        double *mean, double *iters)
{
    return run_sheet_on("newton_cholmod", w, m, steps, worst, mean, iters);
}

/* Free vertices: |f_elastic + f_ext| against the load per edge vertex; pins: the reactions
 * (defsim_world_get_pin_forces) sum to minus the load. */
static void force_balance(defsim_world *w, const defsim_mesh *m, const double *fext,
                          double fx, double *res, double *reaction)
{
    const int32_t nv = m->vertex_count;
    double x[3 * (NX + 1) * (NY + 1)], f[3 * (NX + 1) * (NY + 1)], r[3 * (NX + 1) * (NY + 1)];
    assert_int_equal(defsim_world_get_positions(w, x, nv), DEFSIM_OK);
    assert_int_equal(defsim_world_forces(w, x, f), DEFSIM_OK);
    assert_int_equal(defsim_world_get_pin_forces(w, r, nv), DEFSIM_OK);
    double worst = 0.0, rx = 0.0, ry = 0.0;
    for (int32_t i = 0; i < nv; ++i) {
        if (i % (NX + 1) == 0) {
            rx += r[3 * i];
            ry += r[3 * i + 1];
            continue;
        }
        for (int k = 0; k < 3; ++k) worst = fmax(worst, fabs(f[3 * i + k] + fext[3 * i + k]));
    }
    *res = worst / (fx / NY);
    *reaction = fmax(fabs(rx + fx), fabs(ry)) / fx;
}

static void test_sheet_cap(void **state)
{
    (void)state;
    if (!built_backend("newton_cholmod")) return;
    const int32_t nv = (NX + 1) * (NY + 1);
    double fext[3 * (NX + 1) * (NY + 1)];
    const double fx = load_30();
    defsim_mesh m;
    double worst, mean, it, res, reac;

    /* without the limit */
    defsim_world *w = pinned_sheet(0.0, fx, &m, fext);
    double s = run_sheet(w, &m, 20, &worst, &mean, &it);
    force_balance(w, &m, fext, fx, &res, &reac);
    print_message("load %.2f N (30 %% uniaxial StVK stretch of the free strip), no limit: largest "
                  "principal stretch %.4f, right edge at %.4f SL, %.0f Newton iterations in 20 "
                  "steps; force residual %.2g, reactions %.2g of the load\n", fx, s, mean, it,
                  res, reac);
    assert_true(s > 1.3 && mean > 1.25);
    assert_true(res < 1e-6 && reac < 1e-6);
    defsim_world_destroy(w);
    defsim_mesh_free(&m);

    /* with a 10 % cap and 5 % */
    const double caps[2] = {0.1, 0.05};
    for (int c = 0; c < 2; ++c) {
        w = pinned_sheet(caps[c], fx, &m, fext);
        s = run_sheet(w, &m, 20, &worst, &mean, &it);
        force_balance(w, &m, fext, fx, &res, &reac);
        print_message("cap %.0f %%: largest principal stretch %.6f at the end, %.6f over all 20 "
                      "steps (from the positions), right edge at %.4f SL, %.0f Newton iterations; "
                      "force residual %.2g, reactions %.2g of the load\n", 100 * caps[c], s,
                      worst, mean, it, res, reac);
        assert_true(worst < 1.0 + caps[c]);
        assert_true(s > 1.0 + 0.9 * caps[c]);   /* in the band: the limit holds the load */
        assert_true(res < 1e-6 && reac < 1e-6);
        defsim_energy en;
        assert_int_equal(defsim_world_energy(w, &en), DEFSIM_OK);
        assert_true(isfinite(en.elastic) && en.elastic > 0.0);
        defsim_world_destroy(w);
        defsim_mesh_free(&m);
    }
    /* the other backends with a filtered line search: BDF2 and Newmark (trapezoidal: no
     * numerical damping, the suddenly applied load overshoots, the cap holds) */
    const char *others[2] = {"bdf2", "newmark"};
    for (int b = 0; b < 2; ++b) {
        if (!built_backend(others[b])) continue;
        w = pinned_sheet_on(others[b], 0.1, fx, &m, fext);
        s = run_sheet_on(others[b], w, &m, 20, &worst, &mean, &it);
        print_message("%s, cap 10 %%: largest principal stretch %.6f at the end, %.6f over the "
                      "20 steps, %.0f Newton iterations\n", others[b], s, worst, it);
        assert_true(worst < 1.1 && worst > 1.09);
        defsim_world_destroy(w);
        defsim_mesh_free(&m);
    }
    (void)nv;
}

/* Far from the cap the barrier does nothing: a tenth of the load (about 3 %) under a 50 % cap
 * runs with the bits of the run without a cap. */
static void test_inactive_bits(void **state)
{
    (void)state;
    if (!built_backend("newton_cholmod")) return;
    const int32_t nv = (NX + 1) * (NY + 1);
    double fext[3 * (NX + 1) * (NY + 1)], xa[3 * (NX + 1) * (NY + 1)], xb[3 * (NX + 1) * (NY + 1)];
    double va[3 * (NX + 1) * (NY + 1)], vb[3 * (NX + 1) * (NY + 1)];
    defsim_mesh m, m2;
    defsim_world *a = pinned_sheet(0.0, 0.1 * load_30(), &m, fext);
    defsim_world *b = pinned_sheet(0.5, 0.1 * load_30(), &m2, fext);
    for (int k = 0; k < 10; ++k) {
        assert_int_equal(defsim_world_step(a, 0.05), DEFSIM_OK);
        assert_int_equal(defsim_world_step(b, 0.05), DEFSIM_OK);
    }
    assert_int_equal(defsim_world_get_positions(a, xa, nv), DEFSIM_OK);
    assert_int_equal(defsim_world_get_positions(b, xb, nv), DEFSIM_OK);
    assert_int_equal(defsim_world_get_velocities(a, va, nv), DEFSIM_OK);
    assert_int_equal(defsim_world_get_velocities(b, vb, nv), DEFSIM_OK);
    const double s = max_stretch(&m, xa, NULL);
    print_message("a tenth of the load, 10 steps of 50 ms: largest stretch %.4f; with a 50 %% cap "
                  "the same bits (positions and velocities)\n", s);
    assert_true(s > 1.01 && s < 1.45);
    assert_memory_equal(xa, xb, sizeof xa);
    assert_memory_equal(va, vb, sizeof va);
    defsim_energy ea, eb;
    assert_int_equal(defsim_world_energy(a, &ea), DEFSIM_OK);
    assert_int_equal(defsim_world_energy(b, &eb), DEFSIM_OK);
    assert_true(ea.elastic == eb.elastic);
    defsim_world_destroy(a);
    defsim_world_destroy(b);
    defsim_mesh_free(&m);
    defsim_mesh_free(&m2);
}

/* Bad input: a negative, non-finite or too large cap, a cap on a tet body, on a body of
 * springs, on a shell without a membrane; an explicit backend; initial positions over the cap. */
static void test_validation(void **state)
{
    (void)state;
    defsim_mesh m;
    memset(&m, 0, sizeof m);
    m.size = sizeof m;
    const double o[3] = {0, 0, 0}, u[3] = {0.2, 0, 0}, v[3] = {0, 0.2, 0};
    assert_int_equal(defsim_mesh_cloth(o, u, v, 4, 4, &m), DEFSIM_OK);
    const char *be = built_backend("newton_cholmod") ? "newton_cholmod" : NULL;
    if (!be) return;
    defsim_world *w = tu_world(be, 0.0, 1);
    const double bad[] = {-0.01, 1.5, NAN, INFINITY};
    for (size_t i = 0; i < sizeof bad / sizeof *bad; ++i) {
        defsim_body_def d = test_shell_body(&m);
        d.shell_membrane = DEFSIM_SHELL_MEMBRANE_STVK;
        d.shell_strain_limit = bad[i];
        assert_int_equal(defsim_world_add_body(w, &d, NULL), DEFSIM_ERR_INVALID_MATERIAL);
    }
    {   /* no membrane: bending only */
        defsim_body_def d = test_shell_body(&m);
        d.shell_bending_rigidity = 1e-5;
        d.shell_strain_limit = 0.1;
        assert_int_equal(defsim_world_add_body(w, &d, NULL), DEFSIM_ERR_INVALID_MATERIAL);
    }
    {   /* a tet body */
        defsim_mesh box;
        memset(&box, 0, sizeof box);
        box.size = sizeof box;
        const double lo[3] = {0, 0, 0}, hi[3] = {0.1, 0.1, 0.1};
        assert_int_equal(defsim_mesh_box(lo, hi, 1, 1, 1, &box), DEFSIM_OK);
        defsim_body_def d = test_mesh_body(&box, DEFSIM_MODEL_STVK);
        d.shell_strain_limit = 0.1;
        assert_int_equal(defsim_world_add_body(w, &d, NULL), DEFSIM_ERR_INVALID_MATERIAL);
        d.shell_strain_limit = 0.0;
        assert_int_equal(defsim_world_add_body(w, &d, NULL), DEFSIM_OK);
        defsim_mesh_free(&box);
    }
    {   /* springs (the cloth's) */
        defsim_body_def d;
        defsim_body_def_init(&d, sizeof d);
        d.rest_positions = m.positions;
        d.vertex_count = m.vertex_count;
        d.springs = m.springs;
        d.spring_count = m.spring_count;
        d.material = (defsim_material){0};
        defsim_material_init(&d.material, sizeof d.material, DEFSIM_MODEL_SPRING);
        d.material.vertex_mass = 1e-3;
        d.shell_strain_limit = 0.1;
        assert_int_equal(defsim_world_add_body(w, &d, NULL), DEFSIM_ERR_INVALID_MATERIAL);
    }
    {   /* initial positions stretched 20 % along x under a 10 % cap; 5 % passes */
        double x0[3 * 25];
        defsim_body_def d = test_shell_body(&m);
        d.shell_membrane = DEFSIM_SHELL_MEMBRANE_STVK;
        d.shell_strain_limit = 0.1;
        d.initial_positions = x0;
        memcpy(x0, m.positions, sizeof x0);
        for (int i = 0; i < 25; ++i) x0[3 * i] *= 1.2;
        assert_int_equal(defsim_world_add_body(w, &d, NULL), DEFSIM_ERR_INVALID_ARGUMENT);
        for (int i = 0; i < 25; ++i) x0[3 * i] = m.positions[3 * i] * 1.05;
        assert_int_equal(defsim_world_add_body(w, &d, NULL), DEFSIM_OK);
    }
    {   /* a state set over the cap: the step fails (its energy is +inf at the start) and the
         * state stays */
        const int32_t nv = defsim_world_vertex_count(w);
        double *x = tu_positions(w), *x2 = malloc(3 * (size_t)nv * sizeof *x2);
        for (int32_t i = nv - 25; i < nv; ++i) x[3 * i] *= 1.2 / 1.05;
        assert_int_equal(defsim_world_set_state(w, x, NULL), DEFSIM_OK);
        assert_int_equal(defsim_world_step(w, 0.01), DEFSIM_ERR_NOT_CONVERGED);
        assert_int_equal(defsim_world_get_positions(w, x2, nv), DEFSIM_OK);
        assert_memory_equal(x, x2, 3 * (size_t)nv * sizeof *x2);
        free(x);
        free(x2);
    }
    defsim_world_destroy(w);
    /* backends without a filtered line search refuse it (explicit ones, and sundials_ida, which
     * is implicit but has no CCD hook); the same body without a cap is taken */
    const char *expl[] = {"symplectic_euler", "explicit_euler", "velocity_verlet", "sundials_ida"};
    for (int k = 0; k < 4; ++k) {
        if (!built_backend(expl[k])) continue;
        defsim_world *e = tu_world(expl[k], 0.0, 1);
        defsim_body_def d = test_shell_body(&m);
        d.shell_membrane = DEFSIM_SHELL_MEMBRANE_STVK;
        d.shell_strain_limit = 0.1;
        assert_int_equal(defsim_world_add_body(e, &d, NULL), DEFSIM_ERR_BACKEND_UNAVAILABLE);
        d.shell_strain_limit = 0.0;
        assert_int_equal(defsim_world_add_body(e, &d, NULL), DEFSIM_OK);
        defsim_world_destroy(e);
    }
    defsim_mesh_free(&m);
}

/* Checkpoints (format 10) hold the cap: the capped sheet saved after 5 steps of 0.5 s, loaded,
 * steps 5 more with the bits of the uninterrupted run, and the loaded world saves the same bytes;
 * the limit is active (the largest stretch in its band). */
static void test_checkpoint(void **state)
{
    (void)state;
    if (!built_backend("newton_cholmod")) return;
    const int32_t nv = (NX + 1) * (NY + 1);
    double fext[3 * (NX + 1) * (NY + 1)], xa[3 * (NX + 1) * (NY + 1)], xb[3 * (NX + 1) * (NY + 1)];
    defsim_mesh m;
    defsim_world *a = pinned_sheet(0.1, load_30(), &m, fext);
    for (int k = 0; k < 5; ++k) assert_int_equal(defsim_world_step(a, 0.5), DEFSIM_OK);
    void *buf = NULL, *again = NULL;
    size_t n = 0, n2 = 0;
    assert_int_equal(defsim_world_save_buffer(a, &buf, &n), DEFSIM_OK);
    assert_int_equal(((const unsigned char *)buf)[8], 11);   /* today's format */
    defsim_world *b = NULL;
    assert_int_equal(defsim_world_load_buffer(buf, n, NULL, NULL, &b), DEFSIM_OK);
    assert_int_equal(defsim_world_save_buffer(b, &again, &n2), DEFSIM_OK);
    assert_int_equal(n2, n);
    assert_memory_equal(again, buf, n);
    defsim_buffer_free(buf);
    defsim_buffer_free(again);
    for (int k = 0; k < 5; ++k) {
        assert_int_equal(defsim_world_step(a, 0.5), DEFSIM_OK);
        assert_int_equal(defsim_world_step(b, 0.5), DEFSIM_OK);
    }
    assert_int_equal(defsim_world_get_positions(a, xa, nv), DEFSIM_OK);
    assert_int_equal(defsim_world_get_positions(b, xb, nv), DEFSIM_OK);
    assert_memory_equal(xa, xb, sizeof xa);
    const double s = max_stretch(&m, xb, NULL);
    print_message("checkpoint of the 10 %% capped sheet: continued bit for bit, largest stretch "
                  "%.6f\n", s);
    assert_true(s > 1.09 && s < 1.1);
    defsim_world_destroy(a);
    defsim_world_destroy(b);
    defsim_mesh_free(&m);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_barrier_fd),
        cmocka_unit_test(test_barrier_band),
        cmocka_unit_test(test_element_fd),
        cmocka_unit_test(test_filter),
        cmocka_unit_test(test_sheet_cap),
        cmocka_unit_test(test_inactive_bits),
        cmocka_unit_test(test_validation),
        cmocka_unit_test(test_checkpoint),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
