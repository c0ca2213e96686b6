/* SPDX-License-Identifier: MIT */
/* Small helpers shared by the unit tests: worlds, box bodies, a fixed-seed RNG. */
#ifndef DEFSIM_TEST_UTIL_H
#define DEFSIM_TEST_UTIL_H

#include <defsim/defsim.h>

#include <stdarg.h>
#include <stddef.h>
#include <setjmp.h>
#include <cmocka.h>

/* Deterministic uniform in [-1, 1). */
double tu_rand(unsigned long long *state);

/* A world with the given backend, gravity along y and thread count; fails the test on error. */
defsim_world *tu_world(const char *backend, double gy, int threads);

/* Adds an nx*ny*nz-cell box of tets on [lo, hi] of material *mat; returns its id. */
defsim_body_id tu_add_box_material(defsim_world *w, int nx, int ny, int nz, const double lo[3],
                                   const double hi[3], const defsim_material *mat);

/* Adds an nx*ny*nz-cell box of tets on [lo, hi] with the given model; returns its id. */
defsim_body_id tu_add_box(defsim_world *w, defsim_model model, int nx, int ny, int nz,
                          const double lo[3], const double hi[3], double E, double nu, double rho);

/* Adds one spring k (Rayleigh alpha, beta) between vertex 0 (mass m0, pinned if `pin`) and vertex
 * 1 (mass m): rest positions `rest`, initial positions `x0` (6 doubles each), initial velocities
 * `v0` (6 doubles, or NULL for rest). Returns the body's id. */
defsim_body_id tu_add_spring_pair(defsim_world *w, const double rest[6], const double x0[6],
                                  const double *v0, double m0, double m, double k, double alpha,
                                  double beta, int pin);

/* Steps w `steps` times by h and returns E_total(end) / E_total(start); *max_dev receives the
 * largest |E(t) - E(0)| / |E(0)| over the steps (checked after every step). */
double tu_energy_run(defsim_world *w, double h, int steps, double *max_dev);

/* A world (no gravity, one thread, auto_substep as given) holding one spring k (Rayleigh alpha,
 * beta) between vertex 0 at the origin (mass m0, pinned if `pin`) and vertex 1 of mass m, at rest
 * at x = 1 and started at x = 1 + a: with the pin, x'' = -(k/m) x - (alpha + beta k/m) x'. */
defsim_world *tu_oscillator(const char *backend, double m0, double m, double k, double alpha,
                            double beta, double a, int pin, int auto_substep);

/* Pins every vertex of body b whose coordinate `axis` is <= value (+1e-12). Returns the count. */
int tu_pin_below(defsim_world *w, defsim_body_id b, int axis, double value);

/* Copies of the world's state (malloc'd, 3 n doubles). */
double *tu_positions(const defsim_world *w);
double *tu_velocities(const defsim_world *w);

/* max |a - b| / max(max |b|, floor) */
double tu_rel_diff(const double *a, const double *b, int n, double floor);

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

#define TU_OK(expr) assert_int_equal((expr), DEFSIM_OK)

#endif
