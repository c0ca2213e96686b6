/* SPDX-License-Identifier: MIT */
/*
 * Recordings of a run and their backward pass (docs/gradients.md): a tape follows the world's
 * successful steps (the world calls it through its link, world.h), storing the step sizes, each
 * step's held external forces, attachment targets and colliders' poses, the state of every k-th
 * step (checkpoints) and the last state. The backward pass walks the
 * checkpoints from the last: it steps the world forward again from a checkpoint to the next
 * (bit for bit, checked against the stored state), then runs the backend's adjoint step over
 * each step of that segment in reverse, accumulating the loss's adjoints of the state and,
 * through the host's reverse-mode services (adjoint.c), of the parameters; last it maps the
 * parameters' gradients to the bodies' material fields and restores the world.
 *
 * Contents: the tape; recording; checks of what a recording supports; the backward pass;
 * the public API.
 */
#include "adjoint.h"
#include "chunk.h"
#include "clock.h"
#include "material.h"
#include "step.h"
#include "terms.h"
#include "world.h"

#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* ------------------------------------------------------------------------------------------ */
/* The tape */

struct defsim_tape {
    defsim__tape_link link;   /* first: the world's view (world.h) */
    int32_t nv;
    int automatic;            /* interval 0: thinned to stay within max_bytes */
    int64_t max_bytes;
    int32_t k;                /* the interval in effect */
    int64_t nsteps, hcap;
    double *h;                /* nsteps step sizes */
    int64_t *fi;              /* nsteps: the held forces of each step (index into f), -1: none */
    int64_t nf, fcap;
    double *f;                /* nf distinct held-force vectors (3 nv each), in order of use */
    int32_t natt;             /* attachments (the compiled ones, in the world's order) */
    int64_t *pi;              /* nsteps: the attachments' targets of each step (index into p) */
    int64_t np, pcap;
    double *p;                /* np distinct target vectors (3 natt each) */
    int64_t *gi;              /* nsteps: the driven pins' targets of each step (index into g) */
    int64_t ng, gcap;
    double *g;                /* ng distinct target vectors (3 nv; NaN: not driven that step) */
    double *gbuf;             /* 3 nv: the step's, assembled */
    int drove0;               /* the step before the recording drove pins (coupling_set.h) */
    int64_t ncp, cpcap;
    double *cp;               /* ncp states (6 nv: x then v) of steps 0, k, 2k, ... */
    double *cpt;              /* their times */
    int hist;                 /* the backend's adjoint reads the history (ADJOINT_HISTORY) */
    int keep;                 /* hist, with steps to recompute (interval 0 or > 1): cprev, cpb */
    double *cprev;            /* hist: ncp states (6 nv), each the one before its checkpoint's */
    defsim__bw *cpb;          /* hist: ncp backend histories (save_state) at the checkpoints */
    uint8_t *fresh;           /* nsteps: the step began without the backend's history */
    uint64_t drops;           /* the backend's history drops (world.h) at the last record */
    double *last;             /* 6 nv: the state after the last recorded step */
    double last_t;
    uint64_t plan_serial;     /* of the plan the recording follows */
    defsim__settings set;     /* the core's settings then */
    double *opt;              /* the backend's option values then */
    int32_t nopt;
    defsim__collider *col;    /* the colliders' slots then (their defs; poses may change) */
    int32_t ncol;
    int64_t q0;               /* the colliders' poses at state 0 (index into q) */
    int64_t *qi;              /* nsteps: their poses at the end of each step (index into q) */
    int64_t nq, qcap;
    double *q;                /* nq distinct pose sets (7 ncol: position, quaternion per slot) */
    double *qbuf;             /* 7 ncol: the poses now, assembled */
    int broken;               /* the world changed in a way the recording cannot follow */
    char why[320];            /* what changed */
    int replaying;            /* the backward pass steps the world: not recorded */
    double mark;              /* the world's time_step at the last recorded step */
    defsim_tape_stats stats;
    char err[400];
};

static size_t state_bytes(const defsim_tape *t) { return 6 * (size_t)t->nv * sizeof(double); }

/* What the history of a backend with ADJOINT_HISTORY costs at the checkpoints. */
static size_t history_bytes(const defsim_tape *t)
{
    if (!t->keep) return 0;
    size_t b = (size_t)t->cpcap * (state_bytes(t) + sizeof(defsim__bw));
    for (int64_t c = 0; c < t->ncp; ++c) b += t->cpb[c].cap;
    return b;
}

/* The backend's history now into b (emptied first; nothing when it has none to give). Returns 0
 * when out of memory or the backend fails. */
static int history_save(defsim_world *w, defsim__bw *b)
{
    b->n = 0;
    b->oom = 0;
    const defsim_backend *be = w->backend.table;
    if (!be->save_state || !w->backend.ready) return 1;
    const defsim_state_writer wr = defsim__state_writer(b);
    return be->save_state(&defsim__host, &w->handle, w->backend.state, &wr) == DEFSIM_OK &&
           !b->oom;
}

/* Loads a history that history_save kept (none: the backend stays as reset). */
static defsim_status history_load(defsim_world *w, const defsim__bw *b)
{
    const defsim_backend *be = w->backend.table;
    if (b->n == 0 || !be->load_state || !w->backend.ready) return DEFSIM_OK;
    defsim__br r = {b->p, b->n, 0, 0};
    const defsim_state_reader rd = defsim__state_reader(&r);
    const defsim_status st = be->load_state(&defsim__host, &w->handle, w->backend.state, &rd);
    return st == DEFSIM_OK && !defsim__read_whole(&r) ? DEFSIM_ERR_IO : st;
}

static int64_t tape_bytes(const defsim_tape *t)
{
    return (int64_t)((size_t)t->cpcap * (state_bytes(t) + sizeof(double)) +
                     (size_t)t->hcap * (sizeof(double) + sizeof(int64_t)) +
                     (size_t)t->fcap * state_bytes(t) / 2 + state_bytes(t) +
                     (size_t)t->hcap * sizeof(int64_t) +
                     (size_t)t->pcap * 3 * (size_t)t->natt * sizeof(double) +
                     (size_t)t->nopt * sizeof(double) + (size_t)t->ncol * sizeof *t->col +
                     sizeof *t +
                     (size_t)t->hcap * (sizeof(uint8_t) + sizeof(int64_t)) + history_bytes(t) +
                     (size_t)(t->qcap + 1) * 7 * (size_t)t->ncol * sizeof(double) +
                     (size_t)t->hcap * sizeof(int64_t) +
                     (size_t)(t->gcap + 1) * state_bytes(t) / 2);
}

static void tape_error(defsim_tape *t, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(t->err, sizeof t->err, fmt, ap);
    va_end(ap);
    if (t->link.world) defsim__error(t->link.world->msg, "%s", t->err);
    else defsim__set_last_error("%s", t->err);
}

static void save_state(const defsim_world *w, double *dst)
{
    const size_t b = 3 * (size_t)w->nv * sizeof(double);
    memcpy(dst, w->state.x, b);
    memcpy(dst + 3 * (int64_t)w->nv, w->state.v, b);
}

static void breaks(defsim_tape *t, const char *why)
{
    if (t->broken) return;
    t->broken = 1;
    snprintf(t->why, sizeof t->why, "%s", why);
}

