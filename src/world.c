/* SPDX-License-Identifier: MIT */
/*
 * Worlds, bodies, pins, state, stepping: the public API over the compiled system.
 *
 * Contents: creation; bodies; pins; state; evaluation; stability; stepping.
 */
#include "world.h"

#include "clock.h"
#include "energy.h"
#include "forces.h"
#include "mat3.h"
#include "plan.h"
#include "registry.h"
#include "terms.h"
#include "watchdog.h"

#include <math.h>
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#ifdef _OPENMP
#include <omp.h>
#endif


/* ------------------------------------------------------------------------------------------ */
/* Creation */

/* Worlds made one after another get different tags (ids of one are stale in the other) and a
 * run is reproducible: the tag is a serial number, not a random one. */
static atomic_uint world_serial;

void defsim_world_def_init(defsim_world_def *def, size_t size)
{
    if (!def || size < sizeof(uint32_t)) return;
    defsim_world_def d;
    memset(&d, 0, sizeof d);
    d.size = (uint32_t)sizeof d;
    d.backend = "symplectic_euler";
    d.gravity[1] = -9.81;
    if (size > sizeof d) size = sizeof d;
    memcpy(def, &d, size);
    def->size = (uint32_t)size;
}

static defsim_status check_world_def(const defsim_world_def *d)
{
    if (!d->backend || !d->backend[0]) {
        defsim__set_last_error("world def: backend name is NULL or empty");
        return DEFSIM_ERR_INVALID_ARGUMENT;
    }
    if (strlen(d->backend) >= 64) {
        defsim__set_last_error("world def: backend name longer than 63 characters");
        return DEFSIM_ERR_INVALID_ARGUMENT;
    }
    for (int i = 0; i < 3; ++i)
        if (!isfinite(d->gravity[i])) {
            defsim__set_last_error("world def: gravity[%d] is not finite", i);
            return DEFSIM_ERR_INVALID_ARGUMENT;
        }
    if (d->num_threads < 0) {
        defsim__set_last_error("world def: num_threads %d < 0", (int)d->num_threads);
        return DEFSIM_ERR_INVALID_ARGUMENT;
    }
    return DEFSIM_OK;
}

defsim_status defsim_world_create(const defsim_world_def *def, defsim_world **out)
{
    if (out) *out = NULL;
    if (!def || !out) {
        defsim__set_last_error("defsim_world_create: def and out must not be NULL");
        return DEFSIM_ERR_INVALID_ARGUMENT;
    }
    if (def->size < offsetof(defsim_world_def, log)) {
        defsim__set_last_error("defsim_world_create: def->size %u is too small (use "
                               "defsim_world_def_init)", (unsigned)def->size);
        return DEFSIM_ERR_INVALID_ARGUMENT;
    }
    defsim_world_def d;
    defsim_world_def_init(&d, sizeof d);
    memcpy(&d, def, def->size < sizeof d ? def->size : sizeof d);
    d.size = sizeof d;
    defsim_status st = check_world_def(&d);
    if (st != DEFSIM_OK) return st;
    const defsim_backend *b = NULL;
    st = defsim__find_backend(d.backend, &b);
    if (st != DEFSIM_OK) return st;

    defsim_world *w = calloc(1, sizeof *w);
    if (!w) {
        defsim__set_last_error("out of memory");
        return DEFSIM_ERR_OUT_OF_MEMORY;
    }
    w->msg = calloc(1, sizeof *w->msg);
    if (!w->msg) {
        free(w);
        defsim__set_last_error("out of memory");
        return DEFSIM_ERR_OUT_OF_MEMORY;
    }
    w->magic = DEFSIM__WORLD_MAGIC;
    const uint32_t tag = (uint32_t)atomic_fetch_add(&world_serial, 1u) % DEFSIM__ID_TAGS + 1u;
    w->bodies.ids.tag = w->colliders.ids.tag = w->coupling.att_ids.tag = tag;
    w->def = d;
    w->msg->log = d.log;
    w->msg->log_user = d.log_user;
    snprintf(w->backend.name, sizeof w->backend.name, "%s", d.backend);
    w->def.backend = w->backend.name;
    w->backend.table = b;
    const defsim_option_spec *term_options[DEFSIM__CORE_MAX];
    const int32_t nterm = defsim__terms_options(term_options, DEFSIM__CORE_MAX);
    st = defsim__options_init(&w->options, b, term_options, nterm);
    if (st != DEFSIM_OK) {
        free(w->msg);
        free(w);
        return st;
    }
    defsim__options_resolve(&w->options, &w->set);
    if (b->state_size > 0) {
        w->backend.state = calloc(1, b->state_size);
        if (!w->backend.state) {
            free(w->msg);
            defsim__options_free(&w->options);
            free(w);
            defsim__set_last_error("out of memory");
            return DEFSIM_ERR_OUT_OF_MEMORY;
        }
    }
#ifdef _OPENMP
    w->nthreads = d.num_threads > 0 ? d.num_threads : omp_get_max_threads();
#else
    w->nthreads = 1;
#endif
    if (w->nthreads < 1) w->nthreads = 1;
    w->stats.size = sizeof w->stats;
    w->stats.threads = w->nthreads;
    w->handle = (defsim_system){.sys = &w->sys, .work = &w->work, .state = &w->state,
                                .gravity = w->def.gravity, .stats = &w->stats, .passes = &w->step.passes,
                                .msg = w->msg, .options = &w->options, .cpl = &w->coupling.cpl};
    _Static_assert((int)DEFSIM__CSTAT_COUNT == (int)DEFSIM__CONTACT_STATS,
                   "contact.h's statistics and options.c's names must agree");
    w->options.contact_stats = w->contact.stat;
    *out = w;
    return DEFSIM_OK;
}

