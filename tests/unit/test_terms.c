/* SPDX-License-Identifier: MIT */
/*
 * The per-term conformance suite (issue 24; SUNDIALS' generic test_sunlinsol in spirit): every
 * term kind of term_list.h runs in a small world that activates it, through its own ops only:
 *  - forces = -dE/dx (central differences of the term's energy);
 *  - values = -dforces/dx (central differences of the term's forces; contact's blocks against
 *    the PSD projection of the differenced Hessian where the engine projects), and for damping
 *    terms the damping matrix against -dforces/dv;
 *  - apply equal to the assembled values times a vector, and, for terms that cache their blocks,
 *    products at one x that linearise once (no geometry in a product);
 *  - max_step never lands a pair below zero distance (checked along the segment by an
 *    independent distance);
 *  - the checkpoint chunk's round trip is bit-exact (and so are the forces after it);
 * and the suite fails if a kind of the list went untested.
 */
#include "test_util.h"

#include "mesh_body.h"

#include "assembly.h"
#include "terms.h"
#include "world.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static int tested[DEFSIM__TERM_KINDS];

static const defsim__term *term_of(defsim_world *w, int kind)
{
    const defsim__term *t = defsim__terms_find(&w->sys, kind);
    if (!t) fail_msg("term kind %d is not in the list", kind);
    tested[kind] = 1;
    return t;
}

/* The term's forces alone at (x, v). */
static void term_forces(defsim_world *w, const defsim__term *t, const double *x, const double *v,
                        uint32_t which, double *f)
{
    memset(f, 0, 3 * (size_t)w->nv * sizeof *f);
    const defsim__eval ev = {x, v, 0.0, which};
    uint32_t used = 0;
    TU_OK(t->ops->forces(t, &w->sys, &ev, f, &used));
}

/* The term's values (FULL pattern) as a dense matrix over all DOFs. */
static double *term_dense(defsim_world *w, const defsim__term *t, const double *x,
                          defsim_matrix_coeffs c)
{
    defsim__system *s = &w->sys;
    TU_OK(defsim__pattern_build(s));
    const int64_t n = 3 * (int64_t)w->nv;
    defsim_csc p;
    double *val = NULL, *D = calloc((size_t)(n * n), sizeof *D);
    for (int grew = 1; grew;) {   /* body contact's pairs join the pattern, then are scattered */
        TU_OK(defsim__matrix_pattern(s, DEFSIM_TRIANGLE_FULL, &p));
        free(val);
        val = calloc((size_t)p.nnz, sizeof *val);
        if (t->ops->linearise) TU_OK(t->ops->linearise(t, s, x, &c, DEFSIM__LIN_VALUES));
        t->ops->values(t, s, x, &c, 0, p.col_ptr, val, NULL);
        grew = 0;
        if (t->ops->pattern_update) TU_OK(t->ops->pattern_update(t, s, &grew));
    }
    for (int64_t j = 0; j < p.n; ++j)
        for (int64_t k = p.col_ptr[j]; k < p.col_ptr[j + 1]; ++k)
            D[s->free_dofs[p.row_idx[k]] * n + s->free_dofs[j]] = val[k];
    free(val);
    return D;
}

/* forces = -dE/dx on the free DOFs; returns the largest |f|. */
static double check_gradient(defsim_world *w, const defsim__term *t, double *x, uint32_t which,
                             double h, double tol)
{
    const int64_t n = 3 * (int64_t)w->nv;
    double *f = malloc((size_t)n * sizeof *f);
    term_forces(w, t, x, NULL, which, f);
    double err = 0.0, big = 0.0;
    for (int64_t i = 0; i < n; ++i) {
        if (w->sys.pinned[i / 3]) continue;
        const double x0 = x[i];
        x[i] = x0 + h;
        const double ep = t->ops->energy(t, &w->sys, &w->work, x, 0.0);
        x[i] = x0 - h;
        const double em = t->ops->energy(t, &w->sys, &w->work, x, 0.0);
        x[i] = x0;
        err = fmax(err, fabs(-(ep - em) / (2.0 * h) - f[i]));
        big = fmax(big, fabs(f[i]));
    }
    printf("  %-18s |f| %.3g, |f + dE/dx| %.3g\n", t->ops->name, big, err);
    assert_true(big > 0.0);
    assert_true(err <= tol * big);
    free(f);
    return big;
}

/* -d f / d(u) by central differences over the free DOFs, u = x (wrt_v 0) or v (1). */
static double *fd_jacobian(defsim_world *w, const defsim__term *t, double *x, double *v,
                           uint32_t which, int wrt_v, double h)
{
    const int64_t n = 3 * (int64_t)w->nv;
    double *J = calloc((size_t)(n * n), sizeof *J), *fp = malloc((size_t)n * sizeof *fp);
    double *fm = malloc((size_t)n * sizeof *fm), *u = wrt_v ? v : x;
    for (int64_t j = 0; j < n; ++j) {
        if (w->sys.pinned[j / 3]) continue;
        const double u0 = u[j];
        u[j] = u0 + h;
        term_forces(w, t, x, v, which, fp);
        u[j] = u0 - h;
        term_forces(w, t, x, v, which, fm);
        u[j] = u0;
        for (int64_t i = 0; i < n; ++i)
            if (!w->sys.pinned[i / 3]) J[i * n + j] = -(fp[i] - fm[i]) / (2.0 * h);
    }
    free(fp);
    free(fm);
    return J;
}

static double max_diff(const double *a, const double *b, int64_t n, double *scale)
{
    double e = 0.0, m = 0.0;
    for (int64_t i = 0; i < n; ++i) {
        e = fmax(e, fabs(a[i] - b[i]));
        m = fmax(m, fabs(b[i]));
    }
    *scale = m;
    return e;
}

