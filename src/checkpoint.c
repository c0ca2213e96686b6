/* SPDX-License-Identifier: MIT */
/*
 * Checkpoints (defsim.h "Checkpoints", docs/checkpoints.md): a world written as a header and
 * tagged chunks (chunk.h: every number little-endian, doubles as IEEE binary64 bit patterns,
 * each chunk closed by its CRC-32, the file by an END chunk). The world's sub-objects write and
 * read their own chunks: the bodies (body.c), the coupling set (coupling_set.c), the collider
 * set (collider.c), the terms' state that carries from step to step (each kind's save and load
 * ops, term.h), the backend slot (the backend's save_state and load_state); this file keeps the
 * world's own chunks (creation parameters, options, state, statistics) and the order. Loading
 * checks the whole file before it builds a new world through the public API (so every value is
 * validated as the host's would be), then writes the state, statistics and backend history in.
 *
 * Contents: save (the sections, buffer, file); chunk index; load (the readers, the build);
 * enumeration of bodies and attachments; SDF colliders of a loaded world.
 */
#include "checkpoint.h"

#include "assembly.h"
#include "contact.h"
#include "file_read.h"
#include "step.h"
#include "terms.h"
#include "world.h"

#include <errno.h>
#include <fcntl.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

/* Terms write their chunks as they hold their numbers; the format is little-endian. */
#if defined(__BYTE_ORDER__) && __BYTE_ORDER__ != __ORDER_LITTLE_ENDIAN__
#error "checkpoints: the terms' chunks assume a little-endian machine"
#endif

/* ------------------------------------------------------------------------------------------ */
/* Save: one section per sub-object, in the order the loader needs (bodies before what names
 * them, the state after the bodies, the backend's history last). */

/* The world's creation parameters (WRLD) and its options by name (OPTS). */
static defsim_status save_world(defsim__bw *b, const defsim_world *w)
{
    const defsim_world_def *d = &w->def;
    size_t c = defsim__chunk_begin(b, "WRLD");
    defsim__put_str(b, w->backend.name);
    defsim__put_f64s(b, d->gravity, 3);
    defsim__put_i32(b, w->nthreads);   /* resolved: the same bits need the same thread count */
    defsim__chunk_end(b, c);   /* the settings are options: the OPTS chunk holds them by name */

    c = defsim__chunk_begin(b, "OPTS");
    const int32_t n = defsim__options_count(&w->options);
    defsim__put_u32(b, (uint32_t)n);
    for (int32_t i = 0; i < n; ++i) {
        defsim_option_info info;
        info.size = sizeof info;
        defsim__options_info(&w->options, i, &info);
        defsim__put_str(b, info.name);
        defsim__put_f64(b, info.value);
    }
    defsim__chunk_end(b, c);
    return DEFSIM_OK;
}

/* A BODY chunk per live body, in vertex order, with its saved id (id slot + 1). */
static defsim_status save_bodies(defsim__bw *b, const defsim_world *w)
{
    for (int32_t i = 0; i < w->bodies.n; ++i) {
        const defsim__body *body = &w->bodies.b[i];
        if (!(body->generation & 1u)) continue;
        uint32_t saved = 0;
        for (int32_t s = 0; s < w->bodies.ids.nslots && !saved; ++s)
            if ((w->bodies.ids.gen[s] & 1u) && w->bodies.ids.dense[s] == i) saved = (uint32_t)s + 1;
        defsim__body_save(b, body, saved);
    }
    return DEFSIM_OK;
}

static defsim_status save_coupling(defsim__bw *b, const defsim_world *w)
{
    defsim__coupling_save(b, &w->coupling, w->nv, &w->bodies.ids);
    return DEFSIM_OK;
}

static defsim_status save_colliders(defsim__bw *b, const defsim_world *w)
{
    defsim__collider_set_save(b, &w->colliders, w->nv);
    return DEFSIM_OK;
}

/* A TERM chunk per kind whose state carries from step to step (version 6): the kind's name,
 * then what its save op writes. Written for a planned world only: planning drops that state. */
static defsim_status save_terms(defsim__bw *b, const defsim_world *w)
{
    defsim_world *mw = (defsim_world *)w;   /* a kind's ops take its state mutable */
    for (int k = 0; k < DEFSIM__TERM_KINDS && w->planned; ++k) {
        void *data = defsim__world_term_state(mw, k);
        const defsim__term t = defsim__terms_detached(&w->sys, k, data);
        if (!data || !t.ops->save) continue;
        const size_t need = t.ops->save(&t, NULL, 0);
        if (need == 0) continue;
        unsigned char *buf = malloc(need);
        if (!buf) {
            b->oom = 1;
            return DEFSIM_OK;
        }
        (void)t.ops->save(&t, buf, need);
        const size_t c = defsim__chunk_begin(b, "TERM");
        defsim__put_str(b, t.ops->name);
        defsim__put(b, buf, need);
        defsim__chunk_end(b, c);
        free(buf);
    }
    return DEFSIM_OK;
}

/* The vertex pairs that body contact added to the matrix pattern (PEXT, version 4): the loaded
 * world starts from the same pattern, so its factorisations round alike. */
static defsim_status save_pattern(defsim__bw *b, const defsim_world *w)
{
    if (!w->planned || w->sys.pattern.nextra == 0) return DEFSIM_OK;
    const size_t c = defsim__chunk_begin(b, "PEXT");
    defsim__put_u32(b, (uint32_t)w->sys.pattern.nextra);
    for (int64_t k = 0; k < w->sys.pattern.nextra; ++k)
        defsim__put_u64(b, (uint64_t)w->sys.pattern.extra[k]);
    defsim__chunk_end(b, c);
    return DEFSIM_OK;
}

