/* SPDX-License-Identifier: MIT */
/* Rest shape of one tet: the degenerate-tet rule and Dm, shared by add_body and the loaders. */
#ifndef DEFSIM_TET_REST_H
#define DEFSIM_TET_REST_H

#include <stdint.h>

/* A tet whose |det Dm| is not above this fraction of its longest edge cubed is degenerate. */
#define DEFSIM__DEGENERATE_REL 1e-12

typedef struct defsim__tet_rest {
    double det;           /* det Dm (signed: negative for a left-handed tet); volume |det| / 6 */
    double longest_edge;  /* longest of the six edges, m */
    int degenerate;       /* 1 if !(|det| > DEFSIM__DEGENERATE_REL * longest_edge^3) */
} defsim__tet_rest;

/*
 * Rest data of the tet `tet` (4 indices into `pos`, 3 doubles per vertex) with
 * Dm = [x0 - x3, x1 - x3, x2 - x3] (columns). With `dm_inv` non-NULL it also receives Dm^-1
 * (row-major; zero when det Dm == 0). Returns `degenerate`.
 */
int defsim__tet_rest_eval(const double *pos, const int32_t tet[4], defsim__tet_rest *out,
                          double dm_inv[9]);

#endif
