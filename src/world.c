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
#include "material.h"
#include "plan.h"
#include "registry.h"
#include "stability.h"
#include "terms.h"
#include "tet_rest.h"
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
    d.tolerance = 1e-6;
    d.max_iterations = 50;
    d.rtol = 1e-4;
    d.atol = 1e-6;
    d.projection = DEFSIM_PROJECTION_CLAMP;
    d.max_order = 5;
    d.max_internal_steps = 100000;
    d.substep_safety = 0.8;
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
    if (!(d->tolerance > 0.0) || !isfinite(d->tolerance) || d->max_iterations < 1) {
        defsim__set_last_error("world def: tolerance %g must be > 0 and max_iterations %d >= 1",
                               d->tolerance, (int)d->max_iterations);
        return DEFSIM_ERR_INVALID_ARGUMENT;
    }
    if (!(d->rtol > 0.0) || !(d->atol > 0.0) || !isfinite(d->rtol) || !isfinite(d->atol)) {
        defsim__set_last_error("world def: rtol %g and atol %g must be finite and > 0", d->rtol,
                               d->atol);
        return DEFSIM_ERR_INVALID_ARGUMENT;
    }
    if ((int)d->projection < 0 || (int)d->projection > 2) {
        defsim__set_last_error("world def: unknown projection %d", (int)d->projection);
        return DEFSIM_ERR_INVALID_ARGUMENT;
    }
    if (d->auto_substep != 0 && d->auto_substep != 1) {
        defsim__set_last_error("world def: auto_substep %d must be 0 or 1", (int)d->auto_substep);
        return DEFSIM_ERR_INVALID_ARGUMENT;
    }
    if (!(d->substep_safety > 0.0 && d->substep_safety <= 1.0)) {
        defsim__set_last_error("world def: substep_safety %g must be in (0, 1]", d->substep_safety);
        return DEFSIM_ERR_INVALID_ARGUMENT;
    }
    if (d->max_order < 1 || d->max_order > 5 || d->max_internal_steps < 1) {
        defsim__set_last_error("world def: max_order %d must be in 1..5, max_internal_steps %d >= 1",
                               (int)d->max_order, (int)d->max_internal_steps);
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
    w->id_tag = (uint32_t)atomic_fetch_add(&world_serial, 1u) % DEFSIM__ID_TAGS + 1u;
    w->def = d;
    w->msg->log = d.log;
    w->msg->log_user = d.log_user;
    snprintf(w->backend_name, sizeof w->backend_name, "%s", d.backend);
    w->def.backend = w->backend_name;
    w->backend = b;
    st = defsim__options_init(&w->options, b, &d);
    if (st != DEFSIM_OK) {
        free(w->msg);
        free(w);
        return st;
    }
    if (b->state_size > 0) {
        w->bstate = calloc(1, b->state_size);
        if (!w->bstate) {
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
                                .def = &w->def, .stats = &w->stats, .passes = &w->step_passes,
                                .msg = w->msg, .options = &w->options, .cpl = &w->cpl};
    _Static_assert((int)DEFSIM__CSTAT_COUNT == (int)DEFSIM__CONTACT_STATS,
                   "contact.h's statistics and options.c's names must agree");
    w->options.contact_stats = w->contact.stat;
    *out = w;
    return DEFSIM_OK;
}

static void backend_fini(defsim_world *w)
{
    if (w->backend_ready) {
        w->backend->fini(&defsim__host, &w->handle, w->bstate);
        w->backend_ready = 0;
    }
    if (w->bstate) memset(w->bstate, 0, w->backend->state_size);
}

defsim_status defsim__world_backend_start(defsim_world *w)
{
    defsim_status st = w->backend->init(&defsim__host, &w->handle, w->bstate);
    if (st != DEFSIM_OK) {
        w->backend->fini(&defsim__host, &w->handle, w->bstate);
        if (w->bstate) memset(w->bstate, 0, w->backend->state_size);
        if (!w->msg->error[0]) defsim__error(w->msg, "backend %s failed to initialise", w->backend->name);
        return st;
    }
    w->backend_ready = 1;
    return DEFSIM_OK;
}

void defsim__world_backend_stop(defsim_world *w) { backend_fini(w); }

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
    if ((index >> DEFSIM__ID_SLOT_BITS) != w->id_tag) return -1;
    return DEFSIM__ID_SLOT(index);
}

uint32_t defsim__world_id_index(const defsim_world *w, int32_t slot)
{
    return w->id_tag << DEFSIM__ID_SLOT_BITS | (uint32_t)(slot + 1);
}

const char *defsim__world_id_problem(const defsim_world *w, uint32_t index, uint32_t generation)
{
    if (index == 0 && generation == 0) return "null";
    return defsim__world_id_slot(w, index) < 0 ? "not of this world" : "stale (removed)";
}

defsim_status defsim__world_plan(defsim_world *w)
{
    if (w->planned) return DEFSIM_OK;
    w->h_stable = 0.0;
    const defsim__plan_input in = {
        .bodies = w->bodies, .nbodies = w->nbodies, .nv = w->nv, .mass = w->mass,
        .pinned = w->pinned, .gravity = w->def.gravity,
        .projection = defsim__options_projection(&w->options, (int)w->def.projection),
        .tet_kernels = defsim__options_tet_kernels(&w->options), .nthreads = w->nthreads,
        .need_matrix = (w->backend->flags & DEFSIM_BACKEND_NEEDS_MATRIX) != 0,
        .attachments = w->att, .nattachments = w->natt, .body_dense = w->body_dense};
    defsim_status st = defsim__plan(&w->sys, &w->work, &in);
    if (st == DEFSIM_OK && (st = defsim__coupling_reserve(w)) != DEFSIM_OK)
        defsim__unplan(&w->sys, &w->work);
    if (st != DEFSIM_OK) {
        defsim__error(w->msg, "out of memory while planning the world");
        return st;
    }
    w->sys.fext = w->fext_nonzero ? w->fext : NULL;
    w->sys.host = &w->handle;
    if ((st = defsim__terms_compile(&w->sys)) != DEFSIM_OK) {
        defsim__unplan(&w->sys, &w->work);
        defsim__error(w->msg, "out of memory while planning the world");
        return st;
    }
    w->contact.omega_elastic = 0.0;
    w->contact.surf_planned = 0;
    w->planned = 1;
    return DEFSIM_OK;
}

static void body_free(defsim__body *b)
{
    free(b->rest); free(b->mass); free(b->tets); free(b->springs); free(b->k); free(b->pinned);
    free(b->tris); free(b->edges);
    b->rest = b->mass = b->k = NULL;
    b->tets = b->springs = b->tris = b->edges = NULL;
    b->pinned = NULL;
}

