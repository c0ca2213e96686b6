/* SPDX-License-Identifier: MIT */
/*
 * Contact between vertices and colliders (contact.h; the method and its parameters are in
 * docs/contact.md). Geometry comes only from the collider queries (collider.h), never per shape.
 *
 * Contents: the scalar functions (barrier, friction smoothing); pairs and the broad phase;
 * energy, forces and blocks; continuous collision detection and the feasible start; the end of a
 * step.
 */
#include "contact.h"

#include "array.h"
#include "broad_phase.h"
#include "clock.h"
#include "contact_barrier.h"
#include "contact_prim.h"
#include "mat3.h"
#include "mesh.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

/* ------------------------------------------------------------------------------------------ */
/* Scalar functions */

/* The point that x becomes when carried rigidly from pose a to pose b. */
static void carry(const defsim__pose *a, const defsim__pose *b, const double x[3], double out[3])
{
    const double d[3] = {x[0] - a->p[0], x[1] - a->p[1], x[2] - a->p[2]};
    double l[3];
    for (int i = 0; i < 3; ++i) l[i] = a->R[i] * d[0] + a->R[3 + i] * d[1] + a->R[6 + i] * d[2];
    for (int i = 0; i < 3; ++i)
        out[i] = b->p[i] + b->R[3 * i] * l[0] + b->R[3 * i + 1] * l[1] + b->R[3 * i + 2] * l[2];
}

/* ------------------------------------------------------------------------------------------ */
/* Pairs and the broad phase */

static int live(const defsim__contact *c, int32_t j) { return (c->col[j].generation & 1u) != 0; }

static double kfac(const defsim__contact *c, int32_t i) { return c->khat * c->mass[i]; }

/* Vertex i's thickness offset (m): half its body's contact thickness. */
static double vxi(const defsim__contact *c, int32_t i) { return c->xi ? c->xi[i] : 0.0; }

defsim_status defsim__contact_offsets(defsim__contact *c, const defsim__body *bodies,
                                      int32_t nbodies, int32_t nv)
{
    c->xi_max = 0.0;
    for (int32_t b = 0; b < nbodies; ++b)
        if ((bodies[b].generation & 1u) && 0.5 * bodies[b].thickness > c->xi_max)
            c->xi_max = 0.5 * bodies[b].thickness;
    if (!(c->xi_max > 0.0)) {
        free(c->xi);
        c->xi = NULL;
        c->cap_xi = 0;
        return DEFSIM_OK;
    }
    if (nv > c->cap_xi) {
        free(c->xi);
        c->xi = malloc((size_t)nv * sizeof *c->xi);
        c->cap_xi = c->xi ? nv : 0;
        if (!c->xi) return DEFSIM_ERR_OUT_OF_MEMORY;
    }
    memset(c->xi, 0, (size_t)nv * sizeof *c->xi);
    for (int32_t b = 0; b < nbodies; ++b) {
        if (!(bodies[b].generation & 1u)) continue;
        const double half = 0.5 * bodies[b].thickness;
        for (int32_t i = 0; i < bodies[b].nv; ++i) c->xi[bodies[b].offset + i] = half;
    }
    return DEFSIM_OK;
}

/* Records a distance to collider slot j that failed: an SDF's callback (CALLBACK) or, for the
 * other shapes, a distance that overflowed (UNSTABLE: a vertex far beyond the coordinate bound;
 * colliders are held within it). The first failure of a step is kept. */
static void geometry_failed(defsim__contact *c, int32_t j)
{
    if (!c->failed)
        c->failed = c->col[j].def.shape == DEFSIM_SHAPE_SDF ? DEFSIM_ERR_CALLBACK
                                                            : DEFSIM_ERR_UNSTABLE;
}

const char *defsim__contact_failure(const defsim__contact *c)
{
    switch (c->failed) {
    case DEFSIM_ERR_CALLBACK:
        return "a collider's SDF callback returned a non-finite value";
    case DEFSIM_ERR_UNSTABLE:
        return "the distance of a vertex to a collider is not finite (the vertex lies far "
               "beyond the coordinate bound of +-1e100 m)";
    default:
        return "out of memory for contact pairs";
    }
}

/* Distance of x to collider slot j at its end-of-step pose; on a failure records it and
 * returns NaN. */
static double distance(defsim__contact *c, int32_t j, const double x[3], double n[3],
                       double H[9])
{
    double d, g[3];
    if (defsim__collider_distance(&c->col[j], &c->pose1[j], x, &d, n ? n : g, H) != DEFSIM_OK ||
        !isfinite(d)) {
        geometry_failed(c, j);
        return NAN;
    }
    return d;
}

static int reserve_pairs(defsim__contact *c, int32_t n)
{
    if (n <= c->cap_pair) return 1;
    const int64_t cap = defsim__grown_cap(c->cap_pair, n, 64);
    void **const arrays[] = {(void **)&c->pv, (void **)&c->pc, (void **)&c->lam,
                             (void **)&c->nrm, (void **)&c->uc, (void **)&c->off};
    const size_t elem[] = {sizeof *c->pv, sizeof *c->pc, sizeof *c->lam, 3 * sizeof *c->nrm,
                           3 * sizeof *c->uc, sizeof *c->off};
    if (!defsim__grow_parallel(arrays, elem, 6, cap)) return 0;
    c->cap_pair = (int32_t)cap;
    return 1;
}

static int moves(const defsim__contact *c, int32_t j)
{
    return memcmp(c->pose0[j].p, c->pose1[j].p, sizeof c->pose0[j].p) != 0 ||
           memcmp(c->pose0[j].q, c->pose1[j].q, sizeof c->pose0[j].q) != 0;
}

/* Pairs vertex i with every live collider (only those near all the balls, unless `grown`: the
 * ball left the box the broad phase saw) that its ball can bring within dhat during the step,
 * skipping colliders it is paired with already (grown). */
static void pair_vertex(defsim__contact *c, int32_t i, int grown)
{
    const double *x = c->xn + 3 * (int64_t)i, r = c->radius[i];
    const int skip_existing = grown;
    for (int32_t j = 0; j < c->ncol; ++j) {
        if (!live(c, j) || (!grown && !c->near[j])) continue;
        const double *lo = c->lo + 3 * (int64_t)j, *hi = c->hi + 3 * (int64_t)j;
        if (x[0] + r < lo[0] || x[0] - r > hi[0] || x[1] + r < lo[1] || x[1] - r > hi[1] ||
            x[2] + r < lo[2] || x[2] - r > hi[2])
            continue;
        /* The distance is 1-Lipschitz: within the ball it stays above d(xn) - r. A moving
         * collider's surface near xn moves by about the displacement of its point at xn (exact
         * for translations, first order for rotations). */
        double d = distance(c, j, x, NULL, NULL);
        if (isnan(d)) return;
        if (moves(c, j)) {
            double d0, g[3], moved[3];
            if (defsim__collider_distance(&c->col[j], &c->pose0[j], x, &d0, g, NULL) != DEFSIM_OK ||
                !isfinite(d0)) {
                geometry_failed(c, j);
                return;
            }
            carry(&c->pose0[j], &c->pose1[j], x, moved);
            const double u[3] = {moved[0] - x[0], moved[1] - x[1], moved[2] - x[2]};
            d = fmin(d, d0) - sqrt(defsim__v3_dot(u, u));
        }
        if (!(d <= r + c->dhat + vxi(c, i))) continue;
        if (skip_existing) {
            int found = 0;
            for (int32_t p = 0; p < c->npair && !found; ++p) found = c->pv[p] == i && c->pc[p] == j;
            if (found) continue;
        }
        if (!reserve_pairs(c, c->npair + 1)) {
            if (!c->failed) c->failed = DEFSIM_ERR_OUT_OF_MEMORY;
            return;
        }
        const int32_t p = c->npair++;
        c->pv[p] = i;
        c->pc[p] = j;
        c->lam[p] = 0.0;
        c->off[p] = 0;
        memset(c->nrm + 3 * (int64_t)p, 0, 3 * sizeof(double));
        memset(c->uc + 3 * (int64_t)p, 0, 3 * sizeof(double));
    }
}

/* How far each side of the box [lo, hi] may move out with collider j still unable to come within
 * dhat of a point of it in this step (> 0), or <= 0 when it may come within dhat already: the
 * gap along an axis that separates the box from the collider's bounds (grown by dhat), or else
 * the distance from the box's centre, less the box's half diagonal (the distance is
 * 1-Lipschitz), the collider's motion there and dhat, over sqrt(3) (moving each side out by t
 * grows the half diagonal by at most sqrt(3) t). At most one query per collider. */