/* values = -dforces/dx (or the damping matrix against -dforces/dv). */
static void check_values(defsim_world *w, const defsim__term *t, const defsim__term *mt,
                         double *x, double *v, uint32_t which, int wrt_v, defsim_matrix_coeffs c,
                         double h, double tol)
{
    const int64_t n = 3 * (int64_t)w->nv;
    double *J = fd_jacobian(w, t, x, v, which, wrt_v, h), *D = term_dense(w, mt, x, c), scale;
    const double err = max_diff(D, J, n * n, &scale);
    printf("  %-18s |values + df/d%s| %.3g of %.3g\n", t->ops->name, wrt_v ? "v" : "x", err,
           scale);
    assert_true(scale > 0.0);
    assert_true(err <= tol * scale);
    free(J);
    free(D);
}

/* apply = values dx, and the cached terms linearise once for many products at one x. */
static void check_apply(defsim_world *w, const defsim__term *t, const double *x,
                        defsim_matrix_coeffs c)
{
    const int64_t n = 3 * (int64_t)w->nv;
    double *D = term_dense(w, t, x, c), *dx = malloc((size_t)n * sizeof *dx);
    double *out = calloc((size_t)n, sizeof *out), *ref = calloc((size_t)n, sizeof *ref);
    unsigned long long seed = 11;
    for (int64_t i = 0; i < n; ++i) dx[i] = w->sys.pinned[i / 3] ? 0.0 : tu_rand(&seed);
    for (int64_t i = 0; i < n; ++i)
        for (int64_t j = 0; j < n; ++j) ref[i] += D[i * n + j] * dx[j];
    const int64_t lin0 = t->cache->linearisations;
    for (int rep = 0; rep < 5; ++rep) {
        memset(out, 0, (size_t)n * sizeof *out);
        if (t->ops->linearise) TU_OK(t->ops->linearise(t, &w->sys, x, &c, DEFSIM__LIN_LAZY));
        t->ops->apply(t, &w->sys, x, &c, w->sys.projection, dx, out);
    }
    double scale;
    const double err = max_diff(out, ref, n, &scale);
    printf("  %-18s |apply - values dx| %.3g of %.3g, linearisations in 5 products at the "
           "values' x: %lld\n", t->ops->name, err, scale, (long long)(t->cache->linearisations - lin0));
    assert_true(scale > 0.0);
    assert_true(err <= 1e-12 * scale);
    assert_true(t->cache->linearisations == lin0);
    free(D);
    free(dx);
    free(out);
    free(ref);
}

/* The chunk's round trip: save, clobber by loading an empty-state chunk is not possible in
 * general, so load what was saved into the live state and save again: bytes equal, forces at x
 * bit-identical to the ones before. */
static void check_chunk(defsim_world *w, const defsim__term *t, const double *x, uint32_t which)
{
    const int64_t n = 3 * (int64_t)w->nv;
    const size_t need = t->ops->save(t, NULL, 0);
    unsigned char *a = malloc(need), *b = malloc(need);
    assert_int_equal(t->ops->save(t, a, need), need);
    double *f0 = malloc((size_t)n * sizeof *f0), *f1 = malloc((size_t)n * sizeof *f1);
    term_forces(w, t, x, NULL, which, f0);
    TU_OK(t->ops->load(t, a, need));
    assert_int_equal(t->ops->save(t, b, need), need);
    assert_memory_equal(a, b, need);
    term_forces(w, t, x, NULL, which, f1);
    assert_memory_equal(f0, f1, (size_t)n * sizeof *f0);
    /* a truncated or inconsistent chunk is refused */
    if (need > 1) assert_int_equal(t->ops->load(t, a, need - 1), DEFSIM_ERR_INVALID_ARGUMENT);
    printf("  %-18s checkpoint chunk of %zu bytes: round trip bit-exact\n", t->ops->name, need);
    free(a);
    free(b);
    free(f0);
    free(f1);
}

/* ------------------------------------------------------------------------------------------ */
/* Worlds */

static defsim_world *world(double gy)
{
    return tu_world("explicit_euler", gy, 1);
}

static defsim_body_id add_box_of(defsim_world *w, defsim_model model, const double lo[3],
                                 double size, double alpha, double beta, int quadratic)
{
    const double hi[3] = {lo[0] + size, lo[1] + size, lo[2] + size};
    defsim_mesh m;
    memset(&m, 0, sizeof m);
    m.size = sizeof m;
    TU_OK(defsim_mesh_box(lo, hi, 1, 1, 1, &m));
    if (quadratic) TU_OK(defsim_mesh_make_quadratic(&m));
    defsim_body_def bd = test_mesh_body(&m, model);
    bd.material.youngs_modulus = 1e4;
    bd.material.poisson_ratio = 0.3;
    bd.material.density = 1000.0;
    bd.material.mass_damping = alpha;
    bd.material.stiffness_damping = beta;
    defsim_body_id id;
    if (defsim_world_add_body(w, &bd, &id) != DEFSIM_OK)
        fail_msg("add_body: %s", defsim_world_last_error(w));
    defsim_mesh_free(&m);
    return id;
}

static defsim_body_id add_box(defsim_world *w, defsim_model model, const double lo[3],
                              double size, double alpha, double beta)
{
    return add_box_of(w, model, lo, size, alpha, beta, 0);
}

/* The state perturbed (seeded) off rest, with velocities; returns x (owned). */
static double *perturbed(defsim_world *w, double amp, double **v_out)
{
    TU_OK(defsim__world_plan(w));
    const int64_t n = 3 * (int64_t)w->nv;
    double *x = tu_positions(w), *v = malloc((size_t)n * sizeof *v);
    unsigned long long seed = 3;
    for (int64_t i = 0; i < n; ++i) {
        x[i] += amp * tu_rand(&seed);
        v[i] = 0.1 * tu_rand(&seed);
    }
    TU_OK(defsim_world_set_state(w, x, v));
    TU_OK(defsim__world_plan(w));
    w->sys.projection = DEFSIM_PROJECTION_NONE;   /* exact Hessians, for the differences */
    *v_out = v;
    return x;
}

static const defsim_matrix_coeffs K1 = {1.0, 0.0, 0.0, 0.0}, KD1 = {0.0, 1.0, 0.0, 0.0};
static const defsim_matrix_coeffs MD1 = {0.0, 0.0, 0.0, 1.0};

