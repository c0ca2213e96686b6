/* SPDX-License-Identifier: MIT */
/* The box beam shared by the benchmarks and the peers' scripts (../shared/peers): 3n x n x n
 * cells on [0,3] x [0,1] x [0,1] m, 6 tets per cell (n = 18: 104976 tets), clamped at x = 0. */
#ifndef DEFSIM_TOOLS_BENCH_BEAM_H
#define DEFSIM_TOOLS_BENCH_BEAM_H

#include <defsim/defsim.h>

/* Makes the beam mesh (free with defsim_mesh_free). */
defsim_status bench_beam_mesh(int n, defsim_mesh *m);

/* Writes the vertices at x = 0 into out (room for m->vertex_count); returns their count. */
int32_t bench_clamp_list(const defsim_mesh *m, int32_t *out);

/* Adds the beam as a body of `material` and, if `clamp`, pins its x = 0 end. On an error the
 * message is in defsim_world_last_error(w). */
defsim_status bench_add_beam(defsim_world *w, const defsim_mesh *m, const defsim_material *material,
                             int clamp, defsim_body_id *id);

/* The material model named "snh", "nh", "corotated" or "stvk" (the tools' short names);
 * 0 if the name is none of them. */
defsim_model bench_model_by_name(const char *name);

/* Sets the option "<backend>.<leaf>" of w to value where w's backend (`backend`) has one;
 * returns DEFSIM_OK also when it has none (a tool's tolerance for a backend without one). */
defsim_status bench_backend_option(defsim_world *w, const char *backend, const char *leaf,
                                   double value);

/* The counter "<backend>.<leaf>" of w (the backend's counters by name), or 0 where the backend
 * has none. */
double bench_backend_stat(const defsim_world *w, const char *backend, const char *leaf);

#endif
