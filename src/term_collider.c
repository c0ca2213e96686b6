/* SPDX-License-Identifier: MIT */
/*
 * Contact with the world's colliders (contact.c does the geometry; docs/contact.md): in the list
 * while the world has attached its contact state for a step. Its matrix blocks touch only each
 * vertex's own 3x3 block; linearise evaluates them once per x (and coefficients, substep and
 * friction velocities) into the kind's cache, which values and products read, so a product
 * never queries a collider.
 */
#include "adjoint.h"
#include "assembly.h"
#include "chunk.h"
#include "collider.h"
#include "contact.h"
#include "host.h"
#include "options.h"
#include "stability.h"
#include "system.h"
#include "term_cache.h"

#include <float.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static defsim__contact *contact(const defsim__term *t) { return t->data; }

static int compile(defsim__system *s, defsim__term *out)
{
    return defsim__term_contact(s, s->nv, s->contact, &s->cache[DEFSIM__TERM_KIND_collider],
                                9 * (size_t)(s->nv > 0 ? s->nv : 1) * sizeof(double), out);
}

static double energy(const defsim__term *t, const defsim__system *s, defsim__work *wk,
                     const double *x, double e)
{
    (void)s;
    (void)wk;
    return e + defsim__contact_energy(contact(t), x);
}

static defsim_status forces(const defsim__term *t, const defsim__system *s, const defsim__eval *ev,
                            double *f, uint32_t *used)
{
    (void)s;
    (void)used;
    if (!(ev->which & (DEFSIM_FORCE_ELASTIC | DEFSIM_FORCE_DAMPING))) return DEFSIM_OK;
    /* PENALTY friction's blocks use the velocities of the latest damping evaluation */
    if ((ev->which & DEFSIM_FORCE_DAMPING) && ev->v) t->cache->epoch++;
    return defsim__contact_forces(contact(t), ev->x, ev->v, ev->which, f);
}

static defsim_status linearise(const defsim__term *t, const defsim__system *s, const double *x,
                               const defsim_matrix_coeffs *c, int mode)
{
    defsim__term_cache *ca = t->cache;
    if (mode != DEFSIM__LIN_VALUES && defsim__cache_hit(ca, s->nv, x, c)) return DEFSIM_OK;
    contact(t)->exact = s->exact_contact;
    ca->any = (c->k != 0.0 || c->kd != 0.0) &&
              defsim__contact_blocks(contact(t), x, c->k, c->kd, ca->buf);
    defsim__cache_store(ca, s->nv, x, c);
    return DEFSIM_OK;
}

/* The blocks linearise cached hold the coefficients already. */
static const double *diagonal(const defsim__term *t, const defsim_matrix_coeffs *c, double *f)
{
    (void)c;
    *f = 1.0;
    return t->cache->any ? t->cache->buf : NULL;
}

/* Only barrier steps filter their line search (the penalty's backends never ask). */
static double max_step(const defsim__term *t, const double *x, const double *dx)
{
    defsim__contact *c = contact(t);
    return c->mode == DEFSIM__CONTACT_BARRIER ? defsim__contact_max_step(c, x, dx, 0.2) : 1.0;
}

/* A vertex carried with a moving collider may be cut back across another by a later term: then
 * this runs again (DEFSIM__START_AGAIN). */
static int start(const defsim__term *t, double *x)
{
    defsim__contact *c = contact(t);
    if (c->mode != DEFSIM__CONTACT_BARRIER) return 0;
    const int r = defsim__contact_start(c, x);
    return (r & 2 ? DEFSIM__START_MOVED : 0) | (r & 1 ? DEFSIM__START_AGAIN : 0);
}

static void block(const defsim__term *t)
{
    defsim__contact *c = contact(t);
    if (c->mode == DEFSIM__CONTACT_BARRIER) defsim__contact_block(c, -1);
}

/* The factor on the penalty's frequency in the stable step: measured on boxes resting on and
 * dropped onto a plane (docs/stability.md "Contact"), the heating stays slow up to
 * h sqrt(omega_el^2 + (1.9..2.45 omega_c)^2) = 2; 2.5 leaves room for a host's 0.9. */
