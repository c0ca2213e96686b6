/* SPDX-License-Identifier: MIT */
/*
 * Bodies as the host gives them (body.h): defaults, validation of a defsim_body_def (counts,
 * material, finite coordinates, indices, rest shapes, masses, spring stiffnesses) and the body
 * built from it (arrays copied, tets reordered to positive orientation, lumped masses, contact
 * edges of a rope). The world (world.c) only finds the body an id and its vertices a place.
 */
#include "body.h"

#include "material.h"
#include "tet10.h"
#include "tet_rest.h"

#include <math.h>
#include <stddef.h>
#include <stdlib.h>
#include <string.h>

void defsim_body_def_init(defsim_body_def *def, size_t size)
{
    if (!def || size < sizeof(uint32_t)) return;
    defsim_body_def d;
    memset(&d, 0, sizeof d);
    d.size = (uint32_t)sizeof d;
    defsim_material_init(&d.material, sizeof d.material, DEFSIM_MODEL_STABLE_NEOHOOKEAN);
    d.shear_stiffness = d.bend_stiffness = -1.0;
    d.self_contact = 1;
    d.collision_group = 1u;
    d.collision_mask = 0xFFFFFFFFu;
    d.friction = 0.5;
    d.tet_nodes = 4;
    if (size > sizeof d) size = sizeof d;
    memcpy(def, &d, size);
    def->size = (uint32_t)size;
}

void defsim__body_free(defsim__body *b)
{
    free(b->rest); free(b->mass); free(b->tets); free(b->springs); free(b->k); free(b->pinned);
    free(b->tris); free(b->edges);
    b->rest = b->mass = b->k = NULL;
    b->tets = b->springs = b->tris = b->edges = NULL;
    b->pinned = NULL;
}

static defsim_status validate_array(defsim__messages *msg, const double *a, int64_t n, const char *what)
{
    for (int64_t i = 0; i < n; ++i)
        if (!isfinite(a[i])) {
            defsim__error(msg, "%s: vertex %lld coordinate %d is not finite", what,
                          (long long)(i / 3), (int)(i % 3));
            return DEFSIM_ERR_INVALID_MESH;
        }
    return DEFSIM_OK;
}

