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

static defsim__collider *collider_or_error(const defsim_world *w, defsim_collider_id id)
{
    const int64_t slot =
        defsim__id_pool_lookup(&w->colliders.ids, w->msg, "collider", id.index, id.generation);
    return slot < 0 ? NULL : &w->colliders.col[slot];
}

defsim_status defsim_world_add_collider(defsim_world *w, const defsim_collider_def *def,
                                        defsim_collider_id *out)
{
    defsim_status st = defsim__world_enter(w);
    if (st != DEFSIM_OK) return st;
    defsim__collider c;
    if ((st = defsim__collider_make(w->msg, def, &c)) != DEFSIM_OK) return st;
    int32_t slot;
    defsim__collider *col = defsim__id_pool_add(&w->colliders.ids, w->msg, "colliders",
                                                w->colliders.col, sizeof *col, &w->colliders.ncol,
                                                &w->colliders.cap_col, &slot);
    if (!col) {
        defsim__collider_free(&c);
        return DEFSIM_ERR_OUT_OF_MEMORY;
    }
    w->colliders.col = col;
    c.generation = defsim__id_pool_take(&w->colliders.ids, slot, slot);
    w->colliders.col[slot] = c;
    w->colliders.changed = 1;
    if (out) {
        out->index = defsim__id_pool_index(&w->colliders.ids, slot);
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
    defsim__id_pool_remove(&w->colliders.ids, (int32_t)(c - w->colliders.col), &c->generation);
    w->colliders.changed = 1;
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
    return defsim__world_live(w) ? defsim__collider_set_live(&w->colliders) : 0;
}

defsim_status defsim_world_get_collider(const defsim_world *w, int32_t i, defsim_collider_id *id,
                                        defsim_collider_def *def)
{
    if (!defsim__world_live(w)) return DEFSIM_ERR_INVALID_ARGUMENT;
    if (def && def->size < offsetof(defsim_collider_def, friction) + sizeof(double)) {
        defsim__error(w->msg, "get_collider: def->size is too small");
        return DEFSIM_ERR_INVALID_ARGUMENT;
    }
    for (int32_t s = 0, n = 0; s < w->colliders.ncol; ++s) {
        const defsim__collider *c = &w->colliders.col[s];
        if (!(c->generation & 1u) || n++ != i) continue;
        if (id) {
            id->index = defsim__id_pool_index(&w->colliders.ids, s);
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
    if (w->colliders.force && w->colliders.force_nv == n)
        memcpy(out, w->colliders.force, (size_t)ndof * sizeof *out);
    else
        memset(out, 0, (size_t)ndof * sizeof *out);
    return DEFSIM_OK;
}
