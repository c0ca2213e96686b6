/* SPDX-License-Identifier: MIT */
/*
 * Backend registry: built-in backends, backends registered by hosts, and modules loaded with
 * dlopen on first use. Entries live for the life of the process (worlds point at them), and
 * every table is copied into a full-size, zero-filled entry so that optional ops appended after
 * the backend was built read as NULL.
 *
 * Modules are searched, in order, in DEFSIM_BACKEND_PATH (a colon-separated override), then
 * beside the loaded library: <libdir>/defsim (an installed tree) and <libdir>/modules (the build
 * tree, and the Python package's layout), then the installed module directory (for programs
 * linked with the static library, whose "library" is the executable itself): the configure-time
 * DEFSIM_MODULE_DIR in the build tree, the install prefix's in an installed library.
 */
#define _GNU_SOURCE 1   /* dladdr */
#include "registry.h"

#include "builtin_backends.h"
#include "options.h"
#include "host.h"
#include "status.h"

#include <dirent.h>
#include <dlfcn.h>
#include <limits.h>
#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#ifndef DEFSIM_MODULE_DIR
#define DEFSIM_MODULE_DIR ""
#endif

/* The installed module directory, for programs linked with the static library (their "library"
 * is the executable, so the directories beside it are the program's). Configure time puts
 * DEFSIM_MODULE_DIR here; the install step writes the prefix it installs to over it in the
 * installed libdefsim.a and .so (cmake/set_module_dir.c finds the record by its mark and
 * keeps its size), so that `cmake --install --prefix P` leaves P/<libdir>/defsim in them, not
 * the configure-time prefix's. Read through an opaque pointer: the compiler must not fold the
 * contents it was compiled with. */
#define MODULE_DIR_MARK "defsim-module-dir[4096]:"
__attribute__((used)) static const char module_dir_record[4096] =
    MODULE_DIR_MARK DEFSIM_MODULE_DIR;

static const char *installed_module_dir(void)
{
    const char *p = module_dir_record;
    __asm__("" : "+r"(p));
    p += sizeof MODULE_DIR_MARK - 1;
    return memchr(p, '\0', sizeof module_dir_record - (sizeof MODULE_DIR_MARK - 1)) ? p : "";
}

typedef struct entry {
    defsim_backend table;
    char name[64];
    struct entry *next;
} entry;

static pthread_mutex_t lock = PTHREAD_MUTEX_INITIALIZER;
static pthread_once_t builtins_once = PTHREAD_ONCE_INIT;
static entry *entries;

