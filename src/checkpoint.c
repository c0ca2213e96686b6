/* SPDX-License-Identifier: MIT */
/*
 * Checkpoints (defsim.h "Checkpoints", docs/checkpoints.md): a world written as a header and
 * tagged chunks, every number little-endian (doubles as IEEE binary64 bit patterns), each chunk
 * closed by its CRC-32, the file by an END chunk. Loading checks the whole file before it builds
 * a new world through the public API (so every value is validated as the host's would be), then
 * writes the state, statistics and backend history in.
 *
 * Contents: CRC-32; byte writer; chunk writers; save (buffer, file); byte reader; chunk index;
 * load; enumeration of bodies and attachments.
 */
#include "checkpoint.h"

#include "assembly.h"
#include "contact.h"

#include "file_read.h"
#include "step.h"
#include "world.h"

#include <errno.h>
#include <fcntl.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

/* ------------------------------------------------------------------------------------------ */
/* CRC-32 */

uint32_t defsim__crc32(uint32_t crc, const void *data, size_t n)
{
    const unsigned char *p = data;
    crc = ~crc;
    for (size_t i = 0; i < n; ++i) {
        crc ^= p[i];
        for (int k = 0; k < 8; ++k) crc = (crc >> 1) ^ (0xEDB88320u & (0u - (crc & 1u)));
    }
    return ~crc;
}

/* ------------------------------------------------------------------------------------------ */
/* Byte writer: a growing buffer; after an allocation failure every put is ignored and `oom`
 * stays set. */

typedef struct bw {
    unsigned char *p;
    size_t n, cap;
    int oom;
} bw;

static void put(bw *b, const void *data, size_t n)
{
    if (b->oom) return;
    if (b->n + n > b->cap) {
        size_t cap = b->cap ? b->cap : 4096;
        while (cap < b->n + n) cap *= 2;
        unsigned char *q = realloc(b->p, cap);
        if (!q) {
            b->oom = 1;
            return;
        }
        b->p = q;
        b->cap = cap;
    }
    memcpy(b->p + b->n, data, n);
    b->n += n;
}

static void put_u32(bw *b, uint32_t v)
{
    unsigned char c[4] = {(unsigned char)v, (unsigned char)(v >> 8), (unsigned char)(v >> 16),
                          (unsigned char)(v >> 24)};
    put(b, c, 4);
}

static void put_u64(bw *b, uint64_t v)
{
    unsigned char c[8];
    for (int k = 0; k < 8; ++k) c[k] = (unsigned char)(v >> (8 * k));
    put(b, c, 8);
}

static void put_i32(bw *b, int32_t v) { put_u32(b, (uint32_t)v); }

static void put_f64(bw *b, double v)
{
    uint64_t u;
    memcpy(&u, &v, sizeof u);
    put_u64(b, u);
}

static void put_f64s(bw *b, const double *v, int64_t n)
{
    for (int64_t i = 0; i < n; ++i) put_f64(b, v[i]);
}

static void put_i32s(bw *b, const int32_t *v, int64_t n)
{
    for (int64_t i = 0; i < n; ++i) put_i32(b, v[i]);
}

static void put_str(bw *b, const char *s)
{
    const size_t n = strlen(s);
    put_u32(b, (uint32_t)n);
    put(b, s, n);
}

/* A chunk: tag (4 ASCII bytes), payload length (u64), payload, CRC-32 of all of those. */
static size_t chunk_begin(bw *b, const char tag[4])
{
    const size_t at = b->n;
    put(b, tag, 4);
    put_u64(b, 0);
    return at;
}

static void chunk_end(bw *b, size_t at)
{
    if (b->oom) return;
    const uint64_t len = b->n - at - 12;
    for (int k = 0; k < 8; ++k) b->p[at + 4 + k] = (unsigned char)(len >> (8 * k));
    put_u32(b, defsim__crc32(0, b->p + at, b->n - at));
}

/* The backend's writer (defsim_state_writer) over a byte writer. */
static defsim_status sw_f64(void *ctx, const double *v, int64_t n)
{
    put_f64s(ctx, v, n);
    return ((bw *)ctx)->oom ? DEFSIM_ERR_OUT_OF_MEMORY : DEFSIM_OK;
}

static defsim_status sw_i64(void *ctx, const int64_t *v, int64_t n)
{
    for (int64_t i = 0; i < n; ++i) put_u64(ctx, (uint64_t)v[i]);
    return ((bw *)ctx)->oom ? DEFSIM_ERR_OUT_OF_MEMORY : DEFSIM_OK;
}

/* ------------------------------------------------------------------------------------------ */
/* Save */

static void write_world(bw *b, const defsim_world *w)
{
    const defsim_world_def *d = &w->def;
    size_t c = chunk_begin(b, "WRLD");
    put_str(b, w->backend_name);
    put_f64s(b, d->gravity, 3);
    put_i32(b, w->nthreads);   /* resolved: the same bits need the same thread count */
    chunk_end(b, c);   /* the settings are options: the OPTS chunk holds them by name */

    c = chunk_begin(b, "OPTS");
    const int32_t n = defsim__options_count(&w->options);
    put_u32(b, (uint32_t)n);
    for (int32_t i = 0; i < n; ++i) {
        defsim_option_info info;
        info.size = sizeof info;
        defsim__options_info(&w->options, i, &info);
        put_str(b, info.name);
        put_f64(b, info.value);
    }
    chunk_end(b, c);
}

/* Saved ids are id slots + 1, without the world's tag (so that the same world saves the same
 * bytes whatever world it was loaded into): the id of bodies[dense], and of a body id. */
static uint32_t saved_body_index(const defsim_world *w, int32_t dense)
{
    for (int32_t s = 0; s < w->body_ids.nslots; ++s)
        if ((w->body_ids.gen[s] & 1u) && w->body_ids.dense[s] == dense) return (uint32_t)s + 1;
    return 0;
}