/* Each tet model's elastic term, and stiffness damping (its matrix is the elastic term's): a
 * box of linear tets, or (quadratic) of 6 quadratic tets, 27 vertices, every node moved off rest
 * so that the elements are distorted and curved at x. */
static void check_elastic(int quadratic)
{
    const defsim_model models[4] = {DEFSIM_MODEL_STVK, DEFSIM_MODEL_COROTATED,
                                    DEFSIM_MODEL_NEOHOOKEAN, DEFSIM_MODEL_STABLE_NEOHOOKEAN};
    const int kind = quadratic ? DEFSIM__TERM_KIND_elastic_quadratic : DEFSIM__TERM_KIND_elastic;
    for (int m = 0; m < 4; ++m) {
        defsim_world *w = world(0.0);
        const double lo[3] = {0, 0, 0};
        add_box_of(w, models[m], lo, 0.1, 0.0, 0.01, quadratic);
        if (quadratic) assert_int_equal(w->nv, 27);
        double *v, *x = perturbed(w, quadratic ? 0.005 : 0.01, &v);
        const defsim__term *t = term_of(w, kind);
        if (quadratic) assert_null(defsim__terms_find(&w->sys, DEFSIM__TERM_KIND_elastic));
        check_gradient(w, t, x, DEFSIM_FORCE_ELASTIC, 1e-7, 1e-5);
        check_values(w, t, t, x, v, DEFSIM_FORCE_ELASTIC, 0, K1, 1e-7, 1e-5);
        check_apply(w, t, x, K1);
        const defsim__term *d = term_of(w, DEFSIM__TERM_KIND_stiffness_damping);
        check_values(w, d, t, x, v, DEFSIM_FORCE_DAMPING, 1, KD1, 1e-6, 1e-6);
        free(x);
        free(v);
        defsim_world_destroy(w);
    }
}

/* Whether the dense symmetric n x n matrix A (over the free DOFs of s) is positive
 * semi-definite to tol * its largest entry: a Cholesky factorisation of A + tol max|A| I. */
static int dense_psd(const defsim__system *sys, const double *A, int64_t n, double tol)
{
    int64_t m = 0;
    double big = 0.0;
    for (int64_t i = 0; i < n * n; ++i) big = fmax(big, fabs(A[i]));
    int64_t *f = malloc((size_t)n * sizeof *f);
    for (int64_t i = 0; i < n; ++i)
        if (!sys->pinned[i / 3]) f[m++] = i;
    double *L = calloc((size_t)(m * m), sizeof *L);
    int ok = 1;
    for (int64_t j = 0; j < m && ok; ++j) {
        double d = A[f[j] * n + f[j]] + tol * big;
        for (int64_t k = 0; k < j; ++k) d -= L[j * m + k] * L[j * m + k];
        if (!(d > 0.0)) { ok = 0; break; }
        L[j * m + j] = sqrt(d);
        for (int64_t i = j + 1; i < m; ++i) {
            double r = A[f[i] * n + f[j]];
            for (int64_t k = 0; k < j; ++k) r -= L[i * m + k] * L[j * m + k];
            L[i * m + j] = r / L[j * m + j];
        }
    }
    free(L);
    free(f);
    return ok;
}

/* The terms of the models with an isochoric / volumetric split (neo-Hookean and stable
 * neo-Hookean, nu = 0.45, stiffness damping, volume_averaging): the volume-averaged linear tets
 * on a 2 x 2 x 1-cell box, or (quadratic) the mean-dilatation quadratic tets on a 2 x 1 x 1-cell
 * box whose rest is curved (every mid-edge node moved off its edge's middle), each distorted off
 * rest: forces, the exact Hessian and the damping matrix against differences, products; under
 * clamp (and abs) projection the matrix is positive semi-definite at a state where the exact one
 * is not. */
static void check_split_term(int quadratic)
{
    const defsim_model models[2] = {DEFSIM_MODEL_NEOHOOKEAN, DEFSIM_MODEL_STABLE_NEOHOOKEAN};
    const int kind = quadratic ? DEFSIM__TERM_KIND_quadratic_mixed : DEFSIM__TERM_KIND_nodal_volume;
    for (int k = 0; k < 2; ++k) {
        defsim_world *w = world(0.0);
        const double lo[3] = {0, 0, 0}, hi[3] = {0.2, quadratic ? 0.1 : 0.2, 0.1};
        defsim_mesh m;
        memset(&m, 0, sizeof m);
        m.size = sizeof m;
        TU_OK(defsim_mesh_box(lo, hi, 2, quadratic ? 1 : 2, 1, &m));
        const int32_t corners = m.vertex_count;
        unsigned long long seed = 23;
        if (quadratic) {
            TU_OK(defsim_mesh_make_quadratic(&m));
            for (int32_t i = 3 * corners; i < 3 * m.vertex_count; ++i)
                m.positions[i] += 0.008 * tu_rand(&seed);
        }
        defsim_body_def bd = test_mesh_body(&m, models[k]);
        bd.material.youngs_modulus = 1e4;
        bd.material.poisson_ratio = 0.45;
        bd.material.density = 1000.0;
        bd.material.stiffness_damping = 0.01;
        bd.volume_averaging = 1;
        defsim_body_id id;
        TU_OK(defsim_world_add_body(w, &bd, &id));
        tu_pin_below(w, id, 0, 0.0);
        defsim_mesh_free(&m);
        double *v, *x = perturbed(w, quadratic ? 0.005 : 0.01, &v);
        assert_null(defsim__terms_find(&w->sys, DEFSIM__TERM_KIND_elastic));
        assert_null(defsim__terms_find(&w->sys, DEFSIM__TERM_KIND_elastic_quadratic));
        const defsim__term *t = term_of(w, kind);
        check_gradient(w, t, x, DEFSIM_FORCE_ELASTIC, 1e-7, 1e-5);
        check_values(w, t, t, x, v, DEFSIM_FORCE_ELASTIC, 0, K1, 1e-7, 1e-5);
        check_apply(w, t, x, K1);
        check_values(w, t, t, x, v, DEFSIM_FORCE_DAMPING, 1, KD1, 1e-6, 1e-6);
        check_apply(w, t, x, (defsim_matrix_coeffs){1.0, 0.5, 0.0, 0.0});
        /* a strong twist-and-squash: the exact Hessian is indefinite, the clamped one is not */
        const int64_t n = 3 * (int64_t)w->nv;
        seed = 5;
        for (int64_t i = 0; i < n; ++i)
            if (!w->sys.pinned[i / 3]) x[i] += (quadratic ? 0.01 : 0.04) * tu_rand(&seed);
        double *D = term_dense(w, t, x, K1);
        const int exact_psd = dense_psd(&w->sys, D, n, 1e-10);
        for (int64_t i = 0; i < n * n; ++i) assert_true(isfinite(D[i]));   /* none inverted */
        free(D);
        const int proj[2] = {DEFSIM_PROJECTION_CLAMP, DEFSIM_PROJECTION_ABS};
        for (int p = 0; p < 2; ++p) {
            w->sys.projection = proj[p];
            D = term_dense(w, t, x, K1);
            const int psd = dense_psd(&w->sys, D, n, 1e-10);
            printf("  %-18s at a large distortion: exact Hessian PSD %d, %s %d\n", t->ops->name,
                   exact_psd, p ? "abs" : "clamped", psd);
            assert_false(exact_psd);
            assert_true(psd);
            check_apply(w, t, x, K1);
            free(D);
        }
        free(x);
        free(v);
        defsim_world_destroy(w);
    }
}

