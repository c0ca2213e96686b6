/* SPDX-License-Identifier: MIT */
/*
 * The geometry of colliders: signed distance with gradient and Hessian, world bounds and a
 * conservative time of impact, per shape. Points are taken to the collider's local frame
 * (R^T (p - c)), measured there, and gradients and Hessians rotated back.
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
    default:
        *d = INFINITY;
        gl[0] = 0.0; gl[1] = 1.0; gl[2] = 0.0;
        break;
    }
    vec_to_world(pose, gl, grad);
    if (hess) mat_to_world(pose, hl, hess);
    return DEFSIM_OK;
}

void defsim__collider_bounds(const defsim__collider *c, const defsim__pose *pose, double margin,
                             double lo[3], double hi[3])
{
    switch (c->def.shape) {
    case DEFSIM_SHAPE_SPHERE:
        for (int k = 0; k < 3; ++k) {
            lo[k] = pose->p[k] - c->def.radius - margin;
            hi[k] = pose->p[k] + c->def.radius + margin;
        }
        return;
    default:
        for (int k = 0; k < 3; ++k) {
            lo[k] = -INFINITY;
            hi[k] = INFINITY;
        }
        return;
    }
}

defsim_status defsim__collider_toi(const defsim__collider *c, const defsim__pose *pose,
                                   const double p0[3], const double p1[3], double min_distance,
                                   double *t)
{
    double d0, d1, g[3];
    defsim_status st = defsim__collider_distance(c, pose, p0, &d0, g, NULL);
    if (st != DEFSIM_OK) return st;
    if (c->def.shape == DEFSIM_SHAPE_PLANE) {
        /* Exact: the distance is affine along the segment. */
        if ((st = defsim__collider_distance(c, pose, p1, &d1, g, NULL)) != DEFSIM_OK) return st;
        *t = d1 >= min_distance ? 1.0 : (d0 - min_distance) / (d0 - d1);
        if (*t < 0.0) *t = 0.0;
        return DEFSIM_OK;
    }
    /* Conservative advancement: the distance is 1-Lipschitz in the point, so the point can move
     * d - min_distance along the segment without reaching min_distance. */
    double len = 0.0;
    for (int k = 0; k < 3; ++k) len += (p1[k] - p0[k]) * (p1[k] - p0[k]);
    len = sqrt(len);
    double s = 0.0, d = d0;
    for (int it = 0; it < 200 && s < 1.0; ++it) {
        const double gap = d - min_distance;
        if (gap <= 1e-3 * (d0 - min_distance) || len == 0.0) break;
        s += 0.9 * gap / len;
        if (s >= 1.0) {
            s = 1.0;
            break;
        }
        double q[3];
        for (int k = 0; k < 3; ++k) q[k] = p0[k] + s * (p1[k] - p0[k]);
        if ((st = defsim__collider_distance(c, pose, q, &d, g, NULL)) != DEFSIM_OK) return st;
    }
    *t = s;
    return DEFSIM_OK;
}
