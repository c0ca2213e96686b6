/* SPDX-License-Identifier: MIT */
/* Colliders: the public API (add, remove, pose, listing, contact-force read-back). */
#include "collider.h"
#include "mesh.h"
#include "world.h"

#include <math.h>
#include <stddef.h>
#include <stdlib.h>
#include <string.h>

/* ------------------------------------------------------------------------------------------ */
/* The public API */

static defsim__collider *collider(const defsim_world *w, defsim_collider_id id)
{
    const int64_t slot = defsim__world_id_slot(w, id.index);
    if (slot < 0 || slot >= w->ncol) return NULL;
    defsim__collider *c = &w->col[slot];
    return c->generation == id.generation && (c->generation & 1u) ? c : NULL;
}

static defsim__collider *collider_or_error(const defsim_world *w, defsim_collider_id id)
{
    defsim__collider *c = collider(w, id);
    if (!c)
        defsim__error(w->msg, "collider id {%u, %u} is %s", (unsigned)id.index,
                      (unsigned)id.generation,
                      defsim__world_id_problem(w, id.index, id.generation));
    return c;
}

defsim_status defsim_world_add_collider(defsim_world *w, const defsim_collider_def *def,
                                        defsim_collider_id *out)
{
    defsim_status st = defsim__world_enter(w);
    if (st != DEFSIM_OK) return st;
    defsim__collider c;
    if ((st = defsim__collider_make(w->msg, def, &c)) != DEFSIM_OK) return st;
    int32_t slot = 0;
    while (slot < w->ncol && (w->col[slot].generation & 1u)) ++slot;
    if (slot == DEFSIM__ID_MAX_SLOTS) {
        defsim__collider_free(&c);
        defsim__error(w->msg, "add_collider: the world holds %d colliders, the most it can",
                      (int)DEFSIM__ID_MAX_SLOTS);
        return DEFSIM_ERR_OUT_OF_MEMORY;
    }
    if (slot == w->ncol && w->ncol == w->cap_col) {
        const int32_t cap = w->cap_col ? 2 * w->cap_col : 4;
        defsim__collider *nc = realloc(w->col, (size_t)cap * sizeof *nc);
        if (!nc) {
            defsim__collider_free(&c);
            defsim__error(w->msg, "out of memory");
            return DEFSIM_ERR_OUT_OF_MEMORY;
        }
        w->col = nc;
        w->cap_col = cap;
    }
    if (slot == w->ncol) w->col[w->ncol++].generation = 0;
    c.generation = w->col[slot].generation + 1;
    w->col[slot] = c;
    w->colliders_changed = 1;
    if (out) {
        out->index = defsim__world_id_index(w, slot);
        out->generation = c.generation;
    }
    return DEFSIM_OK;
}

defsim_status defsim_world_remove_collider(defsim_world *w, defsim_collider_id id)
{
    defsim_status st = defsim__world_enter(w);
    if (st != DEFSIM_OK) return st;
    defsim__collider *c = collider_or_error(w, id);
    if (!c) return DEFSIM_ERR_STALE_ID;
    defsim__collider_free(c);
    c->generation++;
    w->colliders_changed = 1;
    return DEFSIM_OK;
}

defsim_status defsim_collider_set_pose(defsim_world *w, defsim_collider_id id,
                                       const double position[3], const double rotation[4])
{
    defsim_status st = defsim__world_enter(w);
    if (st != DEFSIM_OK) return st;
    defsim__collider *c = collider_or_error(w, id);
    if (!c) return DEFSIM_ERR_STALE_ID;
    double q[4];
    if (!position || !rotation || !defsim__unit_quaternion(rotation, q)) {
        defsim__error(w->msg, "collider_set_pose: position and rotation must not be NULL and the "
                      "rotation must be a unit quaternion (w, x, y, z) within 1e-6");
        return DEFSIM_ERR_INVALID_ARGUMENT;
    }
    if (!defsim__collider_coords_ok(position, 3)) {
        defsim__error(w->msg, "collider_set_pose: position (%g, %g, %g) must be finite and within "
                      "+-%g m (the coordinate bound: distances would overflow)", position[0],
                      position[1], position[2], DEFSIM__COORD_MAX);
        return DEFSIM_ERR_INVALID_ARGUMENT;
    }
    memcpy(c->pos1, position, sizeof c->pos1);
    memcpy(c->rot1, q, sizeof c->rot1);
    return DEFSIM_OK;
}

int32_t defsim_world_collider_count(const defsim_world *w)
{
    if (!defsim__world_live(w)) return 0;
    int32_t n = 0;
    for (int32_t i = 0; i < w->ncol; ++i) n += (w->col[i].generation & 1u) != 0;
    return n;
}

defsim_status defsim_world_get_collider(const defsim_world *w, int32_t i, defsim_collider_id *id,
                                        defsim_collider_def *def)
{
    if (!defsim__world_live(w)) return DEFSIM_ERR_INVALID_ARGUMENT;
    if (def && def->size < offsetof(defsim_collider_def, friction) + sizeof(double)) {
        defsim__error(w->msg, "get_collider: def->size is too small");
        return DEFSIM_ERR_INVALID_ARGUMENT;
    }
    for (int32_t s = 0, n = 0; s < w->ncol; ++s) {
        const defsim__collider *c = &w->col[s];
        if (!(c->generation & 1u) || n++ != i) continue;
        if (id) {
            id->index = defsim__world_id_index(w, s);
            id->generation = c->generation;
        }
        if (def) {
            defsim_collider_def d = c->def;
            memcpy(d.position, c->pos, sizeof d.position);
            memcpy(d.rotation, c->rot, sizeof d.rotation);
            const uint32_t size = def->size < sizeof d ? def->size : (uint32_t)sizeof d;
            memcpy(def, &d, size);
            def->size = size;
        }
        return DEFSIM_OK;
    }
    defsim__error(w->msg, "get_collider: index %d out of range [0, %d)", (int)i,
                  (int)defsim_world_collider_count(w));
    return DEFSIM_ERR_INVALID_ARGUMENT;
}

defsim_status defsim_world_get_contact_forces(const defsim_world *w, double *out, int32_t n)
{
    if (!defsim__world_live(w)) return DEFSIM_ERR_INVALID_ARGUMENT;
    if (!out || n != w->nv) {
        defsim__error(w->msg, "get_contact_forces: out is NULL or n = %d but the world has %d "
                      "vertices", (int)n, (int)w->nv);
        return DEFSIM_ERR_INVALID_ARGUMENT;
    }
    const int64_t ndof = 3 * (int64_t)n;
    if (w->contact_force && w->contact_nv == n)
        memcpy(out, w->contact_force, (size_t)ndof * sizeof *out);
    else
        memset(out, 0, (size_t)ndof * sizeof *out);
    return DEFSIM_OK;
}

void defsim__colliders_free(defsim_world *w)
{
    for (int32_t i = 0; i < w->ncol; ++i)
        if (w->col[i].generation & 1u) defsim__collider_free(&w->col[i]);
    free(w->col);
    free(w->contact_force);
    w->col = NULL;
    w->contact_force = NULL;
    w->ncol = w->cap_col = 0;
}