defsim_status defsim__body_build(defsim__messages *msg, const defsim_body_def *def,
                                 int32_t world_nv, defsim_body_def *dout, defsim__body *out,
                                 int32_t *reordered_out)
{
    memset(out, 0, sizeof *out);
    defsim_status st;
    if (!def || def->size < offsetof(defsim_body_def, material) + sizeof(uint32_t)) {
        defsim__error(msg, "add_body: def is NULL or def->size is too small "
                              "(use defsim_body_def_init)");
        return DEFSIM_ERR_INVALID_ARGUMENT;
    }
    defsim_body_def d;
    defsim_body_def_init(&d, sizeof d);
    memcpy(&d, def, def->size < sizeof d ? def->size : sizeof d);
    if (d.material.size < offsetof(defsim_material, youngs_modulus)) {
        defsim__error(msg, "add_body: material.size %u is too small (use "
                              "defsim_material_init)", (unsigned)d.material.size);
        return DEFSIM_ERR_INVALID_ARGUMENT;
    }
    if (d.material.size < sizeof d.material) {
        /* An older material struct: keep the defaults for fields it lacks. */
        defsim_material m;
        defsim_material_init(&m, sizeof m, d.material.model);
        memcpy(&m, &def->material, d.material.size);
        m.size = sizeof m;
        d.material = m;
    }
    if (!d.rest_positions || d.vertex_count < 1 || d.tet_count < 0 || d.spring_count < 0 ||
        (d.tet_count > 0 && !d.tets) || (d.spring_count > 0 && !d.springs)) {
        defsim__error(msg, "add_body: needs rest_positions, vertex_count >= 1, and arrays "
                              "for non-zero tet_count / spring_count");
        return DEFSIM_ERR_INVALID_ARGUMENT;
    }
    if (d.tet_nodes != 4 && d.tet_nodes != 10) {
        defsim__error(msg, "add_body: tet_nodes %d must be 4 (linear tets) or 10 (quadratic tets)",
                      (int)d.tet_nodes);
        return DEFSIM_ERR_INVALID_ARGUMENT;
    }
    if (d.vertex_count > (INT32_MAX - world_nv) / 3 || d.tet_count > INT32_MAX / 40 ||
        d.spring_count > INT32_MAX / 4) {
        defsim__error(msg, "add_body: counts too large");
        return DEFSIM_ERR_INVALID_ARGUMENT;
    }
    char why[256];
    st = defsim__material_check(&d.material, d.tet_count > 0, d.spring_count > 0, why,
                                sizeof why);
    if (st != DEFSIM_OK) {
        defsim__error(msg, "add_body: %s", why);
        return st;
    }
    if (d.spring_kinds && d.spring_stiffness) {
        defsim__error(msg, "add_body: give spring_stiffness or spring_kinds, not both");
        return DEFSIM_ERR_INVALID_ARGUMENT;
    }
    if (d.triangle_count < 0 || d.triangle_count > INT32_MAX / 6 ||
        (d.triangle_count > 0 && !d.triangles) || (d.self_contact != 0 && d.self_contact != 1)) {
        defsim__error(msg, "add_body: triangle_count %d must be >= 0 (with triangles for a "
                              "non-zero count) and self_contact %d 0 or 1",
                      (int)d.triangle_count, (int)d.self_contact);
        return DEFSIM_ERR_INVALID_ARGUMENT;
    }
    if (!isfinite(d.friction) || d.friction < 0.0 || d.friction > 10.0) {
        defsim__error(msg, "add_body: friction %g must be in [0, 10]", d.friction);
        return DEFSIM_ERR_INVALID_MATERIAL;
    }
    if (d.volume_averaging != 0 && d.volume_averaging != 1) {
        defsim__error(msg, "add_body: volume_averaging %d must be 0 or 1",
                      (int)d.volume_averaging);
        return DEFSIM_ERR_INVALID_MATERIAL;
    }
    if (d.volume_averaging && d.tet_nodes == 10) {
        defsim__error(msg, "add_body: volume_averaging is for linear tets; quadratic tets "
                           "(tet_nodes 10) do not lock and have no averaged element");
        return DEFSIM_ERR_INVALID_MATERIAL;
    }
    if (d.volume_averaging && d.tet_count > 0) {
        const defsim__model *law = defsim__model_find(d.material.model);
        if (!law || !law->split) {
            defsim__error(msg, "add_body: volume_averaging needs a model whose volumetric energy "
                               "depends on J alone (neohookean, stable_neohookean); %s has no "
                               "such split", law ? law->name : "this model");
            return DEFSIM_ERR_INVALID_MATERIAL;
        }
    }
    const int32_t nv = d.vertex_count, nt = d.tet_count, ns = d.spring_count;
    st = validate_array(msg, d.rest_positions, 3 * (int64_t)nv, "rest_positions");
    if (st == DEFSIM_OK && d.initial_positions)
        st = validate_array(msg, d.initial_positions, 3 * (int64_t)nv, "initial_positions");
    if (st == DEFSIM_OK && d.initial_velocities)
        st = validate_array(msg, d.initial_velocities, 3 * (int64_t)nv, "initial_velocities");
    if (st != DEFSIM_OK) return st;

    defsim__body b;
    memset(&b, 0, sizeof b);
    const int tn = d.tet_nodes;
    b.nv = nv; b.nt = nt; b.ns = ns;
    b.tet_nodes = tn;
    b.mat = d.material;
    b.self_contact = d.self_contact;
    b.group = d.collision_group;
    b.mask = d.collision_mask;
    b.friction = d.friction;
    b.volume_averaging = d.volume_averaging;
    /* Contact edges of a rope: its stretch springs (all springs without kinds). */
    int32_t nedge = 0;
    if (nt == 0 && d.triangle_count == 0)
        for (int32_t s = 0; s < ns; ++s)
            nedge += !d.spring_kinds || d.spring_kinds[s] == DEFSIM_SPRING_STRETCH;
    b.ntri = d.triangle_count;
    b.nedge = nedge;
    if (b.ntri > 0) b.tris = malloc(3 * (size_t)b.ntri * sizeof *b.tris);
    if (nedge > 0) b.edges = malloc(2 * (size_t)nedge * sizeof *b.edges);
    b.rest = malloc(3 * (size_t)nv * sizeof *b.rest);
    b.mass = calloc((size_t)nv, sizeof *b.mass);
    b.pinned = calloc((size_t)nv, 1);
    b.tets = malloc((size_t)(nt > 0 ? nt : 1) * tn * sizeof *b.tets);
    b.springs = malloc((size_t)(ns > 0 ? ns : 1) * 2 * sizeof *b.springs);
    b.k = malloc((size_t)(ns > 0 ? ns : 1) * sizeof *b.k);
    if (!b.rest || !b.mass || !b.pinned || !b.tets || !b.springs || !b.k ||
        (b.ntri > 0 && !b.tris) || (nedge > 0 && !b.edges)) {
        defsim__body_free(&b);
        defsim__error(msg, "out of memory");
        return DEFSIM_ERR_OUT_OF_MEMORY;
    }
    memcpy(b.rest, d.rest_positions, 3 * (size_t)nv * sizeof *b.rest);
    if (nt > 0) {
        memcpy(b.tets, d.tets, (size_t)tn * nt * sizeof *b.tets);
        defsim__lame(b.mat.youngs_modulus, b.mat.poisson_ratio, &b.mu, &b.lambda);
    }
    if (ns > 0) memcpy(b.springs, d.springs, 2 * (size_t)ns * sizeof *b.springs);
    if (b.ntri > 0) memcpy(b.tris, d.triangles, 3 * (size_t)b.ntri * sizeof *b.tris);
    for (int32_t s = 0, e = 0; e < nedge; ++s)
        if (!d.spring_kinds || d.spring_kinds[s] == DEFSIM_SPRING_STRETCH) {
            b.edges[2 * (int64_t)e] = d.springs[2 * (int64_t)s];
            b.edges[2 * (int64_t)e + 1] = d.springs[2 * (int64_t)s + 1];
            ++e;
        }

    int32_t reordered = 0;
    st = DEFSIM_ERR_INVALID_MESH;
    for (int32_t t = 0; t < nt; ++t) {
        int32_t *tt = b.tets + tn * (int64_t)t;
        for (int a = 0; a < tn; ++a) {
            if (tt[a] < 0 || tt[a] >= nv) {
                defsim__error(msg, "add_body: tet %d vertex %d index %d out of range [0, %d)",
                                    (int)t, a, (int)tt[a], (int)nv);
                goto fail;
            }
            for (int c = 0; c < a; ++c)
                if (tt[c] == tt[a]) {
                    defsim__error(msg, "add_body: tet %d repeats vertex %d", (int)t, (int)tt[a]);
                    goto fail;
                }
        }
        defsim__tet_rest rest;
        if (defsim__tet_rest_eval(b.rest, tt, &rest, NULL)) {
            defsim__error(msg, "add_body: tet %d is degenerate (volume %g, longest edge %g)",
                          (int)t, rest.det / 6.0, rest.longest_edge);
            goto fail;
        }
        const double det = rest.det;
        if (det < 0.0) {
            if (tn == 10) {
                defsim__tet10_flip(tt);
            } else {
                int32_t tmp = tt[0]; tt[0] = tt[1]; tt[1] = tmp;
            }
            ++reordered;
        }
        if (tn == 10) {
            const double r = defsim__tet10_min_jacobian(b.rest, tt);
            if (!(r > DEFSIM__TET10_MIN_JACOBIAN)) {
                defsim__error(msg, "add_body: quadratic tet %d is degenerate or inverted by its "
                                   "mid-edge nodes (Jacobian determinant down to %g of its "
                                   "corners' tet; needs > %g everywhere)",
                              (int)t, r, DEFSIM__TET10_MIN_JACOBIAN);
                goto fail;
            }
            defsim__tet10_mass(b.rest, tt, b.mat.density, b.mass);
            continue;
        }
        const double m4 = b.mat.density * fabs(det) / 24.0;
        for (int a = 0; a < 4; ++a) b.mass[tt[a]] += m4;
    }
    for (int32_t s = 0; s < ns; ++s) {
        const int32_t a = b.springs[2 * (int64_t)s], c = b.springs[2 * (int64_t)s + 1];
        if (a < 0 || a >= nv || c < 0 || c >= nv) {
            defsim__error(msg, "add_body: spring %d index out of range [0, %d)", (int)s, (int)nv);
            goto fail;
        }
        const double *pa = b.rest + 3 * (int64_t)a, *pc = b.rest + 3 * (int64_t)c;
        double l = sqrt((pa[0] - pc[0]) * (pa[0] - pc[0]) + (pa[1] - pc[1]) * (pa[1] - pc[1]) +
                        (pa[2] - pc[2]) * (pa[2] - pc[2]));
        if (a == c || !(l > 0.0)) {
            defsim__error(msg, "add_body: spring %d has zero rest length", (int)s);
            goto fail;
        }
        double k = d.spring_stiffness ? d.spring_stiffness[s] : b.mat.stiffness;
        if (d.spring_kinds) {
            const int32_t kind = d.spring_kinds[s];
            if (kind < DEFSIM_SPRING_STRETCH || kind > DEFSIM_SPRING_BEND) {
                defsim__error(msg, "add_body: spring %d has kind %d (not a defsim_spring_kind)",
                              (int)s, (int)kind);
                st = DEFSIM_ERR_INVALID_MESH;
                goto fail;
            }
            const double by_kind = kind == DEFSIM_SPRING_SHEAR ? d.shear_stiffness
                                   : kind == DEFSIM_SPRING_BEND ? d.bend_stiffness : -1.0;
            if (by_kind >= 0.0 || isnan(by_kind)) k = by_kind;
        }
        if (!isfinite(k) || k < 0.0) {
            defsim__error(msg, "add_body: spring %d stiffness %g must be finite and >= 0",
                          (int)s, k);
            st = DEFSIM_ERR_INVALID_MATERIAL;
            goto fail;
        }
        b.k[s] = k;
    }
    for (int32_t t = 0; t < b.ntri; ++t) {
        const int32_t *tt = b.tris + 3 * (int64_t)t;
        if (tt[0] < 0 || tt[0] >= nv || tt[1] < 0 || tt[1] >= nv || tt[2] < 0 || tt[2] >= nv ||
            tt[0] == tt[1] || tt[1] == tt[2] || tt[0] == tt[2]) {
            defsim__error(msg, "add_body: triangle %d (%d %d %d) has an index out of range "
                                  "[0, %d) or repeats a vertex", (int)t, (int)tt[0], (int)tt[1],
                          (int)tt[2], (int)nv);
            st = DEFSIM_ERR_INVALID_MESH;
            goto fail;
        }
    }
    for (int32_t i = 0; i < nv; ++i) {
        double m = d.vertex_mass ? d.vertex_mass[i] : b.mass[i] + b.mat.vertex_mass;
        if (!isfinite(m) || !(m > 0.0)) {
            defsim__error(msg, "add_body: vertex %d has mass %g (needs a positive mass: "
                                  "give vertex_mass, or put it in a tet with density > 0)",
                          (int)i, m);
            st = d.vertex_mass ? DEFSIM_ERR_INVALID_MATERIAL : DEFSIM_ERR_INVALID_MESH;
            goto fail;
        }
        b.mass[i] = m;
    }
    *dout = d;
    b.mass_given = d.vertex_mass != NULL;
    *out = b;
    *reordered_out = reordered;
    return DEFSIM_OK;
fail:
    defsim__body_free(&b);
    return st;
}