static double box_clearance(defsim__contact *c, int32_t j, const double lo[3], const double hi[3])
{
    const double *cl = c->lo + 3 * (int64_t)j, *ch = c->hi + 3 * (int64_t)j;
    double gap = -INFINITY;
    for (int k = 0; k < 3; ++k) gap = fmax(gap, fmax(cl[k] - hi[k], lo[k] - ch[k]));
    if (gap > 0.0) return gap;
    double m[3], half = 0.0;
    for (int k = 0; k < 3; ++k) {
        m[k] = 0.5 * (lo[k] + hi[k]);
        half += 0.25 * (hi[k] - lo[k]) * (hi[k] - lo[k]);
    }
    if (!isfinite(half)) return -INFINITY;
    double d = distance(c, j, m, NULL, NULL);
    if (isnan(d)) return -INFINITY;
    if (moves(c, j)) {
        double d0, g[3], moved[3];
        if (defsim__collider_distance(&c->col[j], &c->pose0[j], m, &d0, g, NULL) != DEFSIM_OK ||
            !isfinite(d0))
            return -INFINITY;
        carry(&c->pose0[j], &c->pose1[j], m, moved);
        const double u[3] = {moved[0] - m[0], moved[1] - m[1], moved[2] - m[2]};
        d = fmin(d, d0) - sqrt(defsim__v3_dot(u, u));
    }
    return (d - sqrt(half) - c->dhat - c->xi_max) / sqrt(3.0);
}

/* Whether collider j can come within dhat of a point of the box [lo, hi] in this step. */
static int near_box(defsim__contact *c, int32_t j, const double lo[3], const double hi[3])
{
    return !(box_clearance(c, j, lo, hi) > 0.0);
}

/* Each free vertex's ball about xn: twice its inertial motion in the step, plus dhat; and the
 * box around all balls. */
static void vertex_balls(defsim__contact *c)
{
    double lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
    const double h = c->hstep, base = c->g * h * h + c->dhat;
    for (int32_t i = 0; i < c->nv; ++i) {
        if (c->pinned[i]) continue;
        /* |v|_1 >= |v|: a cheap, larger ball */
        const double *vi = c->vn + 3 * (int64_t)i, *xi = c->xn + 3 * (int64_t)i;
        const double r = c->radius[i] = 2.0 * h * (fabs(vi[0]) + fabs(vi[1]) + fabs(vi[2])) + base;
        for (int k = 0; k < 3; ++k) {
            const double a = xi[k] - r, b = xi[k] + r;
            lo[k] = a < lo[k] ? a : lo[k];
            hi[k] = b > hi[k] ? b : hi[k];
        }
    }
    memcpy(c->ball_lo, lo, sizeof lo);
    memcpy(c->ball_hi, hi, sizeof hi);
    c->balls = 1;
}

/* The per-vertex broad phase from the balls: the colliders near the box around all balls, then
 * each free vertex against those. Returns whether any collider is near. */
static int pair_balls(defsim__contact *c)
{
    int any = 0;
    for (int32_t j = 0; j < c->ncol; ++j)
        any |= c->near[j] = live(c, j) && near_box(c, j, c->ball_lo, c->ball_hi);
    for (int32_t i = 0; i < c->nv && !c->failed && any; ++i)
        if (!c->pinned[i]) pair_vertex(c, i, 0);
    return any;
}

/* The safe box after a broad phase that found no collider near the balls: their box grown on
 * each side by half the smallest clearance, so that it also holds the vertices of the steps
 * that follow while the colliders keep clear of it (then no step needs the balls). */
static void set_safe(defsim__contact *c)
{
    double t = INFINITY;
    for (int32_t j = 0; j < c->ncol; ++j)
        if (live(c, j)) t = fmin(t, box_clearance(c, j, c->ball_lo, c->ball_hi));
    t = 0.5 * t;
    if (!(t > 0.0 && t < INFINITY)) t = 0.0;
    for (int k = 0; k < 3; ++k) {
        c->safe_lo[k] = c->ball_lo[k] - t;
        c->safe_hi[k] = c->ball_hi[k] + t;
    }
    /* by construction clear; rounding must not make it otherwise */
    for (int32_t j = 0; j < c->ncol && t > 0.0; ++j)
        if (live(c, j) && near_box(c, j, c->safe_lo, c->safe_hi)) {
            memcpy(c->safe_lo, c->ball_lo, sizeof c->safe_lo);
            memcpy(c->safe_hi, c->ball_hi, sizeof c->safe_hi);
            break;
        }
    c->safe_set = 1;
}

static int outside(const double lo[3], const double hi[3], const double p[3])
{
    return !((p[0] >= lo[0]) & (p[0] <= hi[0]) & (p[1] >= lo[1]) & (p[1] <= hi[1]) &
             (p[2] >= lo[2]) & (p[2] <= hi[2]));
}

/* Whether every free vertex of x (of x + dx when dx is not NULL) lies in the safe box; a
 * coordinate that is not a number lies outside. Branch-free: it runs at every evaluation. */
static int in_safe(const defsim__contact *c, const double *x, const double *dx)
{
    const double *lo = c->safe_lo, *hi = c->safe_hi;
    const uint8_t *pin = c->pinned;
    int out = 0;
    if (!dx) {
        for (int32_t i = 0; i < c->nv; ++i) out |= outside(lo, hi, x + 3 * (int64_t)i) & !pin[i];
    } else {
        for (int32_t i = 0; i < c->nv; ++i) {
            const double *a = x + 3 * (int64_t)i, *u = dx + 3 * (int64_t)i;
            const double p[3] = {a[0] + u[0], a[1] + u[1], a[2] + u[2]};
            out |= outside(lo, hi, p) & !pin[i];
        }
    }
    return !out;
}

/* A point left the safe box: the per-vertex broad phase after all, for the rest of the step,
 * and a new safe box at the next. The start positions were in the box (BARRIER checks them; a
 * PENALTY pair acts only at evaluated points), so no new pair has friction lagged from them. */
static void leave_far(defsim__contact *c)
{
    c->far = 0;
    c->safe_set = 0;
    if (!c->balls) vertex_balls(c);
    (void)pair_balls(c);
}

/* Grows the ball of every vertex whose position in x left it, and pairs it again: a backend's
 * iterate may go anywhere, and no contact may be missed. */
static void ensure(defsim__contact *c, const double *x)
{
    if (c->far) {
        if (in_safe(c, x, NULL)) return;
        leave_far(c);
    }
    for (int32_t i = 0; i < c->nv; ++i) {
        if (c->pinned[i]) continue;
        const double *a = x + 3 * (int64_t)i, *b = c->xn + 3 * (int64_t)i;
        const double d2 = (a[0] - b[0]) * (a[0] - b[0]) + (a[1] - b[1]) * (a[1] - b[1]) +
                          (a[2] - b[2]) * (a[2] - b[2]);
        if (d2 <= c->radius[i] * c->radius[i]) continue;
        c->radius[i] = 2.0 * sqrt(d2);
        pair_vertex(c, i, 1);
    }
}

void defsim__contact_free(defsim__contact *c)
{
    const double om = c->omega_elastic;
    const int readback = c->readback_set;
    free(c->pose0); free(c->pose1); free(c->lo); free(c->hi); free(c->near);
    free(c->radius); free(c->vel); free(c->blk);
    free(c->base); free(c->dstart); free(c->carrier); free(c->cpos); free(c->hit);
    free(c->face); free(c->edge); free(c->xi);
    free(c->pv); free(c->pc); free(c->lam); free(c->nrm); free(c->uc); free(c->off);
    memset(c, 0, sizeof *c);
    c->omega_elastic = om;
    c->readback_set = readback;
}

double defsim__contact_khat(const defsim__contact_params *p, double dhat, double h,
                            const double gravity[3])
{
    const double g = sqrt(defsim__v3_dot(gravity, gravity));
    if (p->mode == DEFSIM__CONTACT_BARRIER)
        return p->kappa > 0.0 ? p->kappa : g / dhat + 1.0 / (h * h);
    const double w = p->frequency > 0.0 ? p->frequency : fmax(p->omega_elastic, sqrt(2.0 * g / dhat));
    return w * w;
}

static int reserve(defsim__contact *c, int32_t nv, int32_t ncol)
{
    if (nv > c->cap_v) {
        free(c->radius); free(c->vel); free(c->blk);
        free(c->base); free(c->dstart); free(c->carrier); free(c->cpos); free(c->hit);
        c->radius = malloc((size_t)nv * sizeof *c->radius);
        c->vel = calloc(3 * (size_t)nv, sizeof *c->vel);
        c->blk = malloc(9 * (size_t)nv * sizeof *c->blk);
        c->base = malloc(3 * (size_t)nv * sizeof *c->base);
        c->dstart = malloc(3 * (size_t)nv * sizeof *c->dstart);
        c->carrier = malloc((size_t)nv * sizeof *c->carrier);
        c->cpos = malloc(3 * (size_t)nv * sizeof *c->cpos);
        c->hit = malloc((size_t)nv * sizeof *c->hit);
        c->cap_v = c->radius && c->vel && c->blk && c->base && c->dstart && c->carrier &&
                           c->cpos && c->hit ? nv : 0;
        if (!c->cap_v) return 0;
    }
    if (ncol > c->cap_col) {
        free(c->pose0); free(c->pose1); free(c->lo); free(c->hi); free(c->near);
        c->pose0 = malloc((size_t)ncol * sizeof *c->pose0);
        c->pose1 = malloc((size_t)ncol * sizeof *c->pose1);
        c->lo = malloc(3 * (size_t)ncol * sizeof *c->lo);
        c->hi = malloc(3 * (size_t)ncol * sizeof *c->hi);
        c->near = malloc((size_t)ncol * sizeof *c->near);
        c->cap_col = c->pose0 && c->pose1 && c->lo && c->hi && c->near ? ncol : 0;
        if (!c->cap_col) return 0;
    }
    return 1;
}

