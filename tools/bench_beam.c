/* SPDX-License-Identifier: MIT */
#include "bench_beam.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

defsim_model bench_model_by_name(const char *name)
{
    static const struct { const char *name; defsim_model model; } models[] = {
        {"snh", DEFSIM_MODEL_STABLE_NEOHOOKEAN}, {"nh", DEFSIM_MODEL_NEOHOOKEAN},
        {"corotated", DEFSIM_MODEL_COROTATED}, {"stvk", DEFSIM_MODEL_STVK}};
    for (size_t i = 0; i < sizeof models / sizeof models[0]; ++i)
        if (!strcmp(name, models[i].name)) return models[i].model;
    return (defsim_model)0;
}

defsim_status bench_beam_mesh(int n, defsim_mesh *m)
{
    const double lo[3] = {0, 0, 0}, hi[3] = {3, 1, 1};
    m->size = sizeof *m;
    return defsim_mesh_box(lo, hi, 3 * n, n, n, m);
}

int32_t bench_clamp_list(const defsim_mesh *m, int32_t *out)
{
    int32_t np = 0;
    for (int32_t i = 0; i < m->vertex_count; ++i)
        if (m->positions[3 * (int64_t)i] == 0.0) out[np++] = i;
    return np;
}

defsim_status bench_add_beam(defsim_world *w, const defsim_mesh *m, const defsim_material *material,
                             int clamp, defsim_body_id *id)
{
    defsim_body_def bd;
    defsim_body_def_init(&bd, sizeof bd);
    bd.rest_positions = m->positions;
    bd.vertex_count = m->vertex_count;
    bd.tets = m->tets;
    bd.tet_count = m->tet_count;
    bd.material = *material;
    defsim_status st = defsim_world_add_body(w, &bd, id);
    if (st != DEFSIM_OK || !clamp) return st;
    int32_t *pins = malloc((size_t)m->vertex_count * sizeof *pins);
    if (!pins) return DEFSIM_ERR_OUT_OF_MEMORY;
    st = defsim_body_pin(w, *id, pins, bench_clamp_list(m, pins));
    free(pins);
    return st;
}

defsim_status bench_backend_option(defsim_world *w, const char *backend, const char *leaf,
                                   double value)
{
    char name[160];
    snprintf(name, sizeof name, "%s.%s", backend, leaf);
    double now;
    if (defsim_world_get_option(w, name, &now) != DEFSIM_OK) return DEFSIM_OK;
    return defsim_world_set_option_number(w, name, value);
}

double bench_backend_stat(const defsim_world *w, const char *backend, const char *leaf)
{
    char name[160];
    snprintf(name, sizeof name, "%s.%s", backend, leaf);
    double v = 0.0;
    return defsim_world_stat(w, name, &v) == DEFSIM_OK ? v : 0.0;
}
