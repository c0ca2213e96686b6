/* SPDX-License-Identifier: MIT */
/*
 * Colliders: validation of the host's defs, and poses (quaternions, their interpolation over a
 * step). The public API is in collider_api.c, the shapes' geometry in collider_shape.c and
 * collider_mesh.c.
 */
#include "collider.h"
#include "mesh.h"

#include <float.h>
#include <math.h>
#include <stddef.h>
#include <stdlib.h>
#include <string.h>

/* ------------------------------------------------------------------------------------------ */
/* Poses */

void defsim__pose_set(defsim__pose *pose, const double p[3], const double q[4])
{
    const double w = q[0], x = q[1], y = q[2], z = q[3];
    for (int k = 0; k < 3; ++k) pose->p[k] = p[k];
    for (int k = 0; k < 4; ++k) pose->q[k] = q[k];
    double *R = pose->R;
    R[0] = 1 - 2 * (y * y + z * z); R[1] = 2 * (x * y - w * z);     R[2] = 2 * (x * z + w * y);
    R[3] = 2 * (x * y + w * z);     R[4] = 1 - 2 * (x * x + z * z); R[5] = 2 * (y * z - w * x);
    R[6] = 2 * (x * z - w * y);     R[7] = 2 * (y * z + w * x);     R[8] = 1 - 2 * (x * x + y * y);
}

void defsim__collider_pose_at(const defsim__collider *c, double s, defsim__pose *out)
{
    double p[3], q[4];
    for (int k = 0; k < 3; ++k) p[k] = s >= 1.0 ? c->pos1[k] : c->pos[k] + s * (c->pos1[k] - c->pos[k]);
    const double *q0 = c->rot, *q1 = c->rot1;
    double dot = q0[0] * q1[0] + q0[1] * q1[1] + q0[2] * q1[2] + q0[3] * q1[3];
    const double sign = dot < 0.0 ? -1.0 : 1.0;   /* the shortest arc */
    dot *= sign;
    if (s <= 0.0) {
        memcpy(q, q0, sizeof q);
    } else if (s >= 1.0) {
        memcpy(q, q1, sizeof q);
    } else {
        double a = 1.0 - s, b = s * sign;
        if (dot < 1.0 - 1e-12) {
            const double th = acos(dot > 1.0 ? 1.0 : dot), sn = sin(th);
            a = sin((1.0 - s) * th) / sn;
            b = sin(s * th) / sn * sign;
        }
        double n = 0.0;
        for (int k = 0; k < 4; ++k) {
            q[k] = a * q0[k] + b * q1[k];
            n += q[k] * q[k];
        }
        n = sqrt(n);
        for (int k = 0; k < 4; ++k) q[k] /= n;
    }
    defsim__pose_set(out, p, q);
}

/* ------------------------------------------------------------------------------------------ */
/* Validation */

static int all_finite(const double *a, int n)
{
    for (int i = 0; i < n; ++i)
        if (!isfinite(a[i])) return 0;
    return 1;
}

/* Normalises a quaternion within 1e-6 of unit length; returns 0 for any other. */
int defsim__unit_quaternion(const double *in, double out[4])
{
    if (!all_finite(in, 4)) return 0;
    const double n = sqrt(in[0] * in[0] + in[1] * in[1] + in[2] * in[2] + in[3] * in[3]);
    if (!(fabs(n - 1.0) <= 1e-6)) return 0;
    for (int k = 0; k < 4; ++k) out[k] = in[k] / n;
    return 1;
}

void defsim_collider_def_init(defsim_collider_def *def, size_t size)
{
    if (!def || size < sizeof(uint32_t)) return;
    defsim_collider_def d;
    memset(&d, 0, sizeof d);
    d.size = (uint32_t)sizeof d;
    d.shape = DEFSIM_SHAPE_PLANE;
    d.rotation[0] = 1.0;
    d.normal[1] = 1.0;
    d.radius = 0.5;
    for (int k = 0; k < 3; ++k) d.half_extents[k] = 0.5;
    d.half_height = 0.5;
    if (size > sizeof d) size = sizeof d;
    memcpy(def, &d, size);
    def->size = (uint32_t)size;
}

#define BAD(...) do { defsim__error(msg, __VA_ARGS__); return DEFSIM_ERR_INVALID_ARGUMENT; } while (0)

/* A radius, half extent or half height: a positive normal number (a denormal's square is zero)
 * within the coordinate bound (its square and the bounds stay finite). */