/* The state (STAT) and the statistics by name (STCS). */
static defsim_status save_state(defsim__bw *b, const defsim_world *w)
{
    size_t c = defsim__chunk_begin(b, "STAT");
    defsim__put_i32(b, w->nv);
    defsim__put_f64s(b, w->state.x, 3 * (int64_t)w->nv);
    defsim__put_f64s(b, w->state.v, 3 * (int64_t)w->nv);
    defsim__put_f64(b, w->state.t);
    defsim__put_i32(b, w->coupling.drove);
    /* Version 2: auto_substep's cached stable step and its age, which set the substeps. */
    const int kept = w->planned && !w->options.reinit;   /* else the next step drops it */
    defsim__put_f64(b, kept ? w->step.h_stable : 0.0);
    defsim__put_i32(b, kept ? w->step.since_estimate : 0);
    defsim__chunk_end(b, c);

    c = defsim__chunk_begin(b, "STCS");
    const int32_t n = defsim__options_stat_count(&w->options);
    defsim__put_u32(b, (uint32_t)n);
    for (int32_t i = 0; i < n; ++i) {
        const char *name;
        double value;
        defsim__options_stat_info(&w->options, &w->stats, i, &name, &value);
        defsim__put_str(b, name);
        defsim__put_f64(b, value);
    }
    defsim__chunk_end(b, c);
    return DEFSIM_OK;
}

/* The backend's history (BKND), when it has one to give: initialised for the current bodies,
 * pins and options (a pending change would drop the history at the next step anyway). */
static defsim_status save_backend(defsim__bw *b, const defsim_world *w)
{
    const defsim_backend *be = w->backend.table;
    if (!be->save_state || !w->backend.ready || !w->planned || w->options.reinit) return DEFSIM_OK;
    const size_t c = defsim__chunk_begin(b, "BKND");
    defsim__put_str(b, be->name);
    const defsim_state_writer wr = defsim__state_writer(b);
    defsim_world *mw = (defsim_world *)w;   /* host services take a mutable system */
    const defsim_status st = be->save_state(&defsim__host, &mw->handle, w->backend.state, &wr);
    if (st != DEFSIM_OK) {
        if (!w->msg->error[0])
            defsim__error(w->msg, "save: backend %s could not save its history (%s)", be->name,
                          defsim_status_string(st));
        return st;
    }
    defsim__chunk_end(b, c);
    return DEFSIM_OK;
}

static defsim_status (*const sections[])(defsim__bw *, const defsim_world *) = {
    save_world, save_bodies, save_coupling, save_colliders, save_terms, save_pattern,
    save_state, save_backend};

static defsim_status save_to(const defsim_world *w, defsim__bw *b)
{
    defsim__put(b, DEFSIM__CKPT_MAGIC, 8);
    defsim__put_u32(b, DEFSIM__CKPT_VERSION);
    defsim__put_u32(b, 0);
    for (size_t i = 0; i < sizeof sections / sizeof sections[0]; ++i) {
        const defsim_status st = sections[i](b, w);
        if (st != DEFSIM_OK) return st;
    }
    const size_t c = defsim__chunk_begin(b, "END ");
    defsim__chunk_end(b, c);
    if (b->oom) {
        defsim__error(w->msg, "save: out of memory");
        return DEFSIM_ERR_OUT_OF_MEMORY;
    }
    return DEFSIM_OK;
}

static defsim_status save_checks(const defsim_world *w)
{
    /* Inside a host callback the state is mid-step: refuse, like every other call that would
     * act on it. */
    if (w->msg->locked) {
        defsim__error(w->msg, "save: called from inside a host callback");
        return DEFSIM_ERR_LOCKED;
    }
    w->msg->error[0] = '\0';
    return DEFSIM_OK;
}

defsim_status defsim_world_save_buffer(const defsim_world *w, void **data, size_t *size)
{
    if (data) *data = NULL;
    if (size) *size = 0;
    if (!defsim__world_live(w)) return DEFSIM_ERR_INVALID_ARGUMENT;
    if (!data || !size) {
        defsim__error(w->msg, "save_buffer: data or size is NULL");
        return DEFSIM_ERR_INVALID_ARGUMENT;
    }
    defsim_status st = save_checks(w);
    if (st != DEFSIM_OK) return st;
    defsim__bw b = {0};
    if ((st = save_to(w, &b)) != DEFSIM_OK) {
        free(b.p);
        return st;
    }
    *data = b.p;
    *size = b.n;
    return DEFSIM_OK;
}

void defsim_buffer_free(void *data) { free(data); }

/* Writes n bytes to a new temporary file beside `path`, flushes it, and renames it over path. */
static defsim_status write_atomic(const defsim_world *w, const char *path, const void *data,
                                  size_t n)
{
    const size_t len = strlen(path);
    char *tmp = malloc(len + 32);
    if (!tmp) {
        defsim__error(w->msg, "save: out of memory");
        return DEFSIM_ERR_OUT_OF_MEMORY;
    }
    /* Not mkstemp: its files are private (0600); this one gets the mode a new file gets. */
    static _Atomic unsigned serial;
    const char *call = "open";
    int fd = -1;
    for (int tries = 0; fd < 0 && tries < 100; ++tries) {
        snprintf(tmp, len + 32, "%s.tmp.%ld.%u", path, (long)getpid(), serial++);
        fd = open(tmp, O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0666);
        if (fd < 0 && errno != EEXIST) break;
    }
    int ok = fd >= 0;
    const unsigned char *p = data;
    for (size_t done = 0; ok && done < n;) {
        const ssize_t k = write(fd, p + done, n - done);
        if (k < 0 && errno == EINTR) continue;
        if (k <= 0) { ok = 0; call = "write"; break; }
        done += (size_t)k;
    }
    if (ok && fsync(fd) != 0) { ok = 0; call = "fsync"; }
    int err = errno;
    if (fd >= 0 && close(fd) != 0 && ok) { ok = 0; call = "close"; err = errno; }
    if (ok && rename(tmp, path) != 0) { ok = 0; call = "rename"; err = errno; }
    if (!ok) {
        if (fd >= 0) unlink(tmp);
        defsim__error(w->msg, "save: %s for '%s' failed: %s", call, path, strerror(err));
        free(tmp);
        return DEFSIM_ERR_IO;
    }
    free(tmp);
    /* The rename itself reaches the disk with the directory. */
    char *dir = strdup(path);
    if (dir) {
        char *slash = strrchr(dir, '/');
        const char *d = slash ? (slash == dir ? "/" : (*slash = '\0', dir)) : ".";
        const int dfd = open(d, O_RDONLY);
        if (dfd >= 0) {
            (void)fsync(dfd);
            close(dfd);
        }
        free(dir);
    }
    return DEFSIM_OK;
}

