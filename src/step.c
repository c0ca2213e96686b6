/* SPDX-License-Identifier: MIT */
/*
 * The world's step (defsim_world_step) and its stable step, in the order a step walks:
 * plan (world.c plans and starts the backend), terms (the coupling set's hooks, collider
 * contact, body contact), the backend's calls (auto-substep, roll-back and retry), the
 * stability watchdog's verdict, and the read-back (contact forces, colliders' poses, the
 * callback's forces for the next step). src/README.md writes the walk down.
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

static defsim_status contact_begin(defsim_world *w, double h);

/* The terms' list follows what is attached to the system (collider and body contact): compiled
 * again only when that differs from what it was compiled with (contact, body), once for all
 * the begins of a step and once for all its ends. */
static defsim_status terms_follow(defsim_world *w, const void *contact, const void *body,
                                  defsim_status st)
{
    if (w->sys.contact == contact && w->sys.body_contact == body) return st;
    const defsim_status ct = defsim__terms_compile(&w->sys);
    return st == DEFSIM_OK ? ct : st;
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
    const void *was = w->sys.contact;
    if (w->nv > 0 && penalty) st = contact_begin(w, 0.0);
    st = terms_follow(w, was, w->sys.body_contact, st);
    if (w->nv > 0 && st == DEFSIM_OK) st = estimate_stable_step(w, &h, &om);
    was = w->sys.contact;
    w->sys.contact = NULL;
    st = terms_follow(w, was, w->sys.body_contact, st);
    if (st != DEFSIM_OK) return st;
    if (h_out) *h_out = h;
    if (omega_out) *omega_out = om;
    return DEFSIM_OK;
}

/* ------------------------------------------------------------------------------------------ */
/* Stepping */

/* The work terms of the step for the watchdog (watchdog.h): the callback's recorded forces,
 * the forces at moving driven pins, the colliders' work and their energy at the start. */
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
    defsim__contact *ct = w->sys.contact;
    if (ct && ct->npair > 0) {
        in->colliders_changed = w->colliders.came;
        if (!w->wd.have_ref || w->colliders.came)
            in->contact_start = defsim__contact_energy_start(ct, w->step.x_save);
        in->contact_work = defsim__contact_work(ct, w->step.x_save, w->state.x);
    }
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

/* Contact (contact.h) for a step of h (0: for the stable step): BARRIER for backends whose line
 * search uses contact_max_step, PENALTY for the others; the system sees it until the step ends.
 * Attaches it only: the caller compiles the terms' list again (terms_follow). */
