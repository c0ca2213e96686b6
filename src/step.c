/* SPDX-License-Identifier: MIT */
/*
 * The world's step (defsim_world_step) and its stable step, in the order a step walks: plan
 * (world.c plans and starts the backend), terms (the kinds' begins through terms.c: the coupling
 * set's hooks, collider contact, body contact), the backend's calls (auto-substep, the per-call
 * hooks through terms.c, roll-back and retry), the stability watchdog's verdict (watchdog.c,
 * which reads the colliders' work through the terms), and the read-back (the kinds' ends
 * through terms.c: contact forces, colliders' poses; the callback's forces for the next step,
 * statistics). src/README.md writes the walk down; tests/tools/step_walk.py checks it.
 *
 * Contents: stability; stepping.
 */
#include "step.h"

#include "clock.h"
#include "stability.h"
#include "terms.h"
#include "watchdog.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* ------------------------------------------------------------------------------------------ */
/* Stability */

/* What the kinds' step hooks see of the world (term.h), for a step of h (0: no step). */
static defsim__step_ctx hooks(defsim_world *w, double h)
{
    return (defsim__step_ctx){
        .h = h, .x0 = w->step.x_save, .v0 = w->step.v_save, .state = &w->state, .set = &w->set,
        .host = &defsim__host, .backend = w->backend.table, .handle = &w->handle,
        .backend_state = w->backend.state, .backend_ready = w->backend.ready,
        .bodies = w->bodies.b, .nbodies = w->bodies.n, .work = &w->work,
        .coupling = &w->coupling, .colliders = &w->colliders, .contact = &w->contact,
        .body_contact = &w->body_contact, .body_contact_last = &w->step.body_contact_last,
        .passes = &w->step.passes, .watchdog_trips = &w->stats.watchdog_trips, .msg = w->msg};
}

static defsim_status estimate_stable_step(defsim_world *w, double *h, double *omega)
{
    double om = 0.0;
    defsim_status st = defsim__omega_max(&w->sys, &w->work, w->state.x, &om);
    if (st != DEFSIM_OK) {
        defsim__error(w->msg, st == DEFSIM_ERR_OUT_OF_MEMORY ? "out of memory"
                                                              : "stable step: non-finite stiffness");
        return st;
    }
    const double c = defsim__damping_coeff(&w->sys, w->state.x, om);
    const defsim_backend *b = w->backend.table;
    *h = b->stable_step_options ? b->stable_step_options(defsim__options_values(&w->options), om, c)
         : b->stable_step       ? b->stable_step(om, c)
                                : INFINITY;
    if (omega) *omega = om;
    w->stats.stable_step = *h;
    return DEFSIM_OK;
}

defsim_status defsim_world_stable_step(defsim_world *w, double *h_out, double *omega_out)
{
    defsim_status st = defsim__world_enter(w);
    if (st != DEFSIM_OK) return st;
    st = defsim__world_plan(w);
    if (st != DEFSIM_OK) return st;
    double h = INFINITY, om = 0.0;
    /* Penalty contact stiffens the system (explicit backends' limit); the barrier's backends
     * have no limit. */
    const int penalty = !(w->backend.table->flags & DEFSIM_BACKEND_CONTACT_CCD);
    if (w->nv > 0 && penalty) {
        const defsim__step_ctx sc = hooks(w, 0.0);
        st = defsim__terms_step_begin(&w->sys, &sc);
    }
    if (w->nv > 0 && st == DEFSIM_OK) st = estimate_stable_step(w, &h, &om);
    const defsim_status dt = defsim__terms_detach(&w->sys);
    if (st == DEFSIM_OK) st = dt;
    if (st != DEFSIM_OK) return st;
    if (h_out) *h_out = h;
    if (omega_out) *omega_out = om;
    return DEFSIM_OK;
}

/* ------------------------------------------------------------------------------------------ */
/* Stepping */

/* The work terms of the step for the watchdog (watchdog.h): the callback's recorded forces,
 * the forces at moving driven pins, and whether the colliders' energy at the start is wanted
 * (the check reads the colliders' work through the terms). */
