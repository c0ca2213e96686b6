/* SPDX-License-Identifier: MIT */
/* Options and statistics by name (src/options.c): a host-registered backend that declares an
 * option of every type and two counters, the core's options, the deprecated world-def fields,
 * stats by name against defsim_stats, and the registry's checks of option tables. */
#include "test_util.h"

#include "assembly.h"
#include "tet_forces.h"
#include "world.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

/* ------------------------------------------------------------------------------------------ */
/* "opt_test": evaluates forces, then drifts (x += h v; pinned vertices have v = 0); records the
 * options it saw at init and counts inits and steps */

enum { OPT_RTOL, OPT_MAX_ORDER, OPT_VERBOSE, OPT_PROJECTION, OPT_MAX_ITERATIONS, OPT_N };
enum { CNT_INITS, CNT_STEPS, CNT_N };

static const defsim_option_spec OT_OPTIONS[OPT_N] = {
    {"rtol", DEFSIM_OPTION_REAL, 1e-4, 1e-12, 1.0, NULL, "relative tolerance"},
    {"max_order", DEFSIM_OPTION_INT, 4, 1, 4, NULL, "maximum order"},
    {"verbose", DEFSIM_OPTION_BOOL, 0, 0, 1, NULL, "log every step"},
    {"projection", DEFSIM_OPTION_CHOICE, 1, 0, 0, "none|clamp|abs", "Hessian projection"},
    {"max_iterations", DEFSIM_OPTION_INT, 5, 1, 10, NULL, "iterations per step"},
};
static const defsim_counter_spec OT_COUNTERS[CNT_N] = {
    {"inits", "initialisations since the counters were zeroed"},
    {"steps_taken", "steps"},
};

typedef struct ot_state {
    double *f;
} ot_state;

static double seen[OPT_N];   /* option values at the last init */

static defsim_status ot_init(const defsim_host *host, defsim_system *sys, void *state)
{
    ot_state *s = state;
    const double *v = host->option_values(sys);
    memcpy(seen, v, sizeof seen);
    host->counters(sys)[CNT_INITS] += 1.0;
    s->f = host->alloc((size_t)host->dof_count(sys) * sizeof(double));
    return s->f ? DEFSIM_OK : DEFSIM_ERR_OUT_OF_MEMORY;
}

static defsim_status ot_step(const defsim_host *host, defsim_system *sys, void *state, double h)
{
    ot_state *s = state;
    const int64_t n = host->dof_count(sys);
    defsim_status st = host->forces(sys, host->positions(sys), host->velocities(sys),
                                    DEFSIM_FORCE_ALL, s->f);
    for (int64_t i = 0; i < n && st == DEFSIM_OK; ++i)
        host->positions(sys)[i] += h * host->velocities(sys)[i];
    if (st != DEFSIM_OK) return st;
    host->counters(sys)[CNT_STEPS] += 1.0;
    return DEFSIM_OK;
}

static void ot_fini(const defsim_host *host, defsim_system *sys, void *state)
{
    (void)sys;
    ot_state *s = state;
    host->release(s->f);
    s->f = NULL;
}

static const defsim_backend OT_BACKEND = {
    .abi_version = DEFSIM_BACKEND_ABI_VERSION,
    .struct_size = sizeof(defsim_backend),
    .name = "opt_test",
    .state_size = sizeof(ot_state),
    .init = ot_init,
    .step = ot_step,
    .fini = ot_fini,
    .options = OT_OPTIONS,
    .option_count = OPT_N,
    .counters = OT_COUNTERS,
    .counter_count = CNT_N,
};

static int register_once(void **state)
{
    (void)state;
    defsim_status st = defsim_register_backend(&OT_BACKEND);
    return st == DEFSIM_OK || st == DEFSIM_ERR_CONFLICT ? 0 : -1;
}

static const double LO[3] = {0, 0, 0}, HI[3] = {0.4, 0.1, 0.1};

/* A clamped beam of 4x1x1 cells on backend `name`. */
static defsim_world *beam_world(const char *name)
{
    defsim_world *w = tu_world(name, -9.81, 1);
    defsim_body_id b = tu_add_box(w, DEFSIM_MODEL_STABLE_NEOHOOKEAN, 4, 1, 1, LO, HI, 1e5, 0.3,
                                  1000);
    assert_true(tu_pin_below(w, b, 0, 0.0) == 4);
    return w;
}

static double get(const defsim_world *w, const char *name)
{
    double v = NAN;
    TU_OK(defsim_world_get_option(w, name, &v));
    return v;
}

static double stat(const defsim_world *w, const char *name)
{
    double v = NAN;
    TU_OK(defsim_world_stat(w, name, &v));
    return v;
}