defsim_status defsim_world_save(const defsim_world *w, const char *path)
{
    if (!defsim__world_live(w)) return DEFSIM_ERR_INVALID_ARGUMENT;
    if (!path || !path[0]) {
        defsim__error(w->msg, "save: path is NULL or empty");
        return DEFSIM_ERR_INVALID_ARGUMENT;
    }
    defsim_status st = save_checks(w);
    if (st != DEFSIM_OK) return st;
    defsim__bw b = {0};
    if ((st = save_to(w, &b)) == DEFSIM_OK) st = write_atomic(w, path, b.p, b.n);
    free(b.p);
    return st;
}

/* ------------------------------------------------------------------------------------------ */
/* Chunk index: the file checked whole before anything is built. */

typedef struct chunk {
    char tag[5];
    const unsigned char *payload;
    size_t len;
} chunk;

typedef struct ckpt {
    uint32_t version;
    chunk *c;
    int32_t n;
} ckpt;

static defsim_status index_chunks(const unsigned char *p, size_t n, ckpt *out)
{
    memset(out, 0, sizeof *out);
    if (n < DEFSIM__CKPT_HEADER || memcmp(p, DEFSIM__CKPT_MAGIC, 8) != 0) {
        defsim__set_last_error("load: not a defsim checkpoint (no DEFSIMCK header)");
        return DEFSIM_ERR_IO;
    }
    defsim__br h = {p, n, 8, 0};
    out->version = defsim__get_u32(&h);
    const uint32_t flags = defsim__get_u32(&h);
    if (out->version < 1 || out->version > DEFSIM__CKPT_VERSION || flags != 0) {
        defsim__set_last_error("load: checkpoint format version %u (flags %u); this library "
                               "reads versions 1 to %u", (unsigned)out->version, (unsigned)flags,
                               (unsigned)DEFSIM__CKPT_VERSION);
        return DEFSIM_ERR_IO;
    }
    size_t at = DEFSIM__CKPT_HEADER;
    int32_t cap = 0;
    for (;;) {
        if (n - at < 16) {
            defsim__set_last_error("load: checkpoint truncated at byte %zu (no END chunk)", at);
            goto fail;
        }
        defsim__br r = {p, n, at + 4, 0};
        const uint64_t len = defsim__get_u64(&r);
        if (len > n - at - 16) {
            defsim__set_last_error("load: checkpoint truncated: chunk '%.4s' at byte %zu claims "
                                   "%llu bytes", (const char *)p + at, at,
                                   (unsigned long long)len);
            goto fail;
        }
        r.at = at + 12 + (size_t)len;
        const uint32_t crc = defsim__get_u32(&r);
        if (crc != defsim__crc32(0, p + at, 12 + (size_t)len)) {
            defsim__set_last_error("load: checkpoint corrupted: CRC mismatch in chunk '%.4s' at "
                                   "byte %zu", (const char *)p + at, at);
            goto fail;
        }
        if (out->n == cap) {
            cap = cap ? 2 * cap : 16;
            chunk *nc = realloc(out->c, (size_t)cap * sizeof *nc);
            if (!nc) {
                defsim__set_last_error("load: out of memory");
                free(out->c);
                out->c = NULL;
                return DEFSIM_ERR_OUT_OF_MEMORY;
            }
            out->c = nc;
        }
        chunk *c = &out->c[out->n++];
        memcpy(c->tag, p + at, 4);
        c->tag[4] = '\0';
        c->payload = p + at + 12;
        c->len = (size_t)len;
        at += 16 + (size_t)len;
        if (strcmp(c->tag, "END ") == 0) break;
    }
    if (at != n) {
        defsim__set_last_error("load: %zu bytes after the END chunk", n - at);
        goto fail;
    }
    return DEFSIM_OK;
fail:
    free(out->c);
    out->c = NULL;
    return DEFSIM_ERR_IO;
}


static defsim__br chunk_reader(const chunk *c) { return (defsim__br){c->payload, c->len, 0, 0}; }

/* ------------------------------------------------------------------------------------------ */
/* Load: a reader per tag; the sub-objects' chunks are applied as they come (bodies before what
 * names them), the rest kept for the build's fixed order once the world is planned. */

/* Fails the load of chunk c with a malformed-file message. */
static defsim_status malformed(const chunk *c, const char *what)
{
    defsim__set_last_error("load: malformed '%s' chunk: %s", c->tag, what);
    return DEFSIM_ERR_IO;
}

static defsim_status out_of_memory(void)
{
    defsim__set_last_error("load: out of memory");
    return DEFSIM_ERR_OUT_OF_MEMORY;
}

/* Moves a world's last error into the thread's (the world is about to go). */
static defsim_status world_failed(defsim_world *w, defsim_status st, const char *what)
{
    defsim__set_last_error("load: %s: %s", what, w->msg->error);
    return st;
}

/* A sub-object's read: IO as malformed with its reason, other failures as they are. */
static defsim_status read_failed(const chunk *c, defsim_status st, const char *why)
{
    if (st == DEFSIM_ERR_IO) return malformed(c, why ? why : "wrong length");
    return st == DEFSIM_ERR_OUT_OF_MEMORY ? out_of_memory() : st;
}