const double *defsim__contact_vel(const defsim__contact *c, int32_t nv)
{
    return nv > 0 && c->cap_v >= nv ? c->vel : NULL;
}

defsim_status defsim__contact_set_vel(defsim__contact *c, int32_t nv, const double *vel)
{
    if (!reserve(c, nv, 0)) return DEFSIM_ERR_OUT_OF_MEMORY;
    memcpy(c->vel, vel, 3 * (size_t)nv * sizeof *vel);
    return DEFSIM_OK;
}

defsim_status defsim__contact_begin(defsim__contact *c, const defsim__system *s,
                                    const defsim__collider *col, int32_t ncol,
                                    const defsim__contact_params *p, const double *x,
                                    const double *v, double h, defsim__messages *msg)
{
    const double t0 = defsim__now();
    if (!reserve(c, s->nv, ncol)) {
        defsim__error(msg, "out of memory for contact");
        return DEFSIM_ERR_OUT_OF_MEMORY;
    }
    c->mode = p->mode;
    c->failed = DEFSIM_OK;
    c->exact = 0;
    c->blocked = 0;
    c->col = col;
    c->ncol = ncol;
    c->nv = s->nv;
    c->mass = s->mass;
    c->pinned = s->pinned;
    c->h = h;
    c->dhat = p->dhat_rel * s->length_scale;
    c->eps_v = p->eps_v;
    c->khat = defsim__contact_khat(p, c->dhat, h, s->gravity);
    c->omega_c = sqrt(c->khat);
    c->mu_max = 0.0;
    for (int32_t j = 0; j < ncol; ++j) {
        if (!live(c, j)) continue;
        defsim__collider_pose_at(&col[j], 0.0, &c->pose0[j]);
        defsim__collider_pose_at(&col[j], 1.0, &c->pose1[j]);
        /* over the step: the union of the bounds at both ends (exact for translations) */
        double *lo = c->lo + 3 * (int64_t)j, *hi = c->hi + 3 * (int64_t)j, l0[3], h0[3];
        defsim__collider_bounds(&col[j], &c->pose1[j], c->dhat + c->xi_max, lo, hi);
        defsim__collider_bounds(&col[j], &c->pose0[j], c->dhat + c->xi_max, l0, h0);
        for (int k = 0; k < 3; ++k) {
            lo[k] = fmin(lo[k], l0[k]);
            hi[k] = fmax(hi[k], h0[k]);
        }
        c->mu_max = fmax(c->mu_max, col[j].def.friction);
    }
    c->g = sqrt(defsim__v3_dot(s->gravity, s->gravity));
    c->hstep = h;
    c->xn = x;
    c->vn = v;
    c->npair = 0;
    c->balls = 0;
    /* The safe box of an earlier step serves while every collider keeps clear of it (O(colliders)
     * per step) and, for BARRIER, whose friction is lagged from xn, it holds xn; every evaluated
     * point is tested against it (ensure). Otherwise the balls; none near: a new safe box. */
    int keep = c->safe_set;
    for (int32_t j = 0; j < ncol && keep; ++j)
        keep = !live(c, j) || !near_box(c, j, c->safe_lo, c->safe_hi);
    if (keep && c->mode == DEFSIM__CONTACT_BARRIER) keep = in_safe(c, x, NULL);
    c->far = keep;
    if (!keep) {
        vertex_balls(c);
        c->safe_set = 0;
        if (!pair_balls(c) && !c->failed) {
            set_safe(c);
            c->far = 1;
        }
    }
    /* BARRIER: friction lagged from the start of the step (IPC): the normal force and normal at
     * x_n against the pose the collider had then, and the collider's motion at the vertex. */
    for (int32_t q = 0; q < c->npair && !c->failed && c->mode == DEFSIM__CONTACT_BARRIER; ++q) {
        const int32_t i = c->pv[q], j = c->pc[q];
        const double *xi = x + 3 * (int64_t)i;
        double d0, d1, n0[3], g1[3], moved[3];
        if (defsim__collider_distance(&col[j], &c->pose0[j], xi, &d0, n0, NULL) != DEFSIM_OK ||
            !isfinite(d0)) {
            geometry_failed(c, j);
            break;
        }
        d1 = distance(c, j, xi, g1, NULL) - vxi(c, i);
        d0 -= vxi(c, i);   /* beyond the thickness offset, as everywhere below */
        c->off[q] = d0 <= 0.0 && d1 <= 0.0;
        carry(&c->pose0[j], &c->pose1[j], xi, moved);
        for (int k = 0; k < 3; ++k) {
            c->uc[3 * (int64_t)q + k] = moved[k] - xi[k];
            c->nrm[3 * (int64_t)q + k] = n0[k];
        }
        c->lam[q] = d0 > 0.0 && d0 < c->dhat ? -kfac(c, i) * barrier_d1(d0, c->dhat) : 0.0;
    }
    c->stat[DEFSIM__CSTAT_PAIRS] = c->npair;
    c->stat[DEFSIM__CSTAT_TIME_BROAD] += defsim__now() - t0;
    if (c->failed) {
        defsim__error(msg, "contact: %s", defsim__contact_failure(c));
        return c->failed;
    }
    return DEFSIM_OK;
}

void defsim__contact_substep(defsim__contact *c, double s0, double s1, double hsub)
{
    if (c->mode != DEFSIM__CONTACT_PENALTY) return;
    for (int32_t j = 0; j < c->ncol; ++j) {
        if (!live(c, j)) continue;
        defsim__collider_pose_at(&c->col[j], s0, &c->pose0[j]);
        defsim__collider_pose_at(&c->col[j], s1, &c->pose1[j]);
    }
    c->h = hsub;
}

/* ------------------------------------------------------------------------------------------ */
/* Energy, forces and blocks */

/* BARRIER friction of pair q at x: ut = P (x_i - xn_i - uc) with the lagged normal; returns
 * mu lam (0 when the pair has no friction). */
static double friction_tangent(const defsim__contact *c, int32_t q, const double *x, double ut[3],
                               double *y)
{
    const double mul = c->col[c->pc[q]].def.friction * c->lam[q];
    if (!(mul > 0.0)) return 0.0;
    const int32_t i = c->pv[q];
    const double *n = c->nrm + 3 * (int64_t)q, *uc = c->uc + 3 * (int64_t)q;
    double u[3];
    for (int k = 0; k < 3; ++k) u[k] = x[3 * (int64_t)i + k] - c->xn[3 * (int64_t)i + k] - uc[k];
    const double un = defsim__v3_dot(u, n);
    for (int k = 0; k < 3; ++k) ut[k] = u[k] - un * n[k];
    *y = sqrt(defsim__v3_dot(ut, ut));
    return mul;
}

static double contact_energy(defsim__contact *c, const double *x);

double defsim__contact_energy(defsim__contact *c, const double *x)
{
    const double t0 = defsim__now();
    if (c->blocked) return INFINITY;
    ensure(c, x);
    double e = contact_energy(c, x);
    c->stat[DEFSIM__CSTAT_TIME_EVAL] += defsim__now() - t0;
    return e;
}

static double contact_energy(defsim__contact *c, const double *x)
{
    double e = 0.0;
    const double dh = c->dhat, eps = c->eps_v * c->h;
    for (int32_t q = 0; q < c->npair; ++q) {
        if (c->off[q]) continue;
        const int32_t i = c->pv[q];
        const double d = distance(c, c->pc[q], x + 3 * (int64_t)i, NULL, NULL) - vxi(c, i);
        if (isnan(d)) return INFINITY;
        if (c->mode == DEFSIM__CONTACT_BARRIER) {
            if (d <= 0.0) return INFINITY;
            if (d < dh) e += kfac(c, i) * barrier(d, dh);
            double ut[3], y;
            const double mul = friction_tangent(c, q, x, ut, &y);
            if (mul > 0.0) e += mul * friction_f0(y, eps);
        } else if (d < dh) {
            e += 0.5 * kfac(c, i) * (dh - d) * (dh - d);
        }
    }
    return c->failed ? INFINITY : e;
}

/* The collider's velocity at world point x over the step (m/s). */
static void collider_velocity(const defsim__contact *c, int32_t j, const double x[3],
                              double vc[3])
{
    /* A collider that keeps its pose over the step has no velocity: exactly zero, not the
     * roundoff of carrying x through the pose and back (which also made a checkpoint's replayed
     * step, which sees colliders still, differ from the step it replays). */
    if (memcmp(&c->pose0[j], &c->pose1[j], sizeof c->pose0[j]) == 0) {
        vc[0] = vc[1] = vc[2] = 0.0;
        return;
    }
    double back[3];
    carry(&c->pose1[j], &c->pose0[j], x, back);
    for (int k = 0; k < 3; ++k) vc[k] = c->h > 0.0 ? (x[k] - back[k]) / c->h : 0.0;
}

/* PENALTY friction of pair q: the tangential relative velocity vt (relative to the collider's
 * surface) and mu lam, lam the penalty's normal force at distance d. */