#define PENALTY_KINK 2.5

/* The penalty springs (diagonal, k_i = omega_c^2 m_i) raise the top of the spectrum by at most
 * omega_c^2 (Weyl), whether or not a contact is active at x. That bound is the linear one; the
 * penalty switches on and off at d = dhat, and an explicit step that lands past the switch gains
 * or loses energy: near the linear limit a body at rest on a collider heats up and blows up
 * within thousands of steps. The energy goes to the fastest modes, the springs' or the body's
 * own, so the term is PENALTY_KINK times the larger of omega_c and omega_el (docs/stability.md
 * "Contact"). */
static double lambda_bound(const defsim__term *t, const defsim__system *s, double lambda)
{
    (void)s;
    const defsim__contact *c = contact(t);
    if (c->mode != DEFSIM__CONTACT_PENALTY) return lambda;
    const double el = lambda > 0.0 ? lambda : 0.0;
    return el + PENALTY_KINK * PENALTY_KINK * fmax(c->khat, el);
}

static void rates(const defsim__term *t, const defsim__system *s, const double *x,
                  defsim__rates *r)
{
    if (x) r->alpha_add += defsim__contact_damping_rate(contact(t), x, s->gravity);
}

static void substep(const defsim__term *t, double s0, double s1, double h)
{
    defsim__contact_substep(contact(t), s0, s1, h);
    t->cache->epoch++;
}

static void step_end(const defsim__term *t) { t->cache->valid = t->cache->any = 0; }

/* The colliders' work over x0 -> x1 and their energy at x0 (the watchdog's work terms). */
static int work(const defsim__term *t, const double *x0, const double *x1, int start, double *e0,
                double *w)
{
    defsim__contact *ct = contact(t);
    if (ct->npair == 0) return 0;
    if (start) *e0 = defsim__contact_energy_start(ct, x0);
    *w = defsim__contact_work(ct, x0, x1);
    return 1;
}

/* A step's begin (h = 0: for the stable step's estimate or a replay): BARRIER for backends
 * whose line search uses contact_max_step, PENALTY for the others; the world's contact state is
 * attached to the system until the step ends. */
static defsim_status begin(defsim__system *s, const defsim__step_ctx *sc)
{
    s->contact = NULL;   /* left attached by a failed step: detached */
    defsim__collider_set *cs = sc->colliders;
    const double h = sc->h;
    /* The penalty is a force that jumps when a collider comes, goes or moves between steps:
     * backends that carry force evaluations from the last step (velocity_verlet's f(x_n),
     * ERK's first-same-as-last stage, IDA's history) start afresh, as after set_state. */
    const int penalty = !(sc->backend->flags & DEFSIM_BACKEND_CONTACT_CCD);
    int jumped = cs->changed;
    for (int32_t j = 0; j < cs->ncol && !jumped; ++j)
        jumped = (cs->col[j].generation & 1u) &&
                 (memcmp(cs->col[j].pos, cs->col[j].pos1, sizeof cs->col[j].pos) != 0 ||
                  memcmp(cs->col[j].rot, cs->col[j].rot1, sizeof cs->col[j].rot) != 0);
    if (h > 0.0 && jumped && penalty && sc->backend_ready && sc->backend->reset) {
        const defsim_status st = sc->backend->reset(sc->host, sc->handle, sc->backend_state);
        if (st != DEFSIM_OK) {
            defsim__error(sc->msg, "backend %s failed to reset for the colliders' change",
                          sc->backend->name);
            return st;
        }
    }
    if (h > 0.0) {
        /* The watchdog counts the energy of colliders that came until a step succeeds. */
        cs->came |= cs->changed;
        cs->changed = 0;
    }
    if (defsim__collider_set_live(cs) == 0) return DEFSIM_OK;
    const defsim__settings *set = sc->set;
    defsim__contact_params p = {
        .mode = penalty ? DEFSIM__CONTACT_PENALTY : DEFSIM__CONTACT_BARRIER,
        .dhat_rel = set->contact_dhat, .kappa = set->contact_kappa,
        .frequency = set->contact_frequency, .eps_v = set->friction_eps_v};
    defsim__contact *c = sc->contact;
    if (p.mode == DEFSIM__CONTACT_PENALTY && p.frequency == 0.0 && c->omega_elastic == 0.0) {
        double om = 0.0;   /* the bodies' own top frequency, without contact, once per plan */
        defsim_status st = defsim__omega_max(s, sc->work, sc->state->x, &om);
        if (st != DEFSIM_OK) {
            defsim__error(sc->msg, "contact: the elastic frequency is not finite");
            return st;
        }
        c->omega_elastic = om;
    }
    p.omega_elastic = c->omega_elastic;
    if (p.mode == DEFSIM__CONTACT_BARRIER && !c->surf_planned &&
        defsim__contact_surfaces(c, sc->bodies, sc->nbodies) != DEFSIM_OK) {
        defsim__error(sc->msg, "contact: out of memory for the bodies' surfaces");
        return DEFSIM_ERR_OUT_OF_MEMORY;
    }
    if (defsim__contact_offsets(c, sc->bodies, sc->nbodies, s->nv) != DEFSIM_OK) {
        defsim__error(sc->msg, "contact: out of memory for the thickness offsets");
        return DEFSIM_ERR_OUT_OF_MEMORY;
    }
    /* A step's start: the world's copies, which nothing changes until the step ends. */
    defsim_status st = defsim__contact_begin(c, s, cs->col, cs->ncol, &p,
                                             h > 0.0 ? sc->x0 : sc->state->x,
                                             h > 0.0 ? sc->v0 : sc->state->v, h, sc->msg);
    if (st != DEFSIM_OK) return st;
    s->contact = c;
    return DEFSIM_OK;
}

