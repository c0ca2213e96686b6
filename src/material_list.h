/* SPDX-License-Identifier: MIT */
/*
 * The tet material models, one line each, in the order of their element groups (which is the
 * order forces are summed in). Model `name` lives in src/material_<name>.c and exports the table
 * `defsim__model_<name>` (material.h); in the per-instruction-set compiles (DEFSIM_ISA) the same
 * file gives the batched kernel `defsim__batched_<name>_<isa>` (tet_batch.h). CMake reads this
 * list to compile those files, so adding a model is its file plus one line here.
 */
#ifndef DEFSIM_MATERIAL_LIST_H
#define DEFSIM_MATERIAL_LIST_H

#define DEFSIM__TET_MODEL_LIST(X) \
    X(stvk)                       \
    X(corotated)                  \
    X(neohookean)                 \
    X(stable_neohookean)

#endif /* DEFSIM_MATERIAL_LIST_H */
