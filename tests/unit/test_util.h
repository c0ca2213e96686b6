/* SPDX-License-Identifier: MIT */
/* Small helpers shared by the unit tests: worlds, box bodies, a fixed-seed RNG. */
#ifndef DEFSIM_TEST_UTIL_H
#define DEFSIM_TEST_UTIL_H

#include <defsim/defsim.h>

#include "mesh_body.h"

#include <stdarg.h>
#include <stddef.h>
#include <setjmp.h>
#include <cmocka.h>

/* Deterministic uniform in [-1, 1). */
double tu_rand(unsigned long long *state);

/* A world with the given backend, gravity along y and thread count; fails the test on error.
 * tu_world_def is its def, for tests that set more; tu_create creates a world or fails. */
defsim_world *tu_world(const char *backend, double gy, int threads);
defsim_world_def tu_world_def(const char *backend, double gy, int threads);
defsim_world *tu_create(const defsim_world_def *d);

/* The statistic `name` of w (defsim_world_stat: a field of defsim_stats, "<backend>.<counter>",
 * ...); fails the test when w has none of that name. */
double tu_stat(const defsim_world *w, const char *name);

/* The counter `leaf` of w's backend, whatever the backend ("<backend>.<leaf>": the first
 * statistic so named in the listing, where the backend's counters precede contact's and the
 * terms'), or 0 when the backend has no such counter (as for tests run over every backend). */
double tu_bstat(const defsim_world *w, const char *leaf);

/* Sets the option "<backend>.<leaf>" of w (backend: w's) to value where the backend has it
 * (a setting a test gives every backend it runs, ignored by those without it); fails the test
 * when the option refuses the value. Returns 1 if the backend has the option. */
int tu_backend_option(defsim_world *w, const char *backend, const char *leaf, double value);

/* A world with an implicit backend's settings: Newton tolerance, iterations and projection,
 * each set as an option where the backend has it. */
defsim_world *tu_implicit_world(const char *backend, double gy, int threads, double tol,
                                int max_iter, defsim_projection proj);

/* A spring ladder (cloth strip) of 4 rungs along x: vertices 2i = (x0 + cell i, 0, 0) and
 * 2i + 1 = (x0 + cell i, cell, z1), and 10 springs: the rungs, then the two rails' diagonals. */
void tu_ladder(double x0, double cell, double z1, double x[24], int32_t springs[20]);

/* Adds an nx*ny*nz-cell box of tets on [lo, hi] of material *mat; returns its id. */
defsim_body_id tu_add_box_material(defsim_world *w, int nx, int ny, int nz, const double lo[3],
                                   const double hi[3], const defsim_material *mat);

/* Adds an nx*ny*nz-cell box of tets on [lo, hi] with the given model; returns its id. */
defsim_body_id tu_add_box(defsim_world *w, defsim_model model, int nx, int ny, int nz,
                          const double lo[3], const double hi[3], double E, double nu, double rho);

/* Adds a spring cloth (defsim_mesh_cloth: corner o, edges u and v, nu x nv cells) of spring
 * stiffness k (N/m) and vertex_mass (kg per vertex); returns its id. */
defsim_body_id tu_add_spring_cloth(defsim_world *w, const double o[3], const double u[3],
                                   const double v[3], int nu, int nv, double k,
                                   double vertex_mass);

/* Two vertices joined by one spring (the oscillators and pendulums of the integrator tests):
 * vertex 0 of mass m0 at `anchor`, vertex 1 of mass m1 at rest at anchor + (l0, 0, 0), starting
 * at x1 (absolute) with velocity v1, vertex 0 at rest; material stiffness k and Rayleigh alpha,
 * beta. With pin_anchor, vertex 0 is pinned. Fails the test on error. */
typedef struct tu_spring2 {
    double anchor[3], l0, x1[3], v1[3];
    double m0, m1, k, alpha, beta;
    int pin_anchor;
} tu_spring2;
defsim_body_id tu_add_spring2(defsim_world *w, const tu_spring2 *o);

/* Momentum of a free body changes by M g t and by nothing else: adds a 2x2x2-cell co-rotated
 * unit box (E 1e5 Pa, nu 0.3, 1000 kg/m^3) to w (gravity gy along y, no other body), perturbs
 * its positions and velocities (seed), takes `steps` steps of h and asserts each component of
 * the momentum to tol * M (kg m/s). `what` names the run in the printed drift. */