static int size_ok(double r) { return isnormal(r) && r > 0.0 && r <= DEFSIM__COORD_MAX; }

defsim_status defsim__collider_make(defsim__messages *msg, const defsim_collider_def *def,
                                    defsim__collider *c)
{
    memset(c, 0, sizeof *c);
    if (!def || def->size < offsetof(defsim_collider_def, friction) + sizeof(double))
        BAD("add_collider: def is NULL or def->size is too small (use defsim_collider_def_init)");
    defsim_collider_def *d = &c->def;
    defsim_collider_def_init(d, sizeof *d);
    memcpy(d, def, def->size < sizeof *d ? def->size : sizeof *d);
    d->size = sizeof *d;
    if ((unsigned)d->shape > (unsigned)DEFSIM_SHAPE_SDF)
        BAD("add_collider: unknown shape %d", (int)d->shape);
    if (!defsim__collider_coords_ok(d->position, 3))
        BAD("add_collider: position (%g, %g, %g) must be finite and within +-%g m (the "
            "coordinate bound: distances would overflow)", d->position[0], d->position[1],
            d->position[2], DEFSIM__COORD_MAX);
    if (!defsim__unit_quaternion(def->rotation, d->rotation))
        BAD("add_collider: rotation (%g, %g, %g, %g) is not a unit quaternion (w, x, y, z) "
            "within 1e-6", def->rotation[0], def->rotation[1], def->rotation[2],
            def->rotation[3]);
    if (d->normalized != 0 && d->normalized != 1)
        BAD("add_collider: normalized %d must be 0 or 1", (int)d->normalized);
    if (d->normalized) memcpy(d->rotation, def->rotation, sizeof d->rotation);
    if (!isfinite(d->friction) || d->friction < 0.0)
        BAD("add_collider: friction %g must be finite and >= 0", d->friction);
    switch (d->shape) {
    case DEFSIM_SHAPE_PLANE: {
        const double n = sqrt(d->normal[0] * d->normal[0] + d->normal[1] * d->normal[1] +
                              d->normal[2] * d->normal[2]);
        if (!all_finite(d->normal, 3) || !(n > 0.0) || !isfinite(n))
            BAD("add_collider: plane normal (%g, %g, %g) must be finite and not zero",
                d->normal[0], d->normal[1], d->normal[2]);
        if (d->normalized && !(fabs(n - 1.0) <= 1e-6))
            BAD("add_collider: normalized is 1 but the plane normal's length is %.17g", n);
        if (!d->normalized)
            for (int k = 0; k < 3; ++k) d->normal[k] /= n;
        break;
    }
    case DEFSIM_SHAPE_SPHERE:
        if (!size_ok(d->radius))
            BAD("add_collider: sphere radius %g must be in [%g, %g] m (a positive normal number "
                "within the coordinate bound)", d->radius, DBL_MIN, DEFSIM__COORD_MAX);
        break;
    case DEFSIM_SHAPE_BOX:
        for (int k = 0; k < 3; ++k)
            if (!size_ok(d->half_extents[k]))
                BAD("add_collider: box half_extents (%g, %g, %g) must each be in [%g, %g] m (a "
                    "positive normal number within the coordinate bound)", d->half_extents[0],
                    d->half_extents[1], d->half_extents[2], DBL_MIN, DEFSIM__COORD_MAX);
        break;
    case DEFSIM_SHAPE_CAPSULE:
        if (!size_ok(d->radius))
            BAD("add_collider: capsule radius %g must be in [%g, %g] m (a positive normal number "
                "within the coordinate bound)", d->radius, DBL_MIN, DEFSIM__COORD_MAX);
        if (d->half_height != 0.0 && !size_ok(d->half_height))
            BAD("add_collider: capsule half_height %g must be 0 or in [%g, %g] m", d->half_height,
                DBL_MIN, DEFSIM__COORD_MAX);
        break;
    case DEFSIM_SHAPE_MESH: {
        defsim_status st = defsim__mesh_check(msg, d);
        if (st != DEFSIM_OK) return st;
        const size_t nx = 3 * (size_t)d->vertex_count, nt = 3 * (size_t)d->triangle_count;
        c->mesh_x = malloc(nx * sizeof *c->mesh_x);
        c->mesh_t = malloc(nt * sizeof *c->mesh_t);
        if (!c->mesh_x || !c->mesh_t) {
            defsim__collider_free(c);
            defsim__error(msg, "out of memory");
            return DEFSIM_ERR_OUT_OF_MEMORY;
        }
        memcpy(c->mesh_x, d->vertices, nx * sizeof *c->mesh_x);
        memcpy(c->mesh_t, d->triangles, nt * sizeof *c->mesh_t);
        d->vertices = c->mesh_x;
        d->triangles = c->mesh_t;
        if ((st = defsim__mesh_build(c)) != DEFSIM_OK) {
            defsim__collider_free(c);
            defsim__error(msg, "out of memory");
            return st;
        }
        break;
    }
    case DEFSIM_SHAPE_SDF: {
        if (!d->sdf) BAD("add_collider: an SDF collider needs its callback sdf (NULL given)");
        if (!defsim__collider_coords_ok(d->sdf_bounds, 6))
            BAD("add_collider: sdf_bounds must be finite and within +-%g m (the coordinate "
                "bound)", DEFSIM__COORD_MAX);
        int any = 0;
        for (int k = 0; k < 6; ++k) any |= d->sdf_bounds[k] != 0.0;
        for (int k = 0; any && k < 3; ++k)
            if (!(d->sdf_bounds[k] <= d->sdf_bounds[3 + k]))
                BAD("add_collider: sdf_bounds lo (%g, %g, %g) must not exceed hi (%g, %g, %g)",
                    d->sdf_bounds[0], d->sdf_bounds[1], d->sdf_bounds[2], d->sdf_bounds[3],
                    d->sdf_bounds[4], d->sdf_bounds[5]);
        break;
    }
    }
    memcpy(c->pos, d->position, sizeof c->pos);
    memcpy(c->rot, d->rotation, sizeof c->rot);
    memcpy(c->pos1, c->pos, sizeof c->pos);
    memcpy(c->rot1, c->rot, sizeof c->rot);
    return DEFSIM_OK;
}