static defsim_status contact_begin(defsim_world *w, double h)
{
    w->sys.contact = NULL;   /* left attached by a failed step: detached */
    /* The penalty is a force that jumps when a collider comes, goes or moves between steps:
     * backends that carry force evaluations from the last step (velocity_verlet's f(x_n),
     * ERK's first-same-as-last stage, IDA's history) start afresh, as after set_state. */
    const int penalty = !(w->backend.table->flags & DEFSIM_BACKEND_CONTACT_CCD);
    int jumped = w->colliders.changed;
    for (int32_t j = 0; j < w->colliders.ncol && !jumped; ++j)
        jumped = (w->colliders.col[j].generation & 1u) &&
                 (memcmp(w->colliders.col[j].pos, w->colliders.col[j].pos1, sizeof w->colliders.col[j].pos) != 0 ||
                  memcmp(w->colliders.col[j].rot, w->colliders.col[j].rot1, sizeof w->colliders.col[j].rot) != 0);
    if (h > 0.0 && jumped && penalty && w->backend.ready && w->backend.table->reset) {
        const defsim_status st =
            w->backend.table->reset(&defsim__host, &w->handle, w->backend.state);
        if (st != DEFSIM_OK) {
            defsim__error(w->msg, "backend %s failed to reset for the colliders' change",
                          w->backend.table->name);
            return st;
        }
    }
    if (h > 0.0) {
        /* The watchdog counts the energy of colliders that came until a step succeeds. */
        w->colliders.came |= w->colliders.changed;
        w->colliders.changed = 0;
    }
    if (defsim__collider_set_live(&w->colliders) == 0) return DEFSIM_OK;
    defsim__contact_params p = {
        .mode = (w->backend.table->flags & DEFSIM_BACKEND_CONTACT_CCD) ? DEFSIM__CONTACT_BARRIER
                                                                 : DEFSIM__CONTACT_PENALTY,
        .dhat_rel = w->set.contact_dhat, .kappa = w->set.contact_kappa,
        .frequency = w->set.contact_frequency, .eps_v = w->set.friction_eps_v};
    defsim__contact *c = &w->contact;
    if (p.mode == DEFSIM__CONTACT_PENALTY && p.frequency == 0.0 && c->omega_elastic == 0.0) {
        double om = 0.0;   /* the bodies' own top frequency, without contact, once per plan */
        defsim_status st = defsim__omega_max(&w->sys, &w->work, w->state.x, &om);
        if (st != DEFSIM_OK) {
            defsim__error(w->msg, "contact: the elastic frequency is not finite");
            return st;
        }
        c->omega_elastic = om;
    }
    p.omega_elastic = c->omega_elastic;
    if (p.mode == DEFSIM__CONTACT_BARRIER && !c->surf_planned &&
        defsim__contact_surfaces(c, w->bodies.b, w->bodies.n) != DEFSIM_OK) {
        defsim__error(w->msg, "contact: out of memory for the bodies' surfaces");
        return DEFSIM_ERR_OUT_OF_MEMORY;
    }
    /* A step's start: the world's copies, which nothing changes until the step ends. */
    defsim_status st = defsim__contact_begin(c, &w->sys, w->colliders.col, w->colliders.ncol, &p,
                                             h > 0.0 ? w->step.x_save : w->state.x,
                                             h > 0.0 ? w->step.v_save : w->state.v, h, w->msg);
    if (st != DEFSIM_OK) return st;
    w->sys.contact = c;
    return DEFSIM_OK;
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
    const void *was = w->sys.contact;
    defsim_status st = contact_begin(w, 0.0);
    st = terms_follow(w, was, w->sys.body_contact, st);
    for (int32_t j = 0; j < w->colliders.ncol; ++j) {
        defsim__collider *c = &w->colliders.col[j];
        memcpy(c->pos1, keep + 7 * (int64_t)j, sizeof c->pos1);
        memcpy(c->rot1, keep + 7 * (int64_t)j + 3, sizeof c->rot1);
    }
    free(keep);
    return st;
}

void defsim__world_replay_contact_end(defsim_world *w)
{
    const void *was = w->sys.contact;
    w->sys.contact = NULL;
    (void)terms_follow(w, was, w->sys.body_contact, DEFSIM_OK);
}

void *defsim__world_term_state(defsim_world *w, int kind)
{
    /* Body contact keeps candidates between steps only to skip a broad phase: a loaded world's
     * first step finds them again, in the same deterministic order. Its chunk is a step's pairs,
     * read against the surfaces that a step's begin builds. */
    return kind == DEFSIM__TERM_KIND_collider ? &w->contact : NULL;
}

/* A zeroed contact-force read-back of the world's vertex count. */
static defsim_status readback_reserve(defsim_world *w)
{
    free(w->colliders.force);
    w->colliders.force_nv = 0;
    w->colliders.force = calloc(3 * (size_t)w->nv, sizeof *w->colliders.force);
    if (!w->colliders.force) {
        defsim__error(w->msg, "out of memory for the contact forces");
        return DEFSIM_ERR_OUT_OF_MEMORY;
    }
    w->colliders.force_nv = w->nv;
    return DEFSIM_OK;
}

/* Closes contact's part of a step: a callback's failure is the step's; after a success, the
 * contact forces for the host and the colliders' poses at the end of the step. */