/* Appends the current state as a checkpoint, thinning them first when automatic and full. */
static int push_checkpoint(defsim_tape *t, const defsim_world *w)
{
    if (t->automatic && t->ncp >= 2 &&
        (int64_t)((size_t)(t->ncp + 1) * state_bytes(t)) > t->max_bytes) {
        int64_t n = 0;
        for (int64_t i = 0; i < t->ncp; i += 2, ++n) {
            memmove(t->cp + 6 * (int64_t)t->nv * n, t->cp + 6 * (int64_t)t->nv * i, state_bytes(t));
            t->cpt[n] = t->cpt[i];
            if (!t->keep) continue;
            memmove(t->cprev + 6 * (int64_t)t->nv * n, t->cprev + 6 * (int64_t)t->nv * i,
                    state_bytes(t));
            if (n != i) {
                defsim__bw b = t->cpb[n];
                t->cpb[n] = t->cpb[i];
                t->cpb[i] = b;
            }
        }
        t->ncp = n;
        t->k *= 2;
        if (t->nsteps % t->k != 0) return 1;   /* this step is no longer a checkpoint's */
    }
    if (t->ncp == t->cpcap) {
        const int64_t cap = t->cpcap ? 2 * t->cpcap : 16;
        double *cp = realloc(t->cp, (size_t)cap * state_bytes(t));
        if (!cp) return 0;
        t->cp = cp;
        double *ct = realloc(t->cpt, (size_t)cap * sizeof *ct);
        if (!ct) return 0;
        t->cpt = ct;
        if (t->keep) {
            double *pv = realloc(t->cprev, (size_t)cap * state_bytes(t));
            if (!pv) return 0;
            t->cprev = pv;
            defsim__bw *bw = realloc(t->cpb, (size_t)cap * sizeof *bw);
            if (!bw) return 0;
            memset(bw + t->cpcap, 0, (size_t)(cap - t->cpcap) * sizeof *bw);
            t->cpb = bw;
        }
        t->cpcap = cap;
    }
    if (t->keep && t->ncp > 0) {
        /* the state before the checkpoint's (the step's start) and the backend's history */
        double *pv = t->cprev + 6 * (int64_t)t->nv * t->ncp;
        memcpy(pv, w->step.x_save, state_bytes(t) / 2);
        memcpy(pv + 3 * (int64_t)t->nv, w->step.v_save, state_bytes(t) / 2);
        if (!history_save((defsim_world *)w, &t->cpb[t->ncp])) return 0;
    }
    save_state(w, t->cp + 6 * (int64_t)t->nv * t->ncp);
    t->cpt[t->ncp++] = w->state.t;
    return 1;
}

/* Keeps vector v (len doubles; NULL: none, index -1) of the step under way in the list (*a,
 * *n of them, room for *cap) and its index in *index: a new entry when it differs from the last
 * one kept. Returns 0 when out of memory. */
static int keep_vector(const double *v, int64_t len, double **a, int64_t *n, int64_t *cap,
                       int64_t *index)
{
    if (!v || len == 0) {
        *index = -1;
        return 1;
    }
    if (*n > 0 && memcmp(*a + len * (*n - 1), v, (size_t)len * sizeof(double)) == 0) {
        *index = *n - 1;
        return 1;
    }
    if (*n == *cap) {
        const int64_t c = *cap ? 2 * *cap : 4;
        double *b = realloc(*a, (size_t)c * (size_t)len * sizeof *b);
        if (!b) return 0;
        *a = b;
        *cap = c;
    }
    memcpy(*a + len * *n, v, (size_t)len * sizeof(double));
    *index = (*n)++;
    return 1;
}

/* The held external forces, the attachments' targets and the driven pins' targets of the step
 * that just ended. */
static int record_forces(defsim_tape *t, const defsim_world *w)
{
    const defsim__coupling *c = &w->coupling.cpl;
    if (c->ndrv_done > 0) {
        for (int64_t i = 0; i < 3 * (int64_t)t->nv; ++i) t->gbuf[i] = NAN;
        for (int64_t k = 0; k < c->ndrv_done; ++k) t->gbuf[c->drv[k]] = c->drv_target[k];
    }
    return keep_vector(w->coupling.fext_nonzero ? w->coupling.fext : NULL, 3 * (int64_t)t->nv,
                       &t->f, &t->nf, &t->fcap, &t->fi[t->nsteps]) &&
           keep_vector(t->natt > 0 ? w->sys.att.p : NULL, 3 * (int64_t)t->natt, &t->p, &t->np,
                       &t->pcap, &t->pi[t->nsteps]) &&
           keep_vector(c->ndrv_done > 0 ? t->gbuf : NULL, 3 * (int64_t)t->nv, &t->g, &t->ng,
                       &t->gcap, &t->gi[t->nsteps]);
}

/* Keeps the colliders' poses now (each slot's position and quaternion; the end of the step that
 * just ended, or state 0) and their index in *index. Returns 0 when out of memory. */
static int record_poses(defsim_tape *t, const defsim_world *w, int64_t *index)
{
    for (int32_t j = 0; j < t->ncol; ++j) {
        memcpy(t->qbuf + 7 * (int64_t)j, w->colliders.col[j].pos, 3 * sizeof(double));
        memcpy(t->qbuf + 7 * (int64_t)j + 3, w->colliders.col[j].rot, 4 * sizeof(double));
    }
    return keep_vector(t->qbuf, 7 * (int64_t)t->ncol, &t->q, &t->nq, &t->qcap, index);
}

/* The colliders' poses at recorded state s (7 per slot), or NULL without colliders. */
static const double *poses_at(const defsim_tape *t, int64_t s)
{
    const int64_t i = s == 0 ? t->q0 : t->qi[s - 1];
    return i >= 0 ? t->q + 7 * (int64_t)t->ncol * i : NULL;
}

/* Puts the colliders where recorded step j had them: at state j's poses, moving to state
 * j + 1's over the step (as defsim_collider_set_pose left them for it). */
static void hold_poses(const defsim_tape *t, defsim_world *w, int64_t j)
{
    const double *a = poses_at(t, j), *b = poses_at(t, j + 1);
    for (int32_t k = 0; a && k < t->ncol; ++k) {
        defsim__collider *c = &w->colliders.col[k];
        memcpy(c->pos, a + 7 * (int64_t)k, sizeof c->pos);
        memcpy(c->rot, a + 7 * (int64_t)k + 3, sizeof c->rot);
        memcpy(c->pos1, b + 7 * (int64_t)k, sizeof c->pos1);
        memcpy(c->rot1, b + 7 * (int64_t)k + 3, sizeof c->rot1);
    }
}

/* The driven pins' targets of recorded step j (3 nv, NaN where not driven), or NULL. */
static const double *pin_targets(const defsim_tape *t, int64_t j)
{
    return j >= 0 && t->gi[j] >= 0 ? t->g + 3 * (int64_t)t->nv * t->gi[j] : NULL;
}

/* Sets the driven pins' targets of recorded step j in the world for its next step (as
 * defsim_body_set_pin_targets does), and whether the step before it drove pins. */
static void hold_pins(const defsim_tape *t, defsim_world *w, int64_t j)
{
    defsim__coupling_set *cs = &w->coupling;
    cs->drove = j > 0 ? pin_targets(t, j - 1) != NULL : t->drove0;
    const double *g = pin_targets(t, j);
    if (!g) return;
    for (int32_t v = 0; v < t->nv; ++v) {
        if (isnan(g[3 * (int64_t)v])) continue;
        if (!cs->targeted[v]) {
            cs->targeted[v] = 1;
            cs->ntargeted++;
        }
        memcpy(cs->pin_target + 3 * (int64_t)v, g + 3 * (int64_t)v, 3 * sizeof(double));
    }
}

/* Sets the world-point targets of the attachments to p (3 natt; body targets left alone). */
static defsim_status set_targets(const defsim_tape *t, defsim_world *w, const double *p)
{
    for (int32_t e = 0; e < t->natt; ++e) {
        const int32_t *nd = w->sys.att.node + DEFSIM__ATTACH_NODES * (int64_t)e;
        int point = 1;
        for (int j = 1; j < DEFSIM__ATTACH_NODES; ++j) point &= nd[j] < 0;
        if (!point) continue;
        defsim_attachment_id id;
        defsim_status st = defsim_world_attachment_at(w, e, &id);
        if (st == DEFSIM_OK) st = defsim_attachment_set_target(w, id, p + 3 * (int64_t)e);
        if (st != DEFSIM_OK) return st;
    }
    return DEFSIM_OK;
}

