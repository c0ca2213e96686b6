/* SPDX-License-Identifier: MIT */
/* Backend registry: built-ins, host registration, and modules loaded on demand with dlopen. */
#include "test_util.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <defsim/backend.h>

static double *run(const char *backend, int steps)
{
    defsim_world *w = tu_world(backend, -9.81, 1);
    const double lo[3] = {0, 0, 0}, hi[3] = {2, 1, 1};
    defsim_body_id b = tu_add_box(w, DEFSIM_MODEL_STABLE_NEOHOOKEAN, 4, 2, 2, lo, hi, 1e5, 0.3, 1000);
    tu_pin_below(w, b, 0, 0.0);
    for (int i = 0; i < steps; ++i) TU_OK(defsim_world_step(w, 1e-3));
    double *x = tu_positions(w);
    defsim_world_destroy(w);
    return x;
}

/* Worlds with built-in backends load no module (this test runs first). */
static void test_builtins_load_nothing(void **state)
{
    (void)state;
    free(run("explicit_euler", 3));
    free(run("symplectic_euler", 3));
    assert_int_equal(tu_mapped("defsim_testmod.so"), 0);
    assert_int_equal(tu_mapped("defsim_newton_cholmod.so"), 0);
    assert_int_equal(tu_mapped("defsim_sundials"), 0);
}

/* The module is found through DEFSIM_BACKEND_PATH, loaded on first use, and computes exactly
 * what the built-in symplectic Euler computes. */
static void test_module_loads_and_matches(void **state)
{
    (void)state;
    double *a = run("testmod", 50), *b = run("symplectic_euler", 50);
    assert_int_equal(tu_mapped("defsim_testmod.so"), 1);
    assert_memory_equal(a, b, 3 * 5 * 3 * 3 * sizeof(double));
    free(a);
    free(b);
    /* reset is called when the host sets the state. */
    defsim_world *w = tu_world("testmod", 0.0, 1);
    const double lo[3] = {0, 0, 0}, hi[3] = {1, 1, 1};
    tu_add_box(w, DEFSIM_MODEL_STVK, 1, 1, 1, lo, hi, 1e5, 0.3, 1000);
    TU_OK(defsim_world_step(w, 1e-3));
    double *x = tu_positions(w);
    TU_OK(defsim_world_set_state(w, x, NULL));
    TU_OK(defsim_world_step(w, 1e-3));
    double steps = 0.0;
    TU_OK(defsim_world_stat(w, "testmod.steps", &steps));
    assert_true(steps == 2.0);
    free(x);
    defsim_world_destroy(w);
}

static void test_missing_module(void **state)
{
    (void)state;
    defsim_world_def d;
    defsim_world_def_init(&d, sizeof d);
    d.backend = "no_such_module";
    defsim_world *w = NULL;
    assert_int_equal(defsim_world_create(&d, &w), DEFSIM_ERR_BACKEND_UNAVAILABLE);
    assert_null(w);
    assert_non_null(strstr(defsim_last_error(), "no_such_module"));
}

/* Counts the quoted names in the last error: the unknown name itself, and the suggestion. */
static int quoted_names(const char *msg)
{
    int n = 0;
    for (const char *p = msg; *p; ++p) n += *p == '\'';
    return n / 2;
}

static const char *create_error(const char *backend)
{
    defsim_world_def d;
    defsim_world_def_init(&d, sizeof d);
    d.backend = backend;
    defsim_world *w = NULL;
    assert_int_equal(defsim_world_create(&d, &w), DEFSIM_ERR_BACKEND_UNAVAILABLE);
    assert_null(w);
    return defsim_last_error();
}

/* An unknown name lists what is available, modules not yet loaded included, and suggests the
 * nearest name by edit distance, also for names outside [a-z0-9_]; a name far from every
 * backend gets no suggestion. */
static void test_unknown_name_suggests(void **state)
{
    (void)state;
    const char *msg = create_error("symplectc_euler");
    assert_non_null(strstr(msg, "'symplectic_euler'"));
    assert_non_null(strstr(msg, "testmod"));          /* listed from DEFSIM_BACKEND_PATH */
    assert_non_null(strstr(msg, "velocity_verlet"));
    msg = create_error("Symplectic-Euler");
    assert_non_null(strstr(msg, "'symplectic_euler'"));
    msg = create_error("testmdo");
    assert_non_null(strstr(msg, "'testmod'"));
    msg = create_error("qqqqqqqqqqqq");
    assert_int_equal(quoted_names(msg), 1);
    assert_non_null(strstr(msg, "explicit_euler"));
}