static void *attached(const defsim__system *s) { return s->contact; }
static void detach(defsim__system *s) { s->contact = NULL; }

/* Closes contact's part of a step: a callback's failure is the step's; after a success, the
 * contact forces for the host and the colliders' poses at the end of the step. */
static defsim_status end(defsim__system *s, const defsim__step_ctx *sc, void *was,
                         defsim_status st)
{
    defsim__collider_set *cs = sc->colliders;
    defsim__contact *c = was;
    const int32_t nv = s->nv;
    if (!c) {   /* no collider: the read-back is zero (dropped once after the last one went) */
        if (st == DEFSIM_OK && sc->contact->readback_set) {
            free(cs->force);
            cs->force = NULL;
            cs->force_nv = 0;
            sc->contact->readback_set = 0;
        }
        return st;
    }
    if (st == DEFSIM_OK && (!cs->force || cs->force_nv != nv)) {
        if (defsim__collider_set_readback(cs, nv, sc->msg) != DEFSIM_OK)
            return DEFSIM_ERR_OUT_OF_MEMORY;
        cs->force_zero = 1;
    }
    /* The read-back goes to scratch first: a callback failing there fails the step too, and
     * a failed step changes neither the read-back nor the poses. Without pairs (colliders far
     * away) the forces are zero: nothing to compute or copy when the read-back is zero already. */
    const double *x = sc->state->x;
    const int none = st == DEFSIM_OK && cs->force_zero && defsim__contact_none(c, x);
    if (st == DEFSIM_OK && !c->failed && none) {
        c->stat[DEFSIM__CSTAT_ACTIVE] = 0;
        c->stat[DEFSIM__CSTAT_MIN_DISTANCE] = INFINITY;
    } else if (st == DEFSIM_OK && !c->failed) {
        defsim__contact_end(c, x, sc->state->v, c->blk);
    }
    if (c->failed) {
        defsim__error(sc->msg, "contact: %s; state restored", defsim__contact_failure(c));
        return c->failed;
    }
    if (st != DEFSIM_OK && c->blocked) {
        char who[48] = "a surface";
        if (c->blocked_vertex >= 0) snprintf(who, sizeof who, "vertex %d", (int)c->blocked_vertex);
        defsim__error(sc->msg, "contact: no Newton start keeps %s clear of the moving colliders "
                      "in this step (squeezed between colliders that move differently, swept by "
                      "one, or cut back by body contact); state restored", who);
    }
    if (st != DEFSIM_OK) return st;
    if (c->mode == DEFSIM__CONTACT_BARRIER && sc->set->watchdog &&
        !(c->stat[DEFSIM__CSTAT_MIN_DISTANCE] > 0.0)) {
        /* The watchdog's contact check: the barrier is infinite at zero distance and the line
         * search keeps every vertex out, so a vertex at d <= 0 means that guarantee broke. */
        (*sc->watchdog_trips)++;
        defsim__error(sc->msg, "step: watchdog: a vertex crossed a collider's surface (distance "
                      "%g m) although the contact barrier forbids it; state restored. This is a "
                      "defect: please report it with the scene",
                      c->stat[DEFSIM__CSTAT_MIN_DISTANCE]);
        return DEFSIM_ERR_UNSTABLE;
    }
    if (!none) memcpy(cs->force, c->blk, 3 * (size_t)nv * sizeof *cs->force);
    cs->force_zero = c->npair == 0;
    c->readback_set = 1;
    for (int32_t j = 0; j < cs->ncol; ++j) {
        memcpy(cs->col[j].pos, cs->col[j].pos1, sizeof cs->col[j].pos);
        memcpy(cs->col[j].rot, cs->col[j].rot1, sizeof cs->col[j].rot);
    }
    return DEFSIM_OK;
}

