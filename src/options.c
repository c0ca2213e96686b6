/* SPDX-License-Identifier: MIT */
/*
 * Options and statistics by name.
 *
 * Contents:
 *   1. the core's options and the stats table (every field of defsim_stats by name)
 *   2. checking a backend's declared options and counters (registry)
 *   3. values: parsing text, validating numbers, describing what is valid
 *   4. a world's options: init, free, what the core reads
 *   5. by name: set, get, iterate, stats (world.c wraps these as the public calls)
 */
#include "options.h"

#include "status.h"
#include "tet_forces.h"

#include <float.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>

/* ------------------------------------------------------------------------------------------ */
/* 1. Tables */

static const char SIMD_CHOICES[] = "auto|scalar|generic|avx2|avx512";
enum { SIMD_AUTO = 0, SIMD_SCALAR = 1 };

static const defsim_option_spec CORE_SPECS[DEFSIM__CORE_OWN] = {
    {"simd", DEFSIM_OPTION_CHOICE, 0.0, 0.0, 0.0, SIMD_CHOICES,
     "tet and shell force kernels: auto (the fastest this CPU runs), scalar (reference), or one "
     "batched variant; the environment variable DEFSIM_SIMD gives the default, the option set "
     "wins"},
    {"auto_substep", DEFSIM_OPTION_BOOL, 0.0, 0.0, 1.0, NULL,
     "conditionally stable backends: split each step into substeps of at most substep_safety "
     "times the estimated stable step"},
    /* Below 0.01 a step would split into more than 100 x the substeps stability needs; 1e-300
     * made every step fail with "auto_substep would need 1e+300 substeps". */
    {"substep_safety", DEFSIM_OPTION_REAL, 0.8, 0.01, 1.0, NULL,
     "fraction of the stable step that auto_substep uses, in [0.01, 1]"},
    {"watchdog", DEFSIM_OPTION_BOOL, 1.0, 0.0, 1.0, NULL,
     "fail a step whose state leaves the envelope the scene explains (energy, extent, "
     "inversion; docs/watchdog.md) with DEFSIM_ERR_UNSTABLE; non-finite states fail either way"},
    {"watchdog_energy_growth", DEFSIM_OPTION_REAL, 10.0, 1.0, 1e300, NULL,
     "kinetic energy may reach this multiple of the energy at the reference plus the work of "
     "gravity and applied forces since (plus mass x size x max(|g|, 9.81 m/s^2))"},
    {"watchdog_max_stretch", DEFSIM_OPTION_REAL, 100.0, 1.0, 1e300, NULL,
     "a body's bounding-box diagonal may reach this multiple of its rest diagonal"},
};
static const char *const CORE_NAMES[DEFSIM__CORE_OWN] = {
    "core.simd", "core.auto_substep", "core.substep_safety", "core.watchdog",
    "core.watchdog_energy_growth", "core.watchdog_max_stretch"};
static const char *const CONTACT_STAT_NAMES[DEFSIM__CONTACT_STATS] = {
    "contact.active", "contact.pairs", "contact.min_distance", "contact.time_broad_phase",
    "contact.time_ccd", "contact.ccd_calls", "contact.time_eval", "contact.body_candidates",
    "contact.body_active", "contact.body_min_distance", "contact.time_body_broad",
    "contact.time_body_ccd", "contact.time_body_eval", "contact.pattern_growths"};

typedef enum { ST_U32, ST_I32, ST_I64, ST_F64 } stat_kind;
typedef struct stat_field {
    const char *name;
    size_t offset;
    stat_kind kind;
} stat_field;

#define STAT(field, kind) {#field, offsetof(defsim_stats, field), kind}
static const stat_field STATS[] = {
    STAT(passes, ST_U32), STAT(steps, ST_I64), STAT(failed_steps, ST_I64),
    STAT(threads, ST_I32), STAT(reordered_tets, ST_I32), STAT(time_step, ST_F64),
    STAT(time_forces, ST_F64), STAT(time_hessian, ST_F64), STAT(force_evals, ST_I64),
    STAT(hessian_evals, ST_I64), STAT(energy_evals, ST_I64), STAT(substeps, ST_I64),
    STAT(stable_step, ST_F64), STAT(min_volume_ratio, ST_F64), STAT(inverted_elements, ST_I64),
    STAT(energy_drift, ST_F64), STAT(watchdog_trips, ST_I64),
};
#undef STAT
enum { NSTATS = (int)(sizeof STATS / sizeof STATS[0]) };
/* A field appended to defsim_stats must be added above (and here). */
_Static_assert(offsetof(defsim_stats, watchdog_trips) + sizeof(int64_t) == sizeof(defsim_stats),
               "options.c: STATS must name every field of defsim_stats");