static void backend_fini(defsim_world *w)
{
    if (w->backend.ready) {
        w->backend.table->fini(&defsim__host, &w->handle, w->backend.state);
        w->backend.ready = 0;
    }
    if (w->backend.state) memset(w->backend.state, 0, w->backend.table->state_size);
}

defsim_status defsim__world_backend_start(defsim_world *w)
{
    defsim_status st = w->backend.table->init(&defsim__host, &w->handle, w->backend.state);
    if (st != DEFSIM_OK) {
        w->backend.table->fini(&defsim__host, &w->handle, w->backend.state);
        if (w->backend.state) memset(w->backend.state, 0, w->backend.table->state_size);
        if (!w->msg->error[0])
            defsim__error(w->msg, "backend %s failed to initialise", w->backend.table->name);
        return st;
    }
    w->backend.ready = 1;
    return DEFSIM_OK;
}

void defsim__world_backend_stop(defsim_world *w) { backend_fini(w); }

defsim_status defsim__world_backend_prepare(defsim_world *w)
{
    if (defsim__options_take_reinit(&w->options)) {   /* an option changed */
        backend_fini(w);
        w->step.h_stable = 0.0;   /* the stability limit may depend on it */
    }
    return w->backend.ready ? DEFSIM_OK : defsim__world_backend_start(w);
}

void defsim__world_unplan(defsim_world *w)
{
    defsim__unplan(&w->sys, &w->work);
    defsim__body_contact_unplan(&w->body_contact);
    w->planned = 0;
    defsim__watchdog_forget(&w->wd, 1);
}

void defsim__world_invalidate(defsim_world *w)
{
    backend_fini(w);
    defsim__world_unplan(w);
}

defsim_status defsim__world_check_unlocked(defsim_world *w)
{
    if (!w->msg->locked) return DEFSIM_OK;
    defsim__error(w->msg, "the world cannot be changed from inside a host callback (log, force "
                          "callback or its Jacobian)");
    return DEFSIM_ERR_LOCKED;
}

int defsim__world_live(const defsim_world *w)
{
    if (w && w->magic == DEFSIM__WORLD_MAGIC) return 1;
    defsim__set_last_error("%s", !w ? "the world is NULL"
                                 : w->magic == DEFSIM__WORLD_DEAD
                                     ? "the world was destroyed"
                                     : "not a world made by defsim_world_create");
    return 0;
}

defsim_status defsim__world_enter(defsim_world *w)
{
    if (!defsim__world_live(w)) return DEFSIM_ERR_INVALID_ARGUMENT;
    return defsim__world_check_unlocked(w);
}

int64_t defsim__world_id_slot(const defsim_world *w, uint32_t index)
{
    return defsim__id_pool_slot(&w->bodies.ids, index);
}

uint32_t defsim__world_id_index(const defsim_world *w, int32_t slot)
{
    return defsim__id_pool_index(&w->bodies.ids, slot);
}

const char *defsim__world_id_problem(const defsim_world *w, uint32_t index, uint32_t generation)
{
    return defsim__id_pool_problem(&w->bodies.ids, index, generation);
}

defsim_status defsim__world_plan(defsim_world *w)
{
    if (w->planned) return DEFSIM_OK;
    w->step.h_stable = 0.0;
    const defsim__plan_input in = {
        .bodies = w->bodies.b, .nbodies = w->bodies.n, .nv = w->nv, .mass = w->bodies.mass,
        .pinned = w->bodies.pinned, .gravity = w->def.gravity,
        .projection = w->set.projection, .tet_kernels = w->set.tet_kernels,
        .nthreads = w->nthreads,
        .need_matrix = (w->backend.table->flags & DEFSIM_BACKEND_NEEDS_MATRIX) != 0,
        .attachments = w->coupling.att, .nattachments = w->coupling.natt,
        .body_dense = w->bodies.ids.dense};
    defsim_status st = defsim__plan(&w->sys, &w->work, &in);
    if (st == DEFSIM_OK && (st = defsim__coupling_reserve(&w->coupling, w->nv, w->sys.has_pins)) != DEFSIM_OK)
        defsim__unplan(&w->sys, &w->work);
    if (st != DEFSIM_OK) {
        defsim__error(w->msg, "out of memory while planning the world");
        return st;
    }
    w->sys.fext = w->coupling.fext_nonzero ? w->coupling.fext : NULL;
    w->sys.host = &w->handle;
    if ((st = defsim__terms_compile(&w->sys)) != DEFSIM_OK) {
        defsim__unplan(&w->sys, &w->work);
        defsim__error(w->msg, "out of memory while planning the world");
        return st;
    }
    w->contact.omega_elastic = 0.0;
    w->contact.surf_planned = 0;
    w->planned = 1;
    w->plan_serial++;
    return DEFSIM_OK;
}