/* Holds the forces and attachment targets of recorded step j in the world. */
static defsim_status hold_forces(const defsim_tape *t, defsim_world *w, int64_t j)
{
    defsim_status st = defsim_world_set_external_forces(
        w, t->fi[j] >= 0 ? t->f + 3 * (int64_t)t->nv * t->fi[j] : NULL, t->nv);
    if (st == DEFSIM_OK && t->pi[j] >= 0)
        st = set_targets(t, w, t->p + 3 * (int64_t)t->natt * t->pi[j]);
    return st;
}

static const char *unsupported(const defsim_world *w, char *buf, size_t size);

/* What changed since the recording began, or NULL. */
static const char *changed(const defsim_tape *t, const defsim_world *w)
{
    if (w->plan_serial != t->plan_serial || !w->planned)
        return "the bodies, pins or attachments changed";
    if (memcmp(&w->set, &t->set, sizeof w->set) != 0) return "a core option changed";
    if (t->nopt > 0 &&
        memcmp(defsim__options_values(&w->options), t->opt, (size_t)t->nopt * sizeof(double)) != 0)
        return "a backend option changed";
    return NULL;
}

/* Whether the colliders changed since the recording began, other than in their poses, which
 * the tape records (checked after what a recording cannot differentiate: a collider that came
 * to a penalty backend is that). */
static const char *colliders_changed(const defsim_tape *t, const defsim_world *w)
{
    int same = w->colliders.ncol == t->ncol;
    for (int32_t j = 0; j < t->ncol && same; ++j) {
        defsim__collider c;   /* slot j now, with the poses it had then */
        memcpy(&c, &w->colliders.col[j], sizeof c);
        memcpy(c.pos, t->col[j].pos, sizeof c.pos);
        memcpy(c.rot, t->col[j].rot, sizeof c.rot);
        memcpy(c.pos1, t->col[j].pos1, sizeof c.pos1);
        memcpy(c.rot1, t->col[j].rot1, sizeof c.rot1);
        same = memcmp(&c, &t->col[j], sizeof c) == 0;
    }
    if (!same)
        return "a collider was added, removed or replaced (gradients follow the colliders' poses, "
               "collider_poses, but not a change of their shape, friction or number)";
    return NULL;
}

/* ------------------------------------------------------------------------------------------ */
/* Recording: the world's step calls this after every successful step. */

static void tape_step(defsim__tape_link *link, double h)
{
    defsim_tape *t = (defsim_tape *)link;
    defsim_world *w = link->world;
    if (t->replaying || t->broken) return;
    const char *why = changed(t, w);
    char buf[400];
    if (!why) why = unsupported(w, buf, sizeof buf);   /* a collider, a callback came */
    if (!why) why = colliders_changed(t, w);
    if (why) {
        breaks(t, why);
        return;
    }
    const size_t b = 3 * (size_t)t->nv * sizeof(double);
    /* a pinned DOF's velocity does not enter a step (the step sets it: 0, or a driven pin's),
     * and defsim_body_set_pin_targets zeroes it */
    int same_v = 1;
    const double *v0 = t->last + 3 * (int64_t)t->nv;
    for (int32_t v = 0; v < t->nv && same_v; ++v)
        same_v = w->sys.pinned[v] ||
                 memcmp(w->step.v_save + 3 * (int64_t)v, v0 + 3 * (int64_t)v, 3 * sizeof *v0) == 0;
    if (memcmp(w->step.x_save, t->last, b) != 0 || !same_v || t->last_t + h != w->state.t) {
        breaks(t, "the state or time was set between recorded steps");
        return;
    }
    if (t->nsteps == t->hcap) {
        const int64_t cap = t->hcap ? 2 * t->hcap : 64;
        double *hh = realloc(t->h, (size_t)cap * sizeof *hh);
        int64_t *fi = hh ? realloc(t->fi, (size_t)cap * sizeof *fi) : NULL;
        if (hh) t->h = hh;
        if (fi) t->fi = fi;
        int64_t *pi = fi ? realloc(t->pi, (size_t)cap * sizeof *pi) : NULL;
        if (pi) t->pi = pi;
        uint8_t *fr = pi ? realloc(t->fresh, (size_t)cap * sizeof *fr) : NULL;
        if (fr) t->fresh = fr;
        int64_t *gi = fr ? realloc(t->gi, (size_t)cap * sizeof *gi) : NULL;
        if (gi) t->gi = gi;
        int64_t *qi = gi ? realloc(t->qi, (size_t)cap * sizeof *qi) : NULL;
        if (!hh || !fi || !pi || !fr || !gi || !qi) {
            breaks(t, "out of memory while recording");
            return;
        }
        t->qi = qi;
        t->hcap = cap;
    }
    if (!record_forces(t, w) || !record_poses(t, w, &t->qi[t->nsteps])) {
        breaks(t, "out of memory while recording");
        return;
    }
    /* a failed step (step.c resets the backend) or a re-initialisation (an option set and set
     * back) between recorded steps dropped the backend's history */
    t->fresh[t->nsteps] = t->nsteps == 0 || w->backend.drops != t->drops;
    t->drops = w->backend.drops;
    t->h[t->nsteps++] = h;
    save_state(w, t->last);
    t->last_t = w->state.t;
    if (t->nsteps % t->k == 0 && !push_checkpoint(t, w)) breaks(t, "out of memory while recording");
    t->stats.time_forward += w->stats.time_step - t->mark;
    t->mark = w->stats.time_step;
}

/* ------------------------------------------------------------------------------------------ */
/* What a recording supports: the message for the first thing it does not, or NULL. */

static const char *unsupported(const defsim_world *w, char *buf, size_t size)
{
    const defsim_backend *b = w->backend.table;
    if (b->struct_size < offsetof(defsim_backend, adjoint_step) + sizeof b->adjoint_step ||
        !b->adjoint_step) {
        snprintf(buf, size, "record: backend %s is not differentiable (it has no adjoint step; "
                            "differentiable: explicit_euler, symplectic_euler, velocity_verlet, "
                            "newton_cholmod, newmark, bdf2)",
                 b->name);
        return buf;
    }
    const char *term = NULL;
    if (defsim__collider_set_live(&w->colliders) > 0 && !(b->flags & DEFSIM_BACKEND_CONTACT_CCD)) {
        snprintf(buf, size, "record: backend %s has collider contact as a penalty force, which "
                            "gradients do not differentiate (the barrier's backends do: "
                            "newton_cholmod, newmark, bdf2)",
                 b->name);
        return buf;
    }
    if (w->coupling.cpl.fn) term = "the force callback";
    if (!term) term = defsim__forces_vjp_missing(&w->sys);
    if (term) {
        snprintf(buf, size, "record: the scene uses %s, which gradients do not differentiate "
                            "yet (docs/gradients.md)", term);
        return buf;
    }
    if (w->set.auto_substep && (b->stable_step || b->stable_step_options)) {
        snprintf(buf, size, "record: core.auto_substep splits the steps of backend %s; the "
                            "adjoint of a split step is not supported: turn it off", b->name);
        return buf;
    }
    return NULL;
}

/* ------------------------------------------------------------------------------------------ */
/* The backward pass */

/* What a backward pass restores: the world's state, time, statistics and counters. */
typedef struct world_saved {
    double *x;                /* 6 nv */
    double t;
    defsim_stats stats;
    double *counters;
    int32_t ncounters;
    int64_t lin[DEFSIM__TERM_KINDS];
    double h_stable;
    int32_t since_estimate;
    double *fext;             /* the host's held forces (3 nv), or NULL: none */
    double *att_p;            /* the attachments' targets (3 natt), or NULL: none */
    defsim__bw history;       /* the backend's history (save_state), if it has one */
    int drove;                /* the coupling's: the last step drove pins */
    int32_t ntargeted;        /* the host's pending pin targets (copies, or NULL: none) */
    uint8_t *targeted;
    double *pin_target;
    double cstat[DEFSIM__CSTAT_COUNT];   /* the contact statistics */
    unsigned char *carry;     /* what collider contact carries to the next step (its chunk) */
    size_t ncarry;
    double *poses;            /* the colliders' poses now and at the next step's end (14 each) */
} world_saved;

