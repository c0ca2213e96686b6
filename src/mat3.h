/* SPDX-License-Identifier: MIT */
/*
 * Small dense linear algebra for the material kernels.
 *
 * 3x3 matrices are row-major double[9]: A[3*i+j] = A_ij. The inline helpers write their result
 * through a temporary, so an output may alias an input. Larger symmetric matrices (element
 * Hessians, n <= 12) are row-major double[n*n].
 *
 * The formulas of the products, the cofactor matrix and its determinant are written once, as
 * the DEFSIM__M3_* macros over row-major arrays of any element type: double in the helpers here
 * and the scalar kernels (element.h), the SIMD vectors of tet_batch.h in the batched kernels,
 * one matrix per lane. Both thus compute the same expressions in the same order.
 */
#ifndef DEFSIM_MAT3_H
#define DEFSIM_MAT3_H

#include <string.h>

/* Largest n accepted by defsim__project_psd (a tet's 12 x 12 Hessian). */
#define DEFSIM__EIG_MAX_N 12

/* Entry (i, j) of A B, A^T B and A B^T. */
#define DEFSIM__M3_MUL(A, B, i, j)                                                            \
    ((A)[3 * (i)] * (B)[(j)] + (A)[3 * (i) + 1] * (B)[3 + (j)] + (A)[3 * (i) + 2] * (B)[6 + (j)])
#define DEFSIM__M3_MUL_TN(A, B, i, j)                                                         \
    ((A)[(i)] * (B)[(j)] + (A)[3 + (i)] * (B)[3 + (j)] + (A)[6 + (i)] * (B)[6 + (j)])
#define DEFSIM__M3_MUL_NT(A, B, i, j)                                                         \
    ((A)[3 * (i)] * (B)[3 * (j)] + (A)[3 * (i) + 1] * (B)[3 * (j) + 1] +                      \
     (A)[3 * (i) + 2] * (B)[3 * (j) + 2])

/* C = cof A = dJ/dA with J = det A (C = det(A) A^-T when A is invertible); C must not alias A. */
#define DEFSIM__M3_COFACTOR(A, C)                                                             \
    do {                                                                                      \
        (C)[0] = (A)[4] * (A)[8] - (A)[5] * (A)[7];                                           \
        (C)[1] = (A)[5] * (A)[6] - (A)[3] * (A)[8];                                           \
        (C)[2] = (A)[3] * (A)[7] - (A)[4] * (A)[6];                                           \
        (C)[3] = (A)[2] * (A)[7] - (A)[1] * (A)[8];                                           \
        (C)[4] = (A)[0] * (A)[8] - (A)[2] * (A)[6];                                           \
        (C)[5] = (A)[1] * (A)[6] - (A)[0] * (A)[7];                                           \
        (C)[6] = (A)[1] * (A)[5] - (A)[2] * (A)[4];                                           \
        (C)[7] = (A)[2] * (A)[3] - (A)[0] * (A)[5];                                           \
        (C)[8] = (A)[0] * (A)[4] - (A)[1] * (A)[3];                                           \
    } while (0)

/* det A from C = cof A (expansion along the first row). */
#define DEFSIM__M3_DET_COF(A, C) ((A)[0] * (C)[0] + (A)[1] * (C)[1] + (A)[2] * (C)[2])

/* 3-vectors: a . b, a x b and a - b (through a temporary: c may alias a or b). */
static inline double defsim__v3_dot(const double a[3], const double b[3])
{
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}

static inline void defsim__v3_cross(const double a[3], const double b[3], double c[3])
{
    const double t[3] = {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2],
                         a[0] * b[1] - a[1] * b[0]};
    memcpy(c, t, sizeof t);
}

static inline void defsim__v3_sub(const double a[3], const double b[3], double c[3])
{
    const double t[3] = {a[0] - b[0], a[1] - b[1], a[2] - b[2]};
    memcpy(c, t, sizeof t);
}

static inline void defsim__m3_identity(double A[9])
{
    static const double I[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1};
    memcpy(A, I, sizeof I);
}

static inline double defsim__m3_det(const double A[9])
{
    return A[0] * (A[4] * A[8] - A[5] * A[7]) - A[1] * (A[3] * A[8] - A[5] * A[6]) +
           A[2] * (A[3] * A[7] - A[4] * A[6]);
}

/* Cofactor matrix C = dJ/dA with J = det A (C = det(A) A^-T when A is invertible). */
static inline void defsim__m3_cofactor(const double A[9], double C[9])
{
    double c[9];
    DEFSIM__M3_COFACTOR(A, c);
    memcpy(C, c, sizeof c);
}

