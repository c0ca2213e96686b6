/* SPDX-License-Identifier: MIT */
/*
 * Stiffness damping, forces -beta K_e(x) v_e per element (tets of every group, then springs, then
 * quadratic tets; the volume-averaged and the mean-dilatation quadratic tets damp in their own
 * terms' forces, with their own stiffness) with the element stiffness made positive
 * semi-definite (analytic eigenvalue clamping of dP/dF): linear in v, never injects energy. Its
 * matrix B shares each element's matrix with the elastic term (term_elastic.c, term_spring.c),
 * so that an element is scattered once.
 */
#include "adjoint.h"
#include "element.h"
#include "material.h"
#include "system.h"
#include "term_cache.h"
#include "tet10.h"

#include <math.h>
#include <string.h>

enum { PAR_MIN = 1024 };

static int compile(defsim__system *s, defsim__term *out)
{
    return defsim__term_one(s->has_stiffness_damping, s, NULL, 0, out);
}

static void damping_tets(const defsim__group *g, const double *x, const double *v, double *f,
                         int nthreads)
{
    (void)nthreads;   /* used by OpenMP pragmas only */
    for (int32_t c = 0; c < g->ncolors; ++c) {
        const int32_t e0 = g->color_ptr[c], e1 = g->color_ptr[c + 1];
#pragma omp parallel for schedule(static) num_threads(nthreads) if (e1 - e0 > PAR_MIN / 8)
        for (int32_t e = e0; e < e1; ++e) {
            if (g->beta[e] == 0.0) continue;
            const int32_t *id = g->idx + 4 * (int64_t)e;
            const double *dm = g->dminv + 9 * (int64_t)e;
            double F[9], dF[9], D[81], dP[9];
            tet_deformation(x, id, dm, F);
            tet_deformation(v, id, dm, dF);
            defsim__model_dpdf_projected(g->law, g->mu[e], g->lambda[e], F,
                                         DEFSIM_PROJECTION_CLAMP, D, 0, NULL);
            apply_dpdf(D, dF, dP);
            tet_scatter(f, id, dm, dP, -g->beta[e] * g->vol[e]);
        }
    }
}

static void damping_springs(const defsim__group *g, const double *x, const double *v, double *f,
                            int nthreads)
{
    (void)nthreads;   /* used by OpenMP pragmas only */
    for (int32_t c = 0; c < g->ncolors; ++c) {
        const int32_t e0 = g->color_ptr[c], e1 = g->color_ptr[c + 1];
#pragma omp parallel for schedule(static) num_threads(nthreads) if (e1 - e0 > PAR_MIN)
        for (int32_t e = e0; e < e1; ++e) {
            if (g->beta[e] == 0.0) continue;
            const int32_t a = g->idx[2 * (int64_t)e], b = g->idx[2 * (int64_t)e + 1];
            double Kb[9];
            defsim__model_spring.block(x + 3 * (int64_t)a, x + 3 * (int64_t)b, g->k[e], g->l0[e],
                                       DEFSIM_PROJECTION_CLAMP, Kb);
            const double *va = v + 3 * (int64_t)a, *vb = v + 3 * (int64_t)b;
            double dv[3] = {vb[0] - va[0], vb[1] - va[1], vb[2] - va[2]};
            for (int i = 0; i < 3; ++i) {
                double s = g->beta[e] * (Kb[3 * i] * dv[0] + Kb[3 * i + 1] * dv[1] +
                                         Kb[3 * i + 2] * dv[2]);
                f[3 * (int64_t)a + i] += s;
                f[3 * (int64_t)b + i] -= s;
            }
        }
    }
}

static defsim_status forces(const defsim__term *t, const defsim__system *s, const defsim__eval *ev,
                            double *f, uint32_t *used)
{
    (void)t;
    if (!(ev->which & DEFSIM_FORCE_DAMPING) || !ev->v) return DEFSIM_OK;
    for (int m = 0; m < DEFSIM__TET_MODELS; ++m)
        if (s->groups[m].n > 0) damping_tets(&s->groups[m], ev->x, ev->v, f, s->nthreads);
    const defsim__group *sg = &s->groups[DEFSIM__TET_MODELS];
    if (sg->n > 0) damping_springs(sg, ev->x, ev->v, f, s->nthreads);
    for (int m = DEFSIM__QUAD_GROUP; m < DEFSIM__QUAD_GROUP + DEFSIM__TET_MODELS; ++m)
        if (s->groups[m].n > 0)
            defsim__tet10_damping_forces(&s->groups[m], ev->x, ev->v, f, s->nthreads);
    *used |= DEFSIM_PASS_STIFFNESS_DAMPING;
    return DEFSIM_OK;
}

