/* SPDX-License-Identifier: MIT */
/*
 * Body-body and self-contact (body_contact.c does the geometry; docs/body-contact.md): in the
 * list while the world has attached its body contact for a step. linearise evaluates every
 * contact Hessian of the constraint set at x once (barriers, then lagged friction) into the
 * kind's cache; values scatter and products multiply what it cached, so a product neither
 * touches the surfaces nor regrows the candidates. The vertex pairs that contacts couple but the
 * pattern lacks are merged when the host asks (pattern_update).
 */
#include "adjoint.h"
#include "assembly.h"
#include "body_contact.h"
#include "collider.h"
#include "contact.h"
#include "host.h"
#include "options.h"
#include "system.h"
#include "term_cache.h"

#include <stdlib.h>
#include <string.h>

/* A cached contact Hessian: 3n x 3n over the vertices idx (-1: unused). */
typedef struct entry {
    int32_t idx[4];
    int32_t n;
    double H[144];
} entry;

static defsim__body_contact *bcon(const defsim__term *t) { return t->data; }

static int compile(defsim__system *s, defsim__term *out)
{
    return defsim__term_contact(s, s->nv, s->body_contact,
                                &s->cache[DEFSIM__TERM_KIND_body_contact], sizeof(entry), out);
}

static double energy(const defsim__term *t, const defsim__system *s, defsim__work *wk,
                     const double *x, double e)
{
    (void)s;
    (void)wk;
    return e + defsim__body_contact_energy(bcon(t), x);
}

static defsim_status forces(const defsim__term *t, const defsim__system *s, const defsim__eval *ev,
                            double *f, uint32_t *used)
{
    (void)s;
    (void)used;
    if (!(ev->which & DEFSIM_FORCE_ELASTIC)) return DEFSIM_OK;
    return defsim__body_contact_forces(bcon(t), ev->x, f);
}

typedef struct collect {
    defsim__term_cache *c;
    defsim__body_contact *bc;
} collect;

static void collect_fn(void *ctx, const int32_t *idx, int n, const double *H)
{
    collect *k = ctx;
    defsim__term_cache *c = k->c;
    if (k->bc->failed) return;
    /* grow geometrically: pairs arrive one by one */
    const size_t need = ((size_t)c->count + 1) * sizeof(entry);
    if (need > c->cap && !defsim__cache_reserve(c, need > 2 * c->cap ? need : 2 * c->cap, 0)) {
        k->bc->failed = DEFSIM_ERR_OUT_OF_MEMORY;
        return;
    }
    entry *e = (entry *)c->buf + c->count++;
    for (int i = 0; i < 4; ++i) e->idx[i] = i < n ? idx[i] : -1;
    e->n = n;
    memcpy(e->H, H, 9 * (size_t)n * n * sizeof *H);
}

/* The Hessians do not depend on k (values and products scale them), so the key holds none. */
static const defsim_matrix_coeffs unit = {0.0, 0.0, 0.0, 0.0};

static defsim_status linearise(const defsim__term *t, const defsim__system *s, const double *x,
                               const defsim_matrix_coeffs *c, int mode)
{
    if (c->k == 0.0) return DEFSIM_OK;
    defsim__term_cache *ca = t->cache;
    if (mode != DEFSIM__LIN_VALUES && defsim__cache_hit(ca, s->nv, x, &unit)) return DEFSIM_OK;
    defsim__body_contact *bc = bcon(t);
    bc->exact = s->exact_contact;
    ca->valid = 0;
    ca->count = 0;
    collect k = {ca, bc};
    defsim__body_contact_hessians(bc, x, collect_fn, &k);
    if (bc->failed) return bc->failed;
    defsim__cache_store(ca, s->nv, x, &unit);
    ca->any = ca->count > 0;
    return DEFSIM_OK;
}