static defsim_status watch_work(defsim_world *w, defsim__watchdog_step *in, char *what,
                                size_t size)
{
    const defsim__coupling *c = &w->coupling.cpl;
    if (c->fn) {
        if (c->implicit) in->cb_f[in->ncb++] = c->f0;   /* the start, evaluated by step_begin */
        if (c->nrec > 0) in->cb_f[in->ncb++] = c->rec_first;
        if (c->nrec > 1) in->cb_f[in->ncb++] = c->rec_last;
        if (c->rec_prev_t == w->state.t && w->wd.have_ref) in->cb_f[in->ncb++] = c->rec_prev;
    }
    if (w->coupling.drove) {
        /* The forces that the pins hold at the start (those of the last step's end when that
         * ended here) and at the end. Not counted as the backend's force evaluations. */
        defsim__watchdog *wd = &w->wd;
        double *f0 = defsim__watchdog_pin_buffer(wd, w->nv, 0);
        double *f1 = defsim__watchdog_pin_buffer(wd, w->nv, 1);
        if (!f0 || !f1) {
            snprintf(what, size, "out of memory");
            return DEFSIM_ERR_OUT_OF_MEMORY;
        }
        defsim_status st = DEFSIM_OK;
        if (!(wd->pin_f_t == w->state.t && wd->have_ref)) {
            st = defsim__watchdog_pin_forces(wd, &w->sys, w->step.x_save, w->step.v_save, f0);
            wd->pin_f_t = st == DEFSIM_OK ? w->state.t : NAN;
        }
        if (st == DEFSIM_OK)
            st = defsim__watchdog_pin_forces(wd, &w->sys, w->state.x, w->state.v, f1);
        if (st != DEFSIM_OK) {
            snprintf(what, size, st == DEFSIM_ERR_OUT_OF_MEMORY
                                     ? "out of memory"
                                     : "the forces on the driven pins are not finite");
            return st;
        }
        wd->pin_end = 1;
        in->pin_f0 = f0;
        in->pin_f1 = f1;
    }
    in->colliders_changed = w->colliders.came;
    in->contact_start_wanted = !w->wd.have_ref || w->colliders.came;
    return DEFSIM_OK;
}

/* The stability watchdog over a step the backend finished; on a trip the message says what
 * tripped and what to do, with the stable step at the restored start (docs/watchdog.md). */
static defsim_status watch_step(defsim_world *w, double h)
{
    defsim__watchdog_step in = {
        .sys = &w->sys, .work = &w->work, .bodies = w->bodies.b, .nbodies = w->bodies.n,
        .x = w->state.x, .v = w->state.v, .x0 = w->step.x_save, .v0 = w->step.v_save,
        .on = w->set.watchdog, .energy_growth = w->set.energy_growth,
        .max_stretch = w->set.max_stretch};
    char what[400];
    w->wd.pin_end = 0;
    defsim_status st = in.on ? watch_work(w, &in, what, sizeof what) : DEFSIM_OK;
    const int64_t evals = w->wd.energy_evals;
    if (st == DEFSIM_OK) st = defsim__watchdog_check(&w->wd, &in, what, sizeof what);
    w->stats.energy_evals += w->wd.energy_evals - evals;
    if (st != DEFSIM_ERR_UNSTABLE) {
        if (st != DEFSIM_OK) defsim__error(w->msg, "step: %s", what);
        return st;
    }
    w->stats.watchdog_trips++;
    const size_t bytes = 3 * (size_t)w->nv * sizeof(double);
    memcpy(w->state.x, w->step.x_save, bytes);   /* the estimate is of the start */
    memcpy(w->state.v, w->step.v_save, bytes);
    const int limited = w->backend.table->stable_step || w->backend.table->stable_step_options;
    double hs = INFINITY;
    const int estimated = limited && estimate_stable_step(w, &hs, NULL) == DEFSIM_OK;
    char msg[sizeof w->msg->error];
    defsim__watchdog_message(msg, sizeof msg, what, h, w->state.t, w->backend.table->name, limited,
                             estimated ? hs : NAN, w->set.auto_substep);
    defsim__error(w->msg, "%s", msg);
    return DEFSIM_ERR_UNSTABLE;
}