/* ------------------------------------------------------------------------------------------ */

/* Every type by text and by number; the info iterator describes core then backend options. */
static void test_types(void **state)
{
    (void)state;
    defsim_world *w = beam_world("opt_test");
    assert_int_equal(defsim_world_option_count(w), 11 + OPT_N);
    const char *names[16] = {"core.simd", "core.auto_substep", "core.substep_safety",
                            "core.watchdog", "core.watchdog_energy_growth",
                            "core.watchdog_max_stretch", "core.contact_dhat", "core.contact_kappa",
                            "core.contact_frequency", "core.friction_eps_v", "core.body_contact",
                            "opt_test.rtol",
                            "opt_test.max_order", "opt_test.verbose", "opt_test.projection",
                            "opt_test.max_iterations"};
    const defsim_option_type types[16] = {DEFSIM_OPTION_CHOICE, DEFSIM_OPTION_BOOL,
                                         DEFSIM_OPTION_REAL, DEFSIM_OPTION_BOOL,
                                         DEFSIM_OPTION_REAL, DEFSIM_OPTION_REAL,
                                         DEFSIM_OPTION_REAL, DEFSIM_OPTION_REAL,
                                         DEFSIM_OPTION_REAL, DEFSIM_OPTION_REAL,
                                         DEFSIM_OPTION_BOOL, DEFSIM_OPTION_REAL,
                                         DEFSIM_OPTION_INT, DEFSIM_OPTION_BOOL,
                                         DEFSIM_OPTION_CHOICE, DEFSIM_OPTION_INT};
    const double defaults[16] = {0, 0, 0.8, 1, 10, 100, 1e-3, 0, 0, 1e-3, 0, 1e-4, 4, 0, 1, 5};
    const double maxima[16] = {4, 1, 1, 1, 1e300, 1e300, 0.1, 1e20, 1e12, 1e3, 1, 1, 4, 1, 2, 10};
    for (int i = 0; i < 16; ++i) {
        defsim_option_info info = {.size = sizeof info};
        TU_OK(defsim_world_option_info(w, i, &info));
        assert_string_equal(info.name, names[i]);
        assert_int_equal(info.type, types[i]);
        assert_true(info.value == defaults[i] && info.default_value == defaults[i]);
        assert_true(info.max_value == maxima[i]);
        assert_true(get(w, names[i]) == defaults[i]);
        assert_true((info.choices != NULL) == (types[i] == DEFSIM_OPTION_CHOICE));
        assert_non_null(info.doc);
    }
    defsim_option_info info = {.size = sizeof info};
    assert_int_equal(defsim_world_option_info(w, 16, &info), DEFSIM_ERR_INVALID_ARGUMENT);
    assert_int_equal(defsim_world_option_info(w, -1, &info), DEFSIM_ERR_INVALID_ARGUMENT);
    /* An older, shorter info struct receives the fields it knows. */
    struct { uint32_t size; const char *name; } small = {sizeof small, NULL};
    TU_OK(defsim_world_option_info(w, 11, (defsim_option_info *)&small));
    assert_string_equal(small.name, "opt_test.rtol");

    TU_OK(defsim_world_set_option(w, "opt_test.rtol", " 2.5e-7 "));
    assert_true(get(w, "opt_test.rtol") == 2.5e-7);
    TU_OK(defsim_world_set_option_number(w, "opt_test.rtol", 1.0));   /* inclusive bound */
    assert_true(get(w, "opt_test.rtol") == 1.0);
    TU_OK(defsim_world_set_option(w, "opt_test.max_order", "2"));
    assert_true(get(w, "opt_test.max_order") == 2);
    TU_OK(defsim_world_set_option(w, "opt_test.max_order", "1e0"));
    assert_true(get(w, "opt_test.max_order") == 1);
    const char *bools[6] = {"true", "off", "ON", "0", "1", "False"};
    const double bv[6] = {1, 0, 1, 0, 1, 0};
    for (int i = 0; i < 6; ++i) {
        TU_OK(defsim_world_set_option(w, "opt_test.verbose", bools[i]));
        assert_true(get(w, "opt_test.verbose") == bv[i]);
    }
    TU_OK(defsim_world_set_option(w, "opt_test.projection", "abs"));
    assert_true(get(w, "opt_test.projection") == 2);
    TU_OK(defsim_world_set_option(w, "opt_test.projection", "none"));
    assert_true(get(w, "opt_test.projection") == 0);
    TU_OK(defsim_world_set_option_number(w, "opt_test.projection", 1));
    assert_true(get(w, "opt_test.projection") == 1);
    TU_OK(defsim_world_set_option(w, "core.substep_safety", "0.25"));
    assert_true(get(w, "core.substep_safety") == 0.25);
    TU_OK(defsim_world_set_option(w, "core.auto_substep", "on"));
    assert_true(get(w, "core.auto_substep") == 1);
    TU_OK(defsim_world_set_option(w, "core.simd", "generic"));
    assert_true(get(w, "core.simd") == 2);
    defsim_world_destroy(w);
}

