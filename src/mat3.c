/* SPDX-License-Identifier: MIT */
#include "mat3.h"

#include <float.h>
#include <math.h>



static void swap3(double a[3], double b[3])
{
    for (int i = 0; i < 3; ++i) {
        double t = a[i];
        a[i] = b[i];
        b[i] = t;
    }
}

/* A unit vector orthogonal to the unit vector u. */
static void any_orthogonal(const double u[3], double w[3])
{
    double e[3] = {0, 0, 0};
    int k = 0;
    if (fabs(u[1]) < fabs(u[k])) k = 1;
    if (fabs(u[2]) < fabs(u[k])) k = 2;
    e[k] = 1.0;
    defsim__v3_cross(u, e, w);
    double n = sqrt(defsim__v3_dot(w, w));
    for (int i = 0; i < 3; ++i) w[i] /= n;
}

/*
 * One-sided (Hestenes) Jacobi: rotate pairs of columns of A = F/scale until they are mutually
 * orthogonal, accumulating the rotations in V. Then A = F V has columns sigma_k u_k. Working on
 * the columns of F rather than on F^T F keeps the small singular values accurate, and scaling by
 * the largest entry keeps every intermediate far from overflow and underflow.
 */
void defsim__svd3(const double F[9], double U[9], double sigma[3], double V[9])
{
    double scale = 0.0;
    for (int i = 0; i < 9; ++i) {
        double a = fabs(F[i]);
        if (a > scale) scale = a;
    }
    if (!(scale > 0.0) || !isfinite(scale)) {
        defsim__m3_identity(U);
        defsim__m3_identity(V);
        sigma[0] = sigma[1] = sigma[2] = 0.0;
        return;
    }

    /* a[c] is column c of F / scale, v[c] column c of V. */
    double a[3][3], v[3][3];
    for (int c = 0; c < 3; ++c)
        for (int r = 0; r < 3; ++r) {
            a[c][r] = F[3 * r + c] / scale;
            v[c][r] = (r == c) ? 1.0 : 0.0;
        }

    static const int pairs[3][2] = {{0, 1}, {0, 2}, {1, 2}};
    const double tol2 = DBL_EPSILON * DBL_EPSILON;
    for (int sweep = 0; sweep < 40; ++sweep) {
        int rotated = 0;
        for (int k = 0; k < 3; ++k) {
            int p = pairs[k][0], q = pairs[k][1];
            /* Norms are recomputed, not updated: an update would carry an error of eps |a_p|^2
             * into |a_q|^2, fatal when sigma_q / sigma_p is small. */
            double alpha = defsim__v3_dot(a[p], a[p]), beta = defsim__v3_dot(a[q], a[q]);
            double gamma = defsim__v3_dot(a[p], a[q]);
            /* Converged pair: also true for gamma == 0, which covers zero columns. */
            if (gamma * gamma <= tol2 * alpha * beta) continue;
            /* Rotation angle th with tan(2 th) = y / x: t = tan th is the root of least
             * magnitude, cs^2 = (r + |x|)/(2r). gamma^2 > 0 here, so r > 0 (no 0/0). */
            double x = beta - alpha, y = 2.0 * gamma;
            double r = sqrt(x * x + y * y);
            double t = (x >= 0.0 ? y : -y) / (fabs(x) + r);
            double cs = sqrt((r + fabs(x)) / (2.0 * r));
            double sn = cs * t;
            for (int i = 0; i < 3; ++i) {
                double ap = a[p][i], aq = a[q][i];
                a[p][i] = cs * ap - sn * aq;
                a[q][i] = sn * ap + cs * aq;
                double vp = v[p][i], vq = v[q][i];
                v[p][i] = cs * vp - sn * vq;
                v[q][i] = sn * vp + cs * vq;
            }
            rotated = 1;
        }
        if (!rotated) break;
    }

    double n[3];
    for (int c = 0; c < 3; ++c) n[c] = sqrt(defsim__v3_dot(a[c], a[c]));

    /* Sort by decreasing norm (three compare-swaps). */
    static const int order[3][2] = {{0, 1}, {1, 2}, {0, 1}};
    for (int k = 0; k < 3; ++k) {
        int i = order[k][0], j = order[k][1];
        if (n[i] < n[j]) {
            double t = n[i];
            n[i] = n[j];
            n[j] = t;
            swap3(a[i], a[j]);
            swap3(v[i], v[j]);
        }
    }

    /* Make V a proper rotation; F v2 = a2 keeps holding after negating both. */
    double w[3];
    defsim__v3_cross(v[0], v[1], w);
    if (defsim__v3_dot(w, v[2]) < 0.0) {
        for (int r = 0; r < 3; ++r) {
            v[2][r] = -v[2][r];
            a[2][r] = -a[2][r];
        }
    }

    /* u0 and u1 from the columns (n[0] >= 1/sqrt(3) since |A|_F >= 1); u2 = u0 x u1 makes U
     * proper, and the sign of det F then lands on sigma2 = a2 . u2. */
    double u[3][3];
    for (int r = 0; r < 3; ++r) u[0][r] = a[0][r] / n[0];
    double proj = defsim__v3_dot(a[1], u[0]);
    for (int r = 0; r < 3; ++r) u[1][r] = a[1][r] - proj * u[0][r];
    double nr = sqrt(defsim__v3_dot(u[1], u[1]));
    if (nr > 1e-200) {
        for (int r = 0; r < 3; ++r) u[1][r] /= nr;
    } else {
        any_orthogonal(u[0], u[1]);
    }
    defsim__v3_cross(u[0], u[1], u[2]);

    /* |a2 . u2| can exceed n[1] by an ulp when the two are equal; keep the order exact. */
    double s2 = defsim__v3_dot(a[2], u[2]);
    if (fabs(s2) > n[1]) s2 = (s2 < 0.0) ? -n[1] : n[1];
    sigma[0] = n[0] * scale;
    sigma[1] = n[1] * scale;
    sigma[2] = s2 * scale;
    for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 3; ++c) {
            U[3 * r + c] = u[c][r];
            V[3 * r + c] = v[c][r];
        }
}

