/* SPDX-License-Identifier: MIT */
/*
 * The geometry of colliders: signed distance with gradient and Hessian, world bounds and a
 * conservative time of impact, per shape. Points are taken to the collider's local frame
 * (R^T (p - c)), measured there, and gradients and Hessians rotated back. Triangle meshes are in
 * collider_mesh.c.
 */
#include "collider.h"

#include <math.h>
#include <string.h>

static void to_local(const defsim__pose *pose, const double p[3], double l[3])
{
    const double *R = pose->R;
    const double d[3] = {p[0] - pose->p[0], p[1] - pose->p[1], p[2] - pose->p[2]};
    for (int i = 0; i < 3; ++i) l[i] = R[i] * d[0] + R[3 + i] * d[1] + R[6 + i] * d[2];
}

static void vec_to_world(const defsim__pose *pose, const double l[3], double g[3])
{
    const double *R = pose->R;
    for (int i = 0; i < 3; ++i) g[i] = R[3 * i] * l[0] + R[3 * i + 1] * l[1] + R[3 * i + 2] * l[2];
}

/* H_world = R H_local R^T */
static void mat_to_world(const defsim__pose *pose, const double hl[9], double h[9])
{
    const double *R = pose->R;
    double t[9];
    for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j)
            t[3 * i + j] = R[3 * i] * hl[j] + R[3 * i + 1] * hl[3 + j] + R[3 * i + 2] * hl[6 + j];
    for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j)
            h[3 * i + j] = t[3 * i] * R[3 * j] + t[3 * i + 1] * R[3 * j + 1] +
                           t[3 * i + 2] * R[3 * j + 2];
}

/* Distance to a ball of radius r about the local origin: Hessian (I - n n^T) / |l|. */
static void ball(const double l[3], double r, double *d, double g[3], double h[9])
{
    const double n = sqrt(l[0] * l[0] + l[1] * l[1] + l[2] * l[2]);
    if (n > 0.0) {
        for (int k = 0; k < 3; ++k) g[k] = l[k] / n;
    } else {
        g[0] = 0.0; g[1] = 1.0; g[2] = 0.0;   /* the centre: any direction is a closest one */
    }
    *d = n - r;
    if (h) {
        const double inv = n > 0.0 ? 1.0 / n : 0.0;
        for (int i = 0; i < 3; ++i)
            for (int j = 0; j < 3; ++j) h[3 * i + j] = ((i == j) - g[i] * g[j]) * inv;
    }
}

/* Distance to a box of half extents e about the local origin. Outside, the distance to the
 * clamped point: its Hessian is (P - n n^T) / d, P the projection on the axes where the point is
 * out of the slab (one axis, a face: zero; two, an edge: like a line; three, a corner: like a
 * point). Inside, the largest (|l_k| - e_k), affine with zero Hessian. */
static void box(const double l[3], const double e[3], double *d, double g[3], double h[9])
{
    double v[3], out = 0.0;
    int outside[3];
    for (int k = 0; k < 3; ++k) {
        const double a = fabs(l[k]) - e[k];
        outside[k] = a > 0.0;
        v[k] = outside[k] ? (l[k] < 0.0 ? -a : a) : 0.0;
        out += v[k] * v[k];
    }
    if (out > 0.0) {
        const double n = sqrt(out);
        *d = n;
        for (int k = 0; k < 3; ++k) g[k] = v[k] / n;
        for (int i = 0; i < 3; ++i)
            for (int j = 0; j < 3; ++j)
                h[3 * i + j] = ((i == j && outside[i]) - g[i] * g[j]) / n;
        return;
    }
    int m = 0;
    for (int k = 1; k < 3; ++k)
        if (fabs(l[k]) - e[k] > fabs(l[m]) - e[m]) m = k;
    *d = fabs(l[m]) - e[m];
    g[0] = g[1] = g[2] = 0.0;
    g[m] = l[m] < 0.0 ? -1.0 : 1.0;
}