/* Saved body index -> id in the new world. */
typedef struct id_map {
    uint32_t old_index, old_generation;
    defsim_body_id id;
} id_map;

/* What a load has built and what it keeps for later. */
typedef struct loader {
    defsim_world *w;
    uint32_t version;
    id_map *map;              /* one per BODY chunk */
    int32_t nmap;
    const chunk *state, *stats, *backend, *forces, *pattern, *contact5;
    const chunk *terms[DEFSIM__TERM_KINDS];
    int32_t nterms;
} loader;

static defsim_status load_world(const chunk *c, defsim_log_fn log, void *log_user,
                                defsim_world **out)
{
    defsim__br r = chunk_reader(c);
    char backend[64];
    defsim__get_str(&r, backend, sizeof backend);
    defsim_world_def d;
    defsim_world_def_init(&d, sizeof d);
    d.backend = backend;
    defsim__get_f64s(&r, d.gravity, 3);
    d.num_threads = defsim__get_i32(&r);
    /* Files written before the world def lost its nine backend settings carry them here:
     * tolerance, max_iterations, rtol, atol, projection, ... At creation they set the options
     * of the same names, which the OPTS chunk holds, except the projection of a backend that
     * had no such option then (sundials_ida, sundials_kinsol): set it here where it has one. */
    int32_t projection = DEFSIM_PROJECTION_CLAMP;
    if (!r.bad && r.n - r.at == 4 * sizeof(double) + 5 * sizeof(int32_t)) {
        r.at += 3 * sizeof(double) + sizeof(int32_t);
        projection = defsim__get_i32(&r);
        r.at = r.n;
    }
    if (!defsim__read_whole(&r)) return malformed(c, "wrong length");
    d.log = log;
    d.log_user = log_user;
    defsim_status st = defsim_world_create(&d, out);
    if (st != DEFSIM_OK || projection == DEFSIM_PROJECTION_CLAMP) return st;
    char name[80];
    snprintf(name, sizeof name, "%s.projection", backend);
    double now;
    if (defsim_world_get_option(*out, name, &now) == DEFSIM_OK &&
        (st = defsim_world_set_option_number(*out, name, projection)) != DEFSIM_OK) {
        st = world_failed(*out, st, "projection");
        defsim_world_destroy(*out);
        *out = NULL;
    }
    return st;
}

static defsim_status load_options(defsim_world *w, const chunk *c)
{
    defsim__br r = chunk_reader(c);
    const uint32_t n = defsim__get_u32(&r);
    for (uint32_t i = 0; i < n && !r.bad; ++i) {
        char name[160];
        defsim__get_str(&r, name, sizeof name);
        const double value = defsim__get_f64(&r);
        if (r.bad) break;
        /* An option at the value it has is left alone: it stays a default, and an environment
         * variable's default (DEFSIM_SIMD) still applies as it did to the saved run. */
        double now;
        if (defsim_world_get_option(w, name, &now) == DEFSIM_OK && now == value) continue;
        const defsim_status st = defsim_world_set_option_number(w, name, value);
        if (st != DEFSIM_OK) return world_failed(w, st, "option");
    }
    if (!defsim__read_whole(&r)) return malformed(c, "wrong length");
    return DEFSIM_OK;
}

static defsim_status read_body(loader *L, const chunk *c)
{
    if (L->state) return malformed(c, "after the state");
    defsim__br r = chunk_reader(c);
    defsim__body_saved s;
    const char *why = NULL;
    defsim_status st = defsim__body_read(&r, L->version, &s, &why);
    id_map *m = &L->map[L->nmap++];
    m->old_index = s.id;
    m->old_generation = s.generation;
    if (st != DEFSIM_OK) {
        st = read_failed(c, st, why);
    } else if ((st = defsim_world_add_body(L->w, &s.def, &m->id)) != DEFSIM_OK) {
        st = world_failed(L->w, st, "body");
    } else {
        if (L->version >= 4) {   /* the contact edges as saved: the body takes the buffer */
            defsim__body *bd = defsim__world_find_body(L->w, m->id);
            free(bd->edges);
            bd->edges = s.nedge > 0 ? s.edges : NULL;
            bd->nedge = s.nedge;
            if (s.nedge > 0) s.edges = NULL;
        }
        if (s.npin > 0 && (st = defsim_body_pin(L->w, m->id, s.pins, s.npin)) != DEFSIM_OK)
            st = world_failed(L->w, st, "pins");
    }
    defsim__body_saved_free(&s);
    return st;
}

static defsim_status map_body(const loader *L, const chunk *c, const uint32_t saved[2],
                              defsim_body_id *out)
{
    for (int32_t i = 0; i < L->nmap; ++i)
        if (L->map[i].old_index == saved[0] && L->map[i].old_generation == saved[1]) {
            *out = L->map[i].id;
            return DEFSIM_OK;
        }
    return malformed(c, "names a body that the checkpoint does not hold");
}

static defsim_status read_attachment(loader *L, const chunk *c)
{
    defsim__br r = chunk_reader(c);
    defsim_attachment_def d;
    uint32_t body[2], target[2];
    defsim_attachment_def_init(&d, sizeof d);
    if (defsim__attachment_read(&r, &d, body, target) != DEFSIM_OK)
        return malformed(c, "wrong length");
    defsim_status st = map_body(L, c, body, &d.body);
    if (st == DEFSIM_OK && (target[0] != 0 || target[1] != 0))
        st = map_body(L, c, target, &d.target_body);
    if (st == DEFSIM_OK && (st = defsim_world_add_attachment(L->w, &d, NULL)) != DEFSIM_OK)
        st = world_failed(L->w, st, "attachment");
    return st;
}