static int host_steps;
static defsim_status my_init(const defsim_host *h, defsim_system *s, void *st)
{
    (void)h; (void)s; (void)st;
    return DEFSIM_OK;
}
static defsim_status my_step(const defsim_host *h, defsim_system *s, void *st, double dt)
{
    (void)st;
    /* Drift: x += dt v, a valid (if physics-free) integrator. */
    double *x = h->positions(s), *v = h->velocities(s);
    for (int64_t i = 0; i < h->dof_count(s); ++i) x[i] += dt * v[i];
    host_steps++;
    return DEFSIM_OK;
}
static void my_fini(const defsim_host *h, defsim_system *s, void *st) { (void)h; (void)s; (void)st; }

/* A backend table shorter than this header's (no reset field). */
typedef struct old_backend {
    uint32_t abi_version, struct_size;
    const char *name;
    uint32_t flags;
    size_t state_size;
    void *init, *step, *fini;
} old_backend;

static void test_register(void **state)
{
    (void)state;
    defsim_backend b = {.abi_version = DEFSIM_BACKEND_ABI_VERSION,
                        .struct_size = sizeof(defsim_backend), .name = "drift", .state_size = 16,
                        .init = my_init, .step = my_step, .fini = my_fini};
    static defsim_backend keep;
    keep = b;
    TU_OK(defsim_register_backend(&keep));
    assert_int_equal(defsim_register_backend(&keep), DEFSIM_ERR_CONFLICT);
    defsim_backend clash = keep;
    clash.name = "symplectic_euler";
    assert_int_equal(defsim_register_backend(&clash), DEFSIM_ERR_CONFLICT);
    assert_int_equal(defsim_register_backend(NULL), DEFSIM_ERR_INVALID_ARGUMENT);
    defsim_backend bad = keep;
    bad.name = "Bad Name";
    assert_int_equal(defsim_register_backend(&bad), DEFSIM_ERR_INVALID_ARGUMENT);
    bad = keep;
    bad.name = "newer";
    bad.abi_version = DEFSIM_BACKEND_ABI_VERSION + 1;
    assert_int_equal(defsim_register_backend(&bad), DEFSIM_ERR_INVALID_ARGUMENT);
    bad = keep;
    bad.name = "nostep";
    bad.step = NULL;
    assert_int_equal(defsim_register_backend(&bad), DEFSIM_ERR_INVALID_ARGUMENT);

    static old_backend old;
    old.abi_version = 1;
    old.struct_size = sizeof old;
    old.name = "old_drift";
    old.state_size = 0;
    *(defsim_status (**)(const defsim_host *, defsim_system *, void *))&old.init = my_init;
    *(defsim_status (**)(const defsim_host *, defsim_system *, void *, double))&old.step = my_step;
    *(void (**)(const defsim_host *, defsim_system *, void *))&old.fini = my_fini;
    /* Built against a version before 8 (which broke the host table): refused. */
    assert_int_equal(defsim_register_backend((const defsim_backend *)&old),
                     DEFSIM_ERR_INVALID_ARGUMENT);
    old.abi_version = DEFSIM_BACKEND_ABI_VERSION;
    TU_OK(defsim_register_backend((const defsim_backend *)&old));

    const char *names[2] = {"drift", "old_drift"};
    for (int k = 0; k < 2; ++k) {
        host_steps = 0;
        defsim_world *w = tu_world(names[k], -9.81, 1);
        const double lo[3] = {0, 0, 0}, hi[3] = {1, 1, 1};
        tu_add_box(w, DEFSIM_MODEL_STVK, 1, 1, 1, lo, hi, 1e5, 0.3, 1000);
        double v[3 * 8];
        for (int i = 0; i < 24; ++i) v[i] = i % 3 == 0 ? 2.0 : 0.0;
        TU_OK(defsim_world_set_state(w, NULL, v));   /* old table: reset reads as NULL */
        TU_OK(defsim_world_step(w, 0.5));
        double *x = tu_positions(w);
        assert_true(fabs(x[0] - 1.0) < 1e-15);   /* vertex 0 at x = 0 drifted by 0.5 * 2 */
        assert_int_equal(host_steps, 1);
        free(x);
        defsim_world_destroy(w);
    }
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_builtins_load_nothing),
        cmocka_unit_test(test_module_loads_and_matches),
        cmocka_unit_test(test_missing_module),
        cmocka_unit_test(test_unknown_name_suggests),
        cmocka_unit_test(test_register),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
