/* SPDX-License-Identifier: MIT */
/*
 * The world's coupling set (coupling_set.h): its workspaces, the step hooks that the world's
 * step calls (driven pins' targets and velocities per substep, the callback at the start of an
 * implicit step), and what a body's removal drops. It sees the system and the state it is
 * handed, never the world: the public API over it is coupling.c.
 *
 * Contents: workspaces; steps; bodies.
 */
#include "coupling_set.h"


#include <math.h>
#include <stdlib.h>
#include <string.h>

/* ------------------------------------------------------------------------------------------ */
/* Workspaces */

static void release_callback(defsim__coupling *c)
{
    free(c->f0); free(c->K0); free(c->x0); free(c->kcb); free(c->veval);
    free(c->rec_first); free(c->rec_last); free(c->rec_prev);
    c->f0 = c->K0 = c->x0 = c->kcb = c->veval = NULL;
    c->rec_first = c->rec_last = c->rec_prev = NULL;
    c->rec_prev_t = NAN;
}

static void release_drive(defsim__coupling *c)
{
    free(c->drv); free(c->drv_start); free(c->drv_target); free(c->drv_x0); free(c->drv_x1);
    free(c->pin_vel);
    c->drv = NULL;
    c->drv_start = c->drv_target = c->drv_x0 = c->drv_x1 = c->pin_vel = NULL;
}

defsim_status defsim__coupling_reserve(defsim__coupling_set *cs, int32_t nv, int has_pins)
{
    defsim__coupling *c = &cs->cpl;
    const size_t n = (size_t)(nv > 0 ? nv : 1);
    if (c->nv != nv) {
        release_callback(c);
        release_drive(c);
        c->nv = nv;
    }
    if (c->fn && !c->f0) {
        c->f0 = malloc(3 * n * sizeof *c->f0);
        c->x0 = malloc(3 * n * sizeof *c->x0);
        c->veval = malloc(3 * n * sizeof *c->veval);
        c->K0 = malloc(9 * n * sizeof *c->K0);
        c->kcb = malloc(9 * n * sizeof *c->kcb);
        c->rec_first = malloc(3 * n * sizeof *c->rec_first);
        c->rec_last = malloc(3 * n * sizeof *c->rec_last);
        c->rec_prev = malloc(3 * n * sizeof *c->rec_prev);
        c->rec_prev_t = NAN;
        if (!c->f0 || !c->x0 || !c->veval || !c->K0 || !c->kcb || !c->rec_first ||
            !c->rec_last || !c->rec_prev) {
            release_callback(c);
            return DEFSIM_ERR_OUT_OF_MEMORY;
        }
    }
    if (has_pins && !c->drv) {
        c->drv = malloc(3 * n * sizeof *c->drv);
        c->drv_start = malloc(3 * n * sizeof *c->drv_start);
        c->drv_target = malloc(3 * n * sizeof *c->drv_target);
        c->drv_x0 = malloc(3 * n * sizeof *c->drv_x0);
        c->drv_x1 = malloc(3 * n * sizeof *c->drv_x1);
        c->pin_vel = calloc(3 * n, sizeof *c->pin_vel);
        if (!c->drv || !c->drv_start || !c->drv_target || !c->drv_x0 || !c->drv_x1 ||
            !c->pin_vel) {
            release_drive(c);
            return DEFSIM_ERR_OUT_OF_MEMORY;
        }
    }
    return DEFSIM_OK;
}

void defsim__coupling_free(defsim__coupling_set *cs)
{
    release_callback(&cs->cpl);
    release_drive(&cs->cpl);
    free(cs->fext); free(cs->att); free(cs->pin_target); free(cs->targeted);
    defsim__id_pool_free(&cs->att_ids);
    memset(cs, 0, sizeof *cs);
}

/* ------------------------------------------------------------------------------------------ */
/* Steps */

