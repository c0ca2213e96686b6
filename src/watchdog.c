/* SPDX-License-Identifier: MIT */
/*
 * The stability watchdog: the envelope a successful step must stay in, and the diagnostics.
 *
 * The energy bound. Let E = K + U (kinetic over free vertices, elastic relative to rest with the
 * attachment springs). Between a reference and now, the true motion satisfies
 * E(now) = E(ref) + W - D, with W the work of gravity, held external forces and moved attachment
 * targets (all known: the forces are constant within a step, so W = sum (m g + f_ext) . dx), and
 * D >= 0 what damping took out. Every elastic energy here is >= 0 (stable neo-Hookean up to a
 * small negative part far from rest, which the floor covers), so K(now) <= E(ref) + W. Only K
 * and W are needed per step: both come from one pass over the vertices that also checks
 * finiteness and body extents, and the elastic energy is evaluated once per reference, not per
 * step. A step trips when K > growth (E(ref) + W) + floor. K alone lags by a step where an
 * instability shows first in the elastic energy (a stiff body stepped far beyond its limit
 * stores 1e4 times the scene's energy while K is still small); so the full E = K + U is
 * checked against the same limit (one energy evaluation, about the cost of a step of an
 * explicit backend) in the steps where garbage can hide from K: the first step after a
 * reference, a step in which K more than doubled (and exceeds a thousandth of the floor), a
 * step that deformed some element by more than MOVE_FRACTION of the smallest element size, and
 * every ENERGY_EVERY-th step. Deformed: an edge of a tet from its fourth vertex, a spring, or an
 * attachment's spring changed by more than that (the displacements of its ends differ by more;
 * the other tet edges then by at most twice that).
 * U changes only through those, so moving a body as a whole (falling, swinging, thrown) checks
 * nothing more; a stable explicit run changes them by a small fraction of an element per step
 * (its CFL condition), so it pays the evaluation in a few steps only. (Until this was measured
 * on the cantilever at h = 2.8 ms, the trigger was any vertex moving that far: every step of
 * the sagging beam paid an energy evaluation, twice the cost of its explicit step.)
 *
 * Inversion of a neo-Hookean element (J = det F <= 0, where its energy is undefined) is checked
 * by a pass over those elements in the same steps, and in every step while the smallest J seen
 * is below JMIN_WATCH. Between, no column of a tet's Ds = [x0 - x3, x1 - x3, x2 - x3] changed by
 * more than MOVE_FRACTION of the smallest element size, which changes J of a tet of ordinary
 * shape by a few hundredths (3 columns x 1 % x a cofactor near 1 for F near I; the former
 * bound of each vertex moving 1 %, 0.12, still holds with room): from J >= JMIN_WATCH = 0.5 no
 * step of that kind reaches J <= 0. (The pass alone costs about
 * a fifth of an explicit step over the same elements.) The growth factor covers the bounded
 * energy error of a stable explicit method (symplectic Euler at 0.9 of its limit swings its
 * kinetic energy up to 1 / (1 - 0.81) ~ 5 times the true energy); an unstable one grows
 * geometrically and passes any factor within a few steps.
 *
 * The work of the host's other terms joins W in the steps that have them (world.c gathers what
 * they need; docs/watchdog.md "Work done on the system"): the force callback's, from the forces
 * the backend's own evaluations recorded (no extra call of the callback); the driven pins', from
 * the elastic and damping forces at the pinned vertices at both ends of the step; the colliders'
 * motion against the contact forces; and the contact energy of colliders that came, as work
 * put in by the host. Each is the larger of its values with the forces at either end (the
 * midpoint rule plus half the spread), an upper bound of the work along the step whenever the
 * force varies monotonically over it. So the check stays on in every step: a kinetic energy
 * beyond growth x (E(ref) + W) + floor, or one that overflows, fails the step, and no free
 * vertex leaves a step faster than sqrt(2 (growth (E(ref) + W) + floor) / m_i).
 */
#include "watchdog.h"