static double stat_read(const defsim_stats *s, const stat_field *f)
{
    const char *p = (const char *)s + f->offset;
    switch (f->kind) {
    case ST_U32: { uint32_t v; memcpy(&v, p, sizeof v); return (double)v; }
    case ST_I32: { int32_t v; memcpy(&v, p, sizeof v); return (double)v; }
    case ST_I64: { int64_t v; memcpy(&v, p, sizeof v); return (double)v; }
    default: { double v; memcpy(&v, p, sizeof v); return v; }
    }
}

/* ------------------------------------------------------------------------------------------ */
/* 2. Checking a backend's table */

static int valid_word(const char *s, size_t len)
{
    if (len == 0 || len > 63) return 0;
    for (size_t i = 0; i < len; ++i)
        if (!((s[i] >= 'a' && s[i] <= 'z') || (s[i] >= '0' && s[i] <= '9') || s[i] == '_'))
            return 0;
    return 1;
}

/* Number of names in a '|' list, or 0 if any is empty or not [a-z0-9_]+. */
static int count_choices(const char *choices)
{
    if (!choices) return 0;
    int n = 0;
    for (const char *p = choices;; ++n) {
        const char *bar = strchr(p, '|');
        size_t len = bar ? (size_t)(bar - p) : strlen(p);
        if (!valid_word(p, len)) return 0;
        if (!bar) return n + 1;
        p = bar + 1;
    }
}

/* Index of `name` (length len) in a '|' list, or -1. */
static int find_choice(const char *choices, const char *name, size_t len)
{
    int i = 0;
    for (const char *p = choices; p; ++i) {
        const char *bar = strchr(p, '|');
        size_t l = bar ? (size_t)(bar - p) : strlen(p);
        if (l == len && strncmp(p, name, len) == 0) return i;
        p = bar ? bar + 1 : NULL;
    }
    return -1;
}

static int spec_valid(const defsim_option_spec *s, char *msg, size_t size)
{
    if (!s->name || !valid_word(s->name, strlen(s->name))) {
        snprintf(msg, size, "option name '%s' is not of the form [a-z0-9_]{1,63}",
                 s->name ? s->name : "(null)");
        return 0;
    }
    const double d = s->default_value;
    switch (s->type) {
    case DEFSIM_OPTION_REAL:
    case DEFSIM_OPTION_INT:
        if (isnan(s->min_value) || isnan(s->max_value) || !(s->min_value <= s->max_value) ||
            !isfinite(d) || d < s->min_value || d > s->max_value ||
            (s->type == DEFSIM_OPTION_INT && d != floor(d))) {
            snprintf(msg, size, "option '%s': default %g outside [%g, %g] or not a %s", s->name,
                     d, s->min_value, s->max_value,
                     s->type == DEFSIM_OPTION_INT ? "whole number" : "finite number");
            return 0;
        }
        return 1;
    case DEFSIM_OPTION_BOOL:
        if (d != 0.0 && d != 1.0) {
            snprintf(msg, size, "option '%s': BOOL default %g is not 0 or 1", s->name, d);
            return 0;
        }
        return 1;
    case DEFSIM_OPTION_CHOICE: {
        int n = count_choices(s->choices);
        if (n == 0 || !(d >= 0.0 && d < n) || d != floor(d)) {
            snprintf(msg, size, "option '%s': choices '%s' are not names [a-z0-9_]+ separated "
                     "by '|', or default %g is not an index of them", s->name,
                     s->choices ? s->choices : "(null)", d);
            return 0;
        }
        return 1;
    }
    default:
        snprintf(msg, size, "option '%s': unknown type %d", s->name, (int)s->type);
        return 0;
    }
}

