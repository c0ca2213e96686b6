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
#include "tet_rest.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#ifdef _OPENMP
#include <omp.h>
#endif


/* ------------------------------------------------------------------------------------------ */
/* Creation */

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

void defsim__world_unplan(defsim_world *w)
{
    defsim__unplan(&w->sys, &w->work);
    w->planned = 0;
}

void defsim__world_invalidate(defsim_world *w)
{
    backend_fini(w);
    defsim__world_unplan(w);
}

defsim_status defsim__world_check_unlocked(defsim_world *w)
{
    if (!w->cpl.locked) return DEFSIM_OK;
    defsim__error(w->msg, "the world cannot be changed from inside its force callback");
    return DEFSIM_ERR_LOCKED;
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
        .attachments = w->att, .nattachments = w->natt};
    defsim_status st = defsim__plan(&w->sys, &w->work, &in);
    if (st == DEFSIM_OK && (st = defsim__coupling_reserve(w)) != DEFSIM_OK)
        defsim__unplan(&w->sys, &w->work);
    if (st != DEFSIM_OK) {
        defsim__error(w->msg, "out of memory while planning the world");
        return st;
    }
    w->sys.fext = w->fext_nonzero ? w->fext : NULL;
    w->planned = 1;
    return DEFSIM_OK;
}

static void body_free(defsim__body *b)
{
    free(b->rest); free(b->mass); free(b->tets); free(b->springs); free(b->k); free(b->pinned);
    b->rest = b->mass = b->k = NULL;
    b->tets = b->springs = NULL;
    b->pinned = NULL;
}

void defsim_world_destroy(defsim_world *w)
{
    if (!w) return;
    backend_fini(w);
    defsim__world_unplan(w);
    for (int32_t i = 0; i < w->nbodies; ++i) body_free(&w->bodies[i]);
    free(w->bodies);
    free(w->state.x); free(w->state.v); free(w->mass); free(w->pinned);
    free(w->x_save); free(w->v_save);
    free(w->bstate);
    defsim__coupling_free(w);
    defsim__colliders_free(w);
    free(w->msg);
    defsim__options_free(&w->options);
    free(w);
}

const char *defsim_world_last_error(const defsim_world *w) { return w ? w->msg->error : ""; }

/* ------------------------------------------------------------------------------------------ */
/* Bodies */