/* Bad names and values fail with INVALID_ARGUMENT and change nothing: the world then steps
 * bit-identically to one that never saw them, without re-initialising its backend. */
static void test_bad_input(void **state)
{
    (void)state;
    defsim_world *w = beam_world("opt_test"), *ref = beam_world("opt_test");
    TU_OK(defsim_world_step(w, 1e-4));
    TU_OK(defsim_world_step(ref, 1e-4));
    struct { const char *name, *value; } bad[] = {
        {"opt_test.rtol", "0"},          {"opt_test.rtol", "2"},
        {"opt_test.rtol", "1e-4x"},      {"opt_test.rtol", ""},
        {"opt_test.rtol", "nan"},        {"opt_test.rtol", "inf"},
        {"opt_test.max_order", "2.5"},   {"opt_test.max_order", "5"},
        {"opt_test.max_order", "0"},     {"opt_test.verbose", "maybe"},
        {"opt_test.verbose", "2"},       {"opt_test.projection", "clip"},
        {"opt_test.projection", "1"},    {"opt_test.nothing", "1"},
        {"sundials_ida.rtol", "1e-6"},   {"symplectic_euler.rtol", "1e-6"},
        {"rtol", "1e-6"},                {"core.nothing", "1"},
        {"core.substep_safety", "0"},    {"core.substep_safety", "1.5"},
        {"core.simd", "sse2"},           {"opt_test.rtol", NULL},
        {NULL, "1"},                     {"", "1"},
    };
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; ++i) {
        assert_int_equal(defsim_world_set_option(w, bad[i].name, bad[i].value),
                         DEFSIM_ERR_INVALID_ARGUMENT);
        assert_true(defsim_world_last_error(w)[0] != '\0');
    }
    const struct { const char *name; double value; } badn[] = {
        {"opt_test.rtol", -1.0},        {"opt_test.rtol", NAN},
        {"opt_test.rtol", INFINITY},    {"opt_test.max_order", 3.5},
        {"opt_test.verbose", 0.5},      {"opt_test.projection", 3},
        {"opt_test.projection", -1},    {"opt_test.projection", 0.5},
        {"core.auto_substep", 2},
    };
    for (size_t i = 0; i < sizeof badn / sizeof badn[0]; ++i)
        assert_int_equal(defsim_world_set_option_number(w, badn[i].name, badn[i].value),
                         DEFSIM_ERR_INVALID_ARGUMENT);
    double v;
    assert_int_equal(defsim_world_get_option(w, "opt_test.nothing", &v),
                     DEFSIM_ERR_INVALID_ARGUMENT);
    assert_int_equal(defsim_world_get_option(w, "opt_test.rtol", NULL),
                     DEFSIM_ERR_INVALID_ARGUMENT);
    assert_int_equal(defsim_world_set_option(NULL, "opt_test.rtol", "1"),
                     DEFSIM_ERR_INVALID_ARGUMENT);
    assert_int_equal(defsim_world_option_count(NULL), 0);
    for (int i = 0; i < OPT_N; ++i) {
        defsim_option_info info = {.size = sizeof info};
        TU_OK(defsim_world_option_info(w, 11 + i, &info));
        assert_true(info.value == OT_OPTIONS[i].default_value);
    }
    for (int k = 0; k < 3; ++k) {
        TU_OK(defsim_world_step(w, 1e-4));
        TU_OK(defsim_world_step(ref, 1e-4));
    }
    assert_true(stat(w, "opt_test.inits") == 1.0);
    double *x = tu_positions(w), *xr = tu_positions(ref);
    int n = defsim_world_vertex_count(w);
    assert_memory_equal(x, xr, 3 * (size_t)n * sizeof *x);
    free(x);
    free(xr);
    defsim_world_destroy(w);
    defsim_world_destroy(ref);
}

/* A changed backend option re-initialises the backend before the next step, which sees the new
 * value; the same value, or a core option, does not. Counters survive re-initialisation. */