int defsim__options_check_table(const defsim_backend *b, char *msg, size_t size)
{
    if (b->option_count < 0 || b->counter_count < 0 || (b->option_count > 0 && !b->options) ||
        (b->counter_count > 0 && !b->counters)) {
        snprintf(msg, size, "negative option_count / counter_count, or a NULL table");
        return 0;
    }
    for (int32_t i = 0; i < b->option_count; ++i) {
        if (!spec_valid(&b->options[i], msg, size)) return 0;
        for (int32_t j = 0; j < i; ++j)
            if (strcmp(b->options[j].name, b->options[i].name) == 0) {
                snprintf(msg, size, "option '%s' is declared twice", b->options[i].name);
                return 0;
            }
    }
    for (int32_t i = 0; i < b->counter_count; ++i) {
        const char *n = b->counters[i].name;
        if (!n || !valid_word(n, strlen(n))) {
            snprintf(msg, size, "counter name '%s' is not of the form [a-z0-9_]{1,63}",
                     n ? n : "(null)");
            return 0;
        }
        for (int32_t j = 0; j < i; ++j)
            if (strcmp(b->counters[j].name, n) == 0) {
                snprintf(msg, size, "counter '%s' is declared twice", n);
                return 0;
            }
    }
    return 1;
}

/* ------------------------------------------------------------------------------------------ */
/* 3. Values */

/* "[min, max]", "true|false|on|off|1|0" or the choices: what `s` accepts, for messages. */
static void describe_valid(const defsim_option_spec *s, char *out, size_t size)
{
    switch (s->type) {
    case DEFSIM_OPTION_REAL:
        if (s->min_value == DBL_MIN)   /* how an open bound at 0 is declared */
            snprintf(out, size, "a number in (0, %g]", s->max_value);
        else
            snprintf(out, size, "a number in [%g, %g]", s->min_value, s->max_value);
        break;
    case DEFSIM_OPTION_INT:
        snprintf(out, size, "a whole number in [%.0f, %.0f]", s->min_value, s->max_value);
        break;
    case DEFSIM_OPTION_BOOL:
        snprintf(out, size, "true|false|on|off|1|0");
        break;
    default:
        snprintf(out, size, "one of %s", s->choices);
        break;
    }
}

/* Checks a number against `s`; 1 if it is valid. */
static int number_valid(const defsim_option_spec *s, double v)
{
    switch (s->type) {
    case DEFSIM_OPTION_REAL:
        return isfinite(v) && v >= s->min_value && v <= s->max_value;
    case DEFSIM_OPTION_INT:
        return isfinite(v) && v == floor(v) && v >= s->min_value && v <= s->max_value;
    case DEFSIM_OPTION_BOOL:
        return v == 0.0 || v == 1.0;
    default:
        return v >= 0.0 && v < count_choices(s->choices) && v == floor(v);
    }
}

/* Parses text for `s` into *v; 1 on success (range not checked yet). */
static int parse_text(const defsim_option_spec *s, const char *text, double *v)
{
    while (*text == ' ' || *text == '\t') ++text;
    size_t len = strlen(text);
    while (len > 0 && (text[len - 1] == ' ' || text[len - 1] == '\t')) --len;
    if (len == 0) return 0;
    if (s->type == DEFSIM_OPTION_BOOL) {
        static const char *const words[6] = {"false", "true", "off", "on", "0", "1"};
        for (int i = 0; i < 6; ++i)
            if (strlen(words[i]) == len && strncasecmp(text, words[i], len) == 0) {
                *v = (double)(i & 1);
                return 1;
            }
        return 0;
    }
    if (s->type == DEFSIM_OPTION_CHOICE) {
        int i = find_choice(s->choices, text, len);
        if (i < 0) return 0;
        *v = (double)i;
        return 1;
    }
    char *end;
    *v = strtod(text, &end);
    return end == text + len;
}

/* ------------------------------------------------------------------------------------------ */
/* 4. A world's options */

static int find_backend_option(const defsim_backend *b, const char *name)
{
    for (int32_t i = 0; i < b->option_count; ++i)
        if (strcmp(b->options[i].name, name) == 0) return i;
    return -1;
}

void defsim__options_free(defsim__options *o)
{
    free(o->values);
    free(o->counters);
    free(o->values_set);
    free(o->names);
    free(o->name_buf);
    memset(o, 0, sizeof *o);
}

