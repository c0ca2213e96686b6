/* SPDX-License-Identifier: MIT */
/* The table of host services that every backend receives (backend.h). */
#include "world.h"

#include <stdlib.h>
#include <string.h>

#define W(sys) ((defsim_world *)(sys))
#define CW(sys) ((const defsim_world *)(sys))

static int64_t dof_count(const defsim_system *s) { return 3 * (int64_t)CW(s)->nv; }
static int64_t free_dof_count(const defsim_system *s) { return CW(s)->nfree; }
static const int64_t *free_dofs(const defsim_system *s) { return CW(s)->free_dofs; }
static const int64_t *dof_to_free(const defsim_system *s) { return CW(s)->dof_to_free; }
static double *positions(defsim_system *s) { return W(s)->x; }
static double *velocities(defsim_system *s) { return W(s)->v; }
static double sys_time(const defsim_system *s) { return CW(s)->t; }
static const double *mass(const defsim_system *s) { return CW(s)->mass3; }
static const double *mass_damping(const defsim_system *s) { return CW(s)->alpha3; }
static int has_stiffness_damping(const defsim_system *s) { return CW(s)->has_stiffness_damping; }

static defsim_status forces(defsim_system *s, const double *x, const double *v, uint32_t which,
                            double *f)
{
    if (!x || !f || ((which & DEFSIM_FORCE_DAMPING) && !v)) return DEFSIM_ERR_INVALID_ARGUMENT;
    return defsim__forces(W(s), x, v, which & DEFSIM_FORCE_ALL, f);
}

static double potential_energy(defsim_system *s, const double *x)
{
    return defsim__potential_energy(W(s), x);
}

static defsim_status matrix_pattern(defsim_system *s, defsim_triangle tri, defsim_csc *out)
{
    return defsim__matrix_pattern(W(s), tri, out);
}

static defsim_status matrix_values(defsim_system *s, const double *x,
                                   const defsim_matrix_coeffs *c, defsim_triangle tri,
                                   double *values)
{
    return defsim__matrix_values(W(s), x, c, tri, values);
}

static defsim_status matrix_product(defsim_system *s, const double *x,
                                    const defsim_matrix_coeffs *c, const double *dx, double *out)
{
    return defsim__matrix_product(W(s), x, c, dx, out);
}

static const defsim_world_def *options(const defsim_system *s) { return &CW(s)->def; }
static int32_t num_threads(const defsim_system *s) { return CW(s)->nthreads; }
static double length_scale(const defsim_system *s) { return CW(s)->length_scale; }
static defsim_stats *stats(defsim_system *s) { return &W(s)->stats; }

static void log_message(defsim_system *s, int level, const char *message)
{
    defsim__world_log(W(s), level, "%s", message ? message : "");
}

static void set_error(defsim_system *s, const char *message)
{
    defsim__world_error(W(s), "%s", message ? message : "");
}

static const double *option_values(const defsim_system *s)
{
    return defsim__options_values(&CW(s)->options);
}
static double *counters(defsim_system *s) { return defsim__options_counters(&W(s)->options); }

static defsim_status omega_max(defsim_system *s, const double *x, double *omega, double *damping)
{
    if (!x || !omega || !damping) return DEFSIM_ERR_INVALID_ARGUMENT;
    const defsim_status st = defsim__omega_max(W(s), x, omega);
    *damping = st == DEFSIM_OK ? defsim__damping_rate(CW(s), *omega) : 0.0;
    return st;
}

static void *alloc(size_t bytes) { return malloc(bytes); }
static void release(void *p) { free(p); }

const defsim_host defsim__host = {
    .abi_version = DEFSIM_BACKEND_ABI_VERSION,
    .size = sizeof(defsim_host),
    .dof_count = dof_count,
    .free_dof_count = free_dof_count,
    .free_dofs = free_dofs,
    .dof_to_free = dof_to_free,
    .positions = positions,
    .velocities = velocities,
    .time = sys_time,
    .mass = mass,
    .mass_damping = mass_damping,
    .has_stiffness_damping = has_stiffness_damping,
    .forces = forces,
    .potential_energy = potential_energy,
    .matrix_pattern = matrix_pattern,
    .matrix_values = matrix_values,
    .matrix_product = matrix_product,
    .options = options,
    .num_threads = num_threads,
    .length_scale = length_scale,
    .stats = stats,
    .wall_time = defsim__now,
    .log = log_message,
    .set_error = set_error,
    .alloc = alloc,
    .release = release,
    .option_values = option_values,
    .counters = counters,
    .omega_max = omega_max,
};
