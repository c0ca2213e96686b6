/* SPDX-License-Identifier: MIT */
#include "tet_rest.h"

#include "mat3.h"

#include <math.h>

int defsim__tet_rest_eval(const double *pos, const int32_t tet[4], defsim__tet_rest *out,
                          double dm_inv[9])
{
    double dm[9], l2max = 0.0;
    const double *p3 = pos + 3 * (int64_t)tet[3];
    for (int a = 0; a < 3; ++a)
        for (int i = 0; i < 3; ++i) dm[3 * i + a] = pos[3 * (int64_t)tet[a] + i] - p3[i];
    for (int a = 0; a < 4; ++a)
        for (int c = a + 1; c < 4; ++c) {
            const double *pa = pos + 3 * (int64_t)tet[a], *pc = pos + 3 * (int64_t)tet[c];
            double l2 = (pa[0] - pc[0]) * (pa[0] - pc[0]) + (pa[1] - pc[1]) * (pa[1] - pc[1]) +
                        (pa[2] - pc[2]) * (pa[2] - pc[2]);
            if (l2 > l2max) l2max = l2;
        }
    /* sqrt is monotonic and correctly rounded: the longest edge is the same whether one takes
     * the root before or after the maximum. */
    const double lmax = sqrt(l2max);
    out->det = defsim__m3_det(dm);
    out->longest_edge = lmax;
    out->degenerate = !(fabs(out->det) > DEFSIM__DEGENERATE_REL * lmax * lmax * lmax);
    if (dm_inv) defsim__m3_inverse(dm, dm_inv);
    return out->degenerate;
}