static void test_nodal_volume(void **state)
{
    (void)state;
    check_split_term(0);
}

static void test_quadratic_mixed(void **state)
{
    (void)state;
    check_split_term(1);
}

static void test_elastic(void **state)
{
    (void)state;
    check_elastic(0);
}

static void test_elastic_quadratic(void **state)
{
    (void)state;
    check_elastic(1);
}

/* Springs (a rope) with stiffness damping, and mass damping with the inertia's diagonal. */
static void test_spring_and_mass(void **state)
{
    (void)state;
    defsim_world *w = world(-9.81);
    const double x[12] = {0, 0, 0, 0.1, 0, 0, 0.2, 0.01, 0, 0.3, 0, 0.02};
    const int32_t s[6] = {0, 1, 1, 2, 2, 3};
    defsim_body_def d;
    defsim_body_def_init(&d, sizeof d);
    defsim_material_init(&d.material, sizeof d.material, DEFSIM_MODEL_SPRING);
    d.material.stiffness = 100.0;
    d.material.vertex_mass = 0.5;
    d.material.mass_damping = 0.3;
    d.material.stiffness_damping = 0.02;
    d.rest_positions = x;
    d.vertex_count = 4;
    d.springs = s;
    d.spring_count = 3;
    TU_OK(defsim_world_add_body(w, &d, NULL));
    double *v, *xp = perturbed(w, 0.01, &v);
    const defsim__term *t = term_of(w, DEFSIM__TERM_KIND_spring);
    check_gradient(w, t, xp, DEFSIM_FORCE_ELASTIC, 1e-7, 1e-6);
    check_values(w, t, t, xp, v, DEFSIM_FORCE_ELASTIC, 0, K1, 1e-7, 1e-5);
    check_apply(w, t, xp, K1);
    check_values(w, term_of(w, DEFSIM__TERM_KIND_stiffness_damping), t, xp, v,
                 DEFSIM_FORCE_DAMPING, 1, KD1, 1e-6, 1e-6);
    const defsim__term *in = term_of(w, DEFSIM__TERM_KIND_inertia);
    check_values(w, term_of(w, DEFSIM__TERM_KIND_mass_damping), in, xp, v, DEFSIM_FORCE_DAMPING,
                 1, MD1, 1e-6, 1e-9);
    check_apply(w, in, xp, (defsim_matrix_coeffs){0.0, 0.0, 1.0, 0.5});
    /* gravity: its energy's gradient */
    check_gradient(w, term_of(w, DEFSIM__TERM_KIND_gravity), xp, DEFSIM_FORCE_GRAVITY, 1e-6,
                   1e-8);
    free(xp);
    free(v);
    defsim_world_destroy(w);
}