void defsim_body_def_init(defsim_body_def *def, size_t size)
{
    if (!def || size < sizeof(uint32_t)) return;
    defsim_body_def d;
    memset(&d, 0, sizeof d);
    d.size = (uint32_t)sizeof d;
    defsim_material_init(&d.material, sizeof d.material, DEFSIM_MODEL_STABLE_NEOHOOKEAN);
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
    if (!w) return DEFSIM_ERR_INVALID_ARGUMENT;
    if (defsim__world_check_unlocked(w) != DEFSIM_OK) return DEFSIM_ERR_LOCKED;
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
    defsim_status st = defsim__material_check(&d.material, d.tet_count > 0, d.spring_count > 0,
                                              msg, sizeof msg);
    if (st != DEFSIM_OK) {
        defsim__error(w->msg, "add_body: %s", msg);
        return st;
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
    b.rest = malloc(3 * (size_t)nv * sizeof *b.rest);
    b.mass = calloc((size_t)nv, sizeof *b.mass);
    b.pinned = calloc((size_t)nv, 1);
    b.tets = malloc((size_t)(nt > 0 ? nt : 1) * 4 * sizeof *b.tets);
    b.springs = malloc((size_t)(ns > 0 ? ns : 1) * 2 * sizeof *b.springs);
    b.k = malloc((size_t)(ns > 0 ? ns : 1) * sizeof *b.k);
    if (!b.rest || !b.mass || !b.pinned || !b.tets || !b.springs || !b.k) {
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
        if (!isfinite(k) || k < 0.0) {
            defsim__error(w->msg, "add_body: spring %d stiffness %g must be finite and >= 0",
                          (int)s, k);
            st = DEFSIM_ERR_INVALID_MATERIAL;
            goto fail;
        }
        b.k[s] = k;
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

    if (w->nbodies == w->cap_bodies) {
        int32_t cap = w->cap_bodies ? 2 * w->cap_bodies : 8;
        defsim__body *nb = realloc(w->bodies, (size_t)cap * sizeof *nb);
        if (!nb) { st = DEFSIM_ERR_OUT_OF_MEMORY; defsim__error(w->msg, "out of memory"); goto fail; }
        w->bodies = nb;
        w->cap_bodies = cap;
    }
    int32_t *old = malloc(((size_t)w->nbodies + 1) * sizeof *old);
    if (!old) { st = DEFSIM_ERR_OUT_OF_MEMORY; defsim__error(w->msg, "out of memory"); goto fail; }
    for (int32_t i = 0; i < w->nbodies; ++i) old[i] = w->bodies[i].offset;
    old[w->nbodies] = -1;
    b.generation = 1;
    w->bodies[w->nbodies++] = b;
    st = rebuild_vertices(w, old, d.initial_positions ? d.initial_positions : d.rest_positions,
                          d.initial_velocities);
    free(old);
    if (st != DEFSIM_OK) {
        w->nbodies--;
        defsim__error(w->msg, "out of memory");
        goto fail;
    }
    w->stats.reordered_tets += reordered;
    if (out) {
        out->index = (uint32_t)w->nbodies;
        out->generation = 1;
    }
    return DEFSIM_OK;
fail:
    body_free(&b);
    return st;
}

static defsim__body *lookup(const defsim_world *w, defsim_body_id id)
{
    if (id.index == 0 || id.index > (uint32_t)w->nbodies) return NULL;
    defsim__body *b = &w->bodies[id.index - 1];
    if (b->generation != id.generation || !(b->generation & 1u)) return NULL;
    return b;
}

defsim__body *defsim__world_body(const defsim_world *w, defsim_body_id id)
{
    defsim__body *b = lookup(w, id);
    if (!b)
        defsim__error(w->msg, "body id {%u, %u} is null, removed or not of this world",
                      (unsigned)id.index, (unsigned)id.generation);
    return b;
}

defsim_status defsim_world_remove_body(defsim_world *w, defsim_body_id id)
{
    if (!w) return DEFSIM_ERR_INVALID_ARGUMENT;
    if (defsim__world_check_unlocked(w) != DEFSIM_OK) return DEFSIM_ERR_LOCKED;
    defsim__body *b = defsim__world_body(w, id);
    if (!b) return DEFSIM_ERR_STALE_ID;
    int32_t *old = malloc(((size_t)w->nbodies + 1) * sizeof *old);
    if (!old) { defsim__error(w->msg, "out of memory"); return DEFSIM_ERR_OUT_OF_MEMORY; }
    for (int32_t i = 0; i < w->nbodies; ++i) old[i] = w->bodies[i].offset;
    b->generation++;
    defsim_status st = rebuild_vertices(w, old, NULL, NULL);
    free(old);
    if (st != DEFSIM_OK) {
        b->generation--;
        defsim__error(w->msg, "out of memory");
        return st;
    }
    defsim__coupling_drop_body(w, (int32_t)(b - w->bodies));
    body_free(b);
    return DEFSIM_OK;
}

int32_t defsim_body_vertex_count(const defsim_world *w, defsim_body_id id)
{
    if (!w) return DEFSIM_ERR_INVALID_ARGUMENT;
    const defsim__body *b = lookup(w, id);
    return b ? b->nv : DEFSIM_ERR_STALE_ID;
}

int32_t defsim_body_vertex_offset(const defsim_world *w, defsim_body_id id)
{
    if (!w) return DEFSIM_ERR_INVALID_ARGUMENT;
    const defsim__body *b = lookup(w, id);
    return b ? b->offset : DEFSIM_ERR_STALE_ID;
}

static defsim_status set_pins(defsim_world *w, defsim_body_id id, const int32_t *verts,
                              int32_t n, uint8_t value)
{
    if (!w) return DEFSIM_ERR_INVALID_ARGUMENT;
    if (defsim__world_check_unlocked(w) != DEFSIM_OK) return DEFSIM_ERR_LOCKED;
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

/* ------------------------------------------------------------------------------------------ */
/* State */

int32_t defsim_world_vertex_count(const defsim_world *w) { return w ? w->nv : 0; }
double defsim_world_time(const defsim_world *w) { return w ? w->state.t : 0.0; }

static defsim_status copy_out(const defsim_world *w, const double *src, int width, double *out,
                              int32_t n)
{
    if (!w || !out) return DEFSIM_ERR_INVALID_ARGUMENT;
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
    return copy_out(w, w ? w->state.x : NULL, 3, out, n);
}

defsim_status defsim_world_get_velocities(const defsim_world *w, double *out, int32_t n)
{
    return copy_out(w, w ? w->state.v : NULL, 3, out, n);
}

defsim_status defsim_world_get_masses(const defsim_world *w, double *out, int32_t n)
{
    return copy_out(w, w ? w->mass : NULL, 1, out, n);
}

defsim_status defsim_world_set_state(defsim_world *w, const double *x, const double *v)
{
    if (!w) return DEFSIM_ERR_INVALID_ARGUMENT;
    if (defsim__world_check_unlocked(w) != DEFSIM_OK) return DEFSIM_ERR_LOCKED;
    const int64_t ndof = 3 * (int64_t)w->nv;
    for (int64_t i = 0; i < ndof; ++i)
        if ((x && !isfinite(x[i])) || (v && !isfinite(v[i]))) {
            defsim__error(w->msg, "set_state: DOF %lld is not finite", (long long)i);
            return DEFSIM_ERR_INVALID_ARGUMENT;
        }
    if (x) memcpy(w->state.x, x, (size_t)ndof * sizeof *x);
    if (v) memcpy(w->state.v, v, (size_t)ndof * sizeof *v);
    w->h_stable = 0.0;
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
    if (!w || !out) return DEFSIM_ERR_INVALID_ARGUMENT;
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
            .attachments = w->att, .nattachments = w->natt};
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
    return DEFSIM_OK;
}

defsim_status defsim_world_forces(defsim_world *w, const double *x, double *f_out)
{
    if (!w || !f_out) return DEFSIM_ERR_INVALID_ARGUMENT;
    defsim_status st = defsim__world_plan(w);
    if (st != DEFSIM_OK) return st;
    const double t0 = defsim__now();
    (void)defsim__forces(&w->sys, x ? x : w->state.x, NULL,
                         DEFSIM_FORCE_ELASTIC | DEFSIM__FORCE_KEEP_PINNED, f_out, NULL);
    w->stats.force_evals++;
    w->stats.time_forces += defsim__now() - t0;
    return DEFSIM_OK;
}

defsim_status defsim_world_stats(const defsim_world *w, defsim_stats *out)
{
    if (!w || !out || out->size < sizeof(uint32_t)) return DEFSIM_ERR_INVALID_ARGUMENT;
    size_t n = out->size < sizeof w->stats ? out->size : sizeof w->stats;
    uint32_t size = out->size;
    memcpy(out, &w->stats, n);
    out->size = size;
    return DEFSIM_OK;
}

void defsim_world_reset_stats(defsim_world *w)
{
    if (!w) return;
    defsim_stats s;
    memset(&s, 0, sizeof s);
    s.size = sizeof s;
    s.passes = w->stats.passes;
    s.threads = w->stats.threads;
    s.reordered_tets = w->stats.reordered_tets;
    w->stats = s;
    defsim__options_reset_counters(&w->options);
}

/* ------------------------------------------------------------------------------------------ */
/* Stability */

static defsim_status estimate_stable_step(defsim_world *w, double *h, double *omega)
{
    double om = 0.0;
    defsim_status st = defsim__omega_max(&w->sys, &w->work, w->state.x, &om);
    if (st != DEFSIM_OK) {
        defsim__error(w->msg, st == DEFSIM_ERR_OUT_OF_MEMORY ? "out of memory"
                                                              : "stable step: non-finite stiffness");
        return st;
    }
    const double c = defsim__damping_coeff(&w->sys, om);
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
    if (!w) return DEFSIM_ERR_INVALID_ARGUMENT;
    defsim_status st = defsim__world_plan(w);
    if (st != DEFSIM_OK) return st;
    double h = INFINITY, om = 0.0;
    if (w->nv > 0 && (st = estimate_stable_step(w, &h, &om)) != DEFSIM_OK) return st;
    if (h_out) *h_out = h;
    if (omega_out) *omega_out = om;
    return DEFSIM_OK;
}

/* ------------------------------------------------------------------------------------------ */
/* Stepping */

defsim_status defsim_world_step(defsim_world *w, double h)
{
    if (!w) return DEFSIM_ERR_INVALID_ARGUMENT;
    if (defsim__world_check_unlocked(w) != DEFSIM_OK) return DEFSIM_ERR_LOCKED;
    if (!isfinite(h) || !(h > 0.0)) {
        defsim__error(w->msg, "step: h = %g must be finite and > 0", h);
        return DEFSIM_ERR_INVALID_ARGUMENT;
    }
    double t0 = defsim__now();
    defsim_status st = defsim__world_plan(w);
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
    if (!w->backend_ready) {
        st = w->backend->init(&defsim__host, &w->handle, w->bstate);
        if (st != DEFSIM_OK) {
            w->backend->fini(&defsim__host, &w->handle, w->bstate);
            memset(w->bstate, 0, w->backend->state_size);
            if (!w->msg->error[0]) defsim__error(w->msg, "backend %s failed to initialise", w->backend->name);
            w->stats.failed_steps++;
            return st;
        }
        w->backend_ready = 1;
    }
    const size_t bytes = 3 * (size_t)w->nv * sizeof(double);
    memcpy(w->x_save, w->state.x, bytes);
    memcpy(w->v_save, w->state.v, bytes);
    w->step_passes = 0;
    w->msg->error[0] = '\0';
    const int substep = defsim__options_auto_substep(&w->options) &&
                        (w->backend->stable_step || w->backend->stable_step_options);
    st = defsim__coupling_step_begin(w, h);
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
    if (st == DEFSIM_OK) {
        const int64_t ndof = 3 * (int64_t)w->nv;
        int ok = 1;
        for (int64_t i = 0; i < ndof; ++i) ok &= isfinite(w->state.x[i]) & isfinite(w->state.v[i]);
        if (!ok) {
            st = DEFSIM_ERR_UNSTABLE;
            defsim__error(w->msg, "step: the state became non-finite (h = %g at t = %g); "
                                  "state restored", h, w->state.t);
        }
    }
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
    if (!w) return DEFSIM_ERR_INVALID_ARGUMENT;
    return options_changed(w, defsim__options_set_text(&w->options, w->msg, name, value));
}

defsim_status defsim_world_set_option_number(defsim_world *w, const char *name, double value)
{
    if (!w) return DEFSIM_ERR_INVALID_ARGUMENT;
    return options_changed(w, defsim__options_set_number(&w->options, w->msg, name, value));
}

defsim_status defsim_world_get_option(const defsim_world *w, const char *name, double *value)
{
    return w ? defsim__options_get(&w->options, w->msg, name, value) : DEFSIM_ERR_INVALID_ARGUMENT;
}

int32_t defsim_world_option_count(const defsim_world *w)
{
    return w ? defsim__options_count(&w->options) : 0;
}

defsim_status defsim_world_option_info(const defsim_world *w, int32_t i, defsim_option_info *out)
{
    return w ? defsim__options_info(&w->options, i, out) : DEFSIM_ERR_INVALID_ARGUMENT;
}

int32_t defsim_world_stat_count(const defsim_world *w)
{
    return w ? defsim__options_stat_count(&w->options) : 0;
}

defsim_status defsim_world_stat_info(const defsim_world *w, int32_t i, const char **name,
                                     double *value)
{
    return w ? defsim__options_stat_info(&w->options, &w->stats, i, name, value)
             : DEFSIM_ERR_INVALID_ARGUMENT;
}

defsim_status defsim_world_stat(const defsim_world *w, const char *name, double *value)
{
    return w ? defsim__options_stat(&w->options, w->msg, &w->stats, name, value)
             : DEFSIM_ERR_INVALID_ARGUMENT;
}