static double penalty_tangent(const defsim__contact *c, int32_t q, double d, const double n[3],
                              const double *v, double vt[3], double *y)
{
    const int32_t i = c->pv[q], j = c->pc[q];
    const double mul = c->col[j].def.friction * kfac(c, i) * (c->dhat - d);
    if (!(mul > 0.0)) return 0.0;
    double vc[3], vr[3];
    collider_velocity(c, j, c->xn + 3 * (int64_t)i, vc);
    for (int k = 0; k < 3; ++k) vr[k] = v[3 * (int64_t)i + k] - vc[k];
    const double vn = defsim__v3_dot(vr, n);
    for (int k = 0; k < 3; ++k) vt[k] = vr[k] - vn * n[k];
    *y = sqrt(defsim__v3_dot(vt, vt));
    return mul;
}

static defsim_status contact_forces(defsim__contact *c, const double *x, const double *v,
                                   uint32_t which, double *f);

defsim_status defsim__contact_forces(defsim__contact *c, const double *x, const double *v,
                                     uint32_t which, double *f)
{
    const double t0 = defsim__now();
    ensure(c, x);
    const defsim_status st = contact_forces(c, x, v, which, f);
    c->stat[DEFSIM__CSTAT_TIME_EVAL] += defsim__now() - t0;
    return st;
}

static defsim_status contact_forces(defsim__contact *c, const double *x, const double *v,
                                   uint32_t which, double *f)
{
    const int elastic = (which & DEFSIM_FORCE_ELASTIC) != 0;
    const int damping = (which & DEFSIM_FORCE_DAMPING) && v && c->mode == DEFSIM__CONTACT_PENALTY;
    /* The velocities for the friction blocks of the matrices; no pair, no block. */
    if (damping && c->npair > 0) memcpy(c->vel, v, 3 * (size_t)c->nv * sizeof *v);
    if (!elastic && !damping) return DEFSIM_OK;
    const double dh = c->dhat, eps = c->eps_v * c->h;
    for (int32_t q = 0; q < c->npair; ++q) {
        if (c->off[q]) continue;
        const int32_t i = c->pv[q];
        double *fi = f + 3 * (int64_t)i, n[3];
        const double d = distance(c, c->pc[q], x + 3 * (int64_t)i, n, NULL) - vxi(c, i);
        if (isnan(d)) return c->failed;
        if (c->mode == DEFSIM__CONTACT_BARRIER) {
            if (!elastic) continue;
            if (d <= 0.0) return DEFSIM_ERR_UNSTABLE;
            if (d < dh) {
                const double s = -kfac(c, i) * barrier_d1(d, dh);
                for (int k = 0; k < 3; ++k) fi[k] += s * n[k];
            }
            double ut[3], y;
            const double mul = friction_tangent(c, q, x, ut, &y);
            if (mul > 0.0) {
                const double s = mul * friction_f1_over_y(y, eps);
                for (int k = 0; k < 3; ++k) fi[k] -= s * ut[k];
            }
            continue;
        }
        if (!(d < dh)) continue;
        if (elastic)
            for (int k = 0; k < 3; ++k) fi[k] += kfac(c, i) * (dh - d) * n[k];
        if (damping) {
            double vt[3], y;
            const double mul = penalty_tangent(c, q, d, n, v, vt, &y);
            if (mul > 0.0) {
                const double s = mul * friction_f1_over_y(y, c->eps_v);
                for (int k = 0; k < 3; ++k) fi[k] -= s * vt[k];
            }
        }
    }
    return c->failed;
}

static int contact_blocks(defsim__contact *c, const double *x, double k, double kd,
                          double *blk);

int defsim__contact_blocks(defsim__contact *c, const double *x, double k, double kd,
                           double *blk)
{
    const double t0 = defsim__now();
    ensure(c, x);
    const int any = contact_blocks(c, x, k, kd, blk);
    c->stat[DEFSIM__CSTAT_TIME_EVAL] += defsim__now() - t0;
    return any;
}

static int contact_blocks(defsim__contact *c, const double *x, double k, double kd,
                          double *blk)
{
    memset(blk, 0, 9 * (size_t)c->nv * sizeof *blk);
    int any = 0;
    const double dh = c->dhat, eps = c->eps_v * c->h;
    for (int32_t q = 0; q < c->npair; ++q) {
        if (c->off[q]) continue;
        const int32_t i = c->pv[q];
        double n[3], H[9], B[9] = {0};
        const double d = distance(c, c->pc[q], x + 3 * (int64_t)i, n, H) - vxi(c, i);
        if (isnan(d)) return any;
        int add = 0;
        if (c->mode == DEFSIM__CONTACT_BARRIER) {
            if (k == 0.0) continue;
            if (d > 0.0 && d < dh) {
                const double b1 = barrier_d1(d, dh), b2 = barrier_d2(d, dh), kap = kfac(c, i);
                for (int r = 0; r < 9; ++r) B[r] = kap * (b2 * n[r / 3] * n[r % 3] + b1 * H[r]);
                if (!c->exact) defsim__project_psd(3, B, DEFSIM_PROJECTION_CLAMP);
                for (int r = 0; r < 9; ++r) B[r] *= k;
                add = 1;
            }
            double ut[3], y;
            const double mul = friction_tangent(c, q, x, ut, &y);
            if (mul > 0.0) {
                friction_block(k * mul, c->nrm + 3 * (int64_t)q, ut, y, eps, B);
                add = 1;
            }
        } else if (d < dh) {
            if (k != 0.0) {
                const double kp = kfac(c, i);
                for (int r = 0; r < 9; ++r) B[r] = kp * (n[r / 3] * n[r % 3] - (dh - d) * H[r]);
                defsim__project_psd(3, B, DEFSIM_PROJECTION_CLAMP);
                for (int r = 0; r < 9; ++r) B[r] *= k;
                add = 1;
            }
            double vt[3], y;
            const double mul = kd != 0.0 ? penalty_tangent(c, q, d, n, c->vel, vt, &y) : 0.0;
            if (mul > 0.0) {
                friction_block(kd * mul, n, vt, y, c->eps_v, B);
                add = 1;
            }
        }
        if (!add) continue;
        for (int r = 0; r < 9; ++r) blk[9 * (int64_t)i + r] += B[r];
        any = 1;
    }
    return any;
}

/* The reverse mode (contact.h). Per pair, with k = khat m_i, the barrier's force is
 * f = -k b'(d) n, so (df/dx)^T w = -k (b'' n (n . w) + b' H w). Friction's is f = -mu lam s(y) ut,
 * ut = P u, P = I - n0 n0^T, u = x_i - x_n,i - uc, s = f1(y)/y, with B = s P + (s'/y) ut ut^T
 * its exact Hessian in u (friction_block): (df/dx)^T w = -mu lam B w. The lagged quantities are
 * functions of x_n (the collider at its start pose): lam = -k b'(d0), n0 = grad d0 (dn0/dx_n =
 * H0), uc = C x_n - x_n + const with C = R1 R0^T; with F = s (w . ut), dF/du = B w and
 * dF/dn0 = -(n0 . u)(B w + s (n0 . w) n0) - s (n0 . w) u, so w^T f = -mu lam F has
 * d/dx_n = -F mu dlam/dx_n - mu lam (-B w - (C - I)^T B w + H0 dF/dn0).
 *
 * The poses (gpose): a collider moved by a small rigid motion g (dp, then dtheta about its
 * origin p: R' = (I + [dtheta]) R) has the distance d'(x) = d(g^-1 x), g^-1 x = x - dp -
 * dtheta x (x - p), and the gradient grad d'(x) = (I + [dtheta]) grad d(g^-1 x). The barrier's
 * force at the end pose thus changes by dtheta x f - J (dp + dtheta x (x - p)), J = df/dx:
 * w^T df/dp1 = -J^T w, w^T df/dtheta1 = f x w - (x - p1) x J^T w. Friction sees the end pose
 * only through the carried point c = x_n + uc = p1 + R1 R0^T (x_n - p0), u = x - c: with
 * gf = (df/du)^T w = -mu lam B w, dc = dp1 + dtheta1 x (c - p1) gives -gf and -(c - p1) x gf.
 * The start pose moves lam, n0 and c as x_n moved by dx = -dp0 - dtheta0 x (x_n - p0) would,
 * and turns n0 by dtheta0 x n0: with G0 = w^T df/dx_n of the pair (above), -G0 and
 * -(x_n - p0) x G0 - mu lam n0 x dF/dn0. */
static void add_pose_gradient(double *g, const double a[3], const double r[3])
{
    /* a point x of the pair that moves by dx = -dp - dtheta x r, with a = the pair's w^T df/dx
     * there: g[0..2] (dp) -= a, g[3..5] (dtheta) += a x r */
    double ar[3];
    defsim__v3_cross(a, r, ar);
    for (int k = 0; k < 3; ++k) {
        g[k] -= a[k];
        g[3 + k] += ar[k];
    }
}

