/* SPDX-License-Identifier: MIT */
/* The table of host services that every backend receives (backend.h): the compiled system's
 * physics, plus the counting and timing of statistics. */
#include "host.h"

#include "assembly.h"
#include "clock.h"
#include "energy.h"
#include "forces.h"
#include "stability.h"

#include <stdlib.h>

static int64_t dof_count(const defsim_system *s) { return 3 * (int64_t)s->sys->nv; }
static int64_t free_dof_count(const defsim_system *s) { return s->sys->nfree; }
static const int64_t *free_dofs(const defsim_system *s) { return s->sys->free_dofs; }
static const int64_t *dof_to_free(const defsim_system *s) { return s->sys->dof_to_free; }
static double *positions(defsim_system *s) { return s->state->x; }
static double *velocities(defsim_system *s) { return s->state->v; }
static double sys_time(const defsim_system *s) { return s->state->t; }
static const double *mass(const defsim_system *s) { return s->sys->mass3; }
static const double *mass_damping(const defsim_system *s) { return s->sys->alpha3; }
static int has_stiffness_damping(const defsim_system *s) { return s->sys->has_stiffness_damping; }

static defsim_status forces(defsim_system *s, const double *x, const double *v, uint32_t which,
                            double *f)
{
    if (!x || !f || ((which & DEFSIM_FORCE_DAMPING) && !v)) return DEFSIM_ERR_INVALID_ARGUMENT;
    const double t0 = defsim__now();
    defsim_status st = defsim__forces(s->sys, x, v, which & DEFSIM_FORCE_ALL, f, s->passes);
    s->stats->force_evals++;
    s->stats->time_forces += defsim__now() - t0;
    return st;
}

static double potential_energy(defsim_system *s, const double *x)
{
    const double e = defsim__potential_energy(s->sys, s->work, x);
    s->stats->energy_evals++;
    *s->passes |= DEFSIM_PASS_ENERGY;
    return e;
}

/* Backends that do not declare DEFSIM_BACKEND_NEEDS_MATRIX get the pattern on first use. */
static defsim_status ensure_pattern(defsim_system *s)
{
    defsim_status st = defsim__pattern_build(s->sys);
    if (st != DEFSIM_OK) defsim__error(s->msg, "out of memory building the matrix pattern");
    return st;
}

static defsim_status matrix_pattern(defsim_system *s, defsim_triangle tri, defsim_csc *out)
{
    defsim_status st = ensure_pattern(s);
    return st != DEFSIM_OK ? st : defsim__matrix_pattern(s->sys, tri, out);
}

static defsim_status matrix_values(defsim_system *s, const double *x,
                                   const defsim_matrix_coeffs *c, defsim_triangle tri,
                                   double *values)
{
    defsim_status st = ensure_pattern(s);
    if (st != DEFSIM_OK) return st;
    const double t0 = defsim__now();
    st = defsim__matrix_values(s->sys, x, c, tri, values, s->passes);
    if (st != DEFSIM_OK) return st;
    s->stats->hessian_evals++;
    s->stats->time_hessian += defsim__now() - t0;
    return DEFSIM_OK;
}

static defsim_status matrix_product(defsim_system *s, const double *x,
                                    const defsim_matrix_coeffs *c, const double *dx, double *out)
{
    return defsim__matrix_product(s->sys, x, c, dx, out);
}

static const defsim_world_def *options(const defsim_system *s) { return s->def; }
static int32_t num_threads(const defsim_system *s) { return s->sys->nthreads; }
static double length_scale(const defsim_system *s) { return s->sys->length_scale; }
static defsim_stats *stats(defsim_system *s) { return s->stats; }

static void log_message(defsim_system *s, int level, const char *message)
{
    defsim__log(s->msg, level, "%s", message ? message : "");
}

static void set_error(defsim_system *s, const char *message)
{
    defsim__error(s->msg, "%s", message ? message : "");
}

static const double *option_values(const defsim_system *s)
{
    return defsim__options_values(s->options);
}
static double *counters(defsim_system *s) { return defsim__options_counters(s->options); }

static defsim_status omega_max(defsim_system *s, const double *x, double *omega, double *damping)
{
    if (!x || !omega || !damping) return DEFSIM_ERR_INVALID_ARGUMENT;
    const defsim_status st = defsim__omega_max(s->sys, s->work, x, omega);
    *damping = st == DEFSIM_OK ? defsim__damping_coeff(s->sys, *omega) : 0.0;
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
