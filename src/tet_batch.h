/* SPDX-License-Identifier: MIT */
/*
 * The machinery of batched (SIMD) tet force kernels, shared by the per-instruction-set compiles
 * of the material files (material_<name>.c with DEFSIM_ISA defined) and tet_forces.c: gather,
 * F = Ds Dm^-1 and the scatter of forces lane-wise, and the kernel skeleton around a model's
 * law. The laws are those of the scalar models, rewritten lane-wise: same formulas, same
 * conventions (DESIGN.md section 4). Results differ from the scalar kernels only by rounding:
 * the vector log is fdlibm's algorithm (within 1 ulp of libm), and the FMA-capable variants
 * contract a*b+c (-ffp-contract=fast), so machines with different instruction sets differ in
 * the last bits. On one machine a variant is deterministic, whatever the thread count: every
 * lane's arithmetic depends on its own element only, and the scatter order is the colour order.
 */
#ifndef DEFSIM_TET_BATCH_H
#define DEFSIM_TET_BATCH_H

#include "mat3.h"
#include "simd.h"
#include "tet_forces.h"

#include <stddef.h>
#include <string.h>

enum {
    NSUB = DEFSIM__BATCH / DEFSIM_VW,          /* vectors per batch */
    PAR_MIN_BATCHES = 1024 / DEFSIM__BATCH     /* same threshold as the scalar kernels */
};

/* Row r of a batch's data block d, lanes of sub-batch s. */
#define ROW(d, r, s) ((d) + (r) * DEFSIM__BATCH + (s) * DEFSIM_VW)

/* ------------------------------------------------------------------------------------------ */
/* Shared batch machinery: gather, F = Ds Dm^-1, forces h_a = -vol P g_a, scatter.             */

/* The three coordinates of the lanes' vertices id[0 .. VW-1] (on Zen 4, row loads and
 * transposes measured faster than hardware gathers). */
DEFSIM_SIMD_INLINE void gather3(const double *x, const int32_t *id, vd p[3])
{
    const double *rows[DEFSIM_VW];
    for (int l = 0; l < DEFSIM_VW; ++l) rows[l] = x + 3 * (int64_t)id[l];
    v_gather_rows3(rows, p);
}

/* F = Ds Dm^-1 with Ds = [x0 - x3, x1 - x3, x2 - x3] for the lanes of sub-batch s. */
DEFSIM_SIMD_INLINE void batch_deformation(const double *x, const int32_t *id, const double *d,
                                          int s, vd dm[9], vd F[9])
{
    for (int r = 0; r < 9; ++r) dm[r] = v_load(ROW(d, DEFSIM__ROW_DMINV + r, s));
    vd p[4][3], ds[9];
    for (int a = 0; a < 4; ++a) gather3(x, id + a * DEFSIM__BATCH + s * DEFSIM_VW, p[a]);
    for (int i = 0; i < 3; ++i)
        for (int a = 0; a < 3; ++a) ds[3 * i + a] = p[a][i] - p[3][i];
    for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j)
            F[3 * i + j] = DEFSIM__M3_MUL(ds, dm, i, j);
}

/* h_a[i] = -vol sum_j P_ij Dminv[a][j], h_3 = -(h_0 + h_1 + h_2), added to the forces of the
 * first nl lanes. Elements of a colour share no vertex, so neither do lanes. */
DEFSIM_SIMD_INLINE void batch_scatter(double *f, const int32_t *id, const vd P[9],
                                      const vd dm[9], vd nvol, int nl)
{
    vd h[4][3];
    for (int a = 0; a < 3; ++a)
        for (int i = 0; i < 3; ++i)
            h[a][i] = nvol * DEFSIM__M3_MUL_NT(P, dm, i, a);
    for (int i = 0; i < 3; ++i) h[3][i] = -(h[0][i] + h[1][i] + h[2][i]);
    for (int a = 0; a < 4; ++a) {
        double *rows[DEFSIM_VW];
        for (int l = 0; l < DEFSIM_VW; ++l) rows[l] = f + 3 * (int64_t)id[a * DEFSIM__BATCH + l];
        v_scatter_add_rows3(rows, h[a], nl);
    }
}