static void rates(const defsim__term *t, const defsim__system *s, const double *x,
                  defsim__rates *r)
{
    (void)t;
    (void)x;
    for (int m = 0; m < DEFSIM__GROUPS; ++m)
        for (int32_t e = 0; e < s->groups[m].n; ++e)
            if (s->groups[m].beta[e] > r->beta) r->beta = s->groups[m].beta[e];
}

/* Reverse mode. A tet's w . f_e = -beta vol phi with phi(F, mu, lambda) = dF(w) : Dc : dF(v),
 * Dc = dP/dF clamped to PSD at F = F(x): linear in v (Dc is symmetric, so its v-derivative is
 * -beta K_e w), while its x- and (mu, lambda)-derivatives are third derivatives of the energy
 * through the clamp: they are central differences of phi in the 9 entries of F and in mu and
 * lambda (relative step DEFSIM__VJP_FD_STEP: truncation and rounding near 1e-10 of phi). */
static double tet_phi(const defsim__model *law, double mu, double la, const double F[9],
                      const double a[9], const double b[9])
{
    double D[81], Db[9];
    defsim__model_dpdf_projected(law, mu, la, F, DEFSIM_PROJECTION_CLAMP, D, 0, NULL);
    apply_dpdf(D, b, Db);
    return defsim__m3_ddot(a, Db);
}

static void vjp_tets(const defsim__group *gr, int m, const defsim__eval *ev, const double *w,
                     double *gx, double *gv, defsim__grad *g)
{
    for (int32_t e = 0; e < gr->n; ++e) {
        const double beta = gr->beta[e];
        const int want_beta = g && (g->want & DEFSIM__WANT_BETA);
        if (beta == 0.0 && !want_beta) continue;
        const int32_t *id = gr->idx + 4 * (int64_t)e;
        const double *dm = gr->dminv + 9 * (int64_t)e;
        const double mu = gr->mu[e], la = gr->lambda[e], s = -beta * gr->vol[e];
        double F[9], dFw[9], dFv[9];
        tet_deformation(ev->x, id, dm, F);
        tet_deformation(w, id, dm, dFw);
        tet_deformation(ev->v, id, dm, dFv);
        if (beta == 0.0) {   /* only d/dbeta: -vol phi */
            g->beta[m][e] -= gr->vol[e] * tet_phi(gr->law, mu, la, F, dFw, dFv);
            continue;
        }
        if (gv) {
            double D[81], dP[9];
            defsim__model_dpdf_projected(gr->law, mu, la, F, DEFSIM_PROJECTION_CLAMP, D, 0, NULL);
            apply_dpdf(D, dFw, dP);
            tet_scatter(gv, id, dm, dP, s);
        }
        if (gx) {
            double G[9], Fp[9];
            memcpy(Fp, F, sizeof Fp);
            for (int k = 0; k < 9; ++k) {
                const double d = DEFSIM__VJP_FD_STEP * (1.0 + fabs(F[k]));
                Fp[k] = F[k] + d;
                const double hi = tet_phi(gr->law, mu, la, Fp, dFw, dFv);
                Fp[k] = F[k] - d;
                const double lo = tet_phi(gr->law, mu, la, Fp, dFw, dFv);
                Fp[k] = F[k];
                G[k] = (hi - lo) / (2.0 * d);
            }
            tet_scatter(gx, id, dm, G, s);
        }
        if (g && (g->want & DEFSIM__WANT_LAME)) {
            const double dmu = DEFSIM__VJP_FD_STEP * mu;
            const double dla = DEFSIM__VJP_FD_STEP * fmax(fabs(la), mu);
            if (dmu > 0.0)
                g->mu[m][e] += s * (tet_phi(gr->law, mu + dmu, la, F, dFw, dFv) -
                                    tet_phi(gr->law, mu - dmu, la, F, dFw, dFv)) / (2.0 * dmu);
            if (dla > 0.0)
                g->lambda[m][e] += s * (tet_phi(gr->law, mu, la + dla, F, dFw, dFv) -
                                        tet_phi(gr->law, mu, la - dla, F, dFw, dFv)) / (2.0 * dla);
        }
        if (want_beta) g->beta[m][e] -= gr->vol[e] * tet_phi(gr->law, mu, la, F, dFw, dFv);
    }
}