defsim_status defsim__world_replay_contact_begin(defsim_world *w)
{
    if (w->nv == 0 || defsim__collider_set_live(&w->colliders) == 0 ||
        (w->backend.table->flags & DEFSIM_BACKEND_CONTACT_CCD))
        return DEFSIM_OK;
    /* An SDF collider has no function until the host installs it after the load: the replay
     * goes without contact (and, if it touched one, misses and restarts). */
    for (int32_t j = 0; j < w->colliders.ncol; ++j)
        if ((w->colliders.col[j].generation & 1u) && w->colliders.col[j].def.shape == DEFSIM_SHAPE_SDF)
            return DEFSIM_OK;
    /* contact_begin takes both poses of the step from the colliders: the end pose made the
     * current one for that call (begin copies the poses), then the pending targets back. */
    double *keep = malloc(7 * (size_t)w->colliders.ncol * sizeof *keep);
    if (!keep) {
        defsim__error(w->msg, "out of memory");
        return DEFSIM_ERR_OUT_OF_MEMORY;
    }
    for (int32_t j = 0; j < w->colliders.ncol; ++j) {
        defsim__collider *c = &w->colliders.col[j];
        memcpy(keep + 7 * (int64_t)j, c->pos1, sizeof c->pos1);
        memcpy(keep + 7 * (int64_t)j + 3, c->rot1, sizeof c->rot1);
        memcpy(c->pos1, c->pos, sizeof c->pos);
        memcpy(c->rot1, c->rot, sizeof c->rot);
    }
    const defsim__step_ctx sc = hooks(w, 0.0);
    const defsim_status st = defsim__terms_step_begin(&w->sys, &sc);
    for (int32_t j = 0; j < w->colliders.ncol; ++j) {
        defsim__collider *c = &w->colliders.col[j];
        memcpy(c->pos1, keep + 7 * (int64_t)j, sizeof c->pos1);
        memcpy(c->rot1, keep + 7 * (int64_t)j + 3, sizeof c->rot1);
    }
    free(keep);
    return st;
}

void defsim__world_replay_contact_end(defsim_world *w) { (void)defsim__terms_detach(&w->sys); }

defsim_status defsim__world_adjoint_begin(defsim_world *w, const double *x0, const double *v0,
                                          double h)
{
    if (w->nv == 0 || (defsim__collider_set_live(&w->colliders) == 0 && !w->set.body_contact))
        return DEFSIM_OK;
    const size_t bytes = 3 * (size_t)w->nv * sizeof(double);
    memcpy(w->step.x_save, x0, bytes);   /* contact borrows the step's start from here */
    memcpy(w->step.v_save, v0, bytes);
    const defsim__step_ctx sc = hooks(w, h);
    return defsim__terms_step_begin(&w->sys, &sc);
}

void defsim__world_adjoint_end(defsim_world *w)
{
    (void)defsim__terms_detach(&w->sys);
    if (w->planned)
        for (int k = 0; k < DEFSIM__TERM_KINDS; ++k) w->sys.cache[k].valid = 0;
}

void *defsim__world_term_state(defsim_world *w, int kind)
{
    /* Body contact keeps candidates between steps only to skip a broad phase: a loaded world's
     * first step finds them again, in the same deterministic order. Its chunk is a step's pairs,
     * read against the surfaces that a step's begin builds. */
    return kind == DEFSIM__TERM_KIND_collider ? &w->contact : NULL;
}

