/* SPDX-License-Identifier: MIT */
/* The public headers compile as strict C11 (-pedantic -Werror) and link. */
#include <defsim/backend.h>
#include <defsim/defsim.h>
#include <string.h>

int main(void)
{
    defsim_world_def def;
    defsim_world_def_init(&def, sizeof def);
    if (def.size != sizeof def) return 1;
    if (strcmp(defsim_status_string(DEFSIM_ERR_STALE_ID), "stale id") != 0) return 2;
    return defsim_version_number() == DEFSIM_VERSION_NUMBER ? 0 : 3;
}