#include "energy.h"
#include "element.h"
#include "forces.h"
#include "material.h"
#include "terms.h"
#include "tet10.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

enum { ENERGY_EVERY = 256 };
static const double MOVE_FRACTION = 0.01, JMIN_WATCH = 0.5;

static double det3(const double *x, const int32_t *id)
{
    const double *p3 = x + 3 * (int64_t)id[3];
    double a[3], b[3], c[3];
    for (int i = 0; i < 3; ++i) {
        a[i] = x[3 * (int64_t)id[0] + i] - p3[i];
        b[i] = x[3 * (int64_t)id[1] + i] - p3[i];
        c[i] = x[3 * (int64_t)id[2] + i] - p3[i];
    }
    return a[0] * (b[1] * c[2] - b[2] * c[1]) - a[1] * (b[0] * c[2] - b[2] * c[0]) +
           a[2] * (b[0] * c[1] - b[1] * c[0]);
}

/* The element groups the checks walk: the system's groups (tets per model, springs, quadratic
 * tets per model), then the volume-averaged tets per model. */
enum { NGROUPS = DEFSIM__GROUPS + DEFSIM__TET_MODELS };

static const defsim__group *group_at(const defsim__system *s, int m)
{
    return m < DEFSIM__GROUPS ? &s->groups[m] : &s->vgroups[m - DEFSIM__GROUPS].g;
}

/* Smallest volume ratio J = det Ds / det Dm of group g at x, and the count with J <= 0 (or not
 * a number). Rest tets are positively oriented, so det Dm = 6 vol. A quadratic tet's J is det F
 * at its quadrature points (where its energy is evaluated). */
static int64_t volume_ratios(const defsim__group *g, const double *x, int nthreads, double *jmin)
{
    int64_t bad = 0;
    double lo = INFINITY;
#pragma omp parallel for schedule(static) num_threads(nthreads) if (g->n > 20000) \
    reduction(+ : bad) reduction(min : lo)
    for (int32_t e = 0; e < g->n; ++e) {
        const double J = g->nodes == 10 ? defsim__tet10_min_det(g, x, e)
                                        : det3(x, g->idx + 4 * (int64_t)e) / (6.0 * g->vol[e]);
        bad += !(J > 0.0);
        if (J < lo) lo = J;
    }
    *jmin = lo;
    return bad;
}

/* Diagonal of the bounding box of points first .. first + n - 1 of x; NaN if a coordinate is
 * not finite. */
static double span(const double *x, int32_t first, int32_t n)
{
    double lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
    for (int32_t i = first; i < first + n; ++i)
        for (int k = 0; k < 3; ++k) {
            const double c = x[3 * (int64_t)i + k];
            lo[k] = c < lo[k] ? c : lo[k];
            hi[k] = c > hi[k] ? c : hi[k];
        }
    return sqrt((hi[0] - lo[0]) * (hi[0] - lo[0]) + (hi[1] - lo[1]) * (hi[1] - lo[1]) +
                (hi[2] - lo[2]) * (hi[2] - lo[2]));
}

static void take_rest(defsim__watchdog *wd, const defsim__watchdog_step *in)
{
    const defsim__system *s = in->sys;
    double mass = 0.0;
    for (int32_t i = 0; i < s->nv; ++i) mass += s->mass[i];
    const double *g = s->gravity;
    const double gn = sqrt(g[0] * g[0] + g[1] * g[1] + g[2] * g[2]);
    wd->e_floor = mass * s->length_scale * (gn > 9.81 ? gn : 9.81);
    /* Smallest element size: (6 V)^(1/3) of a tet (its edge for a right-corner cube tet), half
     * that for a quadratic tet (its nodes' spacing), the rest length of a spring. */
    double size = s->length_scale;
    for (int m = 0; m < NGROUPS; ++m) {
        const defsim__group *gr = group_at(s, m);
        for (int32_t e = 0; e < gr->n; ++e) {
            const double l = gr->nodes == 4    ? cbrt(6.0 * gr->vol[e])
                             : gr->nodes == 10 ? 0.5 * cbrt(6.0 * gr->vol[e])
                                               : gr->l0[e];
            if (l > 0.0 && l < size) size = l;
        }
    }
    wd->move2 = (MOVE_FRACTION * size) * (MOVE_FRACTION * size);
    wd->jmin = 0.0;   /* not measured yet: the first check measures it */
    for (int32_t b = 0; b < in->nbodies; ++b) {
        const defsim__body *bd = &in->bodies[b];
        wd->rest_diag[b] = (bd->generation & 1u) && bd->nv > 1 ? span(bd->rest, 0, bd->nv) : 0.0;
    }
    for (int32_t i = 0; i < s->nv; ++i) wd->dof[i] = s->pinned[i] ? 0.0 : s->mass[i];
    wd->have_rest = 1;
}