/* A spring's w . f = beta phi, phi(d) = (w_a - w_b)^T Kc(d) (v_b - v_a), d = x_b - x_a, Kc the
 * clamped 3x3 block: its d-derivative by central differences as for tets. */
static double spring_phi(const defsim__group *gr, int32_t e, const double d[3], const double dw[3],
                         const double dv[3])
{
    static const double zero[3] = {0.0, 0.0, 0.0};
    double Kb[9];
    defsim__model_spring.block(zero, d, gr->k[e], gr->l0[e], DEFSIM_PROJECTION_CLAMP, Kb);
    double r = 0.0;
    for (int i = 0; i < 3; ++i)
        r += dw[i] * (Kb[3 * i] * dv[0] + Kb[3 * i + 1] * dv[1] + Kb[3 * i + 2] * dv[2]);
    return r;
}

static void vjp_springs(const defsim__group *gr, const defsim__eval *ev, const double *w,
                        double *gx, double *gv, defsim__grad *g)
{
    for (int32_t e = 0; e < gr->n; ++e) {
        const double beta = gr->beta[e];
        const int want_beta = g && (g->want & DEFSIM__WANT_BETA);
        if (beta == 0.0 && !want_beta) continue;
        const int32_t a = gr->idx[2 * (int64_t)e], b = gr->idx[2 * (int64_t)e + 1];
        const double *xa = ev->x + 3 * (int64_t)a, *xb = ev->x + 3 * (int64_t)b;
        const double *va = ev->v + 3 * (int64_t)a, *vb = ev->v + 3 * (int64_t)b;
        const double *wa = w + 3 * (int64_t)a, *wb = w + 3 * (int64_t)b;
        double d[3], dw[3], dv[3];
        for (int i = 0; i < 3; ++i) {
            d[i] = xb[i] - xa[i];
            dw[i] = wa[i] - wb[i];
            dv[i] = vb[i] - va[i];
        }
        if (beta == 0.0) {
            g->beta[DEFSIM__TET_MODELS][e] += spring_phi(gr, e, d, dw, dv);
            continue;
        }
        if (gv) {
            double Kb[9];
            defsim__model_spring.block(xa, xb, gr->k[e], gr->l0[e], DEFSIM_PROJECTION_CLAMP, Kb);
            for (int i = 0; i < 3; ++i) {
                const double r = beta * (Kb[3 * i] * dw[0] + Kb[3 * i + 1] * dw[1] +
                                         Kb[3 * i + 2] * dw[2]);
                gv[3 * (int64_t)b + i] += r;
                gv[3 * (int64_t)a + i] -= r;
            }
        }
        if (gx) {
            double dp[3] = {d[0], d[1], d[2]};
            for (int k = 0; k < 3; ++k) {
                const double hstep = DEFSIM__VJP_FD_STEP * (gr->l0[e] + fabs(d[k]));
                dp[k] = d[k] + hstep;
                const double hi = spring_phi(gr, e, dp, dw, dv);
                dp[k] = d[k] - hstep;
                const double lo = spring_phi(gr, e, dp, dw, dv);
                dp[k] = d[k];
                const double gk = beta * (hi - lo) / (2.0 * hstep);
                gx[3 * (int64_t)b + k] += gk;
                gx[3 * (int64_t)a + k] -= gk;
            }
        }
        if (want_beta) g->beta[DEFSIM__TET_MODELS][e] += spring_phi(gr, e, d, dw, dv);
    }
}

static defsim_status vjp(const defsim__term *t, const defsim__system *s, const defsim__eval *ev,
                         const double *w, double *gx, double *gv, defsim__grad *g)
{
    (void)t;
    if (!(ev->which & DEFSIM_FORCE_DAMPING) || !ev->v) return DEFSIM_OK;
    for (int m = 0; m < DEFSIM__TET_MODELS; ++m)
        if (s->groups[m].n > 0) vjp_tets(&s->groups[m], m, ev, w, gx, gv, g);
    const defsim__group *sg = &s->groups[DEFSIM__TET_MODELS];
    if (sg->n > 0) vjp_springs(sg, ev, w, gx, gv, g);
    return DEFSIM_OK;
}

const defsim__term_ops defsim__term_stiffness_damping = {
    .name = "stiffness_damping", .flags = DEFSIM__TERM_GRAD_OFF, .compile = compile,
    .forces = forces, .rates = rates, .vjp = vjp};
