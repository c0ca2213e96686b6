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
    /* Options by name (ABI version 2 declarations). */
    static const defsim_option_spec spec = {"flag", DEFSIM_OPTION_BOOL, 0.0, 0.0, 1.0, NULL, "doc"};
    static const defsim_counter_spec counter = {"count", "doc"};
    defsim_world *w = NULL;
    defsim_option_info info = {sizeof info, NULL, DEFSIM_OPTION_REAL, 0, 0, 0, 0, NULL, NULL};
    double steps = -1.0;
    if (DEFSIM_BACKEND_ABI_VERSION != 8u || spec.type != DEFSIM_OPTION_BOOL || !counter.name[0] ||
        defsim_world_create(&def, &w) != DEFSIM_OK || defsim_world_option_count(w) != 11 ||
        defsim_world_option_info(w, 2, &info) != DEFSIM_OK || info.value != 0.8 ||
        defsim_world_stat(w, "steps", &steps) != DEFSIM_OK || steps != 0.0)
        return 4;
    defsim_world_destroy(w);
    /* The host's coupling (ABI version 3 host services; public declarations). */
    defsim_attachment_def ad;
    defsim_attachment_def_init(&ad, sizeof ad);
    if (ad.size != sizeof ad || ad.stiffness != 1e3 || ad.target_vertex_count != 0 ||
        sizeof(((defsim_host *)0)->applied_forces_vary) != sizeof(void (*)(void)))
        return 5;
    /* ABI version 8: gravity in the host table, where the world def was. */
    if (sizeof(((defsim_host *)0)->gravity) != sizeof(void (*)(void))) return 7;
    /* Checkpoints (ABI version 5 backend ops; public declarations). */
    void *buf = NULL;
    size_t bytes = 0;
    defsim_world *w2 = NULL;
    if (sizeof(((defsim_backend *)0)->load_state) != sizeof(void (*)(void)) ||
        defsim_world_create(&def, &w) != DEFSIM_OK ||
        defsim_world_save_buffer(w, &buf, &bytes) != DEFSIM_OK ||
        defsim_world_load_buffer(buf, bytes, NULL, NULL, &w2) != DEFSIM_OK ||
        defsim_world_body_count(w2) != 0)
        return 6;
    defsim_buffer_free(buf);
    defsim_world_destroy(w);
    defsim_world_destroy(w2);
    if (strcmp(defsim_status_string(DEFSIM_ERR_STALE_ID), "stale id") != 0) return 2;
    return defsim_version_number() == DEFSIM_VERSION_NUMBER ? 0 : 3;
}