defsim_status defsim__contact_vjp(defsim__contact *c, const double *x, const double *w,
                                  double *gx, double *gxn, double *gmass, double *gmu,
                                  double *gpose)
{
    if (c->mode != DEFSIM__CONTACT_BARRIER) return DEFSIM_ERR_UNSUPPORTED;
    if (c->blocked) return DEFSIM_ERR_UNSTABLE;
    ensure(c, x);
    const double dh = c->dhat, eps = c->eps_v * c->h;
    for (int32_t q = 0; q < c->npair && !c->failed; ++q) {
        if (c->off[q]) continue;
        const int32_t i = c->pv[q], j = c->pc[q];
        const double *xi = x + 3 * (int64_t)i, *wi = w + 3 * (int64_t)i;
        double n[3], H[9];
        const double d = distance(c, j, xi, n, H) - vxi(c, i);   /* beyond the offset */
        if (isnan(d)) break;
        if (d <= 0.0) return DEFSIM_ERR_UNSTABLE;
        const double k = kfac(c, i);
        double *gp0 = gpose ? gpose + 12 * (int64_t)j : NULL, *gp1 = gp0 ? gp0 + 6 : NULL;
        if (d < dh) {
            const double b1 = barrier_d1(d, dh), b2 = barrier_d2(d, dh), nw = defsim__v3_dot(n, wi);
            double Jw[3];
            for (int a = 0; a < 3; ++a)
                Jw[a] = -k * (b2 * n[a] * nw + b1 * (H[3 * a] * wi[0] + H[3 * a + 1] * wi[1] +
                                                     H[3 * a + 2] * wi[2]));
            for (int a = 0; a < 3 && gx; ++a) gx[3 * (int64_t)i + a] += Jw[a];
            if (gmass) gmass[i] -= c->khat * b1 * nw;
            if (gp1) {   /* -J^T w; f x w - (x - p1) x J^T w, f = -k b' n */
                double r[3], fw[3], f[3];
                for (int a = 0; a < 3; ++a) f[a] = -k * b1 * n[a];
                defsim__v3_sub(xi, c->pose1[j].p, r);
                defsim__v3_cross(f, wi, fw);
                add_pose_gradient(gp1, Jw, r);
                for (int a = 0; a < 3; ++a) gp1[3 + a] += fw[a];
            }
        }
        const double lam = c->lam[q], mu = c->col[j].def.friction;
        if (!(lam > 0.0)) continue;
        const double *n0 = c->nrm + 3 * (int64_t)q, *uc = c->uc + 3 * (int64_t)q,
                     *xn = c->xn + 3 * (int64_t)i;
        double u[3], ut[3], B[9] = {0}, Bw[3];
        for (int a = 0; a < 3; ++a) u[a] = xi[a] - xn[a] - uc[a];
        const double un = defsim__v3_dot(u, n0);
        for (int a = 0; a < 3; ++a) ut[a] = u[a] - un * n0[a];
        const double y = sqrt(defsim__v3_dot(ut, ut)), s = friction_f1_over_y(y, eps);
        friction_block(1.0, n0, ut, y, eps, B);
        for (int a = 0; a < 3; ++a) Bw[a] = B[3 * a] * wi[0] + B[3 * a + 1] * wi[1] + B[3 * a + 2] * wi[2];
        const double F = s * defsim__v3_dot(wi, ut);
        if (gmu) gmu[j] -= lam * F;
        if (!(mu > 0.0)) continue;
        const double mul = mu * lam;
        for (int a = 0; a < 3 && gx; ++a) gx[3 * (int64_t)i + a] -= mul * Bw[a];
        if (gmass) gmass[i] -= mul * F / c->mass[i];
        if (gp1) {   /* the carried point c = x_i - u: -gf and -(c - p1) x gf, gf = -mu lam B w */
            double gf[3], r[3];
            for (int a = 0; a < 3; ++a) {
                gf[a] = -mul * Bw[a];
                r[a] = xi[a] - u[a] - c->pose1[j].p[a];
            }
            add_pose_gradient(gp1, gf, r);
        }
        if (!gxn && !gp0) continue;
        double d0, g0[3], H0[9];
        if (defsim__collider_distance(&c->col[j], &c->pose0[j], xn, &d0, g0, H0) != DEFSIM_OK ||
            !isfinite(d0)) {
            geometry_failed(c, j);
            break;
        }
        const double nw = defsim__v3_dot(n0, wi), dlam = -k * barrier_d2(d0 - vxi(c, i), dh);
        double dFdn[3], dFdx[3];
        for (int a = 0; a < 3; ++a) {
            dFdn[a] = -un * (Bw[a] + s * nw * n0[a]) - s * nw * u[a];
            dFdx[a] = -Bw[a];
        }
        for (int a = 0; a < 3; ++a)
            dFdx[a] += H0[3 * a] * dFdn[0] + H0[3 * a + 1] * dFdn[1] + H0[3 * a + 2] * dFdn[2];
        if (moves(c, j)) {   /* uc's derivative (C - I)^T B w, C = R1 R0^T */
            const double *R0 = c->pose0[j].R, *R1 = c->pose1[j].R;
            double r[3];
            for (int a = 0; a < 3; ++a) r[a] = R1[a] * Bw[0] + R1[3 + a] * Bw[1] + R1[6 + a] * Bw[2];
            for (int a = 0; a < 3; ++a)
                dFdx[a] -= R0[3 * a] * r[0] + R0[3 * a + 1] * r[1] + R0[3 * a + 2] * r[2] - Bw[a];
        }
        double G0[3];
        for (int a = 0; a < 3; ++a) G0[a] = -(F * mu * dlam * g0[a] + mul * dFdx[a]);
        for (int a = 0; a < 3 && gxn; ++a) gxn[3 * (int64_t)i + a] += G0[a];
        if (gp0) {   /* -G0; -(x_n - p0) x G0 - mu lam n0 x dF/dn0 */
            double r[3], nf[3];
            defsim__v3_sub(xn, c->pose0[j].p, r);
            defsim__v3_cross(n0, dFdn, nf);
            add_pose_gradient(gp0, G0, r);
            for (int a = 0; a < 3; ++a) gp0[3 + a] -= mul * nf[a];
        }
    }
    return c->failed;
}

/* ------------------------------------------------------------------------------------------ */
/* The witness guard. Contact acts on vertices only, so a body whose elements stretch around a
 * small collider can pass it with every vertex outside: Newton's iterates did that with a soft
 * box against a sphere, its faces sliding over the sphere until the box was free below. The
 * line search and the Newton start therefore also keep the bodies' surface triangles and edges
 * from sweeping across each collider's witness: its core (the shape shrunk to half its size
 * about its centre), as its centre (sphere), axis (capsule) or corners and edges (box, convex
 * mesh). A witness lies deeper inside than vertex-only contact lets an edge cut into the
 * collider while the edges are short against the collider (docs/contact.md), so contact that
 * holds without the guard never meets it; a body pushed across it stops there (the step fails
 * when Newton cannot converge). Planes and SDFs have none. */

enum { WIT_MAX_MESH = 64 };   /* convex meshes of at most this many vertices get a witness */

defsim_status defsim__contact_surfaces(defsim__contact *c, const defsim__body *bodies,
                                       int32_t nbodies)
{
    free(c->face); free(c->edge);
    c->face = c->edge = NULL;
    c->nface = c->nedge = 0;
    int64_t capf = 0, cape = 0;
    defsim_status st = DEFSIM_OK;
    for (int32_t b = 0; b < nbodies && st == DEFSIM_OK; ++b) {
        const defsim__body *bd = &bodies[b];
        if (!(bd->generation & 1u)) continue;
        int32_t *tris = NULL, nt = 0, *edges = NULL, ne = 0;
        if (bd->ntri > 0) {
            tris = malloc(3 * (size_t)bd->ntri * sizeof *tris);
            if (!tris) st = DEFSIM_ERR_OUT_OF_MEMORY;
            else memcpy(tris, bd->tris, 3 * (size_t)bd->ntri * sizeof *tris);
            nt = bd->ntri;
        } else if (bd->nt > 0) {
            st = defsim__tet_surface(bd->rest, bd->tets, bd->tet_nodes, bd->nt, &tris, &nt);
        }
        if (st == DEFSIM_OK && nt > 0) st = defsim__triangle_edges(tris, nt, &edges, &ne);
        const int32_t *src = edges;
        if (st == DEFSIM_OK && nt == 0 && bd->nedge > 0) {
            src = bd->edges;
            ne = bd->nedge;
        }
        if (st == DEFSIM_OK && 3 * ((int64_t)c->nface + nt) > capf) {
            capf = 2 * (3 * ((int64_t)c->nface + nt)) + 64;
            int32_t *f = realloc(c->face, (size_t)capf * sizeof *f);
            if (f) c->face = f;
            else st = DEFSIM_ERR_OUT_OF_MEMORY;
        }
        if (st == DEFSIM_OK && 2 * ((int64_t)c->nedge + ne) > cape) {
            cape = 2 * (2 * ((int64_t)c->nedge + ne)) + 64;
            int32_t *e = realloc(c->edge, (size_t)cape * sizeof *e);
            if (e) c->edge = e;
            else st = DEFSIM_ERR_OUT_OF_MEMORY;
        }
        if (st == DEFSIM_OK) {
            for (int64_t k = 0; k < 3 * (int64_t)nt; ++k)
                c->face[3 * (int64_t)c->nface + k] = tris[k] + bd->offset;
            for (int64_t k = 0; k < 2 * (int64_t)ne; ++k)
                c->edge[2 * (int64_t)c->nedge + k] = src[k] + bd->offset;
            c->nface += nt;
            c->nedge += ne;
        }
        free(tris);
        free(edges);
    }
    if (st != DEFSIM_OK) {
        free(c->face); free(c->edge);
        c->face = c->edge = NULL;
        c->nface = c->nedge = 0;
        return st;
    }
    c->surf_planned = 1;
    return DEFSIM_OK;
}