static void test_reinit_on_change(void **state)
{
    (void)state;
    defsim_world *w = beam_world("opt_test");
    TU_OK(defsim_world_step(w, 1e-4));
    assert_true(stat(w, "opt_test.inits") == 1.0 && seen[OPT_RTOL] == 1e-4);
    TU_OK(defsim_world_set_option(w, "opt_test.rtol", "1e-6"));
    TU_OK(defsim_world_set_option(w, "opt_test.projection", "abs"));
    assert_true(stat(w, "opt_test.inits") == 1.0);   /* not before the next step */
    TU_OK(defsim_world_step(w, 1e-4));
    assert_true(stat(w, "opt_test.inits") == 2.0);
    assert_true(seen[OPT_RTOL] == 1e-6 && seen[OPT_PROJECTION] == 2.0);
    assert_true(stat(w, "opt_test.steps_taken") == 2.0);
    TU_OK(defsim_world_set_option(w, "opt_test.rtol", "1e-6"));
    TU_OK(defsim_world_set_option(w, "core.substep_safety", "0.5"));
    TU_OK(defsim_world_step(w, 1e-4));
    assert_true(stat(w, "opt_test.inits") == 2.0);
    defsim_world_destroy(w);
}

/* The world def holds only what every backend shares; the settings are options that start at
 * their defaults, and a def of the size that ends before log (the first field that a host may
 * leave out) is accepted. */
static void test_def_shared(void **state)
{
    (void)state;
    defsim_world_def d;
    memset(&d, 0xA5, sizeof d);
    defsim_world_def_init(&d, sizeof d);
    assert_int_equal(d.size, sizeof d);
    assert_string_equal(d.backend, "symplectic_euler");
    assert_true(d.gravity[0] == 0.0 && d.gravity[1] == -9.81 && d.gravity[2] == 0.0);
    assert_int_equal(d.num_threads, 0);
    assert_null(d.log);
    assert_null(d.log_user);
    d.backend = "opt_test";
    d.size = (uint32_t)offsetof(defsim_world_def, log);
    defsim_world *w;
    TU_OK(defsim_world_create(&d, &w));
    assert_true(get(w, "opt_test.rtol") == 1e-4);
    assert_true(get(w, "opt_test.max_order") == 4);
    assert_true(get(w, "opt_test.projection") == 1);
    assert_true(get(w, "opt_test.max_iterations") == 5);
    assert_true(get(w, "core.auto_substep") == 0);
    assert_true(get(w, "core.substep_safety") == 0.8);
    defsim_world_destroy(w);
    d.size = (uint32_t)offsetof(defsim_world_def, log) - 1;
    assert_int_equal(defsim_world_create(&d, &w), DEFSIM_ERR_INVALID_ARGUMENT);
    assert_null(w);
}

/* core.auto_substep set by name splits steps the same way whether it is set before the bodies
 * are added or after. */
static void test_auto_substep_option(void **state)
{
    (void)state;
    defsim_world *a = beam_world("symplectic_euler");
    defsim_world_def d;
    defsim_world_def_init(&d, sizeof d);
    d.num_threads = 1;
    defsim_world *b;
    TU_OK(defsim_world_create(&d, &b));
    TU_OK(defsim_world_set_option(b, "core.auto_substep", "on"));
    TU_OK(defsim_world_set_option(b, "core.substep_safety", "0.5"));
    defsim_body_id id = tu_add_box(b, DEFSIM_MODEL_STABLE_NEOHOOKEAN, 4, 1, 1, LO, HI, 1e5, 0.3,
                                   1000);
    tu_pin_below(b, id, 0, 0.0);
    TU_OK(defsim_world_set_option(a, "core.auto_substep", "true"));
    TU_OK(defsim_world_set_option_number(a, "core.substep_safety", 0.5));
    for (int i = 0; i < 5; ++i) {
        TU_OK(defsim_world_step(a, 1e-2));
        TU_OK(defsim_world_step(b, 1e-2));
    }
    assert_true(stat(a, "substeps") > 5 * 2);
    assert_true(stat(a, "substeps") == stat(b, "substeps"));
    double *xa = tu_positions(a), *xb = tu_positions(b);
    assert_memory_equal(xa, xb, 3 * (size_t)defsim_world_vertex_count(a) * sizeof *xa);
    /* Off again: one backend step per call. */
    TU_OK(defsim_world_set_option(a, "core.auto_substep", "false"));
    double s0 = stat(a, "substeps");
    TU_OK(defsim_world_step(a, 1e-5));
    assert_true(stat(a, "substeps") == s0);
    free(xa);
    free(xb);
    defsim_world_destroy(a);
    defsim_world_destroy(b);
}

/* The backend's "projection" option is the projection the core's matrix services apply: a
 * backend without the option gets clamp (the same product as opt_test's clamp), and none
 * differs from clamp where tets are inverted. */