void defsim_world_destroy(defsim_world *w)
{
    if (!w || !defsim__world_live(w)) return;
    if (defsim__world_check_unlocked(w) != DEFSIM_OK) return;   /* the caller is inside it */
    if (w->tape) w->tape->world = NULL;
    backend_fini(w);
    defsim__world_unplan(w);
    defsim__watchdog_free(&w->wd);
    for (int32_t i = 0; i < w->bodies.n; ++i) defsim__body_free(&w->bodies.b[i]);
    free(w->bodies.b);
    defsim__id_pool_free(&w->bodies.ids);
    free(w->state.x); free(w->state.v); free(w->bodies.mass); free(w->bodies.pinned);
    free(w->step.x_save); free(w->step.v_save);
    free(w->backend.state);
    defsim__coupling_free(&w->coupling);
    defsim__collider_set_free(&w->colliders);
    defsim__contact_free(&w->contact);
    defsim__body_contact_free(&w->body_contact);
    free(w->msg);
    defsim__options_free(&w->options);
    w->magic = DEFSIM__WORLD_DEAD;
    free(w);
}

const char *defsim_world_last_error(const defsim_world *w)
{
    if (!w) return "";
    return defsim__world_live(w) ? w->msg->error : defsim_last_error();
}

/* ------------------------------------------------------------------------------------------ */
/* Bodies */

/* Rebuilds the per-vertex world arrays from the live bodies, carrying their state over. On
 * failure nothing changes. `old_offset[b]` is body b's offset before the change (-1: new). */
static defsim_status rebuild_vertices(defsim_world *w, const int32_t *old_offset,
                                      const double *new_x, const double *new_v)
{
    int32_t nv = 0;
    for (int32_t b = 0; b < w->bodies.n; ++b)
        if (w->bodies.b[b].generation & 1u) nv += w->bodies.b[b].nv;
    size_t n = (size_t)(nv > 0 ? nv : 1);
    double *x = malloc(3 * n * sizeof *x), *v = malloc(3 * n * sizeof *v);
    double *xs = malloc(3 * n * sizeof *xs), *vs = malloc(3 * n * sizeof *vs);
    double *mass = malloc(n * sizeof *mass);
    uint8_t *pinned = malloc(n);
    /* the host's per-vertex coupling data, where it has some: new bodies get none */
    double *fext = w->coupling.fext ? calloc(3 * n, sizeof *fext) : NULL;
    double *target = w->coupling.pin_target ? malloc(3 * n * sizeof *target) : NULL;
    uint8_t *targeted = w->coupling.pin_target ? calloc(n, 1) : NULL;
    if (!x || !v || !xs || !vs || !mass || !pinned || (w->coupling.fext && !fext) ||
        (w->coupling.pin_target && (!target || !targeted))) {
        free(x); free(v); free(xs); free(vs); free(mass); free(pinned);
        free(fext); free(target); free(targeted);
        return DEFSIM_ERR_OUT_OF_MEMORY;
    }
    int32_t ntargeted = 0;
    int32_t off = 0;
    for (int32_t b = 0; b < w->bodies.n; ++b) {
        defsim__body *bd = &w->bodies.b[b];
        if (!(bd->generation & 1u)) continue;
        size_t bytes = 3 * (size_t)bd->nv * sizeof(double);
        if (old_offset[b] >= 0) {
            memcpy(x + 3 * (int64_t)off, w->state.x + 3 * (int64_t)old_offset[b], bytes);
            memcpy(v + 3 * (int64_t)off, w->state.v + 3 * (int64_t)old_offset[b], bytes);
            if (fext) memcpy(fext + 3 * (int64_t)off, w->coupling.fext + 3 * (int64_t)old_offset[b], bytes);
            if (target) {
                memcpy(target + 3 * (int64_t)off, w->coupling.pin_target + 3 * (int64_t)old_offset[b],
                       bytes);
                memcpy(targeted + off, w->coupling.targeted + old_offset[b], (size_t)bd->nv);
                for (int32_t i = 0; i < bd->nv; ++i) ntargeted += targeted[off + i];
            }
        } else {
            memcpy(x + 3 * (int64_t)off, new_x, bytes);
            if (new_v) memcpy(v + 3 * (int64_t)off, new_v, bytes);
            else memset(v + 3 * (int64_t)off, 0, bytes);
        }
        memcpy(mass + off, bd->mass, (size_t)bd->nv * sizeof *mass);
        memcpy(pinned + off, bd->pinned, (size_t)bd->nv);
        bd->offset = off;
        off += bd->nv;
    }
    free(w->state.x); free(w->state.v); free(w->step.x_save); free(w->step.v_save);
    free(w->bodies.mass); free(w->bodies.pinned);
    /* Until a step saves its start, the start is now (held forces' energy is relative to it;
     * uninitialised, it made that energy depend on what malloc returned). */
    memcpy(xs, x, 3 * n * sizeof *xs);
    w->state.x = x; w->state.v = v; w->step.x_save = xs; w->step.v_save = vs;
    w->handle.x_start = xs;
    w->bodies.mass = mass; w->bodies.pinned = pinned;
    free(w->coupling.fext); free(w->coupling.pin_target); free(w->coupling.targeted);
    w->coupling.fext = fext; w->coupling.pin_target = target; w->coupling.targeted = targeted;
    w->coupling.ntargeted = ntargeted;
    if (fext) {
        int nonzero = 0;
        for (int64_t i = 0; i < 3 * (int64_t)nv; ++i) nonzero |= fext[i] != 0.0;
        w->coupling.fext_nonzero = nonzero;
    }
    w->nv = nv;
    backend_fini(w);
    defsim__world_unplan(w);
    return DEFSIM_OK;
}