static int world_save(const defsim_world *w, world_saved *s)
{
    memset(s, 0, sizeof *s);
    s->x = malloc(6 * (size_t)w->nv * sizeof(double));
    s->ncounters = w->backend.table->counter_count;
    s->counters = malloc((size_t)(s->ncounters > 0 ? s->ncounters : 1) * sizeof(double));
    if (!s->x || !s->counters) return 0;
    save_state(w, s->x);
    s->t = w->state.t;
    s->stats = w->stats;
    if (s->ncounters > 0)
        memcpy(s->counters, defsim__options_counters((defsim__options *)&w->options),
               (size_t)s->ncounters * sizeof(double));
    for (int k = 0; k < DEFSIM__TERM_KINDS; ++k) s->lin[k] = w->sys.cache[k].linearisations;
    s->h_stable = w->step.h_stable;
    s->since_estimate = w->step.since_estimate;
    if (w->coupling.fext) {
        if (!(s->fext = malloc(3 * (size_t)w->nv * sizeof(double)))) return 0;
        memcpy(s->fext, w->coupling.fext, 3 * (size_t)w->nv * sizeof(double));
    }
    if (w->planned && w->sys.att.n > 0) {
        if (!(s->att_p = malloc(3 * (size_t)w->sys.att.n * sizeof(double)))) return 0;
        memcpy(s->att_p, w->sys.att.p, 3 * (size_t)w->sys.att.n * sizeof(double));
    }
    s->drove = w->coupling.drove;
    s->ntargeted = w->coupling.ntargeted;
    if (w->coupling.targeted) {
        s->targeted = malloc((size_t)w->nv);
        s->pin_target = malloc(3 * (size_t)w->nv * sizeof(double));
        if (!s->targeted || !s->pin_target) return 0;
        memcpy(s->targeted, w->coupling.targeted, (size_t)w->nv);
        memcpy(s->pin_target, w->coupling.pin_target, 3 * (size_t)w->nv * sizeof(double));
    }
    /* The steps run again and the adjoints' contact begin change contact's statistics and what
     * it carries between steps (the safe box): kept as a checkpoint keeps them. */
    memcpy(s->cstat, w->contact.stat, sizeof s->cstat);
    const int32_t ncol = w->colliders.ncol;
    if (!(s->poses = malloc(14 * (size_t)(ncol > 0 ? ncol : 1) * sizeof(double)))) return 0;
    for (int32_t j = 0; j < ncol; ++j) {
        const defsim__collider *c = &w->colliders.col[j];
        double *p = s->poses + 14 * (int64_t)j;
        memcpy(p, c->pos, sizeof c->pos);
        memcpy(p + 3, c->rot, sizeof c->rot);
        memcpy(p + 7, c->pos1, sizeof c->pos1);
        memcpy(p + 10, c->rot1, sizeof c->rot1);
    }
    if (w->planned) {
        const defsim__term tc = defsim__terms_detached(&w->sys, DEFSIM__TERM_KIND_collider,
                                                       (defsim__contact *)&w->contact);
        s->ncarry = tc.ops->save(&tc, NULL, 0);
        if (s->ncarry > 0) {
            if (!(s->carry = malloc(s->ncarry))) return 0;
            (void)tc.ops->save(&tc, s->carry, s->ncarry);
        }
    }
    return history_save((defsim_world *)w, &s->history);
}

/* Puts state s (6 nv) at time t into the world as defsim_world_set_state does (the backend's
 * history and the watchdog's reference dropped). */
static void world_put(defsim_world *w, const double *s, double t)
{
    const size_t b = 3 * (size_t)w->nv * sizeof(double);
    memcpy(w->state.x, s, b);
    memcpy(w->state.v, s + 3 * (int64_t)w->nv, b);
    w->state.t = t;
    defsim__watchdog_forget(&w->wd, 0);
    if (w->backend.ready && w->backend.table->reset &&
        w->backend.table->reset(&defsim__host, &w->handle, w->backend.state) != DEFSIM_OK)
        defsim__world_backend_stop(w);
}

static void world_restore(const defsim_tape *t, defsim_world *w, world_saved *s)
{
    if (s->x) {
        world_put(w, s->x, s->t);
        w->stats = s->stats;
        if (s->ncounters > 0)
            memcpy(defsim__options_counters(&w->options), s->counters,
                   (size_t)s->ncounters * sizeof(double));
        if (w->planned)
            for (int k = 0; k < DEFSIM__TERM_KINDS; ++k) w->sys.cache[k].linearisations = s->lin[k];
        w->step.h_stable = s->h_stable;
        w->step.since_estimate = s->since_estimate;
        (void)defsim_world_set_external_forces(w, s->fext, w->nv);   /* the host's again */
        if (s->att_p) (void)set_targets(t, w, s->att_p);
        /* the backend's history too, so that the run goes on bit for bit */
        if (history_load(w, &s->history) != DEFSIM_OK) defsim__world_backend_stop(w);
        w->coupling.drove = s->drove;
        w->coupling.ntargeted = s->ntargeted;
        if (s->targeted) {
            memcpy(w->coupling.targeted, s->targeted, (size_t)w->nv);
            memcpy(w->coupling.pin_target, s->pin_target, 3 * (size_t)w->nv * sizeof(double));
        }
        memcpy(w->contact.stat, s->cstat, sizeof s->cstat);
        for (int32_t j = 0; s->poses && j < w->colliders.ncol; ++j) {
            defsim__collider *c = &w->colliders.col[j];
            const double *p = s->poses + 14 * (int64_t)j;
            memcpy(c->pos, p, sizeof c->pos);
            memcpy(c->rot, p + 3, sizeof c->rot);
            memcpy(c->pos1, p + 7, sizeof c->pos1);
            memcpy(c->rot1, p + 10, sizeof c->rot1);
        }
        if (w->planned) {
            const defsim__term tc = defsim__terms_detached(&w->sys, DEFSIM__TERM_KIND_collider,
                                                           &w->contact);
            (void)tc.ops->load(&tc, s->carry, s->ncarry);
        }
    }
    free(s->targeted);
    free(s->pin_target);
    free(s->history.p);
    free(s->x);
    free(s->counters);
    free(s->fext);
    free(s->att_p);
    free(s->carry);
    free(s->poses);
}

/* The parameter gradients' arrays, sized for the system. */
static void grad_free(defsim__grad *g)
{
    for (int m = 0; m < DEFSIM__TET_MODELS; ++m) {
        free(g->mu[m]);
        free(g->lambda[m]);
    }
    for (int m = 0; m <= DEFSIM__TET_MODELS; ++m) free(g->beta[m]);
    free(g->alpha3);
    free(g->mass);
    free(g->fext);
    free(g->att_k);
    free(g->att_c);
    free(g->att_p);
    free(g->wmask);
    free(g->xn);
    free(g->mu_col);
    free(g->pose_col);
    free(g->mu_body);
}