/* Whether some element changed shape by more than sqrt(move2) in a step with displacements dx
 * (3 nv): a column x_a - x_3 of a tet's Ds, a spring, or an attachment's spring (whose world
 * point stays put within a step) with |dx_a - dx_b|^2 > move2. lo and hi bound the displacements
 * component-wise: when their box's diagonal is within the limit, no two vertices moved
 * differently by more (a body moved as a whole), and the pass over the elements is skipped. */
static int deformed(const defsim__watchdog *wd, const defsim__system *s, const double *dx,
                    const double lo[3], const double hi[3])
{
    const double box = (hi[0] - lo[0]) * (hi[0] - lo[0]) + (hi[1] - lo[1]) * (hi[1] - lo[1]) +
                       (hi[2] - lo[2]) * (hi[2] - lo[2]);
    if (box <= wd->move2) return 0;
    double most = 0.0;
    for (int m = 0; m < NGROUPS; ++m) {
        const defsim__group *gr = group_at(s, m);
        const int32_t *id = gr->idx;
        if (gr->nodes >= 4) {
            /* every node of a tet (quadratic: its mid-edge nodes too) against node 3 */
            const int nn = gr->nodes;
#pragma omp simd reduction(max : most)
            for (int32_t e = 0; e < gr->n; ++e) {
                const double *d3 = dx + 3 * (int64_t)id[nn * (int64_t)e + 3];
                for (int a = 0; a < nn; ++a) {
                    const double *da = dx + 3 * (int64_t)id[nn * (int64_t)e + a];
                    const double c0 = da[0] - d3[0], c1 = da[1] - d3[1], c2 = da[2] - d3[2];
                    const double q = c0 * c0 + c1 * c1 + c2 * c2;
                    most = q > most ? q : most;
                }
            }
        } else {
#pragma omp simd reduction(max : most)
            for (int32_t e = 0; e < gr->n; ++e) {
                const double *da = dx + 3 * (int64_t)id[2 * (int64_t)e];
                const double *db = dx + 3 * (int64_t)id[2 * (int64_t)e + 1];
                const double c0 = da[0] - db[0], c1 = da[1] - db[1], c2 = da[2] - db[2];
                const double q = c0 * c0 + c1 * c1 + c2 * c2;
                most = q > most ? q : most;
            }
        }
    }
    const defsim__attachments *at = &s->att;
    for (int32_t e = 0; e < at->n; ++e) {
        double d[3];
        attach_combine(at, e, dx, 0, d);
        const double q = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
        most = q > most ? q : most;
    }
    return !(most <= wd->move2);
}

static double kinetic_free(const defsim__system *s, const double *v)
{
    double ke = 0.0;
    for (int32_t i = 0; i < s->nv; ++i) {
        if (s->pinned[i]) continue;
        const double *u = v + 3 * (int64_t)i;
        ke += 0.5 * s->mass[i] * (u[0] * u[0] + u[1] * u[1] + u[2] * u[2]);
    }
    return ke;
}