/* The loop of a batched kernel over group g's batches (g->nodes ids per lane), colour by colour
 * (the lanes of a colour share no vertex, so their scatters need no atomics), the batches of a
 * colour in parallel: the body (the arguments after g) runs for each sub-batch s with real
 * lanes, with id (the batch's vertex ids: id[a DEFSIM__BATCH + lane]), d (its data rows) and nl
 * (the real lanes from s on) in scope. Needs `nthreads` in scope. */
#define DEFSIM__BATCH_LOOP(g, ...) DEFSIM__BATCH_LOOP_ROWS(g, DEFSIM__BATCH_ROWS, __VA_ARGS__)

/* The same loop over batches of `rows` data rows (a quadratic group's: DEFSIM__QBATCH_ROWS). */
#define DEFSIM__BATCH_LOOP_ROWS(g, rows, ...)                                                 \
    for (int32_t c = 0; c < (g)->ncolors; ++c) {                                              \
        const int32_t b0 = (g)->bcolor_ptr[c], b1 = (g)->bcolor_ptr[c + 1];                   \
        _Pragma("omp parallel for schedule(static) num_threads(nthreads) if(b1 - b0 > PAR_MIN_BATCHES)") \
        for (int32_t b = b0; b < b1; ++b) {                                                   \
            const int32_t *id = (g)->bidx + (g)->nodes * DEFSIM__BATCH * (int64_t)b;          \
            const double *d = (g)->bdata + (rows) * DEFSIM__BATCH * (int64_t)b;             \
            for (int s = 0; s < NSUB && s * DEFSIM_VW < (g)->blanes[b]; ++s) {                \
                const int nl = (g)->blanes[b] - s * DEFSIM_VW;                                \
                __VA_ARGS__                                                                   \
            }                                                                                 \
        }                                                                                     \
    }

/* The batched kernel of model `name` for this instruction set, defsim__batched_<name>_<isa>
 * (listed in tet_forces.c's table): LAW(d, s, F, P) computes P for the lanes of sub-batch s. */
#define DEFSIM__BATCHED_KERNEL(name, LAW)                                                     \
    void DEFSIM__CAT(defsim__batched_##name##_, DEFSIM_ISA)(const defsim__group *g,          \
                                                           const double *x, double *f,       \
                                                           int nthreads)                     \
    {                                                                                         \
        (void)nthreads;                                                                       \
        DEFSIM__BATCH_LOOP(g, {                                                               \
            vd dm[9], F[9], P[9];                                                             \
            batch_deformation(x, id, d, s, dm, F);                                            \
            LAW(d, s, F, P);                                                                  \
            batch_scatter(f, id + s * DEFSIM_VW, P, dm, v_load(ROW(d, DEFSIM__ROW_NVOL, s)),  \
                          nl);                                                                \
        })                                                                                    \
    }

/* Node a's gradients dN_a/dX_j at one quadrature point of a quadratic batch (G: its first
 * gradient row, lanes of the sub-batch). */
DEFSIM_SIMD_INLINE void qgrad(const double *G, int a, vd g[3])
{
    for (int j = 0; j < 3; ++j) g[j] = v_load(G + (3 * a + j) * DEFSIM__BATCH);
}

/* The lanes' ten nodes (id: the sub-batch's first node's ids, id[a DEFSIM__BATCH + lane]). */
DEFSIM_SIMD_INLINE void qgather(const double *x, const int32_t *id, vd p[10][3])
{
    for (int a = 0; a < 10; ++a) gather3(x, id + a * DEFSIM__BATCH, p[a]);
}