static int grad_alloc(defsim__grad *g, const defsim__system *s, int32_t ncol, int32_t nslots,
                      int64_t *bytes)
{
    memset(g, 0, sizeof *g);
    int ok = 1;
    size_t total = 0;
    for (int m = 0; m <= DEFSIM__TET_MODELS; ++m) {
        const size_t n = (size_t)(s->groups[m].n > 0 ? s->groups[m].n : 1);
        if (m < DEFSIM__TET_MODELS) {
            ok &= (g->mu[m] = calloc(n, sizeof(double))) != NULL;
            ok &= (g->lambda[m] = calloc(n, sizeof(double))) != NULL;
            total += 2 * n;
        }
        ok &= (g->beta[m] = calloc(n, sizeof(double))) != NULL;
        total += n;
    }
    const size_t nd = 3 * (size_t)(s->nv > 0 ? s->nv : 1);
    ok &= (g->alpha3 = calloc(nd, sizeof(double))) != NULL;
    ok &= (g->mass = calloc(nd / 3, sizeof(double))) != NULL;
    ok &= (g->wmask = calloc(nd, sizeof(double))) != NULL;
    ok &= (g->fext = calloc(nd, sizeof(double))) != NULL;
    const size_t na = (size_t)(s->att.n > 0 ? s->att.n : 1);
    ok &= (g->att_k = calloc(na, sizeof(double))) != NULL;
    ok &= (g->att_c = calloc(na, sizeof(double))) != NULL;
    ok &= (g->att_p = calloc(3 * na, sizeof(double))) != NULL;
    ok &= (g->xn = calloc(nd, sizeof(double))) != NULL;
    ok &= (g->mu_col = calloc((size_t)(ncol > 0 ? ncol : 1), sizeof(double))) != NULL;
    ok &= (g->pose_col = calloc(12 * (size_t)(ncol > 0 ? ncol : 1), sizeof(double))) != NULL;
    ok &= (g->mu_body = calloc((size_t)(nslots > 0 ? nslots : 1), sizeof(double))) != NULL;
    total += 4 * nd + nd / 3 + 5 * na + 13 * (size_t)(ncol > 0 ? ncol : 1) +
             (size_t)(nslots > 0 ? nslots : 1);
    *bytes += (int64_t)(total * sizeof(double));
    return ok;
}

enum {
    G_X0, G_V0, G_E, G_NU, G_RHO, G_ALPHA, G_BETA, G_FEXT, G_ATT_K, G_ATT_C, G_ATT_P, G_PIN,
    G_MU_COL, G_MU_BODY, G_POSE, G_NAMES
};
static const char *const grad_names[G_NAMES] = {
    "initial_positions", "initial_velocities", "youngs_modulus", "poisson_ratio", "density",
    "mass_damping", "stiffness_damping", "external_forces", "attachment_stiffness",
    "attachment_damping", "attachment_targets", "pin_targets", "collider_friction",
    "body_friction", "collider_poses"};

static int32_t live_bodies(const defsim_world *w)
{
    int32_t n = 0;
    for (int32_t b = 0; b < w->bodies.n; ++b) n += (w->bodies.b[b].generation & 1u) != 0;
    return n;
}

/* The bodies' gradients (G_E .. G_BETA, nb each, into out) from the system's. */
static int body_gradients(const defsim_world *w, const defsim__grad *g, double *out, int32_t nb)
{
    const defsim__system *s = &w->sys;
    int32_t *vbody = malloc((size_t)(w->nv > 0 ? w->nv : 1) * sizeof *vbody);
    double *dmdrho = calloc((size_t)(w->nv > 0 ? w->nv : 1), sizeof *dmdrho);
    const defsim__body **bodies = malloc((size_t)(nb > 0 ? nb : 1) * sizeof *bodies);
    if (!vbody || !dmdrho || !bodies) {
        free(vbody);
        free(dmdrho);
        free(bodies);
        return 0;
    }
    int32_t nbody = 0;
    for (int32_t b = 0; b < w->bodies.n; ++b) {
        const defsim__body *bd = &w->bodies.b[b];
        if (!(bd->generation & 1u)) continue;
        for (int32_t i = 0; i < bd->nv; ++i) vbody[bd->offset + i] = nbody;
        bodies[nbody++] = bd;
    }
    memset(out, 0, (size_t)(G_FEXT - G_E) * (size_t)nb * sizeof *out);
    double *gE = out, *gnu = out + nb, *grho = out + 2 * nb, *galpha = out + 3 * nb,
           *gbeta = out + 4 * nb;   /* the body parameters, G_E .. G_BETA */
    for (int m = 0; m <= DEFSIM__TET_MODELS; ++m) {
        const defsim__group *gr = &s->groups[m];
        for (int32_t e = 0; e < gr->n; ++e) {
            const int32_t b = vbody[gr->idx[(int64_t)gr->nodes * e]];
            gbeta[b] += g->beta[m][e];
            if (m == DEFSIM__TET_MODELS) continue;
            double d[4];
            const defsim_material *mat = &bodies[b]->mat;
            defsim__lame_derivatives(mat->youngs_modulus, mat->poisson_ratio, d);
            gE[b] += g->mu[m][e] * d[0] + g->lambda[m][e] * d[2];
            gnu[b] += g->mu[m][e] * d[1] + g->lambda[m][e] * d[3];
            for (int a = 0; a < 4; ++a) dmdrho[gr->idx[4 * (int64_t)e + a]] += gr->vol[e] / 4.0;
        }
    }
    for (int32_t i = 0; i < w->nv; ++i) {
        const int32_t b = vbody[i];
        if (!bodies[b]->mass_given) grho[b] += g->mass[i] * dmdrho[i];
        for (int c = 0; c < 3; ++c) galpha[b] += g->alpha3[3 * (int64_t)i + c];
    }
    free(vbody);
    free(dmdrho);
    free(bodies);
    return 1;
}

/* Step j's pose gradients (its start and end pose, per slot) added to collider_poses' states j
 * and j + 1 in out (6 per live collider in get_collider's order, or NULL), then zeroed. */
static void pose_gradients(const defsim_tape *t, const defsim_world *w, defsim__grad *g,
                           int64_t j, double *out)
{
    const int64_t nl = defsim__collider_set_live(&w->colliders);
    for (int32_t k = 0, m = 0; out && k < t->ncol; ++k) {
        if (!(w->colliders.col[k].generation & 1u)) continue;
        const double *gp = g->pose_col + 12 * (int64_t)k;
        for (int a = 0; a < 6; ++a) {
            out[6 * (nl * j + m) + a] += gp[a];
            out[6 * (nl * (j + 1) + m) + a] += gp[6 + a];
        }
        ++m;
    }
    if (t->ncol > 0) memset(g->pose_col, 0, 12 * (size_t)t->ncol * sizeof(double));
}

/* The backward pass proper, on a world saved by the caller. ax, av hold dL/dx_N, dL/dv_N on
 * entry and dL/dx_0, dL/dv_0 on return. */