static void test_projection_option(void **state)
{
    (void)state;
    enum { NX = 24 };   /* 8 vertices of one cell */
    double dx[NX], out[3][NX];
    for (int i = 0; i < NX; ++i) dx[i] = sin(1.0 + i);
    const char *backends[3] = {"opt_test", "opt_test", "symplectic_euler"};
    const char *proj[3] = {"none", "clamp", NULL};
    for (int k = 0; k < 3; ++k) {
        defsim_world_def d;
        defsim_world_def_init(&d, sizeof d);
        d.backend = backends[k];
        d.num_threads = 1;
        defsim_world *w;
        TU_OK(defsim_world_create(&d, &w));
        tu_add_box(w, DEFSIM_MODEL_STABLE_NEOHOOKEAN, 1, 1, 1, LO, HI, 1e5, 0.3, 1000);
        if (proj[k]) TU_OK(defsim_world_set_option(w, "opt_test.projection", proj[k]));
        double *x = tu_positions(w);
        for (int a = 0; a < 3; ++a) x[3 * 7 + a] = -0.3 * HI[a];   /* corner (1,1,1) pushed through */
        TU_OK(defsim__world_plan(w));
        defsim_matrix_coeffs c = {1.0, 0.0, 0.0, 0.0};
        TU_OK(defsim__matrix_product(&w->sys, x, &c, dx, out[k]));
        free(x);
        defsim_world_destroy(w);
    }
    assert_memory_equal(out[1], out[2], sizeof out[0]);
    double diff = 0.0, norm = 0.0;
    for (int i = 0; i < NX; ++i) {
        diff = fmax(diff, fabs(out[0][i] - out[1][i]));
        norm = fmax(norm, fabs(out[0][i]));
    }
    assert_true(diff > 1e-3 * norm);
}

/* Every field of defsim_stats by its name equals the struct's after steps; the iterator lists
 * them and the backend's counters, each once; counters reset with the stats. */
static void test_stats_by_name(void **state)
{
    (void)state;
    defsim_world *w = beam_world("opt_test");
    for (int i = 0; i < 7; ++i) TU_OK(defsim_world_step(w, 1e-4));
    TU_OK(defsim_world_stable_step(w, NULL, NULL));
    defsim_stats s = {.size = sizeof s};
    TU_OK(defsim_world_stats(w, &s));
    const struct { const char *name; double value; } fields[] = {
        {"passes", s.passes}, {"steps", (double)s.steps}, {"failed_steps", (double)s.failed_steps},
        {"threads", s.threads}, {"reordered_tets", s.reordered_tets},
        {"time_step", s.time_step}, {"time_forces", s.time_forces},
        {"time_hessian", s.time_hessian}, {"force_evals", (double)s.force_evals},
        {"hessian_evals", (double)s.hessian_evals}, {"energy_evals", (double)s.energy_evals},
        {"substeps", (double)s.substeps}, {"stable_step", s.stable_step},
        {"min_volume_ratio", s.min_volume_ratio},
        {"inverted_elements", (double)s.inverted_elements}, {"energy_drift", s.energy_drift},
        {"watchdog_trips", (double)s.watchdog_trips},
    };
    const int nf = (int)(sizeof fields / sizeof fields[0]);
    for (int i = 0; i < nf; ++i) assert_true(stat(w, fields[i].name) == fields[i].value);
    assert_true(stat(w, "steps") == 7 && stat(w, "opt_test.steps_taken") == 7);
    /* the backend counters that defsim_stats held before are names of no statistic now */
    double gone;
    assert_int_equal(defsim_world_stat(w, "internal_steps", &gone), DEFSIM_ERR_INVALID_ARGUMENT);
    assert_int_equal(defsim_world_stat(w, "newton_iterations", &gone),
                     DEFSIM_ERR_INVALID_ARGUMENT);
    assert_true(stat(w, "force_evals") >= 7 && stat(w, "stable_step") > 0);
    /* and 14 contact.*, then the term kinds' counters (no contact here: zero) */
    static const char *const term_counters[] = {
        "collider.linearisations", "body_contact.linearisations", "body_contact.cached_pairs"};
    enum { NT = 3 };
    assert_int_equal(defsim_world_stat_count(w), nf + CNT_N + 14 + NT);
    for (int i = 0; i < nf + CNT_N + 14 + NT; ++i) {
        const char *name;
        double v, by_name;
        TU_OK(defsim_world_stat_info(w, i, &name, &v));
        TU_OK(defsim_world_stat(w, name, &by_name));
        assert_true(v == by_name);
        if (i < nf) assert_string_equal(name, fields[i].name);
        if (i >= nf + CNT_N + 14) {
            assert_string_equal(name, term_counters[i - nf - CNT_N - 14]);
            assert_true(v == 0.0);
        }
    }
    assert_true(stat(w, "opt_test.steps_taken") == 7 && stat(w, "opt_test.inits") == 1);
    double v;
    assert_int_equal(defsim_world_stat(w, "size", &v), DEFSIM_ERR_INVALID_ARGUMENT);
    assert_int_equal(defsim_world_stat(w, "opt_test.nothing", &v), DEFSIM_ERR_INVALID_ARGUMENT);
    assert_int_equal(defsim_world_stat_info(w, nf + CNT_N + 14 + NT, NULL, &v),
                     DEFSIM_ERR_INVALID_ARGUMENT);

    defsim_world_reset_stats(w);
    assert_true(stat(w, "opt_test.steps_taken") == 0 && stat(w, "opt_test.inits") == 0);
    assert_true(stat(w, "steps") == 0 && stat(w, "force_evals") == 0);
    assert_true(stat(w, "threads") == 1);
    for (int i = 0; i < 2; ++i) TU_OK(defsim_world_step(w, 1e-4));
    assert_true(stat(w, "opt_test.steps_taken") == 2 && stat(w, "opt_test.inits") == 0);
    defsim_world_destroy(w);
}