/* Reverse mode (docs/gradients.md): the barrier and the lagged friction (contact.c), the
 * friction's x_n-derivatives into g->xn, the masses', the colliders' mu and poses into g. */
static defsim_status vjp(const defsim__term *t, const defsim__system *s, const defsim__eval *ev,
                         const double *w, double *gx, double *gv, defsim__grad *g)
{
    (void)s;
    (void)gv;
    if (!(ev->which & DEFSIM_FORCE_ELASTIC)) return DEFSIM_OK;
    return defsim__contact_vjp(contact(t), ev->x, w, gx, g ? g->xn : NULL, g ? g->mass : NULL,
                               g ? g->mu_col : NULL, g ? g->pose_col : NULL);
}

static const char *const COUNTERS[] = {"collider.linearisations"};

static double counter(const defsim__term *t, int32_t i)
{
    (void)i;
    return (double)t->cache->linearisations;
}

/* The contact model's parameters ("core.<name>"), which body contact shares (contact.h). */
static const defsim_option_spec OPTIONS[] = {
    {"contact_dhat", DEFSIM_OPTION_REAL, 1e-3, DBL_MIN, 0.1, NULL,
     "contact activation distance dhat relative to the length scale (diagonal of the rest "
     "bounding box), in (0, 0.1]"},
    {"contact_kappa", DEFSIM_OPTION_REAL, 0.0, 0.0, 1e20, NULL,
     "barrier stiffness per unit vertex mass (1/s^2); 0: automatic, |g| / dhat + 1 / h^2"},
    {"contact_frequency", DEFSIM_OPTION_REAL, 0.0, 0.0, 1e12, NULL,
     "penalty contact frequency omega_c (rad/s; stiffness m_i omega_c^2); 0: automatic, the "
     "bodies' highest elastic frequency, at least sqrt(2 |g| / dhat)"},
    {"friction_eps_v", DEFSIM_OPTION_REAL, 1e-3, DBL_MIN, 1e3, NULL,
     "friction's stick-slip threshold (m/s): below it friction is a smooth viscous law"},
};

/* The chunk: what carries from one step to the next (the pairs do not: each step's begin finds
 * them again). The penalty's automatic frequency, computed by power iteration at the first
 * step after a plan and kept for the plan (a loaded world would compute it at another state:
 * another stiffness); the safe box, kept while no collider comes near it; PENALTY friction's
 * velocities of the latest damping evaluation with pairs, which sundials_kinsol's damping
 * matrix B(x_n) takes from the end of the step before (a loaded world would have zeros).
 * Little-endian as the rest of a checkpoint: f64 frequency, i32 safe_set, f64 safe box (lo,
 * hi), i32 vertices of the velocities that follow (0: none), their 3 nv f64. Nothing to carry
 * (no frequency, box or velocities): 0 bytes. */
