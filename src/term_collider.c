/* SPDX-License-Identifier: MIT */
/*
 * Contact with the world's colliders (contact.c does the geometry; docs/contact.md): in the list
 * while the world has attached its contact state for a step. Its matrix blocks touch only each
 * vertex's own 3x3 block; linearise evaluates them once per x (and coefficients, substep and
 * friction velocities) into the kind's cache, which values and products read, so a product
 * never queries a collider.
 */
#include "assembly.h"
#include "contact.h"
#include "system.h"
#include "term_cache.h"

#include <float.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

static defsim__contact *contact(const defsim__term *t) { return t->data; }

static int compile(defsim__system *s, defsim__term *out)
{
    if (!s->contact) return 0;
    defsim__term_cache *c = &s->cache[DEFSIM__TERM_KIND_collider];
    if (!defsim__cache_reserve(c, 9 * (size_t)(s->nv > 0 ? s->nv : 1) * sizeof(double), s->nv))
        return -1;
    memset(out, 0, sizeof *out);
    out->model = s;
    out->data = s->contact;
    return 1;
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
    ca->any = (c->k != 0.0 || c->kd != 0.0) &&
              defsim__contact_blocks(contact(t), x, c->k, c->kd, ca->buf);
    defsim__cache_store(ca, s->nv, x, c);
    return DEFSIM_OK;
}

static void values(const defsim__term *t, const defsim__system *s, const double *x,
                   const defsim_matrix_coeffs *c, int upper, const int64_t *cp, double *val,
                   uint32_t *passes)
{
    (void)x;
    (void)c;
    (void)passes;
    if (t->cache->any) defsim__add_diagonal(s, t->cache->buf, 1.0, upper, cp, val);
}

