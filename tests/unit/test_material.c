/* SPDX-License-Identifier: MIT */
/*
 * Unit tests of the material models (src/material.c, src/material_*.c) and of the small
 * linear algebra they use (src/mat3.c): signed SVD, symmetric eigen-decomposition and PSD
 * projection. Models are exercised through the public defsim_material_eval.
 */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>

#include <cmocka.h>

#include <float.h>
#include <math.h>
#include <string.h>

#include "defsim/defsim.h"
#include "isotropic.h"
#include "mat3.h"
#include "material.h"
#include "material.h"

/* ------------------------------------------------------------------------------------------ */
/* Helpers                                                                                    */

/* splitmix64: fixed seed per test so that every run sees the same matrices. */
static uint64_t rng_state;

static void rng_seed(uint64_t seed)
{
    rng_state = seed;
}

static double rng_uniform(double lo, double hi)
{
    uint64_t z = (rng_state += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    z ^= z >> 31;
    return lo + (hi - lo) * ((double)(z >> 11) * (1.0 / 9007199254740992.0));
}

static void random_rotation(double R[9])
{
    double q[4], n2;
    do {
        n2 = 0.0;
        for (int i = 0; i < 4; ++i) {
            q[i] = rng_uniform(-1.0, 1.0);
            n2 += q[i] * q[i];
        }
    } while (n2 < 0.01 || n2 > 1.0);
    double n = sqrt(n2), w = q[0] / n, x = q[1] / n, y = q[2] / n, z = q[3] / n;
    double r[9] = {1 - 2 * (y * y + z * z), 2 * (x * y - w * z),     2 * (x * z + w * y),
                   2 * (x * y + w * z),     1 - 2 * (x * x + z * z), 2 * (y * z - w * x),
                   2 * (x * z - w * y),     2 * (y * z + w * x),     1 - 2 * (x * x + y * y)};
    memcpy(R, r, sizeof r);
}

static void random_matrix(double A[9], double lo, double hi)
{
    for (int i = 0; i < 9; ++i) A[i] = rng_uniform(lo, hi);
}

/* F = U diag(s) V^T */
static void compose_usv(const double U[9], const double s[3], const double V[9], double F[9])
{
    double US[9];
    for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j) US[3 * i + j] = U[3 * i + j] * s[j];
    defsim__m3_mul_nt(US, V, F);
}

static void diag3(double a, double b, double c, double F[9])
{
    double d[9] = {a, 0, 0, 0, b, 0, 0, 0, c};
    memcpy(F, d, sizeof d);
}

static double norm_n(const double *a, int n)
{
    double s = 0.0;
    for (int i = 0; i < n; ++i) s += a[i] * a[i];
    return sqrt(s);
}

static double diff_n(const double *a, const double *b, int n)
{
    double s = 0.0;
    for (int i = 0; i < n; ++i) s += (a[i] - b[i]) * (a[i] - b[i]);
    return sqrt(s);
}

static int all_finite(const double *a, int n)
{
    for (int i = 0; i < n; ++i)
        if (!isfinite(a[i])) return 0;
    return 1;
}

static void assert_close(double got, double want, double tol)
{
    if (!(fabs(got - want) <= tol)) {
        print_error("got %.17g, want %.17g (tolerance %.3g)\n", got, want, tol);
        fail();
    }
}

static void assert_below(double value, double bound)
{
    if (!(value <= bound)) {
        print_error("%.6g is not <= %.6g\n", value, bound);
        fail();
    }
}

static defsim_material make_material(defsim_model model, double E, double nu)
{
    defsim_material m;
    defsim_material_init(&m, sizeof m, model);
    m.youngs_modulus = E;
    m.poisson_ratio = nu;
    return m;
}

static void eval_ok(const defsim_material *m, const double F[9], double *psi, double P[9],
                    double dPdF[81])
{
    assert_int_equal(defsim_material_eval(m, F, psi, P, dPdF), DEFSIM_OK);
}

static double eval_psi(const defsim_material *m, const double F[9])
{
    double psi = NAN;
    eval_ok(m, F, &psi, NULL, NULL);
    return psi;
}

/* Stress scale mu + lambda of a material, for tolerances. */
static double stress_scale(const defsim_material *m)
{
    double mu, lambda;
    defsim__lame(m->youngs_modulus, m->poisson_ratio, &mu, &lambda);
    return mu + lambda;
}

/* Materials every model test runs over: typical, incompressible-ish, and nu = 0. */
static const double test_E[3] = {1e6, 2.5e4, 7e5};
static const double test_nu[3] = {0.3, 0.45, 0.0};

/*
 * Deformation gradients: identity, near-identity, large stretch/shear; with `inverted`, also
 * det F < 0 ones kept away from s_i + s_j = 0 (where corotated's signed SVD switches branch).
 * For the neo-Hookean model (positive_only) every F has det F > 0.
 */
#define MAX_SET 32
static int build_set(double Fs[MAX_SET][9], int inverted)
{
    int n = 0;
    defsim__m3_identity(Fs[n++]);
    for (int k = 0; k < 4; ++k, ++n) {
        random_matrix(Fs[n], -1e-3, 1e-3);
        Fs[n][0] += 1.0;
        Fs[n][4] += 1.0;
        Fs[n][8] += 1.0;
    }
    for (int k = 0; k < 6; ++k, ++n) {
        double U[9], V[9], s[3];
        random_rotation(U);
        random_rotation(V);
        for (int i = 0; i < 3; ++i) s[i] = rng_uniform(0.4, 2.2);
        compose_usv(U, s, V, Fs[n]);
    }
    /* Shear-dominated: I + strictly upper triangular, det 1. */
    for (int k = 0; k < 2; ++k, ++n) {
        defsim__m3_identity(Fs[n]);
        Fs[n][1] = rng_uniform(-1.5, 1.5);
        Fs[n][2] = rng_uniform(-1.5, 1.5);
        Fs[n][5] = rng_uniform(-1.5, 1.5);
    }
    for (int k = 0; k < 4; ++k, ++n) {
        do {
            random_matrix(Fs[n], -0.7, 0.7);
            Fs[n][0] += 1.0;
            Fs[n][4] += 1.0;
            Fs[n][8] += 1.0;
        } while (defsim__m3_det(Fs[n]) < 0.2);
    }
    if (inverted) {
        static const double s_inv[4][3] = {
            {1.4, 0.8, -0.3}, {1.1, 0.9, -0.6}, {2.0, 1.3, -0.2}, {0.9, 0.7, -0.1}};
        for (int k = 0; k < 4; ++k, ++n) {
            double U[9], V[9];
            random_rotation(U);
            random_rotation(V);
            compose_usv(U, s_inv[k], V, Fs[n]);
        }
        diag3(-0.5, 1.0, 1.0, Fs[n++]);
    }
    return n;
}

typedef struct model_case {
    defsim_model model;
    int inverted; /* model is defined (and smooth enough for finite differences) at det F < 0 */
} model_case;

static const model_case case_stvk = {DEFSIM_MODEL_STVK, 1};
static const model_case case_corotated = {DEFSIM_MODEL_COROTATED, 1};
static const model_case case_neohookean = {DEFSIM_MODEL_NEOHOOKEAN, 0};
static const model_case case_snh = {DEFSIM_MODEL_STABLE_NEOHOOKEAN, 1};

/* ------------------------------------------------------------------------------------------ */
/* Per-model tests (prestate: a model_case)                                                   */