/* Distance to the points within r of the segment (0, -hh, 0)..(0, hh, 0): beside the segment
 * like a line along y (Hessian (I - y y^T - n n^T) / |v|), beyond its ends like a point. */
static void capsule(const double l[3], double r, double hh, double *d, double g[3], double h[9])
{
    const double y = l[1] > hh ? hh : l[1] < -hh ? -hh : l[1];
    const double v[3] = {l[0], l[1] - y, l[2]};
    const int side = y == l[1];   /* the closest point is inside the segment */
    const double n = sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
    *d = n - r;
    if (!(n > 0.0)) {
        /* on the axis: any normal of the segment there is a subgradient */
        g[0] = g[1] = g[2] = 0.0;
        if (side && fabs(l[1]) < hh) g[0] = 1.0;
        else g[1] = l[1] < 0.0 ? -1.0 : 1.0;
        return;
    }
    for (int k = 0; k < 3; ++k) g[k] = v[k] / n;
    for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j)
            h[3 * i + j] = ((i == j) - (side && i == 1 && j == 1) - g[i] * g[j]) / n;
}

/* Central-difference step (m) of the Hessian of an SDF collider: small against the features a
 * contact resolves, large against the rounding of a double-precision gradient. */
#define SDF_STEP 1e-5

/* The host's callback, its gradient normalised. CALLBACK for a non-finite value or a gradient of
 * zero length. */
static defsim_status sdf_eval(const defsim__collider *c, const double l[3], double *d,
                              double g[3])
{
    g[0] = g[1] = g[2] = 0.0;
    *d = c->def.sdf(c->def.sdf_user, l, g);
    const double n = sqrt(g[0] * g[0] + g[1] * g[1] + g[2] * g[2]);
    if (!isfinite(*d) || !isfinite(n) || !(n > 0.0)) return DEFSIM_ERR_CALLBACK;
    for (int k = 0; k < 3; ++k) g[k] /= n;
    return DEFSIM_OK;
}

/* Hessian of an SDF: central differences of its unit gradient, symmetrised (6 more calls). */
static defsim_status sdf_hessian(const defsim__collider *c, const double l[3], double h[9])
{
    for (int j = 0; j < 3; ++j) {
        double a[3], b[3], ga[3], gb[3], da, db;
        memcpy(a, l, sizeof a);
        memcpy(b, l, sizeof b);
        a[j] += SDF_STEP;
        b[j] -= SDF_STEP;
        defsim_status st;
        if ((st = sdf_eval(c, a, &da, ga)) != DEFSIM_OK) return st;
        if ((st = sdf_eval(c, b, &db, gb)) != DEFSIM_OK) return st;
        for (int i = 0; i < 3; ++i) h[3 * i + j] = (ga[i] - gb[i]) / (2.0 * SDF_STEP);
    }
    for (int i = 0; i < 3; ++i)
        for (int j = i + 1; j < 3; ++j) h[3 * i + j] = h[3 * j + i] = 0.5 * (h[3 * i + j] + h[3 * j + i]);
    return DEFSIM_OK;
}

defsim_status defsim__collider_distance(const defsim__collider *c, const defsim__pose *pose,
                                        const double p[3], double *d, double grad[3],
                                        double hess[9])
{
    double l[3], gl[3], hl[9];
    to_local(pose, p, l);
    memset(hl, 0, sizeof hl);
    switch (c->def.shape) {
    case DEFSIM_SHAPE_PLANE: {
        const double *n = c->def.normal;
        *d = n[0] * l[0] + n[1] * l[1] + n[2] * l[2];
        memcpy(gl, n, sizeof gl);
        break;
    }
    case DEFSIM_SHAPE_SPHERE:
        ball(l, c->def.radius, d, gl, hl);
        break;
    case DEFSIM_SHAPE_BOX:
        box(l, c->def.half_extents, d, gl, hl);
        break;
    case DEFSIM_SHAPE_CAPSULE:
        capsule(l, c->def.radius, c->def.half_height, d, gl, hl);
        break;
    case DEFSIM_SHAPE_MESH:
        defsim__mesh_distance(c, l, d, gl, hess ? hl : NULL);
        break;
    case DEFSIM_SHAPE_SDF: {
        defsim_status st = sdf_eval(c, l, d, gl);
        if (st == DEFSIM_OK && hess) st = sdf_hessian(c, l, hl);
        if (st != DEFSIM_OK) return st;
        break;
    }
    }
    vec_to_world(pose, gl, grad);
    if (hess) mat_to_world(pose, hl, hess);
    return DEFSIM_OK;
}

