/* SPDX-License-Identifier: MIT */
/*
 * Forces f(x, v) of a compiled system: elastic (one kernel per tet model: the batched SIMD
 * kernels of tet_forces.c when chosen, else the model's scalar one), springs, attachments,
 * stiffness and mass damping, gravity and held external forces, pins. Elements of a group are
 * sorted by colour (no two elements of a colour share a vertex), so each colour scatters in
 * parallel without atomics and every sum is formed in the same order whatever the thread count:
 * results are bit-identical for any number of threads.
 *
 * Contents: stiffness damping; attachments; defsim__forces.
 */
#include "forces.h"

#include "body_contact.h"
#include "contact.h"
#include "element.h"
#include "material.h"
#include "tet_forces.h"

#include <math.h>
#include <string.h>

enum { PAR_MIN = 1024 };

/* Stiffness damping -beta K_e(x) v_e per element with the element stiffness made positive
 * semi-definite (analytic eigenvalue clamping of dP/dF): linear in v, never injects energy, and
 * the same matrix B that implicit backends assemble. */
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

/* Attachment springs (ELASTIC) and dampers (DAMPING): f_j -= a_j (k d + c sum_l a_l v_l). Few,
 * and sharing vertices freely, so one thread in a fixed order. */
static void forces_attachments(const defsim__attachments *at, const double *x, const double *v,
                               int elastic, int damping, double *f)
{
    for (int32_t e = 0; e < at->n; ++e) {
        const int32_t *nd = at->node + DEFSIM__ATTACH_NODES * (int64_t)e;
        const double *a = at->a + DEFSIM__ATTACH_NODES * (int64_t)e;
        const double k = elastic ? at->k[e] : 0.0, c = damping ? at->c[e] : 0.0;
        double d[3] = {0.0, 0.0, 0.0}, w[3] = {0.0, 0.0, 0.0};
        if (k != 0.0) attach_combine(at, e, x, 1, d);
        if (c != 0.0) attach_combine(at, e, v, 0, w);
        for (int j = 0; j < DEFSIM__ATTACH_NODES; ++j)
            if (nd[j] >= 0)
                for (int i = 0; i < 3; ++i) f[3 * (int64_t)nd[j] + i] -= a[j] * (k * d[i] + c * w[i]);
    }
}

static int all_finite(const double *a, int64_t n)
{
    int ok = 1;
    for (int64_t i = 0; i < n; ++i) ok &= isfinite(a[i]);
    return ok;
}

defsim_status defsim__forces(const defsim__system *s, const double *x, const double *v,
                             uint32_t which, double *f, uint32_t *passes)
{
    const int64_t ndof = 3 * (int64_t)s->nv;
    const int nt = s->nthreads;
    uint32_t used = 0;
    memset(f, 0, (size_t)ndof * sizeof *f);
    if (which & DEFSIM_FORCE_ELASTIC) {
        for (int m = 0; m < DEFSIM__TET_MODELS; ++m) {
            if (s->groups[m].n == 0) continue;
            if (s->tet_kernels) s->tet_kernels->forces[m](&s->groups[m], x, f, nt);
            else s->groups[m].law->forces(&s->groups[m], x, f, nt);
            used |= s->groups[m].pass;
        }
        const defsim__group *sg = &s->groups[DEFSIM__TET_MODELS];
        if (sg->n > 0) {
            defsim__model_spring.forces(sg, x, f, nt);
            used |= sg->pass;
        }
    }
    if (s->att.n > 0) {
        const int el = (which & DEFSIM_FORCE_ELASTIC) != 0;
        const int dm = (which & DEFSIM_FORCE_DAMPING) && v && s->has_attachment_damping;
        if (el || dm) {
            forces_attachments(&s->att, x, v, el, dm, f);
            used |= DEFSIM_PASS_ATTACHMENTS;
        }
    }
    if (s->contact && (which & (DEFSIM_FORCE_ELASTIC | DEFSIM_FORCE_DAMPING))) {
        const defsim_status st = defsim__contact_forces(s->contact, x, v, which, f);
        if (st != DEFSIM_OK) return st;
    }
    if (s->body_contact && (which & DEFSIM_FORCE_ELASTIC)) {
        const defsim_status st = defsim__body_contact_forces(s->body_contact, x, f);
        if (st != DEFSIM_OK) return st;
    }
    if ((which & DEFSIM_FORCE_DAMPING) && v) {
        if (s->has_stiffness_damping) {
            for (int m = 0; m < DEFSIM__TET_MODELS; ++m)
                if (s->groups[m].n > 0) damping_tets(&s->groups[m], x, v, f, nt);
            const defsim__group *sg = &s->groups[DEFSIM__TET_MODELS];
            if (sg->n > 0) damping_springs(sg, x, v, f, nt);
            used |= DEFSIM_PASS_STIFFNESS_DAMPING;
        }
        if (s->has_mass_damping) {
            for (int64_t i = 0; i < ndof; ++i) f[i] -= s->alpha3[i] * s->mass3[i] * v[i];
            used |= DEFSIM_PASS_MASS_DAMPING;
        }
    }
    if ((which & DEFSIM_FORCE_GRAVITY) && s->has_gravity) {
        const double *gr = s->gravity;
        for (int32_t i = 0; i < s->nv; ++i) {
            f[3 * (int64_t)i + 0] += s->mass[i] * gr[0];
            f[3 * (int64_t)i + 1] += s->mass[i] * gr[1];
            f[3 * (int64_t)i + 2] += s->mass[i] * gr[2];
        }
        used |= DEFSIM_PASS_GRAVITY;
    }
    if ((which & DEFSIM_FORCE_GRAVITY) && s->fext) {
        for (int64_t i = 0; i < ndof; ++i) f[i] += s->fext[i];
        used |= DEFSIM_PASS_EXTERNAL_FORCES;
    }
    if (s->has_pins && !(which & DEFSIM__FORCE_KEEP_PINNED)) {
        for (int32_t i = 0; i < s->nv; ++i)
            if (s->pinned[i]) f[3 * (int64_t)i] = f[3 * (int64_t)i + 1] = f[3 * (int64_t)i + 2] = 0.0;
        used |= DEFSIM_PASS_PINS;
    }
    if (passes) *passes |= used;
    return all_finite(f, ndof) ? DEFSIM_OK : DEFSIM_ERR_UNSTABLE;
}