enum { HEAD_BYTES = 8 + 4 + 48 + 4 };

static size_t save(const defsim__term *t, unsigned char *buf, size_t cap)
{
    const defsim__contact *c = contact(t);
    const defsim__system *s = t->model;
    const double *vel = defsim__contact_vel(c, s->nv);
    const int32_t nvel = vel ? s->nv : 0;
    if (c->omega_elastic == 0.0 && !c->safe_set && !vel) return 0;
    const size_t need = HEAD_BYTES + 24 * (size_t)nvel;
    if (!buf || cap < need) return need;
    defsim__bw b = {buf, 0, need, 0};   /* within cap: never grows */
    defsim__put_f64(&b, c->omega_elastic);
    defsim__put_i32(&b, c->safe_set != 0);
    defsim__put_f64s(&b, c->safe_lo, 3);
    defsim__put_f64s(&b, c->safe_hi, 3);
    defsim__put_i32(&b, nvel);
    defsim__put_f64s(&b, vel, 3 * (int64_t)nvel);
    return need;
}

static defsim_status load(const defsim__term *t, const unsigned char *buf, size_t size)
{
    defsim__contact *c = contact(t);
    const defsim__system *s = t->model;
    if (size == 0) {   /* nothing carried */
        c->omega_elastic = 0.0;
        c->safe_set = 0;
        t->cache->valid = 0;
        return DEFSIM_OK;
    }
    if (!buf) return DEFSIM_ERR_INVALID_ARGUMENT;
    defsim__br r = {buf, size, 0, 0};
    const double omega = defsim__get_f64(&r);
    const int32_t safe = defsim__get_i32(&r);
    double box[6];
    defsim__get_f64s(&r, box, 6);
    const int32_t nvel = defsim__get_i32(&r);
    int finite = 1;
    for (int k = 0; k < 6; ++k) finite &= isfinite(box[k]) != 0;
    if (r.bad || !(omega >= 0.0) || !isfinite(omega) || (safe != 0 && safe != 1) || !finite ||
        (nvel != 0 && nvel != s->nv) || size != HEAD_BYTES + 24 * (size_t)nvel)
        return DEFSIM_ERR_INVALID_ARGUMENT;
    double *vel = NULL;
    if (nvel > 0) {
        vel = malloc(24 * (size_t)nvel);
        if (!vel) return DEFSIM_ERR_OUT_OF_MEMORY;
        defsim__get_f64s(&r, vel, 3 * (int64_t)nvel);
        for (int64_t i = 0; i < 3 * (int64_t)nvel; ++i) finite &= isfinite(vel[i]) != 0;
        const defsim_status st = finite ? defsim__contact_set_vel(c, nvel, vel)
                                        : DEFSIM_ERR_INVALID_ARGUMENT;
        free(vel);
        if (st != DEFSIM_OK) return st;
    }
    c->omega_elastic = omega;
    c->safe_set = safe;
    memcpy(c->safe_lo, box, sizeof c->safe_lo);
    memcpy(c->safe_hi, box + 3, sizeof c->safe_hi);
    t->cache->valid = 0;
    return DEFSIM_OK;
}

const defsim__term_ops defsim__term_collider = {
    .name = "collider", .flags = DEFSIM__TERM_BOUNDED, .energy_rank = 4, .matrix_rank = 4,
    DEFSIM__TERM_FORCES, .linearise = linearise, DEFSIM__TERM_DIAGONAL,
    .max_step = max_step, .start = start, .block = block,
    .lambda_bound = lambda_bound, .rates = rates,
    .substep = substep, .step_end = step_end, .work = work,
    .begin = begin, .attached = attached, .detach = detach, .end = end,
    .counters = COUNTERS, .counter_count = 1, .counter = counter,
    .options = OPTIONS, .option_count = (int32_t)(sizeof OPTIONS / sizeof OPTIONS[0]),
    .save = save, .load = load, .vjp = vjp};