/* ------------------------------------------------------------------------------------------ */
/* Bounds */

/* World bounds of the local box lo..hi at the pose: centre moved, half widths |R| w. */
static void box_bounds(const defsim__pose *pose, const double blo[3], const double bhi[3],
                       double margin, double lo[3], double hi[3])
{
    double cl[3], w[3], cw[3];
    for (int k = 0; k < 3; ++k) {
        cl[k] = 0.5 * (blo[k] + bhi[k]);
        w[k] = 0.5 * (bhi[k] - blo[k]);
    }
    vec_to_world(pose, cl, cw);
    const double *R = pose->R;
    for (int i = 0; i < 3; ++i) {
        const double r = fabs(R[3 * i]) * w[0] + fabs(R[3 * i + 1]) * w[1] + fabs(R[3 * i + 2]) * w[2];
        lo[i] = pose->p[i] + cw[i] - r - margin;
        hi[i] = pose->p[i] + cw[i] + r + margin;
    }
}

void defsim__collider_bounds(const defsim__collider *c, const defsim__pose *pose, double margin,
                             double lo[3], double hi[3])
{
    const defsim_collider_def *d = &c->def;
    for (int k = 0; k < 3; ++k) {
        lo[k] = -INFINITY;
        hi[k] = INFINITY;
    }
    switch (d->shape) {
    case DEFSIM_SHAPE_PLANE: {
        /* a half-space is bounded along its normal only when that is a world axis */
        double n[3];
        vec_to_world(pose, d->normal, n);
        for (int k = 0; k < 3; ++k)
            if (n[(k + 1) % 3] == 0.0 && n[(k + 2) % 3] == 0.0) {
                if (n[k] > 0.0) hi[k] = pose->p[k] + margin;
                else lo[k] = pose->p[k] - margin;
            }
        return;
    }
    case DEFSIM_SHAPE_SPHERE:
        for (int k = 0; k < 3; ++k) {
            lo[k] = pose->p[k] - d->radius - margin;
            hi[k] = pose->p[k] + d->radius + margin;
        }
        return;
    case DEFSIM_SHAPE_BOX: {
        const double blo[3] = {-d->half_extents[0], -d->half_extents[1], -d->half_extents[2]};
        box_bounds(pose, blo, d->half_extents, margin, lo, hi);
        return;
    }
    case DEFSIM_SHAPE_CAPSULE: {
        const double *R = pose->R;
        for (int i = 0; i < 3; ++i) {
            const double r = fabs(R[3 * i + 1]) * d->half_height + d->radius + margin;
            lo[i] = pose->p[i] - r;
            hi[i] = pose->p[i] + r;
        }
        return;
    }
    case DEFSIM_SHAPE_MESH:
        if (pose->q[0] == 1.0) {   /* not rotated: the tree's root box */
            defsim__mesh_local_bounds(c, lo, hi);
            for (int k = 0; k < 3; ++k) {
                lo[k] += pose->p[k] - margin;
                hi[k] += pose->p[k] + margin;
            }
            return;
        }
        /* the rotated vertices: tight, one pass over them */
        for (int k = 0; k < 3; ++k) {
            lo[k] = INFINITY;
            hi[k] = -INFINITY;
        }
        for (int32_t i = 0; i < d->vertex_count; ++i) {
            double w[3];
            vec_to_world(pose, c->mesh_x + 3 * (size_t)i, w);
            for (int k = 0; k < 3; ++k) {
                if (w[k] < lo[k]) lo[k] = w[k];
                if (w[k] > hi[k]) hi[k] = w[k];
            }
        }
        for (int k = 0; k < 3; ++k) {
            lo[k] += pose->p[k] - margin;
            hi[k] += pose->p[k] + margin;
        }
        return;
    case DEFSIM_SHAPE_SDF: {
        int any = 0;
        for (int k = 0; k < 6; ++k) any |= d->sdf_bounds[k] != 0.0;
        if (any) box_bounds(pose, d->sdf_bounds, d->sdf_bounds + 3, margin, lo, hi);
        return;
    }
    }
}