/* F = sum_a x_a G_a^T at one quadrature point (G as qgrad's) from the lanes' ten nodes p. */
DEFSIM_SIMD_INLINE void qdeformation(const vd p[10][3], const double *G, vd F[9])
{
    for (int r = 0; r < 9; ++r) F[r] = v_set1(0.0);
    for (int a = 0; a < 10; ++a) {
        vd gr[3];
        qgrad(G, a, gr);
        for (int i = 0; i < 3; ++i) {
            F[3 * i] += p[a][i] * gr[0];
            F[3 * i + 1] += p[a][i] * gr[1];
            F[3 * i + 2] += p[a][i] * gr[2];
        }
    }
}

/* h_a += P G_a for the ten nodes at one point (G as qgrad's; P scaled by -w_q: forces). */
DEFSIM_SIMD_INLINE void qnodal(const double *G, const vd P[9], vd h[10][3])
{
    for (int a = 0; a < 10; ++a) {
        vd gr[3];
        qgrad(G, a, gr);
        for (int i = 0; i < 3; ++i)
            h[a][i] += P[3 * i] * gr[0] + P[3 * i + 1] * gr[1] + P[3 * i + 2] * gr[2];
    }
}

/* Adds the nodal forces h of the ten nodes to f for the first nl lanes (id: the sub-batch's
 * first node's ids, id[a DEFSIM__BATCH + lane]). */
DEFSIM_SIMD_INLINE void qscatter(double *f, const int32_t *id, const vd h[10][3], int nl)
{
    for (int a = 0; a < 10; ++a) {
        double *rows[DEFSIM_VW];
        for (int l = 0; l < DEFSIM_VW; ++l) rows[l] = f + 3 * (int64_t)id[a * DEFSIM__BATCH + l];
        v_scatter_add_rows3(rows, h[a], nl);
    }
}

/* *sum += the first nl lanes of e (lane order; padding lanes never). */
DEFSIM_SIMD_INLINE void qlanes_add(vd e, int nl, double *sum)
{
    for (int l = 0; l < DEFSIM_VW && l < nl; ++l) *sum += e[l];
}

/* The batched kernel of model `name` for quadratic tets (tet10.h), defsim__batched_q<name>_<isa>,
 * over the DEFSIM__QBATCH_ROWS layout with the linear kernel's LAW: per lane the ten nodes
 * gathered once, at each of the 4 quadrature points F = sum_a x_a G_a^T (the order of
 * defsim__tet10_F) and P = LAW(F), the nodal forces -w_q P G_a summed over the points, then
 * scattered once (the scalar kernel scatters point by point: the same sums to rounding). */
#define DEFSIM__BATCHED_QKERNEL(name, LAW)                                                    \
    void DEFSIM__CAT(defsim__batched_q##name##_, DEFSIM_ISA)(const defsim__group *g,         \
                                                            const double *x, double *f,      \
                                                            int nthreads)                    \
    {                                                                                         \
        (void)nthreads;                                                                       \
        DEFSIM__BATCH_LOOP_ROWS(g, DEFSIM__QBATCH_ROWS, {                                     \
            vd p[10][3], h[10][3];                                                            \
            qgather(x, id + s * DEFSIM_VW, p);                                                \
            for (int a = 0; a < 10; ++a) h[a][0] = h[a][1] = h[a][2] = v_set1(0.0);           \
            for (int q = 0; q < 4; ++q) {                                                     \
                const double *G = ROW(d, DEFSIM__QROW_G + 30 * q, s);                         \
                vd F[9], P[9];                                                                \
                qdeformation((const vd(*)[3])p, G, F);                                        \
                LAW(d, s, F, P);                                                              \
                const vd nw = v_load(ROW(d, DEFSIM__QROW_NW + q, s));                         \
                for (int i = 0; i < 9; ++i) P[i] *= nw;                                       \
                qnodal(G, P, h);                                                              \
            }                                                                                 \
            qscatter(f, id + s * DEFSIM_VW, (const vd(*)[3])h, nl);                           \
        })                                                                                    \
    }