/* Shells: each membrane law's term and the hinges, on a bent 4 x 3 sheet off its rest shape. */
static void test_shells(void **state)
{
    (void)state;
    const int32_t laws[3] = {DEFSIM_SHELL_MEMBRANE_STVK, DEFSIM_SHELL_MEMBRANE_NEOHOOKEAN,
                             DEFSIM_SHELL_MEMBRANE_ORTHOTROPIC_STVK};
    for (int k = 0; k < 3; ++k) {
        defsim_world *w = world(-9.81);
        const double o[3] = {0, 0, 0}, u[3] = {0.2, 0, 0}, vv[3] = {0, 0.15, 0};
        defsim_mesh m;
        memset(&m, 0, sizeof m);
        m.size = sizeof m;
        TU_OK(defsim_mesh_cloth(o, u, vv, 4, 3, &m));
        for (int i = 0; i < m.vertex_count; ++i)   /* a pre-bent rest shape */
            m.positions[3 * i + 2] = 0.5 * m.positions[3 * i] * m.positions[3 * i];
        defsim_body_def d;
        defsim_body_def_init(&d, sizeof d);
        d.rest_positions = m.positions;
        d.vertex_count = m.vertex_count;
        d.triangles = m.triangles;
        d.triangle_count = m.triangle_count;
        d.shell_membrane = laws[k];
        d.shell_youngs_modulus = 1e5;
        d.shell_thickness = 1e-3;
        d.shell_warp_direction[1] = 0.5;
        d.shell_bending_rigidity = 1e-3;
        d.shell_bending_rigidity_weft = 3e-4;
        TU_OK(defsim_world_add_body(w, &d, NULL));
        defsim_mesh_free(&m);
        double *v, *x = perturbed(w, 0.01, &v);
        const defsim__term *mt = term_of(w, DEFSIM__TERM_KIND_membrane);
        check_gradient(w, mt, x, DEFSIM_FORCE_ELASTIC, 1e-7, 1e-6);
        check_values(w, mt, mt, x, v, DEFSIM_FORCE_ELASTIC, 0, K1, 1e-7, 1e-5);
        check_apply(w, mt, x, K1);
        const defsim__term *ht = term_of(w, DEFSIM__TERM_KIND_hinge);
        check_gradient(w, ht, x, DEFSIM_FORCE_ELASTIC, 1e-7, 1e-6);
        check_values(w, ht, ht, x, v, DEFSIM_FORCE_ELASTIC, 0, K1, 1e-7, 1e-5);
        check_apply(w, ht, x, K1);
        free(x);
        free(v);
        defsim_world_destroy(w);
    }
    /* The strain limit (on a backend that takes it): the flat sheet stretched 1.28 times along x
     * under a 30 % cap (its band 1.27 .. 1.3), perturbed by 1e-4 m; its filter along a pull of
     * the right edge by 0.1 m cuts the step, and the path up to the cut stays below the cap. */
    if (!tu_available("newton_cholmod")) return;
    defsim_world *w = tu_world("newton_cholmod", 0.0, 1);
    const double o[3] = {0, 0, 0}, u[3] = {0.2, 0, 0}, vv[3] = {0, 0.15, 0};
    defsim_mesh m;
    memset(&m, 0, sizeof m);
    m.size = sizeof m;
    TU_OK(defsim_mesh_cloth(o, u, vv, 4, 3, &m));
    defsim_body_def d = test_shell_body(&m);
    d.shell_membrane = DEFSIM_SHELL_MEMBRANE_STVK;
    d.shell_youngs_modulus = 1e5;
    d.shell_strain_limit = 0.3;
    TU_OK(defsim_world_add_body(w, &d, NULL));
    TU_OK(defsim__world_plan(w));
    const int64_t n = 3 * (int64_t)w->nv;
    double *x = tu_positions(w), *v = calloc((size_t)n, sizeof *v);
    unsigned long long seed = 9;
    for (int64_t i = 0; i < n; ++i) x[i] = (i % 3 == 0 ? 1.28 : 1.0) * x[i] + 1e-4 * tu_rand(&seed);
    TU_OK(defsim_world_set_state(w, x, v));
    TU_OK(defsim__world_plan(w));
    w->sys.projection = DEFSIM_PROJECTION_NONE;
    const defsim__term *lt = term_of(w, DEFSIM__TERM_KIND_strain_limit);
    check_gradient(w, lt, x, DEFSIM_FORCE_ELASTIC, 1e-8, 1e-6);
    check_values(w, lt, lt, x, v, DEFSIM_FORCE_ELASTIC, 0, K1, 1e-8, 1e-5);
    check_apply(w, lt, x, K1);
    double *dx = calloc((size_t)n, sizeof *dx);
    for (int32_t i = 0; i < w->nv; ++i)
        if (m.positions[3 * i] > 0.19) dx[3 * i] = 0.1;
    const double a = lt->ops->max_step(lt, x, dx);
    printf("  %-18s max_step %.4g along a pull of 0.1 m\n", lt->ops->name, a);
    assert_true(a > 0.0 && a < 1.0);
    for (int k = 0; k <= 100; ++k) {
        double *y = malloc((size_t)n * sizeof *y);
        for (int64_t i = 0; i < n; ++i) y[i] = x[i] + a * k / 100.0 * dx[i];
        assert_true(isfinite(lt->ops->energy(lt, &w->sys, &w->work, y, 0.0)));
        free(y);
    }
    free(dx);
    free(x);
    free(v);
    defsim_mesh_free(&m);
    defsim_world_destroy(w);
}

/* Attachments to a world point and to another body's tet, with dampers; held forces. */
static void test_attach_and_held(void **state)
{
    (void)state;
    defsim_world *w = world(0.0);
    const double lo0[3] = {0, 0, 0}, lo1[3] = {0.2, 0, 0};
    const defsim_body_id a = add_box(w, DEFSIM_MODEL_COROTATED, lo0, 0.1, 0.0, 0.0);
    const defsim_body_id b = add_box(w, DEFSIM_MODEL_COROTATED, lo1, 0.1, 0.0, 0.0);
    defsim_attachment_def ad;
    defsim_attachment_def_init(&ad, sizeof ad);
    ad.body = a;
    ad.vertex = 1;
    ad.stiffness = 500.0;
    ad.damping = 2.0;
    ad.target[0] = 0.15;
    TU_OK(defsim_world_add_attachment(w, &ad, NULL));
    ad.vertex = 2;
    ad.target_body = b;
    ad.target_vertex_count = 3;
    ad.target_vertices[0] = 0, ad.target_vertices[1] = 1, ad.target_vertices[2] = 2;
    ad.target_weights[0] = 0.2, ad.target_weights[1] = 0.3, ad.target_weights[2] = 0.5;
    TU_OK(defsim_world_add_attachment(w, &ad, NULL));
    double *v, *x = perturbed(w, 0.01, &v);
    const defsim__term *t = term_of(w, DEFSIM__TERM_KIND_attach);
    check_gradient(w, t, x, DEFSIM_FORCE_ELASTIC, 1e-7, 1e-6);
    check_values(w, t, t, x, v, DEFSIM_FORCE_ELASTIC, 0, K1, 1e-7, 1e-6);
    check_values(w, t, t, x, v, DEFSIM_FORCE_DAMPING, 1, KD1, 1e-6, 1e-6);
    check_apply(w, t, x, (defsim_matrix_coeffs){1.0, 0.5, 0.0, 0.0});
    const int64_t n = 3 * (int64_t)w->nv;
    double *fe = malloc((size_t)n * sizeof *fe);
    for (int64_t i = 0; i < n; ++i) fe[i] = 0.1 * (double)(i % 7) - 0.3;
    TU_OK(defsim_world_set_external_forces(w, fe, w->nv));
    check_gradient(w, term_of(w, DEFSIM__TERM_KIND_held), x, DEFSIM_FORCE_GRAVITY, 1e-6, 1e-8);
    free(fe);
    free(x);
    free(v);
    defsim_world_destroy(w);
}