defsim_status defsim__options_init(defsim__options *o, const defsim_backend *b,
                                   const defsim_option_spec *const *terms, int32_t nterm)
{
    memset(o, 0, sizeof *o);
    o->backend = b;
    if (nterm < 0 || nterm > DEFSIM__CORE_MAX - DEFSIM__CORE_OWN) {
        defsim__set_last_error("the term kinds declare %d options, more than %d", (int)nterm,
                               DEFSIM__CORE_MAX - DEFSIM__CORE_OWN);
        return DEFSIM_ERR_INVALID_ARGUMENT;
    }
    o->ncore = DEFSIM__CORE_OWN + nterm;
    for (int32_t i = 0; i < o->ncore; ++i) {
        o->core_specs[i] = i < DEFSIM__CORE_OWN ? &CORE_SPECS[i] : terms[i - DEFSIM__CORE_OWN];
        o->core[i] = o->core_specs[i]->default_value;
    }
    const size_t nk = (size_t)o->ncore, no = (size_t)b->option_count, nc = (size_t)b->counter_count;
    size_t bytes = 1;
    for (int32_t i = 0; i < nterm; ++i) bytes += strlen(terms[i]->name) + sizeof "core.";
    for (size_t i = 0; i < no; ++i) bytes += strlen(b->name) + strlen(b->options[i].name) + 2;
    for (size_t i = 0; i < nc; ++i) bytes += strlen(b->name) + strlen(b->counters[i].name) + 2;
    o->values = calloc(no + 1, sizeof *o->values);
    o->counters = calloc(nc + 1, sizeof *o->counters);
    o->values_set = calloc(no + 1, 1);
    o->names = calloc(nk + no + nc, sizeof *o->names);
    o->name_buf = malloc(bytes);
    if (!o->values || !o->counters || !o->values_set || !o->names || !o->name_buf) {
        defsim__options_free(o);
        defsim__set_last_error("out of memory");
        return DEFSIM_ERR_OUT_OF_MEMORY;
    }
    char *p = o->name_buf;
    for (size_t i = 0; i < nk + no + nc; ++i) {
        int n;
        if (i < DEFSIM__CORE_OWN) {
            o->names[i] = CORE_NAMES[i];
            continue;
        }
        if (i < nk) {
            n = sprintf(p, "core.%s", o->core_specs[i]->name);
        } else {
            const size_t k = i - nk;
            n = sprintf(p, "%s.%s", b->name, k < no ? b->options[k].name : b->counters[k - no].name);
        }
        o->names[i] = p;
        p += n + 1;
    }
    for (size_t i = 0; i < no; ++i) o->values[i] = b->options[i].default_value;

    return DEFSIM_OK;
}

void defsim__options_reset_counters(defsim__options *o)
{
    if (o->backend && o->backend->counter_count > 0)
        memset(o->counters, 0, (size_t)o->backend->counter_count * sizeof *o->counters);
}

int defsim__options_take_reinit(defsim__options *o)
{
    int r = o->reinit;
    o->reinit = 0;
    return r;
}

/* The backend's "projection" option, else clamp (defsim_projection): what assembly applies.
 * "auto" assembles the exact Hessians; the backend asks for the clamped ones where it needs
 * them (matrix_values_projected). */
static int projection(const defsim__options *o)
{
    int k = o->backend ? find_backend_option(o->backend, "projection") : -1;
    if (k >= 0 && o->backend->options[k].type == DEFSIM_OPTION_CHOICE) {
        const int p = (int)o->values[k];
        return p == DEFSIM_PROJECTION_AUTO ? DEFSIM_PROJECTION_NONE : p;
    }
    return DEFSIM_PROJECTION_CLAMP;
}

