/* SPDX-License-Identifier: MIT */
/*
 * The host's coupling API (defsim.h "Coupling with the host"): held external forces, the force
 * callback, driven pins, attachments, and what the host reads back (pin forces, attachment
 * forces, element stress). The physics of these terms lives with the rest of the physics
 * (forces.c, energy.c, assembly.c over the compiled system); this file keeps what the host
 * made and calls the host's callbacks.
 *
 * Contents: workspaces; steps; external forces; driven pins; attachments; read-back.
 */
#include "element.h"
#include "forces.h"
#include "mat3.h"
#include "material.h"
#include "tet10.h"
#include "terms.h"
#include "world.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

static int64_t first_non_finite(const double *a, int64_t n)
{
    for (int64_t i = 0; i < n; ++i)
        if (!isfinite(a[i])) return i;
    return -1;
}

/* ------------------------------------------------------------------------------------------ */
/* External forces and the callback */

defsim_status defsim_world_set_external_forces(defsim_world *w, const double *f, int32_t n)
{
    defsim_status st = defsim__world_enter(w);
    if (st != DEFSIM_OK) return st;
    if (!f) {
        free(w->coupling.fext);
        w->coupling.fext = NULL;
        w->coupling.fext_nonzero = 0;
        w->sys.fext = NULL;
        return w->planned ? defsim__terms_compile(&w->sys) : DEFSIM_OK;
    }
    if (n != w->nv) {
        defsim__error(w->msg, "set_external_forces: n = %d but the world has %d vertices",
                      (int)n, (int)w->nv);
        return DEFSIM_ERR_INVALID_ARGUMENT;
    }
    const int64_t ndof = 3 * (int64_t)n, bad = first_non_finite(f, ndof);
    if (bad >= 0) {
        defsim__error(w->msg, "set_external_forces: the force on vertex %lld is not finite",
                      (long long)(bad / 3));
        return DEFSIM_ERR_INVALID_ARGUMENT;
    }
    if (!w->coupling.fext) {
        w->coupling.fext = malloc((size_t)(ndof > 0 ? ndof : 1) * sizeof *w->coupling.fext);
        if (!w->coupling.fext) {
            defsim__error(w->msg, "out of memory");
            return DEFSIM_ERR_OUT_OF_MEMORY;
        }
    }
    int nonzero = 0;
    for (int64_t i = 0; i < ndof; ++i) {
        w->coupling.fext[i] = f[i];
        nonzero |= f[i] != 0.0;
    }
    w->coupling.fext_nonzero = nonzero;
    if (!w->planned) return DEFSIM_OK;
    w->sys.fext = nonzero ? w->coupling.fext : NULL;
    return defsim__terms_compile(&w->sys);
}

defsim_status defsim_world_set_force_callback(defsim_world *w, defsim_force_fn fn,
                                              defsim_force_jacobian_fn jacobian, void *user)
{
    defsim_status st = defsim__world_enter(w);
    if (st != DEFSIM_OK) return st;
    if (!fn && jacobian) {
        defsim__error(w->msg, "set_force_callback: a jacobian needs a force function");
        return DEFSIM_ERR_INVALID_ARGUMENT;
    }
    defsim__coupling *c = &w->coupling.cpl;
    const defsim__coupling old = *c;
    c->fn = fn;
    c->jac = fn ? jacobian : NULL;
    c->user = fn ? user : NULL;
    c->rec_prev_t = NAN;   /* another callback: its forces of the last step are not known */
    if (w->planned && (st = defsim__coupling_reserve(&w->coupling, w->nv, w->sys.has_pins)) != DEFSIM_OK) {
        c->fn = old.fn;
        c->jac = old.jac;
        c->user = old.user;
        defsim__error(w->msg, "out of memory");
        return st;
    }
    return w->planned ? defsim__terms_compile(&w->sys) : DEFSIM_OK;
}

/* ------------------------------------------------------------------------------------------ */
/* Driven pins */