static defsim_status read_fext(loader *L, const chunk *c)
{
    defsim_world *w = L->w;
    if (c->len != 24 * (size_t)w->nv) return malformed(c, "length does not match the vertices");
    defsim__br r = chunk_reader(c);
    double *f = malloc(3 * (size_t)(w->nv > 0 ? w->nv : 1) * sizeof *f);
    if (!f) return out_of_memory();
    defsim__get_f64s(&r, f, 3 * (int64_t)w->nv);
    defsim_status st = defsim_world_set_external_forces(w, f, w->nv);
    free(f);
    return st == DEFSIM_OK ? st : world_failed(w, st, "external forces");
}

/* Driven-pin targets: every vertex named must be pinned already (the BODY chunks pin them). */
static defsim_status read_targets(loader *L, const chunk *c)
{
    defsim__br r = chunk_reader(c);
    const char *why = NULL;
    const defsim_status st =
        defsim__coupling_load_targets(&L->w->coupling, &r, L->w->nv, L->w->bodies.pinned, &why);
    return st == DEFSIM_OK ? st : read_failed(c, st, why);
}

/* Stands in for an SDF collider's function until the host installs it again
 * (defsim_collider_set_sdf): a step that queries it fails with DEFSIM_ERR_CALLBACK. */
static double sdf_missing(void *user, const double p[3], double grad[3])
{
    (void)user;
    (void)p;
    grad[0] = grad[1] = grad[2] = NAN;
    return NAN;
}

static defsim_status read_collider(loader *L, const chunk *c)
{
    defsim_world *w = L->w;
    defsim__br r = chunk_reader(c);
    defsim__collider_saved s;
    const char *why = NULL;
    defsim_status st = defsim__collider_read(&r, &s, &why);
    defsim_collider_id id;
    if (st != DEFSIM_OK) {
        st = read_failed(c, st, why);
    } else {
        if (s.def.shape == DEFSIM_SHAPE_SDF) s.def.sdf = sdf_missing;
        if ((st = defsim_world_add_collider(w, &s.def, &id)) != DEFSIM_OK)
            st = world_failed(w, st, "collider");
        else if ((st = defsim_collider_set_pose(w, id, s.pos1, s.rot1)) != DEFSIM_OK)
            st = world_failed(w, st, "collider pose");
        else
            defsim__collider_restore(&w->colliders.col[defsim__world_id_slot(w, id.index)], &s);
    }
    defsim__collider_saved_free(&s);
    return st;
}

/* Chunks applied once the world is planned: kept. */
static defsim_status keep_forces(loader *L, const chunk *c) { L->forces = c; return DEFSIM_OK; }
static defsim_status keep_pattern(loader *L, const chunk *c) { L->pattern = c; return DEFSIM_OK; }
static defsim_status keep_contact5(loader *L, const chunk *c) { L->contact5 = c; return DEFSIM_OK; }
static defsim_status keep_state(loader *L, const chunk *c) { L->state = c; return DEFSIM_OK; }
static defsim_status keep_stats(loader *L, const chunk *c) { L->stats = c; return DEFSIM_OK; }
static defsim_status keep_backend(loader *L, const chunk *c) { L->backend = c; return DEFSIM_OK; }

static defsim_status keep_term(loader *L, const chunk *c)
{
    if (L->nterms == DEFSIM__TERM_KINDS) return malformed(c, "more than one per kind");
    L->terms[L->nterms++] = c;
    return DEFSIM_OK;
}

/* The readers by tag, with the format versions that have the chunk. */
static const struct {
    char tag[5];
    uint32_t since, until;
    defsim_status (*read)(loader *L, const chunk *c);
} readers[] = {
    {"BODY", 1, DEFSIM__CKPT_VERSION, read_body},
    {"ATCH", 1, DEFSIM__CKPT_VERSION, read_attachment},
    {"FEXT", 1, DEFSIM__CKPT_VERSION, read_fext},
    {"PTGT", 1, DEFSIM__CKPT_VERSION, read_targets},
    {"COLL", 3, DEFSIM__CKPT_VERSION, read_collider},
    {"CFRC", 3, DEFSIM__CKPT_VERSION, keep_forces},
    {"PEXT", 4, DEFSIM__CKPT_VERSION, keep_pattern},
    {"CNTC", 5, 5, keep_contact5},   /* version 6 keeps it in the collider term's TERM chunk */
    {"TERM", 6, DEFSIM__CKPT_VERSION, keep_term},
    {"STAT", 1, DEFSIM__CKPT_VERSION, keep_state},
    {"STCS", 1, DEFSIM__CKPT_VERSION, keep_stats},
    {"BKND", 1, DEFSIM__CKPT_VERSION, keep_backend},
};

static defsim_status load_pattern(defsim_world *w, const chunk *c)
{
    defsim__br r = chunk_reader(c);
    const uint32_t n = defsim__get_u32(&r);
    if (!defsim__fits(&r, n, 8)) return malformed(c, "count out of range");
    int64_t *pairs = malloc(((size_t)n + 1) * sizeof *pairs);
    if (!pairs) return out_of_memory();
    const int64_t nfv = w->sys.nfree_v;
    for (uint32_t k = 0; k < n && !r.bad; ++k) {
        pairs[k] = (int64_t)defsim__get_u64(&r);
        const int64_t fa = pairs[k] >> 32, fb = pairs[k] & 0xFFFFFFFF;
        if (fa < 0 || fa >= fb || fb >= nfv) r.bad = 1;
    }
    defsim_status st = DEFSIM_OK;
    int grew = 0;
    if (!defsim__read_whole(&r)) st = malformed(c, "wrong length or a pair out of range");
    /* Built first: growing a pattern that is not built yet (a backend that builds it at its
     * first use) would drop the pairs. */
    else if ((st = defsim__pattern_build(&w->sys)) != DEFSIM_OK ||
             (st = defsim__pattern_grow(&w->sys, pairs, (int64_t)n, &grew)) != DEFSIM_OK)
        defsim__set_last_error("load: out of memory");
    free(pairs);
    return st;
}