static defsim_status contact_end(defsim_world *w, defsim__contact *c, defsim_status st)
{
    if (!c) {   /* no collider: the read-back is zero (dropped once after the last one went) */
        if (st == DEFSIM_OK && w->contact.readback_set) {
            free(w->colliders.force);
            w->colliders.force = NULL;
            w->colliders.force_nv = 0;
            w->contact.readback_set = 0;
        }
        return st;
    }
    if (st == DEFSIM_OK && (!w->colliders.force || w->colliders.force_nv != w->nv)) {
        if (readback_reserve(w) != DEFSIM_OK) return DEFSIM_ERR_OUT_OF_MEMORY;
        w->colliders.force_zero = 1;
    }
    /* The read-back goes to scratch first: a callback failing there fails the step too, and
     * a failed step changes neither the read-back nor the poses. Without pairs (colliders far
     * away) the forces are zero: nothing to compute or copy when the read-back is zero already. */
    const int none = st == DEFSIM_OK && w->colliders.force_zero && defsim__contact_none(c, w->state.x);
    if (st == DEFSIM_OK && !c->failed && none) {
        c->stat[DEFSIM__CSTAT_ACTIVE] = 0;
        c->stat[DEFSIM__CSTAT_MIN_DISTANCE] = INFINITY;
    } else if (st == DEFSIM_OK && !c->failed) {
        defsim__contact_end(c, w->state.x, w->state.v, c->blk);
    }
    if (c->failed) {
        defsim__error(w->msg, "contact: %s; state restored", defsim__contact_failure(c));
        return c->failed;
    }
    if (st != DEFSIM_OK && c->blocked) {
        char who[48] = "a surface";
        if (c->blocked_vertex >= 0) snprintf(who, sizeof who, "vertex %d", (int)c->blocked_vertex);
        defsim__error(w->msg, "contact: no Newton start keeps %s clear of the moving colliders in "
                      "this step (squeezed between colliders that move differently, swept by "
                      "one, or cut back by body contact); state restored", who);
    }
    if (st != DEFSIM_OK) return st;
    if (c->mode == DEFSIM__CONTACT_BARRIER &&
        w->set.watchdog &&
        !(c->stat[DEFSIM__CSTAT_MIN_DISTANCE] > 0.0)) {
        /* The watchdog's contact check: the barrier is infinite at zero distance and the line
         * search keeps every vertex out, so a vertex at d <= 0 means that guarantee broke. */
        w->stats.watchdog_trips++;
        defsim__error(w->msg, "step: watchdog: a vertex crossed a collider's surface (distance "
                      "%g m) although the contact barrier forbids it; state restored. This is a "
                      "defect: please report it with the scene", c->stat[DEFSIM__CSTAT_MIN_DISTANCE]);
        return DEFSIM_ERR_UNSTABLE;
    }
    if (!none) memcpy(w->colliders.force, c->blk, 3 * (size_t)w->nv * sizeof *w->colliders.force);
    w->colliders.force_zero = c->npair == 0;
    c->readback_set = 1;
    for (int32_t j = 0; j < w->colliders.ncol; ++j) {
        memcpy(w->colliders.col[j].pos, w->colliders.col[j].pos1, sizeof w->colliders.col[j].pos);
        memcpy(w->colliders.col[j].rot, w->colliders.col[j].rot1, sizeof w->colliders.col[j].rot);
    }
    return DEFSIM_OK;
}

/* Body contact (body_contact.h) for a step of h while the option is on (the step refused
 * backends without contact CCD already). */
static defsim_status body_begin(defsim_world *w, double h)
{
    w->sys.body_contact = NULL;   /* left attached by a failed step: detached */
    if (!w->set.body_contact) {
        w->step.body_contact_last = 0;
        return DEFSIM_OK;
    }
    if (!w->step.body_contact_last) w->body_contact.fresh = 1;
    w->step.body_contact_last = 1;
    const defsim_status st = defsim__body_contact_begin(
        &w->body_contact, &w->sys, w->bodies.b, w->bodies.n,
        w->set.contact_dhat, w->set.contact_kappa, w->set.friction_eps_v, w->step.x_save,
        w->state.v, h,
        w->contact.stat, w->msg);
    if (st != DEFSIM_OK) return st;
    w->sys.body_contact = &w->body_contact;
    return DEFSIM_OK;
}

/* Closes body contact's part of a step: the forces of the end state (into its scratch, for the
 * read-back) and the statistics; the watchdog's check that no pair reached distance 0. */
