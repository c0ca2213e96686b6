/* SPDX-License-Identifier: MIT */
/*
 * The table of batched elastic force kernels of one instruction set (tet_forces.h): this file
 * is compiled once per instruction set (CMake defines DEFSIM_ISA: generic, avx2, avx512, with
 * the matching -m flags), as are the material files that give the kernels (tet_batch.h); the
 * planner picks a variant at plan time.
 */
#include "tet_forces.h"

#include "material_list.h"

#define DEFSIM__DECLARE_BATCHED(name)                                                         \
    void DEFSIM__CAT(defsim__batched_##name##_, DEFSIM_ISA)(const defsim__group *g,          \
                                                           const double *x, double *f,       \
                                                           int nthreads);
DEFSIM__TET_MODEL_LIST(DEFSIM__DECLARE_BATCHED)
#define DEFSIM__BATCHED(name) DEFSIM__CAT(defsim__batched_##name##_, DEFSIM_ISA),
/* The same models' kernels for quadratic tets (tet_batch.h's DEFSIM__BATCHED_QKERNEL). */
#define DEFSIM__DECLARE_QBATCHED(name) DEFSIM__DECLARE_BATCHED(q##name)
DEFSIM__TET_MODEL_LIST(DEFSIM__DECLARE_QBATCHED)
#define DEFSIM__QBATCHED(name) DEFSIM__BATCHED(q##name)
/* Their energies (tet_batch.h's DEFSIM__BATCHED_QENERGY). */
#define DEFSIM__DECLARE_QENERGY(name)                                                         \
    double DEFSIM__CAT(defsim__batched_qenergy_##name##_, DEFSIM_ISA)(                        \
        const defsim__group *g, const double *x, int32_t b0, int32_t b1);
DEFSIM__TET_MODEL_LIST(DEFSIM__DECLARE_QENERGY)
#define DEFSIM__QENERGY(name) DEFSIM__CAT(defsim__batched_qenergy_##name##_, DEFSIM_ISA),
/* The mean-dilatation kernels of the models with a split (DEFSIM__BATCHED_QMIXED); a model
 * added to material_list.h needs its line here (NULL without a split). */
#define DEFSIM__QMIXED_DECLARE(name)                                                          \
    void DEFSIM__CAT(defsim__batched_qmixed_##name##_, DEFSIM_ISA)(                           \
        const defsim__group *g, const double *x, double *f, int nthreads);                    \
    double DEFSIM__CAT(defsim__batched_qmixed_energy_##name##_, DEFSIM_ISA)(                  \
        const defsim__group *g, const double *x, int32_t b0, int32_t b1);
DEFSIM__QMIXED_DECLARE(neohookean)
DEFSIM__QMIXED_DECLARE(stable_neohookean)
#define DEFSIM__QMIXED_F_stvk NULL
#define DEFSIM__QMIXED_F_corotated NULL
#define DEFSIM__QMIXED_F_neohookean DEFSIM__CAT(defsim__batched_qmixed_neohookean_, DEFSIM_ISA)
#define DEFSIM__QMIXED_F_stable_neohookean                                                    \
    DEFSIM__CAT(defsim__batched_qmixed_stable_neohookean_, DEFSIM_ISA)
#define DEFSIM__QMIXED_E_stvk NULL
#define DEFSIM__QMIXED_E_corotated NULL
#define DEFSIM__QMIXED_E_neohookean                                                           \
    DEFSIM__CAT(defsim__batched_qmixed_energy_neohookean_, DEFSIM_ISA)
#define DEFSIM__QMIXED_E_stable_neohookean                                                    \
    DEFSIM__CAT(defsim__batched_qmixed_energy_stable_neohookean_, DEFSIM_ISA)
#define DEFSIM__QMIXED_F(name) DEFSIM__QMIXED_F_##name,
#define DEFSIM__QMIXED_E(name) DEFSIM__QMIXED_E_##name,

/* shell_batch.c: the membranes' and the hinges' kernels. */
void DEFSIM__CAT(defsim__batched_membrane_stvk_, DEFSIM_ISA)(const defsim__group *g,
                                                            const double *x, double *f,
                                                            int nthreads);
void DEFSIM__CAT(defsim__batched_membrane_neohookean_, DEFSIM_ISA)(const defsim__group *g,
                                                                  const double *x, double *f,
                                                                  int nthreads);
void DEFSIM__CAT(defsim__batched_hinge_, DEFSIM_ISA)(const defsim__group *g, const double *x,
                                                    double *f, int nthreads);

/* material_corotated.c: the co-rotated kernel's polar decomposition, exposed for tests. */
void DEFSIM__CAT(defsim__rotations_, DEFSIM_ISA)(int32_t n, const double *F, double *R);

const defsim__tet_kernels DEFSIM__CAT(defsim__tet_kernels_, DEFSIM_ISA) = {
    .name = DEFSIM__STR(DEFSIM_ISA),
    .forces = {DEFSIM__TET_MODEL_LIST(DEFSIM__BATCHED)},
    .rotation = DEFSIM__CAT(defsim__rotations_, DEFSIM_ISA),
    .shells = {DEFSIM__CAT(defsim__batched_membrane_stvk_, DEFSIM_ISA),
               DEFSIM__CAT(defsim__batched_membrane_neohookean_, DEFSIM_ISA),
               DEFSIM__CAT(defsim__batched_hinge_, DEFSIM_ISA)},
    .qforces = {DEFSIM__TET_MODEL_LIST(DEFSIM__QBATCHED)},
    .qenergy = {DEFSIM__TET_MODEL_LIST(DEFSIM__QENERGY)},
    .qmforces = {DEFSIM__TET_MODEL_LIST(DEFSIM__QMIXED_F)},
    .qmenergy = {DEFSIM__TET_MODEL_LIST(DEFSIM__QMIXED_E)},
};