defsim_status defsim_body_set_pin_targets(defsim_world *w, defsim_body_id id,
                                          const int32_t *verts, int32_t n,
                                          const double *positions)
{
    defsim_status st = defsim__world_enter(w);
    if (st != DEFSIM_OK) return st;
    defsim__body *b = defsim__world_body(w, id);
    if (!b) return DEFSIM_ERR_STALE_ID;
    if (n < 0 || (n > 0 && (!verts || !positions))) {
        defsim__error(w->msg, "set_pin_targets: n %d < 0, or verts or positions NULL", (int)n);
        return DEFSIM_ERR_INVALID_ARGUMENT;
    }
    for (int32_t i = 0; i < n; ++i) {
        if (verts[i] < 0 || verts[i] >= b->nv) {
            defsim__error(w->msg, "set_pin_targets: vertex %d (entry %d) out of range [0, %d)",
                          (int)verts[i], (int)i, (int)b->nv);
            return DEFSIM_ERR_INVALID_ARGUMENT;
        }
        for (int k = 0; k < 3; ++k)
            if (!isfinite(positions[3 * (int64_t)i + k])) {
                defsim__error(w->msg, "set_pin_targets: target of entry %d is not finite", (int)i);
                return DEFSIM_ERR_INVALID_ARGUMENT;
            }
    }
    if (n == 0) return DEFSIM_OK;
    if (!w->coupling.pin_target) {
        w->coupling.pin_target = malloc(3 * (size_t)w->nv * sizeof *w->coupling.pin_target);
        w->coupling.targeted = calloc((size_t)w->nv, 1);
        if (!w->coupling.pin_target || !w->coupling.targeted) {
            free(w->coupling.pin_target); free(w->coupling.targeted);
            w->coupling.pin_target = NULL;
            w->coupling.targeted = NULL;
            defsim__error(w->msg, "out of memory");
            return DEFSIM_ERR_OUT_OF_MEMORY;
        }
    }
    if ((st = defsim_body_pin(w, id, verts, n)) != DEFSIM_OK) return st;
    for (int32_t i = 0; i < n; ++i) {
        const int64_t v = (int64_t)b->offset + verts[i];
        if (!w->coupling.targeted[v]) {
            w->coupling.targeted[v] = 1;
            w->coupling.ntargeted++;
        }
        for (int k = 0; k < 3; ++k) w->coupling.pin_target[3 * v + k] = positions[3 * (int64_t)i + k];
    }
    return DEFSIM_OK;
}

/* ------------------------------------------------------------------------------------------ */
/* Attachments */

void defsim_attachment_def_init(defsim_attachment_def *def, size_t size)
{
    if (!def || size < sizeof(uint32_t)) return;
    defsim_attachment_def d;
    memset(&d, 0, sizeof d);
    d.size = (uint32_t)sizeof d;
    d.stiffness = 1e3;
    if (size > sizeof d) size = sizeof d;
    memcpy(def, &d, size);
    def->size = (uint32_t)size;
}

static defsim__attachment *attachment_or_error(const defsim_world *w, defsim_attachment_id id)
{
    const int64_t slot =
        defsim__id_pool_lookup(&w->coupling.att_ids, w->msg, "attachment", id.index, id.generation);
    return slot < 0 ? NULL : &w->coupling.att[slot];
}

static int is_null(defsim_body_id id) { return id.index == 0 && id.generation == 0; }