/* The force callback's work in a step with displacements dx: per free vertex, the largest
 * f . dx over the evaluations recorded in the step (the midpoint rule plus half their spread:
 * exact for a force held over the step, an upper bound of the work along the step whenever the
 * force's component along dx stays between the recorded values). */
static double callback_work(const defsim__watchdog *wd, const defsim__system *s,
                            const double *const *f, int n, const double *dx)
{
    double w = 0.0;
    for (int32_t i = 0; i < s->nv; ++i) {
        if (!(wd->dof[i] > 0.0)) continue;
        const double *d = dx + 3 * (int64_t)i;
        double most = -INFINITY;
        for (int r = 0; r < n; ++r) {
            const double *fi = f[r] + 3 * (int64_t)i;
            const double p = fi[0] * d[0] + fi[1] * d[1] + fi[2] * d[2];
            most = p > most ? p : most;
        }
        w += most;
    }
    return w;
}

/* The driven pins' work on the free vertices and the elements: -f . dx at the pinned vertices
 * that moved, f the elastic and damping forces on them (the pin holds them against f), the
 * larger of its values with the forces at the start and at the end (as the callback's). */
static double pin_work(const defsim__system *s, const double *f0, const double *f1,
                       const double *dx)
{
    double w = 0.0;
    for (int32_t i = 0; i < s->nv; ++i) {
        if (!s->pinned[i]) continue;
        const double *d = dx + 3 * (int64_t)i, *a = f0 + 3 * (int64_t)i, *b = f1 + 3 * (int64_t)i;
        if (d[0] == 0.0 && d[1] == 0.0 && d[2] == 0.0) continue;
        const double pa = -(a[0] * d[0] + a[1] * d[1] + a[2] * d[2]);
        const double pb = -(b[0] * d[0] + b[1] * d[1] + b[2] * d[2]);
        w += pa > pb ? pa : pb;
    }
    return w;
}

/* Lists the elements with a pinned vertex (once per plan). */
static int list_pinned_elements(defsim__watchdog *wd, const defsim__system *s)
{
    int64_t n = 0;
    for (int pass = 0; pass < 2; ++pass) {
        n = 0;
        for (int m = 0; m < DEFSIM__GROUPS; ++m) {
            const defsim__group *g = &s->groups[m];
            for (int32_t e = 0; e < g->n; ++e) {
                int held = 0;
                for (int a = 0; a < g->nodes; ++a)
                    held |= s->pinned[g->idx[(int64_t)g->nodes * e + a]];
                if (!held) continue;
                if (pass) {
                    wd->pin_el[2 * n] = m;
                    wd->pin_el[2 * n + 1] = e;
                }
                ++n;
            }
        }
        if (!pass) {
            free(wd->pin_el);
            wd->pin_el = malloc((2 * (size_t)n + 1) * sizeof *wd->pin_el);
            if (!wd->pin_el) return 0;
        }
    }
    wd->npin_el = (int32_t)n;
    wd->pin_el_ok = 1;
    return 1;
}