static void values(const defsim__term *t, const defsim__system *s, const double *x,
                   const defsim_matrix_coeffs *c, int upper, const int64_t *cp, double *val,
                   uint32_t *passes)
{
    (void)x;
    (void)passes;
    if (c->k == 0.0 || !t->cache->valid) return;
    const entry *e = t->cache->buf;
    for (int64_t i = 0; i < t->cache->count; ++i)
        defsim__body_contact_scatter(bcon(t), s, e[i].idx, e[i].n, e[i].H, c->k, upper, cp, val);
}

/* out += k H dx over each pair's free vertices. */
static void apply(const defsim__term *t, const defsim__system *s, const double *x,
                  const defsim_matrix_coeffs *c, int proj, const double *dx, double *out)
{
    (void)x;
    (void)proj;
    if (c->k == 0.0 || !t->cache->valid) return;
    const uint8_t *pinned = s->pinned;
    const entry *en = t->cache->buf;
    for (int64_t q = 0; q < t->cache->count; ++q) {
        const int32_t *idx = en[q].idx;
        const int n = en[q].n, nd = 3 * n;
        const double *H = en[q].H;
        double u[12];
        for (int i = 0; i < n; ++i)
            for (int k = 0; k < 3; ++k)
                u[3 * i + k] = idx[i] >= 0 && !pinned[idx[i]] ? dx[3 * (int64_t)idx[i] + k] : 0.0;
        for (int i = 0; i < n; ++i) {
            if (idx[i] < 0 || pinned[idx[i]]) continue;
            for (int k = 0; k < 3; ++k) {
                double sum = 0.0;
                for (int j = 0; j < nd; ++j) sum += H[(3 * i + k) * nd + j] * u[j];
                out[3 * (int64_t)idx[i] + k] += c->k * sum;
            }
        }
    }
}

static defsim_status pattern_update(const defsim__term *t, defsim__system *s, int *grew)
{
    defsim__body_contact *bc = bcon(t);
    *grew = 0;
    if (bc->npend == 0) return DEFSIM_OK;
    const defsim_status st = defsim__pattern_grow(s, bc->pend, bc->npend, grew);
    bc->npend = 0;
    if (*grew) bc->stat[DEFSIM__CSTAT_PATTERN_GROWTHS] += 1.0;
    return st;
}

static double max_step(const defsim__term *t, const double *x, const double *dx)
{
    return defsim__body_contact_max_step(bcon(t), x, dx);
}

static int start(const defsim__term *t, double *x)
{
    return defsim__body_contact_start(bcon(t), x) ? DEFSIM__START_MOVED : 0;
}

static void step_end(const defsim__term *t) { t->cache->valid = t->cache->any = 0; }

/* Reverse mode (docs/gradients.md): the barriers and the lagged friction (body_contact.c). */
static defsim_status vjp(const defsim__term *t, const defsim__system *s, const defsim__eval *ev,
                         const double *w, double *gx, double *gv, defsim__grad *g)
{
    (void)s;
    (void)gv;
    if (!(ev->which & DEFSIM_FORCE_ELASTIC)) return DEFSIM_OK;
    return defsim__body_contact_vjp(bcon(t), ev->x, w, gx, g ? g->xn : NULL, g ? g->mass : NULL,
                                    g ? g->mu_body : NULL);
}

static const char *const COUNTERS[] = {"body_contact.linearisations", "body_contact.cached_pairs"};

static double counter(const defsim__term *t, int32_t i)
{
    return (double)(i == 0 ? t->cache->linearisations : t->cache->count);
}

static const defsim_option_spec OPTIONS[] = {
    {"body_contact", DEFSIM_OPTION_BOOL, 0.0, 0.0, 1.0, NULL,
     "body-body and self-contact (barrier, CCD, lagged friction; docs/body-contact.md) on "
     "backends with contact CCD (newton_cholmod, newmark, bdf2); other backends refuse to step"},
};

/* memcpy that allows empty arrays (NULL before any pair): advances the cursor. */
static void put(unsigned char **p, const void *src, size_t n)
{
    if (n) memcpy(*p, src, n);
    *p += n;
}