/* Validates the host's def into *out (defaults for fields an older def lacks). */
static defsim_status check_attachment(defsim_world *w, const defsim_attachment_def *def,
                                      defsim_attachment_def *out)
{
    if (!def || def->size < offsetof(defsim_attachment_def, damping)) {
        defsim__error(w->msg, "add_attachment: def is NULL or def->size is too small "
                      "(use defsim_attachment_def_init)");
        return DEFSIM_ERR_INVALID_ARGUMENT;
    }
    defsim_attachment_def_init(out, sizeof *out);
    memcpy(out, def, def->size < sizeof *out ? def->size : sizeof *out);
    out->size = sizeof *out;
    const defsim_attachment_def *d = out;
    const defsim__body *b = defsim__world_body(w, d->body);
    if (!b) return DEFSIM_ERR_STALE_ID;
    if (d->vertex < 0 || d->vertex >= b->nv) {
        defsim__error(w->msg, "add_attachment: vertex %d out of range [0, %d)", (int)d->vertex,
                      (int)b->nv);
        return DEFSIM_ERR_INVALID_ARGUMENT;
    }
    if (!isfinite(d->stiffness) || !(d->stiffness > 0.0) || !isfinite(d->damping) ||
        d->damping < 0.0) {
        defsim__error(w->msg, "add_attachment: stiffness %g must be finite and > 0, damping %g "
                      "finite and >= 0", d->stiffness, d->damping);
        return DEFSIM_ERR_INVALID_ARGUMENT;
    }
    if (is_null(d->target_body)) {
        if (first_non_finite(d->target, 3) >= 0) {
            defsim__error(w->msg, "add_attachment: the target point is not finite");
            return DEFSIM_ERR_INVALID_ARGUMENT;
        }
        return DEFSIM_OK;
    }
    const defsim__body *tb = defsim__world_body(w, d->target_body);
    if (!tb) return DEFSIM_ERR_STALE_ID;
    if (d->target_vertex_count < 1 || d->target_vertex_count > 4) {
        defsim__error(w->msg, "add_attachment: target_vertex_count %d must be 1..4",
                      (int)d->target_vertex_count);
        return DEFSIM_ERR_INVALID_ARGUMENT;
    }
    double sum = 0.0;
    for (int j = 0; j < d->target_vertex_count; ++j) {
        if (d->target_vertices[j] < 0 || d->target_vertices[j] >= tb->nv) {
            defsim__error(w->msg, "add_attachment: target vertex %d out of range [0, %d)",
                          (int)d->target_vertices[j], (int)tb->nv);
            return DEFSIM_ERR_INVALID_ARGUMENT;
        }
        if (!isfinite(d->target_weights[j])) {
            defsim__error(w->msg, "add_attachment: target weight %d is not finite", j);
            return DEFSIM_ERR_INVALID_ARGUMENT;
        }
        sum += d->target_weights[j];
    }
    if (!(fabs(sum - 1.0) <= 1e-9)) {
        defsim__error(w->msg, "add_attachment: target weights sum to %.17g, not 1", sum);
        return DEFSIM_ERR_INVALID_ARGUMENT;
    }
    return DEFSIM_OK;
}

defsim_status defsim_world_add_attachment(defsim_world *w, const defsim_attachment_def *def,
                                          defsim_attachment_id *out)
{
    defsim_status st = defsim__world_enter(w);
    if (st != DEFSIM_OK) return st;
    defsim_attachment_def d;
    if ((st = check_attachment(w, def, &d)) != DEFSIM_OK) return st;
    if (is_null(d.target_body)) d.target_vertex_count = 0;
    int32_t slot;
    defsim__attachment *att = defsim__id_pool_add(&w->coupling.att_ids, w->msg, "attachments",
                                                  w->coupling.att, sizeof *att, &w->coupling.natt,
                                                  &w->coupling.cap_att, &slot);
    if (!att) return DEFSIM_ERR_OUT_OF_MEMORY;
    w->coupling.att = att;
    defsim__attachment *a = &w->coupling.att[slot];
    a->generation = defsim__id_pool_take(&w->coupling.att_ids, slot, slot);
    a->def = d;
    defsim__world_invalidate(w);
    if (out) {
        out->index = defsim__id_pool_index(&w->coupling.att_ids, slot);
        out->generation = a->generation;
    }
    return DEFSIM_OK;
}