defsim_status defsim__watchdog_pin_forces(defsim__watchdog *wd, const defsim__system *s,
                                          const double *x, const double *v, double *f)
{
    if (s->has_stiffness_damping || s->has_attachment_damping || s->body_contact ||
        s->has_volume_averaging)
        return defsim__forces(s, x, v, DEFSIM_FORCE_ELASTIC | DEFSIM_FORCE_DAMPING |
                                           DEFSIM__FORCE_KEEP_PINNED, f, NULL);
    if (!wd->pin_el_ok && !list_pinned_elements(wd, s)) return DEFSIM_ERR_OUT_OF_MEMORY;
    for (int32_t i = 0; i < s->nv; ++i)
        if (s->pinned[i]) f[3 * (int64_t)i] = f[3 * (int64_t)i + 1] = f[3 * (int64_t)i + 2] = 0.0;
    /* Each element's forces into a local copy, then only its pinned nodes' into f. (Mass
     * damping does no work across a pin: the free vertices' share of it is -alpha m v^2.) */
    for (int32_t k = 0; k < wd->npin_el; ++k) {
        const defsim__group *g = &s->groups[wd->pin_el[2 * k]];
        const int32_t e = wd->pin_el[2 * k + 1];
        const int32_t *id = g->idx + (int64_t)g->nodes * e;
        double fl[30] = {0};
        if (g->nodes == 10) {
            defsim__tet10_element_forces(g, x, e, fl);
        } else if (g->nodes == 4) {
            const int32_t loc[4] = {0, 1, 2, 3};
            const double *dm = g->dminv + 9 * (int64_t)e;
            double F[9], P[9], xl[12];
            for (int a = 0; a < 4; ++a)
                memcpy(xl + 3 * a, x + 3 * (int64_t)id[a], 3 * sizeof *xl);
            tet_deformation(xl, loc, dm, F);
            (void)g->law->P(g->mu[e], g->lambda[e], F, P);
            tet_scatter(fl, loc, dm, P, -g->vol[e]);
        } else {
            const double *xa = x + 3 * (int64_t)id[0], *xb = x + 3 * (int64_t)id[1];
            const double d[3] = {xa[0] - xb[0], xa[1] - xb[1], xa[2] - xb[2]};
            const double l = sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
            const double c = l > 0.0 ? -g->k[e] * (l - g->l0[e]) / l : 0.0;
            for (int i = 0; i < 3; ++i) {
                fl[i] = c * d[i];
                fl[3 + i] = -c * d[i];
            }
        }
        for (int a = 0; a < g->nodes; ++a)
            if (s->pinned[id[a]])
                for (int i = 0; i < 3; ++i) f[3 * (int64_t)id[a] + i] += fl[3 * a + i];
    }
    const defsim__attachments *at = &s->att;
    for (int32_t e = 0; e < at->n; ++e) {
        const int32_t *nd = at->node + DEFSIM__ATTACH_NODES * (int64_t)e;
        double d[3];
        attach_combine(at, e, x, 1, d);
        const double *a = at->a + DEFSIM__ATTACH_NODES * (int64_t)e;
        for (int j = 0; j < DEFSIM__ATTACH_NODES; ++j)
            if (nd[j] >= 0 && s->pinned[nd[j]])
                for (int i = 0; i < 3; ++i) f[3 * (int64_t)nd[j] + i] -= at->k[e] * a[j] * d[i];
    }
    for (int32_t i = 0; i < s->nv; ++i)
        if (s->pinned[i] && !(isfinite(f[3 * (int64_t)i]) && isfinite(f[3 * (int64_t)i + 1]) &&
                              isfinite(f[3 * (int64_t)i + 2])))
            return DEFSIM_ERR_UNSTABLE;
    return DEFSIM_OK;
}

double *defsim__watchdog_pin_buffer(defsim__watchdog *wd, int32_t nv, int end)
{
    if (wd->pin_nv != nv || !wd->pin_f0 || !wd->pin_f1) {
        free(wd->pin_f0);
        free(wd->pin_f1);
        wd->pin_f0 = malloc((3 * (size_t)nv + 1) * sizeof *wd->pin_f0);
        wd->pin_f1 = malloc((3 * (size_t)nv + 1) * sizeof *wd->pin_f1);
        wd->pin_nv = nv;
        wd->pin_f_t = NAN;
        if (!wd->pin_f0 || !wd->pin_f1) {
            free(wd->pin_f0);
            free(wd->pin_f1);
            wd->pin_f0 = wd->pin_f1 = NULL;
            return NULL;
        }
    }
    return end ? wd->pin_f1 : wd->pin_f0;
}

/* Frees the buffers of the reference's rest data and the check's displacements. */
static void free_rest(defsim__watchdog *wd)
{
    free(wd->rest_diag);
    free(wd->dof);
    free(wd->dx);
    wd->rest_diag = wd->dof = wd->dx = NULL;
}

