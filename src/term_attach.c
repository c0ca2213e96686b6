/* SPDX-License-Identifier: MIT */
/*
 * Attachments (system.h's defsim__attachments, built by plan.c): zero-rest-length springs on
 * d = sum_j a_j x[node_j] - p, energy k/2 |d|^2, with dampers -c a_j sum_l a_l v[node_l].
 * Few, and sharing vertices freely, so one thread in a fixed order.
 *
 * The kind also carries the step hooks of the coupling set the attachments belong to (driven
 * pins, the callback at an implicit step's start; coupling_set.h): the first of the coupling
 * set's kinds in the list, so its begin runs before contact's, which read the pins' velocities.
 */
#include "adjoint.h"
#include "assembly.h"
#include "coupling_set.h"
#include "element.h"
#include "system.h"
#include "term_cache.h"

#include <math.h>
#include <stdlib.h>

static int compile(defsim__system *s, defsim__term *out)
{
    return defsim__term_one(s->att.n > 0, &s->att, NULL, 0, out);
}

static double energy(const defsim__term *t, const defsim__system *s, defsim__work *wk,
                     const double *x, double total)
{
    (void)s;
    (void)wk;
    const defsim__attachments *at = t->model;
    for (int32_t e = 0; e < at->n; ++e) {
        double d[3];
        attach_combine(at, e, x, 1, d);
        total += 0.5 * at->k[e] * (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
    }
    return total;
}

/* Springs (ELASTIC) and dampers (DAMPING): f_j -= a_j (k d + c sum_l a_l v_l). */
static defsim_status forces(const defsim__term *t, const defsim__system *s, const defsim__eval *ev,
                            double *f, uint32_t *used)
{
    const defsim__attachments *at = t->model;
    const int elastic = (ev->which & DEFSIM_FORCE_ELASTIC) != 0;
    const int damping = (ev->which & DEFSIM_FORCE_DAMPING) && ev->v && s->has_attachment_damping;
    if (!elastic && !damping) return DEFSIM_OK;
    for (int32_t e = 0; e < at->n; ++e) {
        const int32_t *nd = at->node + DEFSIM__ATTACH_NODES * (int64_t)e;
        const double *a = at->a + DEFSIM__ATTACH_NODES * (int64_t)e;
        const double k = elastic ? at->k[e] : 0.0, c = damping ? at->c[e] : 0.0;
        double d[3] = {0.0, 0.0, 0.0}, w[3] = {0.0, 0.0, 0.0};
        if (k != 0.0) attach_combine(at, e, ev->x, 1, d);
        if (c != 0.0) attach_combine(at, e, ev->v, 0, w);
        for (int j = 0; j < DEFSIM__ATTACH_NODES; ++j)
            if (nd[j] >= 0)
                for (int i = 0; i < 3; ++i) f[3 * (int64_t)nd[j] + i] -= a[j] * (k * d[i] + c * w[i]);
    }
    *used |= DEFSIM_PASS_ATTACHMENTS;
    return DEFSIM_OK;
}

/* Reverse mode: with W = sum_j a_j w_j, w . f = -(k d + c u) . W (u = sum_l a_l v_l), so
 * node l gets -k a_l W in x and -c a_l W in v; k gets -d . W, c -u . W, a world target p
 * (every target node unused) k W. */
static defsim_status vjp(const defsim__term *t, const defsim__system *s, const defsim__eval *ev,
                         const double *w, double *gx, double *gv, defsim__grad *g)
{
    const defsim__attachments *at = t->model;
    const int elastic = (ev->which & DEFSIM_FORCE_ELASTIC) != 0;
    const int damping = (ev->which & DEFSIM_FORCE_DAMPING) && ev->v;
    if (!elastic && !damping) return DEFSIM_OK;
    const int damped = damping && s->has_attachment_damping;
    for (int32_t e = 0; e < at->n; ++e) {
        const int32_t *nd = at->node + DEFSIM__ATTACH_NODES * (int64_t)e;
        const double *a = at->a + DEFSIM__ATTACH_NODES * (int64_t)e;
        double W[3];
        attach_combine(at, e, w, 0, W);
        int point = 1;
        for (int j = 1; j < DEFSIM__ATTACH_NODES; ++j) point &= nd[j] < 0;
        for (int j = 0; j < DEFSIM__ATTACH_NODES; ++j) {
            if (nd[j] < 0) continue;
            for (int i = 0; i < 3; ++i) {
                if (elastic && gx) gx[3 * (int64_t)nd[j] + i] -= at->k[e] * a[j] * W[i];
                if (damped && gv) gv[3 * (int64_t)nd[j] + i] -= at->c[e] * a[j] * W[i];
            }
        }
        if (!g) continue;
        if (elastic) {
            double d[3];
            attach_combine(at, e, ev->x, 1, d);
            g->att_k[e] -= d[0] * W[0] + d[1] * W[1] + d[2] * W[2];
            if (point)
                for (int i = 0; i < 3; ++i) g->att_p[3 * (int64_t)e + i] += at->k[e] * W[i];
        }
        if (damping) {
            double u[3];
            attach_combine(at, e, ev->v, 0, u);
            g->att_c[e] -= u[0] * W[0] + u[1] * W[1] + u[2] * W[2];
        }
    }
    return DEFSIM_OK;
}

static void pairs(const defsim__term *t, const defsim__system *s, int64_t *pos, int32_t *list)
{
    const defsim__attachments *at = t->model;
    defsim__element_pairs(s, at->node, DEFSIM__ATTACH_NODES, at->n, pos, list);
}

static defsim_status ranks(const defsim__term *t, defsim__system *s)
{
    (void)t;
    free(s->att.blk);
    s->att.blk = defsim__element_ranks(s, s->att.node, DEFSIM__ATTACH_NODES, s->att.n);
    return s->att.blk ? DEFSIM_OK : DEFSIM_ERR_OUT_OF_MEMORY;
}

/* Free vertex of attachment e's node a, or -1 (unused node or pinned vertex). */
static int32_t attach_free(const defsim__system *s, const defsim__attachments *at, int64_t e,
                           int a)
{
    const int32_t v = at->node[DEFSIM__ATTACH_NODES * e + a];
    return v >= 0 ? s->vfree[v] : -1;
}

/* (k k_e + kd c_e) a_r a_s I3 in the block of node pair (r, s). */
static void values(const defsim__term *t, const defsim__system *s, const double *x,
                   const defsim_matrix_coeffs *c, int upper, const int64_t *cp, double *val,
                   uint32_t *passes)
{
    (void)x;
    if (c->k == 0.0 && c->kd == 0.0) return;
    const defsim__attachments *at = t->model;
    const int an = DEFSIM__ATTACH_NODES;
    for (int32_t e = 0; e < at->n; ++e) {
        const double w = c->k * at->k[e] + c->kd * at->c[e];
        const double *a = at->a + an * (int64_t)e;
        const int32_t *blk = at->blk + (int64_t)an * an * e;
        for (int rb = 0; rb < an; ++rb) {
            const int32_t fb = attach_free(s, at, e, rb);
            if (fb < 0) continue;
            for (int ra = 0; ra < an; ++ra) {
                const int32_t r = blk[ra * an + rb], fa = attach_free(s, at, e, ra);
                if (r < 0 || (upper && fa > fb)) continue;
                for (int cc = 0; cc < 3; ++cc)
                    val[cp[3 * (int64_t)fb + cc] + 3 * (int64_t)r + cc] += w * a[ra] * a[rb];
            }
        }
    }
    if (passes) *passes |= DEFSIM_PASS_HESSIAN | DEFSIM_PASS_ATTACHMENTS;
}

static void apply(const defsim__term *t, const defsim__system *s, const double *x,
                  const defsim_matrix_coeffs *c, int proj, const double *dx, double *out)
{
    (void)x;
    (void)proj;
    if (c->k == 0.0 && c->kd == 0.0) return;
    const defsim__attachments *at = t->model;
    for (int32_t e = 0; e < at->n; ++e) {
        const int32_t *nd = at->node + DEFSIM__ATTACH_NODES * (int64_t)e;
        const double *a = at->a + DEFSIM__ATTACH_NODES * (int64_t)e;
        const double w = c->k * at->k[e] + c->kd * at->c[e];
        double d[3] = {0.0, 0.0, 0.0};
        for (int j = 0; j < DEFSIM__ATTACH_NODES; ++j)
            if (nd[j] >= 0 && !s->pinned[nd[j]])
                for (int i = 0; i < 3; ++i) d[i] += a[j] * dx[3 * (int64_t)nd[j] + i];
        for (int j = 0; j < DEFSIM__ATTACH_NODES; ++j)
            if (nd[j] >= 0 && !s->pinned[nd[j]])
                for (int i = 0; i < 3; ++i) out[3 * (int64_t)nd[j] + i] += w * a[j] * d[i];
    }
}

/* A damper acts on its nodes at a rate of at most c sum_j a_j^2 / min m. */
static void rates(const defsim__term *t, const defsim__system *s, const double *x,
                  defsim__rates *r)
{
    (void)x;
    const defsim__attachments *at = t->model;
    for (int32_t e = 0; e < at->n; ++e) {
        if (at->c[e] == 0.0) continue;
        double a2 = 0.0, mmin = INFINITY;
        for (int j = 0; j < DEFSIM__ATTACH_NODES; ++j) {
            const int32_t v = at->node[DEFSIM__ATTACH_NODES * (int64_t)e + j];
            if (v < 0 || s->pinned[v]) continue;
            const double a = at->a[DEFSIM__ATTACH_NODES * (int64_t)e + j];
            a2 += a * a;
            if (s->mass[v] < mmin) mmin = s->mass[v];
        }
        if (a2 > 0.0 && at->c[e] * a2 / mmin > r->alpha) r->alpha = at->c[e] * a2 / mmin;
    }
}

/* The coupling set's step hooks (h = 0: no step, nothing to begin). */
static defsim_status restart(defsim__system *s, const defsim__step_ctx *c)
{
    return defsim__coupling_step_begin(c->coupling, s, c->state,
                                       (c->backend->flags & DEFSIM_BACKEND_IMPLICIT) != 0, c->h,
                                       c->passes, c->msg);
}

static defsim_status begin(defsim__system *s, const defsim__step_ctx *c)
{
    return c->h > 0.0 ? restart(s, c) : DEFSIM_OK;
}

static void before(const defsim__step_ctx *c, int64_t i, int64_t n)
{
    defsim__coupling_substep_before(c->coupling, c->state, i, n, c->h / (double)n);
}

static void after(const defsim__step_ctx *c)
{
    defsim__coupling_substep_after(c->coupling, c->state);
}

static defsim_status finish(defsim__system *s, const defsim__step_ctx *c, defsim_status st)
{
    return defsim__coupling_step_end(c->coupling, s, st);
}

const defsim__term_ops defsim__term_attach = {
    .name = "attach", .flags = DEFSIM__TERM_ELASTIC, .energy_rank = 2, .matrix_rank = 2,
    DEFSIM__TERM_FORCES, .pairs = pairs, .ranks = ranks, DEFSIM__TERM_MATRIX, .rates = rates,
    .begin = begin, .restart = restart, .before = before, .after = after, .finish = finish,
    .vjp = vjp};