/* Ainv = A^-1; returns det A. When det A == 0, Ainv is set to zero. */
static inline double defsim__m3_inverse(const double A[9], double Ainv[9])
{
    double C[9];
    defsim__m3_cofactor(A, C);
    double det = DEFSIM__M3_DET_COF(A, C);
    if (det == 0.0) {
        memset(Ainv, 0, 9 * sizeof(double));
        return det;
    }
    double r = 1.0 / det;
    double inv[9] = {C[0] * r, C[3] * r, C[6] * r, C[1] * r, C[4] * r,
                     C[7] * r, C[2] * r, C[5] * r, C[8] * r};
    memcpy(Ainv, inv, sizeof inv);
    return det;
}

static inline void defsim__m3_transpose(const double A[9], double At[9])
{
    double t[9] = {A[0], A[3], A[6], A[1], A[4], A[7], A[2], A[5], A[8]};
    memcpy(At, t, sizeof t);
}

static inline double defsim__m3_trace(const double A[9])
{
    return A[0] + A[4] + A[8];
}

/* A : B = tr(A^T B) = sum_ij A_ij B_ij. */
static inline double defsim__m3_ddot(const double A[9], const double B[9])
{
    double s = 0.0;
    for (int i = 0; i < 9; ++i) s += A[i] * B[i];
    return s;
}

/* C = A B, A^T B and A B^T: one body over the entry formula. */
#define DEFSIM__M3_PRODUCT_FN(name, ENTRY)                                                    \
    static inline void name(const double A[9], const double B[9], double C[9])                \
    {                                                                                         \
        double c[9];                                                                          \
        for (int i = 0; i < 3; ++i)                                                           \
            for (int j = 0; j < 3; ++j) c[3 * i + j] = ENTRY(A, B, i, j);                     \
        memcpy(C, c, sizeof c);                                                               \
    }
DEFSIM__M3_PRODUCT_FN(defsim__m3_mul, DEFSIM__M3_MUL)         /* C = A B */
DEFSIM__M3_PRODUCT_FN(defsim__m3_mul_tn, DEFSIM__M3_MUL_TN)   /* C = A^T B */
DEFSIM__M3_PRODUCT_FN(defsim__m3_mul_nt, DEFSIM__M3_MUL_NT)   /* C = A B^T */

/*
 * Signed SVD: F = U diag(sigma) V^T with U and V proper rotations (det +1). sigma is sorted by
 * decreasing magnitude; sigma[0] >= sigma[1] >= 0, and sigma[2] < 0 exactly when det F < 0.
 * Robust for any finite F (zero, rank-deficient, repeated singular values, inverted): never
 * produces NaN. One-sided Jacobi, so small singular values keep their relative accuracy.
 */
void defsim__svd3(const double F[9], double U[9], double sigma[3], double V[9]);

/*
 * Eigen-decomposition of the symmetric n x n row-major matrix A (1 <= n <= 12; only the upper
 * triangle is read): Householder tridiagonalisation and implicit QR. A is destroyed. evals[k]
 * is the k-th eigenvalue (in no particular order) and column k of evecs (evecs[i*n+k]) its unit
 * eigenvector.
 */
void defsim__sym_eig(int n, double *A, double *evals, double *evecs);

/*
 * Makes the symmetric n x n matrix A (1 <= n <= DEFSIM__EIG_MAX_N) positive semi-definite:
 * mode 1 (clamp) replaces it by V max(Lambda, 0) V^T, mode 2 (abs) by V |Lambda| V^T; mode 0 and
 * other modes or sizes do nothing. Returns 1 if A was changed (it had a negative eigenvalue),
 * else 0, in which case A is left bit-for-bit as it was.
 */
int defsim__project_psd(int n, double *A, int mode);

/*
 * defsim__project_psd for the Hessian H (nd x nd, row-major) of an energy of m (2 <= m <= 4)
 * vertices that translations leave unchanged (a contact pair, a hinge), whose nonzero 3 x 3
 * blocks are those of the vertices `nodes` (indices of 3 x 3 blocks): the same projection,
 * computed in the (3m - 3)-dimensional translation-free subspace, where the eigenproblem is
 * (m - 1)^3 / m^3 as costly. Returns 1 if H was changed (the projected matrix then has exactly
 * zero translation components), else 0 and H is left as it was.
 */
int defsim__project_psd_nodes(int nd, double *H, int m, const int *nodes, int mode);

/* Node weights of an orthonormal basis of the vectors over m (2 <= m <= 4) nodes orthogonal to
 * (1, ..., 1): basis vector k (k < m - 1) is defsim__node_basis[m][k][0 .. m - 1]. */
extern const double defsim__node_basis[5][3][4];

#endif /* DEFSIM_MAT3_H */