static defsim_status load_contact_forces(defsim_world *w, const chunk *c)
{
    defsim__br r = chunk_reader(c);
    const defsim_status st = defsim__collider_set_load_forces(&w->colliders, &r, w->nv);
    if (st == DEFSIM_ERR_IO)
        return malformed(c, "length does not match the vertices, or a bad flag");
    return st == DEFSIM_OK ? st : out_of_memory();
}

/* The terms' state (version 6): each TERM chunk to its kind's load op, once the world is
 * planned (planning drops that state). */
static defsim_status load_terms(const loader *L)
{
    defsim_world *w = L->w;
    for (int32_t i = 0; i < L->nterms; ++i) {
        const chunk *c = L->terms[i];
        defsim__br r = chunk_reader(c);
        char name[64];
        defsim__get_str(&r, name, sizeof name);
        if (r.bad) return malformed(c, "no term name");
        int kind = -1;
        for (int k = 0; k < DEFSIM__TERM_KINDS && kind < 0; ++k)
            if (strcmp(defsim__terms_detached(&w->sys, k, NULL).ops->name, name) == 0) kind = k;
        void *data = kind >= 0 ? defsim__world_term_state(w, kind) : NULL;
        const defsim__term t = defsim__terms_detached(&w->sys, kind >= 0 ? kind : 0, data);
        if (!data || !t.ops->load) return malformed(c, "a term kind without state to load");
        const defsim_status st = t.ops->load(&t, r.p + r.at, r.n - r.at);
        if (st == DEFSIM_ERR_INVALID_ARGUMENT) return malformed(c, "the term refused its state");
        if (st != DEFSIM_OK) return out_of_memory();
    }
    return DEFSIM_OK;
}

/* Version 5's contact state (CNTC: the penalty's frequency, PENALTY friction's velocities), what
 * version 6 keeps in the collider term's chunk; applied once the world is planned. */
static defsim_status load_contact_state(defsim_world *w, const chunk *c)
{
    defsim__br r = chunk_reader(c);
    const double omega = defsim__get_f64(&r);
    const int32_t has_vel = defsim__get_i32(&r);
    const int64_t ndof = 3 * (int64_t)w->nv;
    if (r.bad || !(omega >= 0.0) || !isfinite(omega) || (has_vel != 0 && has_vel != 1) ||
        (has_vel && w->nv == 0) || c->len != 12 + (has_vel ? 8 * (size_t)ndof : 0))
        return malformed(c, "wrong length, a bad flag, or a frequency that is not finite and "
                            ">= 0");
    if (has_vel) {
        double *vel = malloc((size_t)ndof * sizeof *vel);
        if (!vel) return out_of_memory();
        defsim__get_f64s(&r, vel, ndof);
        int finite = 1;
        for (int64_t i = 0; i < ndof; ++i) finite &= isfinite(vel[i]) != 0;
        const defsim_status st = finite ? defsim__contact_set_vel(&w->contact, w->nv, vel)
                                        : DEFSIM_ERR_IO;
        free(vel);
        if (st == DEFSIM_ERR_IO) return malformed(c, "a velocity is not finite");
        if (st != DEFSIM_OK) return out_of_memory();
    }
    w->contact.omega_elastic = omega;
    return DEFSIM_OK;
}

/* The terms' state of either version. */
static defsim_status load_carried(const loader *L)
{
    return L->contact5 ? load_contact_state(L->w, L->contact5) : load_terms(L);
}

/* The state; the auto_substep cache goes to *h_stable and *age (set once the world is planned,
 * since planning clears it). */
static defsim_status load_state(defsim_world *w, const chunk *c, uint32_t version,
                                double *h_stable, int32_t *age)
{
    defsim__br r = chunk_reader(c);
    const size_t tail = version >= 2 ? 12 : 0;
    if (defsim__get_i32(&r) != w->nv || c->len != 4 + 48 * (size_t)w->nv + 8 + 4 + tail)
        return malformed(c, "the vertex count does not match the bodies");
    const int64_t ndof = 3 * (int64_t)w->nv;
    double *x = malloc(2 * (size_t)(ndof > 0 ? ndof : 1) * sizeof *x);
    if (!x) return out_of_memory();
    defsim__get_f64s(&r, x, 2 * ndof);
    const double t = defsim__get_f64(&r);
    const int32_t drove = defsim__get_i32(&r);
    /* Version 1 files lack the auto_substep cache: the first step estimates it again. */
    *h_stable = version >= 2 ? defsim__get_f64(&r) : 0.0;
    *age = version >= 2 ? defsim__get_i32(&r) : 0;
    const char *bad = NULL;
    if (!(*h_stable >= 0.0) || *age < 0) bad = "a bad stable-step cache";
    for (int64_t i = 0; i < 2 * ndof && !bad; ++i)
        if (!isfinite(x[i])) bad = "a position or velocity is not finite";
    if (!bad && (!isfinite(t) || (drove != 0 && drove != 1)))
        bad = "time not finite, or a bad flag";
    if (bad) {
        free(x);
        return malformed(c, bad);
    }
    /* Written directly: set_state would zero the velocities of driven pins. */
    if (ndof > 0) {   /* an empty world has no state arrays */
        memcpy(w->state.x, x, (size_t)ndof * sizeof *x);
        memcpy(w->state.v, x + ndof, (size_t)ndof * sizeof *x);
    }
    free(x);
    w->state.t = t;
    w->coupling.drove = drove;
    return DEFSIM_OK;
}