static void test_gradient_fd(void **state)
{
    const model_case *mc = *state;
    rng_seed(11);
    for (int mi = 0; mi < 3; ++mi) {
        defsim_material m = make_material(mc->model, test_E[mi], test_nu[mi]);
        double scale = stress_scale(&m);
        double Fs[MAX_SET][9];
        int n = build_set(Fs, mc->inverted);
        for (int t = 0; t < n; ++t) {
            double psi, P[9], Pfd[9];
            eval_ok(&m, Fs[t], &psi, P, NULL);
            assert_close(psi, eval_psi(&m, Fs[t]), 1e-14 * fabs(psi));
            const double h = 1e-6;
            for (int kl = 0; kl < 9; ++kl) {
                double Fp[9], Fm[9];
                memcpy(Fp, Fs[t], sizeof Fp);
                memcpy(Fm, Fs[t], sizeof Fm);
                Fp[kl] += h;
                Fm[kl] -= h;
                Pfd[kl] = (eval_psi(&m, Fp) - eval_psi(&m, Fm)) / (2.0 * h);
            }
            double tol = 1e-6 * fmax(norm_n(P, 9), scale);
            if (!(diff_n(P, Pfd, 9) <= tol)) {
                print_error("model %d material %d F #%d: |P - P_fd| = %g > %g\n", mc->model, mi,
                            t, diff_n(P, Pfd, 9), tol);
                fail();
            }
        }
    }
}

static void test_hessian_fd(void **state)
{
    const model_case *mc = *state;
    rng_seed(12);
    for (int mi = 0; mi < 3; ++mi) {
        defsim_material m = make_material(mc->model, test_E[mi], test_nu[mi]);
        double scale = stress_scale(&m);
        double Fs[MAX_SET][9];
        int n = build_set(Fs, mc->inverted);
        for (int t = 0; t < n; ++t) {
            double dPdF[81], fd[81];
            eval_ok(&m, Fs[t], NULL, NULL, dPdF);
            const double h = 1e-6;
            for (int kl = 0; kl < 9; ++kl) {
                double Fp[9], Fm[9], Pp[9], Pm[9];
                memcpy(Fp, Fs[t], sizeof Fp);
                memcpy(Fm, Fs[t], sizeof Fm);
                Fp[kl] += h;
                Fm[kl] -= h;
                eval_ok(&m, Fp, NULL, Pp, NULL);
                eval_ok(&m, Fm, NULL, Pm, NULL);
                for (int ij = 0; ij < 9; ++ij) fd[9 * ij + kl] = (Pp[ij] - Pm[ij]) / (2.0 * h);
            }
            double tol = 1e-6 * fmax(norm_n(dPdF, 81), scale);
            if (!(diff_n(dPdF, fd, 81) <= tol)) {
                print_error("model %d material %d F #%d: |dPdF - fd| = %g > %g\n", mc->model, mi,
                            t, diff_n(dPdF, fd, 81), tol);
                fail();
            }
            /* The tensor is a Hessian: symmetric. */
            for (int r = 0; r < 9; ++r)
                for (int c = 0; c < r; ++c)
                    assert_close(dPdF[9 * r + c], dPdF[9 * c + r], 1e-12 * norm_n(dPdF, 81));
        }
    }
}

/* psi(I), P(I) and dPdF(I) = the linear elasticity tensor. */
static void test_rest(void **state)
{
    const model_case *mc = *state;
    for (int mi = 0; mi < 3; ++mi) {
        defsim_material m = make_material(mc->model, test_E[mi], test_nu[mi]);
        double mu, lambda;
        defsim__lame(m.youngs_modulus, m.poisson_ratio, &mu, &lambda);
        double scale = mu + lambda;
        double I[9], psi, P[9], dPdF[81];
        defsim__m3_identity(I);
        eval_ok(&m, I, &psi, P, dPdF);

        double psi0 = 0.0;
        if (mc->model == DEFSIM_MODEL_STABLE_NEOHOOKEAN) {
            double mp = 4.0 / 3.0 * mu, lp = lambda + 5.0 / 6.0 * mu;
            double alpha = 1.0 + 3.0 * mp / (4.0 * lp);
            psi0 = 0.5 * lp * (1.0 - alpha) * (1.0 - alpha) - 0.5 * mp * log(4.0);
            assert_close(defsim__model_stable_neohookean.psi_rest(mu, lambda), psi0, 1e-12 * scale);
        }
        assert_close(psi, psi0, 1e-12 * scale);
        assert_below(norm_n(P, 9), 1e-12 * scale);

        for (int i = 0; i < 3; ++i)
            for (int j = 0; j < 3; ++j)
                for (int k = 0; k < 3; ++k)
                    for (int l = 0; l < 3; ++l) {
                        double want = mu * ((i == k && j == l) + (i == l && j == k)) +
                                      lambda * (i == j && k == l);
                        assert_close(dPdF[9 * (3 * i + j) + 3 * k + l], want, 1e-10 * scale);
                    }
    }
}

/* Frame indifference: psi(R F) = psi(F), P(R F) = R P(F). */
static void test_rotation_invariance(void **state)
{
    const model_case *mc = *state;
    rng_seed(13);
    defsim_material m = make_material(mc->model, 1e6, 0.3);
    double scale = stress_scale(&m);
    double Fs[MAX_SET][9];
    int n = build_set(Fs, mc->inverted);
    for (int t = 0; t < n; ++t) {
        double psi, P[9];
        eval_ok(&m, Fs[t], &psi, P, NULL);
        for (int r = 0; r < 3; ++r) {
            double R[9], RF[9], psi_r, P_r[9], RP[9];
            random_rotation(R);
            defsim__m3_mul(R, Fs[t], RF);
            eval_ok(&m, RF, &psi_r, P_r, NULL);
            defsim__m3_mul(R, P, RP);
            assert_close(psi_r, psi, 1e-10 * fabs(psi) + 1e-13 * scale);
            assert_below(diff_n(P_r, RP, 9), 1e-10 * norm_n(P, 9) + 1e-12 * scale);
        }
    }
}

/* Uniaxial stretch F = diag(s, 1, 1): psi and P by hand. */
static void test_uniaxial(void **state)
{
    const model_case *mc = *state;
    static const double stretches[5] = {0.3, 0.8, 1.0, 1.5, 2.5};
    for (int mi = 0; mi < 3; ++mi) {
        defsim_material m = make_material(mc->model, test_E[mi], test_nu[mi]);
        double mu, lambda;
        defsim__lame(m.youngs_modulus, m.poisson_ratio, &mu, &lambda);
        double scale = mu + lambda;
        for (int k = 0; k < 5; ++k) {
            double s = stretches[k], F[9], psi, P[9];
            diag3(s, 1.0, 1.0, F);
            eval_ok(&m, F, &psi, P, NULL);
            double want_psi, p0, p1;
            switch (mc->model) {
            case DEFSIM_MODEL_STVK: {
                double e = 0.5 * (s * s - 1.0);
                want_psi = mu * e * e + 0.5 * lambda * e * e;
                p0 = s * (2.0 * mu * e + lambda * e);
                p1 = lambda * e;
                break;
            }
            case DEFSIM_MODEL_COROTATED:
                want_psi = (mu + 0.5 * lambda) * (s - 1.0) * (s - 1.0);
                p0 = (2.0 * mu + lambda) * (s - 1.0);
                p1 = lambda * (s - 1.0);
                break;
            case DEFSIM_MODEL_NEOHOOKEAN:
                want_psi = 0.5 * mu * (s * s - 1.0) - mu * log(s) + 0.5 * lambda * log(s) * log(s);
                p0 = mu * (s - 1.0 / s) + lambda * log(s) / s;
                p1 = lambda * log(s);
                break;
            default: {
                double mp = 4.0 / 3.0 * mu, lp = lambda + 5.0 / 6.0 * mu;
                double alpha = 1.0 + 3.0 * mp / (4.0 * lp), ic = s * s + 2.0;
                want_psi = 0.5 * mp * (ic - 3.0) + 0.5 * lp * (s - alpha) * (s - alpha) -
                           0.5 * mp * log(ic + 1.0);
                double c1 = mp * (1.0 - 1.0 / (ic + 1.0)), c2 = lp * (s - alpha);
                /* cof(diag(s, 1, 1)) = diag(1, s, s) */
                p0 = c1 * s + c2;
                p1 = c1 + c2 * s;
                break;
            }
            }
            double want_P[9];
            diag3(p0, p1, p1, want_P);
            assert_close(psi, want_psi, 1e-12 * scale);
            assert_below(diff_n(P, want_P, 9), 1e-12 * scale);
        }
    }
}