static const struct defsim__tet_kernels *tet_kernels(const defsim__options *o)
{
    /* The environment's choice, for benchmarks and cross-checks, is a default: a host that
     * set core.simd gets what it set. Unknown or unsupported names fall back to the best
     * variant, as before the option existed. */
    const char *env = getenv("DEFSIM_SIMD");
    if (env && env[0] && !o->core_set[DEFSIM__OPT_SIMD]) {
        if (!strcmp(env, "scalar")) return NULL;
        const defsim__tet_kernels *k = defsim__tet_kernels_find(env);
        return k ? k : defsim__tet_kernels_best();
    }
    const int c = (int)o->core[DEFSIM__OPT_SIMD];
    if (c == SIMD_SCALAR) return NULL;
    if (c == SIMD_AUTO) return defsim__tet_kernels_best();
    char name[16];
    const char *p = SIMD_CHOICES;
    for (int i = 0; i < c; ++i) p = strchr(p, '|') + 1;
    size_t len = strcspn(p, "|");
    snprintf(name, sizeof name, "%.*s", (int)len, p);
    const defsim__tet_kernels *k = defsim__tet_kernels_find(name);
    return k ? k : defsim__tet_kernels_best();   /* set_option refuses unsupported variants */
}

/* The value of the core option `name` (a term's: the name is static, so it is found). */
static double core_value(const defsim__options *o, const char *name)
{
    for (int32_t i = DEFSIM__CORE_OWN; i < o->ncore; ++i)
        if (!strcmp(o->core_specs[i]->name, name)) return o->core[i];
    return 0.0;
}

void defsim__options_resolve(const defsim__options *o, defsim__settings *out)
{
    const double *c = o->core;
    *out = (defsim__settings){
        .tet_kernels = tet_kernels(o),
        .projection = projection(o),
        .auto_substep = c[DEFSIM__OPT_AUTO_SUBSTEP] != 0.0,
        .substep_safety = c[DEFSIM__OPT_SUBSTEP_SAFETY],
        .watchdog = c[DEFSIM__OPT_WATCHDOG] != 0.0,
        .energy_growth = c[DEFSIM__OPT_WATCHDOG_ENERGY_GROWTH],
        .max_stretch = c[DEFSIM__OPT_WATCHDOG_MAX_STRETCH],
        .contact_dhat = core_value(o, "contact_dhat"),
        .contact_kappa = core_value(o, "contact_kappa"),
        .contact_frequency = core_value(o, "contact_frequency"),
        .friction_eps_v = core_value(o, "friction_eps_v"),
        .body_contact = core_value(o, "body_contact") != 0.0};
}

int32_t defsim__options_is_set(const defsim__options *o, int32_t index)
{
    return o->backend && index >= 0 && index < o->backend->option_count &&
           o->values_set[index];
}

const double *defsim__options_values(const defsim__options *o)
{
    return o->backend && o->backend->option_count > 0 ? o->values : NULL;
}

double *defsim__options_counters(defsim__options *o)
{
    return o->backend && o->backend->counter_count > 0 ? o->counters : NULL;
}

/* ------------------------------------------------------------------------------------------ */
/* 5. By name (the public calls in world.c) */

typedef struct option_ref {
    const defsim_option_spec *spec;
    int index;        /* into the core's values, or the backend's */
    const char *full;
    int backend;      /* 1: an option of the backend (changing it re-initialises it) */
} option_ref;

/* Resolves a full name; on failure writes the reason into the world's error. */
static int resolve(const defsim__options *o, defsim__messages *msg, const char *name,
                   option_ref *r)
{
    const defsim_backend *b = o->backend;
    const char *dot = name ? strchr(name, '.') : NULL;
    if (!dot) {
        defsim__error(msg, "option '%s' is not of the form core.<name> or %s.<name>",
                            name ? name : "(null)", b->name);
        return 0;
    }
    const size_t plen = (size_t)(dot - name);
    char list[1024];
    size_t used = 0;
    list[0] = '\0';
    if (plen == 4 && strncmp(name, "core", 4) == 0) {
        for (int32_t c = 0; c < o->ncore; ++c) {
            if (strcmp(o->core_specs[c]->name, dot + 1) == 0) {
                *r = (option_ref){o->core_specs[c], c, o->names[c], 0};
                return 1;
            }
            if (used < sizeof list)
                used += (size_t)snprintf(list + used, sizeof list - used, "%s%s", c ? ", " : "",
                                         o->names[c]);
        }
        defsim__error(msg, "no option '%s'; the core's options: %s", name, list);
        return 0;
    }
    if (strlen(b->name) != plen || strncmp(name, b->name, plen) != 0) {
        defsim__error(msg, "option '%s' is not of this world's backend '%s' (set options "
                               "named %s.<name> or core.<name>)", name, b->name, b->name);
        return 0;
    }
    int k = find_backend_option(b, dot + 1);
    if (k >= 0) {
        *r = (option_ref){&b->options[k], k, o->names[o->ncore + k], 1};
        return 1;
    }
    for (int32_t i = 0; i < b->option_count && used < sizeof list; ++i)
        used += (size_t)snprintf(list + used, sizeof list - used, "%s%s", i ? ", " : "",
                                 o->names[o->ncore + i]);
    defsim__error(msg, "backend '%s' has no option '%s'; its options: %s", b->name, dot + 1,
                        b->option_count ? list : "(none)");
    return 0;
}

