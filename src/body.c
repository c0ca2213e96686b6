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
#include "shell.h"
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
    d.shell_membrane = DEFSIM_SHELL_MEMBRANE_NONE;
    d.shell_youngs_modulus = 1e6;
    d.shell_poisson_ratio = 0.3;
    d.shell_thickness = 1e-3;
    d.shell_warp_modulus = d.shell_weft_modulus = d.shell_shear_modulus = 1e3;
    d.shell_warp_poisson = 0.0;
    d.shell_warp_direction[0] = 1.0;
    d.shell_areal_density = 0.1;
    d.shell_bending_rigidity = d.shell_bending_rigidity_weft = -1.0;
    d.shell_strain_limit = 0.0;
    if (size > sizeof d) size = sizeof d;
    memcpy(def, &d, size);
    def->size = (uint32_t)size;
}

void defsim__body_free(defsim__body *b)
{
    free(b->rest); free(b->mass); free(b->tets); free(b->springs); free(b->k); free(b->pinned);
    free(b->tris); free(b->edges);
    free(b->mrow); free(b->marea); free(b->hinges); free(b->hw); free(b->htheta0);
    b->mrow = b->marea = b->hw = b->htheta0 = NULL;
    b->hinges = NULL;
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

/* ------------------------------------------------------------------------------------------ */
/* Shells */

static int finite_pos(double v) { return isfinite(v) && v > 0.0; }
static int finite_nonneg(double v) { return isfinite(v) && v >= 0.0; }

/* The bending rigidities of a shell def: warp and weft (N m), defaults resolved. */
static void shell_rigidity(const defsim_body_def *d, double *dw, double *df)
{
    const int iso = d->shell_membrane == DEFSIM_SHELL_MEMBRANE_STVK ||
                    d->shell_membrane == DEFSIM_SHELL_MEMBRANE_NEOHOOKEAN;
    const double E = d->shell_youngs_modulus, nu = d->shell_poisson_ratio, t = d->shell_thickness;
    *dw = d->shell_bending_rigidity;
    if (*dw < 0.0) *dw = iso ? E * t * t * t / (12.0 * (1.0 - nu * nu)) : 0.0;
    *df = d->shell_bending_rigidity_weft < 0.0 ? *dw : d->shell_bending_rigidity_weft;
}

/* The shell fields of a def by the rules of defsim_body_def (the header's comment). */
static defsim_status shell_check(defsim__messages *msg, const defsim_body_def *d)
{
    const int32_t m = d->shell_membrane;
    if (m < DEFSIM_SHELL_MEMBRANE_NONE || m > DEFSIM_SHELL_MEMBRANE_ORTHOTROPIC_STVK) {
        defsim__error(msg, "add_body: shell_membrane %d is not a defsim_shell_membrane", (int)m);
        return DEFSIM_ERR_INVALID_MATERIAL;
    }
    const char *bad = NULL;
    if (m == DEFSIM_SHELL_MEMBRANE_STVK || m == DEFSIM_SHELL_MEMBRANE_NEOHOOKEAN) {
        if (!finite_pos(d->shell_youngs_modulus)) bad = "shell_youngs_modulus must be finite and > 0";
        else if (!(d->shell_poisson_ratio >= 0.0 && d->shell_poisson_ratio < 0.5))
            bad = "shell_poisson_ratio must be in [0, 0.5)";
        else if (!finite_pos(d->shell_thickness)) bad = "shell_thickness must be finite and > 0";
    } else if (m == DEFSIM_SHELL_MEMBRANE_ORTHOTROPIC_STVK) {
        if (!finite_pos(d->shell_warp_modulus) || !finite_pos(d->shell_weft_modulus) ||
            !finite_pos(d->shell_shear_modulus))
            bad = "shell_warp_modulus, shell_weft_modulus and shell_shear_modulus must be finite "
                  "and > 0";
        else if (!finite_nonneg(d->shell_warp_poisson) ||
                 !(d->shell_warp_poisson * d->shell_warp_poisson * d->shell_weft_modulus <
                   d->shell_warp_modulus))
            bad = "shell_warp_poisson must be >= 0 with nu12^2 weft / warp < 1";
    }
    const double *w = d->shell_warp_direction;
    if (!bad && (!isfinite(w[0]) || !isfinite(w[1]) || !isfinite(w[2]) ||
                 !(w[0] * w[0] + w[1] * w[1] + w[2] * w[2] > 0.0)))
        bad = "shell_warp_direction must be finite and not zero";
    if (!bad && !finite_nonneg(d->shell_areal_density))
        bad = "shell_areal_density must be finite and >= 0";
    if (!bad && (!isfinite(d->shell_bending_rigidity) || !isfinite(d->shell_bending_rigidity_weft)))
        bad = "shell_bending_rigidity and shell_bending_rigidity_weft must be finite";
    if (bad) {
        defsim__error(msg, "add_body: %s", bad);
        return DEFSIM_ERR_INVALID_MATERIAL;
    }
    return DEFSIM_OK;
}

/* The initial positions of a body with a strain limit: every triangle below its cap. */
static defsim_status limit_check(defsim__messages *msg, const defsim_body_def *d,
                                 const defsim__body *b)
{
    for (int32_t t = 0; t < b->ntri; ++t) {
        const int32_t *v = b->tris + 3 * (int64_t)t;
        double X[9], row[DEFSIM__MEMBRANE_WIDTH];
        for (int a = 0; a < 3; ++a)
            memcpy(X + 3 * a, d->initial_positions + 3 * (int64_t)v[a], 3 * sizeof *X);
        defsim__strain_limit_row(b->membrane, b->mrow + DEFSIM__MEMBRANE_WIDTH * (int64_t)t,
                                 b->strain_limit, row);
        int active;
        if (!isfinite(defsim__strain_limit_element(row, b->marea[t], X, NULL, NULL, 0, &active))) {
            defsim__error(msg, "add_body: initial_positions stretch shell triangle %d to or over "
                               "its strain limit %g", (int)t, b->strain_limit);
            return DEFSIM_ERR_INVALID_ARGUMENT;
        }
    }
    return DEFSIM_OK;
}

typedef struct edge_ref { uint64_t key; int32_t tri, opp; } edge_ref;

static int edge_cmp(const void *pa, const void *pb)
{
    const edge_ref *a = pa, *b = pb;
    if (a->key != b->key) return a->key < b->key ? -1 : 1;
    return a->tri < b->tri ? -1 : a->tri > b->tri;
}

/* The shell of b (its triangles copied and checked): membrane rows, hinges, lumped masses. */
static defsim_status shell_build(defsim__messages *msg, const defsim_body_def *d, defsim__body *b)
{
    const int32_t nt = b->ntri;
    const int need_warp = d->shell_membrane == DEFSIM_SHELL_MEMBRANE_ORTHOTROPIC_STVK;
    double dw, df, prm[4];
    shell_rigidity(d, &dw, &df);
    b->membrane = defsim__membrane_params(d->shell_membrane, d->shell_youngs_modulus,
                                          d->shell_poisson_ratio, d->shell_thickness,
                                          d->shell_warp_modulus, d->shell_weft_modulus,
                                          d->shell_shear_modulus, d->shell_warp_poisson, prm);
    b->mrow = malloc((size_t)nt * DEFSIM__MEMBRANE_WIDTH * sizeof *b->mrow);
    b->marea = malloc((size_t)nt * sizeof *b->marea);
    edge_ref *ed = malloc(3 * (size_t)nt * sizeof *ed);
    if (!b->mrow || !b->marea || !ed) {
        free(ed);
        defsim__error(msg, "out of memory");
        return DEFSIM_ERR_OUT_OF_MEMORY;
    }
    for (int32_t t = 0; t < nt; ++t) {
        const int32_t *v = b->tris + 3 * (int64_t)t;
        double *row = b->mrow + DEFSIM__MEMBRANE_WIDTH * (int64_t)t;
        const int r = defsim__shell_frame(b->rest + 3 * (int64_t)v[0], b->rest + 3 * (int64_t)v[1],
                                          b->rest + 3 * (int64_t)v[2], d->shell_warp_direction,
                                          need_warp, row, &b->marea[t], NULL);
        if (r != 0) {
            free(ed);
            defsim__error(msg, r == 1 ? "add_body: shell triangle %d has zero area (%g)"
                                      : "add_body: shell triangle %d: the warp direction is "
                                        "normal to it (area %g)", (int)t, b->marea[t]);
            return DEFSIM_ERR_INVALID_MESH;
        }
        for (int i = 0; i < 4; ++i) row[4 + i] = prm[i];
        for (int a = 0; a < 3; ++a) {
            b->mass[v[a]] += d->shell_areal_density * b->marea[t] / 3.0;
            const uint32_t p = (uint32_t)v[a], q = (uint32_t)v[(a + 1) % 3];
            edge_ref *r3 = &ed[3 * (int64_t)t + a];
            r3->key = p < q ? ((uint64_t)p << 32 | q) : ((uint64_t)q << 32 | p);
            r3->tri = t;
            r3->opp = v[(a + 2) % 3];
        }
    }
    const int64_t ne = 3 * (int64_t)nt;
    qsort(ed, (size_t)ne, sizeof *ed, edge_cmp);
    int32_t nh = 0;
    for (int64_t i = 0; i < ne;) {
        int64_t j = i + 1;
        while (j < ne && ed[j].key == ed[i].key) ++j;
        if (j - i > 2) {
            defsim__error(msg, "add_body: shell edge (%u %u) is shared by %d triangles (at most 2)",
                          (unsigned)(ed[i].key >> 32), (unsigned)(ed[i].key & 0xFFFFFFFFu),
                          (int)(j - i));
            free(ed);
            return DEFSIM_ERR_INVALID_MESH;
        }
        nh += (j - i == 2 && (dw > 0.0 || df > 0.0));
        i = j;
    }
    b->nhinge = nh;
    b->hinges = malloc(4 * (size_t)(nh > 0 ? nh : 1) * sizeof *b->hinges);
    b->hw = malloc((size_t)(nh > 0 ? nh : 1) * sizeof *b->hw);
    b->htheta0 = malloc((size_t)(nh > 0 ? nh : 1) * sizeof *b->htheta0);
    if (!b->hinges || !b->hw || !b->htheta0) {
        free(ed);
        defsim__error(msg, "out of memory");
        return DEFSIM_ERR_OUT_OF_MEMORY;
    }
    int32_t h = 0;
    for (int64_t i = 0; i < ne && nh > 0;) {
        int64_t j = i + 1;
        while (j < ne && ed[j].key == ed[i].key) ++j;
        if (j - i == 2) {
            int32_t *hv = b->hinges + 4 * (int64_t)h;
            hv[0] = (int32_t)(ed[i].key >> 32);
            hv[1] = (int32_t)(ed[i].key & 0xFFFFFFFFu);
            hv[2] = ed[i].opp;
            hv[3] = ed[i + 1].opp;
            double X[12];
            for (int a = 0; a < 4; ++a) memcpy(X + 3 * a, b->rest + 3 * (int64_t)hv[a], 3 * sizeof *X);
            const int r = defsim__hinge_rest(X, d->shell_warp_direction, dw, df, &b->hw[h],
                                             &b->htheta0[h]);
            if (r != 0) {
                defsim__error(msg, r == 1 ? "add_body: shell hinge on edge (%d %d) is degenerate"
                                          : "add_body: shell hinge on edge (%d %d): the warp "
                                            "direction is normal to it", (int)hv[0], (int)hv[1]);
                free(ed);
                return DEFSIM_ERR_INVALID_MESH;
            }
            ++h;
        }
        i = j;
    }
    free(ed);
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
    if (!isfinite(d.contact_thickness) || d.contact_thickness < 0.0 ||
        d.contact_thickness > 1e3) {
        defsim__error(msg, "add_body: contact_thickness %g must be finite, >= 0 and at most "
                           "1e3 m", d.contact_thickness);
        return DEFSIM_ERR_INVALID_ARGUMENT;
    }
    if (d.volume_averaging != 0 && d.volume_averaging != 1) {
        defsim__error(msg, "add_body: volume_averaging %d must be 0 or 1",
                      (int)d.volume_averaging);
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
    st = shell_check(msg, &d);
    if (st != DEFSIM_OK) return st;
    double shell_dw, shell_df;
    shell_rigidity(&d, &shell_dw, &shell_df);
    const int shell = d.shell_membrane != DEFSIM_SHELL_MEMBRANE_NONE || shell_dw > 0.0 ||
                      shell_df > 0.0;
    if (shell && (d.tet_count > 0 || d.triangle_count < 1)) {
        defsim__error(msg, "add_body: a shell body needs triangles (%d given) and no tets (%d)",
                      (int)d.triangle_count, (int)d.tet_count);
        return DEFSIM_ERR_INVALID_MESH;
    }
    const double cap = d.shell_strain_limit;
    if (!(cap >= 0.0 && cap <= 1.0) ||
        (cap > 0.0 && (!shell || d.shell_membrane == DEFSIM_SHELL_MEMBRANE_NONE))) {
        defsim__error(msg, "add_body: shell_strain_limit %g must be 0 (none) or in (0, 1] on a "
                           "shell body with a membrane (this body: %s)", cap,
                      !shell ? "no shell" : d.shell_membrane == DEFSIM_SHELL_MEMBRANE_NONE
                                                ? "no membrane" : "a membrane");
        return DEFSIM_ERR_INVALID_MATERIAL;
    }
    if (shell && d.material.stiffness_damping != 0.0) {
        defsim__error(msg, "add_body: stiffness damping does not act on shells (material."
                           "stiffness_damping %g must be 0)", d.material.stiffness_damping);
        return DEFSIM_ERR_INVALID_MATERIAL;
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
    b.thickness = d.contact_thickness;
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
    b.shell = shell;
    b.membrane = -1;
    b.shell_membrane = d.shell_membrane;
    defsim__body_shell_fields(&d, b.shell_fields, 0);
    if (shell && (st = shell_build(msg, &d, &b)) != DEFSIM_OK) goto fail;
    b.strain_limit = cap;
    if (cap > 0.0 && d.initial_positions && (st = limit_check(msg, &d, &b)) != DEFSIM_OK)
        goto fail;
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
    /* version 9: the shell fields as the def gave them */
    defsim__put_i32(b, body->shell_membrane);
    defsim__put_f64s(b, body->shell_fields, DEFSIM__SHELL_FIELDS);
    /* version 10: the strain limit */
    defsim__put_f64(b, body->strain_limit);
    /* version 11: the contact thickness */
    defsim__put_f64(b, body->thickness);
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
    /* The shell fields (version 9); older files: defsim_body_def_init's (no shell). */
    if (version >= 9) {
        d->shell_membrane = defsim__get_i32(r);
        double p[DEFSIM__SHELL_FIELDS];
        defsim__get_f64s(r, p, DEFSIM__SHELL_FIELDS);
        defsim__body_shell_fields(d, p, 1);
    }
    /* The strain limit (version 10); older files: none. */
    if (version >= 10) d->shell_strain_limit = defsim__get_f64(r);
    /* The contact thickness (version 11); older files: 0. */
    if (version >= 11) d->contact_thickness = defsim__get_f64(r);
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