/* ------------------------------------------------------------------------------------------ */
/* Time of impact */

/* The target distance of a time of impact, above min_distance by a sliver of the initial gap, so
 * that the rounding of the last iterate cannot put the point closer than min_distance. */
#define TOI_KEEP 1e-9

/* Convex shapes (box, capsule; any convex set's signed distance is convex along a line): Newton
 * from the left on d(t) = target. The tangent lies below the convex d, so every iterate is at or
 * before the first crossing: conservative, and quadratic near it (one step on a face). */
static defsim_status toi_convex(const defsim__collider *c, const defsim__pose *pose,
                                const double p0[3], const double v[3], double s, double target,
                                double *t)
{
    for (int it = 0; it < 64; ++it) {
        double q[3], d, g[3];
        for (int k = 0; k < 3; ++k) q[k] = p0[k] + s * v[k];
        defsim_status st = defsim__collider_distance(c, pose, q, &d, g, NULL);
        if (st != DEFSIM_OK) return st;
        const double gap = d - target, slope = g[0] * v[0] + g[1] * v[1] + g[2] * v[2];
        if (!(slope < 0.0)) {   /* moving away from here on: d never decreases again */
            *t = 1.0;
            return DEFSIM_OK;
        }
        if (gap <= 0.0) break;
        const double ds = gap / -slope;
        if (s + ds >= 1.0) {
            *t = 1.0;
            return DEFSIM_OK;
        }
        if (ds <= 1e-15 * (1.0 + s)) break;
        s += ds;
    }
    *t = s;
    return DEFSIM_OK;
}

/* Meshes and SDFs: conservative advancement. |d| is 1-Lipschitz (for an SDF by the host's
 * promise |grad| <= 1), so the point can move by d - target without coming closer. A sample
 * below the target (the sign flip behind the boundary of an open mesh, or an SDF breaking its
 * promise) is bisected back to the last sample above it. */
static defsim_status toi_advance(const defsim__collider *c, const defsim__pose *pose,
                                 const double p0[3], const double v[3], double d0, double target,
                                 double *t)
{
    const double len = sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
    double s = 0.0, d = d0;
    defsim_status st;
    for (int it = 0; it < 256; ++it) {
        const double gap = d - target;
        if (gap <= 1e-6 * (d0 - target)) break;
        double s1 = s + gap / len, d1, g[3], q[3];
        if (s1 > 1.0) s1 = 1.0;
        for (int k = 0; k < 3; ++k) q[k] = p0[k] + s1 * v[k];
        if ((st = defsim__collider_distance(c, pose, q, &d1, g, NULL)) != DEFSIM_OK) return st;
        if (d1 < target) {
            double good = s, bad = s1;
            for (int b = 0; b < 60 && bad - good > 1e-12; ++b) {
                const double m = 0.5 * (good + bad);
                for (int k = 0; k < 3; ++k) q[k] = p0[k] + m * v[k];
                if ((st = defsim__collider_distance(c, pose, q, &d1, g, NULL)) != DEFSIM_OK)
                    return st;
                if (d1 >= target) good = m;
                else bad = m;
            }
            *t = good;
            return DEFSIM_OK;
        }
        s = s1;
        d = d1;
        if (s >= 1.0) break;
    }
    *t = s;
    return DEFSIM_OK;
}