static defsim_status run_backward(defsim_tape *t, defsim_world *w, const double *dl_dx,
                                  const double *dl_dv, double *ax, double *av, double *fext_out,
                                  double *attp_out, double *pin_out, double *pose_out,
                                  defsim__grad *g, int64_t *peak)
{
    const int64_t n3 = 3 * (int64_t)t->nv, n6 = 2 * n3;
    const int32_t k = t->k;
    double *seg = malloc((size_t)(k + 1) * state_bytes(t));
    double *ax0 = malloc(4 * (size_t)n3 * sizeof *ax0);
    if (!seg || !ax0) {
        free(seg);
        free(ax0);
        tape_error(t, "backward: out of memory");
        return DEFSIM_ERR_OUT_OF_MEMORY;
    }
    *peak += (int64_t)((size_t)(k + 1) * state_bytes(t) + 4 * (size_t)n3 * sizeof(double));
    double *av0 = ax0 + n3, *ap1 = av0 + n3, *v0 = ap1 + n3;
    const uint8_t *pinned = w->sys.pinned;
    const defsim_backend *b = w->backend.table;
    defsim_status st = DEFSIM_OK;
    for (int64_t c = t->ncp - 1; c >= 0 && st == DEFSIM_OK; --c) {
        const int64_t s0 = c * k, s1 = s0 + k < t->nsteps ? s0 + k : t->nsteps;
        if (s0 >= t->nsteps) continue;
        memcpy(seg, t->cp + n6 * c, state_bytes(t));
        const double *end = s1 == t->nsteps ? t->last : t->cp + n6 * (c + 1);
        if (s1 - s0 > 1) {
            /* Recompute the segment's states from its checkpoint, as the recording stepped. */
            const double r0 = defsim__now();
            world_put(w, seg, t->cpt[c]);
            if (t->keep && c > 0 && !t->fresh[s0]) st = history_load(w, &t->cpb[c]);
            t->replaying = 1;
            for (int64_t j = s0; j < s1 && st == DEFSIM_OK; ++j) {
                if (t->hist && j > s0 && t->fresh[j] && b->reset)
                    st = b->reset(&defsim__host, &w->handle, w->backend.state);
                if (st == DEFSIM_OK) st = hold_forces(t, w, j);
                if (st == DEFSIM_OK) {
                    hold_pins(t, w, j);
                    hold_poses(t, w, j);
                    st = defsim_world_step(w, t->h[j]);
                }
                if (st == DEFSIM_OK) save_state(w, seg + n6 * (j + 1 - s0));
            }
            t->replaying = 0;
            t->stats.recomputed_steps += s1 - s0;
            t->stats.time_recompute += defsim__now() - r0;
            if (st != DEFSIM_OK) {
                tape_error(t, "backward: recomputing step %lld failed: %s", (long long)s0,
                           w->msg->error);
                break;
            }
            if (memcmp(seg + n6 * (s1 - s0), end, state_bytes(t)) != 0) {
                tape_error(t, "backward: the recomputed state of step %lld differs from the "
                              "recording (a backend or term that is not deterministic)",
                           (long long)s1);
                st = DEFSIM_ERR_UNSUPPORTED;
                break;
            }
        } else {
            memcpy(seg + n6, end, state_bytes(t));
        }
        for (int64_t j = s1 - 1; j >= s0; --j) {
            const double *S0 = seg + n6 * (j - s0), *S1 = seg + n6 * (j + 1 - s0);
            /* the history: the state before S0 (in the segment, or kept with its checkpoint) */
            const double *P = !t->hist || t->fresh[j] ? NULL
                              : j > s0               ? S0 - n6
                              : t->keep              ? t->cprev + n6 * c
                                                     : t->cp + n6 * (c - 1);   /* interval 1 */
            /* the pins' velocities over the step: (target - x0)/h where driven, else 0 */
            const double *G = pin_targets(t, j);
            memcpy(v0, S0 + n3, (size_t)n3 * sizeof *v0);
            for (int32_t v = 0; v < t->nv; ++v)
                for (int q = 0; pinned[v] && q < 3; ++q) {
                    const int64_t i = 3 * (int64_t)v + q;
                    v0[i] = G && !isnan(G[i]) ? (G[i] - S0[i]) / t->h[j] : 0.0;
                }
            memset(ap1, 0, (size_t)n3 * sizeof *ap1);
            const defsim_adjoint_step a = {.x0 = S0, .v0 = v0, .x1 = S1, .v1 = S1 + n3,
                                           .ax1 = ax, .av1 = av, .ax0 = ax0, .av0 = av0,
                                           .x_prev = P, .v_prev = P ? P + n3 : NULL,
                                           .h_prev = P ? t->h[j - 1] : 0.0,
                                           .first = j == t->nsteps - 1,
                                           .prev_drove = j > 0 ? pin_targets(t, j - 1) != NULL
                                                               : t->drove0,
                                           .drives = G != NULL, .ap1 = ap1};
            w->msg->error[0] = '\0';
            st = hold_forces(t, w, j);   /* the forces the step held, for its evaluations */
            hold_poses(t, w, j);         /* and the colliders' poses */
            /* the step's contact: its pairs and what friction lags from its start */
            if (st == DEFSIM_OK) st = defsim__world_adjoint_begin(w, S0, S0 + n3, t->h[j]);
            if (st == DEFSIM_OK)
                st = b->adjoint_step(&defsim__host, &w->handle, w->backend.state, t->h[j], &a);
            defsim__world_adjoint_end(w);
            for (int64_t i = 0; i < n3; ++i) ax0[i] += g->xn[i];
            memset(g->xn, 0, (size_t)n3 * sizeof(double));
            pose_gradients(t, w, g, j, pose_out);
            if (st != DEFSIM_OK) {
                tape_error(t, "backward: the adjoint of step %lld failed: %s", (long long)j,
                           w->msg->error[0] ? w->msg->error : defsim_status_string(st));
                break;
            }
            /* Pinned DOFs: a driven one ends at its target p and moves with (p - x0)/h, which
             * v1 holds too; a static one stays (x1 = x0) with no velocity. The recorded v0 of
             * a pinned DOF does not enter the step. */
            double *gp = pin_out ? pin_out + n3 * j : NULL;
            if (gp) memset(gp, 0, (size_t)n3 * sizeof *gp);
            for (int32_t v = 0; v < t->nv; ++v)
                for (int q = 0; pinned[v] && q < 3; ++q) {
                    const int64_t i = 3 * (int64_t)v + q;
                    if (G && !isnan(G[i])) {
                        const double du = av0[i] + av[i];
                        if (gp) gp[i] = ap1[i] + du / t->h[j];
                        ax0[i] -= du / t->h[j];
                    } else {
                        ax0[i] += ap1[i];
                    }
                    av0[i] = 0.0;
                }
            for (int64_t i = 0; i < n3; ++i) {
                ax[i] = ax0[i] + (dl_dx ? dl_dx[n3 * j + i] : 0.0);
                av[i] = av0[i] + (dl_dv ? dl_dv[n3 * j + i] : 0.0);
            }
            if (fext_out) memcpy(fext_out + n3 * j, g->fext, (size_t)n3 * sizeof(double));
            memset(g->fext, 0, (size_t)n3 * sizeof(double));
            const int64_t na3 = 3 * (int64_t)t->natt;
            if (attp_out && na3 > 0)
                memcpy(attp_out + na3 * j, g->att_p, (size_t)na3 * sizeof(double));
            if (na3 > 0) memset(g->att_p, 0, (size_t)na3 * sizeof(double));
        }
    }
    free(seg);
    free(ax0);
    return st;
}

/* ------------------------------------------------------------------------------------------ */
/* The public API */

void defsim_tape_def_init(defsim_tape_def *def, size_t size)
{
    if (!def || size < sizeof(uint32_t)) return;
    defsim_tape_def d = {.size = (uint32_t)sizeof d, .interval = 0, .max_bytes = 256ll << 20};
    memcpy(def, &d, size < sizeof d ? size : sizeof d);
    def->size = (uint32_t)(size < sizeof d ? size : sizeof d);
}