/* The registry accepts tables of ABI version 1 (which end before `options`) and refuses option
 * and counter tables that are malformed. */
static defsim_status nop_init(const defsim_host *h, defsim_system *s, void *st)
{
    (void)st;
    /* A version-1 backend gets no options and no counters. */
    return h->option_values(s) == NULL && h->counters(s) == NULL ? DEFSIM_OK
                                                                 : DEFSIM_ERR_INVALID_ARGUMENT;
}
static defsim_status nop_step(const defsim_host *h, defsim_system *s, void *st, double dt)
{
    (void)h, (void)s, (void)st, (void)dt;
    return DEFSIM_OK;
}
static void nop_fini(const defsim_host *h, defsim_system *s, void *st) { (void)h, (void)s, (void)st; }
static double half_period(double omega, double c) { (void)c; return 3.14159 / omega; }
/* Version 4: the limit scales with the option rtol, which the op reads from the values given. */
static double rtol_period(const double *values, double omega, double c)
{
    (void)c;
    return values[OPT_RTOL] * 1e4 * 6.28318 / omega;
}

static void test_registry_tables(void **state)
{
    (void)state;
    /* A table that ends before `options` (struct_size): the fields after stable_step are
     * garbage here and must not be read. Built against a version before 8, it is refused. */
    static defsim_backend v1;
    memset(&v1, 0xA5, sizeof v1);
    v1.abi_version = 1;
    v1.struct_size = (uint32_t)offsetof(defsim_backend, options);
    v1.name = "opt_v1";
    v1.flags = 0;
    v1.state_size = 0;
    v1.init = nop_init;
    v1.step = nop_step;
    v1.fini = nop_fini;
    v1.reset = NULL;
    v1.stable_step = NULL;
    assert_int_equal(defsim_register_backend(&v1), DEFSIM_ERR_INVALID_ARGUMENT);
    v1.abi_version = DEFSIM_BACKEND_ABI_VERSION;
    defsim_status st = defsim_register_backend(&v1);
    assert_true(st == DEFSIM_OK || st == DEFSIM_ERR_CONFLICT);
    defsim_world *w = beam_world("opt_v1");
    assert_int_equal(defsim_world_option_count(w), 11);
    assert_int_equal(defsim_world_stat_count(w), 17 + 14 + 3);   /* fields, contact.*, terms' */
    TU_OK(defsim_world_step(w, 1e-4));
    defsim_world_destroy(w);

    /* A table that ends before stable_step_options (garbage here): the core reports
     * stable_step. With stable_step_options, given the world's option values, that op wins
     * over stable_step, and auto_substep follows it after an option changes. */
    static defsim_backend v3, v4;
    memset(&v3, 0xA5, sizeof v3);
    memcpy(&v3, &OT_BACKEND, offsetof(defsim_backend, stable_step_options));
    v3.abi_version = DEFSIM_BACKEND_ABI_VERSION;
    v3.struct_size = (uint32_t)offsetof(defsim_backend, stable_step_options);
    v3.name = "opt_v3";
    v3.stable_step = half_period;
    v4 = OT_BACKEND;
    v4.name = "opt_v4";
    v4.stable_step = half_period;
    v4.stable_step_options = rtol_period;
    for (int k = 0; k < 2; ++k) {
        st = defsim_register_backend(k ? &v4 : &v3);
        assert_true(st == DEFSIM_OK || st == DEFSIM_ERR_CONFLICT);
        w = beam_world(k ? "opt_v4" : "opt_v3");
        TU_OK(defsim_world_set_option(w, "core.auto_substep", "true"));
        double h = 0.0, om = 0.0, subs = 0.0;
        TU_OK(defsim_world_stable_step(w, &h, &om));
        /* rtol defaults to 1e-4: 2 pi / omega for version 4, pi / omega for version 3. */
        assert_true(om > 0.0 && fabs(h * om - (k ? 6.28318 : 3.14159)) < 1e-12);
        TU_OK(defsim_world_set_option(w, k ? "opt_v4.rtol" : "opt_v3.rtol", "2e-4"));
        TU_OK(defsim_world_stable_step(w, &h, NULL));
        assert_true(fabs(h * om - (k ? 12.56636 : 3.14159)) < 1e-12);
        /* One step of 39.9 limits at safety 0.8: ceil(49.875) = 50 substeps. */
        TU_OK(defsim_world_step(w, 39.9 * h));
        TU_OK(defsim_world_stat(w, "substeps", &subs));
        assert_true(subs == 50.0);
        defsim_world_destroy(w);
    }

    static const defsim_option_spec dup[2] = {
        {"a", DEFSIM_OPTION_REAL, 0, 0, 1, NULL, ""}, {"a", DEFSIM_OPTION_INT, 0, 0, 1, NULL, ""}};
    static const defsim_option_spec bad_default[1] = {{"a", DEFSIM_OPTION_REAL, 2, 0, 1, NULL, ""}};
    static const defsim_option_spec bad_int[1] = {{"a", DEFSIM_OPTION_INT, 0.5, 0, 1, NULL, ""}};
    static const defsim_option_spec bad_bool[1] = {{"a", DEFSIM_OPTION_BOOL, 2, 0, 1, NULL, ""}};
    static const defsim_option_spec bad_choice[1] = {{"a", DEFSIM_OPTION_CHOICE, 0, 0, 0, "x||y", ""}};
    static const defsim_option_spec no_choice[1] = {{"a", DEFSIM_OPTION_CHOICE, 0, 0, 0, NULL, ""}};
    static const defsim_option_spec choice_idx[1] = {{"a", DEFSIM_OPTION_CHOICE, 2, 0, 0, "x|y", ""}};
    static const defsim_option_spec bad_name[1] = {{"A", DEFSIM_OPTION_REAL, 0, 0, 1, NULL, ""}};
    static const defsim_option_spec bad_type[1] = {{"a", (defsim_option_type)9, 0, 0, 1, NULL, ""}};
    static const defsim_counter_spec dup_counters[2] = {{"c", ""}, {"c", ""}};
    const struct { const defsim_option_spec *o; int32_t no; const defsim_counter_spec *c;
                   int32_t nc; } cases[] = {
        {dup, 2, NULL, 0},        {bad_default, 1, NULL, 0}, {bad_int, 1, NULL, 0},
        {bad_bool, 1, NULL, 0},   {bad_choice, 1, NULL, 0},  {no_choice, 1, NULL, 0},
        {choice_idx, 1, NULL, 0}, {bad_name, 1, NULL, 0},    {bad_type, 1, NULL, 0},
        {NULL, 1, NULL, 0},       {dup, -1, NULL, 0},        {NULL, 0, dup_counters, 2},
        {NULL, 0, NULL, 1},
    };
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; ++i) {
        defsim_backend b = OT_BACKEND;
        b.name = "opt_bad";
        b.options = cases[i].o;
        b.option_count = cases[i].no;
        b.counters = cases[i].c;
        b.counter_count = cases[i].nc;
        assert_int_equal(defsim_register_backend(&b), DEFSIM_ERR_INVALID_ARGUMENT);
    }
    defsim_backend core = OT_BACKEND;
    core.name = "core";
    assert_int_equal(defsim_register_backend(&core), DEFSIM_ERR_INVALID_ARGUMENT);
}