static defsim_status body_end(defsim_world *w, defsim__body_contact *bc, defsim_status st)
{
    if (!bc || st != DEFSIM_OK) return st;
    if (bc->failed) {
        defsim__error(w->msg, "out of memory for body contact pairs; state restored");
        return bc->failed;
    }
    const double dmin = defsim__body_contact_end(bc, &w->sys, w->state.x, bc->scratch);
    if (bc->failed) {
        defsim__error(w->msg, "out of memory rebuilding the matrix pattern; state restored");
        return bc->failed;
    }
    if (w->set.watchdog && !(dmin > 0.0)) {
        w->stats.watchdog_trips++;
        defsim__error(w->msg, "step: watchdog: two body surfaces touched (distance %g m) although "
                      "the contact barrier forbids it; state restored. This is a defect: please "
                      "report it with the scene", dmin);
        return DEFSIM_ERR_UNSTABLE;
    }
    return DEFSIM_OK;
}

/* Adds body contact's forces of a successful step to the read-back (after the colliders'). */
static defsim_status body_readback(defsim_world *w, int colliders)
{
    if (!w->colliders.force || w->colliders.force_nv != w->nv) {
        if (readback_reserve(w) != DEFSIM_OK) return DEFSIM_ERR_OUT_OF_MEMORY;
    } else if (!colliders) {
        memset(w->colliders.force, 0, 3 * (size_t)w->nv * sizeof *w->colliders.force);
    }
    const double *f = w->body_contact.scratch;
    for (int64_t i = 0; i < 3 * (int64_t)w->nv; ++i) w->colliders.force[i] += f[i];
    w->colliders.force_zero = 0;
    w->contact.readback_set = 1;
    return DEFSIM_OK;
}

/* The coupling set's start of a step (driven pins, the callback at the start). */
static defsim_status step_begin(defsim_world *w, double h)
{
    return defsim__coupling_step_begin(&w->coupling, &w->sys, &w->state,
                                       (w->backend.table->flags & DEFSIM_BACKEND_IMPLICIT) != 0, h,
                                       &w->step.passes, w->msg);
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
    const void *was_contact = w->sys.contact, *was_body = w->sys.body_contact;
    st = step_begin(w, h);
    if (st == DEFSIM_OK) st = contact_begin(w, h);
    if (st == DEFSIM_OK) st = body_begin(w, h);
    st = terms_follow(w, was_contact, was_body, st);
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
            defsim__coupling_substep_before(&w->coupling, &w->state, i, n, h / (double)n);
            defsim__terms_substep(&w->sys, (double)i / (double)n, (double)(i + 1) / (double)n,
                                  h / (double)n);
            st = w->backend.table->step(&defsim__host, &w->handle, w->backend.state, h / (double)n);
            defsim__coupling_substep_after(&w->coupling, &w->state);
        }
        if (substep) w->stats.substeps += n;
        if (st != DEFSIM_ERR_UNSTABLE || !substep) break;
        /* Unstable despite substepping: roll back and retry once, re-estimated and halved. */
        memcpy(w->state.x, w->step.x_save, bytes);
        memcpy(w->state.v, w->step.v_save, bytes);
        st = step_begin(w, h);
        if (st != DEFSIM_OK) break;
        if (w->backend.table->reset)
            w->backend.table->reset(&defsim__host, &w->handle, w->backend.state);
    }
    st = defsim__coupling_step_end(&w->coupling, &w->sys, st);
    if (substep && st == DEFSIM_OK) w->step.since_estimate++;
    if (st == DEFSIM_OK) st = watch_step(w, h);
    defsim__contact *c = w->sys.contact;
    defsim__body_contact *bc = w->sys.body_contact;
    w->sys.contact = NULL;
    w->sys.body_contact = NULL;
    st = terms_follow(w, c, bc, st);
    st = body_end(w, bc, st);
    st = contact_end(w, c, st);
    if (st == DEFSIM_OK && bc) st = body_readback(w, c != NULL);
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
    return DEFSIM_OK;
}