defsim_status defsim__coupling_step_begin(defsim__coupling_set *cs, const defsim__system *s,
                                          defsim__state *state, int implicit, double h,
                                          uint32_t *passes, defsim__messages *msg)
{
    defsim__coupling *c = &cs->cpl;
    c->implicit = implicit;
    c->failed = 0;
    c->t0 = state->t;
    c->h = h;
    c->ndrv = 0;
    c->nrec = 0;
    if (s->has_pins && (cs->ntargeted > 0 || cs->drove)) {
        for (int32_t v = 0; v < s->nv; ++v) {
            if (!s->pinned[v]) continue;
            for (int k = 0; k < 3; ++k) {
                const int64_t d = 3 * (int64_t)v + k;
                double vel = 0.0;
                if (cs->targeted && cs->targeted[v]) {
                    c->drv[c->ndrv] = d;
                    c->drv_start[c->ndrv] = state->x[d];
                    c->drv_target[c->ndrv] = cs->pin_target[d];
                    c->ndrv++;
                    vel = (cs->pin_target[d] - state->x[d]) / h;
                }
                c->pin_vel[d] = vel;
                state->v[d] = vel;
            }
        }
        if (c->ndrv > 0) *passes |= DEFSIM_PASS_DRIVEN_PINS;
    }
    if (c->fn && c->implicit) {
        /* Implicit backends hold the callback (without a Jacobian) or model its energy (with
         * one) from its value at the start of the step. */
        const size_t bytes = 3 * (size_t)s->nv * sizeof(double);
        memset(c->f0, 0, bytes);
        memcpy(c->x0, state->x, bytes);
        defsim_status st = defsim__callback_forces(c, msg, s->nv, state->x, state->v, c->t0,
                                                   c->f0);
        if (st == DEFSIM_OK && c->jac)
            st = defsim__callback_stiffness(c, msg, s->nv, s->projection, state->x, state->v,
                                            c->t0, c->K0);
        if (st != DEFSIM_OK) return st;
        memcpy(c->veval, state->v, bytes);
        c->teval = c->t0;
        c->hold = c->jac == NULL;
        *passes |= DEFSIM_PASS_FORCE_CALLBACK;
    } else {
        c->hold = 0;
    }
    c->in_step = 1;
    return DEFSIM_OK;
}

void defsim__coupling_substep_before(defsim__coupling_set *cs, defsim__state *state, int64_t i,
                                     int64_t n, double hsub)
{
    defsim__coupling *c = &cs->cpl;
    c->t0 = state->t + (double)i * hsub;
    c->h = hsub;
    const double r = (double)(i + 1) / (double)n;
    for (int64_t k = 0; k < c->ndrv; ++k) {
        const int64_t d = c->drv[k];
        c->drv_x0[k] = state->x[d];
        c->drv_x1[k] = i + 1 == n ? c->drv_target[k]
                                  : c->drv_start[k] + r * (c->drv_target[k] - c->drv_start[k]);
        state->v[d] = c->pin_vel[d];
    }
}

void defsim__coupling_substep_after(defsim__coupling_set *cs, defsim__state *state)
{
    const defsim__coupling *c = &cs->cpl;
    for (int64_t k = 0; k < c->ndrv; ++k) {
        state->x[c->drv[k]] = c->drv_x1[k];
        state->v[c->drv[k]] = c->pin_vel[c->drv[k]];
    }
}

defsim_status defsim__coupling_step_end(defsim__coupling_set *cs, defsim__system *sys,
                                        defsim_status st)
{
    defsim__coupling *c = &cs->cpl;
    c->in_step = 0;
    c->hold = 0;
    if (c->failed) {
        c->failed = 0;
        st = DEFSIM_ERR_CALLBACK;   /* the callback's failure is the cause, whatever followed */
    }
    if (st == DEFSIM_OK) {
        cs->drove = c->ndrv > 0;
        c->ndrv_done = c->ndrv;   /* what a recording keeps of the step (tape.c) */
        if (cs->ntargeted > 0) memset(cs->targeted, 0, (size_t)sys->nv);
        cs->ntargeted = 0;
    }
    c->ndrv = 0;
    return st;
}

/* ------------------------------------------------------------------------------------------ */
/* Bodies */

void defsim__coupling_drop_body(defsim__coupling_set *cs, defsim_body_id id)
{
    for (int32_t i = 0; i < cs->natt; ++i) {
        defsim__attachment *a = &cs->att[i];
        if ((a->generation & 1u) &&
            (a->def.body.index == id.index || a->def.target_body.index == id.index))
            defsim__id_pool_remove(&cs->att_ids, i, &a->generation);
    }
}

/* ------------------------------------------------------------------------------------------ */
/* Checkpoint chunks */

/* A body id as a checkpoint keeps it: slot + 1 without the world's tag, 0 for none. */
static uint32_t saved_id(const defsim__id_pool *bodies, uint32_t index)
{
    const int64_t slot = index ? defsim__id_pool_slot(bodies, index) : -1;
    return slot < 0 ? 0 : (uint32_t)slot + 1;
}