static uint32_t saved_id_index(const defsim_world *w, uint32_t index)
{
    const int64_t slot = defsim__world_id_slot(w, index);
    return slot < 0 ? 0 : (uint32_t)slot + 1;
}

static void write_bodies(bw *b, const defsim_world *w)
{
    for (int32_t i = 0; i < w->nbodies; ++i) {
        const defsim__body *body = &w->bodies[i];
        if (!(body->generation & 1u)) continue;
        const size_t c = chunk_begin(b, "BODY");
        put_u32(b, saved_body_index(w, i));   /* the saved id, for the attachments naming it */
        put_u32(b, body->generation);
        put_i32(b, body->nv);
        put_i32(b, body->nt);
        put_i32(b, body->ns);
        const defsim_material *m = &body->mat;
        put_i32(b, (int32_t)m->model);
        const double mp[7] = {m->youngs_modulus, m->poisson_ratio, m->density, m->stiffness,
                              m->vertex_mass, m->mass_damping, m->stiffness_damping};
        put_f64s(b, mp, 7);
        put_f64s(b, body->rest, 3 * (int64_t)body->nv);
        put_f64s(b, body->mass, body->nv);
        put_i32s(b, body->tets, 4 * (int64_t)body->nt);
        put_i32s(b, body->springs, 2 * (int64_t)body->ns);
        put_f64s(b, body->k, body->ns);
        put(b, body->pinned, (size_t)body->nv);
        /* version 4: body contact */
        put_i32(b, body->ntri);
        put_i32(b, body->nedge);
        put_i32s(b, body->tris, 3 * (int64_t)body->ntri);
        put_i32s(b, body->edges, 2 * (int64_t)body->nedge);
        put_i32(b, body->self_contact);
        put_u32(b, body->group);
        put_u32(b, body->mask);
        put_f64(b, body->friction);
        chunk_end(b, c);
    }
}

static void write_coupling(bw *b, const defsim_world *w)
{
    for (int32_t i = 0; i < w->coupling.natt; ++i) {
        const defsim__attachment *a = &w->coupling.att[i];
        if (!(a->generation & 1u)) continue;
        const defsim_attachment_def *d = &a->def;
        const size_t c = chunk_begin(b, "ATCH");
        put_u32(b, saved_id_index(w, d->body.index));
        put_u32(b, d->body.generation);
        put_i32(b, d->vertex);
        put_f64(b, d->stiffness);
        put_f64(b, d->damping);
        put_f64s(b, d->target, 3);
        put_u32(b, d->target_body.index ? saved_id_index(w, d->target_body.index) : 0);
        put_u32(b, d->target_body.generation);
        put_i32(b, d->target_vertex_count);
        put_i32s(b, d->target_vertices, 4);
        put_f64s(b, d->target_weights, 4);
        chunk_end(b, c);
    }
    if (w->coupling.fext) {
        const size_t c = chunk_begin(b, "FEXT");
        put_f64s(b, w->coupling.fext, 3 * (int64_t)w->nv);
        chunk_end(b, c);
    }
    if (w->coupling.ntargeted > 0) {
        const size_t c = chunk_begin(b, "PTGT");
        put_u32(b, (uint32_t)w->coupling.ntargeted);
        for (int32_t v = 0; v < w->nv; ++v)
            if (w->coupling.targeted[v]) {
                put_i32(b, v);
                put_f64s(b, w->coupling.pin_target + 3 * (int64_t)v, 3);
            }
        chunk_end(b, c);
    }
}

/* Colliders (version 3): each live one in slot order with its pose now and at the end of the
 * next step, as stored (normalised), so that the loaded world has the same bits. */
static void write_colliders(bw *b, const defsim_world *w)
{
    for (int32_t i = 0; i < w->colliders.ncol; ++i) {
        const defsim__collider *c = &w->colliders.col[i];
        if (!(c->generation & 1u)) continue;
        const defsim_collider_def *d = &c->def;
        const size_t at = chunk_begin(b, "COLL");
        put_i32(b, (int32_t)d->shape);
        put_f64s(b, c->pos, 3);
        put_f64s(b, c->rot, 4);
        put_f64s(b, c->pos1, 3);
        put_f64s(b, c->rot1, 4);
        put_f64s(b, d->normal, 3);
        put_f64(b, d->radius);
        put_f64s(b, d->half_extents, 3);
        put_f64(b, d->half_height);
        put_f64(b, d->friction);
        put_f64s(b, d->sdf_bounds, 6);
        const int mesh = d->shape == DEFSIM_SHAPE_MESH;
        put_i32(b, mesh ? d->vertex_count : 0);
        put_i32(b, mesh ? d->triangle_count : 0);
        if (mesh) {
            put_f64s(b, d->vertices, 3 * (int64_t)d->vertex_count);
            put_i32s(b, d->triangles, 3 * (int64_t)d->triangle_count);
        }
        chunk_end(b, at);
    }
    /* Whether the colliders changed since the last step, and that step's contact forces (the
     * read-back) when they are still of these vertices. */
    const int forces = w->colliders.force && w->colliders.force_nv == w->nv;
    if (w->colliders.ncol > 0 || forces) {
        const size_t at = chunk_begin(b, "CFRC");
        put_i32(b, w->colliders.changed);
        put_i32(b, forces);
        if (forces) put_f64s(b, w->colliders.force, 3 * (int64_t)w->nv);
        chunk_end(b, at);
    }
}

/* Contact state that the next steps depend on (version 5): the penalty's automatic frequency,
 * computed by power iteration at the state of the first step after a plan and kept for the plan
 * (a loaded world would compute it at the saved state: another stiffness), and the velocities
 * of penalty friction's matrix blocks, those of the latest damping evaluation with pairs, which
 * sundials_kinsol's damping matrix B(x_n) takes from the end of the step before (a loaded world
 * would have zeros). */
