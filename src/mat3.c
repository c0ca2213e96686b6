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

/* Eigenvalues lam and eigenvectors (the columns of V, n x n row-major) of the symmetric n x n
 * matrix A (full, symmetric; destroyed). Householder reduction to tridiagonal form with the
 * reflections accumulated in V, then implicit symmetric QR steps with Wilkinson shifts on the
 * unreduced blocks, the Givens rotations accumulated in V (Golub and Van Loan, Matrix
 * Computations, 4th ed., 8.3.1 and 8.3.3). About 9 n^3 flops: for n = 12 some ten times fewer
 * than the cyclic Jacobi sweeps this replaced. */
static void householder_qr(int n, double *A, double *lam, double *V)
{
    double e[DEFSIM__EIG_MAX_N], v[DEFSIM__EIG_MAX_N], p[DEFSIM__EIG_MAX_N];
    for (int i = 0; i < n; ++i)
        for (int j = 0; j < n; ++j) V[i * n + j] = i == j;
    for (int k = 0; k + 2 < n; ++k) {
        /* The reflection I - beta v v^T that maps A[k+1.., k] onto a multiple of e_{k+1},
         * computed from the column divided by its largest entry (so that no square under- or
         * overflows: a hinge at rest has entries from 1 down to 1e-322); v is scale-free. */
        const double x0 = A[(k + 1) * n + k];
        double big = 0.0;
        for (int i = k + 2; i < n; ++i) big = fmax(big, fabs(A[i * n + k]));
        if (big == 0.0) {
            e[k] = x0;
            continue;
        }
        big = fmax(big, fabs(x0));
        double tail = 0.0;
        for (int i = k + 2; i < n; ++i) {
            v[i] = A[i * n + k] / big;
            tail += v[i] * v[i];
        }
        const double u0 = x0 / big, norm = sqrt(u0 * u0 + tail);
        const double alpha = u0 > 0.0 ? -norm : norm;
        v[k + 1] = u0 - alpha;
        const double beta = 2.0 / (v[k + 1] * v[k + 1] + tail);
        /* A22 <- P A22 P: p = beta A22 v, w = p - (beta p.v / 2) v, A22 -= v w^T + w v^T. */
        double pv = 0.0;
        for (int i = k + 1; i < n; ++i) {
            double s = 0.0;
            for (int j = k + 1; j < n; ++j) s += A[i * n + j] * v[j];
            p[i] = beta * s;
            pv += p[i] * v[i];
        }
        const double kk = 0.5 * beta * pv;
        for (int i = k + 1; i < n; ++i) p[i] -= kk * v[i];
        for (int i = k + 1; i < n; ++i)
            for (int j = k + 1; j < n; ++j) A[i * n + j] -= v[i] * p[j] + p[i] * v[j];
        e[k] = alpha * big;
        /* V <- V P */
        for (int i = 0; i < n; ++i) {
            double s = 0.0;
            for (int j = k + 1; j < n; ++j) s += V[i * n + j] * v[j];
            s *= beta;
            for (int j = k + 1; j < n; ++j) V[i * n + j] -= s * v[j];
        }
    }
    for (int i = 0; i < n; ++i) lam[i] = A[i * n + i];
    if (n >= 2) e[n - 2] = A[(n - 1) * n + n - 2];
    /* Implicit QR on the tridiagonal (lam, e). */
    for (int iter = 0; iter < 60 * n; ++iter) {
        for (int i = 0; i + 1 < n; ++i)
            if (fabs(e[i]) <= DBL_EPSILON * (fabs(lam[i]) + fabs(lam[i + 1])) ||
                fabs(e[i]) < DBL_MIN)
                e[i] = 0.0;
        int hi = n - 1;
        while (hi > 0 && e[hi - 1] == 0.0) --hi;
        if (hi == 0) break;
        int lo = hi - 1;
        while (lo > 0 && e[lo - 1] != 0.0) --lo;
        /* Wilkinson shift from the trailing 2 x 2 block. */
        const double dd = 0.5 * (lam[hi - 1] - lam[hi]), eh = e[hi - 1];
        const double mu = lam[hi] - eh * eh / (dd + copysign(hypot(dd, eh), dd));
        double x = lam[lo] - mu, z = e[lo];
        for (int k = lo; k < hi; ++k) {
            /* The rotation J (J[k][k] = J[k+1][k+1] = c, J[k][k+1] = s = -J[k+1][k]) that
             * zeroes z against x: at k = lo the shifted first column, later the bulge. */
            /* hypot: x and z may be so small that their squares underflow (entries 1e-160
             * beside 1 come from a hinge at rest); x = z = 0: no rotation */
            const double rr = hypot(x, z);
            const double c = rr > 0.0 ? x / rr : 1.0, s = rr > 0.0 ? -z / rr : 0.0;
            if (k > lo) e[k - 1] = c * x - s * z;
            const double a = lam[k], b = e[k], d = lam[k + 1];
            lam[k] = c * c * a - 2.0 * c * s * b + s * s * d;
            lam[k + 1] = s * s * a + 2.0 * c * s * b + c * c * d;
            e[k] = c * s * (a - d) + (c * c - s * s) * b;
            if (k + 1 < hi) {
                z = -s * e[k + 1];
                e[k + 1] *= c;
                x = e[k];
            }
            for (int i = 0; i < n; ++i) {
                const double q0 = V[i * n + k], q1 = V[i * n + k + 1];
                V[i * n + k] = c * q0 - s * q1;
                V[i * n + k + 1] = s * q0 + c * q1;
            }
        }
    }
}