defsim_status defsim__watchdog_check(defsim__watchdog *wd, const defsim__watchdog_step *in,
                                     char *what, size_t size)
{
    const defsim__system *s = in->sys;
    const double *x = in->x, *v = in->v, *x0 = in->x0;
    const int64_t ndof = 3 * (int64_t)s->nv;
    if (!in->on) {
        wd->have_ref = 0;
        int ok = 1;
        for (int64_t i = 0; i < ndof; ++i) ok &= isfinite(x[i]) & isfinite(v[i]);
        if (ok) return DEFSIM_OK;
        snprintf(what, size, "the state became non-finite");
        return DEFSIM_ERR_UNSTABLE;
    }
    if (!wd->have_rest) {
        free_rest(wd);
        wd->rest_diag = malloc(((size_t)in->nbodies + 1) * sizeof *wd->rest_diag);
        wd->dof = malloc(((size_t)s->nv + 1) * sizeof *wd->dof);
        wd->dx = malloc((3 * (size_t)s->nv + 1) * sizeof *wd->dx);
        if (!wd->rest_diag || !wd->dof || !wd->dx) {
            free_rest(wd);
            snprintf(what, size, "out of memory");
            return DEFSIM_ERR_OUT_OF_MEMORY;
        }
        take_rest(wd, in);
    }
    /* The contact energy at the start is stored energy the reference holds; colliders that came
     * or went since the reference put it in as work (the whole of it: at least what changed). */
    double contact_start = 0.0, contact_work = 0.0;
    defsim__terms_work(s, x0, x, in->contact_start_wanted, &contact_start, &contact_work);
    double injected = in->colliders_changed ? contact_start : 0.0;
    if (!wd->have_ref) {
        wd->k_prev = kinetic_free(s, in->v0);
        wd->e_ref = wd->k_prev + defsim__elastic_energy(s, in->work, x0) + contact_start;
        wd->energy_evals++;
        wd->work = 0.0;
        wd->since_full = ENERGY_EVERY;   /* the first step checks the total */
        wd->have_ref = 1;
        injected = 0.0;
    }

    /* One branch-free pass over the vertices (vectorised: it runs in every step): finiteness,
     * kinetic energy and work of the free vertices, and the displacements of the step. x * 0 is
     * NaN exactly when x is inf or NaN; mf is a vertex's mass, 0 if pinned. */
    const double *mf = wd->dof, *fx = s->fext, *g = s->gravity;
    double *dx = wd->dx;
    double nan = 0.0, ke = 0.0, mdx0 = 0.0, mdx1 = 0.0, mdx2 = 0.0, wext = 0.0;
    double lo0 = INFINITY, lo1 = INFINITY, lo2 = INFINITY;
    double hi0 = -INFINITY, hi1 = -INFINITY, hi2 = -INFINITY;
    const int32_t nv = s->nv;
#pragma omp simd reduction(+ : nan, ke, mdx0, mdx1, mdx2, wext) \
    reduction(min : lo0, lo1, lo2) reduction(max : hi0, hi1, hi2)
    for (int32_t i = 0; i < nv; ++i) {
        const double m = mf[i], fr = m > 0.0 ? 1.0 : 0.0;
        const double *p = x + 3 * (int64_t)i, *q = x0 + 3 * (int64_t)i, *u = v + 3 * (int64_t)i;
        const double d0 = p[0] - q[0], d1 = p[1] - q[1], d2 = p[2] - q[2];
        nan += p[0] * 0.0 + p[1] * 0.0 + p[2] * 0.0 + u[0] * 0.0 + u[1] * 0.0 + u[2] * 0.0;
        ke += m * (u[0] * u[0] + u[1] * u[1] + u[2] * u[2]);
        mdx0 += m * d0;
        mdx1 += m * d1;
        mdx2 += m * d2;
        if (fx) {
            const double *f = fx + 3 * (int64_t)i;
            wext += fr * (f[0] * d0 + f[1] * d1 + f[2] * d2);
        }
        dx[3 * (int64_t)i] = d0;
        dx[3 * (int64_t)i + 1] = d1;
        dx[3 * (int64_t)i + 2] = d2;
        lo0 = d0 < lo0 ? d0 : lo0;
        lo1 = d1 < lo1 ? d1 : lo1;
        lo2 = d2 < lo2 ? d2 : lo2;
        hi0 = d0 > hi0 ? d0 : hi0;
        hi1 = d1 > hi1 ? d1 : hi1;
        hi2 = d2 > hi2 ? d2 : hi2;
    }
    ke *= 0.5;
    const int finite = nan == 0.0;
    const double lo[3] = {lo0, lo1, lo2}, hi[3] = {hi0, hi1, hi2};
    if (!finite) {
        snprintf(what, size, "the state became non-finite");
        return DEFSIM_ERR_UNSTABLE;
    }
    /* Work beyond gravity and held forces (only in steps that have it: the pass above is all a
     * plain step pays). A work that overflows leaves only the kinetic energy's finiteness. */
    double work = g[0] * mdx0 + g[1] * mdx1 + g[2] * mdx2 + wext;
    if (in->ncb > 0) work += callback_work(wd, s, in->cb_f, in->ncb, dx);
    if (in->pin_f0) work += pin_work(s, in->pin_f0, in->pin_f1, dx);
    work += contact_work + injected;
    if (!isfinite(work)) work = INFINITY;
    /* The steps where garbage can hide from K and where an element can invert (header). */
    const int full = ke > 2.0 * wd->k_prev + 1e-3 * wd->e_floor ||
                     ++wd->since_full >= ENERGY_EVERY || deformed(wd, s, dx, lo, hi);
    if (full) wd->since_full = 0;
    wd->k_prev = ke;
    {
        const double budget = wd->e_ref + wd->work + work;
        const double limit = in->energy_growth * (budget > 0.0 ? budget : 0.0) + wd->e_floor;
        const double e = full ? ke + defsim__elastic_energy(s, in->work, x) : ke;
        wd->energy_evals += full;
        const char *which = full ? "total" : "kinetic";
        /* Also with an unbounded budget: velocities whose energy overflows are no motion. */
        if (!(e <= limit) || !(ke < INFINITY)) {
            snprintf(what, size, "the %s energy reached %.3g J, over %g x %.3g J (the energy at "
                     "the reference plus the work of gravity, applied forces, the force "
                     "callback, driven pins and colliders since) + %.3g J "
                     "(core.watchdog_energy_growth)", which, e, in->energy_growth, budget,
                     wd->e_floor);
            return DEFSIM_ERR_UNSTABLE;
        }
    }
    for (int32_t b = 0; full && b < in->nbodies; ++b) {
        if (!(wd->rest_diag[b] > 0.0)) continue;   /* removed, or a single vertex */
        const double d = span(x, in->bodies[b].offset, in->bodies[b].nv);
        if (!(d <= in->max_stretch * wd->rest_diag[b])) {
            snprintf(what, size, "body %d spans %.3g m, more than %g times its rest size %.3g m "
                     "(core.watchdog_max_stretch)", (int)b, d, in->max_stretch,
                     wd->rest_diag[b]);
            return DEFSIM_ERR_UNSTABLE;
        }
    }
    for (int m = 0; m < NGROUPS && (full || wd->jmin < JMIN_WATCH); ++m) {
        const defsim__group *gr = group_at(s, m);
        if (gr->n == 0 || gr->nodes == 2 || !gr->law->needs_positive_det) continue;
        double jmin;
        const int64_t bad = volume_ratios(gr, x, s->nthreads, &jmin);
        wd->jmin = jmin;
        if (bad > 0) {
            snprintf(what, size, "%lld %s element(s) inverted (smallest volume ratio J = %.3g; "
                     "the model is undefined at J <= 0)", (long long)bad, gr->law->name, jmin);
            return DEFSIM_ERR_UNSTABLE;
        }
    }
    /* Unbounded work or a reference energy that is not finite (an SDF callback that failed
     * there) bounds nothing further: a new reference at the next step. */
    if (work < INFINITY && wd->e_ref < INFINITY) wd->work += work;
    else wd->have_ref = 0;
    return DEFSIM_OK;
}

