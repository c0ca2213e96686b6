/* SPDX-License-Identifier: MIT */
/*
 * Batched (SIMD) elastic force kernels, one per tet model (material_list.h) and per shell group
 * (the membrane laws and the hinges, shell_batch.c), compiled once per instruction set and
 * chosen once at plan time (plan.c). The batch layout is shared by all variants: each colour of
 * a group is cut into batches of DEFSIM__BATCH elements, the last one padded with copies of its
 * first element that are computed but never scattered.
 */
#ifndef DEFSIM_TET_FORCES_H
#define DEFSIM_TET_FORCES_H

#include "system.h"

#include <stdint.h>

/* Names of per-instruction-set symbols: DEFSIM__CAT(defsim__tet_kernels_, DEFSIM_ISA). */
#ifndef DEFSIM_ISA
#define DEFSIM_ISA generic
#endif
#define DEFSIM__CAT2(a, b) a##b
#define DEFSIM__CAT(a, b) DEFSIM__CAT2(a, b)
#define DEFSIM__STR2(a) #a
#define DEFSIM__STR(a) DEFSIM__STR2(a)

/* Lanes per batch (the widest vector, AVX-512, has 8 doubles; narrower ISAs do sub-batches). */
#define DEFSIM__BATCH 8

/* Rows of a batch's data block, each DEFSIM__BATCH doubles (64-byte aligned): Dm^-1 row-major,
 * -volume, then the model's parameters (mu, lambda; stable neo-Hookean: mu', lambda', alpha). */
enum {
    DEFSIM__ROW_DMINV = 0,
    DEFSIM__ROW_NVOL = 9,
    DEFSIM__ROW_P0 = 10,
    DEFSIM__ROW_P1 = 11,
    DEFSIM__ROW_P2 = 12,
    DEFSIM__BATCH_ROWS = 13
};

/* Rows of a quadratic (10-node, tet10.h) tet's batch: -w_q (the weight times det dX/dxi) of the
 * 4 quadrature points, psi_rest (the law's energy density at F = I, subtracted from the
 * energy), the user's lambda (the split laws' U, material.h), 4 unused rows, the model's parameters at the linear layout's rows (so
 * that the lane-wise laws read them unchanged), then the gradients dN_a/dX_j of point q at row
 * DEFSIM__QROW_G + 30 q + 3 a + j. */
enum {
    DEFSIM__QROW_NW = 0,
    DEFSIM__QROW_REST = 4,
    DEFSIM__QROW_LAMBDA = 5,
    DEFSIM__QROW_G = 13,
    DEFSIM__QBATCH_ROWS = 13 + 4 * 30
};

/* The rows of the shells' batches: a membrane triangle's Dm^-1 (2x2 row-major), -area and its
 * law's four parameters (shell.h); a hinge's weight and rest angle. */
enum {
    DEFSIM__SROW_DMINV = 0,
    DEFSIM__SROW_NAREA = 4,
    DEFSIM__SROW_P = 5,
    DEFSIM__SROW_W = 0,
    DEFSIM__SROW_THETA0 = 1
};

typedef void (*defsim__tet_force_fn)(const defsim__group *g, const double *x, double *f,
                                     int nthreads);

/* The elastic energy of batches [b0, b1) of a group at x (J), relative to rest. */
typedef double (*defsim__tet_energy_fn)(const defsim__group *g, const double *x, int32_t b0,
                                        int32_t b1);

typedef struct defsim__tet_kernels {
    const char *name;       /* "generic", "avx2", "avx512" */
    /* Adds the elastic forces of group g at positions x into f, by model (STVK, COROTATED,
     * NEOHOOKEAN, STABLE_NEOHOOKEAN). */
    defsim__tet_force_fn forces[DEFSIM__TET_MODELS];
    /* R[9 e ..] = the rotation of SO(3) closest to F[9 e ..] (maximising tr(R^T F)), for n
     * row-major matrices: the co-rotated kernel's polar decomposition, exposed for tests. */
    void (*rotation)(int32_t n, const double *F, double *R);
    /* Adds the forces of a shell group (system.h's shells: DEFSIM__MEMBRANE_STVK,
     * DEFSIM__MEMBRANE_NEOHOOKEAN, DEFSIM__SHELL_HINGES) at x into f (shell_batch.c). */
    defsim__tet_force_fn shells[DEFSIM__SHELL_LIMITS];
    /* Adds the elastic forces of a group of quadratic tets (not mean-dilatation ones) at x into
     * f, by model as forces[] (the DEFSIM__QBATCH_ROWS layout). */
    defsim__tet_force_fn qforces[DEFSIM__TET_MODELS];
    /* The energy of a group of quadratic tets (not mean-dilatation ones), by model as forces[]:
     * summed batch by batch in batch order, its +INFINITY where the scalar law's is. */
    defsim__tet_energy_fn qenergy[DEFSIM__TET_MODELS];
    /* The forces and the energy of a group of mean-dilatation quadratic tets
     * (term_quadratic_mixed.c), by model as forces[]; NULL for a model without a split
     * (material.h: StVK, co-rotated), whose bodies cannot have volume_averaging. */
    defsim__tet_force_fn qmforces[DEFSIM__TET_MODELS];
    defsim__tet_energy_fn qmenergy[DEFSIM__TET_MODELS];
} defsim__tet_kernels;

extern const defsim__tet_kernels defsim__tet_kernels_generic;
#if defined(DEFSIM_HAVE_X86_KERNELS)
extern const defsim__tet_kernels defsim__tet_kernels_avx2;
extern const defsim__tet_kernels defsim__tet_kernels_avx512;
#endif

/* The fastest variant this CPU runs. */
const defsim__tet_kernels *defsim__tet_kernels_best(void);

/* The variant of that name if it is built and this CPU runs it, else NULL. */
const defsim__tet_kernels *defsim__tet_kernels_find(const char *name);

#endif /* DEFSIM_TET_FORCES_H */