/* ------------------------------------------------------------------------------------------ */
/* Inversion, degenerate F                                                                    */

static void test_corotated_inverted_closed_form(void **state)
{
    (void)state;
    rng_seed(21);
    defsim_material m = make_material(DEFSIM_MODEL_COROTATED, 1e6, 0.3);
    double mu, lambda;
    defsim__lame(1e6, 0.3, &mu, &lambda);
    /* Signed SVD of diag(-0.5, 1, 1): sigma = (1, 1, -0.5), R = I, S = F, tr(S - I) = -1.5, so
     * psi = mu 1.5^2 + lambda/2 1.5^2 and P = diag(2 mu (-1.5) - 1.5 lambda, -1.5 lambda, ...). */
    double F[9], psi, P[9], want_P[9];
    diag3(-0.5, 1.0, 1.0, F);
    eval_ok(&m, F, &psi, P, NULL);
    double want_psi = mu * 2.25 + 0.5 * lambda * 2.25;
    diag3(-3.0 * mu - 1.5 * lambda, -1.5 * lambda, -1.5 * lambda, want_P);
    assert_close(psi, want_psi, 1e-12 * want_psi);
    assert_below(diff_n(P, want_P, 9), 1e-12 * norm_n(want_P, 9));

    /* Same through random rotations on both sides: P(A F B^T) = A P(F) B^T. */
    for (int r = 0; r < 5; ++r) {
        double A[9], B[9], G[9], T[9], PG[9], want[9];
        random_rotation(A);
        random_rotation(B);
        defsim__m3_mul(A, F, T);
        defsim__m3_mul_nt(T, B, G);
        eval_ok(&m, G, &psi, PG, NULL);
        defsim__m3_mul(A, want_P, T);
        defsim__m3_mul_nt(T, B, want);
        assert_close(psi, want_psi, 1e-12 * want_psi);
        assert_below(diff_n(PG, want, 9), 1e-12 * norm_n(want_P, 9));
    }
}

static void test_snh_inverted_closed_form(void **state)
{
    (void)state;
    defsim_material m = make_material(DEFSIM_MODEL_STABLE_NEOHOOKEAN, 1e6, 0.3);
    double mu, lambda;
    defsim__lame(1e6, 0.3, &mu, &lambda);
    double mp = 4.0 / 3.0 * mu, lp = lambda + 5.0 / 6.0 * mu, alpha = 1.0 + 3.0 * mp / (4.0 * lp);
    double F[9], psi, P[9], dPdF[81], want_P[9];
    diag3(-0.5, 1.0, 1.0, F);
    eval_ok(&m, F, &psi, P, dPdF);
    double ic = 2.25, J = -0.5;
    double want_psi = 0.5 * mp * (ic - 3.0) + 0.5 * lp * (J - alpha) * (J - alpha) -
                      0.5 * mp * log(ic + 1.0);
    double c1 = mp * (1.0 - 1.0 / (ic + 1.0)), c2 = lp * (J - alpha);
    /* cof(diag(-0.5, 1, 1)) = diag(1, -0.5, -0.5) */
    diag3(-0.5 * c1 + c2, c1 - 0.5 * c2, c1 - 0.5 * c2, want_P);
    assert_close(psi, want_psi, 1e-12 * fabs(want_psi));
    assert_below(diff_n(P, want_P, 9), 1e-12 * norm_n(want_P, 9));
    assert_true(all_finite(dPdF, 81));
}

/* Corotated and stable neo-Hookean stay finite for inverted, flat and collapsed elements. */
static void test_degenerate_finite(void **state)
{
    (void)state;
    rng_seed(22);
    double Fs[16][9];
    int n = 0;
    memset(Fs[n++], 0, sizeof Fs[0]);                   /* collapsed to a point */
    diag3(-0.5, 1.0, 1.0, Fs[n++]);                     /* reflected */
    diag3(-1.0, -1.0, -1.0, Fs[n++]);                   /* point reflection */
    diag3(1.0, 1.0, 0.0, Fs[n++]);                      /* flat */
    diag3(1.0, 1.0, -1.0, Fs[n++]);                     /* s1 + s2 = 0 */
    diag3(0.0, 0.0, 1e-300, Fs[n++]);                   /* nearly collapsed */
    for (int i = 0; i < 3; ++i)                          /* rank 1: a b^T */
        for (int j = 0; j < 3; ++j) Fs[n][3 * i + j] = (i + 1.0) * (j - 1.5);
    ++n;
    for (int k = 0; k < 3; ++k, ++n) { /* rank 2 */
        double U[9], V[9], s[3] = {rng_uniform(0.5, 2.0), rng_uniform(0.1, 0.5), 0.0};
        random_rotation(U);
        random_rotation(V);
        compose_usv(U, s, V, Fs[n]);
    }
    for (int k = 0; k < 4; ++k, ++n) { /* random, mostly inverted */
        do random_matrix(Fs[n], -2.0, 2.0);
        while (defsim__m3_det(Fs[n]) > 0.0);
    }
    static const defsim_model models[2] = {DEFSIM_MODEL_COROTATED, DEFSIM_MODEL_STABLE_NEOHOOKEAN};
    for (int mi = 0; mi < 2; ++mi) {
        defsim_material m = make_material(models[mi], 1e6, 0.3);
        for (int t = 0; t < n; ++t) {
            double psi = NAN, P[9], dPdF[81];
            eval_ok(&m, Fs[t], &psi, P, dPdF);
            assert_true(isfinite(psi));
            assert_true(all_finite(P, 9));
            assert_true(all_finite(dPdF, 81));
        }
    }
    /* Collapsed: corotated psi = mu * 3 + lambda/2 * 9, P = -2 mu R - 3 lambda R with R = I. */
    double mu, lambda, psi, P[9];
    defsim__lame(1e6, 0.3, &mu, &lambda);
    defsim_material m = make_material(DEFSIM_MODEL_COROTATED, 1e6, 0.3);
    eval_ok(&m, Fs[0], &psi, P, NULL);
    assert_close(psi, 3.0 * mu + 4.5 * lambda, 1e-12 * psi);
}