/* The callback f_i = -k (x_i - r_i) with its Jacobian, seen as an implicit step sees it: the
 * model -f0 . d + d^T K0 d / 2 from its start x0 = r. */
static const double CB_K = 40.0;
static int cb_force(void *user, const double *x, const double *v, double t, int32_t n, double *f)
{
    (void)v;
    (void)t;
    const double *r = user;
    for (int32_t i = 0; i < 3 * n; ++i) f[i] += -CB_K * (x[i] - r[i]);
    return 0;
}
static int cb_jac(void *user, const double *x, const double *v, double t, int32_t n, double *J)
{
    (void)user;
    (void)x;
    (void)v;
    (void)t;
    for (int32_t i = 0; i < n; ++i)
        for (int k = 0; k < 9; ++k) J[9 * i + k] = k % 4 == 0 ? -CB_K : 0.0;
    return 0;
}

static void test_callback(void **state)
{
    (void)state;
    defsim_world *w = world(0.0);
    const double lo[3] = {0, 0, 0};
    add_box(w, DEFSIM_MODEL_STVK, lo, 0.1, 0.0, 0.0);
    TU_OK(defsim__world_plan(w));
    double *r = tu_positions(w);
    TU_OK(defsim_world_set_force_callback(w, cb_force, cb_jac, r));
    double *v, *x = perturbed(w, 0.01, &v);
    defsim__coupling *c = &w->coupling.cpl;
    c->in_step = c->implicit = 1;
    const int64_t n = 3 * (int64_t)w->nv;
    memcpy(c->x0, r, (size_t)n * sizeof *r);
    memset(c->f0, 0, (size_t)n * sizeof *c->f0);
    TU_OK(defsim__callback_stiffness(c, w->msg, w->nv, DEFSIM_PROJECTION_NONE, r, v, 0.0, c->K0));
    memcpy(c->veval, v, (size_t)n * sizeof *v);
    const defsim__term *t = term_of(w, DEFSIM__TERM_KIND_callback);
    check_gradient(w, t, x, DEFSIM_FORCE_GRAVITY, 1e-6, 1e-7);
    check_values(w, t, t, x, v, DEFSIM_FORCE_GRAVITY, 0, K1, 1e-6, 1e-7);
    /* products reuse what values evaluated (LAZY: no new Jacobian call) */
    check_apply(w, t, x, K1);
    c->in_step = c->implicit = 0;
    const defsim__step_ctx sc = {.coupling = &w->coupling};
    TU_OK(defsim__terms_finish(&w->sys, &sc, DEFSIM_OK));
    free(r);
    free(x);
    free(v);
    defsim_world_destroy(w);
}

/* ------------------------------------------------------------------------------------------ */
/* Contact */

/* A 1-cell box over the plane y = 0 with its bottom vertices within dhat. */
static void test_collider(void **state)
{
    (void)state;
    for (int mode = DEFSIM__CONTACT_BARRIER; mode <= DEFSIM__CONTACT_PENALTY; ++mode) {
        defsim_world *w = world(0.0);
        const double lo[3] = {0, 0, 0};
        add_box(w, DEFSIM_MODEL_NEOHOOKEAN, lo, 0.1, 0.0, 0.0);
        defsim_collider_def cd;
        defsim_collider_def_init(&cd, sizeof cd);
        TU_OK(defsim_world_add_collider(w, &cd, NULL));
        TU_OK(defsim__world_plan(w));
        const int64_t n = 3 * (int64_t)w->nv;
        const double dhat = 1e-3 * w->sys.length_scale;
        double *x = tu_positions(w), *v = calloc((size_t)n, sizeof *v);
        unsigned long long seed = 5;
        for (int32_t i = 0; i < w->nv; ++i)
            if (x[3 * i + 1] < 1e-9) x[3 * i + 1] = (0.3 + 0.4 * (0.5 + 0.5 * tu_rand(&seed))) * dhat;
        TU_OK(defsim_world_set_state(w, x, v));
        const defsim__contact_params p = {.mode = mode, .dhat_rel = 1e-3, .frequency = 300.0,
                                          .eps_v = 0.02};
        TU_OK(defsim__contact_begin(&w->contact, &w->sys, w->colliders.col, w->colliders.ncol, &p, x, v, 0.01,
                                    w->msg));
        w->sys.contact = &w->contact;
        TU_OK(defsim__terms_compile(&w->sys));
        const defsim__term *t = term_of(w, DEFSIM__TERM_KIND_collider);
        check_gradient(w, t, x, DEFSIM_FORCE_ELASTIC, 1e-3 * dhat, 1e-5);
        /* a plane's blocks are exact (no curvature): no projection to undo */
        check_values(w, t, t, x, v, DEFSIM_FORCE_ELASTIC, 0, K1, 1e-3 * dhat, 1e-5);
        check_apply(w, t, x, K1);
        /* products at another x linearise again, once */
        double *x2 = malloc((size_t)n * sizeof *x2), *dx = malloc((size_t)n * sizeof *dx);
        double *out = malloc((size_t)n * sizeof *out);
        for (int64_t i = 0; i < n; ++i) x2[i] = x[i] + (i % 3 == 1 ? 0.1 * dhat : 0.0);
        for (int64_t i = 0; i < n; ++i) dx[i] = 1.0;
        const int64_t l0 = t->cache->linearisations;
        for (int rep = 0; rep < 3; ++rep) defsim__matrix_apply(&w->sys, x2, &K1, 0, dx, out);
        assert_true(t->cache->linearisations == l0 + 1);
        if (mode == DEFSIM__CONTACT_BARRIER) {
            /* max_step along a push 3 dhat down: every vertex stays above the plane on [0, a]
             * (the distance is linear in the step, so the segment's ends decide) */
            for (int64_t i = 0; i < n; ++i) dx[i] = i % 3 == 1 ? -3.0 * dhat : 0.01 * dhat;
            const double a = t->ops->max_step(t, x, dx);
            double dmin = INFINITY;
            for (int32_t i = 0; i < w->nv; ++i) {
                dmin = fmin(dmin, x[3 * i + 1]);
                dmin = fmin(dmin, x[3 * i + 1] + a * dx[3 * i + 1]);
            }
            printf("  %-18s max_step %.4g along a push of 3 dhat: smallest distance %.3g dhat\n",
                   t->ops->name, a, dmin / dhat);
            assert_true(a > 0.0 && a < 1.0);
            assert_true(dmin > 0.0);
        }
        /* friction's velocities (PENALTY keeps them from its latest damping evaluation) are
         * part of the chunk */
        for (int64_t i = 0; i < n; ++i) v[i] = 0.05 * tu_rand(&seed);
        term_forces(w, t, x, v, DEFSIM_FORCE_DAMPING, out);
        double *vel0 = NULL;
        const double *vel = defsim__contact_vel(&w->contact, w->nv);
        if (vel) {
            vel0 = malloc((size_t)n * sizeof *vel0);
            memcpy(vel0, vel, (size_t)n * sizeof *vel0);
        }
        check_chunk(w, t, x, DEFSIM_FORCE_ELASTIC);
        if (vel0) {
            assert_memory_equal(vel0, defsim__contact_vel(&w->contact, w->nv),
                                (size_t)n * sizeof *vel0);
            free(vel0);
        }
        double lin = 0.0;   /* its counter by name */
        TU_OK(defsim_world_stat(w, "collider.linearisations", &lin));
        assert_true(lin == (double)t->cache->linearisations && lin > 0.0);
        defsim_world_reset_stats(w);   /* zeroes the term kinds' cumulative counters too */
        TU_OK(defsim_world_stat(w, "collider.linearisations", &lin));
        assert_true(lin == 0.0 && t->cache->linearisations == 0);
        w->sys.contact = NULL;
        TU_OK(defsim__terms_compile(&w->sys));
        free(x);
        free(x2);
        free(dx);
        free(out);
        free(v);
        defsim_world_destroy(w);
    }
}