defsim_status defsim_world_record(defsim_world *w, const defsim_tape_def *def, defsim_tape **out)
{
    defsim_status st = defsim__world_enter(w);
    if (st != DEFSIM_OK) return st;
    defsim_tape_def d;
    defsim_tape_def_init(&d, sizeof d);
    if (def) {
        if (def->size != sizeof d) {
            defsim__error(w->msg, "record: def->size is %u, not sizeof(defsim_tape_def) = %u",
                          def->size, (unsigned)sizeof d);
            return DEFSIM_ERR_INVALID_ARGUMENT;
        }
        d = *def;
    }
    if (!out || d.interval < 0 || !(d.max_bytes > 0)) {
        defsim__error(w->msg, "record: %s", !out ? "out is NULL"
                                            : d.interval < 0 ? "interval is negative"
                                                             : "max_bytes must be > 0");
        return DEFSIM_ERR_INVALID_ARGUMENT;
    }
    if (w->tape) {
        defsim__error(w->msg, "record: a recording of this world is under way (destroy it first)");
        return DEFSIM_ERR_INVALID_ARGUMENT;
    }
    if (w->nv == 0) {
        defsim__error(w->msg, "record: the world has no vertices");
        return DEFSIM_ERR_INVALID_ARGUMENT;
    }
    if ((st = defsim__world_plan(w)) != DEFSIM_OK) return st;
    char why[400];
    if (unsupported(w, why, sizeof why)) {
        defsim__error(w->msg, "%s", why);
        return DEFSIM_ERR_UNSUPPORTED;
    }
    defsim_tape *t = calloc(1, sizeof *t);
    if (t) {
        t->nv = w->nv;
        t->natt = w->sys.att.n;
        t->nopt = w->backend.table->option_count;
        t->last = malloc(state_bytes(t));
        t->opt = malloc((size_t)(t->nopt > 0 ? t->nopt : 1) * sizeof(double));
    }
    if (!t || !t->last || !t->opt) {
        if (t) {
            free(t->last);
            free(t->opt);
        }
        free(t);
        defsim__error(w->msg, "record: out of memory");
        return DEFSIM_ERR_OUT_OF_MEMORY;
    }
    t->link.world = w;
    t->link.step = tape_step;
    t->hist = (w->backend.table->flags & DEFSIM_BACKEND_ADJOINT_HISTORY) != 0;
    t->drove0 = w->coupling.drove;
    if (!(t->gbuf = malloc(state_bytes(t) / 2))) {
        t->link.world = NULL;
        defsim_tape_destroy(t);
        defsim__error(w->msg, "record: out of memory");
        return DEFSIM_ERR_OUT_OF_MEMORY;
    }
    t->keep = t->hist && d.interval != 1;
    t->drops = w->backend.drops;
    /* The recorded run starts from its first state alone: the backend's history (a carried
     * force, a previous state) is dropped as defsim_world_set_state drops it. */
    if (w->backend.ready && w->backend.table->reset &&
        w->backend.table->reset(&defsim__host, &w->handle, w->backend.state) != DEFSIM_OK)
        defsim__world_backend_stop(w);
    t->automatic = d.interval == 0;
    t->k = d.interval == 0 ? 1 : d.interval;
    t->max_bytes = d.max_bytes;
    t->plan_serial = w->plan_serial;
    t->set = w->set;
    t->ncol = w->colliders.ncol;
    if (t->ncol > 0 && !(t->col = malloc((size_t)t->ncol * sizeof *t->col))) {
        t->link.world = NULL;
        defsim_tape_destroy(t);
        defsim__error(w->msg, "record: out of memory");
        return DEFSIM_ERR_OUT_OF_MEMORY;
    }
    if (t->ncol > 0) memcpy(t->col, w->colliders.col, (size_t)t->ncol * sizeof *t->col);
    t->q0 = -1;
    if (t->ncol > 0 && (!(t->qbuf = malloc(7 * (size_t)t->ncol * sizeof(double))) ||
                        !record_poses(t, w, &t->q0))) {
        t->link.world = NULL;
        defsim_tape_destroy(t);
        defsim__error(w->msg, "record: out of memory");
        return DEFSIM_ERR_OUT_OF_MEMORY;
    }
    if (t->nopt > 0)
        memcpy(t->opt, defsim__options_values(&w->options), (size_t)t->nopt * sizeof(double));
    save_state(w, t->last);
    t->last_t = w->state.t;
    t->mark = w->stats.time_step;
    if (!push_checkpoint(t, w)) {
        t->link.world = NULL;
        defsim_tape_destroy(t);
        defsim__error(w->msg, "record: out of memory");
        return DEFSIM_ERR_OUT_OF_MEMORY;
    }
    w->tape = &t->link;
    *out = t;
    return DEFSIM_OK;
}

/* Checks a backward call's arguments: the index of grads' names into which[], or a status. */
static defsim_status check_backward(defsim_tape *t, const double *dl_dx, const double *dl_dv,
                                    int64_t count, const defsim_gradient *grads, int32_t n,
                                    int *which)
{
    defsim_world *w = t->link.world;
    if (t->broken) {
        tape_error(t, "backward: the recording stopped following the world at step %lld: %s",
                   (long long)t->nsteps, t->why);
        return DEFSIM_ERR_INVALID_ARGUMENT;
    }
    const char *why = changed(t, w);
    if (why) {
        tape_error(t, "backward: since the recording began, %s", why);
        return DEFSIM_ERR_INVALID_ARGUMENT;
    }
    char buf[400];
    if (unsupported(w, buf, sizeof buf)) {
        tape_error(t, "backward: since the last recorded step, %s", buf + strlen("record: "));
        return DEFSIM_ERR_UNSUPPORTED;
    }
    if ((why = colliders_changed(t, w))) {
        tape_error(t, "backward: since the recording began, %s", why);
        return DEFSIM_ERR_INVALID_ARGUMENT;
    }
    const int64_t want = (t->nsteps + 1) * 3 * (int64_t)t->nv;
    if ((dl_dx || dl_dv) && count != want) {
        tape_error(t, "backward: count = %lld, but the loss gradients of %lld recorded states "
                      "of %d vertices hold (N + 1) * 3 * nv = %lld doubles",
                   (long long)count, (long long)(t->nsteps + 1), (int)t->nv, (long long)want);
        return DEFSIM_ERR_INVALID_ARGUMENT;
    }
    for (int64_t i = 0; i < want; ++i)
        if ((dl_dx && !isfinite(dl_dx[i])) || (dl_dv && !isfinite(dl_dv[i]))) {
            tape_error(t, "backward: dl_d%s[%lld] (state %lld, DOF %lld) is not finite",
                       dl_dx && !isfinite(dl_dx[i]) ? "x" : "v", (long long)i,
                       (long long)(i / (3 * (int64_t)t->nv)),
                       (long long)(i % (3 * (int64_t)t->nv)));
            return DEFSIM_ERR_INVALID_ARGUMENT;
        }
    if (n < 0 || (n > 0 && !grads)) {
        tape_error(t, "backward: grads is NULL or n < 0");
        return DEFSIM_ERR_INVALID_ARGUMENT;
    }
    const int64_t nb = live_bodies(w);
    for (int32_t i = 0; i < n; ++i) {
        int k = -1;
        for (int j = 0; grads[i].name && j < G_NAMES; ++j)
            if (strcmp(grads[i].name, grad_names[j]) == 0) k = j;
        if (k < 0) {
            tape_error(t, "backward: grads[%d] names no gradient (\"%s\"); the names: "
                          "initial_positions, initial_velocities, youngs_modulus, poisson_ratio, "
                          "density, mass_damping, stiffness_damping, external_forces, "
                          "attachment_stiffness, attachment_damping, attachment_targets, "
                          "pin_targets, collider_friction, body_friction, collider_poses",
                       (int)i, grads[i].name ? grads[i].name : "(null)");
            return DEFSIM_ERR_INVALID_ARGUMENT;
        }
        const int64_t c = k <= G_V0                  ? 3 * (int64_t)t->nv
                          : k == G_FEXT || k == G_PIN ? 3 * (int64_t)t->nv * t->nsteps
                          : k == G_ATT_P             ? 3 * (int64_t)t->natt * t->nsteps
                          : k == G_MU_COL ? defsim__collider_set_live(&w->colliders)
                          : k == G_POSE ? 6 * (int64_t)defsim__collider_set_live(&w->colliders) *
                                              (t->nsteps + 1)
                          : k == G_MU_BODY           ? nb
                          : k >= G_ATT_K             ? t->natt
                                                     : nb;
        if (grads[i].count != c || (c > 0 && !grads[i].out)) {
            tape_error(t, "backward: grads[%d] (%s) has count %lld, out %s: it needs %lld "
                          "doubles (%s)",
                       (int)i, grad_names[k], (long long)grads[i].count,
                       grads[i].out ? "set" : "NULL", (long long)c,
                       k <= G_V0                    ? "3 * vertex count"
                       : k == G_FEXT || k == G_PIN ? "3 * vertex count per step"
                       : k == G_ATT_P               ? "3 per attachment and step"
                       : k == G_MU_COL              ? "one per collider"
                       : k == G_POSE ? "6 per collider and state: (N + 1) * 6 * collider count"
                       : k == G_MU_BODY             ? "one per body"
                       : k >= G_ATT_K               ? "one per attachment"
                                                    : "one per body");
            return DEFSIM_ERR_INVALID_ARGUMENT;
        }
        which[i] = k;
    }
    return DEFSIM_OK;
}