static void test_neohookean_unstable(void **state)
{
    (void)state;
    defsim_material m = make_material(DEFSIM_MODEL_NEOHOOKEAN, 1e6, 0.3);
    double F[9], psi = 7.0, P[9], dPdF[81];
    diag3(-0.5, 1.0, 1.0, F);
    assert_int_equal(defsim_material_eval(&m, F, &psi, P, dPdF), DEFSIM_ERR_UNSTABLE);
    assert_int_equal(defsim_material_eval(&m, F, NULL, NULL, NULL), DEFSIM_ERR_UNSTABLE);
    diag3(1.0, 1.0, 0.0, F);
    assert_int_equal(defsim_material_eval(&m, F, &psi, P, dPdF), DEFSIM_ERR_UNSTABLE);
    memset(F, 0, sizeof F);
    assert_int_equal(defsim_material_eval(&m, F, &psi, P, dPdF), DEFSIM_ERR_UNSTABLE);
    /* Tiny but positive J is defined. */
    diag3(1e-8, 1.0, 1.0, F);
    eval_ok(&m, F, &psi, P, dPdF);
    assert_true(isfinite(psi) && all_finite(P, 9) && all_finite(dPdF, 81));

    /* The inline kernels report J <= 0 as documented. */
    double mu, lambda;
    defsim__lame(1e6, 0.3, &mu, &lambda);
    diag3(-0.5, 1.0, 1.0, F);
    assert_true(isinf(defsim__model_neohookean.psi(mu, lambda, F)));
    assert_true(isinf(defsim__model_neohookean.P(mu, lambda, F, P)));
    assert_true(isnan(P[0]) && isnan(P[8]));
    defsim__model_neohookean.dPdF(mu, lambda, F, dPdF);
    assert_true(isnan(dPdF[0]) && isnan(dPdF[80]));
}

/* The inline psi, P and dPdF kernels agree with each other for every model. */
static void test_kernels_consistent(void **state)
{
    (void)state;
    rng_seed(23);
    double mu, lambda;
    defsim__lame(3e5, 0.35, &mu, &lambda);
    for (int t = 0; t < 20; ++t) {
        double F[9];
        do {
            random_matrix(F, -0.5, 0.5);
            F[0] += 1.0;
            F[4] += 1.0;
            F[8] += 1.0;
        } while (defsim__m3_det(F) <= 0.1);
        double P[9];
        assert_close(defsim__model_stvk.P(mu, lambda, F, P), defsim__model_stvk.psi(mu, lambda, F),
                     1e-12 * mu);
        assert_close(defsim__model_corotated.P(mu, lambda, F, P), defsim__model_corotated.psi(mu, lambda, F),
                     1e-12 * mu);
        assert_close(defsim__model_neohookean.P(mu, lambda, F, P),
                     defsim__model_neohookean.psi(mu, lambda, F), 1e-12 * mu);
        assert_close(defsim__model_stable_neohookean.P(mu, lambda, F, P), defsim__model_stable_neohookean.psi(mu, lambda, F), 1e-12 * mu);
    }
    /* nu = 0 (lambda = 0): stable neo-Hookean is still well defined. */
    double I[9], P[9], dPdF[81];
    defsim__m3_identity(I);
    defsim__lame(1e6, 0.0, &mu, &lambda);
    assert_true(lambda == 0.0);
    assert_true(isfinite(defsim__model_stable_neohookean.P(mu, lambda, I, P)));
    assert_below(norm_n(P, 9), 1e-10 * mu);
    defsim__model_stable_neohookean.dPdF(mu, lambda, I, dPdF);
    assert_true(all_finite(dPdF, 81));
}

/* ------------------------------------------------------------------------------------------ */
/* Arguments, defaults, validation                                                            */

static void test_bad_input(void **state)
{
    (void)state;
    double I[9], psi, P[9];
    defsim__m3_identity(I);
    defsim_material m = make_material(DEFSIM_MODEL_STVK, 1e6, 0.3);

    assert_int_equal(defsim_material_eval(NULL, I, &psi, P, NULL), DEFSIM_ERR_INVALID_ARGUMENT);
    assert_int_equal(defsim_material_eval(&m, NULL, &psi, P, NULL), DEFSIM_ERR_INVALID_ARGUMENT);
    eval_ok(&m, I, NULL, NULL, NULL);

    double F[9];
    memcpy(F, I, sizeof F);
    F[4] = NAN;
    assert_int_equal(defsim_material_eval(&m, F, &psi, P, NULL), DEFSIM_ERR_INVALID_ARGUMENT);
    F[4] = INFINITY;
    assert_int_equal(defsim_material_eval(&m, F, &psi, P, NULL), DEFSIM_ERR_INVALID_ARGUMENT);
    F[4] = -INFINITY;
    assert_int_equal(defsim_material_eval(&m, F, &psi, P, NULL), DEFSIM_ERR_INVALID_ARGUMENT);

    defsim_material s = make_material(DEFSIM_MODEL_SPRING, 1e6, 0.3);
    assert_int_equal(defsim_material_eval(&s, I, &psi, P, NULL), DEFSIM_ERR_INVALID_ARGUMENT);

    defsim_material b = m;
    b.size = 0;
    assert_int_equal(defsim_material_eval(&b, I, &psi, P, NULL), DEFSIM_ERR_INVALID_ARGUMENT);
    b = m;
    b.model = (defsim_model)0;
    assert_int_equal(defsim_material_eval(&b, I, &psi, P, NULL), DEFSIM_ERR_INVALID_MATERIAL);
    b.model = (defsim_model)6;
    assert_int_equal(defsim_material_eval(&b, I, &psi, P, NULL), DEFSIM_ERR_INVALID_MATERIAL);

    static const double bad_E[4] = {0.0, -1.0, NAN, INFINITY};
    for (int k = 0; k < 4; ++k) {
        b = m;
        b.youngs_modulus = bad_E[k];
        assert_int_equal(defsim_material_eval(&b, I, &psi, P, NULL), DEFSIM_ERR_INVALID_MATERIAL);
    }
    static const double bad_nu[5] = {0.5, 0.7, -0.1, NAN, -INFINITY};
    for (int k = 0; k < 5; ++k) {
        b = m;
        b.poisson_ratio = bad_nu[k];
        assert_int_equal(defsim_material_eval(&b, I, &psi, P, NULL), DEFSIM_ERR_INVALID_MATERIAL);
    }
    b = m;
    b.density = -1.0;
    assert_int_equal(defsim_material_eval(&b, I, &psi, P, NULL), DEFSIM_ERR_INVALID_MATERIAL);
    b.density = NAN;
    assert_int_equal(defsim_material_eval(&b, I, &psi, P, NULL), DEFSIM_ERR_INVALID_MATERIAL);
    b = m;
    b.mass_damping = -1.0;
    assert_int_equal(defsim_material_eval(&b, I, &psi, P, NULL), DEFSIM_ERR_INVALID_MATERIAL);

    /* Limits that are allowed: nu = 0, nu just below 0.5, zero density. */
    b = m;
    b.poisson_ratio = 0.0;
    eval_ok(&b, I, &psi, P, NULL);
    b.poisson_ratio = 0.499;
    b.density = 0.0;
    eval_ok(&b, I, &psi, P, NULL);
}