/* Cyclic Jacobi: replaces the symmetric n x n A by V max(L, 0) V^T. */
static void project_psd(int n, double *A)
{
    double V[144], a[144];
    memcpy(a, A, (size_t)n * n * sizeof *a);
    for (int i = 0; i < n * n; ++i) V[i] = (i / n == i % n);
    for (int sweep = 0; sweep < 100; ++sweep) {
        double off = 0.0, tot = 0.0;
        for (int i = 0; i < n * n; ++i) {
            tot += a[i] * a[i];
            if (i / n != i % n) off += a[i] * a[i];
        }
        if (off <= 1e-30 * tot) break;
        for (int p = 0; p < n; ++p)
            for (int q = p + 1; q < n; ++q) {
                if (a[p * n + q] == 0.0) continue;
                const double th = 0.5 * atan2(2.0 * a[p * n + q], a[q * n + q] - a[p * n + p]);
                const double c = cos(th), s = sin(th);
                for (int k = 0; k < n; ++k) {
                    const double akp = a[k * n + p], akq = a[k * n + q];
                    a[k * n + p] = c * akp - s * akq;
                    a[k * n + q] = s * akp + c * akq;
                }
                for (int k = 0; k < n; ++k) {
                    const double apk = a[p * n + k], aqk = a[q * n + k];
                    a[p * n + k] = c * apk - s * aqk;
                    a[q * n + k] = s * apk + c * aqk;
                }
                for (int k = 0; k < n; ++k) {
                    const double vkp = V[k * n + p], vkq = V[k * n + q];
                    V[k * n + p] = c * vkp - s * vkq;
                    V[k * n + q] = s * vkp + c * vkq;
                }
            }
    }
    for (int i = 0; i < n; ++i)
        for (int j = 0; j < n; ++j) {
            double sum = 0.0;
            for (int k = 0; k < n; ++k) sum += V[i * n + k] * fmax(a[k * n + k], 0.0) * V[j * n + k];
            A[i * n + j] = sum;
        }
}

/* A rope's lower end over a triangle's interior, 0.4 dhat above it: one point-triangle pair
 * (with friction mu: lagged from the start, the point then slid along the triangle). */
static defsim_world *point_over_triangle(double mu, double **x_out, double **v_out)
{
    defsim_world *w = world(0.0);
    const double tri[9] = {0, 0, 0, 1, 0, 0, 0, 1, 0};
    const int32_t tt[3] = {0, 1, 2};
    const double dh = 0.01 * sqrt(3.0);   /* dhat_rel 0.01 of the unit box's diagonal */
    const double rope[6] = {0.25, 0.2, 0.4 * dh, 0.25, 0.2, 1.0};
    const int32_t sp[2] = {0, 1};
    for (int b = 0; b < 2; ++b) {
        defsim_body_def d;
        defsim_body_def_init(&d, sizeof d);
        defsim_material_init(&d.material, sizeof d.material, DEFSIM_MODEL_SPRING);
        d.material.stiffness = 0.0;
        d.material.vertex_mass = 1.0;
        d.rest_positions = b ? rope : tri;
        d.vertex_count = b ? 2 : 3;
        d.triangles = b ? NULL : tt;
        d.triangle_count = b ? 0 : 1;
        d.springs = b ? sp : NULL;
        d.spring_count = b ? 1 : 0;
        d.friction = mu;
        TU_OK(defsim_world_add_body(w, &d, NULL));
    }
    TU_OK(defsim__world_plan(w));
    const int64_t n = 3 * (int64_t)w->nv;
    double *x = tu_positions(w), *v = calloc((size_t)n, sizeof *v);
    memcpy(w->step.x_save, x, (size_t)n * sizeof *x);
    TU_OK(defsim__body_contact_begin(&w->body_contact, &w->sys, w->bodies.b, w->bodies.n, 0.01, 0.0,
                                     1e-3, w->step.x_save, v, 0.01, w->contact.stat, w->msg));
    w->sys.body_contact = &w->body_contact;
    TU_OK(defsim__terms_compile(&w->sys));
    /* evaluated off the start: a tilted triangle, the point moved */
    x[3 * 3 + 0] += 0.1 * dh;
    x[3 * 3 + 2] += 0.2 * dh;
    x[3 * 1 + 2] += 0.1 * dh;
    *x_out = x;
    *v_out = v;
    return w;
}