static void write_contact_state(bw *b, const defsim_world *w)
{
    const double omega = w->planned ? w->contact.omega_elastic : 0.0;
    const double *vel = defsim__contact_vel(&w->contact, w->nv);
    if (omega == 0.0 && !vel) return;
    const size_t at = chunk_begin(b, "CNTC");
    put_f64(b, omega);
    put_i32(b, vel != NULL);
    if (vel) put_f64s(b, vel, 3 * (int64_t)w->nv);
    chunk_end(b, at);
}

static void write_state(bw *b, const defsim_world *w)
{
    size_t c = chunk_begin(b, "STAT");
    put_i32(b, w->nv);
    put_f64s(b, w->state.x, 3 * (int64_t)w->nv);
    put_f64s(b, w->state.v, 3 * (int64_t)w->nv);
    put_f64(b, w->state.t);
    put_i32(b, w->coupling.drove);
    /* Version 2: auto_substep's cached stable step and its age, which set the substeps. */
    const int kept = w->planned && !w->options.reinit;   /* else the next step drops it */
    put_f64(b, kept ? w->h_stable : 0.0);
    put_i32(b, kept ? w->steps_since_estimate : 0);
    chunk_end(b, c);

    c = chunk_begin(b, "STCS");
    const int32_t n = defsim__options_stat_count(&w->options);
    put_u32(b, (uint32_t)n);
    for (int32_t i = 0; i < n; ++i) {
        const char *name;
        double value;
        defsim__options_stat_info(&w->options, &w->stats, i, &name, &value);
        put_str(b, name);
        put_f64(b, value);
    }
    chunk_end(b, c);
}

/* The backend's history, when it has one to give: initialised for the current bodies, pins and
 * options (a pending change would drop the history at the next step anyway). */
static defsim_status write_backend(bw *b, const defsim_world *w)
{
    const defsim_backend *be = w->backend;
    if (!be->save_state || !w->backend_ready || !w->planned || w->options.reinit) return DEFSIM_OK;
    const size_t c = chunk_begin(b, "BKND");
    put_str(b, be->name);
    const defsim_state_writer wr = {b, sw_f64, sw_i64};
    defsim_world *mw = (defsim_world *)w;   /* host services take a mutable system */
    const defsim_status st = be->save_state(&defsim__host, &mw->handle, w->bstate, &wr);
    if (st != DEFSIM_OK) {
        if (!w->msg->error[0])
            defsim__error(w->msg, "save: backend %s could not save its history (%s)", be->name,
                          defsim_status_string(st));
        return st;
    }
    chunk_end(b, c);
    return DEFSIM_OK;
}

/* The vertex pairs that body contact added to the matrix pattern (version 4): the loaded world
 * starts from the same pattern, so its factorisations round alike. */
static void write_pattern(bw *b, const defsim_world *w)
{
    if (!w->planned || w->sys.pattern.nextra == 0) return;
    const size_t c = chunk_begin(b, "PEXT");
    put_u32(b, (uint32_t)w->sys.pattern.nextra);
    for (int64_t k = 0; k < w->sys.pattern.nextra; ++k) put_u64(b, (uint64_t)w->sys.pattern.extra[k]);
    chunk_end(b, c);
}

static defsim_status save_to(const defsim_world *w, bw *b)
{
    put(b, DEFSIM__CKPT_MAGIC, 8);
    put_u32(b, DEFSIM__CKPT_VERSION);
    put_u32(b, 0);
    write_world(b, w);
    write_bodies(b, w);
    write_coupling(b, w);
    write_colliders(b, w);
    write_contact_state(b, w);
    write_pattern(b, w);
    write_state(b, w);
    defsim_status st = write_backend(b, w);
    if (st != DEFSIM_OK) return st;
    const size_t c = chunk_begin(b, "END ");
    chunk_end(b, c);
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
    bw b = {0};
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
    bw b = {0};
    if ((st = save_to(w, &b)) == DEFSIM_OK) st = write_atomic(w, path, b.p, b.n);
    free(b.p);
    return st;
}

/* ------------------------------------------------------------------------------------------ */
/* Byte reader over one chunk's payload: reads past the end set `bad` and yield zeros. */

typedef struct br {
    const unsigned char *p;
    size_t n, at;
    int bad;
} br;

static const unsigned char *take(br *r, size_t n)
{
    if (r->bad || n > r->n - r->at) {
        r->bad = 1;
        return NULL;
    }
    const unsigned char *q = r->p + r->at;
    r->at += n;
    return q;
}

static uint32_t get_u32(br *r)
{
    const unsigned char *c = take(r, 4);
    return c ? (uint32_t)c[0] | (uint32_t)c[1] << 8 | (uint32_t)c[2] << 16 | (uint32_t)c[3] << 24
             : 0;
}

static uint64_t get_u64(br *r)
{
    const unsigned char *c = take(r, 8);
    uint64_t v = 0;
    if (c)
        for (int k = 0; k < 8; ++k) v |= (uint64_t)c[k] << (8 * k);
    return v;
}

static int32_t get_i32(br *r) { return (int32_t)get_u32(r); }

static double get_f64(br *r)
{
    const uint64_t u = get_u64(r);
    double v;
    memcpy(&v, &u, sizeof v);
    return v;
}

static void get_f64s(br *r, double *v, int64_t n)
{
    for (int64_t i = 0; i < n; ++i) v[i] = get_f64(r);
}

static void get_i32s(br *r, int32_t *v, int64_t n)
{
    for (int64_t i = 0; i < n; ++i) v[i] = get_i32(r);
}

/* A string into buf (NUL-terminated); longer than cap - 1 bytes is malformed. */
static void get_str(br *r, char *buf, size_t cap)
{
    const uint32_t n = get_u32(r);
    const unsigned char *c = n < cap ? take(r, n) : NULL;
    if (!c) {
        r->bad = 1;
        buf[0] = '\0';
        return;
    }
    memcpy(buf, c, n);
    buf[n] = '\0';
}

