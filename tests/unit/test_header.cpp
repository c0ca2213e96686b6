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
    // Options by name (ABI version 2 declarations).
    static const defsim_option_spec spec = {"flag", DEFSIM_OPTION_BOOL, 0.0, 0.0, 1.0, nullptr, "doc"};
    static const defsim_counter_spec counter = {"count", "doc"};
    defsim_option_info info{};
    info.size = sizeof info;
    double v = -1.0;
    if (spec.type != DEFSIM_OPTION_BOOL || !counter.name[0] ||
        defsim_world_option_info(w, 0, &info) != DEFSIM_OK || info.type != DEFSIM_OPTION_CHOICE ||
        defsim_world_set_option(w, "core.auto_substep", "true") != DEFSIM_OK ||
        defsim_world_get_option(w, "core.auto_substep", &v) != DEFSIM_OK || v != 1.0)
        return 4;
    defsim_world_destroy(w);
    if (std::strcmp(defsim_status_string(DEFSIM_ERR_UNSTABLE), "unstable") != 0) return 2;
    return defsim_version_number() == DEFSIM_VERSION_NUMBER ? 0 : 3;
}