/* The host table says which backend options the host set (option_is_set, ABI 7): a backend
 * whose environment variable gives an option's default (DEFSIM_CHOLMOD_*) lets the host's
 * setting win. Setting an option to the value it has counts as setting it. */
static void test_option_is_set(void **state)
{
    (void)state;
    defsim_world *w = beam_world("opt_test");
    assert_true(defsim__host.abi_version >= 7u && defsim__host.option_is_set != NULL);
    for (int32_t i = 0; i < OPT_N; ++i) assert_int_equal(defsim__host.option_is_set(&w->handle, i), 0);
    TU_OK(defsim_world_set_option(w, "opt_test.max_order", "4"));   /* the default */
    TU_OK(defsim_world_set_option_number(w, "opt_test.rtol", 1e-6));
    for (int32_t i = 0; i < OPT_N; ++i)
        assert_int_equal(defsim__host.option_is_set(&w->handle, i),
                         i == OPT_MAX_ORDER || i == OPT_RTOL);
    assert_int_equal(defsim__host.option_is_set(&w->handle, OPT_N), 0);   /* out of range */
    assert_int_equal(defsim__host.option_is_set(&w->handle, -1), 0);
    assert_int_equal(defsim_world_set_option(w, "opt_test.max_order", "9"),
                     DEFSIM_ERR_INVALID_ARGUMENT);
    defsim_world_destroy(w);
}