defsim_status defsim_world_add_body(defsim_world *w, const defsim_body_def *def,
                                    defsim_body_id *out)
{
    defsim_status st = defsim__world_enter(w);
    if (st != DEFSIM_OK) return st;
    defsim_body_def d;
    defsim__body b;
    int32_t reordered = 0;
    st = defsim__body_build(w->msg, def, w->nv, &d, &b, &reordered);
    if (st != DEFSIM_OK) return st;
    if (b.strain_limit > 0.0 && !(w->backend.table->flags & DEFSIM_BACKEND_CONTACT_CCD)) {
        defsim__error(w->msg, "add_body: shell_strain_limit needs a backend whose line search "
                              "filters its steps (DEFSIM_BACKEND_CONTACT_CCD: newton_cholmod, "
                              "bdf2, newmark); %s has none", w->backend.table->name);
        defsim__body_free(&b);
        return DEFSIM_ERR_BACKEND_UNAVAILABLE;
    }

    /* The id takes the first free slot (its generation makes the ids of its earlier bodies
     * stale); the vertices still follow those of the bodies added before. */
    int32_t slot;
    if ((st = defsim__id_pool_reserve(&w->bodies.ids, w->msg, "bodies", &slot)) != DEFSIM_OK)
        goto fail;
    st = DEFSIM_ERR_OUT_OF_MEMORY;
    if (w->bodies.n == w->bodies.cap) {
        int32_t cap = w->bodies.cap ? 2 * w->bodies.cap : 8;
        defsim__body *nb = realloc(w->bodies.b, (size_t)cap * sizeof *nb);
        if (!nb) { defsim__error(w->msg, "out of memory"); goto fail; }
        w->bodies.b = nb;
        w->bodies.cap = cap;
    }
    int32_t *old = malloc(((size_t)w->bodies.n + 1) * sizeof *old);
    if (!old) { defsim__error(w->msg, "out of memory"); goto fail; }
    for (int32_t i = 0; i < w->bodies.n; ++i) old[i] = w->bodies.b[i].offset;
    old[w->bodies.n] = -1;
    b.generation = (slot < w->bodies.ids.nslots ? w->bodies.ids.gen[slot] : 0u) + 1u;
    w->bodies.b[w->bodies.n++] = b;
    st = rebuild_vertices(w, old, d.initial_positions ? d.initial_positions : d.rest_positions,
                          d.initial_velocities);
    free(old);
    if (st != DEFSIM_OK) {
        w->bodies.n--;
        defsim__error(w->msg, "out of memory");
        goto fail;
    }
    defsim__id_pool_take(&w->bodies.ids, slot, w->bodies.n - 1);
    w->stats.reordered_tets += reordered;
    if (out) {
        out->index = defsim__world_id_index(w, slot);
        out->generation = b.generation;
    }
    return DEFSIM_OK;
fail:
    defsim__body_free(&b);
    return st;
}

defsim__body *defsim__world_find_body(const defsim_world *w, defsim_body_id id)
{
    const int64_t slot = defsim__id_pool_find(&w->bodies.ids, id.index, id.generation);
    return slot < 0 ? NULL : &w->bodies.b[w->bodies.ids.dense[slot]];
}

defsim__body *defsim__world_body(const defsim_world *w, defsim_body_id id)
{
    const int64_t slot =
        defsim__id_pool_lookup(&w->bodies.ids, w->msg, "body", id.index, id.generation);
    return slot < 0 ? NULL : &w->bodies.b[w->bodies.ids.dense[slot]];
}