static void test_material_init(void **state)
{
    (void)state;
    static const defsim_model models[5] = {DEFSIM_MODEL_SPRING, DEFSIM_MODEL_STVK,
                                           DEFSIM_MODEL_COROTATED, DEFSIM_MODEL_NEOHOOKEAN,
                                           DEFSIM_MODEL_STABLE_NEOHOOKEAN};
    for (int k = 0; k < 5; ++k) {
        defsim_material m;
        memset(&m, 0xAB, sizeof m);
        defsim_material_init(&m, sizeof m, models[k]);
        assert_int_equal(m.size, sizeof(defsim_material));
        assert_int_equal(m.model, models[k]);
        assert_true(m.youngs_modulus == 1e6);
        assert_true(m.poisson_ratio == 0.3);
        assert_true(m.density == 1000.0);
        assert_true(m.stiffness == 1e3);
        assert_true(m.vertex_mass == (models[k] == DEFSIM_MODEL_SPRING ? 0.01 : 0.0));
        assert_true(m.mass_damping == 0.0);
        assert_true(m.stiffness_damping == 0.0);
        char msg[128];
        assert_int_equal(defsim__material_check(&m, models[k] != DEFSIM_MODEL_SPRING, 1, msg,
                                                sizeof msg),
                         DEFSIM_OK);
    }

    /* NULL and too-small sizes are ignored. */
    defsim_material_init(NULL, sizeof(defsim_material), DEFSIM_MODEL_STVK);
    defsim_material m, ref;
    memset(&m, 0xAB, sizeof m);
    memcpy(&ref, &m, sizeof m);
    defsim_material_init(&m, offsetof(defsim_material, youngs_modulus) - 1, DEFSIM_MODEL_STVK);
    assert_memory_equal(&m, &ref, sizeof m);
    defsim_material_init(&m, 0, DEFSIM_MODEL_STVK);
    assert_memory_equal(&m, &ref, sizeof m);

    /* An older, shorter struct gets only the fields it has. */
    size_t part = offsetof(defsim_material, density);
    defsim_material_init(&m, part, DEFSIM_MODEL_COROTATED);
    assert_int_equal(m.size, part);
    assert_int_equal(m.model, DEFSIM_MODEL_COROTATED);
    assert_true(m.youngs_modulus == 1e6 && m.poisson_ratio == 0.3);
    assert_memory_equal((const char *)&m + part, (const char *)&ref + part, sizeof m - part);
    /* ... and is rejected by validation as too small. */
    assert_int_equal(defsim__material_check(&m, 1, 0, NULL, 0), DEFSIM_ERR_INVALID_ARGUMENT);
}

static void test_material_check(void **state)
{
    (void)state;
    char msg[256];
    assert_int_equal(defsim__material_check(NULL, 1, 0, msg, sizeof msg),
                     DEFSIM_ERR_INVALID_ARGUMENT);

    defsim_material s;
    defsim_material_init(&s, sizeof s, DEFSIM_MODEL_SPRING);
    assert_int_equal(defsim__material_check(&s, 0, 1, msg, sizeof msg), DEFSIM_OK);
    assert_int_equal(defsim__material_check(&s, 1, 1, msg, sizeof msg),
                     DEFSIM_ERR_INVALID_MATERIAL);
    assert_true(strlen(msg) > 0);
    /* Tet fields do not matter to a spring body. */
    s.youngs_modulus = -5.0;
    s.poisson_ratio = 0.9;
    assert_int_equal(defsim__material_check(&s, 0, 1, msg, sizeof msg), DEFSIM_OK);
    s.stiffness = -1.0;
    assert_int_equal(defsim__material_check(&s, 0, 1, msg, sizeof msg),
                     DEFSIM_ERR_INVALID_MATERIAL);
    s.stiffness = 0.0;
    assert_int_equal(defsim__material_check(&s, 0, 1, msg, sizeof msg), DEFSIM_OK);
    s.vertex_mass = -0.01;
    assert_int_equal(defsim__material_check(&s, 0, 1, msg, sizeof msg),
                     DEFSIM_ERR_INVALID_MATERIAL);

    defsim_material t;
    defsim_material_init(&t, sizeof t, DEFSIM_MODEL_STABLE_NEOHOOKEAN);
    /* The stiffness is only checked when the body has springs. */
    t.stiffness = NAN;
    assert_int_equal(defsim__material_check(&t, 1, 0, msg, sizeof msg), DEFSIM_OK);
    assert_int_equal(defsim__material_check(&t, 1, 1, msg, sizeof msg),
                     DEFSIM_ERR_INVALID_MATERIAL);
    t.stiffness = 1e3;
    t.stiffness_damping = -1e-3;
    assert_int_equal(defsim__material_check(&t, 1, 0, msg, sizeof msg),
                     DEFSIM_ERR_INVALID_MATERIAL);
    t.stiffness_damping = INFINITY;
    assert_int_equal(defsim__material_check(&t, 1, 0, msg, sizeof msg),
                     DEFSIM_ERR_INVALID_MATERIAL);
    t.stiffness_damping = 0.0;
    t.density = INFINITY;
    assert_int_equal(defsim__material_check(&t, 1, 0, msg, sizeof msg),
                     DEFSIM_ERR_INVALID_MATERIAL);
    /* A short message buffer is fine. */
    assert_int_equal(defsim__material_check(&t, 1, 0, msg, 4), DEFSIM_ERR_INVALID_MATERIAL);
    assert_true(strlen(msg) <= 3);
    t.density = 1000.0;
    assert_int_equal(defsim__material_check(&t, 1, 0, NULL, 0), DEFSIM_OK);
}

static void test_lame(void **state)
{
    (void)state;
    double mu, lambda;
    defsim__lame(1e6, 0.3, &mu, &lambda);
    assert_close(mu, 1e6 / 2.6, 1e-9);
    assert_close(lambda, 3e5 / (1.3 * 0.4), 1e-9);
    defsim__lame(2e5, 0.0, &mu, &lambda);
    assert_close(mu, 1e5, 1e-9);
    assert_true(lambda == 0.0);
}

/* ------------------------------------------------------------------------------------------ */
/* Signed SVD                                                                                 */

static void check_rotation(const double R[9])
{
    double RtR[9], I[9];
    defsim__m3_mul_tn(R, R, RtR);
    defsim__m3_identity(I);
    assert_below(diff_n(RtR, I, 9), 1e-14);
    assert_close(defsim__m3_det(R), 1.0, 1e-14);
}

/* Checks every property of the signed SVD of F; returns the sigma it computed. */
static void check_svd(const double F[9], double sigma_out[3])
{
    double U[9], s[3], V[9], G[9];
    defsim__svd3(F, U, s, V);
    assert_true(all_finite(U, 9) && all_finite(s, 3) && all_finite(V, 9));
    check_rotation(U);
    check_rotation(V);
    compose_usv(U, s, V, G);
    double nf = norm_n(F, 9);
    if (!(diff_n(G, F, 9) <= 1e-14 * nf)) {
        print_error("|U S V^T - F| = %g, |F| = %g\n", diff_n(G, F, 9), nf);
        fail();
    }
    if (!(s[0] >= s[1] && s[1] >= fabs(s[2]) && s[1] >= 0.0)) {
        print_error("sigma = %.17g %.17g %.17g\n", s[0], s[1], s[2]);
        fail();
    }
    double det = defsim__m3_det(F);
    /* det F = s0 s1 s2 exactly in sign where it is clearly non-zero. */
    if (fabs(det) > 1e-12 * nf * nf * nf) assert_true((det < 0.0) == (s[2] < 0.0));
    if (sigma_out) memcpy(sigma_out, s, sizeof s);
}

static void test_svd3_random(void **state)
{
    (void)state;
    rng_seed(31);
    for (int t = 0; t < 2000; ++t) {
        double F[9];
        random_matrix(F, -2.0, 2.0);
        check_svd(F, NULL);
    }
}

/* F = U diag(s) V^T with prescribed singular values, including repeated, zero and negative. */
static void test_svd3_prescribed(void **state)
{
    (void)state;
    rng_seed(32);
    static const double cases[][3] = {
        {1, 1, 1},      {2, 2, 0.5},   {3, 1, 1},     {2, 1, 0},      {1, 0, 0},
        {1, 1, 0},      {0, 0, 0},     {2, 1, -0.5},  {1, 1, -1},     {3, 2, -2},
        {1.5, 1.5, -1}, {1, 1e-8, 0},  {1, 1e-8, 1e-9}, {5, 1e-5, -1e-6}, {1 + 1e-12, 1, 1},
        {1e150, 3e149, 2e149}, {1e-150, 1e-150, -5e-151}, {1, 0.999999999, 0.999999998},
    };
    int ncases = (int)(sizeof cases / sizeof cases[0]);
    for (int c = 0; c < ncases; ++c) {
        for (int r = 0; r < 20; ++r) {
            double U[9], V[9], F[9], s[3];
            random_rotation(U);
            random_rotation(V);
            compose_usv(U, cases[c], V, F);
            check_svd(F, s);
            double smax = fabs(cases[c][0]);
            /* Sorted by magnitude, the smallest carries the sign of det. */
            double want[3] = {fabs(cases[c][0]), fabs(cases[c][1]), cases[c][2]};
            for (int i = 0; i < 3; ++i) assert_close(s[i], want[i], 1e-14 * smax);
        }
    }
}