/* A collider's witness in world coordinates at `pose`: points (at most 8 of its own, or a
 * convex mesh's, up to WIT_MAX_MESH) and edges between them (index pairs). */
typedef struct witness {
    int np, ne;
    double p[WIT_MAX_MESH][3];
    int e[3 * 2 * WIT_MAX_MESH][2];
} witness;

/* Whether the mesh of collider j is convex (every vertex on the inner side of every face's
 * plane, to 1e-9 of its size). */
static int mesh_convex(const defsim__collider *col)
{
    const defsim_collider_def *d = &col->def;
    const double *x = col->mesh_x;
    double lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
    for (int32_t i = 0; i < d->vertex_count; ++i)
        for (int k = 0; k < 3; ++k) {
            lo[k] = fmin(lo[k], x[3 * i + k]);
            hi[k] = fmax(hi[k], x[3 * i + k]);
        }
    const double size = fmax(hi[0] - lo[0], fmax(hi[1] - lo[1], hi[2] - lo[2]));
    for (int32_t t = 0; t < d->triangle_count; ++t) {
        const int32_t *tr = col->mesh_t + 3 * t;
        const double *a = x + 3 * tr[0], *b = x + 3 * tr[1], *e = x + 3 * tr[2];
        const double u[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]};
        const double v[3] = {e[0] - a[0], e[1] - a[1], e[2] - a[2]};
        const double n[3] = {u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2],
                             u[0] * v[1] - u[1] * v[0]};
        const double len = sqrt(defsim__v3_dot(n, n));
        if (!(len > 0.0)) return 0;
        for (int32_t i = 0; i < d->vertex_count; ++i) {
            const double w[3] = {x[3 * i] - a[0], x[3 * i + 1] - a[1], x[3 * i + 2] - a[2]};
            if (defsim__v3_dot(w, n) / len > 1e-9 * size) return 0;
        }
    }
    return 1;
}

static int witness_of(const defsim__contact *c, int32_t j, const defsim__pose *pose, witness *w)
{
    const defsim__collider *col = &c->col[j];
    const defsim_collider_def *d = &col->def;
    double l[WIT_MAX_MESH][3];
    w->np = w->ne = 0;
    switch (d->shape) {
    case DEFSIM_SHAPE_SPHERE:
        l[0][0] = l[0][1] = l[0][2] = 0.0;
        w->np = 1;
        break;
    case DEFSIM_SHAPE_CAPSULE:
        for (int s = 0; s < 2; ++s) {
            l[s][0] = l[s][2] = 0.0;
            l[s][1] = (s ? 0.5 : -0.5) * d->half_height;
        }
        w->np = d->half_height > 0.0 ? 2 : 1;
        if (w->np == 2) {
            w->e[0][0] = 0;
            w->e[0][1] = 1;
            w->ne = 1;
        }
        break;
    case DEFSIM_SHAPE_BOX:
        for (int i = 0; i < 8; ++i)
            for (int k = 0; k < 3; ++k) l[i][k] = ((i >> k) & 1 ? 0.5 : -0.5) * d->half_extents[k];
        w->np = 8;
        for (int i = 0; i < 8; ++i)
            for (int k = 0; k < 3; ++k)
                if (!((i >> k) & 1)) {
                    w->e[w->ne][0] = i;
                    w->e[w->ne++][1] = i | (1 << k);
                }
        break;
    case DEFSIM_SHAPE_MESH: {
        if (d->vertex_count > WIT_MAX_MESH || d->triangle_count > 2 * WIT_MAX_MESH ||
            !mesh_convex(col))
            return 0;
        double m[3] = {0.0, 0.0, 0.0};
        for (int32_t i = 0; i < d->vertex_count; ++i)
            for (int k = 0; k < 3; ++k) m[k] += col->mesh_x[3 * i + k] / d->vertex_count;
        for (int32_t i = 0; i < d->vertex_count; ++i)
            for (int k = 0; k < 3; ++k) l[i][k] = m[k] + 0.5 * (col->mesh_x[3 * i + k] - m[k]);
        w->np = d->vertex_count;
        for (int32_t t = 0; t < d->triangle_count; ++t)
            for (int k = 0; k < 3; ++k) {
                w->e[w->ne][0] = col->mesh_t[3 * t + k];
                w->e[w->ne++][1] = col->mesh_t[3 * t + (k + 1) % 3];
            }
        break;
    }
    default:
        return 0;
    }
    for (int i = 0; i < w->np; ++i)
        for (int k = 0; k < 3; ++k)
            w->p[i][k] = pose->p[k] + pose->R[3 * k] * l[i][0] + pose->R[3 * k + 1] * l[i][1] +
                         pose->R[3 * k + 2] * l[i][2];
    return w->np > 0;
}

/* The box around n vertices idx of x and of x + dx (dx may be NULL). */
static void swept_box(const double *x, const double *dx, const int32_t *idx, int n, double lo[3],
                      double hi[3])
{
    for (int k = 0; k < 3; ++k) {
        lo[k] = INFINITY;
        hi[k] = -INFINITY;
    }
    for (int a = 0; a < n; ++a) {
        const double *p = x + 3 * (int64_t)idx[a];
        for (int k = 0; k < 3; ++k) {
            const double q = dx ? p[k] + dx[3 * (int64_t)idx[a] + k] : p[k];
            lo[k] = fmin(lo[k], fmin(p[k], q));
            hi[k] = fmax(hi[k], fmax(p[k], q));
        }
    }
}

static int in_box(const double lo[3], const double hi[3], const double p[3])
{
    return p[0] >= lo[0] && p[0] <= hi[0] && p[1] >= lo[1] && p[1] <= hi[1] && p[2] >= lo[2] &&
           p[2] <= hi[2];
}

enum { WIT_CCD_ITERATIONS = 5000 };

/* The additive CCD of one primitive pair against a witness, keeping the pair at least dhat
 * and DEFSIM__CONTACT_FRACTION of its distance apart: with no barrier between them, Newton
 * could otherwise push a triangle ever closer to the witness until rounding lets it through. */
static double witness_pair(const defsim__contact *c, int pt, const double X[12],
                           const double D[12], double tmax)
{
    const double d2 = pt ? defsim__pt_dist2(X, X + 3, X + 6, X + 9, NULL, NULL, NULL)
                         : defsim__ee_dist2(X, X + 3, X + 6, X + 9, NULL, NULL, NULL);
    if (!(d2 > 0.0) || !isfinite(d2)) return 0.0;   /* touching, or not a number */
    const double d = sqrt(d2), s = fmax(DEFSIM__CONTACT_FRACTION, c->dhat / d);
    if (!(s < 0.99)) return 0.0;
    return pt ? defsim__pt_accd(X, D, s, tmax, WIT_CCD_ITERATIONS)
              : defsim__ee_accd(X, D, s, tmax, WIT_CCD_ITERATIONS);
}

/* Largest t in [0, tmax] such that no surface triangle of x + t' dx (t' <= t) sweeps across a
 * witness point of w, nor a surface edge across a witness edge. With `hit`, every primitive is
 * tested up to tmax and the vertices of those that would sweep across are marked in hit. */
static double witness_toi(const defsim__contact *c, const witness *w, const double *x,
                          const double *dx, double tmax, uint8_t *hit)
{
    double X[12], D[12], tmin = tmax;
    for (int32_t f = 0; f < c->nface && tmin > 0.0; ++f) {
        const int32_t *t = c->face + 3 * (int64_t)f;
        double lo[3], hi[3];
        swept_box(x, dx, t, 3, lo, hi);
        for (int i = 0; i < w->np && tmin > 0.0; ++i) {
            if (!in_box(lo, hi, w->p[i])) continue;
            memcpy(X, w->p[i], 3 * sizeof *X);
            memset(D, 0, 3 * sizeof *D);
            for (int a = 0; a < 3; ++a)
                for (int k = 0; k < 3; ++k) {
                    X[3 + 3 * a + k] = x[3 * (int64_t)t[a] + k];
                    D[3 + 3 * a + k] = dx[3 * (int64_t)t[a] + k];
                }
            const double ti = witness_pair(c, 1, X, D, hit ? tmax : tmin);
            if (hit && ti < tmax) hit[t[0]] = hit[t[1]] = hit[t[2]] = 1;
            else tmin = fmin(tmin, ti);
        }
    }
    for (int32_t e = 0; e < c->nedge && tmin > 0.0 && w->ne > 0; ++e) {
        const int32_t *ed = c->edge + 2 * (int64_t)e;
        double lo[3], hi[3];
        swept_box(x, dx, ed, 2, lo, hi);
        for (int i = 0; i < w->ne && tmin > 0.0; ++i) {
            const double *a = w->p[w->e[i][0]], *b = w->p[w->e[i][1]];
            int miss = 0;
            for (int k = 0; k < 3; ++k)
                miss |= fmax(a[k], b[k]) < lo[k] || fmin(a[k], b[k]) > hi[k];
            if (miss) continue;
            for (int a2 = 0; a2 < 2; ++a2)
                for (int k = 0; k < 3; ++k) {
                    X[3 * a2 + k] = x[3 * (int64_t)ed[a2] + k];
                    D[3 * a2 + k] = dx[3 * (int64_t)ed[a2] + k];
                }
            memcpy(X + 6, a, 3 * sizeof *X);
            memcpy(X + 9, b, 3 * sizeof *X);
            memset(D + 6, 0, 6 * sizeof *D);
            const double ti = witness_pair(c, 0, X, D, hit ? tmax : tmin);
            if (hit && ti < tmax) hit[ed[0]] = hit[ed[1]] = 1;
            else tmin = fmin(tmin, ti);
        }
    }
    return tmin;
}