/* Cyclic Jacobi: rotations A <- J^T A J zero one off-diagonal pair at a time. */
void defsim__sym_eig(int n, double *A, double *evals, double *evecs)
{
    for (int i = 0; i < n; ++i) {
        for (int j = 0; j < n; ++j) evecs[i * n + j] = (i == j) ? 1.0 : 0.0;
        /* Work on a symmetric copy of the upper triangle. */
        for (int j = 0; j < i; ++j) A[i * n + j] = A[j * n + i];
    }

    double total = 0.0;
    for (int i = 0; i < n * n; ++i) total += A[i] * A[i];

    for (int sweep = 0; sweep < 60 && total > 0.0; ++sweep) {
        double off = 0.0;
        for (int p = 0; p < n; ++p)
            for (int q = p + 1; q < n; ++q) off += A[p * n + q] * A[p * n + q];
        /* Off-diagonal part below 1e-17 of the norm: eigenvalues are as exact as doubles allow. */
        if (off <= 1e-34 * total) break;

        for (int p = 0; p < n; ++p) {
            for (int q = p + 1; q < n; ++q) {
                double apq = A[p * n + q];
                if (apq == 0.0) continue;
                double theta = (A[q * n + q] - A[p * n + p]) / (2.0 * apq);
                double at = fabs(theta);
                double t = (at < 1e150) ? 1.0 / (at + sqrt(1.0 + at * at)) : 0.5 / at;
                if (theta < 0.0) t = -t;
                double c = 1.0 / sqrt(1.0 + t * t);
                double s = c * t;
                for (int k = 0; k < n; ++k) {
                    double akp = A[k * n + p], akq = A[k * n + q];
                    A[k * n + p] = c * akp - s * akq;
                    A[k * n + q] = s * akp + c * akq;
                }
                for (int k = 0; k < n; ++k) {
                    double apk = A[p * n + k], aqk = A[q * n + k];
                    A[p * n + k] = c * apk - s * aqk;
                    A[q * n + k] = s * apk + c * aqk;
                }
                A[p * n + q] = A[q * n + p] = 0.0;
                for (int k = 0; k < n; ++k) {
                    double vkp = evecs[k * n + p], vkq = evecs[k * n + q];
                    evecs[k * n + p] = c * vkp - s * vkq;
                    evecs[k * n + q] = s * vkp + c * vkq;
                }
            }
        }
    }
    for (int i = 0; i < n; ++i) evals[i] = A[i * n + i];
}

int defsim__project_psd(int n, double *A, int mode)
{
    if ((mode != 1 && mode != 2) || n < 1 || n > DEFSIM__EIG_MAX_N) return 0;

    double W[DEFSIM__EIG_MAX_N * DEFSIM__EIG_MAX_N];
    double Q[DEFSIM__EIG_MAX_N * DEFSIM__EIG_MAX_N];
    double lam[DEFSIM__EIG_MAX_N];
    memcpy(W, A, (size_t)(n * n) * sizeof(double));
    defsim__sym_eig(n, W, lam, Q);

    int negative = 0;
    for (int k = 0; k < n; ++k) {
        if (lam[k] < 0.0) {
            negative = 1;
            lam[k] = (mode == 1) ? 0.0 : -lam[k];
        }
    }
    if (!negative) return 0;

    /* A = Q diag(lam) Q^T, computed once per pair and mirrored so that A stays symmetric. */
    for (int i = 0; i < n; ++i) {
        for (int j = i; j < n; ++j) {
            double s = 0.0;
            for (int k = 0; k < n; ++k) s += Q[i * n + k] * lam[k] * Q[j * n + k];
            A[i * n + j] = A[j * n + i] = s;
        }
    }
    return 1;
}