defsim_status defsim_world_remove_attachment(defsim_world *w, defsim_attachment_id id)
{
    defsim_status st = defsim__world_enter(w);
    if (st != DEFSIM_OK) return st;
    defsim__attachment *a = attachment_or_error(w, id);
    if (!a) return DEFSIM_ERR_STALE_ID;
    defsim__id_pool_remove(&w->coupling.att_ids, (int32_t)(a - w->coupling.att), &a->generation);
    defsim__world_invalidate(w);
    return DEFSIM_OK;
}

defsim_status defsim_attachment_set_target(defsim_world *w, defsim_attachment_id id,
                                           const double target[3])
{
    defsim_status st = defsim__world_enter(w);
    if (st != DEFSIM_OK) return st;
    defsim__attachment *a = attachment_or_error(w, id);
    if (!a) return DEFSIM_ERR_STALE_ID;
    if (!target || first_non_finite(target, 3) >= 0) {
        defsim__error(w->msg, "attachment_set_target: target is NULL or not finite");
        return DEFSIM_ERR_INVALID_ARGUMENT;
    }
    for (int k = 0; k < 3; ++k) a->def.target[k] = target[k];
    if (!is_null(a->def.target_body)) {
        /* From a body's element to a world point: a change of the pattern. */
        a->def.target_body = (defsim_body_id){0, 0};
        a->def.target_vertex_count = 0;
        defsim__world_invalidate(w);
        return DEFSIM_OK;
    }
    if (w->planned) {
        /* The compiled attachments are the live ones in slot order. */
        int32_t e = 0;
        for (const defsim__attachment *o = w->coupling.att; o < a; ++o) e += (o->generation & 1u) != 0;
        defsim__watchdog_attachment_moved(&w->wd, &w->sys, e, w->state.x, target);
        for (int k = 0; k < 3; ++k) w->sys.att.p[3 * (int64_t)e + k] = target[k];
    }
    return DEFSIM_OK;
}

/* ------------------------------------------------------------------------------------------ */
/* Read-back */

defsim_status defsim_world_get_attachment(const defsim_world *w, defsim_attachment_id id,
                                         defsim_attachment_def *out)
{
    if (!defsim__world_live(w)) return DEFSIM_ERR_INVALID_ARGUMENT;
    if (!out || out->size < sizeof *out) {
        defsim__error(w->msg, "get_attachment: out is NULL or its size is not "
                              "sizeof(defsim_attachment_def)");
        return DEFSIM_ERR_INVALID_ARGUMENT;
    }
    const defsim__attachment *a = attachment_or_error(w, id);
    if (!a) return DEFSIM_ERR_STALE_ID;
    *out = a->def;
    out->size = (uint32_t)sizeof *out;
    return DEFSIM_OK;
}

defsim_status defsim_world_get_attachment_force(const defsim_world *w, defsim_attachment_id id,
                                                double out[3])
{
    if (!defsim__world_live(w)) return DEFSIM_ERR_INVALID_ARGUMENT;
    if (!out) {
        defsim__error(w->msg, "get_attachment_force: out is NULL");
        return DEFSIM_ERR_INVALID_ARGUMENT;
    }
    const defsim__attachment *a = attachment_or_error(w, id);
    if (!a) return DEFSIM_ERR_STALE_ID;
    const defsim_attachment_def *d = &a->def;
    const int64_t v = (int64_t)defsim__world_find_body(w, d->body)->offset + d->vertex;
    double dx[3], dv[3];
    for (int k = 0; k < 3; ++k) {
        dx[k] = w->state.x[3 * v + k] - d->target[k] * (d->target_vertex_count == 0);
        dv[k] = w->state.v[3 * v + k];
    }
    for (int j = 0; j < d->target_vertex_count; ++j) {
        const int64_t t = (int64_t)defsim__world_find_body(w, d->target_body)->offset +
                          d->target_vertices[j];
        for (int k = 0; k < 3; ++k) {
            dx[k] -= d->target_weights[j] * w->state.x[3 * t + k];
            dv[k] -= d->target_weights[j] * w->state.v[3 * t + k];
        }
    }
    for (int k = 0; k < 3; ++k) out[k] = -d->stiffness * dx[k] - d->damping * dv[k];
    return DEFSIM_OK;
}