defsim_status defsim__collider_toi(const defsim__collider *c, const defsim__pose *pose,
                                   const double p0[3], const double p1[3], double min_distance,
                                   double *t)
{
    double d0, g[3];
    defsim_status st = defsim__collider_distance(c, pose, p0, &d0, g, NULL);
    if (st != DEFSIM_OK) return st;
    const double v[3] = {p1[0] - p0[0], p1[1] - p0[1], p1[2] - p0[2]};
    if (!(d0 > min_distance)) {
        *t = 0.0;
        return DEFSIM_OK;
    }
    if (v[0] == 0.0 && v[1] == 0.0 && v[2] == 0.0) {
        *t = 1.0;
        return DEFSIM_OK;
    }
    const double target = min_distance + TOI_KEEP * (d0 - min_distance);
    switch (c->def.shape) {
    case DEFSIM_SHAPE_PLANE: {
        /* exact: the distance is affine along the segment */
        const double slope = g[0] * v[0] + g[1] * v[1] + g[2] * v[2];
        *t = d0 + slope >= target ? 1.0 : (d0 - target) / -slope;
        return DEFSIM_OK;
    }
    case DEFSIM_SHAPE_SPHERE: {
        /* exact: the first root of |p0 + t v - c|^2 = (r + target)^2 */
        double w[3];
        for (int k = 0; k < 3; ++k) w[k] = p0[k] - pose->p[k];
        const double R = c->def.radius + target;
        const double a = v[0] * v[0] + v[1] * v[1] + v[2] * v[2];
        const double b = w[0] * v[0] + w[1] * v[1] + w[2] * v[2];
        const double cc = w[0] * w[0] + w[1] * w[1] + w[2] * w[2] - R * R;
        const double disc = b * b - a * cc;
        *t = 1.0;
        if (b < 0.0 && disc >= 0.0 && cc > 0.0) {
            const double r = cc / (-b + sqrt(disc));   /* the smaller root, without cancellation */
            if (r < 1.0) *t = r;
        } else if (!(cc > 0.0)) {
            *t = 0.0;
        }
        return DEFSIM_OK;
    }
    case DEFSIM_SHAPE_BOX: {
        /* slabs: the entry into the box grown by target contains the grown (rounded) box, so it
         * is a safe start for the Newton iteration, exact through a face */
        double l0[3], lv[3], t0 = 0.0, t1 = 1.0;
        to_local(pose, p0, l0);
        const double *R = pose->R;
        for (int i = 0; i < 3; ++i) lv[i] = R[i] * v[0] + R[3 + i] * v[1] + R[6 + i] * v[2];
        for (int k = 0; k < 3 && t0 <= t1; ++k) {
            const double e = c->def.half_extents[k] + target;
            if (lv[k] == 0.0) {
                if (fabs(l0[k]) > e) t0 = 2.0;   /* parallel and outside the slab */
                continue;
            }
            double ta = (-e - l0[k]) / lv[k], tb = (e - l0[k]) / lv[k];
            if (ta > tb) { const double x = ta; ta = tb; tb = x; }
            if (ta > t0) t0 = ta;
            if (tb < t1) t1 = tb;
        }
        if (t0 > t1) {
            *t = 1.0;
            return DEFSIM_OK;
        }
        return toi_convex(c, pose, p0, v, t0, target, t);
    }
    case DEFSIM_SHAPE_CAPSULE:
        return toi_convex(c, pose, p0, v, 0.0, target, t);
    case DEFSIM_SHAPE_MESH:
    case DEFSIM_SHAPE_SDF:
        return toi_advance(c, pose, p0, v, d0, target, t);
    }
    *t = 0.0;
    return DEFSIM_OK;
}