void tu_check_free_fall(defsim_world *w, const char *what, double gy, unsigned long long seed,
                        int steps, double h, double tol);

/* Takes `steps` steps of h and asserts that the state stays finite and that every vertex that
 * started at x <= 1e-12 (the clamped end: `npinned` of them) has kept its position exactly with
 * zero velocity. Returns how far the last vertex moved along y (m). */
double tu_check_clamped_end(defsim_world *w, int steps, double h, int npinned);

/* Steps w `steps` times by h and returns E_total(end) / E_total(start); *max_dev receives the
 * largest |E(t) - E(0)| / |E(0)| over the steps (checked after every step). */
double tu_energy_run(defsim_world *w, double h, int steps, double *max_dev);

/* A world (no gravity, one thread, auto_substep as given) holding one spring k (Rayleigh alpha,
 * beta) between vertex 0 at the origin (mass m0, pinned if `pin`) and vertex 1 of mass m, at rest
 * at x = 1 and started at x = 1 + a: with the pin, x'' = -(k/m) x - (alpha + beta k/m) x'. */
defsim_world *tu_oscillator(const char *backend, double m0, double m, double k, double alpha,
                            double beta, double a, int pin, int auto_substep);

/* Backends of this build (CMake's DEFSIM_CONFORMANCE_BACKENDS, compiled in as
 * DEFSIM_TEST_BACKENDS): tu_built says whether one is. tu_create_or_skip creates a world; where
 * that fails for a backend this build does not have, it records a skip (tu_skip) and returns
 * NULL; for a backend it has (or one the test registered), the failure fails the test: a module
 * that no longer loads must not pass as "not available". tu_available: 1 when a world with the
 * backend can be created, else 0 with the skip recorded. */
int tu_built(const char *backend);
defsim_world *tu_create_or_skip(const defsim_world_def *d);
int tu_available(const char *backend);

/* Records that part of a test could not run (printed as "SKIP: <what>"); tu_exit turns a run
 * with skips and no failures into TU_SKIP_CODE, which ctest reports as skipped
 * (SKIP_RETURN_CODE), never as passed. Tests end with return tu_exit(cmocka_run_...). */
#define TU_SKIP_CODE 77
void tu_skip(const char *what);
int tu_exit(int failures);

/* Pins every vertex of body b whose coordinate `axis` is <= value (+1e-12). Returns the count. */
int tu_pin_below(defsim_world *w, defsim_body_id b, int axis, double value);

/* Copies of the world's state (malloc'd, 3 n doubles). */
double *tu_positions(const defsim_world *w);
double *tu_velocities(const defsim_world *w);

/* max |a - b| / max(max |b|, floor) */
double tu_rel_diff(const double *a, const double *b, int n, double floor);

/* 1 if a file whose path contains `needle` is mapped into this process (a loaded module), 0 if
 * not, -1 if /proc/self/maps cannot be read. */
int tu_mapped(const char *needle);

/* A damped linear oscillator: a vertex of mass m on a spring of stiffness k along x to a pinned
 * anchor. In 1D the spring force is exactly -k u and Rayleigh damping gives
 * -(alpha m + beta k) u', so u'' + c u' + w0^2 u = 0 with c = alpha + beta k / m, w0^2 = k / m. */
typedef struct tu_osc {
    double m, k, alpha, beta, u0, v0;
    int32_t vertex;    /* world index of the moving vertex (set by tu_add_oscillator) */
} tu_osc;

/* Adds the oscillator's two-vertex body at height z (anchor pinned); returns its id. */
defsim_body_id tu_add_oscillator(defsim_world *w, tu_osc *o, double z);

/* Exact displacement and velocity at time t from (u0, v0) at time 0 (underdamped). */
void tu_osc_exact(const tu_osc *o, double t, double *u, double *v);

/* A fresh temporary directory (tu_tmpdir) for tests that write files; for CMocka setup and
 * teardown. tu_write_file writes text to tu_tmpdir/name and returns the path (valid until the
 * 8th call after). */
extern char tu_tmpdir[256];
int tu_tmpdir_setup(void **state);
int tu_tmpdir_teardown(void **state);
const char *tu_write_file(const char *name, const char *text);
/* The same for n bytes of any value (NUL included). */
const char *tu_write_bytes(const char *name, const void *data, size_t n);

#define TU_OK(expr) assert_int_equal((expr), DEFSIM_OK)

#endif