static defsim_status load_stats(defsim_world *w, const chunk *c)
{
    defsim__br r = chunk_reader(c);
    const uint32_t n = defsim__get_u32(&r);
    defsim_stats stats = w->stats;
    const int32_t known = defsim__options_stat_count(&w->options);
    /* Statistics are matched by name: ones this library does not know are skipped, ones the
     * file lacks start at zero. */
    for (uint32_t i = 0; i < n && !r.bad; ++i) {
        char name[160];
        defsim__get_str(&r, name, sizeof name);
        const double value = defsim__get_f64(&r);
        if (r.bad) break;
        /* +inf is a value (contact.min_distance without candidates); NaN never is. */
        if (isnan(value) || value == -INFINITY) return malformed(c, "a statistic is NaN or -inf");
        for (int32_t k = 0; k < known; ++k) {
            const char *s;
            defsim__options_stat_info(&w->options, &w->stats, k, &s, NULL);
            if (strcmp(s, name) == 0) {
                defsim__options_stat_write(&w->options, &stats, k, value);
                break;
            }
        }
    }
    if (!defsim__read_whole(&r)) return malformed(c, "wrong length");
    w->stats = stats;
    return DEFSIM_OK;
}

static defsim_status load_backend(defsim_world *w, const chunk *c)
{
    defsim__br r = chunk_reader(c);
    char name[64];
    defsim__get_str(&r, name, sizeof name);
    if (r.bad) return malformed(c, "no backend name");
    const defsim_backend *be = w->backend.table;
    if (strcmp(name, be->name) != 0 || !be->load_state)
        return malformed(c, "history of another backend, or of one that cannot load it");
    if (w->nv == 0) return malformed(c, "history of a world without vertices");
    defsim_status st = defsim__world_plan(w);
    if (st != DEFSIM_OK) return world_failed(w, st, "planning");
    (void)defsim__options_take_reinit(&w->options);   /* the options were set before init */
    if ((st = defsim__world_backend_start(w)) != DEFSIM_OK)
        return world_failed(w, st, "backend initialisation");
    const defsim_state_reader rd = defsim__state_reader(&r);
    /* A backend that replays its last step (sundials_erk) sees the colliders as that step did. */
    st = defsim__world_replay_contact_begin(w);
    if (st != DEFSIM_OK) {
        defsim__world_backend_stop(w);
        return world_failed(w, st, "contact for the backend's history");
    }
    st = be->load_state(&defsim__host, &w->handle, w->backend.state, &rd);
    defsim__world_replay_contact_end(w);
    if (st == DEFSIM_OK && !defsim__read_whole(&r)) st = DEFSIM_ERR_IO;
    if (st != DEFSIM_OK) {
        defsim__world_backend_stop(w);
        if (st == DEFSIM_ERR_IO) return malformed(c, "the backend's history does not fit");
        return world_failed(w, st, "backend history");
    }
    return DEFSIM_OK;
}

/* The chunks in file order: the sub-objects' applied, the others kept; an unknown critical one
 * (upper-case first letter) fails, others are skipped by readers that do not know them. */
static defsim_status read_chunks(loader *L, const ckpt *k)
{
    for (int32_t i = 2; i < k->n; ++i) {
        const chunk *c = &k->c[i];
        if (strcmp(c->tag, "END ") == 0) break;
        size_t j = 0;
        while (j < sizeof readers / sizeof readers[0] &&
               (strcmp(readers[j].tag, c->tag) != 0 || k->version < readers[j].since ||
                k->version > readers[j].until))
            ++j;
        if (j < sizeof readers / sizeof readers[0]) {
            const defsim_status st = readers[j].read(L, c);
            if (st != DEFSIM_OK) return st;
        } else if (c->tag[0] >= 'A' && c->tag[0] <= 'Z') {
            defsim__set_last_error("load: unknown chunk '%s'", c->tag);
            return DEFSIM_ERR_IO;
        }
    }
    if (!L->state) {
        defsim__set_last_error("load: checkpoint has no STAT chunk");
        return DEFSIM_ERR_IO;
    }
    return DEFSIM_OK;
}

/* Builds the world from a checked chunk index: the chunks, then what waits for the plan. */
static defsim_status build(const ckpt *k, defsim_log_fn log, void *log_user, defsim_world **out)
{
    if (k->n < 4 || strcmp(k->c[0].tag, "WRLD") != 0 || strcmp(k->c[1].tag, "OPTS") != 0) {
        defsim__set_last_error("load: checkpoint does not begin with WRLD and OPTS chunks");
        return DEFSIM_ERR_IO;
    }
    loader L;
    memset(&L, 0, sizeof L);
    L.version = k->version;
    defsim_status st = load_world(&k->c[0], log, log_user, &L.w);
    if (st != DEFSIM_OK) return st;
    defsim_world *w = L.w;
    L.map = calloc((size_t)k->n, sizeof *L.map);
    if (!L.map) st = out_of_memory();
    if (st == DEFSIM_OK) st = load_options(w, &k->c[1]);
    if (st == DEFSIM_OK) st = read_chunks(&L, k);
    double h_stable = 0.0;
    int32_t age = 0;
    if (st == DEFSIM_OK) st = load_state(w, L.state, k->version, &h_stable, &age);
    if (st == DEFSIM_OK && L.forces) st = load_contact_forces(w, L.forces);
    /* Planned now, with the options taken as the backend's initial ones, as the saved world
     * was: its first step keeps the cache. The pattern grows before the backend starts: a
     * backend borrows it at init, and growing it later would free what it holds (newmark's
     * first step read freed memory that way). */
    if (st == DEFSIM_OK && (st = defsim__world_plan(w)) != DEFSIM_OK)
        st = world_failed(w, st, "planning");
    if (st == DEFSIM_OK && L.pattern) st = load_pattern(w, L.pattern);
    if (st == DEFSIM_OK) st = load_carried(&L);
    if (st == DEFSIM_OK && L.backend) st = load_backend(w, L.backend);
    /* Again: a replay in the backend's load evaluated friction, which keeps its velocities. */
    if (st == DEFSIM_OK && L.backend) st = load_carried(&L);
    if (st == DEFSIM_OK) {
        (void)defsim__options_take_reinit(&w->options);
        w->step.h_stable = h_stable;
        w->step.since_estimate = age;
    }
    /* Statistics last: planning and the backend's load count nothing the run did. */
    if (st == DEFSIM_OK && L.stats) st = load_stats(w, L.stats);
    free(L.map);
    if (st != DEFSIM_OK) {
        defsim_world_destroy(w);
        return st;
    }
    w->msg->error[0] = '\0';
    *out = w;
    return DEFSIM_OK;
}