void defsim__collider_free(defsim__collider *c)
{
    defsim__mesh_free(c);
    free(c->mesh_x);
    free(c->mesh_t);
    c->mesh_x = NULL;
    c->mesh_t = NULL;
}

/* ------------------------------------------------------------------------------------------ */
/* The world's set of colliders */

int32_t defsim__collider_set_live(const defsim__collider_set *s)
{
    int32_t n = 0;
    for (int32_t i = 0; i < s->ncol; ++i) n += (s->col[i].generation & 1u) != 0;
    return n;
}

defsim_status defsim__collider_set_readback(defsim__collider_set *s, int32_t nv,
                                            defsim__messages *msg)
{
    free(s->force);
    s->force_nv = 0;
    s->force = calloc(3 * (size_t)nv, sizeof *s->force);
    if (!s->force) {
        defsim__error(msg, "out of memory for the contact forces");
        return DEFSIM_ERR_OUT_OF_MEMORY;
    }
    s->force_nv = nv;
    return DEFSIM_OK;
}

void defsim__collider_set_free(defsim__collider_set *s)
{
    for (int32_t i = 0; i < s->ncol; ++i)
        if (s->col[i].generation & 1u) defsim__collider_free(&s->col[i]);
    free(s->col);
    free(s->force);
    defsim__id_pool_free(&s->ids);
    memset(s, 0, sizeof *s);
}

/* ------------------------------------------------------------------------------------------ */
/* Checkpoint chunks */

void defsim__collider_set_save(defsim__bw *b, const defsim__collider_set *s, int32_t nv)
{
    for (int32_t i = 0; i < s->ncol; ++i) {
        const defsim__collider *c = &s->col[i];
        if (!(c->generation & 1u)) continue;
        const defsim_collider_def *d = &c->def;
        const size_t at = defsim__chunk_begin(b, "COLL");
        defsim__put_i32(b, (int32_t)d->shape);
        defsim__put_f64s(b, c->pos, 3);
        defsim__put_f64s(b, c->rot, 4);
        defsim__put_f64s(b, c->pos1, 3);
        defsim__put_f64s(b, c->rot1, 4);
        defsim__put_f64s(b, d->normal, 3);
        defsim__put_f64(b, d->radius);
        defsim__put_f64s(b, d->half_extents, 3);
        defsim__put_f64(b, d->half_height);
        defsim__put_f64(b, d->friction);
        defsim__put_f64s(b, d->sdf_bounds, 6);
        const int mesh = d->shape == DEFSIM_SHAPE_MESH;
        defsim__put_i32(b, mesh ? d->vertex_count : 0);
        defsim__put_i32(b, mesh ? d->triangle_count : 0);
        if (mesh) {
            defsim__put_f64s(b, d->vertices, 3 * (int64_t)d->vertex_count);
            defsim__put_i32s(b, d->triangles, 3 * (int64_t)d->triangle_count);
        }
        defsim__chunk_end(b, at);
    }
    const int forces = s->force && s->force_nv == nv;
    if (s->ncol > 0 || forces) {
        const size_t at = defsim__chunk_begin(b, "CFRC");
        defsim__put_i32(b, s->changed);
        defsim__put_i32(b, forces);
        if (forces) defsim__put_f64s(b, s->force, 3 * (int64_t)nv);
        defsim__chunk_end(b, at);
    }
}