static void get(void *dst, const unsigned char **p, size_t n)
{
    if (n) memcpy(dst, *p, n);
    *p += n;
}

/* The chunk: the step's candidate pairs (kind, a, b) and its lagged friction pairs. */
static size_t save(const defsim__term *t, unsigned char *buf, size_t cap)
{
    const defsim__body_contact *bc = bcon(t);
    const size_t np = (size_t)bc->npair, nf = (size_t)bc->nfric;
    const size_t need = 2 * sizeof(int32_t) + np * (1 + 2 * sizeof(int32_t)) +
                        nf * sizeof(defsim__bc_friction);
    if (!buf || cap < need) return need;
    unsigned char *p = buf;
    put(&p, &bc->npair, sizeof bc->npair);
    put(&p, &bc->nfric, sizeof bc->nfric);
    put(&p, bc->kind, np);
    put(&p, bc->pa, np * sizeof *bc->pa);
    put(&p, bc->pb, np * sizeof *bc->pb);
    put(&p, bc->fric, nf * sizeof *bc->fric);
    return need;
}

static defsim_status load(const defsim__term *t, const unsigned char *buf, size_t size)
{
    defsim__body_contact *bc = bcon(t);
    int32_t np, nf;
    if (!buf || size < 2 * sizeof(int32_t)) return DEFSIM_ERR_INVALID_ARGUMENT;
    memcpy(&np, buf, sizeof np);
    memcpy(&nf, buf + sizeof np, sizeof nf);
    if (np < 0 || nf < 0 ||
        size != 2 * sizeof(int32_t) + (size_t)np * (1 + 2 * sizeof(int32_t)) +
                    (size_t)nf * sizeof(defsim__bc_friction))
        return DEFSIM_ERR_INVALID_ARGUMENT;
    const unsigned char *p = buf + 2 * sizeof(int32_t);
    for (int32_t q = 0; q < np; ++q) {
        int32_t a, b;
        memcpy(&a, p + np + q * sizeof a, sizeof a);
        memcpy(&b, p + np + (size_t)np * sizeof a + q * sizeof b, sizeof b);
        const uint8_t k = p[q];
        const int32_t na = k == DEFSIM__BC_EE ? bc->nedge : bc->nvert;
        const int32_t nb = k == DEFSIM__BC_PT ? bc->nface : bc->nedge;
        if (k > DEFSIM__BC_PE || a < 0 || a >= na || b < 0 || b >= nb)
            return DEFSIM_ERR_INVALID_ARGUMENT;
    }
    if (np > bc->cap_pair) {
        uint8_t *kind = realloc(bc->kind, (size_t)np);
        if (kind) bc->kind = kind;
        int32_t *pa = realloc(bc->pa, (size_t)np * sizeof *pa);
        if (pa) bc->pa = pa;
        int32_t *pb = realloc(bc->pb, (size_t)np * sizeof *pb);
        if (pb) bc->pb = pb;
        if (!kind || !pa || !pb) return DEFSIM_ERR_OUT_OF_MEMORY;
        bc->cap_pair = np;
    }
    if (nf > bc->cap_fric) {
        defsim__bc_friction *fr = realloc(bc->fric, (size_t)nf * sizeof *fr);
        if (!fr) return DEFSIM_ERR_OUT_OF_MEMORY;
        bc->fric = fr;
        bc->cap_fric = nf;
    }
    bc->npair = np;
    bc->nfric = nf;
    get(bc->kind, &p, (size_t)np);
    get(bc->pa, &p, (size_t)np * sizeof *bc->pa);
    get(bc->pb, &p, (size_t)np * sizeof *bc->pb);
    get(bc->fric, &p, (size_t)nf * sizeof *bc->fric);
    /* the candidates' boxes are not saved: the next evaluation finds them again */
    bc->have_pairs = 0;
    bc->con_valid = 0;
    t->cache->valid = 0;
    return DEFSIM_OK;
}

/* A step's begin while the option is on (the step refused backends without contact CCD
 * already); h = 0 (no step) begins nothing. */