static int valid_name_n(const char *name, size_t len)
{
    if (len == 0 || len >= 64) return 0;
    for (size_t i = 0; i < len; ++i) {
        const char c = name[i];
        if (!((c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '_')) return 0;
    }
    return 1;
}

static int valid_name(const char *name) { return name && valid_name_n(name, strlen(name)); }

static entry *find_locked(const char *name)
{
    for (entry *e = entries; e; e = e->next)
        if (strcmp(e->name, name) == 0) return e;
    return NULL;
}

/* Validates and copies a table into a new entry (caller holds the lock). */
static defsim_status add_locked(const defsim_backend *b, const defsim_backend **out)
{
    /* Version 8 broke the host table (backend.h): older tables are refused. */
    if (!b || b->abi_version < 8 || b->abi_version > DEFSIM_BACKEND_ABI_VERSION ||
        b->struct_size < offsetof(defsim_backend, reset) || !valid_name(b->name) || !b->init ||
        !b->step || !b->fini) {
        defsim__set_last_error("backend table is NULL, of an unsupported ABI version or size, "
                               "has a name outside [a-z0-9_]{1,63}, or lacks init/step/fini");
        return DEFSIM_ERR_INVALID_ARGUMENT;
    }
    /* A table may be shorter than this core's (struct_size): the fields it lacks read as
     * NULL / 0. */
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

/* "<dir of the file holding this code>/defsim:<same>/modules", computed once: the library's own
 * directory, so an installed or relocated tree finds its modules without configuration. */
static pthread_once_t self_once = PTHREAD_ONCE_INIT;
static char self_dirs[2 * PATH_MAX + 32];

static void find_self_dirs(void)
{
    static const char anchor = 0;
    Dl_info info;
    char real[PATH_MAX];
    if (!dladdr(&anchor, &info) || !info.dli_fname || !strchr(info.dli_fname, '/') ||
        !realpath(info.dli_fname, real))
        return;
    char *slash = strrchr(real, '/');
    *slash = '\0';
    const char *dir = slash == real ? "" : real;
    snprintf(self_dirs, sizeof self_dirs, "%s/defsim:%s/modules", dir, dir);
}

/* The module directories in search order, colon-separated, into buf. */
static const char *module_dirs(char *buf, size_t size)
{
    pthread_once(&self_once, find_self_dirs);
    const char *env = getenv("DEFSIM_BACKEND_PATH"), *installed = installed_module_dir();
    snprintf(buf, size, "%s%s%s%s%s", env && env[0] ? env : "", env && env[0] ? ":" : "",
             self_dirs, self_dirs[0] && installed[0] ? ":" : "", installed);
    return buf;
}

/* Levenshtein distance of two names (both shorter than 64). */
static int edit_distance(const char *a, const char *b)
{
    int row[65];
    const int nb = (int)strlen(b);
    for (int j = 0; j <= nb; ++j) row[j] = j;
    for (const char *p = a; *p; ++p) {
        int diag = row[0];
        row[0] = (int)(p - a) + 1;
        for (int j = 1; j <= nb; ++j) {
            const int up = row[j];
            int best = diag + (*p != b[j - 1]);
            if (up + 1 < best) best = up + 1;
            if (row[j - 1] + 1 < best) best = row[j - 1] + 1;
            row[j] = best;
            diag = up;
        }
    }
    return row[nb];
}

typedef struct name_list {
    char names[64][64];
    int n;
} name_list;

static void add_name(name_list *l, const char *name, size_t len)
{
    if (len == 0 || len >= 64 || l->n == 64) return;
    for (int i = 0; i < l->n; ++i)
        if (strlen(l->names[i]) == len && strncmp(l->names[i], name, len) == 0) return;
    memcpy(l->names[l->n], name, len);
    l->names[l->n++][len] = '\0';
}

static int cmp_names(const void *a, const void *b) { return strcmp(a, b); }

/* Every backend name a lookup could succeed with: the registered ones and the defsim_*.so files
 * of the module directories (caller holds the lock). */
static void available_locked(const char *dirs, name_list *l)
{
    l->n = 0;
    for (entry *e = entries; e; e = e->next) add_name(l, e->name, strlen(e->name));
    for (const char *p = dirs; p && *p;) {
        const char *end = strchr(p, ':');
        char dir[PATH_MAX];
        snprintf(dir, sizeof dir, "%.*s", (int)(end ? (size_t)(end - p) : strlen(p)), p);
        DIR *d = dir[0] ? opendir(dir) : NULL;
        for (struct dirent *de; d && (de = readdir(d));) {
            const size_t len = strlen(de->d_name);
            if (len > 10 && strncmp(de->d_name, "defsim_", 7) == 0 &&
                strcmp(de->d_name + len - 3, ".so") == 0 && valid_name_n(de->d_name + 7, len - 10))
                add_name(l, de->d_name + 7, len - 10);
        }
        if (d) closedir(d);
        p = end ? end + 1 : NULL;
    }
    qsort(l->names, (size_t)l->n, sizeof l->names[0], cmp_names);
}

/* The error for a name that names no backend: the available ones, and "did you mean 'x'?" when
 * one is within a third of the name's length (at least 2 edits) of it (caller holds the lock). */
static void unknown_name_error(const char *name, const char *why_not, const char *dirs)
{
    name_list l;
    available_locked(dirs, &l);
    int best = -1, best_d = 0;
    for (int i = 0; i < l.n && strlen(name) < 64; ++i) {
        const int d = edit_distance(name, l.names[i]);
        if (best < 0 || d < best_d) { best = i; best_d = d; }
    }
    const int limit = (int)strlen(name) / 3 > 2 ? (int)strlen(name) / 3 : 2;
    char hint[96] = "", list[1024] = "";
    if (best >= 0 && best_d <= limit)
        snprintf(hint, sizeof hint, "did you mean '%s'? ", l.names[best]);
    size_t used = 0;
    for (int i = 0; i < l.n && used < sizeof list; ++i)
        used += (size_t)snprintf(list + used, sizeof list - used, "%s%s", i ? ", " : "",
                                 l.names[i]);
    /* The way out before the list of directories, which may be cut at the message's size. */
    defsim__set_last_error("no backend '%.64s'%s: %savailable: %s (DEFSIM_BACKEND_PATH names "
                           "more directories of defsim_<name>.so modules; searched %.200s)",
                           name, why_not, hint, l.n ? list : "(none)",
                           dirs[0] ? dirs : "no directory");
}

defsim_status defsim__find_backend(const char *name, const defsim_backend **out)
{
    pthread_once(&builtins_once, register_builtins);
    char why[600] = "", dirs[3 * PATH_MAX + 64];
    if (!name) {
        defsim__set_last_error("backend name is NULL");
        return DEFSIM_ERR_BACKEND_UNAVAILABLE;
    }
    if (!valid_name(name)) {
        pthread_mutex_lock(&lock);
        unknown_name_error(name, " (a name is [a-z0-9_]{1,63})", module_dirs(dirs, sizeof dirs));
        pthread_mutex_unlock(&lock);
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
    module_dirs(dirs, sizeof dirs);
    const int found = search_path(dirs, name, &st, out, why, sizeof why);
    if (!found) unknown_name_error(name, "", dirs);
    pthread_mutex_unlock(&lock);
    if (found && st != DEFSIM_OK)
        defsim__set_last_error("backend '%s' failed to load: %s", name, why);
    return st;
}
