/* SPDX-License-Identifier: MIT */
/*
 * The host's coupling API (defsim.h "Coupling with the host"): external forces, the force
 * callback, driven pins, attachments, pin forces and element stress.
 */
#include "world.h"

#include <string.h>

static defsim_status pending(defsim_world *w, const char *what)
{
    if (!w) return DEFSIM_ERR_INVALID_ARGUMENT;
    defsim__error(w->msg, "%s: not available in this build yet", what);
    return DEFSIM_ERR_INVALID_ARGUMENT;
}

defsim_status defsim_world_set_external_forces(defsim_world *w, const double *f, int32_t n)
{
    (void)f; (void)n;
    return pending(w, "set_external_forces");
}

defsim_status defsim_world_set_force_callback(defsim_world *w, defsim_force_fn fn,
                                              defsim_force_jacobian_fn jacobian, void *user)
{
    (void)fn; (void)jacobian; (void)user;
    return pending(w, "set_force_callback");
}

defsim_status defsim_body_set_pin_targets(defsim_world *w, defsim_body_id body,
                                          const int32_t *verts, int32_t n, const double *positions)
{
    (void)body; (void)verts; (void)n; (void)positions;
    return pending(w, "set_pin_targets");
}

void defsim_attachment_def_init(defsim_attachment_def *def, size_t size)
{
    if (!def || size < sizeof(uint32_t)) return;
    defsim_attachment_def d;
    memset(&d, 0, sizeof d);
    d.size = (uint32_t)sizeof d;
    d.stiffness = 1e3;
    if (size > sizeof d) size = sizeof d;
    memcpy(def, &d, size);
    def->size = (uint32_t)size;
}

defsim_status defsim_world_add_attachment(defsim_world *w, const defsim_attachment_def *def,
                                          defsim_attachment_id *out)
{
    (void)def; (void)out;
    return pending(w, "add_attachment");
}

defsim_status defsim_world_remove_attachment(defsim_world *w, defsim_attachment_id id)
{
    (void)id;
    return pending(w, "remove_attachment");
}

defsim_status defsim_attachment_set_target(defsim_world *w, defsim_attachment_id id,
                                           const double target[3])
{
    (void)id; (void)target;
    return pending(w, "attachment_set_target");
}

defsim_status defsim_world_get_attachment_force(const defsim_world *w, defsim_attachment_id id,
                                                double out[3])
{
    (void)id; (void)out;
    return pending((defsim_world *)w, "get_attachment_force");
}

defsim_status defsim_world_get_pin_forces(defsim_world *w, double *out, int32_t n)
{
    (void)out; (void)n;
    return pending(w, "get_pin_forces");
}

defsim_status defsim_body_element_stress(const defsim_world *w, defsim_body_id body,
                                         double *cauchy, double *von_mises,
                                         double *energy_density, int32_t tet_count)
{
    (void)body; (void)cauchy; (void)von_mises; (void)energy_density; (void)tet_count;
    return pending((defsim_world *)w, "body_element_stress");
}