defsim_status defsim_world_remove_body(defsim_world *w, defsim_body_id id)
{
    defsim_status st = defsim__world_enter(w);
    if (st != DEFSIM_OK) return st;
    defsim__body *b = defsim__world_body(w, id);
    if (!b) return DEFSIM_ERR_STALE_ID;
    int32_t *old = malloc(((size_t)w->bodies.n + 1) * sizeof *old);
    if (!old) { defsim__error(w->msg, "out of memory"); return DEFSIM_ERR_OUT_OF_MEMORY; }
    for (int32_t i = 0; i < w->bodies.n; ++i) old[i] = w->bodies.b[i].offset;
    b->generation++;
    st = rebuild_vertices(w, old, NULL, NULL);
    free(old);
    if (st != DEFSIM_OK) {
        b->generation--;
        defsim__error(w->msg, "out of memory");
        return st;
    }
    defsim__coupling_drop_body(&w->coupling, id);
    defsim__body_free(b);
    /* Close the gap in the dense array; the slot is free for the next body. */
    const int64_t slot = DEFSIM__ID_SLOT(id.index);
    const int32_t dense = w->bodies.ids.dense[slot];
    memmove(w->bodies.b + dense, w->bodies.b + dense + 1,
            (size_t)(w->bodies.n - dense - 1) * sizeof *w->bodies.b);
    w->bodies.n--;
    for (int32_t i = 0; i < w->bodies.ids.nslots; ++i)
        if (w->bodies.ids.dense[i] > dense) w->bodies.ids.dense[i]--;
    defsim__id_pool_release(&w->bodies.ids, (int32_t)slot);
    return DEFSIM_OK;
}

int32_t defsim_body_vertex_count(const defsim_world *w, defsim_body_id id)
{
    if (!defsim__world_live(w)) return DEFSIM_ERR_INVALID_ARGUMENT;
    const defsim__body *b = defsim__world_body(w, id);
    return b ? b->nv : DEFSIM_ERR_STALE_ID;
}

int32_t defsim_body_vertex_offset(const defsim_world *w, defsim_body_id id)
{
    if (!defsim__world_live(w)) return DEFSIM_ERR_INVALID_ARGUMENT;
    const defsim__body *b = defsim__world_body(w, id);
    return b ? b->offset : DEFSIM_ERR_STALE_ID;
}

static defsim_status set_pins(defsim_world *w, defsim_body_id id, const int32_t *verts,
                              int32_t n, uint8_t value)
{
    defsim_status st = defsim__world_enter(w);
    if (st != DEFSIM_OK) return st;
    defsim__body *b = defsim__world_body(w, id);
    if (!b) return DEFSIM_ERR_STALE_ID;
    if (n < 0 || (n > 0 && !verts)) {
        defsim__error(w->msg, "pin: n %d < 0 or verts NULL", (int)n);
        return DEFSIM_ERR_INVALID_ARGUMENT;
    }
    for (int32_t i = 0; i < n; ++i)
        if (verts[i] < 0 || verts[i] >= b->nv) {
            defsim__error(w->msg, "pin: vertex %d (entry %d) out of range [0, %d)",
                                (int)verts[i], (int)i, (int)b->nv);
            return DEFSIM_ERR_INVALID_ARGUMENT;
        }
    int changed = 0;
    for (int32_t i = 0; i < n; ++i) {
        const int32_t v = verts[i];
        if (b->pinned[v] != value) changed = 1;
        b->pinned[v] = value;
        w->bodies.pinned[b->offset + v] = value;
        if (!value && w->coupling.targeted && w->coupling.targeted[b->offset + v]) {
            w->coupling.targeted[b->offset + v] = 0;   /* unpinning drops the target */
            w->coupling.ntargeted--;
        }
        if (value) {
            double *vv = w->state.v + 3 * ((int64_t)b->offset + v);
            vv[0] = vv[1] = vv[2] = 0.0;
        }
    }
    if (changed) {
        backend_fini(w);
        defsim__world_unplan(w);
    }
    return DEFSIM_OK;
}

defsim_status defsim_body_pin(defsim_world *w, defsim_body_id id, const int32_t *verts, int32_t n)
{
    return set_pins(w, id, verts, n, 1);
}

defsim_status defsim_body_unpin(defsim_world *w, defsim_body_id id, const int32_t *verts,
                                int32_t n)
{
    return set_pins(w, id, verts, n, 0);
}

defsim_status defsim_body_set_collision(defsim_world *w, defsim_body_id id, int32_t self_contact,
                                        uint32_t group, uint32_t mask)
{
    defsim_status st = defsim__world_enter(w);
    if (st != DEFSIM_OK) return st;
    defsim__body *b = defsim__world_body(w, id);
    if (!b) return DEFSIM_ERR_STALE_ID;
    if (self_contact != 0 && self_contact != 1) {
        defsim__error(w->msg, "body_set_collision: self_contact %d must be 0 or 1",
                      (int)self_contact);
        return DEFSIM_ERR_INVALID_ARGUMENT;
    }
    /* Body contact reads the filter at each step's start: no re-plan; pairs it let in may
     * cross already. */
    if (b->self_contact != self_contact || b->group != group || b->mask != mask)
        w->body_contact.fresh = 1;
    b->self_contact = self_contact;
    b->group = group;
    b->mask = mask;
    return DEFSIM_OK;
}

