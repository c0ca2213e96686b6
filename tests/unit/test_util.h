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

/* Adds an nx*ny*nz-cell box of tets on [lo, hi] with the given model; returns its id. */
defsim_body_id tu_add_box(defsim_world *w, defsim_model model, int nx, int ny, int nz,
                          const double lo[3], const double hi[3], double E, double nu, double rho);

/* Pins every vertex of body b whose coordinate `axis` is <= value (+1e-12). Returns the count. */
int tu_pin_below(defsim_world *w, defsim_body_id b, int axis, double value);

/* Copies of the world's state (malloc'd, 3 n doubles). */
double *tu_positions(const defsim_world *w);
double *tu_velocities(const defsim_world *w);

/* max |a - b| / max(max |b|, floor) */
double tu_rel_diff(const double *a, const double *b, int n, double floor);

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
