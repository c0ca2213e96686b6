/* SPDX-License-Identifier: MIT */
/*
 * Backend registry: built-in backends, backends registered by hosts, and modules loaded with
 * dlopen on first use. Entries live for the life of the process (worlds point at them), and
 * every table is copied into a full-size, zero-filled entry so that optional ops appended after
 * the backend was built read as NULL.
 */
#include "registry.h"

#include "builtin_backends.h"
#include "options.h"
#include "host.h"
#include "status.h"

#include <dlfcn.h>
#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#ifndef DEFSIM_MODULE_DIR
#define DEFSIM_MODULE_DIR ""
#endif

typedef struct entry {
    defsim_backend table;
    char name[64];
    struct entry *next;
} entry;

static pthread_mutex_t lock = PTHREAD_MUTEX_INITIALIZER;
static pthread_once_t builtins_once = PTHREAD_ONCE_INIT;
static entry *entries;

static int valid_name(const char *name)
{
    if (!name || !name[0] || strlen(name) >= 64) return 0;
    for (const char *p = name; *p; ++p)
        if (!((*p >= 'a' && *p <= 'z') || (*p >= '0' && *p <= '9') || *p == '_')) return 0;
    return 1;
}

static entry *find_locked(const char *name)
{
    for (entry *e = entries; e; e = e->next)
        if (strcmp(e->name, name) == 0) return e;
    return NULL;
}

/* Validates and copies a table into a new entry (caller holds the lock). */
static defsim_status add_locked(const defsim_backend *b, const defsim_backend **out)
{
    if (!b || b->abi_version < 1 || b->abi_version > DEFSIM_BACKEND_ABI_VERSION ||
        b->struct_size < offsetof(defsim_backend, reset) || !valid_name(b->name) || !b->init ||
        !b->step || !b->fini) {
        defsim__set_last_error("backend table is NULL, of an unsupported ABI version or size, "
                               "has a name outside [a-z0-9_]{1,63}, or lacks init/step/fini");
        return DEFSIM_ERR_INVALID_ARGUMENT;
    }
    /* Older tables are shorter (version 1 ends before `options`, 2 and 3 before
     * `stable_step_options`, 4 before `save_state`): the fields they lack read as NULL / 0. */
    defsim_backend full;
    memset(&full, 0, sizeof full);
    memcpy(&full, b, b->struct_size < sizeof full ? b->struct_size : sizeof full);
    char why[200];
    if (!defsim__options_check_table(&full, why, sizeof why)) {
        defsim__set_last_error("backend '%s': %s", b->name, why);
        return DEFSIM_ERR_INVALID_ARGUMENT;
    }
    if (!full.save_state != !full.load_state) {
        defsim__set_last_error("backend '%s': save_state and load_state come together", b->name);
        return DEFSIM_ERR_INVALID_ARGUMENT;
    }
    if (strcmp(b->name, "core") == 0) {
        defsim__set_last_error("the backend name 'core' is reserved for the world's options");
        return DEFSIM_ERR_INVALID_ARGUMENT;
    }
    if (find_locked(b->name)) {
        defsim__set_last_error("a backend named '%s' is already registered", b->name);
        return DEFSIM_ERR_CONFLICT;
    }
    entry *e = calloc(1, sizeof *e);
    if (!e) {
        defsim__set_last_error("out of memory");
        return DEFSIM_ERR_OUT_OF_MEMORY;
    }
    e->table = full;
    snprintf(e->name, sizeof e->name, "%s", b->name);
    e->table.name = e->name;
    e->table.struct_size = sizeof e->table;
    e->next = entries;
    entries = e;
    if (out) *out = &e->table;
    return DEFSIM_OK;
}

static void register_builtins(void)
{
    pthread_mutex_lock(&lock);
    for (const defsim_backend *const *b = defsim__builtin_backends; *b; ++b) add_locked(*b, NULL);
    pthread_mutex_unlock(&lock);
}