static void test_svd3_exact(void **state)
{
    (void)state;
    double F[9], s[3];

    memset(F, 0, sizeof F);
    double U[9], V[9], I[9];
    defsim__svd3(F, U, s, V);
    defsim__m3_identity(I);
    assert_memory_equal(U, I, sizeof I);
    assert_memory_equal(V, I, sizeof I);
    assert_true(s[0] == 0.0 && s[1] == 0.0 && s[2] == 0.0);

    defsim__m3_identity(F);
    check_svd(F, s);
    assert_true(s[0] == 1.0 && s[1] == 1.0 && s[2] == 1.0);

    diag3(-1.0, -1.0, -1.0, F);
    check_svd(F, s);
    assert_close(s[2], -1.0, 1e-15);

    diag3(-0.5, 1.0, 1.0, F);
    check_svd(F, s);
    assert_close(s[0], 1.0, 1e-15);
    assert_close(s[1], 1.0, 1e-15);
    assert_close(s[2], -0.5, 1e-15);

    diag3(-2.0, -3.0, 1.0, F); /* a rotation by pi times a stretch: det > 0 */
    check_svd(F, s);
    assert_close(s[0], 3.0, 1e-15);
    assert_close(s[1], 2.0, 1e-15);
    assert_close(s[2], 1.0, 1e-15);

    /* Permutations (det -1 and +1). */
    static const double perm[2][9] = {{0, 1, 0, 1, 0, 0, 0, 0, 1}, {0, 1, 0, 0, 0, 1, 1, 0, 0}};
    check_svd(perm[0], s);
    assert_close(s[2], -1.0, 1e-15);
    check_svd(perm[1], s);
    assert_close(s[2], 1.0, 1e-15);

    /* Exact rank 1: a b^T has sigma |a||b|. */
    for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j) F[3 * i + j] = (i + 1.0) * (j + 4.0);
    check_svd(F, s);
    assert_close(s[0], sqrt(14.0 * 77.0), 1e-13);
    assert_close(s[1], 0.0, 1e-13);
    assert_close(s[2], 0.0, 1e-13);

    /* A single non-zero entry, and one row only. */
    memset(F, 0, sizeof F);
    F[5] = -3.0;
    check_svd(F, s);
    assert_true(s[0] == 3.0);
    double row[9] = {1, 2, 2, 0, 0, 0, 0, 0, 0};
    check_svd(row, s);
    assert_close(s[0], 3.0, 1e-15);

    /* Two equal columns (rank 2), and subnormal entries. */
    double twin[9] = {1, 1, 0, 2, 2, 1, 3, 3, -1};
    check_svd(twin, s);
    assert_close(s[2], 0.0, 1e-14);
    diag3(1e-310, 2e-310, -3e-310, F);
    defsim__svd3(F, U, s, V);
    assert_true(all_finite(U, 9) && all_finite(s, 3) && all_finite(V, 9));
}

/* ------------------------------------------------------------------------------------------ */
/* Symmetric eigenproblems                                                                    */

static void random_orthogonal(int n, double *Q)
{
    for (int k = 0; k < n; ++k) {
        double nrm;
        do {
            for (int i = 0; i < n; ++i) Q[i * n + k] = rng_uniform(-1.0, 1.0);
            for (int j = 0; j < k; ++j) {
                double d = 0.0;
                for (int i = 0; i < n; ++i) d += Q[i * n + k] * Q[i * n + j];
                for (int i = 0; i < n; ++i) Q[i * n + k] -= d * Q[i * n + j];
            }
            nrm = 0.0;
            for (int i = 0; i < n; ++i) nrm += Q[i * n + k] * Q[i * n + k];
            nrm = sqrt(nrm);
        } while (nrm < 0.1);
        for (int i = 0; i < n; ++i) Q[i * n + k] /= nrm;
    }
}

/* A = Q diag(lam) Q^T */
static void compose_sym(int n, const double *Q, const double *lam, double *A)
{
    for (int i = 0; i < n; ++i)
        for (int j = 0; j < n; ++j) {
            double s = 0.0;
            for (int k = 0; k < n; ++k) s += Q[i * n + k] * lam[k] * Q[j * n + k];
            A[i * n + j] = s;
        }
}