/* ------------------------------------------------------------------------------------------ */
/* State */

int32_t defsim_world_vertex_count(const defsim_world *w)
{
    return defsim__world_live(w) ? w->nv : 0;
}

double defsim_world_time(const defsim_world *w)
{
    return defsim__world_live(w) ? w->state.t : 0.0;
}

/* which: 0 positions, 1 velocities, 2 masses */
static defsim_status copy_out(const defsim_world *w, int which, double *out, int32_t n)
{
    if (!defsim__world_live(w)) return DEFSIM_ERR_INVALID_ARGUMENT;
    const double *src = which == 0 ? w->state.x : which == 1 ? w->state.v : w->bodies.mass;
    const int width = which == 2 ? 1 : 3;
    if (!out) {
        defsim__error(w->msg, "the output array is NULL");
        return DEFSIM_ERR_INVALID_ARGUMENT;
    }
    if (n != w->nv) {
        defsim__error(w->msg, "n = %d but the world has %d vertices", (int)n,
                      (int)w->nv);
        return DEFSIM_ERR_INVALID_ARGUMENT;
    }
    if (n > 0) memcpy(out, src, (size_t)width * (size_t)n * sizeof *out);
    return DEFSIM_OK;
}

defsim_status defsim_world_get_positions(const defsim_world *w, double *out, int32_t n)
{
    return copy_out(w, 0, out, n);
}

defsim_status defsim_world_get_velocities(const defsim_world *w, double *out, int32_t n)
{
    return copy_out(w, 1, out, n);
}

defsim_status defsim_world_state_view(const defsim_world *w, const double **x, const double **v,
                                      int32_t *n)
{
    const int live = defsim__world_live(w);
    const int some = live && w->nv > 0;
    if (x) *x = some ? w->state.x : NULL;
    if (v) *v = some ? w->state.v : NULL;
    if (n) *n = live ? w->nv : 0;
    return live ? DEFSIM_OK : DEFSIM_ERR_INVALID_ARGUMENT;
}

defsim_status defsim_world_get_masses(const defsim_world *w, double *out, int32_t n)
{
    return copy_out(w, 2, out, n);
}

defsim_status defsim_world_get_pinned(const defsim_world *w, uint8_t *out, int32_t n)
{
    if (!defsim__world_live(w)) return DEFSIM_ERR_INVALID_ARGUMENT;
    if (!out || n != w->nv) {
        defsim__error(w->msg, "get_pinned: %s", !out ? "out is NULL" : "n is not the vertex count");
        return DEFSIM_ERR_INVALID_ARGUMENT;
    }
    if (n > 0) memcpy(out, w->bodies.pinned, (size_t)n);
    return DEFSIM_OK;
}

defsim_status defsim_world_set_state(defsim_world *w, const double *x, const double *v)
{
    const defsim_status entered = defsim__world_enter(w);
    if (entered != DEFSIM_OK) return entered;
    const int64_t ndof = 3 * (int64_t)w->nv;
    for (int64_t i = 0; i < ndof; ++i)
        if ((x && !isfinite(x[i])) || (v && !isfinite(v[i]))) {
            defsim__error(w->msg, "set_state: DOF %lld is not finite", (long long)i);
            return DEFSIM_ERR_INVALID_ARGUMENT;
        }
    /* The same bits again (a get_state/set_state round trip, or NULL, NULL) change nothing:
     * backends keep their history, so the run continues bit for bit. */
    const size_t bytes = (size_t)ndof * sizeof(double);
    if (ndof == 0 || ((!x || memcmp(x, w->state.x, bytes) == 0) &&
                      (!v || memcmp(v, w->state.v, bytes) == 0)))
        return DEFSIM_OK;
    if (x) memcpy(w->state.x, x, bytes);
    if (v) memcpy(w->state.v, v, bytes);
    w->step.h_stable = 0.0;
    defsim__watchdog_forget(&w->wd, 0);
    w->body_contact.fresh = 1;   /* the host's state may have crossing surfaces */
    for (int32_t i = 0; i < w->nv; ++i)
        if (w->bodies.pinned[i]) w->state.v[3 * (int64_t)i] = w->state.v[3 * (int64_t)i + 1] = w->state.v[3 * (int64_t)i + 2] = 0.0;
    if (w->backend.ready && w->backend.table->reset) {
        defsim_status st = w->backend.table->reset(&defsim__host, &w->handle, w->backend.state);
        if (st != DEFSIM_OK) backend_fini(w);   /* re-initialised at the next step */
    }
    return DEFSIM_OK;
}