/* The sequential loop of a batched energy over batches [b0, b1) of quadratic group g, in batch
 * order: the body runs for each sub-batch s with real lanes, with id, d and nl in scope as in
 * DEFSIM__BATCH_LOOP. */
#define DEFSIM__QBATCH_SUM(g, b0, b1, ...)                                                    \
    for (int32_t b = (b0); b < (b1); ++b) {                                                   \
        const int32_t *id = (g)->bidx + 10 * DEFSIM__BATCH * (int64_t)b;                      \
        const double *d = (g)->bdata + DEFSIM__QBATCH_ROWS * DEFSIM__BATCH * (int64_t)b;      \
        for (int s = 0; s < NSUB && s * DEFSIM_VW < (g)->blanes[b]; ++s) {                    \
            const int nl = (g)->blanes[b] - s * DEFSIM_VW;                                    \
            __VA_ARGS__                                                                       \
        }                                                                                     \
    }

/* The batched energy of model `name` for quadratic tets, defsim__batched_qenergy_<name>_<isa>
 * (tet_forces.h's qenergy): the sum over batches [b0, b1) of group g, in batch order, each
 * batch's real lanes in lane order, of sum_q w_q (PSI(d, s, F_q) - psi_rest) (the scalar
 * element energy of term_elastic_quadratic.c: its points in the same order, to rounding). A
 * padding lane is never added. */
#define DEFSIM__BATCHED_QENERGY(name, PSI)                                                    \
    double DEFSIM__CAT(defsim__batched_qenergy_##name##_, DEFSIM_ISA)(                        \
        const defsim__group *g, const double *x, int32_t b0, int32_t b1)                      \
    {                                                                                         \
        double sum = 0.0;                                                                     \
        DEFSIM__QBATCH_SUM(g, b0, b1, {                                                       \
            vd p[10][3], e = v_set1(0.0);                                                     \
            qgather(x, id + s * DEFSIM_VW, p);                                                \
            const vd rest = v_load(ROW(d, DEFSIM__QROW_REST, s));                             \
            for (int q = 0; q < 4; ++q) {                                                     \
                vd F[9];                                                                      \
                qdeformation((const vd(*)[3])p, ROW(d, DEFSIM__QROW_G + 30 * q, s), F);       \
                e -= v_load(ROW(d, DEFSIM__QROW_NW + q, s)) * (PSI(d, s, F) - rest);          \
            }                                                                                 \
            qlanes_add(e, nl, &sum);                                                          \
        })                                                                                    \
        return sum;                                                                           \
    }

/* The mean-dilatation quadratic tets (term_quadratic_mixed.c) of a model with a split psi =
 * psi_iso(F) + U(J) (material.h), defsim__batched_qmixed_<name>_<isa> (forces) and
 * defsim__batched_qmixed_energy_<name>_<isa> (energy), over the DEFSIM__QBATCH_ROWS layout:
 * ISO(d, s, F, C, J, P) gives psi_iso and P_iso at F (C = cof F, J = det F), VOL(d, s, Jbar, u)
 * u[0] = U, u[1] = U' at the element's Jbar = sum_q w_q J_q / V, V = sum_q w_q (the order of
 * tet10.c's defsim__tet10_mixed). Forces -sum_q w_q (P_iso(F_q) + U'(Jbar) cof F_q) G_qa
 * scattered once per element; energy sum_q w_q psi_iso(F_q) + V (U(Jbar) - psi_rest), summed as
 * DEFSIM__BATCHED_QENERGY's. */