void defsim_world_destroy(defsim_world *w)
{
    if (!w || !defsim__world_live(w)) return;
    if (defsim__world_check_unlocked(w) != DEFSIM_OK) return;   /* the caller is inside it */
    backend_fini(w);
    defsim__world_unplan(w);
    defsim__watchdog_free(&w->wd);
    for (int32_t i = 0; i < w->nbodies; ++i) body_free(&w->bodies[i]);
    free(w->bodies); free(w->body_gen); free(w->body_dense);
    free(w->state.x); free(w->state.v); free(w->mass); free(w->pinned);
    free(w->x_save); free(w->v_save);
    free(w->bstate);
    defsim__coupling_free(w);
    defsim__colliders_free(w);
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

void defsim_body_def_init(defsim_body_def *def, size_t size)
{
    if (!def || size < sizeof(uint32_t)) return;
    defsim_body_def d;
    memset(&d, 0, sizeof d);
    d.size = (uint32_t)sizeof d;
    defsim_material_init(&d.material, sizeof d.material, DEFSIM_MODEL_STABLE_NEOHOOKEAN);
    d.shear_stiffness = d.bend_stiffness = -1.0;
    d.self_contact = 1;
    d.collision_group = 1u;
    d.collision_mask = 0xFFFFFFFFu;
    d.friction = 0.5;
    if (size > sizeof d) size = sizeof d;
    memcpy(def, &d, size);
    def->size = (uint32_t)size;
}

/* Rebuilds the per-vertex world arrays from the live bodies, carrying their state over. On
 * failure nothing changes. `old_offset[b]` is body b's offset before the change (-1: new). */
static defsim_status rebuild_vertices(defsim_world *w, const int32_t *old_offset,
                                      const double *new_x, const double *new_v)
{
    int32_t nv = 0;
    for (int32_t b = 0; b < w->nbodies; ++b)
        if (w->bodies[b].generation & 1u) nv += w->bodies[b].nv;
    size_t n = (size_t)(nv > 0 ? nv : 1);
    double *x = malloc(3 * n * sizeof *x), *v = malloc(3 * n * sizeof *v);
    double *xs = malloc(3 * n * sizeof *xs), *vs = malloc(3 * n * sizeof *vs);
    double *mass = malloc(n * sizeof *mass);
    uint8_t *pinned = malloc(n);
    /* the host's per-vertex coupling data, where it has some: new bodies get none */
    double *fext = w->fext ? calloc(3 * n, sizeof *fext) : NULL;
    double *target = w->pin_target ? malloc(3 * n * sizeof *target) : NULL;
    uint8_t *targeted = w->pin_target ? calloc(n, 1) : NULL;
    if (!x || !v || !xs || !vs || !mass || !pinned || (w->fext && !fext) ||
        (w->pin_target && (!target || !targeted))) {
        free(x); free(v); free(xs); free(vs); free(mass); free(pinned);
        free(fext); free(target); free(targeted);
        return DEFSIM_ERR_OUT_OF_MEMORY;
    }
    int32_t ntargeted = 0;
    int32_t off = 0;
    for (int32_t b = 0; b < w->nbodies; ++b) {
        defsim__body *bd = &w->bodies[b];
        if (!(bd->generation & 1u)) continue;
        size_t bytes = 3 * (size_t)bd->nv * sizeof(double);
        if (old_offset[b] >= 0) {
            memcpy(x + 3 * (int64_t)off, w->state.x + 3 * (int64_t)old_offset[b], bytes);
            memcpy(v + 3 * (int64_t)off, w->state.v + 3 * (int64_t)old_offset[b], bytes);
            if (fext) memcpy(fext + 3 * (int64_t)off, w->fext + 3 * (int64_t)old_offset[b], bytes);
            if (target) {
                memcpy(target + 3 * (int64_t)off, w->pin_target + 3 * (int64_t)old_offset[b],
                       bytes);
                memcpy(targeted + off, w->targeted + old_offset[b], (size_t)bd->nv);
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
    free(w->state.x); free(w->state.v); free(w->x_save); free(w->v_save);
    free(w->mass); free(w->pinned);
    w->state.x = x; w->state.v = v; w->x_save = xs; w->v_save = vs;
    w->handle.x_start = xs;
    w->mass = mass; w->pinned = pinned;
    free(w->fext); free(w->pin_target); free(w->targeted);
    w->fext = fext; w->pin_target = target; w->targeted = targeted;
    w->ntargeted = ntargeted;
    if (fext) {
        int nonzero = 0;
        for (int64_t i = 0; i < 3 * (int64_t)nv; ++i) nonzero |= fext[i] != 0.0;
        w->fext_nonzero = nonzero;
    }
    w->nv = nv;
    backend_fini(w);
    defsim__world_unplan(w);
    return DEFSIM_OK;
}

static defsim_status validate_array(defsim_world *w, const double *a, int64_t n, const char *what)
{
    for (int64_t i = 0; i < n; ++i)
        if (!isfinite(a[i])) {
            defsim__error(w->msg, "%s: vertex %lld coordinate %d is not finite", what,
                          (long long)(i / 3), (int)(i % 3));
            return DEFSIM_ERR_INVALID_MESH;
        }
    return DEFSIM_OK;
}

defsim_status defsim_world_add_body(defsim_world *w, const defsim_body_def *def,
                                    defsim_body_id *out)
{
    defsim_status st = defsim__world_enter(w);
    if (st != DEFSIM_OK) return st;
    if (!def || def->size < offsetof(defsim_body_def, material) + sizeof(uint32_t)) {
        defsim__error(w->msg, "add_body: def is NULL or def->size is too small "
                              "(use defsim_body_def_init)");
        return DEFSIM_ERR_INVALID_ARGUMENT;
    }
    defsim_body_def d;
    defsim_body_def_init(&d, sizeof d);
    memcpy(&d, def, def->size < sizeof d ? def->size : sizeof d);
    if (d.material.size < offsetof(defsim_material, youngs_modulus)) {
        defsim__error(w->msg, "add_body: material.size %u is too small (use "
                              "defsim_material_init)", (unsigned)d.material.size);
        return DEFSIM_ERR_INVALID_ARGUMENT;
    }
    if (d.material.size < sizeof d.material) {
        /* An older material struct: keep the defaults for fields it lacks. */
        defsim_material m;
        defsim_material_init(&m, sizeof m, d.material.model);
        memcpy(&m, &def->material, d.material.size);
        m.size = sizeof m;
        d.material = m;
    }
    if (!d.rest_positions || d.vertex_count < 1 || d.tet_count < 0 || d.spring_count < 0 ||
        (d.tet_count > 0 && !d.tets) || (d.spring_count > 0 && !d.springs)) {
        defsim__error(w->msg, "add_body: needs rest_positions, vertex_count >= 1, and arrays "
                              "for non-zero tet_count / spring_count");
        return DEFSIM_ERR_INVALID_ARGUMENT;
    }
    if (d.vertex_count > (INT32_MAX - w->nv) / 3 || d.tet_count > INT32_MAX / 16 ||
        d.spring_count > INT32_MAX / 4) {
        defsim__error(w->msg, "add_body: counts too large");
        return DEFSIM_ERR_INVALID_ARGUMENT;
    }
    char msg[256];
    st = defsim__material_check(&d.material, d.tet_count > 0, d.spring_count > 0, msg,
                                sizeof msg);
    if (st != DEFSIM_OK) {
        defsim__error(w->msg, "add_body: %s", msg);
        return st;
    }
    if (d.spring_kinds && d.spring_stiffness) {
        defsim__error(w->msg, "add_body: give spring_stiffness or spring_kinds, not both");
        return DEFSIM_ERR_INVALID_ARGUMENT;
    }
    if (d.triangle_count < 0 || d.triangle_count > INT32_MAX / 6 ||
        (d.triangle_count > 0 && !d.triangles) || (d.self_contact != 0 && d.self_contact != 1)) {
        defsim__error(w->msg, "add_body: triangle_count %d must be >= 0 (with triangles for a "
                              "non-zero count) and self_contact %d 0 or 1",
                      (int)d.triangle_count, (int)d.self_contact);
        return DEFSIM_ERR_INVALID_ARGUMENT;
    }
    if (!isfinite(d.friction) || d.friction < 0.0 || d.friction > 10.0) {
        defsim__error(w->msg, "add_body: friction %g must be in [0, 10]", d.friction);
        return DEFSIM_ERR_INVALID_MATERIAL;
    }
    const int32_t nv = d.vertex_count, nt = d.tet_count, ns = d.spring_count;
    st = validate_array(w, d.rest_positions, 3 * (int64_t)nv, "rest_positions");
    if (st == DEFSIM_OK && d.initial_positions)
        st = validate_array(w, d.initial_positions, 3 * (int64_t)nv, "initial_positions");
    if (st == DEFSIM_OK && d.initial_velocities)
        st = validate_array(w, d.initial_velocities, 3 * (int64_t)nv, "initial_velocities");
    if (st != DEFSIM_OK) return st;

    defsim__body b;
    memset(&b, 0, sizeof b);
    b.nv = nv; b.nt = nt; b.ns = ns;
    b.mat = d.material;
    b.self_contact = d.self_contact;
    b.group = d.collision_group;
    b.mask = d.collision_mask;
    b.friction = d.friction;
    /* Contact edges of a rope: its stretch springs (all springs without kinds). */
    int32_t nedge = 0;
    if (nt == 0 && d.triangle_count == 0)
        for (int32_t s = 0; s < ns; ++s)
            nedge += !d.spring_kinds || d.spring_kinds[s] == DEFSIM_SPRING_STRETCH;
    b.ntri = d.triangle_count;
    b.nedge = nedge;
    if (b.ntri > 0) b.tris = malloc(3 * (size_t)b.ntri * sizeof *b.tris);
    if (nedge > 0) b.edges = malloc(2 * (size_t)nedge * sizeof *b.edges);
    b.rest = malloc(3 * (size_t)nv * sizeof *b.rest);
    b.mass = calloc((size_t)nv, sizeof *b.mass);
    b.pinned = calloc((size_t)nv, 1);
    b.tets = malloc((size_t)(nt > 0 ? nt : 1) * 4 * sizeof *b.tets);
    b.springs = malloc((size_t)(ns > 0 ? ns : 1) * 2 * sizeof *b.springs);
    b.k = malloc((size_t)(ns > 0 ? ns : 1) * sizeof *b.k);
    if (!b.rest || !b.mass || !b.pinned || !b.tets || !b.springs || !b.k ||
        (b.ntri > 0 && !b.tris) || (nedge > 0 && !b.edges)) {
        body_free(&b);
        defsim__error(w->msg, "out of memory");
        return DEFSIM_ERR_OUT_OF_MEMORY;
    }
    memcpy(b.rest, d.rest_positions, 3 * (size_t)nv * sizeof *b.rest);
    if (nt > 0) {
        memcpy(b.tets, d.tets, 4 * (size_t)nt * sizeof *b.tets);
        defsim__lame(b.mat.youngs_modulus, b.mat.poisson_ratio, &b.mu, &b.lambda);
    }
    if (ns > 0) memcpy(b.springs, d.springs, 2 * (size_t)ns * sizeof *b.springs);
    if (b.ntri > 0) memcpy(b.tris, d.triangles, 3 * (size_t)b.ntri * sizeof *b.tris);
    for (int32_t s = 0, e = 0; e < nedge; ++s)
        if (!d.spring_kinds || d.spring_kinds[s] == DEFSIM_SPRING_STRETCH) {
            b.edges[2 * (int64_t)e] = d.springs[2 * (int64_t)s];
            b.edges[2 * (int64_t)e + 1] = d.springs[2 * (int64_t)s + 1];
            ++e;
        }

    int32_t reordered = 0;
    st = DEFSIM_ERR_INVALID_MESH;
    for (int32_t t = 0; t < nt; ++t) {
        int32_t *tt = b.tets + 4 * (int64_t)t;
        for (int a = 0; a < 4; ++a) {
            if (tt[a] < 0 || tt[a] >= nv) {
                defsim__error(w->msg, "add_body: tet %d vertex %d index %d out of range [0, %d)",
                                    (int)t, a, (int)tt[a], (int)nv);
                goto fail;
            }
            for (int c = 0; c < a; ++c)
                if (tt[c] == tt[a]) {
                    defsim__error(w->msg, "add_body: tet %d repeats vertex %d", (int)t, (int)tt[a]);
                    goto fail;
                }
        }
        defsim__tet_rest rest;
        if (defsim__tet_rest_eval(b.rest, tt, &rest, NULL)) {
            defsim__error(w->msg, "add_body: tet %d is degenerate (volume %g, longest edge %g)",
                          (int)t, rest.det / 6.0, rest.longest_edge);
            goto fail;
        }
        const double det = rest.det;
        if (det < 0.0) {
            int32_t tmp = tt[0]; tt[0] = tt[1]; tt[1] = tmp;
            ++reordered;
        }
        const double m4 = b.mat.density * fabs(det) / 24.0;
        for (int a = 0; a < 4; ++a) b.mass[tt[a]] += m4;
    }
    for (int32_t s = 0; s < ns; ++s) {
        const int32_t a = b.springs[2 * (int64_t)s], c = b.springs[2 * (int64_t)s + 1];
        if (a < 0 || a >= nv || c < 0 || c >= nv) {
            defsim__error(w->msg, "add_body: spring %d index out of range [0, %d)", (int)s, (int)nv);
            goto fail;
        }
        const double *pa = b.rest + 3 * (int64_t)a, *pc = b.rest + 3 * (int64_t)c;
        double l = sqrt((pa[0] - pc[0]) * (pa[0] - pc[0]) + (pa[1] - pc[1]) * (pa[1] - pc[1]) +
                        (pa[2] - pc[2]) * (pa[2] - pc[2]));
        if (a == c || !(l > 0.0)) {
            defsim__error(w->msg, "add_body: spring %d has zero rest length", (int)s);
            goto fail;
        }
        double k = d.spring_stiffness ? d.spring_stiffness[s] : b.mat.stiffness;
        if (d.spring_kinds) {
            const int32_t kind = d.spring_kinds[s];
            if (kind < DEFSIM_SPRING_STRETCH || kind > DEFSIM_SPRING_BEND) {
                defsim__error(w->msg, "add_body: spring %d has kind %d (not a defsim_spring_kind)",
                              (int)s, (int)kind);
                st = DEFSIM_ERR_INVALID_MESH;
                goto fail;
            }
            const double by_kind = kind == DEFSIM_SPRING_SHEAR ? d.shear_stiffness
                                   : kind == DEFSIM_SPRING_BEND ? d.bend_stiffness : -1.0;
            if (by_kind >= 0.0 || isnan(by_kind)) k = by_kind;
        }
        if (!isfinite(k) || k < 0.0) {
            defsim__error(w->msg, "add_body: spring %d stiffness %g must be finite and >= 0",
                          (int)s, k);
            st = DEFSIM_ERR_INVALID_MATERIAL;
            goto fail;
        }
        b.k[s] = k;
    }
    for (int32_t t = 0; t < b.ntri; ++t) {
        const int32_t *tt = b.tris + 3 * (int64_t)t;
        if (tt[0] < 0 || tt[0] >= nv || tt[1] < 0 || tt[1] >= nv || tt[2] < 0 || tt[2] >= nv ||
            tt[0] == tt[1] || tt[1] == tt[2] || tt[0] == tt[2]) {
            defsim__error(w->msg, "add_body: triangle %d (%d %d %d) has an index out of range "
                                  "[0, %d) or repeats a vertex", (int)t, (int)tt[0], (int)tt[1],
                          (int)tt[2], (int)nv);
            st = DEFSIM_ERR_INVALID_MESH;
            goto fail;
        }
    }
    for (int32_t i = 0; i < nv; ++i) {
        double m = d.vertex_mass ? d.vertex_mass[i] : b.mass[i] + b.mat.vertex_mass;
        if (!isfinite(m) || !(m > 0.0)) {
            defsim__error(w->msg, "add_body: vertex %d has mass %g (needs a positive mass: "
                                  "give vertex_mass, or put it in a tet with density > 0)",
                          (int)i, m);
            st = d.vertex_mass ? DEFSIM_ERR_INVALID_MATERIAL : DEFSIM_ERR_INVALID_MESH;
            goto fail;
        }
        b.mass[i] = m;
    }

    /* The id takes the first free slot (its generation makes the ids of its earlier bodies
     * stale); the vertices still follow those of the bodies added before. */
    int32_t slot = 0;
    while (slot < w->nslots && (w->body_gen[slot] & 1u)) ++slot;
    st = DEFSIM_ERR_OUT_OF_MEMORY;
    if (slot == DEFSIM__ID_MAX_SLOTS) {
        defsim__error(w->msg, "add_body: the world holds %d bodies, the most it can",
                      (int)DEFSIM__ID_MAX_SLOTS);
        goto fail;
    }
    if (slot == w->cap_slots) {
        int32_t cap = w->cap_slots ? 2 * w->cap_slots : 8;
        if (cap > DEFSIM__ID_MAX_SLOTS) cap = DEFSIM__ID_MAX_SLOTS;
        uint32_t *gen = realloc(w->body_gen, (size_t)cap * sizeof *gen);
        if (gen) w->body_gen = gen;
        int32_t *dense = gen ? realloc(w->body_dense, (size_t)cap * sizeof *dense) : NULL;
        if (!dense) { defsim__error(w->msg, "out of memory"); goto fail; }
        w->body_dense = dense;
        w->cap_slots = cap;
    }
    if (w->nbodies == w->cap_bodies) {
        int32_t cap = w->cap_bodies ? 2 * w->cap_bodies : 8;
        defsim__body *nb = realloc(w->bodies, (size_t)cap * sizeof *nb);
        if (!nb) { defsim__error(w->msg, "out of memory"); goto fail; }
        w->bodies = nb;
        w->cap_bodies = cap;
    }
    int32_t *old = malloc(((size_t)w->nbodies + 1) * sizeof *old);
    if (!old) { defsim__error(w->msg, "out of memory"); goto fail; }
    for (int32_t i = 0; i < w->nbodies; ++i) old[i] = w->bodies[i].offset;
    old[w->nbodies] = -1;
    b.generation = (slot < w->nslots ? w->body_gen[slot] : 0u) + 1u;
    w->bodies[w->nbodies++] = b;
    st = rebuild_vertices(w, old, d.initial_positions ? d.initial_positions : d.rest_positions,
                          d.initial_velocities);
    free(old);
    if (st != DEFSIM_OK) {
        w->nbodies--;
        defsim__error(w->msg, "out of memory");
        goto fail;
    }
    if (slot == w->nslots) w->nslots++;
    w->body_gen[slot] = b.generation;
    w->body_dense[slot] = w->nbodies - 1;
    w->stats.reordered_tets += reordered;
    if (out) {
        out->index = defsim__world_id_index(w, slot);
        out->generation = b.generation;
    }
    return DEFSIM_OK;
fail:
    body_free(&b);
    return st;
}

defsim__body *defsim__world_find_body(const defsim_world *w, defsim_body_id id)
{
    const int64_t slot = defsim__world_id_slot(w, id.index);
    if (slot < 0 || slot >= w->nslots || w->body_gen[slot] != id.generation ||
        !(id.generation & 1u))
        return NULL;
    return &w->bodies[w->body_dense[slot]];
}

defsim__body *defsim__world_body(const defsim_world *w, defsim_body_id id)
{
    defsim__body *b = defsim__world_find_body(w, id);
    if (!b)
        defsim__error(w->msg, "body id {%u, %u} is %s", (unsigned)id.index,
                      (unsigned)id.generation,
                      defsim__world_id_problem(w, id.index, id.generation));
    return b;
}

defsim_status defsim_world_remove_body(defsim_world *w, defsim_body_id id)
{
    defsim_status st = defsim__world_enter(w);
    if (st != DEFSIM_OK) return st;
    defsim__body *b = defsim__world_body(w, id);
    if (!b) return DEFSIM_ERR_STALE_ID;
    int32_t *old = malloc(((size_t)w->nbodies + 1) * sizeof *old);
    if (!old) { defsim__error(w->msg, "out of memory"); return DEFSIM_ERR_OUT_OF_MEMORY; }
    for (int32_t i = 0; i < w->nbodies; ++i) old[i] = w->bodies[i].offset;
    b->generation++;
    st = rebuild_vertices(w, old, NULL, NULL);
    free(old);
    if (st != DEFSIM_OK) {
        b->generation--;
        defsim__error(w->msg, "out of memory");
        return st;
    }
    defsim__coupling_drop_body(w, id);
    body_free(b);
    /* Close the gap in the dense array; the slot is free for the next body. */
    const int64_t slot = DEFSIM__ID_SLOT(id.index);
    const int32_t dense = w->body_dense[slot];
    memmove(w->bodies + dense, w->bodies + dense + 1,
            (size_t)(w->nbodies - dense - 1) * sizeof *w->bodies);
    w->nbodies--;
    for (int32_t i = 0; i < w->nslots; ++i)
        if (w->body_dense[i] > dense) w->body_dense[i]--;
    w->body_dense[slot] = -1;
    w->body_gen[slot]++;
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
        w->pinned[b->offset + v] = value;
        if (!value && w->targeted && w->targeted[b->offset + v]) {
            w->targeted[b->offset + v] = 0;   /* unpinning drops the target */
            w->ntargeted--;
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
    const double *src = which == 0 ? w->state.x : which == 1 ? w->state.v : w->mass;
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

defsim_status defsim_world_get_masses(const defsim_world *w, double *out, int32_t n)
{
    return copy_out(w, 2, out, n);
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
    w->h_stable = 0.0;
    defsim__watchdog_forget(&w->wd, 0);
    w->body_contact.fresh = 1;   /* the host's state may have crossing surfaces */
    for (int32_t i = 0; i < w->nv; ++i)
        if (w->pinned[i]) w->state.v[3 * (int64_t)i] = w->state.v[3 * (int64_t)i + 1] = w->state.v[3 * (int64_t)i + 2] = 0.0;
    if (w->backend_ready && w->backend->reset) {
        defsim_status st = w->backend->reset(&defsim__host, &w->handle, w->bstate);
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
            .bodies = w->bodies, .nbodies = w->nbodies, .nv = w->nv, .mass = w->mass,
            .pinned = w->pinned, .gravity = w->def.gravity, .nthreads = w->nthreads,
            .attachments = w->att, .nattachments = w->natt, .body_dense = w->body_dense};
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
        ke += 0.5 * w->mass[i] * (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
        ge -= w->mass[i] * (g[0] * x[0] + g[1] * x[1] + g[2] * x[2]);
        if (w->fext_nonzero) {
            const double *f = w->fext + 3 * (int64_t)i;
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
    memset(w->contact.stat, 0, sizeof w->contact.stat);
}

/* ------------------------------------------------------------------------------------------ */
/* Stability */

static defsim_status contact_begin(defsim_world *w, double h);

static defsim_status estimate_stable_step(defsim_world *w, double *h, double *omega)
{
    double om = 0.0;
    defsim_status st = defsim__omega_max(&w->sys, &w->work, w->state.x, &om);
    if (st != DEFSIM_OK) {
        defsim__error(w->msg, st == DEFSIM_ERR_OUT_OF_MEMORY ? "out of memory"
                                                              : "stable step: non-finite stiffness");
        return st;
    }
    const double c = defsim__damping_coeff(&w->sys, w->state.x, om);
    const defsim_backend *b = w->backend;
    *h = b->stable_step_options ? b->stable_step_options(defsim__options_values(&w->options), om, c)
         : b->stable_step       ? b->stable_step(om, c)
                                : INFINITY;
    if (omega) *omega = om;
    w->stats.stable_step = *h;
    return DEFSIM_OK;
}

defsim_status defsim_world_stable_step(defsim_world *w, double *h_out, double *omega_out)
{
    defsim_status st = defsim__world_enter(w);
    if (st != DEFSIM_OK) return st;
    st = defsim__world_plan(w);
    if (st != DEFSIM_OK) return st;
    double h = INFINITY, om = 0.0;
    /* Penalty contact stiffens the system (explicit backends' limit); the barrier's backends
     * have no limit. */
    const int penalty = !(w->backend->flags & DEFSIM_BACKEND_CONTACT_CCD);
    if (w->nv > 0 && penalty && (st = contact_begin(w, 0.0)) != DEFSIM_OK) return st;
    if (w->nv > 0) st = estimate_stable_step(w, &h, &om);
    w->sys.contact = NULL;
    const defsim_status ct = defsim__terms_compile(&w->sys);
    if (st == DEFSIM_OK) st = ct;
    if (st != DEFSIM_OK) return st;
    if (h_out) *h_out = h;
    if (omega_out) *omega_out = om;
    return DEFSIM_OK;
}

/* ------------------------------------------------------------------------------------------ */
/* Stepping */

/* The work terms of the step for the watchdog (watchdog.h): the callback's recorded forces,
 * the forces at moving driven pins, the colliders' work and their energy at the start. */
static defsim_status watch_work(defsim_world *w, defsim__watchdog_step *in, char *what,
                                size_t size)
{
    const defsim__coupling *c = &w->cpl;
    if (c->fn) {
        if (c->implicit) in->cb_f[in->ncb++] = c->f0;   /* the start, evaluated by step_begin */
        if (c->nrec > 0) in->cb_f[in->ncb++] = c->rec_first;
        if (c->nrec > 1) in->cb_f[in->ncb++] = c->rec_last;
        if (c->rec_prev_t == w->state.t && w->wd.have_ref) in->cb_f[in->ncb++] = c->rec_prev;
    }
    if (w->drove) {
        /* The forces that the pins hold at the start (those of the last step's end when that
         * ended here) and at the end. Not counted as the backend's force evaluations. */
        defsim__watchdog *wd = &w->wd;
        double *f0 = defsim__watchdog_pin_buffer(wd, w->nv, 0);
        double *f1 = defsim__watchdog_pin_buffer(wd, w->nv, 1);
        if (!f0 || !f1) {
            snprintf(what, size, "out of memory");
            return DEFSIM_ERR_OUT_OF_MEMORY;
        }
        defsim_status st = DEFSIM_OK;
        if (!(wd->pin_f_t == w->state.t && wd->have_ref)) {
            st = defsim__watchdog_pin_forces(wd, &w->sys, w->x_save, w->v_save, f0);
            wd->pin_f_t = st == DEFSIM_OK ? w->state.t : NAN;
        }
        if (st == DEFSIM_OK)
            st = defsim__watchdog_pin_forces(wd, &w->sys, w->state.x, w->state.v, f1);
        if (st != DEFSIM_OK) {
            snprintf(what, size, st == DEFSIM_ERR_OUT_OF_MEMORY
                                     ? "out of memory"
                                     : "the forces on the driven pins are not finite");
            return st;
        }
        wd->pin_end = 1;
        in->pin_f0 = f0;
        in->pin_f1 = f1;
    }
    defsim__contact *ct = w->sys.contact;
    if (ct && ct->npair > 0) {
        in->colliders_changed = w->colliders_came;
        if (!w->wd.have_ref || w->colliders_came)
            in->contact_start = defsim__contact_energy_start(ct, w->x_save);
        in->contact_work = defsim__contact_work(ct, w->x_save, w->state.x);
    }
    return DEFSIM_OK;
}

/* The stability watchdog over a step the backend finished; on a trip the message says what
 * tripped and what to do, with the stable step at the restored start (docs/watchdog.md). */
static defsim_status watch_step(defsim_world *w, double h)
{
    const defsim__options *o = &w->options;
    defsim__watchdog_step in = {
        .sys = &w->sys, .work = &w->work, .bodies = w->bodies, .nbodies = w->nbodies,
        .x = w->state.x, .v = w->state.v, .x0 = w->x_save, .v0 = w->v_save,
        .on = defsim__options_core(o, DEFSIM__OPT_WATCHDOG) != 0.0,
        .energy_growth = defsim__options_core(o, DEFSIM__OPT_WATCHDOG_ENERGY_GROWTH),
        .max_stretch = defsim__options_core(o, DEFSIM__OPT_WATCHDOG_MAX_STRETCH)};
    char what[400];
    w->wd.pin_end = 0;
    defsim_status st = in.on ? watch_work(w, &in, what, sizeof what) : DEFSIM_OK;
    const int64_t evals = w->wd.energy_evals;
    if (st == DEFSIM_OK) st = defsim__watchdog_check(&w->wd, &in, what, sizeof what);
    w->stats.energy_evals += w->wd.energy_evals - evals;
    if (st != DEFSIM_ERR_UNSTABLE) {
        if (st != DEFSIM_OK) defsim__error(w->msg, "step: %s", what);
        return st;
    }
    w->stats.watchdog_trips++;
    const size_t bytes = 3 * (size_t)w->nv * sizeof(double);
    memcpy(w->state.x, w->x_save, bytes);   /* the estimate is of the start */
    memcpy(w->state.v, w->v_save, bytes);
    const int limited = w->backend->stable_step || w->backend->stable_step_options;
    double hs = INFINITY;
    const int estimated = limited && estimate_stable_step(w, &hs, NULL) == DEFSIM_OK;
    char msg[sizeof w->msg->error];
    defsim__watchdog_message(msg, sizeof msg, what, h, w->state.t, w->backend->name, limited,
                             estimated ? hs : NAN, defsim__options_auto_substep(o));
    defsim__error(w->msg, "%s", msg);
    return DEFSIM_ERR_UNSTABLE;
}

/* Contact (contact.h) for a step of h (0: for the stable step): BARRIER for backends whose line
 * search uses contact_max_step, PENALTY for the others; the system sees it until the step ends. */
static defsim_status contact_begin(defsim_world *w, double h)
{
    if (w->sys.contact) {   /* left attached by a failed step: detach */
        w->sys.contact = NULL;
        (void)defsim__terms_compile(&w->sys);
    }
    /* The penalty is a force that jumps when a collider comes, goes or moves between steps:
     * backends that carry force evaluations from the last step (velocity_verlet's f(x_n),
     * ERK's first-same-as-last stage, IDA's history) start afresh, as after set_state. */
    const int penalty = !(w->backend->flags & DEFSIM_BACKEND_CONTACT_CCD);
    int jumped = w->colliders_changed;
    for (int32_t j = 0; j < w->ncol && !jumped; ++j)
        jumped = (w->col[j].generation & 1u) &&
                 (memcmp(w->col[j].pos, w->col[j].pos1, sizeof w->col[j].pos) != 0 ||
                  memcmp(w->col[j].rot, w->col[j].rot1, sizeof w->col[j].rot) != 0);
    if (h > 0.0 && jumped && penalty && w->backend_ready && w->backend->reset) {
        const defsim_status st = w->backend->reset(&defsim__host, &w->handle, w->bstate);
        if (st != DEFSIM_OK) {
            defsim__error(w->msg, "backend %s failed to reset for the colliders' change",
                          w->backend->name);
            return st;
        }
    }
    if (h > 0.0) {
        /* The watchdog counts the energy of colliders that came until a step succeeds. */
        w->colliders_came |= w->colliders_changed;
        w->colliders_changed = 0;
    }
    if (defsim_world_collider_count(w) == 0) return DEFSIM_OK;
    const defsim__options *o = &w->options;
    defsim__contact_params p = {
        .mode = (w->backend->flags & DEFSIM_BACKEND_CONTACT_CCD) ? DEFSIM__CONTACT_BARRIER
                                                                 : DEFSIM__CONTACT_PENALTY,
        .dhat_rel = defsim__options_core(o, DEFSIM__OPT_CONTACT_DHAT),
        .kappa = defsim__options_core(o, DEFSIM__OPT_CONTACT_KAPPA),
        .frequency = defsim__options_core(o, DEFSIM__OPT_CONTACT_FREQUENCY),
        .eps_v = defsim__options_core(o, DEFSIM__OPT_FRICTION_EPS_V)};
    defsim__contact *c = &w->contact;
    if (p.mode == DEFSIM__CONTACT_PENALTY && p.frequency == 0.0 && c->omega_elastic == 0.0) {
        double om = 0.0;   /* the bodies' own top frequency, without contact, once per plan */
        defsim_status st = defsim__omega_max(&w->sys, &w->work, w->state.x, &om);
        if (st != DEFSIM_OK) {
            defsim__error(w->msg, "contact: the elastic frequency is not finite");
            return st;
        }
        c->omega_elastic = om;
    }
    p.omega_elastic = c->omega_elastic;
    if (p.mode == DEFSIM__CONTACT_BARRIER && !c->surf_planned &&
        defsim__contact_surfaces(c, w->bodies, w->nbodies) != DEFSIM_OK) {
        defsim__error(w->msg, "contact: out of memory for the bodies' surfaces");
        return DEFSIM_ERR_OUT_OF_MEMORY;
    }
    /* A step's start: the world's copies, which nothing changes until the step ends. */
    defsim_status st = defsim__contact_begin(c, &w->sys, w->col, w->ncol, &p,
                                             h > 0.0 ? w->x_save : w->state.x,
                                             h > 0.0 ? w->v_save : w->state.v, h, w->msg);
    if (st != DEFSIM_OK) return st;
    w->sys.contact = c;
    return defsim__terms_compile(&w->sys);
}

defsim_status defsim__world_replay_contact_begin(defsim_world *w)
{
    if (w->nv == 0 || defsim_world_collider_count(w) == 0 ||
        (w->backend->flags & DEFSIM_BACKEND_CONTACT_CCD))
        return DEFSIM_OK;
    /* An SDF collider has no function until the host installs it after the load: the replay
     * goes without contact (and, if it touched one, misses and restarts). */
    for (int32_t j = 0; j < w->ncol; ++j)
        if ((w->col[j].generation & 1u) && w->col[j].def.shape == DEFSIM_SHAPE_SDF)
            return DEFSIM_OK;
    /* contact_begin takes both poses of the step from the colliders: the end pose made the
     * current one for that call (begin copies the poses), then the pending targets back. */
    double *keep = malloc(7 * (size_t)w->ncol * sizeof *keep);
    if (!keep) {
        defsim__error(w->msg, "out of memory");
        return DEFSIM_ERR_OUT_OF_MEMORY;
    }
    for (int32_t j = 0; j < w->ncol; ++j) {
        defsim__collider *c = &w->col[j];
        memcpy(keep + 7 * (int64_t)j, c->pos1, sizeof c->pos1);
        memcpy(keep + 7 * (int64_t)j + 3, c->rot1, sizeof c->rot1);
        memcpy(c->pos1, c->pos, sizeof c->pos);
        memcpy(c->rot1, c->rot, sizeof c->rot);
    }
    const defsim_status st = contact_begin(w, 0.0);
    for (int32_t j = 0; j < w->ncol; ++j) {
        defsim__collider *c = &w->col[j];
        memcpy(c->pos1, keep + 7 * (int64_t)j, sizeof c->pos1);
        memcpy(c->rot1, keep + 7 * (int64_t)j + 3, sizeof c->rot1);
    }
    free(keep);
    return st;
}

void defsim__world_replay_contact_end(defsim_world *w) { w->sys.contact = NULL; }

/* A zeroed contact-force read-back of the world's vertex count. */
static defsim_status readback_reserve(defsim_world *w)
{
    free(w->contact_force);
    w->contact_nv = 0;
    w->contact_force = calloc(3 * (size_t)w->nv, sizeof *w->contact_force);
    if (!w->contact_force) {
        defsim__error(w->msg, "out of memory for the contact forces");
        return DEFSIM_ERR_OUT_OF_MEMORY;
    }
    w->contact_nv = w->nv;
    return DEFSIM_OK;
}

/* Closes contact's part of a step: a callback's failure is the step's; after a success, the
 * contact forces for the host and the colliders' poses at the end of the step. */
static defsim_status contact_end(defsim_world *w, defsim_status st)
{
    defsim__contact *c = w->sys.contact;
    w->sys.contact = NULL;
    if (c && defsim__terms_compile(&w->sys) != DEFSIM_OK) st = DEFSIM_ERR_OUT_OF_MEMORY;
    if (!c) {   /* no collider: the read-back is zero (dropped once after the last one went) */
        if (st == DEFSIM_OK && w->contact.readback_set) {
            free(w->contact_force);
            w->contact_force = NULL;
            w->contact_nv = 0;
            w->contact.readback_set = 0;
        }
        return st;
    }
    if (st == DEFSIM_OK && (!w->contact_force || w->contact_nv != w->nv)) {
        if (readback_reserve(w) != DEFSIM_OK) return DEFSIM_ERR_OUT_OF_MEMORY;
        w->contact_zero = 1;
    }
    /* The read-back goes to scratch first: a callback failing there fails the step too, and
     * a failed step changes neither the read-back nor the poses. Without pairs (colliders far
     * away) the forces are zero: nothing to compute or copy when the read-back is zero already. */
    const int none = st == DEFSIM_OK && w->contact_zero && defsim__contact_none(c, w->state.x);
    if (st == DEFSIM_OK && !c->failed && none) {
        c->stat[DEFSIM__CSTAT_ACTIVE] = 0;
        c->stat[DEFSIM__CSTAT_MIN_DISTANCE] = INFINITY;
    } else if (st == DEFSIM_OK && !c->failed) {
        defsim__contact_end(c, w->state.x, w->state.v, c->blk);
    }
    if (c->failed) {
        defsim__error(w->msg, "contact: %s; state restored", defsim__contact_failure(c));
        return c->failed;
    }
    if (st != DEFSIM_OK && c->blocked) {
        char who[48] = "a surface";
        if (c->blocked_vertex >= 0) snprintf(who, sizeof who, "vertex %d", (int)c->blocked_vertex);
        defsim__error(w->msg, "contact: no Newton start keeps %s clear of the moving colliders in "
                      "this step (squeezed between colliders that move differently, swept by "
                      "one, or cut back by body contact); state restored", who);
    }
    if (st != DEFSIM_OK) return st;
    if (c->mode == DEFSIM__CONTACT_BARRIER &&
        defsim__options_core(&w->options, DEFSIM__OPT_WATCHDOG) != 0.0 &&
        !(c->stat[DEFSIM__CSTAT_MIN_DISTANCE] > 0.0)) {
        /* The watchdog's contact check: the barrier is infinite at zero distance and the line
         * search keeps every vertex out, so a vertex at d <= 0 means that guarantee broke. */
        w->stats.watchdog_trips++;
        defsim__error(w->msg, "step: watchdog: a vertex crossed a collider's surface (distance "
                      "%g m) although the contact barrier forbids it; state restored. This is a "
                      "defect: please report it with the scene", c->stat[DEFSIM__CSTAT_MIN_DISTANCE]);
        return DEFSIM_ERR_UNSTABLE;
    }
    if (!none) memcpy(w->contact_force, c->blk, 3 * (size_t)w->nv * sizeof *w->contact_force);
    w->contact_zero = c->npair == 0;
    c->readback_set = 1;
    for (int32_t j = 0; j < w->ncol; ++j) {
        memcpy(w->col[j].pos, w->col[j].pos1, sizeof w->col[j].pos);
        memcpy(w->col[j].rot, w->col[j].rot1, sizeof w->col[j].rot);
    }
    return DEFSIM_OK;
}

/* Body contact (body_contact.h) for a step of h while the option is on (the step refused
 * backends without contact CCD already). */
static defsim_status body_begin(defsim_world *w, double h)
{
    if (w->sys.body_contact) {   /* left attached by a failed step: detach */
        w->sys.body_contact = NULL;
        (void)defsim__terms_compile(&w->sys);
    }
    const defsim__options *o = &w->options;
    if (defsim__options_core(o, DEFSIM__OPT_BODY_CONTACT) == 0.0) {
        w->body_contact_last = 0;
        return DEFSIM_OK;
    }
    if (!w->body_contact_last) w->body_contact.fresh = 1;
    w->body_contact_last = 1;
    const defsim_status st = defsim__body_contact_begin(
        &w->body_contact, &w->sys, w->bodies, w->nbodies,
        defsim__options_core(o, DEFSIM__OPT_CONTACT_DHAT),
        defsim__options_core(o, DEFSIM__OPT_CONTACT_KAPPA),
        defsim__options_core(o, DEFSIM__OPT_FRICTION_EPS_V), w->x_save, w->state.v, h,
        w->contact.stat, w->msg);
    if (st != DEFSIM_OK) return st;
    w->sys.body_contact = &w->body_contact;
    return defsim__terms_compile(&w->sys);
}

/* Closes body contact's part of a step: the forces of the end state (into its scratch, for the
 * read-back) and the statistics; the watchdog's check that no pair reached distance 0. */
static defsim_status body_end(defsim_world *w, defsim_status st)
{
    defsim__body_contact *bc = w->sys.body_contact;
    w->sys.body_contact = NULL;
    if (bc && defsim__terms_compile(&w->sys) != DEFSIM_OK && st == DEFSIM_OK)
        st = DEFSIM_ERR_OUT_OF_MEMORY;
    if (!bc || st != DEFSIM_OK) return st;
    if (bc->failed) {
        defsim__error(w->msg, "out of memory for body contact pairs; state restored");
        return bc->failed;
    }
    const double dmin = defsim__body_contact_end(bc, w->state.x, bc->scratch);
    if (defsim__options_core(&w->options, DEFSIM__OPT_WATCHDOG) != 0.0 && !(dmin > 0.0)) {
        w->stats.watchdog_trips++;
        defsim__error(w->msg, "step: watchdog: two body surfaces touched (distance %g m) although "
                      "the contact barrier forbids it; state restored. This is a defect: please "
                      "report it with the scene", dmin);
        return DEFSIM_ERR_UNSTABLE;
    }
    return DEFSIM_OK;
}

/* Adds body contact's forces of a successful step to the read-back (after the colliders'). */
static defsim_status body_readback(defsim_world *w, int colliders)
{
    if (!w->contact_force || w->contact_nv != w->nv) {
        if (readback_reserve(w) != DEFSIM_OK) return DEFSIM_ERR_OUT_OF_MEMORY;
    } else if (!colliders) {
        memset(w->contact_force, 0, 3 * (size_t)w->nv * sizeof *w->contact_force);
    }
    const double *f = w->body_contact.scratch;
    for (int64_t i = 0; i < 3 * (int64_t)w->nv; ++i) w->contact_force[i] += f[i];
    w->contact_zero = 0;
    w->contact.readback_set = 1;
    return DEFSIM_OK;
}

defsim_status defsim_world_step(defsim_world *w, double h)
{
    defsim_status st = defsim__world_enter(w);
    if (st != DEFSIM_OK) return st;
    if (!isfinite(h) || !(h > 0.0)) {
        defsim__error(w->msg, "step: h = %g must be finite and > 0", h);
        return DEFSIM_ERR_INVALID_ARGUMENT;
    }
    if (w->state.t + h == w->state.t) {
        defsim__error(w->msg, "step: h = %g s does not advance the time t = %.17g s (t + h rounds "
                      "to t in double precision): use a larger step, or restart the clock",
                      h, w->state.t);
        return DEFSIM_ERR_INVALID_ARGUMENT;
    }
    if (defsim__options_core(&w->options, DEFSIM__OPT_BODY_CONTACT) != 0.0 &&
        !(w->backend->flags & DEFSIM_BACKEND_CONTACT_CCD)) {
        defsim__error(w->msg, "step: body contact (core.body_contact) needs a backend with "
                              "contact CCD (newton_cholmod, newmark or bdf2); backend %s has "
                              "none: turn body_contact off or change the backend",
                      w->backend->name);
        return DEFSIM_ERR_UNSUPPORTED;
    }
    double t0 = defsim__now();
    st = defsim__world_plan(w);
    if (st != DEFSIM_OK) return st;
    if (w->nv == 0) {
        w->state.t += h;
        w->stats.steps++;
        return DEFSIM_OK;
    }
    if (defsim__options_take_reinit(&w->options)) {   /* an option changed */
        backend_fini(w);
        w->h_stable = 0.0;   /* the stability limit may depend on it */
    }
    if (!w->backend_ready && (st = defsim__world_backend_start(w)) != DEFSIM_OK) {
        w->stats.failed_steps++;
        return st;
    }
    const size_t bytes = 3 * (size_t)w->nv * sizeof(double);
    memcpy(w->x_save, w->state.x, bytes);
    memcpy(w->v_save, w->state.v, bytes);
    w->step_passes = 0;
    w->msg->error[0] = '\0';
    const int substep = defsim__options_auto_substep(&w->options) &&
                        (w->backend->stable_step || w->backend->stable_step_options);
    st = defsim__coupling_step_begin(w, h);
    if (st == DEFSIM_OK) st = contact_begin(w, h);
    if (st == DEFSIM_OK) st = body_begin(w, h);
    for (int attempt = 0; attempt < 2 && st == DEFSIM_OK; ++attempt) {
        int64_t n = 1;
        if (substep) {
            /* Re-estimate every 64 steps, after any change, and after a failed attempt. */
            if (w->h_stable <= 0.0 || w->steps_since_estimate >= 64 || attempt > 0) {
                double hs;
                if ((st = estimate_stable_step(w, &hs, NULL)) != DEFSIM_OK) break;
                w->h_stable = attempt > 0 ? 0.5 * hs : hs;
                w->steps_since_estimate = 0;
            }
            double k = ceil(h / (defsim__options_substep_safety(&w->options) * w->h_stable));
            if (!(k <= 1e7)) {
                st = DEFSIM_ERR_UNSTABLE;
                defsim__error(w->msg, "step: auto_substep would need %g substeps (stable step %g s)",
                              k, w->h_stable);
                break;
            }
            n = k < 1.0 ? 1 : (int64_t)k;
        }
        st = DEFSIM_OK;
        for (int64_t i = 0; i < n && st == DEFSIM_OK; ++i) {
            defsim__coupling_substep_before(w, i, n, h / (double)n);
            defsim__terms_substep(&w->sys, (double)i / (double)n, (double)(i + 1) / (double)n,
                                  h / (double)n);
            st = w->backend->step(&defsim__host, &w->handle, w->bstate, h / (double)n);
            defsim__coupling_substep_after(w);
        }
        if (substep) w->stats.substeps += n;
        if (st != DEFSIM_ERR_UNSTABLE || !substep) break;
        /* Unstable despite substepping: roll back and retry once, re-estimated and halved. */
        memcpy(w->state.x, w->x_save, bytes);
        memcpy(w->state.v, w->v_save, bytes);
        st = defsim__coupling_step_begin(w, h);
        if (st != DEFSIM_OK) break;
        if (w->backend->reset) w->backend->reset(&defsim__host, &w->handle, w->bstate);
    }
    st = defsim__coupling_step_end(w, st);
    if (substep && st == DEFSIM_OK) w->steps_since_estimate++;
    if (st == DEFSIM_OK) st = watch_step(w, h);
    const int bodies = w->sys.body_contact != NULL, colliders = w->sys.contact != NULL;
    st = body_end(w, st);
    st = contact_end(w, st);
    if (st == DEFSIM_OK && bodies) st = body_readback(w, colliders);
    if (st != DEFSIM_OK) {
        memcpy(w->state.x, w->x_save, bytes);
        memcpy(w->state.v, w->v_save, bytes);
        if (!w->msg->error[0])
            defsim__error(w->msg, "step: backend %s failed: %s", w->backend->name,
                          defsim_status_string(st));
        if (w->backend->reset &&
            w->backend->reset(&defsim__host, &w->handle, w->bstate) != DEFSIM_OK)
            backend_fini(w);
        w->stats.failed_steps++;
        w->stats.time_step += defsim__now() - t0;
        return st;
    }
    w->state.t += h;
    w->colliders_came = 0;
    defsim__watchdog_step_done(&w->wd, w->state.t);
    if (w->cpl.fn && w->cpl.nrec > 0) {
        /* The callback's last forces of this step serve the next (watch_work). */
        double *r = w->cpl.rec_prev;
        w->cpl.rec_prev = w->cpl.nrec > 1 ? w->cpl.rec_last : w->cpl.rec_first;
        if (w->cpl.nrec > 1) w->cpl.rec_last = r;
        else w->cpl.rec_first = r;
        w->cpl.rec_prev_t = w->state.t;
    }
    w->stats.steps++;
    w->stats.passes = w->step_passes;
    w->stats.time_step += defsim__now() - t0;
    return DEFSIM_OK;
}

/* ------------------------------------------------------------------------------------------ */
/* Options and statistics by name (options.c does the work). */

/* Settings the compiled system holds take effect without a re-plan. */
static defsim_status options_changed(defsim_world *w, defsim_status st)
{
    if (st == DEFSIM_OK && w->planned) {
        w->sys.tet_kernels = defsim__options_tet_kernels(&w->options);
        w->sys.projection = defsim__options_projection(&w->options, (int)w->def.projection);
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

int32_t defsim_world_stat_count(const defsim_world *w)
{
    return defsim__world_live(w) ? defsim__options_stat_count(&w->options) : 0;
}

defsim_status defsim_world_stat_info(const defsim_world *w, int32_t i, const char **name,
                                     double *value)
{
    if (!defsim__world_live(w)) return DEFSIM_ERR_INVALID_ARGUMENT;
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
    if (name && value && !strncmp(name, "term.", 5) &&
        defsim__terms_counter(&w->sys, name + 5, value))
        return DEFSIM_OK;
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