void defsim__coupling_save(defsim__bw *b, const defsim__coupling_set *cs, int32_t nv,
                           const defsim__id_pool *bodies)
{
    for (int32_t i = 0; i < cs->natt; ++i) {
        const defsim__attachment *a = &cs->att[i];
        if (!(a->generation & 1u)) continue;
        const defsim_attachment_def *d = &a->def;
        const size_t c = defsim__chunk_begin(b, "ATCH");
        defsim__put_u32(b, saved_id(bodies, d->body.index));
        defsim__put_u32(b, d->body.generation);
        defsim__put_i32(b, d->vertex);
        defsim__put_f64(b, d->stiffness);
        defsim__put_f64(b, d->damping);
        defsim__put_f64s(b, d->target, 3);
        defsim__put_u32(b, saved_id(bodies, d->target_body.index));
        defsim__put_u32(b, d->target_body.generation);
        defsim__put_i32(b, d->target_vertex_count);
        defsim__put_i32s(b, d->target_vertices, 4);
        defsim__put_f64s(b, d->target_weights, 4);
        defsim__chunk_end(b, c);
    }
    if (cs->fext) {
        const size_t c = defsim__chunk_begin(b, "FEXT");
        defsim__put_f64s(b, cs->fext, 3 * (int64_t)nv);
        defsim__chunk_end(b, c);
    }
    if (cs->ntargeted > 0) {
        const size_t c = defsim__chunk_begin(b, "PTGT");
        defsim__put_u32(b, (uint32_t)cs->ntargeted);
        for (int32_t v = 0; v < nv; ++v)
            if (cs->targeted[v]) {
                defsim__put_i32(b, v);
                defsim__put_f64s(b, cs->pin_target + 3 * (int64_t)v, 3);
            }
        defsim__chunk_end(b, c);
    }
}

defsim_status defsim__attachment_read(defsim__br *r, defsim_attachment_def *d, uint32_t body[2],
                                      uint32_t target[2])
{
    body[0] = defsim__get_u32(r);
    body[1] = defsim__get_u32(r);
    d->vertex = defsim__get_i32(r);
    d->stiffness = defsim__get_f64(r);
    d->damping = defsim__get_f64(r);
    defsim__get_f64s(r, d->target, 3);
    target[0] = defsim__get_u32(r);
    target[1] = defsim__get_u32(r);
    d->target_vertex_count = defsim__get_i32(r);
    defsim__get_i32s(r, d->target_vertices, 4);
    defsim__get_f64s(r, d->target_weights, 4);
    if (target[0] == 0 && target[1] == 0) d->target_vertex_count = 0;
    return defsim__read_whole(r) ? DEFSIM_OK : DEFSIM_ERR_IO;
}

defsim_status defsim__coupling_load_targets(defsim__coupling_set *cs, defsim__br *r,
                                            int32_t nv, const uint8_t *pinned, const char **why)
{
    const uint32_t n = defsim__get_u32(r);
    if (!defsim__fits(r, n, 28) || n > (uint32_t)nv) {
        *why = "count out of range";
        return DEFSIM_ERR_IO;
    }
    if (!cs->pin_target) {
        cs->pin_target = malloc(3 * (size_t)nv * sizeof *cs->pin_target);
        cs->targeted = calloc((size_t)nv, 1);
        if (!cs->pin_target || !cs->targeted) return DEFSIM_ERR_OUT_OF_MEMORY;
    }
    for (uint32_t i = 0; i < n; ++i) {
        const int32_t v = defsim__get_i32(r);
        double p[3];
        defsim__get_f64s(r, p, 3);
        if (r->bad || v < 0 || v >= nv || !pinned[v] || cs->targeted[v] || !isfinite(p[0]) ||
            !isfinite(p[1]) || !isfinite(p[2])) {
            *why = "a target of a vertex that is not pinned, repeated or not finite";
            return DEFSIM_ERR_IO;
        }
        memcpy(cs->pin_target + 3 * (int64_t)v, p, sizeof p);
        cs->targeted[v] = 1;
        cs->ntargeted++;
    }
    if (!defsim__read_whole(r)) {
        *why = "wrong length";
        return DEFSIM_ERR_IO;
    }
    return DEFSIM_OK;
}