/* core.simd picks the tet kernels when the world plans, and at once when it is already planned;
 * DEFSIM_SIMD gives its default, never overrides what the host set. Scalar and batched forces
 * agree to rounding. */
static void test_simd_option(void **state)
{
    (void)state;
    unsetenv("DEFSIM_SIMD");
    defsim_world *w = tu_world("symplectic_euler", 0.0, 1);
    tu_add_box(w, DEFSIM_MODEL_NEOHOOKEAN, 3, 2, 2, LO, HI, 1e5, 0.3, 1000);
    const int n = defsim_world_vertex_count(w);
    double *x = tu_positions(w);
    unsigned long long seed = 7;
    for (int i = 0; i < 3 * n; ++i) x[i] *= 1.0 + 0.05 * tu_rand(&seed);
    double *fs = malloc(3 * (size_t)n * sizeof *fs), *fg = malloc(3 * (size_t)n * sizeof *fg);
    TU_OK(defsim_world_set_option(w, "core.simd", "scalar"));
    TU_OK(defsim_world_forces(w, x, fs));
    assert_null(w->sys.tet_kernels);
    TU_OK(defsim_world_set_option(w, "core.simd", "generic"));   /* planned: applies at once */
    assert_ptr_equal(w->sys.tet_kernels, &defsim__tet_kernels_generic);
    TU_OK(defsim_world_forces(w, x, fg));
    assert_true(tu_rel_diff(fg, fs, 3 * n, 1e-300) < 1e-12);
    TU_OK(defsim_world_set_option(w, "core.simd", "auto"));
    assert_ptr_equal(w->sys.tet_kernels, defsim__tet_kernels_best());
    const char *x86[2] = {"avx2", "avx512"};
    for (int i = 0; i < 2; ++i)
        assert_int_equal(defsim_world_set_option(w, "core.simd", x86[i]),
                         defsim__tet_kernels_find(x86[i]) ? DEFSIM_OK
                                                          : DEFSIM_ERR_INVALID_ARGUMENT);
    /* The environment variable gives the default only: a world whose host did not set
     * core.simd takes it, and an option the host set wins over it (even "auto", the value the
     * option had). */
    setenv("DEFSIM_SIMD", "scalar", 1);
    for (int set_auto = 0; set_auto < 2; ++set_auto) {
        defsim_world *e = tu_world("symplectic_euler", 0.0, 1);
        tu_add_box(e, DEFSIM_MODEL_NEOHOOKEAN, 3, 2, 2, LO, HI, 1e5, 0.3, 1000);
        if (set_auto) TU_OK(defsim_world_set_option(e, "core.simd", "auto"));
        TU_OK(defsim_world_forces(e, x, fg));
        if (set_auto) {
            assert_ptr_equal(e->sys.tet_kernels, defsim__tet_kernels_best());
        } else {
            assert_null(e->sys.tet_kernels);
            assert_memory_equal(fg, fs, 3 * (size_t)n * sizeof *fs);
            TU_OK(defsim_world_set_option(e, "core.simd", "generic"));
            assert_ptr_equal(e->sys.tet_kernels, &defsim__tet_kernels_generic);
        }
        defsim_world_destroy(e);
    }
    unsetenv("DEFSIM_SIMD");
    /* Without it, the host's option as before. */
    TU_OK(defsim_world_set_option(w, "core.simd", "generic"));
    defsim__world_unplan(w);
    TU_OK(defsim_world_forces(w, x, fg));
    assert_ptr_equal(w->sys.tet_kernels, &defsim__tet_kernels_generic);
    free(x);
    free(fs);
    free(fg);
    defsim_world_destroy(w);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_types),
        cmocka_unit_test(test_bad_input),
        cmocka_unit_test(test_reinit_on_change),
        cmocka_unit_test(test_def_shared),
        cmocka_unit_test(test_auto_substep_option),
        cmocka_unit_test(test_projection_option),
        cmocka_unit_test(test_stats_by_name),
        cmocka_unit_test(test_registry_tables),
        cmocka_unit_test(test_simd_option),
        cmocka_unit_test(test_option_is_set),
    };
    return cmocka_run_group_tests(tests, register_once, NULL);
}