defsim_status defsim_world_load_buffer(const void *data, size_t size, defsim_log_fn log,
                                       void *log_user, defsim_world **out)
{
    if (out) *out = NULL;
    if (!data || !out) {
        defsim__set_last_error("load: data and out must not be NULL");
        return DEFSIM_ERR_INVALID_ARGUMENT;
    }
    ckpt k;
    defsim_status st = index_chunks(data, size, &k);
    if (st != DEFSIM_OK) return st;
    st = build(&k, log, log_user, out);
    free(k.c);
    return st;
}

defsim_status defsim_world_load(const char *path, defsim_log_fn log, void *log_user,
                                defsim_world **out)
{
    if (out) *out = NULL;
    if (!path || !out) {
        defsim__set_last_error("load: path and out must not be NULL");
        return DEFSIM_ERR_INVALID_ARGUMENT;
    }
    char *buf = NULL;
    size_t len = 0;
    const int err = defsim__read_file(path, DEFSIM__FILE_MAX, &buf, &len);
    if (err != 0) {
        defsim__set_last_error("load: cannot read '%s': %s", path, strerror(err));
        return err == ENOMEM ? DEFSIM_ERR_OUT_OF_MEMORY : DEFSIM_ERR_IO;
    }
    defsim_status st = defsim_world_load_buffer(buf, len, log, log_user, out);
    free(buf);
    return st;
}

/* ------------------------------------------------------------------------------------------ */
/* Enumeration */

int32_t defsim_world_body_count(const defsim_world *w)
{
    if (!defsim__world_live(w)) return 0;
    int32_t n = 0;
    for (int32_t s = 0; s < w->bodies.ids.nslots; ++s) n += (w->bodies.ids.gen[s] & 1u) != 0;
    return n;
}

defsim_status defsim_world_body_at(const defsim_world *w, int32_t i, defsim_body_id *out)
{
    if (!defsim__world_live(w)) return DEFSIM_ERR_INVALID_ARGUMENT;
    if (!out) {
        defsim__error(w->msg, "body_at: out is NULL");
        return DEFSIM_ERR_INVALID_ARGUMENT;
    }
    /* The i-th body in vertex order is bodies[i]; find the id slot that holds it. */
    for (int32_t s = 0; i >= 0 && i < w->bodies.n && s < w->bodies.ids.nslots; ++s)
        if ((w->bodies.ids.gen[s] & 1u) && w->bodies.ids.dense[s] == i) {
            *out = (defsim_body_id){defsim__world_id_index(w, s), w->bodies.ids.gen[s]};
            return DEFSIM_OK;
        }
    defsim__error(w->msg, "body_at: index %d out of range [0, %d)", (int)i,
                  (int)defsim_world_body_count(w));
    return DEFSIM_ERR_INVALID_ARGUMENT;
}

int32_t defsim_world_attachment_count(const defsim_world *w)
{
    if (!defsim__world_live(w)) return 0;
    int32_t n = 0;
    for (int32_t i = 0; i < w->coupling.natt; ++i) n += (w->coupling.att[i].generation & 1u) != 0;
    return n;
}

defsim_status defsim_world_attachment_at(const defsim_world *w, int32_t i,
                                         defsim_attachment_id *out)
{
    if (!defsim__world_live(w)) return DEFSIM_ERR_INVALID_ARGUMENT;
    if (!out) {
        defsim__error(w->msg, "attachment_at: out is NULL");
        return DEFSIM_ERR_INVALID_ARGUMENT;
    }
    for (int32_t k = 0; i >= 0 && k < w->coupling.natt; ++k)
        if ((w->coupling.att[k].generation & 1u) && i-- == 0) {
            *out = (defsim_attachment_id){defsim__world_id_index(w, k), w->coupling.att[k].generation};
            return DEFSIM_OK;
        }
    defsim__error(w->msg, "attachment_at: index out of range [0, %d)",
                  (int)defsim_world_attachment_count(w));
    return DEFSIM_ERR_INVALID_ARGUMENT;
}

/* ------------------------------------------------------------------------------------------ */
/* SDF colliders of a loaded world */

defsim_status defsim_collider_set_sdf(defsim_world *w, defsim_collider_id id, defsim_sdf_fn sdf,
                                      void *user)
{
    defsim_status st = defsim__world_enter(w);
    if (st != DEFSIM_OK) return st;
    const int64_t slot = defsim__world_id_slot(w, id.index);
    defsim__collider *c = slot >= 0 && slot < w->colliders.ncol ? &w->colliders.col[slot] : NULL;
    if (!c || c->generation != id.generation || !(id.generation & 1u)) {
        defsim__error(w->msg, "collider id {%u, %u} is %s", (unsigned)id.index,
                      (unsigned)id.generation,
                      defsim__world_id_problem(w, id.index, id.generation));
        return DEFSIM_ERR_STALE_ID;
    }
    if (!sdf || c->def.shape != DEFSIM_SHAPE_SDF) {
        defsim__error(w->msg, "collider_set_sdf: %s", !sdf ? "sdf is NULL"
                                                          : "the collider is not an SDF");
        return DEFSIM_ERR_INVALID_ARGUMENT;
    }
    c->def.sdf = sdf;
    c->def.sdf_user = user;
    return DEFSIM_OK;
}