/* The guard over every live collider at its end pose, from x along dx; colliders whose witness
 * lies outside the box swept by all vertices cost one box test. */
static double witness_max_step(defsim__contact *c, const double *x, const double *dx,
                               double tmax)
{
    if (c->far || (c->nface == 0 && c->nedge == 0)) return tmax;
    double lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
    for (int64_t i = 0; i < c->nv; ++i)
        for (int k = 0; k < 3; ++k) {
            const double a = x[3 * i + k], b = a + dx[3 * i + k];
            lo[k] = fmin(lo[k], fmin(a, b));
            hi[k] = fmax(hi[k], fmax(a, b));
        }
    witness w;
    for (int32_t j = 0; j < c->ncol && tmax > 0.0; ++j) {
        if (!live(c, j) || !witness_of(c, j, &c->pose1[j], &w)) continue;
        int near = 0;
        for (int i = 0; i < w.np && !near; ++i) near = in_box(lo, hi, w.p[i]);
        for (int i = 0; i < w.ne && !near; ++i) {
            const double *a = w.p[w.e[i][0]], *b = w.p[w.e[i][1]];
            int miss = 0;
            for (int k = 0; k < 3; ++k)
                miss |= fmax(a[k], b[k]) < lo[k] || fmin(a[k], b[k]) > hi[k];
            near = !miss;
        }
        if (near) tmax = witness_toi(c, &w, x, dx, tmax, NULL);
    }
    return tmax;
}

/* ------------------------------------------------------------------------------------------ */
/* Continuous collision detection and the feasible start */

double defsim__contact_max_step(defsim__contact *c, const double *x, const double *dx,
                                double fraction)
{
    const double t0 = defsim__now();
    /* The safe box and the balls are convex: holding both ends covers the whole segment (an
     * evaluated x is in its balls). */
    if (c->far && !(in_safe(c, x, NULL) && in_safe(c, x, dx))) {
        leave_far(c);
        ensure(c, x);
    }
    for (int32_t i = 0; i < c->nv && !c->far; ++i) {
        if (c->pinned[i]) continue;
        const double *a = x + 3 * (int64_t)i, *u = dx + 3 * (int64_t)i, *b = c->xn + 3 * (int64_t)i;
        double d2 = 0.0;
        for (int k = 0; k < 3; ++k) d2 += (a[k] + u[k] - b[k]) * (a[k] + u[k] - b[k]);
        if (d2 <= c->radius[i] * c->radius[i]) continue;
        c->radius[i] = 2.0 * sqrt(d2);
        pair_vertex(c, i, 1);
    }
    double alpha = 1.0;
    for (int32_t q = 0; q < c->npair && alpha > 0.0; ++q) {
        if (c->off[q]) continue;
        const int32_t i = c->pv[q], j = c->pc[q];
        const double *a = x + 3 * (int64_t)i, *u = dx + 3 * (int64_t)i;
        const double len = sqrt(defsim__v3_dot(u, u));
        if (len == 0.0) continue;
        /* beyond the thickness offset: no vertex comes closer than xi + fraction (d - xi) */
        const double xo = vxi(c, i);
        const double d = distance(c, j, a, NULL, NULL) - xo;
        if (isnan(d) || d <= 0.0) {
            alpha = 0.0;
            break;
        }
        if (len <= (1.0 - fraction) * d) continue;   /* cannot come closer than fraction d */
        const double b[3] = {a[0] + u[0], a[1] + u[1], a[2] + u[2]};
        double t = 1.0;
        if (defsim__collider_toi(&c->col[j], &c->pose1[j], a, b, fraction * d + xo, &t) !=
            DEFSIM_OK) {
            geometry_failed(c, j);
            alpha = 0.0;
            break;
        }
        if (t < alpha) alpha = t;
    }
    if (c->mode == DEFSIM__CONTACT_BARRIER && alpha > 0.0 && !c->failed)
        alpha = witness_max_step(c, x, dx, alpha);
    if (c->failed) alpha = 0.0;
    c->stat[DEFSIM__CSTAT_TIME_CCD] += defsim__now() - t0;
    c->stat[DEFSIM__CSTAT_CCD_CALLS] += 1.0;
    return alpha;
}

/* Whether the straight segment from a to b (world, collider j at its end pose) keeps a
 * clearance of `clear` to collider j; 0 also on a callback failure (recorded). */
static int clear_path(defsim__contact *c, int32_t j, const double a[3], const double b[3],
                      double clear)
{
    if (a[0] == b[0] && a[1] == b[1] && a[2] == b[2]) return 1;
    double t = 1.0;
    if (defsim__collider_toi(&c->col[j], &c->pose1[j], a, b, clear, &t) != DEFSIM_OK) {
        geometry_failed(c, j);
        return 0;
    }
    return t >= 1.0;
}

/* Where x_n of vertex i sits relative to collider j at the end of the step (x_n carried with
 * the collider's motion) and its distance there (that at the start pose, up to rounding); NaN
 * on a callback failure. */
static double start_in_frame(defsim__contact *c, int32_t i, int32_t j, double a[3])
{
    const double *xi = c->xn + 3 * (int64_t)i;
    if (moves(c, j)) carry(&c->pose0[j], &c->pose1[j], xi, a);
    else memcpy(a, xi, 3 * sizeof *a);
    return distance(c, j, a, NULL, NULL) - vxi(c, i);
}

/* The guess must not start Newton past a collider: the barrier is finite on the far side of a
 * thin one, and Newton would converge there. Each vertex's motion relative to a collider is
 * the straight segment, in the collider's frame, from its start to the base, then to the start
 * of Newton (and on by the CCD-limited updates): none crosses the collider. */
int defsim__contact_start(defsim__contact *c, double *x)
{
    const int64_t n3 = 3 * (int64_t)c->nv;
    double *base = c->base, *dx = c->dstart;
    const double fr = DEFSIM__CONTACT_FRACTION;
    c->blocked = 0;
    /* Pairs for every vertex whose guess left its ball; the ball about x_n then holds the whole
     * segment to the guess. Still far: x_n and the guess lie in the safe box, and so does the
     * segment between them, which no collider comes near. */
    ensure(c, x);
    if (c->far) return 0;
    memcpy(base, c->xn, (size_t)n3 * sizeof *base);
    for (int32_t i = 0; i < c->nv; ++i) {
        c->carrier[i] = -1;
        if (c->pinned[i]) memcpy(base + 3 * (int64_t)i, x + 3 * (int64_t)i, 3 * sizeof *x);
    }
    /* The carriers: a moving collider that would pass over the vertex standing still. */
    for (int32_t q = 0; q < c->npair && !c->failed; ++q) {
        const int32_t i = c->pv[q], j = c->pc[q];
        if (c->off[q] || !moves(c, j) || c->carrier[i] >= 0) continue;
        double a[3];
        const double d0 = start_in_frame(c, i, j, a);
        if (!(d0 > 0.0)) continue;   /* NaN (recorded) or inside at the start: no promise */
        if (clear_path(c, j, a, c->xn + 3 * (int64_t)i, fr * fmin(d0, c->dhat) + vxi(c, i)))
            continue;
        if (c->failed) return 0;
        c->carrier[i] = j;
        memcpy(base + 3 * (int64_t)i, a, sizeof a);
    }
    /* A moving collider's witness must not sweep across a surface triangle or edge either
     * (it would pass between the vertices): such primitives ride with the collider too. */
    for (int32_t j = 0; j < c->ncol && !c->failed && (c->nface > 0 || c->nedge > 0); ++j) {
        witness w;
        if (!live(c, j) || !moves(c, j) || !witness_of(c, j, &c->pose1[j], &w)) continue;
        double *cpos = c->cpos, *rel = dx;
        uint8_t *hit = c->hit;
        for (int pass = 0; pass < 4; ++pass) {
            for (int32_t i = 0; i < c->nv; ++i) {
                double *ci = cpos + 3 * (int64_t)i;
                if (c->carrier[i] == j || c->pinned[i])
                    memcpy(ci, base + 3 * (int64_t)i, 3 * sizeof *ci);
                else carry(&c->pose0[j], &c->pose1[j], c->xn + 3 * (int64_t)i, ci);
                for (int k = 0; k < 3; ++k)
                    rel[3 * (int64_t)i + k] = base[3 * (int64_t)i + k] - ci[k];
                hit[i] = 0;
            }
            (void)witness_toi(c, &w, cpos, rel, 1.0, hit);
            int any = 0;
            for (int32_t i = 0; i < c->nv; ++i) {
                if (!hit[i] || c->pinned[i] || c->carrier[i] == j) continue;
                if (c->carrier[i] >= 0) {   /* carried by another collider already */
                    defsim__contact_block(c, i);
                    break;
                }
                c->carrier[i] = j;
                memcpy(base + 3 * (int64_t)i, cpos + 3 * (int64_t)i, 3 * sizeof *base);
                any = 1;
            }
            if (!any || c->blocked) break;
            if (pass == 3) defsim__contact_block(c, -1);   /* still sweeping: give up cleanly */
        }
        if (c->blocked) return 0;
    }
    /* Every collider must keep clear of the way from the vertex's start to its base. */
    int carried = 0;
    for (int32_t i = 0; i < c->nv; ++i) carried |= c->carrier[i] >= 0;
    for (int32_t q = 0; q < c->npair && !c->failed && !c->blocked; ++q) {
        const int32_t i = c->pv[q], j = c->pc[q];
        if (c->off[q] || c->carrier[i] < 0 || c->carrier[i] == j) continue;
        double a[3];
        const double d0 = start_in_frame(c, i, j, a);
        if (!(d0 > 0.0)) continue;
        if (!clear_path(c, j, a, base + 3 * (int64_t)i, fr * fmin(d0, c->dhat) + vxi(c, i)) &&
            !c->failed)
            defsim__contact_block(c, i);
    }
    if (c->failed || c->blocked) return 0;
    ensure(c, base);
    for (int64_t k = 0; k < n3; ++k) dx[k] = x[k] - base[k];
    /* Fraction 0: only a path that reaches a collider (or sweeps a surface across a witness)
     * counts; a guess that merely comes close is kept, as before. */
    const double alpha = defsim__contact_max_step(c, base, dx, 0.0);
    /* The whole way is clear: the guess is kept as it is (base + (x - base) may round
     * differently). */
    if (alpha >= 1.0) return carried;
    /* Otherwise Newton starts at the base, as it did at x_n when the guess lay inside a
     * collider (a guess past a thin one now does the same): a start cut to just short of the
     * collider would leave a vertex where the barrier is steepest. */
    for (int32_t i = 0; i < c->nv; ++i)
        if (!c->pinned[i]) memcpy(x + 3 * (int64_t)i, base + 3 * (int64_t)i, 3 * sizeof *x);
    ensure(c, x);
    return carried | 2;
}