defsim_status defsim_world_get_pin_forces(defsim_world *w, double *out, int32_t n)
{
    defsim_status st = defsim__world_enter(w);   /* it calls the force callback */
    if (st != DEFSIM_OK) return st;
    if (!out || n != w->nv) {
        defsim__error(w->msg, "get_pin_forces: out is NULL or n = %d but the world has %d "
                      "vertices", (int)n, (int)w->nv);
        return DEFSIM_ERR_INVALID_ARGUMENT;
    }
    st = defsim__world_plan(w);
    if (st != DEFSIM_OK) return st;
    const int64_t ndof = 3 * (int64_t)n;
    /* Without pins the answer is zero, but a force callback still runs and may fail (the
     * header's Errors line): only a world without one skips the evaluation. */
    if (!w->sys.has_pins && !w->coupling.cpl.fn) {
        memset(out, 0, (size_t)ndof * sizeof *out);
        return DEFSIM_OK;
    }
    double *f = malloc((size_t)ndof * sizeof *f);
    if (!f) {
        defsim__error(w->msg, "out of memory");
        return DEFSIM_ERR_OUT_OF_MEMORY;
    }
    uint32_t passes = 0;
    uint32_t *saved = w->handle.passes;
    w->handle.passes = &passes;   /* a read-back is not a step: leave the step's passes alone */
    st = defsim__host_forces(&w->handle, w->state.x, w->state.v, w->state.t,
                             DEFSIM_FORCE_ALL | DEFSIM__FORCE_KEEP_PINNED, f);
    w->handle.passes = saved;
    w->coupling.cpl.failed = 0;
    if (st == DEFSIM_OK)
        for (int64_t i = 0; i < ndof; ++i) out[i] = w->bodies.pinned[i / 3] ? -f[i] : 0.0;
    else if (st != DEFSIM_ERR_CALLBACK)
        defsim__error(w->msg, "get_pin_forces: the forces are not finite");
    free(f);
    return st;
}

/* Tet t's stress sigma and energy density psi into the read-back's outputs (each may be NULL),
 * with the von Mises value of sigma (NaN where sigma is). */
static void stress_out(const double sigma[9], double psi, int32_t t, double *cauchy,
                       double *von_mises, double *energy_density)
{
    double vm = NAN;
    if (!isnan(sigma[0])) {
        const double p = (sigma[0] + sigma[4] + sigma[8]) / 3.0;
        double ss = 0.0;
        for (int i = 0; i < 3; ++i)
            for (int j = 0; j < 3; ++j) {
                const double s = sigma[3 * i + j] - (i == j ? p : 0.0);
                ss += s * s;
            }
        vm = sqrt(1.5 * ss);
    }
    if (cauchy) memcpy(cauchy + 9 * (int64_t)t, sigma, 9 * sizeof *sigma);
    if (von_mises) von_mises[t] = vm;
    if (energy_density) energy_density[t] = psi;
}