static defsim_status assign(defsim__options *o, defsim__messages *msg, const option_ref *r,
                            double v)
{
    double *value = r->backend ? &o->values[r->index] : &o->core[r->index];
    uint8_t *set = r->backend ? &o->values_set[r->index] : &o->core_set[r->index];
    if (*value == v) {
        *set = 1;   /* wins over an environment variable's default */
        return DEFSIM_OK;
    }
    if (r->spec == &CORE_SPECS[DEFSIM__OPT_SIMD] && v > SIMD_SCALAR) {
        const char *p = SIMD_CHOICES;
        for (int i = 0; i < (int)v; ++i) p = strchr(p, '|') + 1;
        char name[16];
        snprintf(name, sizeof name, "%.*s", (int)strcspn(p, "|"), p);
        if (!defsim__tet_kernels_find(name)) {
            defsim__error(msg, "core.simd = %s: this build or CPU does not run that "
                                   "variant (auto, scalar and generic always work)", name);
            return DEFSIM_ERR_INVALID_ARGUMENT;
        }
    }
    *value = v;
    *set = 1;
    if (r->backend) o->reinit = 1;
    return DEFSIM_OK;
}

static defsim_status invalid_value(defsim__messages *msg, const option_ref *r,
                                   const char *text, double v)
{
    char valid[160], given[64];
    describe_valid(r->spec, valid, sizeof valid);
    if (text) snprintf(given, sizeof given, "'%.40s'", text);
    else snprintf(given, sizeof given, "%g", v);
    defsim__error(msg, "option %s: %s is not valid; expected %s", r->full, given, valid);
    return DEFSIM_ERR_INVALID_ARGUMENT;
}

defsim_status defsim__options_set_text(defsim__options *o, defsim__messages *msg,
                                      const char *name, const char *value)
{
    option_ref r;
    if (!resolve(o, msg, name, &r)) return DEFSIM_ERR_INVALID_ARGUMENT;
    if (!value) return invalid_value(msg, &r, "(null)", 0.0);
    double v;
    if (!parse_text(r.spec, value, &v) || !number_valid(r.spec, v))
        return invalid_value(msg, &r, value, 0.0);
    return assign(o, msg, &r, v);
}

defsim_status defsim__options_set_number(defsim__options *o, defsim__messages *msg,
                                        const char *name, double value)
{
    option_ref r;
    if (!resolve(o, msg, name, &r)) return DEFSIM_ERR_INVALID_ARGUMENT;
    if (!number_valid(r.spec, value)) return invalid_value(msg, &r, NULL, value);
    return assign(o, msg, &r, value);
}

defsim_status defsim__options_get(const defsim__options *o, defsim__messages *msg,
                                  const char *name, double *value)
{
    if (!value) return DEFSIM_ERR_INVALID_ARGUMENT;
    option_ref r;
    if (!resolve(o, msg, name, &r)) return DEFSIM_ERR_INVALID_ARGUMENT;
    *value = r.backend ? o->values[r.index] : o->core[r.index];
    return DEFSIM_OK;
}

int32_t defsim__options_count(const defsim__options *o)
{
    return o->ncore + o->backend->option_count;
}