void defsim__collider_saved_free(defsim__collider_saved *s)
{
    free(s->vertices);
    free(s->triangles);
    s->vertices = NULL;
    s->triangles = NULL;
}

defsim_status defsim__collider_read(defsim__br *r, defsim__collider_saved *out, const char **why)
{
    memset(out, 0, sizeof *out);
    defsim_collider_def *d = &out->def;
    defsim_collider_def_init(d, sizeof *d);
    d->shape = (defsim_shape)defsim__get_i32(r);
    defsim__get_f64s(r, d->position, 3);
    defsim__get_f64s(r, d->rotation, 4);
    defsim__get_f64s(r, out->pos1, 3);
    defsim__get_f64s(r, out->rot1, 4);
    defsim__get_f64s(r, d->normal, 3);
    d->radius = defsim__get_f64(r);
    defsim__get_f64s(r, d->half_extents, 3);
    d->half_height = defsim__get_f64(r);
    d->friction = defsim__get_f64(r);
    defsim__get_f64s(r, d->sdf_bounds, 6);
    const int32_t nv = defsim__get_i32(r), nt = defsim__get_i32(r);
    if (nv < 0 || nt < 0 || !defsim__fits(r, nv, 24) || !defsim__fits(r, nt, 12)) {
        *why = "mesh counts out of range";
        return DEFSIM_ERR_IO;
    }
    out->vertices = malloc(3 * (size_t)(nv + 1) * sizeof *out->vertices);
    out->triangles = malloc(3 * (size_t)(nt + 1) * sizeof *out->triangles);
    if (!out->vertices || !out->triangles) return DEFSIM_ERR_OUT_OF_MEMORY;
    defsim__get_f64s(r, out->vertices, 3 * (int64_t)nv);
    defsim__get_i32s(r, out->triangles, 3 * (int64_t)nt);
    if (!defsim__read_whole(r) || !all_finite(out->rot1, 4)) {
        *why = "wrong length or a bad pose";
        return DEFSIM_ERR_IO;
    }
    d->vertices = out->vertices;
    d->vertex_count = nv;
    d->triangles = out->triangles;
    d->triangle_count = nt;
    return DEFSIM_OK;
}

void defsim__collider_restore(defsim__collider *c, const defsim__collider_saved *saved)
{
    const defsim_collider_def *d = &saved->def;
    memcpy(c->pos, d->position, sizeof c->pos);
    memcpy(c->rot, d->rotation, sizeof c->rot);
    memcpy(c->pos1, saved->pos1, sizeof c->pos1);
    memcpy(c->rot1, saved->rot1, sizeof c->rot1);
    memcpy(c->def.position, d->position, sizeof d->position);
    memcpy(c->def.rotation, d->rotation, sizeof d->rotation);
    memcpy(c->def.normal, d->normal, sizeof d->normal);
}

defsim_status defsim__collider_set_load_forces(defsim__collider_set *s, defsim__br *r,
                                               int32_t nv)
{
    const int32_t changed = defsim__get_i32(r), forces = defsim__get_i32(r);
    if (r->n != 8 + (forces ? 24 * (size_t)nv : 0) || (changed != 0 && changed != 1) ||
        (forces != 0 && forces != 1))
        return DEFSIM_ERR_IO;
    s->changed = changed;
    if (!forces) return DEFSIM_OK;
    double *f = malloc(3 * (size_t)(nv > 0 ? nv : 1) * sizeof *f);
    if (!f) return DEFSIM_ERR_OUT_OF_MEMORY;
    defsim__get_f64s(r, f, 3 * (int64_t)nv);
    free(s->force);
    s->force = f;
    s->force_nv = nv;
    s->force_zero = 0;
    return DEFSIM_OK;
}