static void test_sym_eig(void **state)
{
    (void)state;
    rng_seed(41);
    static const int sizes[5] = {1, 3, 6, 9, 12};
    for (int si = 0; si < 5; ++si) {
        int n = sizes[si];
        for (int t = 0; t < 20; ++t) {
            double A[144], W[144], lam[12], V[144], Q[144], want[12];
            random_orthogonal(n, Q);
            for (int k = 0; k < n; ++k) want[k] = rng_uniform(-3.0, 3.0);
            if (t % 2 == 1 && n >= 3) { /* repeated eigenvalues */
                want[1] = want[0];
                want[2] = want[0];
            }
            compose_sym(n, Q, want, A);
            memcpy(W, A, sizeof(double) * (size_t)(n * n));
            defsim__sym_eig(n, W, lam, V);
            double na = norm_n(A, n * n);
            /* A v_k = lam_k v_k, V orthonormal. */
            for (int k = 0; k < n; ++k) {
                double res = 0.0;
                for (int i = 0; i < n; ++i) {
                    double av = 0.0;
                    for (int j = 0; j < n; ++j) av += A[i * n + j] * V[j * n + k];
                    res += (av - lam[k] * V[i * n + k]) * (av - lam[k] * V[i * n + k]);
                }
                assert_below(sqrt(res), 1e-13 * na);
                for (int l = 0; l < n; ++l) {
                    double d = 0.0;
                    for (int i = 0; i < n; ++i) d += V[i * n + k] * V[i * n + l];
                    assert_close(d, k == l ? 1.0 : 0.0, 1e-13);
                }
            }
            /* Same multiset of eigenvalues (sort both). */
            for (int a = 0; a < n; ++a)
                for (int b = a + 1; b < n; ++b) {
                    if (lam[b] < lam[a]) { double x = lam[a]; lam[a] = lam[b]; lam[b] = x; }
                    if (want[b] < want[a]) { double x = want[a]; want[a] = want[b]; want[b] = x; }
                }
            for (int k = 0; k < n; ++k) assert_close(lam[k], want[k], 1e-13 * na);
        }
    }
    /* Entries near the ends of the double range: the same eigenvalues, scaled. */
    static const double scales[2] = {1e-150, 1e150};
    for (int si = 0; si < 2; ++si) {
        const int n = 12;
        double A[144], lam[12], V[144], Q[144], want[12];
        random_orthogonal(n, Q);
        for (int k = 0; k < n; ++k) want[k] = scales[si] * rng_uniform(-3.0, 3.0);
        compose_sym(n, Q, want, A);
        defsim__sym_eig(n, A, lam, V);
        for (int a = 0; a < n; ++a)
            for (int b = a + 1; b < n; ++b) {
                if (lam[b] < lam[a]) { double x = lam[a]; lam[a] = lam[b]; lam[b] = x; }
                if (want[b] < want[a]) { double x = want[a]; want[a] = want[b]; want[b] = x; }
            }
        for (int k = 0; k < n; ++k) assert_below(fabs(lam[k] - want[k]), 1e-13 * 3.0 * scales[si]);
    }
    /* A hinge's translation-free 9 x 9 Hessian at rest, captured from a run: entries from 1 down
     * to 1e-322, so that the QR sweep's rotations see numbers whose squares underflow (sqrt(x^2
     * + z^2) gave 0 / 0 and NaN eigenvectors before hypot). */
    {
        static const double H9[81] = {
            0x1.0624dd2f1a9fcp-114, 0x1.0624dd2f1a9fcp-57, -0x1.67d038f9afdecp-218, 0x0p+0, 0x0p+0, 0x0p+0, 0x0p+0, 0x0p+0, 0x0p+0,
            0x1.0624dd2f1a9fcp-57, 0x1.0624dd2f1a9fcp+0, -0x1.67d038f9afdecp-161, 0x0p+0, 0x0p+0, 0x0p+0, 0x0p+0, 0x0p+0, 0x0p+0,
            -0x1.67d038f9afdecp-218, -0x1.67d038f9afdecp-161, 0x1.eddf4f31f81c8p-322, 0x1.67d038f9afdecp-219, 0x1.67d038f9afdecp-162, -0x1.eddf4f31f81c8p-323, 0x1.67d038f9afdecp-219, 0x1.67d038f9afdecp-162, -0x1.eddf4f31f81c8p-323,
            0x0p+0, 0x0p+0, 0x1.67d038f9afdecp-219, 0x0p+0, 0x0p+0, 0x0p+0, 0x0p+0, 0x0p+0, 0x0p+0,
            0x0p+0, 0x0p+0, 0x1.67d038f9afdecp-162, 0x0p+0, 0x0p+0, 0x0p+0, 0x0p+0, 0x0p+0, 0x0p+0,
            0x0p+0, 0x0p+0, -0x1.eddf4f31f81c8p-323, 0x0p+0, 0x0p+0, -0x1p-376, 0x0p+0, 0x0p+0, -0x1.8p-377,
            0x0p+0, 0x0p+0, 0x1.67d038f9afdecp-219, 0x0p+0, 0x0p+0, 0x0p+0, 0x0p+0, 0x0p+0, 0x0p+0,
            0x0p+0, 0x0p+0, 0x1.67d038f9afdecp-162, 0x0p+0, 0x0p+0, 0x0p+0, 0x0p+0, 0x0p+0, 0x0p+0,
            0x0p+0, 0x0p+0, -0x1.eddf4f31f81c8p-323, 0x0p+0, 0x0p+0, -0x1.8p-377, 0x0p+0, 0x0p+0, -0x1p-377};
        double A[81], lam[9], V[81];
        memcpy(A, H9, sizeof A);
        defsim__sym_eig(9, A, lam, V);
        const double na = norm_n(H9, 81);
        for (int k = 0; k < 9; ++k) {
            double res = 0.0, len = 0.0;
            for (int i = 0; i < 9; ++i) {
                double av = 0.0;
                for (int j = 0; j < 9; ++j) av += H9[i * 9 + j] * V[j * 9 + k];
                assert_true(isfinite(V[i * 9 + k]));
                res += (av - lam[k] * V[i * 9 + k]) * (av - lam[k] * V[i * 9 + k]);
                len += V[i * 9 + k] * V[i * 9 + k];
            }
            assert_below(sqrt(res), 1e-13 * na);
            assert_close(len, 1.0, 1e-13);
        }
    }
    /* Graded matrices A_ij = s_i s_j u_ij, s_i from 1 down to 1e-170 (their products reach the
     * subnormals): finite eigenvectors, residual within 1e-6 of the largest entry (measured
     * 1.1e-8 over 2000 such matrices; before the column scaling and hypot the QR solver gave NaN
     * on 337 of them, and the cyclic Jacobi it replaced left residuals of 1). */
    for (int t = 0; t < 500; ++t) {
        const int n = 3 + t % 10;
        double s[12], A[144], W[144], lam[12], V[144];
        for (int i = 0; i < n; ++i) s[i] = pow(10.0, -rng_uniform(0.0, 170.0));
        double na = 0.0;
        for (int i = 0; i < n; ++i)
            for (int j = i; j < n; ++j) {
                A[i * n + j] = A[j * n + i] = s[i] * s[j] * rng_uniform(-1.0, 1.0);
                na = fmax(na, fabs(A[i * n + j]));
            }
        memcpy(W, A, sizeof(double) * (size_t)(n * n));
        defsim__sym_eig(n, W, lam, V);
        for (int k = 0; k < n; ++k)
            for (int i = 0; i < n; ++i) {
                double av = 0.0;
                for (int j = 0; j < n; ++j) av += A[i * n + j] * V[j * n + k];
                assert_true(isfinite(V[i * n + k]));
                assert_below(fabs(av - lam[k] * V[i * n + k]), 1e-6 * na);
            }
    }
    /* The zero matrix. */
    double Z[9] = {0}, lz[3], Vz[9];
    defsim__sym_eig(3, Z, lz, Vz);
    assert_true(lz[0] == 0.0 && lz[1] == 0.0 && lz[2] == 0.0);
}

/* defsim__project_psd_nodes against the whole matrix's projection: random translation-invariant
 * Hessians of m = 2, 3, 4 vertices placed on some of 4 blocks (both modes), and a PSD one left
 * bit for bit. */
static void test_project_psd_nodes(void **state)
{
    (void)state;
    rng_seed(43);
    static const int picks[3][4] = {{3, 1}, {0, 2, 3}, {2, 0, 3, 1}};
    for (int m = 2; m <= 4; ++m)
        for (int t = 0; t < 40; ++t) {
            const int nd = 12, r = 3 * (m - 1);
            const int *nodes = picks[m - 2];
            /* H = P B P^T, B a random symmetric (indefinite, or PSD when t % 4 == 3) r x r */
            double Q[81], lam[9], B[81], H[144] = {0}, W[144];
            random_orthogonal(r, Q);
            for (int k = 0; k < r; ++k) lam[k] = rng_uniform(t % 4 == 3 ? 0.1 : -2.0, 3.0);
            if (t % 4 != 3) lam[0] = rng_uniform(-2.0, -0.1);
            compose_sym(r, Q, lam, B);
            const double(*h)[4] = defsim__node_basis[m];
            for (int i = 0; i < m; ++i)
                for (int j = 0; j < m; ++j)
                    for (int a = 0; a < 3; ++a)
                        for (int b = 0; b < 3; ++b) {
                            double sum = 0.0;
                            for (int k = 0; k < m - 1; ++k)
                                for (int l = 0; l < m - 1; ++l)
                                    sum += h[k][i] * h[l][j] * B[(3 * k + a) * r + 3 * l + b];
                            H[(3 * nodes[i] + a) * nd + 3 * nodes[j] + b] = sum;
                        }
            for (int mode = 1; mode <= 2; ++mode) {
                memcpy(W, H, sizeof W);
                double R[144];
                memcpy(R, H, sizeof R);
                const int changed = defsim__project_psd_nodes(nd, W, m, nodes, mode);
                const int want = defsim__project_psd(nd, R, mode);
                assert_int_equal(changed, t % 4 == 3 ? 0 : 1);
                if (!changed) assert_memory_equal(W, H, sizeof W);
                /* the whole matrix's projection sees the same negative eigenvalues (its null
                 * space's rounding-level ones may count too) */
                assert_true(want >= changed);
                double err = 0.0, scale = 0.0;
                for (int i = 0; i < nd * nd; ++i) {
                    err = fmax(err, fabs(W[i] - R[i]));
                    scale = fmax(scale, fabs(H[i]));
                }
                assert_below(err, 1e-13 * scale);
            }
        }
}

