/* SPDX-License-Identifier: MIT */
/* Colouring of element groups, so that each colour scatters in parallel without atomics. */
#include "colour.h"

#include "tet10.h"

#include <stdlib.h>
#include <string.h>

/* Greedy colouring in windows of 64 colours: an element takes the lowest colour of the window
 * that none of its vertices has; elements that find none wait for the next window. Then the
 * element arrays are permuted so that each colour is contiguous (stable within a colour). */
defsim_status defsim__colour_group(defsim__group *g, int32_t nv)
{
    const int nn = g->nodes;
    int32_t *color = malloc((size_t)(g->n > 0 ? g->n : 1) * sizeof *color);
    uint64_t *mask = malloc((size_t)(nv > 0 ? nv : 1) * sizeof *mask);
    if (!color || !mask) { free(color); free(mask); return DEFSIM_ERR_OUT_OF_MEMORY; }
    for (int32_t e = 0; e < g->n; ++e) color[e] = -1;
    int32_t left = g->n, base = 0;
    while (left > 0) {
        memset(mask, 0, (size_t)nv * sizeof *mask);
        for (int32_t e = 0; e < g->n; ++e) {
            if (color[e] >= 0) continue;
            uint64_t used = 0;
            for (int a = 0; a < nn; ++a) used |= mask[g->idx[(int64_t)nn * e + a]];
            if (used == ~(uint64_t)0) continue;
            int c = __builtin_ctzll(~used);
            for (int a = 0; a < nn; ++a) mask[g->idx[(int64_t)nn * e + a]] |= (uint64_t)1 << c;
            color[e] = base + c;
            --left;
        }
        base += 64;
    }
    free(mask);
    int32_t ncol = 0;
    for (int32_t e = 0; e < g->n; ++e) if (color[e] + 1 > ncol) ncol = color[e] + 1;
    g->ncolors = ncol;
    g->color_ptr = calloc((size_t)ncol + 1, sizeof *g->color_ptr);
    int32_t *perm = malloc((size_t)(g->n > 0 ? g->n : 1) * sizeof *perm);
    if (!g->color_ptr || !perm) { free(color); free(perm); return DEFSIM_ERR_OUT_OF_MEMORY; }
    for (int32_t e = 0; e < g->n; ++e) g->color_ptr[color[e] + 1]++;
    for (int32_t c = 0; c < ncol; ++c) g->color_ptr[c + 1] += g->color_ptr[c];
    {
        int32_t *fill = malloc(((size_t)ncol + 1) * sizeof *fill);
        if (!fill) { free(color); free(perm); return DEFSIM_ERR_OUT_OF_MEMORY; }
        memcpy(fill, g->color_ptr, ((size_t)ncol + 1) * sizeof *fill);
        for (int32_t e = 0; e < g->n; ++e) perm[fill[color[e]]++] = e;
        free(fill);
    }
    free(color);
    /* Apply the permutation to every per-element array. */
#define PERMUTE(arr, width, type)                                                              \
    if (g->arr) {                                                                              \
        type *na = malloc((size_t)g->n * (width) * sizeof *na);                                \
        if (!na) { free(perm); return DEFSIM_ERR_OUT_OF_MEMORY; }                              \
        for (int32_t e = 0; e < g->n; ++e)                                                     \
            memcpy(na + (int64_t)(width) * e, g->arr + (int64_t)(width) * perm[e], (width) * sizeof *na); \
        free(g->arr);                                                                          \
        g->arr = na;                                                                           \
    }
    PERMUTE(idx, nn, int32_t)
    PERMUTE(dminv, 9, double)
    PERMUTE(qrest, DEFSIM__TET10_REST, double)
    PERMUTE(vol, 1, double)
    PERMUTE(mu, 1, double)
    PERMUTE(lambda, 1, double)
    PERMUTE(k, 1, double)
    PERMUTE(l0, 1, double)
    PERMUTE(beta, 1, double)
    PERMUTE(shell, g->shell_width, double)
#undef PERMUTE
    free(perm);
    return DEFSIM_OK;
}