static defsim_status begin(defsim__system *s, const defsim__step_ctx *sc)
{
    if (!(sc->h > 0.0)) return DEFSIM_OK;
    s->body_contact = NULL;   /* left attached by a failed step: detached */
    const defsim__settings *set = sc->set;
    if (!set->body_contact) {
        *sc->body_contact_last = 0;
        return DEFSIM_OK;
    }
    if (!*sc->body_contact_last) sc->body_contact->fresh = 1;
    *sc->body_contact_last = 1;
    const defsim_status st = defsim__body_contact_begin(
        sc->body_contact, s, sc->bodies, sc->nbodies, set->contact_dhat, set->contact_kappa,
        set->friction_eps_v, sc->x0, sc->state->v, sc->h, sc->contact->stat, sc->msg);
    if (st != DEFSIM_OK) return st;
    s->body_contact = sc->body_contact;
    return DEFSIM_OK;
}

static void *attached(const defsim__system *s) { return s->body_contact; }
static void detach(defsim__system *s) { s->body_contact = NULL; }

/* Closes body contact's part of a step: the forces of the end state (into its scratch, for the
 * read-back) and the statistics; the watchdog's check that no pair reached distance 0. */
static defsim_status end(defsim__system *s, const defsim__step_ctx *sc, void *was,
                         defsim_status st)
{
    defsim__body_contact *bc = was;
    if (!bc || st != DEFSIM_OK) return st;
    if (bc->failed) {
        defsim__error(sc->msg, "out of memory for body contact pairs; state restored");
        return bc->failed;
    }
    const double dmin = defsim__body_contact_end(bc, s, sc->state->x, bc->scratch);
    if (bc->failed) {
        defsim__error(sc->msg, "out of memory rebuilding the matrix pattern; state restored");
        return bc->failed;
    }
    if (sc->set->watchdog && !(dmin > 0.0)) {
        (*sc->watchdog_trips)++;
        defsim__error(sc->msg, "step: watchdog: two body surfaces touched (distance %g m) "
                      "although the contact barrier forbids it; state restored. This is a "
                      "defect: please report it with the scene", dmin);
        return DEFSIM_ERR_UNSTABLE;
    }
    return DEFSIM_OK;
}

/* Adds body contact's forces of a successful step to the read-back, after the colliders' (which
 * wrote it this step when they set readback_set; else it starts from zero). */
static defsim_status readback(defsim__system *s, const defsim__step_ctx *sc, void *was,
                              defsim_status st)
{
    defsim__collider_set *cs = sc->colliders;
    const int32_t nv = s->nv;
    if (st != DEFSIM_OK || !was) return st;
    if (!cs->force || cs->force_nv != nv) {
        if (defsim__collider_set_readback(cs, nv, sc->msg) != DEFSIM_OK)
            return DEFSIM_ERR_OUT_OF_MEMORY;
    } else if (!sc->contact->readback_set) {
        memset(cs->force, 0, 3 * (size_t)nv * sizeof *cs->force);
    }
    const double *f = ((defsim__body_contact *)was)->scratch;
    for (int64_t i = 0; i < 3 * (int64_t)nv; ++i) cs->force[i] += f[i];
    cs->force_zero = 0;
    sc->contact->readback_set = 1;
    return DEFSIM_OK;
}

const defsim__term_ops defsim__term_body_contact = {
    .name = "body_contact",
    .energy_rank = 5,
    .matrix_rank = 5,
    .compile = compile,
    .energy = energy,
    .forces = forces,
    .pattern_update = pattern_update,
    .linearise = linearise,
    .values = values,
    .apply = apply,
    .max_step = max_step,
    .start = start,
    .step_end = step_end,
    .begin = begin,
    .attached = attached,
    .detach = detach,
    .end = end,
    .readback = readback,
    .vjp = vjp,
    .counters = COUNTERS,
    .counter_count = 2,
    .counter = counter,
    .options = OPTIONS,
    .option_count = 1,
    .save = save,
    .load = load,
};
