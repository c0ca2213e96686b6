/* SPDX-License-Identifier: MIT */
/* The input limits of the mesh loaders (defsim_set_limit): file bytes (mesh_reader.c), vertices
 * and elements (mesh_raw.c). Below the readers, so that every loader reads them in one place. */
#include "defsim/defsim.h"
#include "status.h"

#include <stdatomic.h>
#include <stdint.h>

static _Atomic int64_t limits[3] = {(int64_t)1 << 30, 10000000, 50000000};
static const int64_t limit_max[3] = {(int64_t)1 << 62, INT32_MAX / 3, INT32_MAX / 6};

defsim_status defsim_set_limit(defsim_limit limit, int64_t value)
{
    if ((unsigned)limit > DEFSIM_LIMIT_ELEMENTS || value < 1 || value > limit_max[limit]) {
        defsim__set_last_error("defsim_set_limit: limit %d = %lld is out of range", (int)limit,
                               (long long)value);
        return DEFSIM_ERR_INVALID_ARGUMENT;
    }
    atomic_store(&limits[limit], value);
    return DEFSIM_OK;
}

int64_t defsim_get_limit(defsim_limit limit)
{
    return (unsigned)limit > DEFSIM_LIMIT_ELEMENTS ? -1 : atomic_load(&limits[limit]);
}