/* ------------------------------------------------------------------------------------------ */
/* Evaluation */

defsim_status defsim_world_energy(const defsim_world *w, defsim_energy *out)
{
    if (!defsim__world_live(w)) return DEFSIM_ERR_INVALID_ARGUMENT;
    if (!out) {
        defsim__error(w->msg, "energy: out is NULL");
        return DEFSIM_ERR_INVALID_ARGUMENT;
    }
    /* A world not planned yet is compiled into a temporary system: this call changes nothing. */
    defsim__system tmp;
    defsim__work tmpw, work = w->work;
    const defsim__system *s = &w->sys;
    if (!w->planned) {
        memset(&tmp, 0, sizeof tmp);
        memset(&tmpw, 0, sizeof tmpw);
        const defsim__plan_input in = {
            .bodies = w->bodies.b, .nbodies = w->bodies.n, .nv = w->nv, .mass = w->bodies.mass,
            .pinned = w->bodies.pinned, .gravity = w->def.gravity, .nthreads = w->nthreads,
            .attachments = w->coupling.att, .nattachments = w->coupling.natt,
            .body_dense = w->bodies.ids.dense};
        if (defsim__plan(&tmp, &tmpw, &in) != DEFSIM_OK) {
            defsim__error(w->msg, "out of memory while planning the world");
            return DEFSIM_ERR_OUT_OF_MEMORY;
        }
        s = &tmp;
        work = tmpw;
    }
    double ke = 0.0, ge = 0.0;
    const double *g = w->def.gravity;
    for (int32_t i = 0; i < w->nv; ++i) {
        const double *v = w->state.v + 3 * (int64_t)i, *x = w->state.x + 3 * (int64_t)i;
        ke += 0.5 * w->bodies.mass[i] * (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
        ge -= w->bodies.mass[i] * (g[0] * x[0] + g[1] * x[1] + g[2] * x[2]);
        if (w->coupling.fext_nonzero) {
            const double *f = w->coupling.fext + 3 * (int64_t)i;
            ge -= f[0] * x[0] + f[1] * x[1] + f[2] * x[2];
        }
    }
    out->kinetic = ke;
    out->elastic = defsim__elastic_energy(s, &work, w->state.x);
    out->gravitational = ge;
    out->total = ke + out->elastic + ge;
    if (!w->planned) defsim__unplan(&tmp, &tmpw);
    if (isfinite(out->total)) return DEFSIM_OK;
    defsim__error(w->msg, "energy: not finite (elastic %g J, kinetic %g J): an inverted neo-Hookean "
                  "element has no energy, or the state overflowed", out->elastic, ke);
    return DEFSIM_ERR_UNSTABLE;
}

defsim_status defsim_world_forces(defsim_world *w, const double *x, double *f_out)
{
    defsim_status st = defsim__world_enter(w);
    if (st != DEFSIM_OK) return st;
    if (!f_out) {
        defsim__error(w->msg, "forces: f_out is NULL");
        return DEFSIM_ERR_INVALID_ARGUMENT;
    }
    st = defsim__world_plan(w);
    if (st != DEFSIM_OK) return st;
    if (x)
        for (int64_t i = 0; i < 3 * (int64_t)w->nv; ++i)
            if (!isfinite(x[i])) {
                defsim__error(w->msg, "forces: x[%lld] = %g is not finite", (long long)i, x[i]);
                return DEFSIM_ERR_INVALID_ARGUMENT;
            }
    const double t0 = defsim__now();
    st = defsim__forces(&w->sys, x ? x : w->state.x, NULL,
                        DEFSIM_FORCE_ELASTIC | DEFSIM__FORCE_KEEP_PINNED, f_out, NULL);
    w->stats.force_evals++;
    w->stats.time_forces += defsim__now() - t0;
    if (st != DEFSIM_OK)
        defsim__error(w->msg, "forces: the elastic forces at these positions are not finite (an "
                      "inverted neo-Hookean element, or an overflow); f_out holds them as computed");
    return st;
}

/* The statistics with the watchdog's diagnostics of the current state filled in. */
static defsim_stats stats_now(const defsim_world *w)
{
    defsim_stats s = w->stats;
    s.min_volume_ratio = NAN;
    s.inverted_elements = 0;
    s.energy_drift = NAN;
    if (w->planned) {
        defsim__work work = w->work;   /* scratch only: the call changes nothing */
        defsim__watchdog_diagnostics(&w->wd, &w->sys, &work, w->state.x, w->state.v, &s);
    }
    return s;
}

defsim_status defsim_world_stats(const defsim_world *w, defsim_stats *out)
{
    if (!defsim__world_live(w)) return DEFSIM_ERR_INVALID_ARGUMENT;
    if (!out || out->size < sizeof(uint32_t)) {
        defsim__error(w->msg, "stats: out is NULL or out->size is 0");
        return DEFSIM_ERR_INVALID_ARGUMENT;
    }
    size_t n = out->size < sizeof w->stats ? out->size : sizeof w->stats;
    uint32_t size = out->size;
    const defsim_stats now = stats_now(w);
    memcpy(out, &now, n);
    out->size = size;
    return DEFSIM_OK;
}

void defsim_world_reset_stats(defsim_world *w)
{
    if (defsim__world_enter(w) != DEFSIM_OK) return;
    defsim_stats s;
    memset(&s, 0, sizeof s);
    s.size = sizeof s;
    s.passes = w->stats.passes;
    s.threads = w->stats.threads;
    s.reordered_tets = w->stats.reordered_tets;
    w->stats = s;
    defsim__options_reset_counters(&w->options);
    defsim__terms_reset_counters(&w->sys);
    memset(w->contact.stat, 0, sizeof w->contact.stat);
}

/* ------------------------------------------------------------------------------------------ */
/* Options and statistics by name (options.c does the work). */

/* The options resolve into the settings when they change; those the compiled system holds
 * take effect without a re-plan. */
static defsim_status options_changed(defsim_world *w, defsim_status st)
{
    if (st != DEFSIM_OK) return st;
    defsim__options_resolve(&w->options, &w->set);
    if (w->planned) {
        w->sys.tet_kernels = w->set.tet_kernels;
        w->sys.projection = w->set.projection;
    }
    return st;
}

defsim_status defsim_world_set_option(defsim_world *w, const char *name, const char *value)
{
    const defsim_status st = defsim__world_enter(w);
    if (st != DEFSIM_OK) return st;
    return options_changed(w, defsim__options_set_text(&w->options, w->msg, name, value));
}

defsim_status defsim_world_set_option_number(defsim_world *w, const char *name, double value)
{
    const defsim_status st = defsim__world_enter(w);
    if (st != DEFSIM_OK) return st;
    return options_changed(w, defsim__options_set_number(&w->options, w->msg, name, value));
}

defsim_status defsim_world_get_option(const defsim_world *w, const char *name, double *value)
{
    return defsim__world_live(w) ? defsim__options_get(&w->options, w->msg, name, value)
                                 : DEFSIM_ERR_INVALID_ARGUMENT;
}

int32_t defsim_world_option_count(const defsim_world *w)
{
    return defsim__world_live(w) ? defsim__options_count(&w->options) : 0;
}

defsim_status defsim_world_option_info(const defsim_world *w, int32_t i, defsim_option_info *out)
{
    return defsim__world_live(w) ? defsim__options_info(&w->options, i, out)
                                 : DEFSIM_ERR_INVALID_ARGUMENT;
}

/* The statistics by name: options.c's (the fields of defsim_stats, the backend's counters,
 * contact's), then the term kinds' counters (terms.c). */
int32_t defsim_world_stat_count(const defsim_world *w)
{
    return defsim__world_live(w)
               ? defsim__options_stat_count(&w->options) + defsim__terms_counter_count()
               : 0;
}

defsim_status defsim_world_stat_info(const defsim_world *w, int32_t i, const char **name,
                                     double *value)
{
    if (!defsim__world_live(w)) return DEFSIM_ERR_INVALID_ARGUMENT;
    const int32_t nopt = defsim__options_stat_count(&w->options);
    if (i >= nopt)
        return defsim__terms_counter(&w->sys, i - nopt, name, value) ? DEFSIM_OK
                                                                     : DEFSIM_ERR_INVALID_ARGUMENT;
    const char *n = NULL;
    defsim_status st = defsim__options_stat_info(&w->options, &w->stats, i, &n, NULL);
    if (st != DEFSIM_OK || !value || !defsim__watchdog_is_diagnostic(n))
        return defsim__options_stat_info(&w->options, &w->stats, i, name, value);
    const defsim_stats now = stats_now(w);
    return defsim__options_stat_info(&w->options, &now, i, name, value);
}

defsim_status defsim_world_stat(const defsim_world *w, const char *name, double *value)
{
    if (!defsim__world_live(w)) return DEFSIM_ERR_INVALID_ARGUMENT;
    const char *n;
    for (int32_t i = 0; name && value && defsim__terms_counter(&w->sys, i, &n, NULL); ++i)
        if (!strcmp(n, name)) {
            defsim__terms_counter(&w->sys, i, NULL, value);
            return DEFSIM_OK;
        }
    if (!name || !defsim__watchdog_is_diagnostic(name))
        return defsim__options_stat(&w->options, w->msg, &w->stats, name, value);
    const defsim_stats now = stats_now(w);
    return defsim__options_stat(&w->options, w->msg, &now, name, value);
}

defsim_status defsim_world_set_log(defsim_world *w, defsim_log_fn fn, void *user)
{
    const defsim_status st = defsim__world_enter(w);
    if (st != DEFSIM_OK) return st;
    w->msg->log = w->def.log = fn;
    w->msg->log_user = w->def.log_user = user;
    return DEFSIM_OK;
}