defsim_status defsim_world_step(defsim_world *w, double h)
{
    defsim_status st = defsim__world_enter(w);
    if (st != DEFSIM_OK) return st;
    if (!isfinite(h) || !(h > 0.0)) {
        defsim__error(w->msg, "step: h = %g must be finite and > 0", h);
        return DEFSIM_ERR_INVALID_ARGUMENT;
    }
    if (w->state.t + h == w->state.t) {
        defsim__error(w->msg, "step: h = %g s does not advance the time t = %.17g s (t + h rounds "
                      "to t in double precision): use a larger step, or restart the clock",
                      h, w->state.t);
        return DEFSIM_ERR_INVALID_ARGUMENT;
    }
    if (w->set.body_contact &&
        !(w->backend.table->flags & DEFSIM_BACKEND_CONTACT_CCD)) {
        defsim__error(w->msg, "step: body contact (core.body_contact) needs a backend with "
                              "contact CCD (newton_cholmod, newmark or bdf2); backend %s has "
                              "none: turn body_contact off or change the backend",
                      w->backend.table->name);
        return DEFSIM_ERR_UNSUPPORTED;
    }
    double t0 = defsim__now();
    st = defsim__world_plan(w);
    if (st != DEFSIM_OK) return st;
    if (w->nv == 0) {
        w->state.t += h;
        w->stats.steps++;
        return DEFSIM_OK;
    }
    if ((st = defsim__world_backend_prepare(w)) != DEFSIM_OK) {
        w->stats.failed_steps++;
        return st;
    }
    const size_t bytes = 3 * (size_t)w->nv * sizeof(double);
    memcpy(w->step.x_save, w->state.x, bytes);
    memcpy(w->step.v_save, w->state.v, bytes);
    w->step.passes = 0;
    w->msg->error[0] = '\0';
    const int substep = w->set.auto_substep &&
                        (w->backend.table->stable_step || w->backend.table->stable_step_options);
    const defsim__step_ctx sc = hooks(w, h);
    st = defsim__terms_step_begin(&w->sys, &sc);
    for (int attempt = 0; attempt < 2 && st == DEFSIM_OK; ++attempt) {
        int64_t n = 1;
        if (substep) {
            /* Re-estimate every 64 steps, after any change, and after a failed attempt. */
            if (w->step.h_stable <= 0.0 || w->step.since_estimate >= 64 || attempt > 0) {
                double hs;
                if ((st = estimate_stable_step(w, &hs, NULL)) != DEFSIM_OK) break;
                w->step.h_stable = attempt > 0 ? 0.5 * hs : hs;
                w->step.since_estimate = 0;
            }
            double k = ceil(h / (w->set.substep_safety * w->step.h_stable));
            if (!(k <= 1e7)) {
                st = DEFSIM_ERR_UNSTABLE;
                defsim__error(w->msg, "step: auto_substep would need %g substeps (stable step %g s)",
                              k, w->step.h_stable);
                break;
            }
            n = k < 1.0 ? 1 : (int64_t)k;
        }
        st = DEFSIM_OK;
        for (int64_t i = 0; i < n && st == DEFSIM_OK; ++i) {
            defsim__terms_substep_before(&w->sys, &sc, i, n);
            st = w->backend.table->step(&defsim__host, &w->handle, w->backend.state, h / (double)n);
            defsim__terms_substep_after(&sc);
        }
        if (substep) w->stats.substeps += n;
        if (st != DEFSIM_ERR_UNSTABLE || !substep) break;
        /* Unstable despite substepping: roll back and retry once, re-estimated and halved. */
        memcpy(w->state.x, w->step.x_save, bytes);
        memcpy(w->state.v, w->step.v_save, bytes);
        st = defsim__terms_restart(&w->sys, &sc);
        if (st != DEFSIM_OK) break;
        if (w->backend.table->reset)
            w->backend.table->reset(&defsim__host, &w->handle, w->backend.state);
    }
    st = defsim__terms_finish(&w->sys, &sc, st);
    if (substep && st == DEFSIM_OK) w->step.since_estimate++;
    if (st == DEFSIM_OK) st = watch_step(w, h);
    st = defsim__terms_step_end(&w->sys, &sc, st);
    if (st != DEFSIM_OK) {
        memcpy(w->state.x, w->step.x_save, bytes);
        memcpy(w->state.v, w->step.v_save, bytes);
        if (!w->msg->error[0])
            defsim__error(w->msg, "step: backend %s failed: %s", w->backend.table->name,
                          defsim_status_string(st));
        if (w->backend.table->reset &&
            w->backend.table->reset(&defsim__host, &w->handle, w->backend.state) != DEFSIM_OK)
            defsim__world_backend_stop(w);
        w->stats.failed_steps++;
        w->stats.time_step += defsim__now() - t0;
        return st;
    }
    w->state.t += h;
    w->colliders.came = 0;
    defsim__watchdog_step_done(&w->wd, w->state.t);
    if (w->coupling.cpl.fn && w->coupling.cpl.nrec > 0) {
        /* The callback's last forces of this step serve the next (watch_work). */
        double *r = w->coupling.cpl.rec_prev;
        w->coupling.cpl.rec_prev = w->coupling.cpl.nrec > 1 ? w->coupling.cpl.rec_last : w->coupling.cpl.rec_first;
        if (w->coupling.cpl.nrec > 1) w->coupling.cpl.rec_last = r;
        else w->coupling.cpl.rec_first = r;
        w->coupling.cpl.rec_prev_t = w->state.t;
    }
    w->stats.steps++;
    w->stats.passes = w->step.passes;
    w->stats.time_step += defsim__now() - t0;
    if (w->tape) w->tape->step(w->tape, h);   /* a recording (tape.c) takes the step */
    return DEFSIM_OK;
}