defsim_status defsim__options_info(const defsim__options *o, int32_t i, defsim_option_info *out)
{
    if (!out || out->size < sizeof(uint32_t) || i < 0 || i >= defsim__options_count(o))
        return DEFSIM_ERR_INVALID_ARGUMENT;
    const int core = i < o->ncore;
    const defsim_option_spec *s = core ? o->core_specs[i] : &o->backend->options[i - o->ncore];
    defsim_option_info info;
    info.size = sizeof info;
    info.name = o->names[i];
    info.type = s->type;
    info.value = core ? o->core[i] : o->values[i - o->ncore];
    info.default_value = s->default_value;
    info.min_value = s->min_value;
    info.max_value = s->max_value;
    if (s->type == DEFSIM_OPTION_BOOL) info.min_value = 0.0, info.max_value = 1.0;
    if (s->type == DEFSIM_OPTION_CHOICE)
        info.min_value = 0.0, info.max_value = count_choices(s->choices) - 1;
    info.choices = s->type == DEFSIM_OPTION_CHOICE ? s->choices : NULL;
    info.doc = s->doc ? s->doc : "";
    const uint32_t size = out->size;
    memcpy(out, &info, size < sizeof info ? size : sizeof info);
    out->size = size;
    return DEFSIM_OK;
}

int32_t defsim__options_stat_count(const defsim__options *o)
{
    return NSTATS + o->backend->counter_count + DEFSIM__CONTACT_STATS;
}

defsim_status defsim__options_stat_info(const defsim__options *o, const defsim_stats *stats,
                                        int32_t i, const char **name, double *value)
{
    if (i < 0 || i >= defsim__options_stat_count(o)) return DEFSIM_ERR_INVALID_ARGUMENT;
    const int32_t k = i - NSTATS, kc = k - o->backend->counter_count;
    if (kc >= 0) {   /* contact's statistics come last */
        if (name) *name = CONTACT_STAT_NAMES[kc];
        if (value) *value = o->contact_stats ? o->contact_stats[kc] : 0.0;
        return DEFSIM_OK;
    }
    if (name)
        *name = k < 0 ? STATS[i].name : o->names[o->ncore + o->backend->option_count + k];
    if (value) *value = k < 0 ? stat_read(stats, &STATS[i]) : o->counters[k];
    return DEFSIM_OK;
}

/* v within [lo, hi]; NaN gives lo. */
static double clamp(double v, double lo, double hi) { return v >= lo ? (v <= hi ? v : hi) : lo; }

void defsim__options_stat_write(defsim__options *o, defsim_stats *stats, int32_t i, double value)
{
    if (i < 0 || i >= defsim__options_stat_count(o)) return;
    const int32_t k = i - NSTATS;
    if (k >= 0) {   /* the backend's counters (statistics listed after them are not ours) */
        if (k < o->backend->counter_count) o->counters[k] = value;
        return;
    }
    char *p = (char *)stats + STATS[i].offset;
    switch (STATS[i].kind) {
    /* Clamped before the conversion: a value out of the type's range (a damaged checkpoint)
     * would be undefined behaviour. */
    case ST_U32: {
        const uint32_t v = (uint32_t)clamp(value, 0.0, 4294967295.0);
        memcpy(p, &v, sizeof v);
        break;
    }
    case ST_I32: {
        const int32_t v = (int32_t)clamp(value, -2147483648.0, 2147483647.0);
        memcpy(p, &v, sizeof v);
        break;
    }
    case ST_I64: {
        const int64_t v = (int64_t)clamp(value, -9223372036854774784.0, 9223372036854774784.0);
        memcpy(p, &v, sizeof v);
        break;
    }
    case ST_F64: memcpy(p, &value, sizeof value); break;
    }
}

defsim_status defsim__options_stat(const defsim__options *o, defsim__messages *msg,
                                   const defsim_stats *stats, const char *name, double *value)
{
    if (!name || !value) return DEFSIM_ERR_INVALID_ARGUMENT;
    const int32_t n = defsim__options_stat_count(o);
    for (int32_t i = 0; i < n; ++i) {
        const char *s;
        defsim__options_stat_info(o, stats, i, &s, NULL);
        if (strcmp(s, name) == 0) return defsim__options_stat_info(o, stats, i, NULL, value);
    }
    defsim__error(msg, "no statistic '%s' (the fields of defsim_stats, and %s.<counter> for "
                       "the backend's counters)", name, o->backend->name);
    return DEFSIM_ERR_INVALID_ARGUMENT;
}