#define DEFSIM__BATCHED_QMIXED(name, ISO, VOL)                                                \
    /* The lanes' points: P_iso + p cof F of each (P), sum_q w_q psi_iso (*iso), V, u. */     \
    DEFSIM_SIMD_INLINE void qmixed_points_##name(const double *x, const int32_t *id,          \
                                                 const double *d, int s, vd P[4][9], vd *iso, \
                                                 vd *V, vd u[2])                              \
    {                                                                                         \
        vd p[10][3], C[4][9], jv = v_set1(0.0);                                               \
        qgather(x, id + s * DEFSIM_VW, p);                                                    \
        *iso = *V = v_set1(0.0);                                                              \
        for (int q = 0; q < 4; ++q) {                                                         \
            vd F[9];                                                                          \
            qdeformation((const vd(*)[3])p, ROW(d, DEFSIM__QROW_G + 30 * q, s), F);           \
            cofactor(F, C[q]);                                                                \
            const vd J = DEFSIM__M3_DET_COF(F, C[q]);                                         \
            const vd w = -v_load(ROW(d, DEFSIM__QROW_NW + q, s));                             \
            *V += w;                                                                          \
            jv += w * J;                                                                      \
            *iso += w * ISO(d, s, F, C[q], J, P[q]);                                          \
        }                                                                                     \
        VOL(d, s, jv / *V, u);                                                                \
        for (int q = 0; q < 4; ++q)                                                           \
            for (int i = 0; i < 9; ++i) P[q][i] += u[1] * C[q][i];                            \
    }                                                                                         \
    void DEFSIM__CAT(defsim__batched_qmixed_##name##_, DEFSIM_ISA)(const defsim__group *g,   \
                                                                  const double *x, double *f, \
                                                                  int nthreads)               \
    {                                                                                         \
        (void)nthreads;                                                                       \
        DEFSIM__BATCH_LOOP_ROWS(g, DEFSIM__QBATCH_ROWS, {                                     \
            vd P[4][9], iso, V, u[2], h[10][3];                                               \
            qmixed_points_##name(x, id, d, s, P, &iso, &V, u);                                \
            for (int a = 0; a < 10; ++a) h[a][0] = h[a][1] = h[a][2] = v_set1(0.0);           \
            for (int q = 0; q < 4; ++q) {                                                     \
                const double *G = ROW(d, DEFSIM__QROW_G + 30 * q, s);                         \
                const vd nw = v_load(ROW(d, DEFSIM__QROW_NW + q, s));                         \
                for (int i = 0; i < 9; ++i) P[q][i] *= nw;                                    \
                qnodal(G, P[q], h);                                                           \
            }                                                                                 \
            qscatter(f, id + s * DEFSIM_VW, (const vd(*)[3])h, nl);                           \
        })                                                                                    \
    }                                                                                         \
    double DEFSIM__CAT(defsim__batched_qmixed_energy_##name##_, DEFSIM_ISA)(                  \
        const defsim__group *g, const double *x, int32_t b0, int32_t b1)                      \
    {                                                                                         \
        double sum = 0.0;                                                                     \
        DEFSIM__QBATCH_SUM(g, b0, b1, {                                                       \
            vd P[4][9], iso, V, u[2];                                                         \
            qmixed_points_##name(x, id, d, s, P, &iso, &V, u);                                \
            const vd e = iso + V * (u[0] - v_load(ROW(d, DEFSIM__QROW_REST, s)));             \
            qlanes_add(e, nl, &sum);                                                          \
        })                                                                                    \
        return sum;                                                                           \
    }

/* ------------------------------------------------------------------------------------------ */
/* Shared by the lane-wise laws of the material files: mat3.h's formulas over vd (the products
 * are used as DEFSIM__M3_MUL and friends directly).                                           */

/* |A|^2 = A : A, lane by lane. */
DEFSIM_SIMD_INLINE vd frob2(const vd A[9])
{
    vd s = A[0] * A[0];
    for (int i = 1; i < 9; ++i) s += A[i] * A[i];
    return s;
}

/* C = cof A, lane by lane (C must not alias A). */
DEFSIM_SIMD_INLINE void cofactor(const vd A[9], vd C[9])
{
    DEFSIM__M3_COFACTOR(A, C);
}

#endif /* DEFSIM_TET_BATCH_H */