defsim_status defsim_tape_backward(defsim_tape *t, const double *dl_dx, const double *dl_dv,
                                   int64_t count, const defsim_gradient *grads, int32_t n)
{
    if (!t) {
        defsim__set_last_error("backward: the tape is NULL");
        return DEFSIM_ERR_INVALID_ARGUMENT;
    }
    t->err[0] = '\0';
    defsim_world *w = t->link.world;
    if (!w) {
        tape_error(t, "backward: the tape's world was destroyed");
        return DEFSIM_ERR_INVALID_ARGUMENT;
    }
    defsim_status st = defsim__world_enter(w);
    if (st != DEFSIM_OK) return st;
    int *which = malloc((size_t)(n > 0 ? n : 1) * sizeof *which);
    if (!which) {
        tape_error(t, "backward: out of memory");
        return DEFSIM_ERR_OUT_OF_MEMORY;
    }
    if ((st = check_backward(t, dl_dx, dl_dv, count, grads, n, which)) != DEFSIM_OK) {
        free(which);
        return st;
    }
    const double t0 = defsim__now();
    t->stats.recomputed_steps = 0;
    t->stats.time_recompute = 0.0;
    const int64_t n3 = 3 * (int64_t)t->nv;
    const int32_t nb = live_bodies(w);
    world_saved saved;
    defsim__grad g;
    memset(&g, 0, sizeof g);
    int64_t peak = 0;
    double *ax = malloc(2 * (size_t)n3 * sizeof *ax);
    double *body = malloc((size_t)(G_FEXT - G_E) * (size_t)(nb > 0 ? nb : 1) * sizeof *body);
    const int ok = world_save(w, &saved) &&
                   grad_alloc(&g, &w->sys, w->colliders.ncol, w->bodies.n, &peak) && ax && body;
    if (!ok) {
        tape_error(t, "backward: out of memory");
        st = DEFSIM_ERR_OUT_OF_MEMORY;
    }
    if (st == DEFSIM_OK && (st = defsim__world_backend_prepare(w)) != DEFSIM_OK)
        tape_error(t, "backward: %s", w->msg->error);
    if (st == DEFSIM_OK) {
        double *av = ax + n3;
        for (int64_t i = 0; i < n3; ++i) {
            ax[i] = dl_dx ? dl_dx[n3 * t->nsteps + i] : 0.0;
            av[i] = dl_dv ? dl_dv[n3 * t->nsteps + i] : 0.0;
        }
        double *fext_out = NULL, *attp_out = NULL, *pin_out = NULL, *pose_out = NULL;
        for (int32_t i = 0; i < n; ++i) {
            if (which[i] == G_FEXT) fext_out = grads[i].out;
            if (which[i] == G_ATT_P) attp_out = grads[i].out;
            if (which[i] == G_PIN) pin_out = grads[i].out;
            if (which[i] == G_POSE && grads[i].count > 0) pose_out = grads[i].out;
        }
        if (pose_out) {   /* summed over the steps that start and end at each state */
            const int64_t c = 6 * (int64_t)defsim__collider_set_live(&w->colliders) *
                              (t->nsteps + 1);
            memset(pose_out, 0, (size_t)c * sizeof *pose_out);
        }
        for (int32_t i = 0; i < n; ++i) {
            if (which[i] == G_E || which[i] == G_NU) g.want |= DEFSIM__WANT_LAME;
            if (which[i] == G_BETA) g.want |= DEFSIM__WANT_BETA;
        }
        w->handle.grad = &g;
        st = run_backward(t, w, dl_dx, dl_dv, ax, av, fext_out, attp_out, pin_out, pose_out, &g,
                          &peak);
        w->handle.grad = NULL;
        if (st == DEFSIM_OK && !body_gradients(w, &g, body, nb)) {
            tape_error(t, "backward: out of memory");
            st = DEFSIM_ERR_OUT_OF_MEMORY;
        }
        if (st == DEFSIM_OK)
            for (int32_t i = 0; i < n; ++i) {
                const int k = which[i];
                if (k == G_FEXT || k == G_ATT_P || k == G_PIN || k == G_POSE) {
                    const double *src = k == G_FEXT ? fext_out : k == G_PIN ? pin_out
                                        : k == G_POSE                      ? pose_out
                                                                           : attp_out;
                    if (grads[i].out != src && grads[i].count > 0)   /* asked twice */
                        memcpy(grads[i].out, src, (size_t)grads[i].count * sizeof(double));
                    continue;
                }
                if (k == G_MU_BODY) {   /* live bodies in slot order */
                    for (int32_t b = 0, m = 0; b < w->bodies.n; ++b)
                        if (w->bodies.b[b].generation & 1u) grads[i].out[m++] = g.mu_body[b];
                    continue;
                }
                if (k == G_MU_COL) {   /* live colliders in slot order (get_collider's) */
                    for (int32_t j = 0, m = 0; j < w->colliders.ncol; ++j)
                        if (w->colliders.col[j].generation & 1u) grads[i].out[m++] = g.mu_col[j];
                    continue;
                }
                const double *src = k == G_X0 ? ax : k == G_V0 ? av : k == G_ATT_K ? g.att_k
                                    : k == G_ATT_C                   ? g.att_c
                                                                     : body + (k - G_E) * nb;
                memcpy(grads[i].out, src, (size_t)grads[i].count * sizeof(double));
            }
    }
    char err[sizeof t->err];
    memcpy(err, t->err, sizeof err);
    world_restore(t, w, &saved);
    grad_free(&g);
    free(ax);
    free(body);
    free(which);
    if (st != DEFSIM_OK) defsim__error(w->msg, "%s", err);
    else w->msg->error[0] = '\0';
    t->stats.backward_bytes = peak;
    t->stats.time_backward = defsim__now() - t0;
    return st;
}

defsim_status defsim_tape_get_stats(const defsim_tape *t, defsim_tape_stats *out)
{
    if (!t || !out || out->size < sizeof(uint32_t)) {
        defsim__set_last_error("tape stats: %s",
                               !t ? "the tape is NULL" : "out is NULL or its size 0");
        return DEFSIM_ERR_INVALID_ARGUMENT;
    }
    defsim_tape_stats s = t->stats;
    s.size = (uint32_t)sizeof s;
    s.steps = t->nsteps;
    s.stored_states = t->ncp + 1;
    s.interval = t->k;
    s.bytes = tape_bytes(t);
    const uint32_t size = out->size;
    memcpy(out, &s, size < sizeof s ? size : sizeof s);
    out->size = size < sizeof s ? size : (uint32_t)sizeof s;
    return DEFSIM_OK;
}

const char *defsim_tape_last_error(const defsim_tape *t) { return t ? t->err : ""; }

void defsim_tape_destroy(defsim_tape *t)
{
    if (!t) return;
    if (t->link.world) t->link.world->tape = NULL;
    free(t->h);
    free(t->fi);
    free(t->f);
    free(t->pi);
    free(t->p);
    free(t->cp);
    free(t->cpt);
    free(t->cprev);
    for (int64_t c = 0; t->cpb && c < t->cpcap; ++c) free(t->cpb[c].p);
    free(t->cpb);
    free(t->fresh);
    free(t->gi);
    free(t->g);
    free(t->gbuf);
    free(t->last);
    free(t->opt);
    free(t->col);
    free(t->qi);
    free(t->q);
    free(t->qbuf);
    free(t);
}