/* ------------------------------------------------------------------------------------------ */
/* Checkpoint chunk */

void defsim__body_save(defsim__bw *b, const defsim__body *body, uint32_t saved)
{
    const size_t c = defsim__chunk_begin(b, "BODY");
    defsim__put_u32(b, saved);   /* the attachments that name it use this */
    defsim__put_u32(b, body->generation);
    defsim__put_i32(b, body->nv);
    defsim__put_i32(b, body->nt);
    defsim__put_i32(b, body->ns);
    defsim__put_i32(b, body->tet_nodes);   /* version 8: quadratic tets */
    const defsim_material *m = &body->mat;
    defsim__put_i32(b, (int32_t)m->model);
    const double mp[7] = {m->youngs_modulus, m->poisson_ratio, m->density, m->stiffness,
                          m->vertex_mass, m->mass_damping, m->stiffness_damping};
    defsim__put_f64s(b, mp, 7);
    defsim__put_f64s(b, body->rest, 3 * (int64_t)body->nv);
    defsim__put_f64s(b, body->mass, body->nv);
    defsim__put_i32s(b, body->tets, (int64_t)body->tet_nodes * body->nt);
    defsim__put_i32s(b, body->springs, 2 * (int64_t)body->ns);
    defsim__put_f64s(b, body->k, body->ns);
    defsim__put(b, body->pinned, (size_t)body->nv);
    /* version 4: body contact */
    defsim__put_i32(b, body->ntri);
    defsim__put_i32(b, body->nedge);
    defsim__put_i32s(b, body->tris, 3 * (int64_t)body->ntri);
    defsim__put_i32s(b, body->edges, 2 * (int64_t)body->nedge);
    defsim__put_i32(b, body->self_contact);
    defsim__put_u32(b, body->group);
    defsim__put_u32(b, body->mask);
    defsim__put_f64(b, body->friction);
    /* version 7: volume averaging */
    defsim__put_i32(b, body->volume_averaging);
    defsim__chunk_end(b, c);
}

