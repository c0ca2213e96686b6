/* SPDX-License-Identifier: MIT */
/* Builds against an installed defsim and steps a falling box: proves headers, library and
 * package files work together. */
#include <defsim/defsim.h>
#include <stdio.h>

int main(void)
{
    if (defsim_version_number() != DEFSIM_VERSION_NUMBER) return 1;
    defsim_world_def wd;
    defsim_world_def_init(&wd, sizeof wd);
    defsim_world *w = NULL;
    if (defsim_world_create(&wd, &w) != DEFSIM_OK) return 2;
    defsim_mesh m = {sizeof m};
    double lo[3] = {0, 0, 0}, hi[3] = {1, 1, 1};
    if (defsim_mesh_box(lo, hi, 1, 1, 1, &m) != DEFSIM_OK) return 3;
    defsim_body_def bd;
    defsim_body_def_init(&bd, sizeof bd);
    bd.rest_positions = m.positions;
    bd.vertex_count = m.vertex_count;
    bd.tets = m.tets;
    bd.tet_count = m.tet_count;
    if (defsim_world_add_body(w, &bd, NULL) != DEFSIM_OK) return 4;
    for (int i = 0; i < 10; ++i)
        if (defsim_world_step(w, 1e-3) != DEFSIM_OK) return 5;
    double x[3 * 8];
    defsim_world_get_positions(w, x, 8);
    printf("version %s, y0 after 10 steps %.6f\n", DEFSIM_VERSION_STRING, x[1]);
    defsim_mesh_free(&m);
    defsim_world_destroy(w);
    return x[1] < 0.0 ? 0 : 6;
}