static void apply(const defsim__term *t, const defsim__system *s, const double *x,
                  const defsim_matrix_coeffs *c, int proj, const double *dx, double *out)
{
    (void)x;
    (void)c;
    (void)proj;
    if (t->cache->any) defsim__apply_diagonal(s, t->cache->buf, 1.0, dx, out);
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

/* The chunk: the frequency cached per plan, the safe box, PENALTY friction's velocities (what
 * the checkpoint's CNTC chunk keeps of them: the next step's first matrix may read them), and the
 * step's candidate pairs with their lagged friction. */
typedef struct chunk_head {
    double omega_elastic;
    double safe_lo[3], safe_hi[3];
    int32_t safe_set, npair;
    int32_t nvel, pad;        /* vertices of the velocities that follow (0: none) */
} chunk_head;

enum { PAIR_BYTES = 2 * sizeof(int32_t) + 7 * sizeof(double) + 1 };

static size_t save(const defsim__term *t, unsigned char *buf, size_t cap)
{
    const defsim__contact *c = contact(t);
    const double *vel = defsim__contact_vel(c, c->nv);
    const int32_t nvel = vel ? c->nv : 0;
    const size_t need =
        sizeof(chunk_head) + 3 * (size_t)nvel * sizeof(double) + (size_t)c->npair * PAIR_BYTES;
    if (!buf || cap < need) return need;
    chunk_head h;
    memset(&h, 0, sizeof h);
    h.omega_elastic = c->omega_elastic;
    memcpy(h.safe_lo, c->safe_lo, sizeof h.safe_lo);
    memcpy(h.safe_hi, c->safe_hi, sizeof h.safe_hi);
    h.safe_set = c->safe_set;
    h.npair = c->npair;
    h.nvel = nvel;
    memcpy(buf, &h, sizeof h);
    unsigned char *p = buf + sizeof h;
    put(&p, vel, 3 * (size_t)nvel * sizeof *vel);
    const size_t n = (size_t)c->npair;
    put(&p, c->pv, n * sizeof *c->pv);
    put(&p, c->pc, n * sizeof *c->pc);
    put(&p, c->lam, n * sizeof *c->lam);
    put(&p, c->nrm, 3 * n * sizeof *c->nrm);
    put(&p, c->uc, 3 * n * sizeof *c->uc);
    put(&p, c->off, n);
    return need;
}

static defsim_status load(const defsim__term *t, const unsigned char *buf, size_t size)
{
    defsim__contact *c = contact(t);
    chunk_head h;
    if (!buf || size < sizeof h) return DEFSIM_ERR_INVALID_ARGUMENT;
    memcpy(&h, buf, sizeof h);
    const size_t vbytes = 3 * (size_t)(h.nvel > 0 ? h.nvel : 0) * sizeof(double);
    if (h.npair < 0 || (h.nvel != 0 && h.nvel != c->nv) ||
        size != sizeof h + vbytes + (size_t)h.npair * PAIR_BYTES)
        return DEFSIM_ERR_INVALID_ARGUMENT;
    const unsigned char *pairs = buf + sizeof h + vbytes;
    for (int32_t i = 0; i < h.npair; ++i) {
        int32_t v, j;
        memcpy(&v, pairs + i * sizeof v, sizeof v);
        memcpy(&j, pairs + (size_t)h.npair * sizeof v + i * sizeof j, sizeof j);
        if (v < 0 || v >= c->nv || j < 0 || j >= c->ncol) return DEFSIM_ERR_INVALID_ARGUMENT;
    }
    if (h.npair > c->cap_pair) {
        const size_t n = (size_t)h.npair;
        int32_t *pv = realloc(c->pv, n * sizeof *pv);
        if (pv) c->pv = pv;
        int32_t *pc = realloc(c->pc, n * sizeof *pc);
        if (pc) c->pc = pc;
        double *lam = realloc(c->lam, n * sizeof *lam);
        if (lam) c->lam = lam;
        double *nrm = realloc(c->nrm, 3 * n * sizeof *nrm);
        if (nrm) c->nrm = nrm;
        double *uc = realloc(c->uc, 3 * n * sizeof *uc);
        if (uc) c->uc = uc;
        uint8_t *off = realloc(c->off, n);
        if (off) c->off = off;
        if (!pv || !pc || !lam || !nrm || !uc || !off) return DEFSIM_ERR_OUT_OF_MEMORY;
        c->cap_pair = h.npair;
    }
    /* the velocities start 8-byte aligned (after the head) in a buffer from malloc */
    if (h.nvel > 0 &&
        defsim__contact_set_vel(c, h.nvel, (const double *)(const void *)(buf + sizeof h)) !=
            DEFSIM_OK)
        return DEFSIM_ERR_OUT_OF_MEMORY;
    c->omega_elastic = h.omega_elastic;
    memcpy(c->safe_lo, h.safe_lo, sizeof h.safe_lo);
    memcpy(c->safe_hi, h.safe_hi, sizeof h.safe_hi);
    c->safe_set = h.safe_set;
    c->npair = h.npair;
    const unsigned char *p = pairs;
    const size_t n = (size_t)c->npair;
    get(c->pv, &p, n * sizeof *c->pv);
    get(c->pc, &p, n * sizeof *c->pc);
    get(c->lam, &p, n * sizeof *c->lam);
    get(c->nrm, &p, 3 * n * sizeof *c->nrm);
    get(c->uc, &p, 3 * n * sizeof *c->uc);
    get(c->off, &p, n);
    t->cache->valid = 0;
    return DEFSIM_OK;
}

const defsim__term_ops defsim__term_collider = {
    .name = "collider",
    .flags = DEFSIM__TERM_BOUNDED,
    .energy_rank = 4,
    .matrix_rank = 4,
    .compile = compile,
    .energy = energy,
    .forces = forces,
    .linearise = linearise,
    .values = values,
    .apply = apply,
    .max_step = max_step,
    .start = start,
    .block = block,
    .lambda_bound = lambda_bound,
    .rates = rates,
    .substep = substep,
    .step_end = step_end,
    .counters = COUNTERS,
    .counter_count = 1,
    .counter = counter,
    .options = OPTIONS,
    .option_count = (int32_t)(sizeof OPTIONS / sizeof OPTIONS[0]),
    .save = save,
    .load = load,
};