static void detach_bodies(defsim_world *w)
{
    w->sys.body_contact = NULL;
    w->body_contact.active = 0;
    TU_OK(defsim__terms_compile(&w->sys));
}

static void test_body_contact_friction(void **state)
{
    (void)state;
    double *x, *v;
    defsim_world *w = point_over_triangle(0.5, &x, &v);
    const defsim__term *t = term_of(w, DEFSIM__TERM_KIND_body_contact);
    assert_true(w->body_contact.nfric == 1);
    check_gradient(w, t, x, DEFSIM_FORCE_ELASTIC, 1e-4 * 0.01 * sqrt(3.0), 1e-5);
    check_chunk(w, t, x, DEFSIM_FORCE_ELASTIC);
    detach_bodies(w);
    free(x);
    free(v);
    defsim_world_destroy(w);
}

static void test_body_contact(void **state)
{
    (void)state;
    const double dh = 0.01 * sqrt(3.0);
    double *x, *v;
    defsim_world *w = point_over_triangle(0.0, &x, &v);
    const int64_t n = 3 * (int64_t)w->nv;
    const defsim__term *t = term_of(w, DEFSIM__TERM_KIND_body_contact);
    check_gradient(w, t, x, DEFSIM_FORCE_ELASTIC, 1e-4 * dh, 1e-5);
    /* values: the engine clamps the eigenvalues of the pair's whole Hessian (contact_pair.c);
     * do the same to the differenced Hessian */
    double *J = fd_jacobian(w, t, x, v, DEFSIM_FORCE_ELASTIC, 0, 1e-7);
    double *D = term_dense(w, t, x, K1);
    /* one point-triangle pair (and no friction) */
    assert_true(t->cache->count >= 1);
    const int32_t *idx = ((const int32_t *)t->cache->buf);   /* the entry's vertices */
    const int m = 4;
    double Hp[144];
    for (int i = 0; i < 12; ++i)
        for (int j = 0; j < 12; ++j)
            Hp[i * 12 + j] = J[(3 * (int64_t)idx[i / 3] + i % 3) * n + 3 * idx[j / 3] + j % 3];
    for (int i = 0; i < 12; ++i)
        for (int j = 0; j < i; ++j)
            Hp[i * 12 + j] = Hp[j * 12 + i] = 0.5 * (Hp[i * 12 + j] + Hp[j * 12 + i]);
    project_psd(12, Hp);
    double err = 0.0, scale = 0.0;
    for (int a = 0; a < m; ++a)
        for (int c = 0; c < m; ++c)
            for (int i = 0; i < 3; ++i)
                for (int k = 0; k < 3; ++k) {
                    const double dv = D[(3 * (int64_t)idx[a] + i) * n + 3 * idx[c] + k];
                    err = fmax(err, fabs(dv - Hp[(3 * a + i) * 12 + 3 * c + k]));
                    scale = fmax(scale, fabs(Hp[(3 * a + i) * 12 + 3 * c + k]));
                }
    printf("  %-18s |values - proj(-df/dx)| %.3g of %.3g\n", t->ops->name, err, scale);
    assert_true(scale > 0.0 && err <= 1e-4 * scale);
    free(J);
    free(D);
    check_apply(w, t, x, K1);
    /* max_step along a push of the point 3 dhat through the triangle: the point's height over
     * the (tilted) triangle's plane, sampled along [0, a], stays positive */
    double *dx = calloc((size_t)n, sizeof *dx);
    dx[3 * 3 + 2] = -3.0 * dh;
    const double a = t->ops->max_step(t, x, dx);
    double hmin = INFINITY;
    const double *p0 = x, *p1 = x + 3, *p2 = x + 6;
    double e1[3], e2[3], nr[3];
    for (int k = 0; k < 3; ++k) e1[k] = p1[k] - p0[k], e2[k] = p2[k] - p0[k];
    nr[0] = e1[1] * e2[2] - e1[2] * e2[1];
    nr[1] = e1[2] * e2[0] - e1[0] * e2[2];
    nr[2] = e1[0] * e2[1] - e1[1] * e2[0];
    const double nn = sqrt(nr[0] * nr[0] + nr[1] * nr[1] + nr[2] * nr[2]);
    for (int s = 0; s <= 1000; ++s) {
        const double tt2 = a * s / 1000.0;
        double hgt = 0.0;
        for (int k = 0; k < 3; ++k) hgt += (x[9 + k] + tt2 * dx[9 + k] - p0[k]) * nr[k] / nn;
        hmin = fmin(hmin, hgt);
    }
    printf("  %-18s max_step %.4g along a push of 3 dhat: smallest height %.3g dhat\n",
           t->ops->name, a, hmin / dh);
    assert_true(a > 0.0 && a < 1.0);
    assert_true(hmin > 0.0);
    free(dx);
    check_chunk(w, t, x, DEFSIM_FORCE_ELASTIC);
    detach_bodies(w);
    free(x);
    free(v);
    defsim_world_destroy(w);
}

/* Every kind of the list was exercised above. */
static void test_all_kinds(void **state)
{
    (void)state;
    for (int k = 0; k < DEFSIM__TERM_KINDS; ++k)
        if (!tested[k]) fail_msg("term kind %d has no conformance test", k);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_elastic),        cmocka_unit_test(test_elastic_quadratic),
        cmocka_unit_test(test_nodal_volume),    cmocka_unit_test(test_quadratic_mixed),
        cmocka_unit_test(test_spring_and_mass),
        cmocka_unit_test(test_shells),
        cmocka_unit_test(test_attach_and_held), cmocka_unit_test(test_callback),
        cmocka_unit_test(test_collider),       cmocka_unit_test(test_body_contact),
        cmocka_unit_test(test_body_contact_friction),
        cmocka_unit_test(test_all_kinds),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