defsim_status defsim_body_element_stress(const defsim_world *w, defsim_body_id id,
                                         double *cauchy, double *von_mises,
                                         double *energy_density, int32_t tet_count)
{
    if (!defsim__world_live(w)) return DEFSIM_ERR_INVALID_ARGUMENT;
    const defsim__body *b = defsim__world_body(w, id);
    if (!b) return DEFSIM_ERR_STALE_ID;
    if (tet_count != b->nt) {
        defsim__error(w->msg, "element_stress: tet_count = %d but the body has %d tets",
                      (int)tet_count, (int)b->nt);
        return DEFSIM_ERR_INVALID_ARGUMENT;
    }
    const double *x = w->state.x + 3 * (int64_t)b->offset;
    const defsim__model *model = defsim__model_find(b->mat.model);
    for (int32_t t = 0; t < b->nt && model && b->tet_nodes == 10; ++t) {
        const int32_t *tt = b->tets + 10 * (int64_t)t;
        double rest[DEFSIM__TET10_REST], sigma[9], psi;
        (void)defsim__tet10_rest(b->rest, tt, rest);
        defsim__tet10_stress(model, b->mu, b->lambda, b->volume_averaging, x, tt, rest, sigma,
                             &psi);
        stress_out(sigma, psi, t, cauchy, von_mises, energy_density);
    }
    /* Volume-averaged tets: each vertex's volume ratio J_n (rest and current nodal volumes in
     * jn[2 v], jn[2 v + 1]), for the tets' averaged pressures and volumetric energies. */
    const defsim__model_split *split =
        b->volume_averaging && b->tet_nodes == 4 && model ? model->split : NULL;
    double *jn = split && b->nt > 0 ? calloc(2 * (size_t)b->nv, sizeof *jn) : NULL;
    if (split && b->nt > 0 && !jn) {
        defsim__error(w->msg, "element_stress: out of memory");
        return DEFSIM_ERR_OUT_OF_MEMORY;
    }
    for (int pass = jn ? 0 : 1; pass < 2; ++pass)
    for (int32_t t = 0; t < b->nt && model && b->tet_nodes == 4; ++t) {
        const int32_t *tt = b->tets + 4 * (int64_t)t;
        double dm[9], dminv[9], F[9], P[9];
        const double *p3 = b->rest + 3 * (int64_t)tt[3];
        for (int a = 0; a < 3; ++a)
            for (int i = 0; i < 3; ++i) dm[3 * i + a] = b->rest[3 * (int64_t)tt[a] + i] - p3[i];
        const double vol = fabs(defsim__m3_inverse(dm, dminv)) / 6.0;
        tet_deformation(x, tt, dminv, F);
        const double J = defsim__m3_det(F);
        if (pass == 0) {
            for (int a = 0; a < 4; ++a) {
                jn[2 * (int64_t)tt[a]] += 0.25 * vol;
                jn[2 * (int64_t)tt[a] + 1] += 0.25 * vol * J;
            }
            continue;
        }
        double psi = INFINITY;
        if (split) {
            /* the element's isochoric stress plus its averaged nodal pressure; its energy
             * density the isochoric one plus the mean of its vertices' U(J_n) */
            double pe = 0.0, ue = 0.0, C[9];
            for (int a = 0; a < 4; ++a) {
                double u[3];
                split->U(b->mu, b->lambda, jn[2 * (int64_t)tt[a] + 1] / jn[2 * (int64_t)tt[a]], u);
                pe += 0.25 * u[1];
                ue += 0.25 * u[0];
            }
            psi = split->P(b->mu, b->lambda, F, P) + ue;
            if (model->psi_rest) psi -= model->psi_rest(b->mu, b->lambda);
            defsim__m3_cofactor(F, C);
            for (int i = 0; i < 9; ++i) P[i] += pe * C[i];
        } else if (!(model->needs_positive_det && !(J > 0.0))) {
            psi = model->P(b->mu, b->lambda, F, P);
            if (model->psi_rest) psi -= model->psi_rest(b->mu, b->lambda);
        }
        double sigma[9];
        const int defined = J != 0.0 && isfinite(psi);
        for (int i = 0; i < 3; ++i)
            for (int j = 0; j < 3; ++j)
                sigma[3 * i + j] = defined ? (P[3 * i] * F[3 * j] + P[3 * i + 1] * F[3 * j + 1] +
                                              P[3 * i + 2] * F[3 * j + 2]) / J
                                           : NAN;
        stress_out(sigma, psi, t, cauchy, von_mises, energy_density);
    }
    free(jn);
    return DEFSIM_OK;
}