void defsim__body_saved_free(defsim__body_saved *s)
{
    free(s->rest); free(s->mass); free(s->k); free(s->tets);
    free(s->springs); free(s->tris); free(s->pins); free(s->edges);
    memset(s, 0, sizeof *s);
}

defsim_status defsim__body_read(defsim__br *r, uint32_t version, defsim__body_saved *out,
                                const char **why)
{
    memset(out, 0, sizeof *out);
    out->id = defsim__get_u32(r);
    out->generation = defsim__get_u32(r);
    const int32_t nv = defsim__get_i32(r), nt = defsim__get_i32(r), ns = defsim__get_i32(r);
    const int32_t tn = version >= 8 ? defsim__get_i32(r) : 4;   /* indices per tet */
    defsim_body_def *d = &out->def;
    defsim_body_def_init(d, sizeof *d);
    d->material.model = (defsim_model)defsim__get_i32(r);
    double mp[7];
    defsim__get_f64s(r, mp, 7);
    d->material.youngs_modulus = mp[0];
    d->material.poisson_ratio = mp[1];
    d->material.density = mp[2];
    d->material.stiffness = mp[3];
    d->material.vertex_mass = mp[4];
    d->material.mass_damping = mp[5];
    d->material.stiffness_damping = mp[6];
    /* Each vertex takes 4 doubles and a byte, each tet 4 tn bytes, each spring 16. */
    if (nv < 1 || nt < 0 || ns < 0 || (tn != 4 && tn != 10) || !defsim__fits(r, nv, 33) ||
        !defsim__fits(r, nt, 4 * (size_t)(tn == 10 ? 10 : 4)) || !defsim__fits(r, ns, 16)) {
        *why = "counts out of range";
        return DEFSIM_ERR_IO;
    }
    out->rest = malloc(3 * (size_t)nv * sizeof *out->rest);
    out->mass = malloc((size_t)nv * sizeof *out->mass);
    out->tets = malloc(((size_t)(tn == 10 ? 10 : 4) * nt + 1) * sizeof *out->tets);
    out->springs = malloc((2 * (size_t)ns + 1) * sizeof *out->springs);
    out->k = malloc(((size_t)ns + 1) * sizeof *out->k);
    out->pins = malloc((size_t)nv * sizeof *out->pins);
    if (!out->rest || !out->mass || !out->tets || !out->springs || !out->k || !out->pins)
        return DEFSIM_ERR_OUT_OF_MEMORY;
    defsim__get_f64s(r, out->rest, 3 * (int64_t)nv);
    defsim__get_f64s(r, out->mass, nv);
    defsim__get_i32s(r, out->tets, (int64_t)tn * nt);
    defsim__get_i32s(r, out->springs, 2 * (int64_t)ns);
    defsim__get_f64s(r, out->k, ns);
    const unsigned char *pinned = defsim__take(r, (size_t)nv);
    for (int32_t i = 0; pinned && i < nv; ++i)
        if (pinned[i]) out->pins[out->npin++] = i;
    /* Body contact (version 4); older files get the defaults. */
    if (version >= 4) {
        const int32_t ntri = defsim__get_i32(r), nedge = defsim__get_i32(r);
        if (ntri < 0 || nedge < 0 || !defsim__fits(r, ntri, 12) || !defsim__fits(r, nedge, 8)) {
            *why = "counts out of range";
            return DEFSIM_ERR_IO;
        }
        out->tris = malloc((3 * (size_t)ntri + 1) * sizeof *out->tris);
        out->edges = malloc((2 * (size_t)nedge + 1) * sizeof *out->edges);
        if (!out->tris || !out->edges) return DEFSIM_ERR_OUT_OF_MEMORY;
        defsim__get_i32s(r, out->tris, 3 * (int64_t)ntri);
        defsim__get_i32s(r, out->edges, 2 * (int64_t)nedge);
        out->nedge = nedge;
        d->self_contact = defsim__get_i32(r);
        d->collision_group = defsim__get_u32(r);
        d->collision_mask = defsim__get_u32(r);
        d->friction = defsim__get_f64(r);
        d->triangles = ntri > 0 ? out->tris : NULL;
        d->triangle_count = ntri;
    }
    /* Volume averaging (version 7); older files: the standard element. */
    if (version >= 7) d->volume_averaging = defsim__get_i32(r);
    for (int32_t e = 0; e < 2 * out->nedge && !r->bad; ++e)
        if (out->edges[e] < 0 || out->edges[e] >= nv) r->bad = 1;
    if (!defsim__read_whole(r)) {
        *why = "wrong length";
        return DEFSIM_ERR_IO;
    }
    d->rest_positions = out->rest;
    d->vertex_count = nv;
    d->tets = nt > 0 ? out->tets : NULL;
    d->tet_count = nt;
    d->tet_nodes = tn;
    d->springs = ns > 0 ? out->springs : NULL;
    d->spring_count = ns;
    d->spring_stiffness = ns > 0 ? out->k : NULL;
    d->vertex_mass = out->mass;
    return DEFSIM_OK;
}
