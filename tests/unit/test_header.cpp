// SPDX-License-Identifier: MIT
// The public headers compile as strict C++17 (-pedantic -Werror) and link.
#include <defsim/backend.h>
#include <defsim/defsim.h>

#include <cstring>

int main()
{
    defsim_world_def def;
    defsim_world_def_init(&def, sizeof def);
    defsim_world *w = nullptr;
    if (defsim_world_create(&def, &w) != DEFSIM_OK) return 1;
    defsim_world_destroy(w);
    if (std::strcmp(defsim_status_string(DEFSIM_ERR_UNSTABLE), "unstable") != 0) return 2;
    return defsim_version_number() == DEFSIM_VERSION_NUMBER ? 0 : 3;
}