void defsim__watchdog_message(char *out, size_t size, const char *what, double h, double t,
                              const char *backend, int limited, double h_stable, int auto_substep)
{
    char advice[240];
    if (!limited)
        snprintf(advice, sizeof advice, "backend %s has no step-size limit: use a smaller step or "
                 "a tighter tolerance, and check the scene's forces", backend);
    else if (isnan(h_stable))
        snprintf(advice, sizeof advice, "the stable step cannot be estimated at the start of the "
                 "step (non-finite stiffness): use a smaller step or an implicit backend");
    else if (auto_substep)
        snprintf(advice, sizeof advice, "defsim_world_stable_step gives %.3g s and "
                 "core.auto_substep is on: lower core.substep_safety, or use an implicit backend",
                 h_stable);
    else
        snprintf(advice, sizeof advice, "defsim_world_stable_step gives %.3g s; use a smaller "
                 "step, enable core.auto_substep, or an implicit backend", h_stable);
    snprintf(out, size, "step: watchdog: %s, in the step of h = %g s from t = %g s (state "
             "restored). %s (core.watchdog = false turns the watchdog off)", what, h, t, advice);
}

void defsim__watchdog_step_done(defsim__watchdog *wd, double t)
{
    if (!wd->pin_end) return;
    double *f = wd->pin_f0;
    wd->pin_f0 = wd->pin_f1;
    wd->pin_f1 = f;
    wd->pin_f_t = t;
    wd->pin_end = 0;
}