void defsim__sym_eig(int n, double *A, double *evals, double *evecs)
{
    /* The upper triangle, mirrored; scaled by the power of two nearest its largest entry (exact,
     * so eigenvalues and vectors are those of A) so that no square under- or overflows. */
    double m = 0.0;
    for (int i = 0; i < n; ++i)
        for (int j = i; j < n; ++j) {
            A[j * n + i] = A[i * n + j];
            m = fmax(m, fabs(A[i * n + j]));
        }
    int e2 = 0;
    const int scaled = m > 0.0 && isfinite(m);
    if (scaled) {
        e2 = ilogb(m);
        for (int i = 0; i < n * n; ++i) A[i] = scalbn(A[i], -e2);
    }
    householder_qr(n, A, evals, evecs);
    if (scaled)
        for (int k = 0; k < n; ++k) evals[k] = scalbn(evals[k], e2);
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

/* Node weights of an orthonormal basis of the vectors over m nodes orthogonal to (1, ..., 1):
 * basis vector k is defsim__node_basis[m][k][0 .. m - 1]. */
const double defsim__node_basis[5][3][4] = {
    {{0}},
    {{0}},
    {{0.70710678118654752, -0.70710678118654752}},
    {{0.70710678118654752, -0.70710678118654752, 0.0},
     {0.40824829046386302, 0.40824829046386302, -0.81649658092772603}},
    {{0.5, 0.5, -0.5, -0.5}, {0.5, -0.5, 0.5, -0.5}, {0.5, -0.5, -0.5, 0.5}},
};

int defsim__project_psd_nodes(int nd, double *H, int m, const int *nodes, int mode)
{
    if ((mode != 1 && mode != 2) || m < 2 || m > 4) return 0;
    const int r = 3 * (m - 1);
    const double(*h)[4] = defsim__node_basis[m];
    /* B = P^T H P with P = [h_k (x) I3] placed on `nodes` */
    double C[DEFSIM__EIG_MAX_N][9], B[81];
    for (int row = 0; row < nd; ++row)
        for (int k = 0; k < m - 1; ++k)
            for (int b = 0; b < 3; ++b) {
                double s = 0.0;
                for (int j = 0; j < m; ++j) s += H[row * nd + 3 * nodes[j] + b] * h[k][j];
                C[row][3 * k + b] = s;
            }
    for (int k = 0; k < m - 1; ++k)
        for (int a = 0; a < 3; ++a)
            for (int col = 0; col < r; ++col) {
                double s = 0.0;
                for (int i = 0; i < m; ++i) s += h[k][i] * C[3 * nodes[i] + a][col];
                B[(3 * k + a) * r + col] = s;
            }
    for (int i = 0; i < r; ++i)
        for (int j = 0; j < i; ++j)
            B[i * r + j] = B[j * r + i] = 0.5 * (B[i * r + j] + B[j * r + i]);
    if (!defsim__project_psd(r, B, mode)) return 0;
    /* H = P B P^T on the vertices' blocks */
    memset(H, 0, (size_t)(nd * nd) * sizeof *H);
    for (int i = 0; i < m; ++i)
        for (int j = i; j < m; ++j)
            for (int a = 0; a < 3; ++a)
                for (int b = i == j ? a : 0; b < 3; ++b) {
                    double s = 0.0;
                    for (int k = 0; k < m - 1; ++k)
                        for (int l = 0; l < m - 1; ++l)
                            s += h[k][i] * h[l][j] * B[(3 * k + a) * r + 3 * l + b];
                    H[(3 * nodes[i] + a) * nd + 3 * nodes[j] + b] = s;
                    H[(3 * nodes[j] + b) * nd + 3 * nodes[i] + a] = s;
                }
    return 1;
}
