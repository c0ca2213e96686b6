/* SPDX-License-Identifier: MIT */
/*
 * Options and counters by name (issue 10): the world's own options ("core.*") and those its
 * backend declares in its table, their current values, the backend's counters, and the names
 * under which hosts reach them. One defsim__options lives in each world; nothing here knows the
 * world's layout, so the world calls in at creation, destruction, stepping and reset_stats.
 */
#ifndef DEFSIM_OPTIONS_H
#define DEFSIM_OPTIONS_H

#include "defsim/backend.h"
#include "status.h"

/* The core's own options, in the order defsim_world_option_info lists them; the options the
 * term kinds declare (term.h: contact's, body contact's) follow as "core.<name>", then the
 * backend's. */
enum {
    DEFSIM__OPT_SIMD = 0,          /* CHOICE auto|scalar|generic|avx2|avx512 */
    DEFSIM__OPT_AUTO_SUBSTEP = 1,  /* BOOL */
    DEFSIM__OPT_SUBSTEP_SAFETY = 2,/* REAL (0, 1] */
    DEFSIM__OPT_WATCHDOG = 3,      /* BOOL: the stability watchdog (watchdog.c) */
    DEFSIM__OPT_WATCHDOG_ENERGY_GROWTH = 4, /* REAL [1, 1e300] */
    DEFSIM__OPT_WATCHDOG_MAX_STRETCH = 5,   /* REAL [1, 1e300] */
    DEFSIM__CORE_OWN = 6,
    DEFSIM__CORE_MAX = 32          /* the core's own plus the terms' */
};

/* Contact's statistics ("contact.<name>"), in the order of contact.h's DEFSIM__CSTAT_*. */
enum { DEFSIM__CONTACT_STATS = 14 };

typedef struct defsim__options {
    int32_t ncore;           /* the core's options: its own, then the terms' */
    const defsim_option_spec *core_specs[DEFSIM__CORE_MAX];
    double core[DEFSIM__CORE_MAX];
    const defsim_backend *backend;
    double *values;          /* backend->option_count: current values */
    double *counters;        /* backend->counter_count */
    uint8_t *values_set;     /* backend->option_count: the host set the option */
    const char **names;      /* full names: core options, backend options, then counters */
    char *name_buf;          /* storage of the terms' and the backend's full names */
    int reinit;              /* a backend option changed since the backend's last init */
    uint8_t core_set[DEFSIM__CORE_MAX]; /* the host set the core option (environment variables
                                           give defaults only) */
    const double *contact_stats; /* DEFSIM__CONTACT_STATS values (the world's contact), or NULL */
} defsim__options;

/* Allocates the values and counters of backend b (defaults, counters zero), with the core's
 * options: its own, then the nterm options the term kinds declare (terms, static tables that
 * terms.c lists; world.c hands them over, as options.c sits below the terms); *o owns what it
 * allocates until defsim__options_free. On failure sets defsim_last_error() and leaves *o
 * freed. */
defsim_status defsim__options_init(defsim__options *o, const defsim_backend *b,
                                   const defsim_option_spec *const *terms, int32_t nterm);
void defsim__options_free(defsim__options *o);

/* Zeroes the backend's counters (defsim_world_reset_stats). */
void defsim__options_reset_counters(defsim__options *o);

/* Returns 1 once after a backend option changed: the world re-initialises its backend. */
int defsim__options_take_reinit(defsim__options *o);

/* The options resolved into what the core reads (MuJoCo's mjOption): the world resolves them
 * when an option changes, and its step and plan read fields, never names or accessors. */
typedef struct defsim__settings {
    const struct defsim__tet_kernels *tet_kernels; /* core.simd's kernels, NULL: scalar */
    int projection;          /* the backend's "projection" option, else clamp */
    int auto_substep;
    double substep_safety;
    int watchdog;
    double energy_growth, max_stretch;   /* core.watchdog_energy_growth, _max_stretch */
    double contact_dhat, contact_kappa, contact_frequency, friction_eps_v;
    int body_contact;
} defsim__settings;

/* Resolves the options into *out. core.simd: the environment variable DEFSIM_SIMD gives the
 * default, and an option the host set wins over it. A backend without a "projection" option
 * gets DEFSIM_PROJECTION_CLAMP. */
void defsim__options_resolve(const defsim__options *o, defsim__settings *out);

/* Host services (backend.h, ABI version 2; option_is_set, ABI 7). */
const double *defsim__options_values(const defsim__options *o);
int32_t defsim__options_is_set(const defsim__options *o, int32_t index);
double *defsim__options_counters(defsim__options *o);

/* Checks the options and counters a backend declares (registry). On error writes why to msg. */
int defsim__options_check_table(const defsim_backend *b, char *msg, size_t size);

/* What the world's public option and statistics calls do (world.c checks the world pointer
 * and applies changed settings to its compiled system). Errors go to msg. */
defsim_status defsim__options_set_text(defsim__options *o, defsim__messages *msg,
                                      const char *name, const char *value);
defsim_status defsim__options_set_number(defsim__options *o, defsim__messages *msg,
                                        const char *name, double value);
defsim_status defsim__options_get(const defsim__options *o, defsim__messages *msg,
                                  const char *name, double *value);
int32_t defsim__options_count(const defsim__options *o);
defsim_status defsim__options_info(const defsim__options *o, int32_t i, defsim_option_info *out);
int32_t defsim__options_stat_count(const defsim__options *o);
defsim_status defsim__options_stat_info(const defsim__options *o, const defsim_stats *stats,
                                        int32_t i, const char **name, double *value);
/* Sets statistic i (as stat_info numbers them) to value, converted to the field's type
 * (checkpoints restore them; the caller checks the range of integer fields). */
void defsim__options_stat_write(defsim__options *o, defsim_stats *stats, int32_t i, double value);
defsim_status defsim__options_stat(const defsim__options *o, defsim__messages *msg,
                                   const defsim_stats *stats, const char *name, double *value);

#endif /* DEFSIM_OPTIONS_H */