void defsim__watchdog_forget(defsim__watchdog *wd, int bodies)
{
    wd->have_ref = 0;
    wd->pin_f_t = NAN;
    if (bodies) {
        wd->have_rest = 0;
        wd->pin_el_ok = 0;
    }
}

void defsim__watchdog_free(defsim__watchdog *wd)
{
    free_rest(wd);
    free(wd->pin_f0);
    free(wd->pin_f1);
    free(wd->pin_el);
    memset(wd, 0, sizeof *wd);
    wd->pin_f_t = NAN;
}

void defsim__watchdog_attachment_moved(defsim__watchdog *wd, const defsim__system *s, int32_t e,
                                       const double *x, const double p[3])
{
    if (!wd->have_ref) return;
    const defsim__attachments *at = &s->att;
    double d[3];
    attach_combine(at, e, x, 1, d);
    double before = 0.0, after = 0.0;
    for (int k = 0; k < 3; ++k) {
        const double dn = d[k] + at->p[3 * (int64_t)e + k] - p[k];
        before += d[k] * d[k];
        after += dn * dn;
    }
    wd->work += 0.5 * at->k[e] * (after - before);
}

void defsim__watchdog_diagnostics(const defsim__watchdog *wd, const defsim__system *s,
                                  defsim__work *wk, const double *x, const double *v,
                                  defsim_stats *out)
{
    double jmin = INFINITY;
    int64_t bad = 0;
    for (int m = 0; m < NGROUPS; ++m) {
        const defsim__group *gr = group_at(s, m);
        if (gr->n == 0 || gr->nodes == 2) continue;
        double j;
        bad += volume_ratios(gr, x, s->nthreads, &j);
        if (j < jmin) jmin = j;
    }
    out->min_volume_ratio = isinf(jmin) ? 1.0 : jmin;
    out->inverted_elements = bad;
    out->energy_drift = wd->have_ref ? kinetic_free(s, v) + defsim__elastic_energy(s, wk, x) -
                                           (wd->e_ref + wd->work)
                                     : NAN;
}

int defsim__watchdog_is_diagnostic(const char *name)
{
    return !strcmp(name, "min_volume_ratio") || !strcmp(name, "inverted_elements") ||
           !strcmp(name, "energy_drift");
}
