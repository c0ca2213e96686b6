/* SPDX-License-Identifier: MIT */
/* Colouring of element groups (colour.c). */
#ifndef DEFSIM_COLOUR_H
#define DEFSIM_COLOUR_H

#include "system.h"

/* Colours the elements of g (no two elements of a colour share a vertex) and permutes every
 * per-element array so that each colour is contiguous (stable within a colour); sets
 * g->ncolors and g->color_ptr. nv: vertex count. DEFSIM_ERR_OUT_OF_MEMORY on failure. */
defsim_status defsim__colour_group(defsim__group *g, int32_t nv);

#endif /* DEFSIM_COLOUR_H */