/* Counts read from a file are checked against what the chunk can still hold before anything is
 * allocated for them (each element takes at least `unit` bytes). */
static int fits(const br *r, int64_t count, size_t unit)
{
    return !r->bad && count >= 0 && (uint64_t)count <= (r->n - r->at) / unit;
}

static defsim_status sr_f64(void *ctx, double *v, int64_t n)
{
    br *r = ctx;
    if (!fits(r, n, 8)) return DEFSIM_ERR_IO;
    get_f64s(r, v, n);
    return DEFSIM_OK;
}

static defsim_status sr_i64(void *ctx, int64_t *v, int64_t n)
{
    br *r = ctx;
    if (!fits(r, n, 8)) return DEFSIM_ERR_IO;
    for (int64_t i = 0; i < n; ++i) v[i] = (int64_t)get_u64(r);
    return DEFSIM_OK;
}

static int64_t sr_remaining(void *ctx)
{
    const br *r = ctx;
    return r->bad ? 0 : (int64_t)((r->n - r->at) / 8);
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
    br h = {p, n, 8, 0};
    out->version = get_u32(&h);
    const uint32_t flags = get_u32(&h);
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
        br r = {p, n, at + 4, 0};
        const uint64_t len = get_u64(&r);
        if (len > n - at - 16) {
            defsim__set_last_error("load: checkpoint truncated: chunk '%.4s' at byte %zu claims "
                                   "%llu bytes", (const char *)p + at, at,
                                   (unsigned long long)len);
            goto fail;
        }
        r.at = at + 12 + (size_t)len;
        const uint32_t crc = get_u32(&r);
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

static br chunk_reader(const chunk *c) { return (br){c->payload, c->len, 0, 0}; }

/* ------------------------------------------------------------------------------------------ */
/* Load */

/* Fails the load of chunk c with a malformed-file message. */
static defsim_status malformed(const chunk *c, const char *what)
{
    defsim__set_last_error("load: malformed '%s' chunk: %s", c->tag, what);
    return DEFSIM_ERR_IO;
}

/* Moves a world's last error into the thread's (the world is about to go). */
static defsim_status world_failed(defsim_world *w, defsim_status st, const char *what)
{
    defsim__set_last_error("load: %s: %s", what, w->msg->error);
    return st;
}

static defsim_status load_world(const chunk *c, defsim_log_fn log, void *log_user,
                                defsim_world **out)
{
    br r = chunk_reader(c);
    char backend[64];
    get_str(&r, backend, sizeof backend);
    defsim_world_def d;
    defsim_world_def_init(&d, sizeof d);
    d.backend = backend;
    get_f64s(&r, d.gravity, 3);
    d.num_threads = get_i32(&r);
    /* Files written before the world def lost its nine backend settings carry them here:
     * tolerance, max_iterations, rtol, atol, projection, ... At creation they set the options
     * of the same names, which the OPTS chunk holds, except the projection of a backend that
     * had no such option then (sundials_ida, sundials_kinsol): set it here where it has one. */
    int32_t projection = DEFSIM_PROJECTION_CLAMP;
    if (!r.bad && r.n - r.at == 4 * sizeof(double) + 5 * sizeof(int32_t)) {
        r.at += 3 * sizeof(double) + sizeof(int32_t);
        projection = get_i32(&r);
        r.at = r.n;
    }
    if (r.bad || r.at != r.n) return malformed(c, "wrong length");
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
    br r = chunk_reader(c);
    const uint32_t n = get_u32(&r);
    for (uint32_t i = 0; i < n && !r.bad; ++i) {
        char name[160];
        get_str(&r, name, sizeof name);
        const double value = get_f64(&r);
        if (r.bad) break;
        /* An option at the value it has is left alone: it stays a default, and an environment
         * variable's default (DEFSIM_SIMD) still applies as it did to the saved run. */
        double now;
        if (defsim_world_get_option(w, name, &now) == DEFSIM_OK && now == value) continue;
        const defsim_status st = defsim_world_set_option_number(w, name, value);
        if (st != DEFSIM_OK) return world_failed(w, st, "option");
    }
    if (r.bad || r.at != r.n) return malformed(c, "wrong length");
    return DEFSIM_OK;
}

/* Saved body index -> id in the new world. */
typedef struct id_map {
    uint32_t old_index, old_generation;
    defsim_body_id id;
} id_map;

static defsim_status load_body(defsim_world *w, const chunk *c, uint32_t version, id_map *map)
{
    br r = chunk_reader(c);
    map->old_index = get_u32(&r);
    map->old_generation = get_u32(&r);
    const int32_t nv = get_i32(&r), nt = get_i32(&r), ns = get_i32(&r);
    defsim_body_def d;
    defsim_body_def_init(&d, sizeof d);
    d.material.model = (defsim_model)get_i32(&r);
    double mp[7];
    get_f64s(&r, mp, 7);
    d.material.youngs_modulus = mp[0];
    d.material.poisson_ratio = mp[1];
    d.material.density = mp[2];
    d.material.stiffness = mp[3];
    d.material.vertex_mass = mp[4];
    d.material.mass_damping = mp[5];
    d.material.stiffness_damping = mp[6];
    /* Each vertex takes 4 doubles and a byte, each tet 16 bytes, each spring 16. */
    if (nv < 1 || nt < 0 || ns < 0 || !fits(&r, nv, 33) || !fits(&r, nt, 16) ||
        !fits(&r, ns, 16))
        return malformed(c, "counts out of range");
    double *rest = malloc(3 * (size_t)nv * sizeof *rest);
    double *mass = malloc((size_t)nv * sizeof *mass);
    int32_t *tets = malloc((4 * (size_t)nt + 1) * sizeof *tets);
    int32_t *springs = malloc((2 * (size_t)ns + 1) * sizeof *springs);
    double *k = malloc(((size_t)ns + 1) * sizeof *k);
    int32_t *pins = malloc((size_t)nv * sizeof *pins);
    defsim_status st = DEFSIM_OK;
    if (!rest || !mass || !tets || !springs || !k || !pins) {
        defsim__set_last_error("load: out of memory");
        st = DEFSIM_ERR_OUT_OF_MEMORY;
        goto done;
    }
    get_f64s(&r, rest, 3 * (int64_t)nv);
    get_f64s(&r, mass, nv);
    get_i32s(&r, tets, 4 * (int64_t)nt);
    get_i32s(&r, springs, 2 * (int64_t)ns);
    get_f64s(&r, k, ns);
    int32_t npin = 0;
    const unsigned char *pinned = take(&r, (size_t)nv);
    for (int32_t i = 0; pinned && i < nv; ++i)
        if (pinned[i]) pins[npin++] = i;
    /* Body contact (version 4); older files get the defaults. The contact edges (a rope's
     * stretch springs) are restored as saved: the springs come back without their kinds. */
    int32_t ntri = 0, nedge = 0, *tris = NULL, *edges = NULL;
    if (version >= 4) {
        ntri = get_i32(&r);
        nedge = get_i32(&r);
        if (ntri < 0 || nedge < 0 || !fits(&r, ntri, 12) || !fits(&r, nedge, 8)) {
            st = malformed(c, "counts out of range");
            goto done;
        }
        tris = malloc((3 * (size_t)ntri + 1) * sizeof *tris);
        edges = malloc((2 * (size_t)nedge + 1) * sizeof *edges);
        if (!tris || !edges) {
            free(tris);
            free(edges);
            defsim__set_last_error("load: out of memory");
            st = DEFSIM_ERR_OUT_OF_MEMORY;
            goto done;
        }
        get_i32s(&r, tris, 3 * (int64_t)ntri);
        get_i32s(&r, edges, 2 * (int64_t)nedge);
        d.self_contact = get_i32(&r);
        d.collision_group = get_u32(&r);
        d.collision_mask = get_u32(&r);
        d.friction = get_f64(&r);
        d.triangles = ntri > 0 ? tris : NULL;
        d.triangle_count = ntri;
    }
    for (int32_t e = 0; e < 2 * nedge && !r.bad; ++e)
        if (edges[e] < 0 || edges[e] >= nv) r.bad = 1;
    if (r.bad || r.at != r.n) {
        free(tris);
        free(edges);
        st = malformed(c, "wrong length");
        goto done;
    }
    /* Masses and stiffnesses as saved, so that the compiled system has the same bits. */
    d.rest_positions = rest;
    d.vertex_count = nv;
    d.tets = nt > 0 ? tets : NULL;
    d.tet_count = nt;
    d.springs = ns > 0 ? springs : NULL;
    d.spring_count = ns;
    d.spring_stiffness = ns > 0 ? k : NULL;
    d.vertex_mass = mass;
    st = defsim_world_add_body(w, &d, &map->id);
    free(tris);
    if (st == DEFSIM_OK && version >= 4) {
        defsim__body *bd = defsim__world_find_body(w, map->id);
        free(bd->edges);
        bd->edges = nedge > 0 ? edges : NULL;
        bd->nedge = nedge;
        if (nedge == 0) free(edges);
    } else {
        free(edges);
    }
    if (st != DEFSIM_OK) {
        st = world_failed(w, st, "body");
        goto done;
    }
    if (npin > 0 && (st = defsim_body_pin(w, map->id, pins, npin)) != DEFSIM_OK)
        st = world_failed(w, st, "pins");
done:
    free(rest); free(mass); free(tets); free(springs); free(k); free(pins);
    return st;
}

static defsim_status map_body(const chunk *c, const id_map *map, int32_t n, uint32_t index,
                              uint32_t generation, defsim_body_id *out)
{
    for (int32_t i = 0; i < n; ++i)
        if (map[i].old_index == index && map[i].old_generation == generation) {
            *out = map[i].id;
            return DEFSIM_OK;
        }
    return malformed(c, "names a body that the checkpoint does not hold");
}

static defsim_status load_attachment(defsim_world *w, const chunk *c, const id_map *map,
                                     int32_t nmap)
{
    br r = chunk_reader(c);
    defsim_attachment_def d;
    defsim_attachment_def_init(&d, sizeof d);
    const uint32_t bi = get_u32(&r), bg = get_u32(&r);
    d.vertex = get_i32(&r);
    d.stiffness = get_f64(&r);
    d.damping = get_f64(&r);
    get_f64s(&r, d.target, 3);
    const uint32_t ti = get_u32(&r), tg = get_u32(&r);
    d.target_vertex_count = get_i32(&r);
    get_i32s(&r, d.target_vertices, 4);
    get_f64s(&r, d.target_weights, 4);
    if (r.bad || r.at != r.n) return malformed(c, "wrong length");
    defsim_status st = map_body(c, map, nmap, bi, bg, &d.body);
    if (st != DEFSIM_OK) return st;
    if (ti != 0 || tg != 0) {
        if ((st = map_body(c, map, nmap, ti, tg, &d.target_body)) != DEFSIM_OK) return st;
    } else {
        d.target_vertex_count = 0;
    }
    if ((st = defsim_world_add_attachment(w, &d, NULL)) != DEFSIM_OK)
        return world_failed(w, st, "attachment");
    return DEFSIM_OK;
}

static defsim_status load_fext(defsim_world *w, const chunk *c)
{
    if (c->len != 24 * (size_t)w->nv) return malformed(c, "length does not match the vertices");
    br r = chunk_reader(c);
    double *f = malloc(3 * (size_t)(w->nv > 0 ? w->nv : 1) * sizeof *f);
    if (!f) {
        defsim__set_last_error("load: out of memory");
        return DEFSIM_ERR_OUT_OF_MEMORY;
    }
    get_f64s(&r, f, 3 * (int64_t)w->nv);
    defsim_status st = defsim_world_set_external_forces(w, f, w->nv);
    free(f);
    return st == DEFSIM_OK ? st : world_failed(w, st, "external forces");
}

/* Driven-pin targets: every vertex named must be pinned already (the BODY chunks pin them). */
static defsim_status load_targets(defsim_world *w, const chunk *c)
{
    br r = chunk_reader(c);
    const uint32_t n = get_u32(&r);
    if (!fits(&r, n, 28) || n > (uint32_t)w->nv) return malformed(c, "count out of range");
    if (!w->coupling.pin_target) {
        w->coupling.pin_target = malloc(3 * (size_t)w->nv * sizeof *w->coupling.pin_target);
        w->coupling.targeted = calloc((size_t)w->nv, 1);
        if (!w->coupling.pin_target || !w->coupling.targeted) {
            defsim__set_last_error("load: out of memory");
            return DEFSIM_ERR_OUT_OF_MEMORY;
        }
    }
    for (uint32_t i = 0; i < n; ++i) {
        const int32_t v = get_i32(&r);
        double p[3];
        get_f64s(&r, p, 3);
        if (r.bad || v < 0 || v >= w->nv || !w->pinned[v] || w->coupling.targeted[v] ||
            !isfinite(p[0]) || !isfinite(p[1]) || !isfinite(p[2]))
            return malformed(c, "a target of a vertex that is not pinned, repeated or not finite");
        memcpy(w->coupling.pin_target + 3 * (int64_t)v, p, sizeof p);
        w->coupling.targeted[v] = 1;
        w->coupling.ntargeted++;
    }
    if (r.at != r.n) return malformed(c, "wrong length");
    return DEFSIM_OK;
}

/* The state; the auto_substep cache goes to *h_stable and *age (set once the world is planned,
 * since planning clears it). */
/* Stands in for an SDF collider's function until the host installs it again
 * (defsim_collider_set_sdf): a step that queries it fails with DEFSIM_ERR_CALLBACK. */
static double sdf_missing(void *user, const double p[3], double grad[3])
{
    (void)user;
    (void)p;
    grad[0] = grad[1] = grad[2] = NAN;
    return NAN;
}

static int finite4(const double *q)
{
    return isfinite(q[0]) && isfinite(q[1]) && isfinite(q[2]) && isfinite(q[3]);
}

static defsim_status load_collider(defsim_world *w, const chunk *c)
{
    br r = chunk_reader(c);
    defsim_collider_def d;
    defsim_collider_def_init(&d, sizeof d);
    d.shape = (defsim_shape)get_i32(&r);
    double pos1[3], rot1[4];
    get_f64s(&r, d.position, 3);
    get_f64s(&r, d.rotation, 4);
    get_f64s(&r, pos1, 3);
    get_f64s(&r, rot1, 4);
    get_f64s(&r, d.normal, 3);
    d.radius = get_f64(&r);
    get_f64s(&r, d.half_extents, 3);
    d.half_height = get_f64(&r);
    d.friction = get_f64(&r);
    get_f64s(&r, d.sdf_bounds, 6);
    const int32_t nv = get_i32(&r), nt = get_i32(&r);
    if (nv < 0 || nt < 0 || !fits(&r, nv, 24) || !fits(&r, nt, 12))
        return malformed(c, "mesh counts out of range");
    double *xv = malloc(3 * (size_t)(nv + 1) * sizeof *xv);
    int32_t *tv = malloc(3 * (size_t)(nt + 1) * sizeof *tv);
    if (!xv || !tv) {
        free(xv);
        free(tv);
        defsim__set_last_error("load: out of memory");
        return DEFSIM_ERR_OUT_OF_MEMORY;
    }
    get_f64s(&r, xv, 3 * (int64_t)nv);
    get_i32s(&r, tv, 3 * (int64_t)nt);
    defsim_status st = DEFSIM_OK;
    if (r.bad || r.at != r.n || !finite4(rot1)) {
        st = malformed(c, "wrong length or a bad pose");
    } else {
        d.vertices = xv;
        d.vertex_count = nv;
        d.triangles = tv;
        d.triangle_count = nt;
        if (d.shape == DEFSIM_SHAPE_SDF) d.sdf = sdf_missing;
        defsim_collider_id id;
        if ((st = defsim_world_add_collider(w, &d, &id)) != DEFSIM_OK) {
            st = world_failed(w, st, "collider");
        } else if ((st = defsim_collider_set_pose(w, id, pos1, rot1)) != DEFSIM_OK) {
            st = world_failed(w, st, "collider pose");
        } else {
            /* The stored bits, not their normalisation again (which may move the last bit). */
            defsim__collider *col = &w->colliders.col[defsim__world_id_slot(w, id.index)];
            memcpy(col->pos, d.position, sizeof col->pos);
            memcpy(col->rot, d.rotation, sizeof col->rot);
            memcpy(col->pos1, pos1, sizeof col->pos1);
            memcpy(col->rot1, rot1, sizeof col->rot1);
            memcpy(col->def.position, d.position, sizeof d.position);
            memcpy(col->def.rotation, d.rotation, sizeof d.rotation);
            memcpy(col->def.normal, d.normal, sizeof d.normal);
        }
    }
    free(xv);
    free(tv);
    return st;
}

static defsim_status load_pattern(defsim_world *w, const chunk *c)
{
    br r = chunk_reader(c);
    const uint32_t n = get_u32(&r);
    if (!fits(&r, n, 8)) return malformed(c, "count out of range");
    int64_t *pairs = malloc(((size_t)n + 1) * sizeof *pairs);
    if (!pairs) {
        defsim__set_last_error("load: out of memory");
        return DEFSIM_ERR_OUT_OF_MEMORY;
    }
    const int64_t nfv = w->sys.nfree_v;
    for (uint32_t k = 0; k < n && !r.bad; ++k) {
        pairs[k] = (int64_t)get_u64(&r);
        const int64_t fa = pairs[k] >> 32, fb = pairs[k] & 0xFFFFFFFF;
        if (fa < 0 || fa >= fb || fb >= nfv) r.bad = 1;
    }
    defsim_status st = DEFSIM_OK;
    int grew = 0;
    if (r.bad || r.at != r.n) st = malformed(c, "wrong length or a pair out of range");
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
    br r = chunk_reader(c);
    const int32_t changed = get_i32(&r), forces = get_i32(&r);
    if (c->len != 8 + (forces ? 24 * (size_t)w->nv : 0) || (changed != 0 && changed != 1) ||
        (forces != 0 && forces != 1))
        return malformed(c, "length does not match the vertices, or a bad flag");
    w->colliders.changed = changed;
    if (!forces) return DEFSIM_OK;
    double *f = malloc(3 * (size_t)(w->nv > 0 ? w->nv : 1) * sizeof *f);
    if (!f) {
        defsim__set_last_error("load: out of memory");
        return DEFSIM_ERR_OUT_OF_MEMORY;
    }
    get_f64s(&r, f, 3 * (int64_t)w->nv);
    free(w->colliders.force);
    w->colliders.force = f;
    w->colliders.force_nv = w->nv;
    w->colliders.force_zero = 0;
    return DEFSIM_OK;
}

/* Version 5's contact state; applied once the world is planned (planning clears the
 * frequency). */
static defsim_status load_contact_state(defsim_world *w, const chunk *c)
{
    br r = chunk_reader(c);
    const double omega = get_f64(&r);
    const int32_t has_vel = get_i32(&r);
    const int64_t ndof = 3 * (int64_t)w->nv;
    if (r.bad || !(omega >= 0.0) || !isfinite(omega) || (has_vel != 0 && has_vel != 1) ||
        (has_vel && w->nv == 0) || c->len != 12 + (has_vel ? 8 * (size_t)ndof : 0))
        return malformed(c, "wrong length, a bad flag, or a frequency that is not finite and "
                            ">= 0");
    if (has_vel) {
        double *vel = malloc((size_t)ndof * sizeof *vel);
        if (!vel) {
            defsim__set_last_error("load: out of memory");
            return DEFSIM_ERR_OUT_OF_MEMORY;
        }
        get_f64s(&r, vel, ndof);
        int finite = 1;
        for (int64_t i = 0; i < ndof; ++i) finite &= isfinite(vel[i]) != 0;
        const defsim_status st = finite ? defsim__contact_set_vel(&w->contact, w->nv, vel)
                                        : DEFSIM_ERR_IO;
        free(vel);
        if (st == DEFSIM_ERR_IO) return malformed(c, "a velocity is not finite");
        if (st != DEFSIM_OK) {
            defsim__set_last_error("load: out of memory");
            return st;
        }
    }
    w->contact.omega_elastic = omega;
    return DEFSIM_OK;
}

static defsim_status load_state(defsim_world *w, const chunk *c, uint32_t version,
                                double *h_stable, int32_t *age)
{
    br r = chunk_reader(c);
    const size_t tail = version >= 2 ? 12 : 0;
    if (get_i32(&r) != w->nv || c->len != 4 + 48 * (size_t)w->nv + 8 + 4 + tail)
        return malformed(c, "the vertex count does not match the bodies");
    const int64_t ndof = 3 * (int64_t)w->nv;
    double *x = malloc(2 * (size_t)(ndof > 0 ? ndof : 1) * sizeof *x);
    if (!x) {
        defsim__set_last_error("load: out of memory");
        return DEFSIM_ERR_OUT_OF_MEMORY;
    }
    get_f64s(&r, x, 2 * ndof);
    const double t = get_f64(&r);
    const int32_t drove = get_i32(&r);
    /* Version 1 files lack the auto_substep cache: the first step estimates it again. */
    *h_stable = version >= 2 ? get_f64(&r) : 0.0;
    *age = version >= 2 ? get_i32(&r) : 0;
    if (!(*h_stable >= 0.0) || *age < 0) {
        free(x);
        return malformed(c, "a bad stable-step cache");
    }
    for (int64_t i = 0; i < 2 * ndof; ++i)
        if (!isfinite(x[i])) {
            free(x);
            return malformed(c, "a position or velocity is not finite");
        }
    if (!isfinite(t) || (drove != 0 && drove != 1)) {
        free(x);
        return malformed(c, "time not finite, or a bad flag");
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
    br r = chunk_reader(c);
    const uint32_t n = get_u32(&r);
    defsim_stats stats = w->stats;
    const int32_t known = defsim__options_stat_count(&w->options);
    /* Statistics are matched by name: ones this library does not know are skipped, ones the
     * file lacks start at zero. */
    for (uint32_t i = 0; i < n && !r.bad; ++i) {
        char name[160];
        get_str(&r, name, sizeof name);
        const double value = get_f64(&r);
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
    if (r.bad || r.at != r.n) return malformed(c, "wrong length");
    w->stats = stats;
    return DEFSIM_OK;
}

static defsim_status load_backend(defsim_world *w, const chunk *c)
{
    br r = chunk_reader(c);
    char name[64];
    get_str(&r, name, sizeof name);
    if (r.bad) return malformed(c, "no backend name");
    const defsim_backend *be = w->backend;
    if (strcmp(name, be->name) != 0 || !be->load_state)
        return malformed(c, "history of another backend, or of one that cannot load it");
    if (w->nv == 0) return malformed(c, "history of a world without vertices");
    defsim_status st = defsim__world_plan(w);
    if (st != DEFSIM_OK) return world_failed(w, st, "planning");
    (void)defsim__options_take_reinit(&w->options);   /* the options were set before init */
    if ((st = defsim__world_backend_start(w)) != DEFSIM_OK)
        return world_failed(w, st, "backend initialisation");
    const defsim_state_reader rd = {&r, sr_f64, sr_i64, sr_remaining};
    /* A backend that replays its last step (sundials_erk) sees the colliders as that step did. */
    st = defsim__world_replay_contact_begin(w);
    if (st != DEFSIM_OK) {
        defsim__world_backend_stop(w);
        return world_failed(w, st, "contact for the backend's history");
    }
    st = be->load_state(&defsim__host, &w->handle, w->bstate, &rd);
    defsim__world_replay_contact_end(w);
    if (st == DEFSIM_OK && (r.bad || r.at != r.n)) st = DEFSIM_ERR_IO;
    if (st != DEFSIM_OK) {
        defsim__world_backend_stop(w);
        if (st == DEFSIM_ERR_IO) return malformed(c, "the backend's history does not fit");
        return world_failed(w, st, "backend history");
    }
    return DEFSIM_OK;
}

/* Builds the world from a checked chunk index; the order of chunks is the writer's. */
static defsim_status build(const ckpt *k, defsim_log_fn log, void *log_user, defsim_world **out)
{
    if (k->n < 4 || strcmp(k->c[0].tag, "WRLD") != 0 || strcmp(k->c[1].tag, "OPTS") != 0) {
        defsim__set_last_error("load: checkpoint does not begin with WRLD and OPTS chunks");
        return DEFSIM_ERR_IO;
    }
    defsim_world *w = NULL;
    defsim_status st = load_world(&k->c[0], log, log_user, &w);
    if (st != DEFSIM_OK) return st;
    id_map *map = calloc((size_t)k->n, sizeof *map);
    int32_t nmap = 0;
    const chunk *state = NULL, *stats = NULL, *backend = NULL, *contact = NULL, *pattern = NULL;
    const chunk *cstate = NULL;
    if (!map) {
        defsim__set_last_error("load: out of memory");
        st = DEFSIM_ERR_OUT_OF_MEMORY;
    }
    if (st == DEFSIM_OK) st = load_options(w, &k->c[1]);
    for (int32_t i = 2; i < k->n && st == DEFSIM_OK; ++i) {
        const chunk *c = &k->c[i];
        if (strcmp(c->tag, "BODY") == 0) {
            if (state) st = malformed(c, "after the state");
            else st = load_body(w, c, k->version, &map[nmap++]);
        } else if (strcmp(c->tag, "ATCH") == 0) {
            st = load_attachment(w, c, map, nmap);
        } else if (strcmp(c->tag, "FEXT") == 0) {
            st = load_fext(w, c);
        } else if (strcmp(c->tag, "PTGT") == 0) {
            st = load_targets(w, c);
        } else if (strcmp(c->tag, "COLL") == 0 && k->version >= 3) {
            st = load_collider(w, c);
        } else if (strcmp(c->tag, "CFRC") == 0 && k->version >= 3) {
            contact = c;
        } else if (strcmp(c->tag, "CNTC") == 0 && k->version >= 5) {
            cstate = c;
        } else if (strcmp(c->tag, "PEXT") == 0 && k->version >= 4) {
            pattern = c;
        } else if (strcmp(c->tag, "STAT") == 0) {
            state = c;
        } else if (strcmp(c->tag, "STCS") == 0) {
            stats = c;
        } else if (strcmp(c->tag, "BKND") == 0) {
            backend = c;
        } else if (strcmp(c->tag, "END ") == 0) {
            break;
        } else if (c->tag[0] >= 'A' && c->tag[0] <= 'Z') {
            /* Critical chunks (upper-case first letter) must be understood; others may be
             * skipped by readers that do not know them. */
            defsim__set_last_error("load: unknown chunk '%s'", c->tag);
            st = DEFSIM_ERR_IO;
        }
    }
    if (st == DEFSIM_OK && !state) {
        defsim__set_last_error("load: checkpoint has no STAT chunk");
        st = DEFSIM_ERR_IO;
    }
    double h_stable = 0.0;
    int32_t age = 0;
    if (st == DEFSIM_OK) st = load_state(w, state, k->version, &h_stable, &age);
    if (st == DEFSIM_OK && contact) st = load_contact_forces(w, contact);
    /* Planned now, with the options taken as the backend's initial ones, as the saved world
     * was: its first step keeps the cache. The pattern grows before the backend starts: a
     * backend borrows it at init, and growing it later would free what it holds (newmark's
     * first step read freed memory that way). */
    if (st == DEFSIM_OK && (st = defsim__world_plan(w)) != DEFSIM_OK)
        st = world_failed(w, st, "planning");
    if (st == DEFSIM_OK && pattern) st = load_pattern(w, pattern);
    if (st == DEFSIM_OK && cstate) st = load_contact_state(w, cstate);
    if (st == DEFSIM_OK && backend) st = load_backend(w, backend);
    /* Again: a replay in the backend's load evaluated friction, which keeps its velocities. */
    if (st == DEFSIM_OK && cstate) st = load_contact_state(w, cstate);
    if (st == DEFSIM_OK) {
        (void)defsim__options_take_reinit(&w->options);
        w->h_stable = h_stable;
        w->steps_since_estimate = age;
    }
    /* Statistics last: planning and the backend's load count nothing the run did. */
    if (st == DEFSIM_OK && stats) st = load_stats(w, stats);
    free(map);
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
    for (int32_t s = 0; s < w->body_ids.nslots; ++s) n += (w->body_ids.gen[s] & 1u) != 0;
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
    for (int32_t s = 0; i >= 0 && i < w->nbodies && s < w->body_ids.nslots; ++s)
        if ((w->body_ids.gen[s] & 1u) && w->body_ids.dense[s] == i) {
            *out = (defsim_body_id){defsim__world_id_index(w, s), w->body_ids.gen[s]};
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