static void test_project_psd(void **state)
{
    (void)state;
    rng_seed(42);
    for (int t = 0; t < 30; ++t) {
        int n = (t % 3 == 0) ? 12 : (t % 3 == 1 ? 9 : 3);
        double Q[144], lam[12], A[144], B[144], want[144];
        random_orthogonal(n, Q);
        for (int k = 0; k < n; ++k) lam[k] = rng_uniform(-2.0, 2.0);
        lam[0] = -1.0; /* at least one clearly negative */
        compose_sym(n, Q, lam, A);
        double na = norm_n(A, n * n);

        for (int mode = 1; mode <= 2; ++mode) {
            double fixed[12];
            for (int k = 0; k < n; ++k)
                fixed[k] = lam[k] >= 0.0 ? lam[k] : (mode == 1 ? 0.0 : -lam[k]);
            compose_sym(n, Q, fixed, want);
            memcpy(B, A, sizeof(double) * (size_t)(n * n));
            assert_int_equal(defsim__project_psd(n, B, mode), 1);
            assert_below(diff_n(B, want, n * n), 1e-13 * na);
            for (int i = 0; i < n; ++i)
                for (int j = 0; j < n; ++j) assert_true(B[i * n + j] == B[j * n + i]);
            /* The result is PSD: projecting it again changes nothing that matters. */
            double W[144], ev[12], V[144];
            memcpy(W, B, sizeof(double) * (size_t)(n * n));
            defsim__sym_eig(n, W, ev, V);
            for (int k = 0; k < n; ++k) assert_true(ev[k] >= -1e-13 * na);
        }

        /* Mode 0 never touches A. */
        memcpy(B, A, sizeof(double) * (size_t)(n * n));
        assert_int_equal(defsim__project_psd(n, B, 0), 0);
        assert_memory_equal(B, A, sizeof(double) * (size_t)(n * n));

        /* Positive definite input is left bit-for-bit unchanged. */
        for (int k = 0; k < n; ++k) lam[k] = rng_uniform(0.1, 3.0);
        compose_sym(n, Q, lam, A);
        for (int mode = 1; mode <= 2; ++mode) {
            memcpy(B, A, sizeof(double) * (size_t)(n * n));
            assert_int_equal(defsim__project_psd(n, B, mode), 0);
            assert_memory_equal(B, A, sizeof(double) * (size_t)(n * n));
        }
    }

    /* An element Hessian from a material: SNH under compression is indefinite, projected. */
    double mu, lambda, F[9], H[81];
    defsim__lame(1e6, 0.3, &mu, &lambda);
    diag3(0.3, 0.4, 0.5, F);
    defsim__model_stable_neohookean.dPdF(mu, lambda, F, H);
    int changed = defsim__project_psd(9, H, 1);
    double W[81], ev[9], V[81];
    memcpy(W, H, sizeof W);
    defsim__sym_eig(9, W, ev, V);
    for (int k = 0; k < 9; ++k) assert_true(ev[k] >= -1e-12 * norm_n(H, 81));
    assert_true(changed == 0 || changed == 1);
}

/* The analytic eigen-structure (each model table's sigma) that element Hessians are projected
 * with: rebuilt through defsim__isotropic_dPdF it equals the model's dPdF, and with h projected
 * and the six twist / flip eigenvalues clamped it equals the 9 x 9 eigensolver's projection. */
static void test_sigma_projection(void **state)
{
    const model_case *mc = *state;
    rng_seed(77 + (uint64_t)mc->model);
    double Fs[MAX_SET][9];
    int n = build_set(Fs, mc->inverted);
    /* Near-repeated and compressed singular values, where projections change most. */
    const double extra[4][3] = {{1.0, 1.0 + 1e-9, 1.0}, {0.3, 0.4, 0.5}, {0.2, 0.2, 0.9},
                                {2.5, 0.5, 0.5}};
    for (int k = 0; k < 4 && n < MAX_SET; ++k, ++n) {
        double U[9], V[9];
        random_rotation(U);
        random_rotation(V);
        compose_usv(U, extra[k], V, Fs[n]);
    }
    for (int t = 0; t < 3; ++t) {
        double mu, lambda;
        defsim__lame(test_E[t], test_nu[t], &mu, &lambda);
        for (int f = 0; f < n; ++f) {
            const double *F = Fs[f];
            double U[9], V[9], s[3], h[9], es[3], ek[3], D[81], Diso[81];
            defsim__svd3(F, U, s, V);
            const defsim__model *md = defsim__model_find(mc->model);
            md->sigma(mu, lambda, s, h, es, ek);
            md->dPdF(mu, lambda, F, D);
            defsim__isotropic_dPdF(U, V, h, es, ek, Diso);
            const double scale = norm_n(D, 81);
            assert_below(diff_n(Diso, D, 81), 1e-10 * scale);
            for (int mode = 1; mode <= 2; ++mode) {
                double want[81], hp[9], esp[3], ekp[3], got[81];
                memcpy(want, D, sizeof want);
                defsim__project_psd(9, want, mode);
                memcpy(hp, h, sizeof hp);
                defsim__project_psd(3, hp, mode);
                for (int p = 0; p < 3; ++p) {
                    esp[p] = es[p] >= 0.0 ? es[p] : (mode == 1 ? 0.0 : -es[p]);
                    ekp[p] = ek[p] >= 0.0 ? ek[p] : (mode == 1 ? 0.0 : -ek[p]);
                }
                defsim__isotropic_dPdF(U, V, hp, esp, ekp, got);
                assert_below(diff_n(got, want, 81), 1e-9 * scale);
            }
        }
    }
    /* The neo-Hookean eigen-structure is undefined where det F <= 0, like its dPdF. */
    if (mc->model == DEFSIM_MODEL_NEOHOOKEAN) {
        const double s[3] = {1.0, 0.5, -0.1};
        double h[9], es[3], ek[3];
        defsim__model_neohookean.sigma(1.0, 1.0, s, h, es, ek);
        assert_true(isnan(h[0]) && isnan(es[0]) && isnan(ek[2]));
    }
}

/* ------------------------------------------------------------------------------------------ */

/* The per-model tests, named "<model>: <test>" in the output. */
#define MODEL_TEST(name, f, mc) {name ": " #f, f, NULL, NULL, (void *)&(mc)}
#define MODEL_TESTS(name, mc)                                                                   \
    MODEL_TEST(name, test_gradient_fd, mc), MODEL_TEST(name, test_hessian_fd, mc),              \
        MODEL_TEST(name, test_rest, mc), MODEL_TEST(name, test_rotation_invariance, mc),        \
        MODEL_TEST(name, test_uniaxial, mc), MODEL_TEST(name, test_sigma_projection, mc)

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_lame),
        cmocka_unit_test(test_material_init),
        cmocka_unit_test(test_material_check),
        cmocka_unit_test(test_bad_input),
        MODEL_TESTS("stvk", case_stvk),
        MODEL_TESTS("corotated", case_corotated),
        MODEL_TESTS("neohookean", case_neohookean),
        MODEL_TESTS("snh", case_snh),
        cmocka_unit_test(test_corotated_inverted_closed_form),
        cmocka_unit_test(test_snh_inverted_closed_form),
        cmocka_unit_test(test_degenerate_finite),
        cmocka_unit_test(test_neohookean_unstable),
        cmocka_unit_test(test_kernels_consistent),
        cmocka_unit_test(test_svd3_random),
        cmocka_unit_test(test_svd3_prescribed),
        cmocka_unit_test(test_svd3_exact),
        cmocka_unit_test(test_sym_eig),
        cmocka_unit_test(test_project_psd),
        cmocka_unit_test(test_project_psd_nodes),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