defsim_status defsim_register_backend(const defsim_backend *backend)
{
    pthread_once(&builtins_once, register_builtins);
    pthread_mutex_lock(&lock);
    defsim_status st = add_locked(backend, NULL);
    pthread_mutex_unlock(&lock);
    return st;
}

/* Tries <dir>/defsim_<name>.so; returns 1 if a file was found (loaded or not). */
static int try_module(const char *dir, size_t dirlen, const char *name, defsim_status *st,
                      const defsim_backend **out, char *why, size_t why_size)
{
    char path[4096];
    int n = snprintf(path, sizeof path, "%.*s/defsim_%s.so", (int)dirlen, dir, name);
    if (n < 0 || (size_t)n >= sizeof path) return 0;
    FILE *f = fopen(path, "rb");
    if (!f) return 0;
    fclose(f);
    void *h = dlopen(path, RTLD_NOW | RTLD_LOCAL);
    if (!h) {
        const char *e = dlerror();
        snprintf(why, why_size, "%.500s", e ? e : path);
        *st = DEFSIM_ERR_BACKEND_UNAVAILABLE;
        return 1;
    }
    defsim_module_init_fn init;
    *(void **)&init = dlsym(h, DEFSIM_MODULE_ENTRY);
    const defsim_backend *b = NULL;
    if (!init) {
        snprintf(why, why_size, "%.300s does not export %s", path, DEFSIM_MODULE_ENTRY);
        *st = DEFSIM_ERR_BACKEND_UNAVAILABLE;
        return 1;   /* the handle stays open: cheap, and safe if anything was initialised */
    }
    *st = init(&defsim__host, &b);
    if (*st != DEFSIM_OK || !b || !b->name || strcmp(b->name, name) != 0) {
        snprintf(why, why_size, "%.300s: %s failed or named another backend", path,
                 DEFSIM_MODULE_ENTRY);
        *st = DEFSIM_ERR_BACKEND_UNAVAILABLE;
        return 1;
    }
    *st = add_locked(b, out);
    if (*st != DEFSIM_OK) {
        snprintf(why, why_size, "%.300s: %.250s", path, defsim_last_error());
        *st = DEFSIM_ERR_BACKEND_UNAVAILABLE;
    }
    return 1;
}

static int search_path(const char *list, const char *name, defsim_status *st,
                       const defsim_backend **out, char *why, size_t why_size)
{
    for (const char *p = list; p && *p;) {
        const char *end = strchr(p, ':');
        size_t len = end ? (size_t)(end - p) : strlen(p);
        if (len > 0 && try_module(p, len, name, st, out, why, why_size)) return 1;
        p = end ? end + 1 : NULL;
    }
    return 0;
}

defsim_status defsim__find_backend(const char *name, const defsim_backend **out)
{
    pthread_once(&builtins_once, register_builtins);
    if (!valid_name(name)) {
        defsim__set_last_error("backend name '%s' is not of the form [a-z0-9_]{1,63}",
                               name ? name : "(null)");
        return DEFSIM_ERR_BACKEND_UNAVAILABLE;
    }
    pthread_mutex_lock(&lock);
    entry *e = find_locked(name);
    if (e) {
        *out = &e->table;
        pthread_mutex_unlock(&lock);
        return DEFSIM_OK;
    }
    defsim_status st = DEFSIM_ERR_BACKEND_UNAVAILABLE;
    char why[600] = "";
    int found = search_path(getenv("DEFSIM_BACKEND_PATH"), name, &st, out, why, sizeof why) ||
                search_path(DEFSIM_MODULE_DIR, name, &st, out, why, sizeof why);
    pthread_mutex_unlock(&lock);
    if (!found)
        defsim__set_last_error("no backend '%s': not built in or registered, and no "
                               "defsim_%s.so in DEFSIM_BACKEND_PATH or %s",
                               name, name, DEFSIM_MODULE_DIR[0] ? DEFSIM_MODULE_DIR : "(none)");
    else if (st != DEFSIM_OK)
        defsim__set_last_error("backend '%s' failed to load: %s", name, why);
    return st;
}