void defsim__contact_block(defsim__contact *c, int32_t vertex)
{
    c->blocked = 1;
    c->blocked_vertex = vertex;
}

/* ------------------------------------------------------------------------------------------ */
/* The end of a step */

int defsim__contact_none(defsim__contact *c, const double *x)
{
    const double t0 = defsim__now();
    ensure(c, x);
    c->stat[DEFSIM__CSTAT_TIME_BROAD] += defsim__now() - t0;
    return c->npair == 0 && !c->failed;
}

void defsim__contact_end(defsim__contact *c, const double *x, const double *v, double *f)
{
    memset(f, 0, 3 * (size_t)c->nv * sizeof *f);
    if (c->npair > 0)
        (void)defsim__contact_forces(c, x, v, DEFSIM_FORCE_ELASTIC | DEFSIM_FORCE_DAMPING, f);
    double dmin = INFINITY;
    int32_t active = 0;
    for (int32_t q = 0; q < c->npair; ++q) {
        if (c->off[q]) continue;
        const int32_t i = c->pv[q];
        const double d = distance(c, c->pc[q], x + 3 * (int64_t)i, NULL, NULL) - vxi(c, i);
        if (d < dmin) dmin = d;
        active += d < c->dhat;
    }
    c->stat[DEFSIM__CSTAT_ACTIVE] = active;
    c->stat[DEFSIM__CSTAT_MIN_DISTANCE] = dmin;
}

/* ------------------------------------------------------------------------------------------ */
/* The watchdog's view */

/* Energy (J, no friction) of pair q at x with its collider at `pose`, and the force on the
 * vertex into f; a barrier pair at d <= 0 gives +inf (NaN on a callback failure). */
static double pair_term(defsim__contact *c, int32_t q, const defsim__pose *pose, const double *x,
                        double f[3])
{
    const int32_t i = c->pv[q];
    double d, n[3];
    f[0] = f[1] = f[2] = 0.0;
    if (defsim__collider_distance(&c->col[c->pc[q]], pose, x + 3 * (int64_t)i, &d, n, NULL) !=
            DEFSIM_OK || !isfinite(d))
        return NAN;
    d -= vxi(c, i);
    const double dh = c->dhat, k = kfac(c, i);
    if (!(d < dh)) return 0.0;
    if (c->mode == DEFSIM__CONTACT_BARRIER) {
        if (d <= 0.0) {
            f[0] = f[1] = f[2] = INFINITY;
            return INFINITY;
        }
        const double s = -k * barrier_d1(d, dh);
        for (int a = 0; a < 3; ++a) f[a] = s * n[a];
        return k * barrier(d, dh);
    }
    for (int a = 0; a < 3; ++a) f[a] = k * (dh - d) * n[a];
    return 0.5 * k * (dh - d) * (dh - d);
}

double defsim__contact_energy_start(defsim__contact *c, const double *x)
{
    double e = 0.0, f[3];
    for (int32_t q = 0; q < c->npair; ++q) {
        if (c->off[q]) continue;
        defsim__pose p0;
        defsim__collider_pose_at(&c->col[c->pc[q]], 0.0, &p0);
        const double u = pair_term(c, q, &p0, x, f);
        if (isnan(u)) return INFINITY;
        if (u < INFINITY) e += u;
    }
    return e;
}

double defsim__contact_work(defsim__contact *c, const double *x0, const double *x1)
{
    int any = 0;
    for (int32_t j = 0; j < c->ncol && !any; ++j)
        any = live(c, j) && (memcmp(c->col[j].pos, c->col[j].pos1, sizeof c->col[j].pos) != 0 ||
                             memcmp(c->col[j].rot, c->col[j].rot1, sizeof c->col[j].rot) != 0);
    if (!any) return 0.0;
    ensure(c, x1);
    double w = 0.0;
    for (int32_t q = 0; q < c->npair; ++q) {
        if (c->off[q]) continue;
        const int32_t i = c->pv[q];
        const defsim__collider *col = &c->col[c->pc[q]];
        defsim__pose p0, p1;
        defsim__collider_pose_at(col, 0.0, &p0);
        defsim__collider_pose_at(col, 1.0, &p1);
        const double *a = x0 + 3 * (int64_t)i, *b = x1 + 3 * (int64_t)i;
        double ua[3], ub[3], fa[3], fb[3], fc[3];
        carry(&p0, &p1, a, ua);
        carry(&p0, &p1, b, ub);
        for (int k = 0; k < 3; ++k) {
            ua[k] -= a[k];
            ub[k] -= b[k];
        }
        const double e0 = pair_term(c, q, &p0, x0, fa);
        if (isnan(e0) || isnan(pair_term(c, q, &p1, x0, fb)) ||
            isnan(pair_term(c, q, &p1, x1, fc)))
            return INFINITY;
        if (e0 == INFINITY) fa[0] = fa[1] = fa[2] = 0.0;   /* starts inside: left out (above) */
        const double pa = defsim__v3_dot(fa, ua), pb = defsim__v3_dot(fb, ua);
        const double pc = defsim__v3_dot(fc, ub);
        const double fbig = fmax(sqrt(defsim__v3_dot(fa, fa)),
                                 fmax(sqrt(defsim__v3_dot(fb, fb)), sqrt(defsim__v3_dot(fc, fc))));
        const double ubig = fmax(sqrt(defsim__v3_dot(ua, ua)), sqrt(defsim__v3_dot(ub, ub)));
        const double fr = col->def.friction > 0.0 ? col->def.friction * fbig * ubig : 0.0;
        w += fmax(pa, fmax(pb, pc)) + fr;
    }
    return isnan(w) ? INFINITY : w;
}

double defsim__contact_damping_rate(defsim__contact *c, const double *x, const double gravity[3])
{
    if (c->mode != DEFSIM__CONTACT_PENALTY || !(c->eps_v > 0.0) || c->mu_max == 0.0) return 0.0;
    ensure(c, x);
    /* -d f / d v_t of the friction at rest is 2 mu lam / eps_v, lam / m_i = khat (dhat - d).
     * Contact that is not active at x may be later, and deeper than a vertex's own weight
     * pushes it (|g| / khat): a vertex under a body rests about where the penalty starts to
     * overlap, d = 0, so the rate is taken at that depth, dhat, at least. */
    double depth = fmax(sqrt(defsim__v3_dot(gravity, gravity)) / c->khat, c->dhat);
    for (int32_t q = 0; q < c->npair; ++q) {
        const int32_t i = c->pv[q];
        const double d = distance(c, c->pc[q], x + 3 * (int64_t)i, NULL, NULL) - vxi(c, i);
        if (d < c->dhat && c->col[c->pc[q]].def.friction > 0.0) depth = fmax(depth, c->dhat - d);
    }
    return 2.0 * c->mu_max * c->khat * depth / c->eps_v;
}
