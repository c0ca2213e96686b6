/* SPDX-License-Identifier: MIT */
/*
 * The choice among the batched kernels' variants (tet_forces.h): tet_forces.c is compiled once
 * per instruction set, so the one function that picks a variant by name or by what the CPU
 * supports lives here, once. The options (core.simd) and the planner call it.
 */
#include "tet_forces.h"

#include <string.h>

/* The batched kernels (tet_forces.c) come in one variant per instruction set; the scalar
 * kernels above remain the reference (DEFSIM_SIMD=scalar). */
const defsim__tet_kernels *defsim__tet_kernels_find(const char *name)
{
    if (!name) return NULL;
    if (!strcmp(name, "generic")) return &defsim__tet_kernels_generic;
#if defined(DEFSIM_HAVE_X86_KERNELS)
    __builtin_cpu_init();
    if (!strcmp(name, "avx2") && __builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma"))
        return &defsim__tet_kernels_avx2;
    if (!strcmp(name, "avx512") && __builtin_cpu_supports("avx512f") &&
        __builtin_cpu_supports("avx512dq") && __builtin_cpu_supports("avx512vl"))
        return &defsim__tet_kernels_avx512;
#endif
    return NULL;
}

const defsim__tet_kernels *defsim__tet_kernels_best(void)
{
    static const char *const order[] = {"avx512", "avx2", "generic"};
    for (int i = 0; i < 3; ++i) {
        const defsim__tet_kernels *k = defsim__tet_kernels_find(order[i]);
        if (k) return k;
    }
    return &defsim__tet_kernels_generic;
}
