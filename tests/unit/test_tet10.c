/* SPDX-License-Identifier: MIT */
/*
 * The 10-node quadratic tet (tet10.c, term_elastic_quadratic.c; issue 29): its quadrature rules
 * (exact to their degree), shape functions, the patch test and rigid motions for every model,
 * a curved element's forces and Hessian against differences of its energy, HRZ masses, the
 * validation of add_body, defsim_mesh_make_quadratic and the boundary's sub-triangles, stress
 * read-back, the watchdog's inverted-element count, the stable step, body contact on the
 * boundary's sub-triangles, and the cost of a force
 * evaluation per element next to linear tets (printed).
 */
#include "test_util.h"

#include "assembly.h"
#include "terms.h"
#include "tet10.h"
#include "world.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

static const defsim_model MODELS[4] = {DEFSIM_MODEL_STVK, DEFSIM_MODEL_COROTATED,
                                       DEFSIM_MODEL_NEOHOOKEAN, DEFSIM_MODEL_STABLE_NEOHOOKEAN};

static double fact(int n) { return n <= 1 ? 1.0 : n * fact(n - 1); }

/* Each rule integrates every monomial L1^a L2^b L3^c of degree <= its own exactly over the
 * reference tet (a! b! c! / (a + b + c + 3)!), and the degree-2 rule misses degree 3. */
static void test_rules(void **state)
{
    (void)state;
    const int degrees[2] = {2, 5};
    for (int r = 0; r < 2; ++r) {
        const double *pts, *w;
        const int nq = defsim__tet10_rule(degrees[r], &pts, &w);
        assert_int_equal(nq, r == 0 ? 4 : 14);
        double worst = 0.0, miss = 0.0;
        for (int a = 0; a <= degrees[r] + 1; ++a)
            for (int b = 0; a + b <= degrees[r] + 1; ++b)
                for (int c = 0; a + b + c <= degrees[r] + 1; ++c) {
                    double sum = 0.0;
                    for (int q = 0; q < nq; ++q) {
                        assert_true(w[q] > 0.0);
                        const double *L = pts + 4 * q;
                        assert_true(fabs(L[0] + L[1] + L[2] + L[3] - 1.0) < 1e-15);
                        sum += w[q] * pow(L[1], a) * pow(L[2], b) * pow(L[3], c);
                    }
                    const double exact = fact(a) * fact(b) * fact(c) / fact(a + b + c + 3);
                    const double e = fabs(sum - exact) / exact;
                    if (a + b + c <= degrees[r]) worst = fmax(worst, e);
                    else miss = fmax(miss, e);
                }
        printf("  degree-%d rule (%d points): largest relative error %.2g up to degree %d, "
               "%.2g at degree %d\n", degrees[r], nq, worst, degrees[r], miss, degrees[r] + 1);
        assert_true(worst < 1e-13);
        assert_true(miss > 1e-6);
    }
}

/* N_a(node b) = delta_ab, sum_a N_a = 1 and sum_a dN_a = 0 anywhere, dN against differences. */
static void test_shape(void **state)
{
    (void)state;
    for (int b = 0; b < 10; ++b) {
        double L[4] = {0, 0, 0, 0}, N[10], dN[10][3];
        if (b < 4) L[b] = 1.0;
        else L[defsim__tet10_edge[b - 4][0]] = L[defsim__tet10_edge[b - 4][1]] = 0.5;
        defsim__tet10_shape(L, N, dN);
        for (int a = 0; a < 10; ++a) assert_true(fabs(N[a] - (a == b)) < 1e-15);
    }
    unsigned long long seed = 5;
    const double h = 1e-6;
    for (int k = 0; k < 20; ++k) {
        double xi[3] = {0.25 + 0.2 * tu_rand(&seed), 0.25 + 0.2 * tu_rand(&seed),
                        0.2 + 0.1 * tu_rand(&seed)};
        double L[4] = {xi[0], xi[1], xi[2], 1.0 - xi[0] - xi[1] - xi[2]}, N[10], dN[10][3];
        defsim__tet10_shape(L, N, dN);
        double sum = 0.0, dsum[3] = {0, 0, 0};
        for (int a = 0; a < 10; ++a) {
            sum += N[a];
            for (int j = 0; j < 3; ++j) dsum[j] += dN[a][j];
        }
        assert_true(fabs(sum - 1.0) < 1e-14);
        for (int j = 0; j < 3; ++j) assert_true(fabs(dsum[j]) < 1e-13);
        for (int j = 0; j < 3; ++j) {
            double Lp[4], Lm[4], Np[10], Nm[10], d[10][3];
            memcpy(Lp, L, sizeof L);
            memcpy(Lm, L, sizeof L);
            Lp[j] += h; Lp[3] -= h;
            Lm[j] -= h; Lm[3] += h;
            defsim__tet10_shape(Lp, Np, d);
            defsim__tet10_shape(Lm, Nm, d);
            for (int a = 0; a < 10; ++a) assert_true(fabs((Np[a] - Nm[a]) / (2 * h) - dN[a][j]) < 1e-8);
        }
    }
}

/* A quadratic box mesh of n^3 cells on [0, 1]^3. */
static defsim_mesh quad_box(int n)
{
    defsim_mesh m;
    memset(&m, 0, sizeof m);
    m.size = sizeof m;
    const double lo[3] = {0, 0, 0}, hi[3] = {1, 1, 1};
    TU_OK(defsim_mesh_box(lo, hi, n, n, n, &m));
    TU_OK(defsim_mesh_make_quadratic(&m));
    return m;
}

static defsim_world *quad_world(const defsim_mesh *m, defsim_model model, const char *backend,
                                double gy, defsim_body_id *id)
{
    defsim_world *w = tu_world(backend, gy, 1);
    defsim_body_def bd = test_mesh_body(m, model);
    bd.material.youngs_modulus = 1e5;
    bd.material.poisson_ratio = 0.3;
    bd.material.density = 1000.0;
    defsim_body_id b;
    if (defsim_world_add_body(w, &bd, &b) != DEFSIM_OK)
        fail_msg("add_body: %s", defsim_world_last_error(w));
    if (id) *id = b;
    return w;
}

/* The patch test: x = A X + c reproduces a homogeneous F = A, so every node off the boundary
 * carries zero force and the energy is V psi(A); a rigid rotation has zero energy and zero
 * forces everywhere. Every model, a 2^3-cell box (its interior nodes: the centre and the mid-edge
 * nodes of the inner edges). */
static void test_patch(void **state)
{
    (void)state;
    defsim_mesh m = quad_box(2);
    const double A[9] = {1.1, 0.2, -0.05, 0.03, 0.95, 0.1, -0.08, 0.04, 1.05};
    const double c = 0.7, s = sqrt(1.0 - 0.49);   /* a rotation about (1, 2, 2)/3 by acos 0.7 */
    const double n[3] = {1.0 / 3, 2.0 / 3, 2.0 / 3};
    double R[9];
    for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j) {
            const double cross = i == j ? 0.0 : (((j - i + 3) % 3 == 1) ? -1.0 : 1.0) * n[3 - i - j];
            R[3 * i + j] = c * (i == j) + (1 - c) * n[i] * n[j] + s * cross;
        }
    for (int mi = 0; mi < 4; ++mi) {
        defsim_world *w = quad_world(&m, MODELS[mi], "explicit_euler", 0.0, NULL);
        const int32_t nv = m.vertex_count;
        double *x = malloc(3 * (size_t)nv * sizeof *x), *f = malloc(3 * (size_t)nv * sizeof *f);
        for (int pass = 0; pass < 2; ++pass) {
            const double *T = pass ? R : A;
            for (int32_t v = 0; v < nv; ++v)
                for (int i = 0; i < 3; ++i) {
                    const double *X = m.positions + 3 * (int64_t)v;
                    x[3 * v + i] = T[3 * i] * X[0] + T[3 * i + 1] * X[1] + T[3 * i + 2] * X[2] + 0.3 * i;
                }
            TU_OK(defsim_world_set_state(w, x, NULL));
            TU_OK(defsim_world_forces(w, x, f));
            defsim_energy e;
            TU_OK(defsim_world_energy(w, &e));
            double fmax_all = 0.0, finner = 0.0;
            for (int32_t v = 0; v < nv; ++v) {
                const double *X = m.positions + 3 * (int64_t)v;
                int inner = 1;
                for (int i = 0; i < 3; ++i) inner &= X[i] > 1e-9 && X[i] < 1.0 - 1e-9;
                for (int i = 0; i < 3; ++i) {
                    fmax_all = fmax(fmax_all, fabs(f[3 * v + i]));
                    if (inner) finner = fmax(finner, fabs(f[3 * v + i]));
                }
            }
            defsim_material mat;
            defsim_material_init(&mat, sizeof mat, MODELS[mi]);
            mat.youngs_modulus = 1e5;
            mat.poisson_ratio = 0.3;
            double psi, P[9], psi0, P0[9];
            const double I[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1};
            TU_OK(defsim_material_eval(&mat, T, &psi, P, NULL));
            TU_OK(defsim_material_eval(&mat, I, &psi0, P0, NULL));
            const double expect = psi - psi0;   /* V = 1 */
            if (pass == 0) {
                printf("  %-18s homogeneous F: interior |f| %.2g of %.3g, energy %.12g vs V psi %.12g\n",
                       mat.model == DEFSIM_MODEL_STVK ? "stvk" : mat.model == DEFSIM_MODEL_COROTATED
                       ? "corotated" : mat.model == DEFSIM_MODEL_NEOHOOKEAN ? "neohookean" : "stable_neohookean",
                       finner, fmax_all, e.elastic, expect);
                assert_true(fmax_all > 1.0);
                assert_true(finner < 1e-9 * fmax_all);
                assert_true(fabs(e.elastic - expect) < 1e-11 * fabs(expect));
            } else {
                printf("  %-18s rotation: |f| %.2g, energy %.2g (E = 1e5 Pa)\n", "", fmax_all, e.elastic);
                assert_true(fmax_all < 1e-9);
                assert_true(fabs(e.elastic) < 1e-9);
            }
        }
        free(x);
        free(f);
        defsim_world_destroy(w);
    }
    defsim_mesh_free(&m);
}

/* One curved, distorted element at rest (mid-edge nodes off their edges' middles) in a deformed
 * state: forces against central differences of the energy and the Hessian (no projection)
 * against differences of the forces, every model. */
static void test_curved_element(void **state)
{
    (void)state;
    double X[30] = {1, 0.1, 0, 0.1, 0, 0, 0, 1.1, 0.05, 0, 0, 0.9};
    const int32_t tet[10] = {0, 1, 2, 3, 4, 5, 6, 7, 8, 9};
    unsigned long long seed = 9;
    for (int k = 0; k < 6; ++k) {
        const int a = defsim__tet10_edge[k][0], b = defsim__tet10_edge[k][1];
        for (int i = 0; i < 3; ++i)
            X[3 * (4 + k) + i] = 0.5 * (X[3 * a + i] + X[3 * b + i]) + 0.1 * tu_rand(&seed);
    }
    const double r = defsim__tet10_min_jacobian(X, tet);
    printf("  curved element: smallest Jacobian ratio %.3f\n", r);
    assert_true(r > 0.3 && r < 0.99);
    for (int mi = 0; mi < 4; ++mi) {
        defsim_world *w = tu_world("explicit_euler", 0.0, 1);
        defsim_body_def bd;
        defsim_body_def_init(&bd, sizeof bd);
        bd.rest_positions = X;
        bd.vertex_count = 10;
        bd.tets = tet;
        bd.tet_count = 1;
        bd.tet_nodes = 10;
        defsim_material_init(&bd.material, sizeof bd.material, MODELS[mi]);
        bd.material.youngs_modulus = 1e4;
        TU_OK(defsim_world_add_body(w, &bd, NULL));
        double x[30], f[30], fp[30], fm[30];
        for (int i = 0; i < 30; ++i) x[i] = 1.1 * X[i] + 0.03 * tu_rand(&seed);
        TU_OK(defsim__world_plan(w));
        const defsim__term *t = defsim__terms_find(&w->sys, DEFSIM__TERM_KIND_elastic_quadratic);
        assert_non_null(t);
        w->sys.projection = DEFSIM_PROJECTION_NONE;
        TU_OK(defsim_world_forces(w, x, f));
        double eg = 0.0, big = 0.0;
        const double h = 1e-6;
        for (int i = 0; i < 30; ++i) {
            const double x0 = x[i];
            x[i] = x0 + h;
            const double ep = t->ops->energy(t, &w->sys, &w->work, x, 0.0);
            x[i] = x0 - h;
            const double em = t->ops->energy(t, &w->sys, &w->work, x, 0.0);
            x[i] = x0;
            eg = fmax(eg, fabs(-(ep - em) / (2 * h) - f[i]));
            big = fmax(big, fabs(f[i]));
        }
        TU_OK(defsim__pattern_build(&w->sys));
        defsim_csc p;
        TU_OK(defsim__matrix_pattern(&w->sys, DEFSIM_TRIANGLE_FULL, &p));
        double *val = calloc((size_t)p.nnz, sizeof *val);
        const defsim_matrix_coeffs K1 = {1.0, 0.0, 0.0, 0.0};
        t->ops->values(t, &w->sys, x, &K1, 0, p.col_ptr, val, NULL);
        double eh = 0.0, hbig = 0.0;
        for (int64_t j = 0; j < p.n; ++j) {
            const double x0 = x[j];
            x[j] = x0 + h;
            TU_OK(defsim_world_forces(w, x, fp));
            x[j] = x0 - h;
            TU_OK(defsim_world_forces(w, x, fm));
            x[j] = x0;
            for (int64_t kk = p.col_ptr[j]; kk < p.col_ptr[j + 1]; ++kk) {
                const int64_t i = p.row_idx[kk];
                const double fd = -(fp[i] - fm[i]) / (2 * h);
                eh = fmax(eh, fabs(val[kk] - fd));
                hbig = fmax(hbig, fabs(fd));
            }
        }
        printf("  model %d: |f + dE/dx| %.2g of %.3g, |K + df/dx| %.2g of %.3g\n", (int)MODELS[mi],
               eg, big, eh, hbig);
        assert_true(big > 0.0 && eg < 1e-6 * big);
        assert_true(hbig > 0.0 && eh < 1e-6 * hbig);
        free(val);
        defsim_world_destroy(w);
    }
}

/* HRZ masses: positive, summing to rho V per element; on a straight element the corners get
 * 1/36 and the mid-edge nodes 4/27 of its mass (the consistent matrix's diagonal 6 : 32). */
static void test_mass(void **state)
{
    (void)state;
    double X[30] = {1, 0.1, 0, 0.2, 0, 0, 0, 1.3, 0.1, 0.1, 0.2, 0.8};
    const int32_t tet[10] = {0, 1, 2, 3, 4, 5, 6, 7, 8, 9};
    for (int k = 0; k < 6; ++k) {
        const int a = defsim__tet10_edge[k][0], b = defsim__tet10_edge[k][1];
        for (int i = 0; i < 3; ++i) X[3 * (4 + k) + i] = 0.5 * (X[3 * a + i] + X[3 * b + i]);
    }
    double dm[9];
    for (int a = 0; a < 3; ++a)
        for (int i = 0; i < 3; ++i) dm[3 * i + a] = X[3 * a + i] - X[9 + i];
    const double det = dm[0] * (dm[4] * dm[8] - dm[5] * dm[7]) - dm[1] * (dm[3] * dm[8] - dm[5] * dm[6]) +
                       dm[2] * (dm[3] * dm[7] - dm[4] * dm[6]);
    assert_true(det > 0.0);
    const double V = det / 6.0, rho = 1200.0;
    double m[10] = {0};
    defsim__tet10_mass(X, tet, rho, m);
    for (int a = 0; a < 10; ++a) {
        const double expect = rho * V * (a < 4 ? 1.0 / 36.0 : 4.0 / 27.0);
        assert_true(fabs(m[a] - expect) < 1e-13 * expect);
    }
    /* A quadratic box body: all masses positive, total rho V, as the world reports them. */
    defsim_mesh mesh = quad_box(3);
    defsim_world *w = quad_world(&mesh, DEFSIM_MODEL_COROTATED, "explicit_euler", 0.0, NULL);
    TU_OK(defsim__world_plan(w));
    double total = 0.0, lo = INFINITY;
    for (int32_t v = 0; v < w->sys.nv; ++v) {
        total += w->sys.mass[v];
        lo = fmin(lo, w->sys.mass[v]);
    }
    printf("  quadratic 3^3 box: total mass %.15g kg (rho V = 1000), smallest %.3g kg\n", total, lo);
    assert_true(fabs(total - 1000.0) < 1e-10);
    assert_true(lo > 0.0);
    defsim_world_destroy(w);
    defsim_mesh_free(&mesh);
}

/* add_body's validation: tet_nodes other than 4 or 10, a mid-edge node that inverts the element,
 * a repeated node; a left-handed element is reordered, with its mid-edge nodes, to the same
 * energy. */
static void test_validation(void **state)
{
    (void)state;
    double X[30] = {0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1};
    int32_t tet[10] = {0, 1, 2, 3, 4, 5, 6, 7, 8, 9};
    for (int k = 0; k < 6; ++k) {
        const int a = defsim__tet10_edge[k][0], b = defsim__tet10_edge[k][1];
        for (int i = 0; i < 3; ++i) X[3 * (4 + k) + i] = 0.5 * (X[3 * a + i] + X[3 * b + i]);
    }
    defsim_world *w = tu_world("explicit_euler", 0.0, 1);
    defsim_body_def bd;
    defsim_body_def_init(&bd, sizeof bd);
    assert_int_equal(bd.tet_nodes, 4);
    bd.rest_positions = X;
    bd.vertex_count = 10;
    bd.tets = tet;
    bd.tet_count = 1;
    bd.tet_nodes = 7;
    assert_int_equal(defsim_world_add_body(w, &bd, NULL), DEFSIM_ERR_INVALID_ARGUMENT);
    bd.tet_nodes = 10;
    /* right-handed here: reordered */
    int32_t reordered_before = (int32_t)tu_stat(w, "reordered_tets");
    TU_OK(defsim_world_add_body(w, &bd, NULL));
    assert_int_equal((int32_t)tu_stat(w, "reordered_tets") - reordered_before, 1);
    defsim_energy e0;
    double x[30];
    memcpy(x, X, sizeof x);
    x[0] += 0.1;
    x[3 * 4 + 1] += 0.05;
    TU_OK(defsim_world_set_state(w, x, NULL));
    TU_OK(defsim_world_energy(w, &e0));
    /* the same element given left-to-right-handed already (0 <-> 1, 12 <-> 02, 03 <-> 13) */
    defsim_world *w2 = tu_world("explicit_euler", 0.0, 1);
    int32_t tet2[10] = {1, 0, 2, 3, 4, 6, 5, 8, 7, 9};
    bd.tets = tet2;
    TU_OK(defsim_world_add_body(w2, &bd, NULL));
    assert_int_equal((int32_t)tu_stat(w2, "reordered_tets"), 0);
    defsim_energy e1;
    TU_OK(defsim_world_set_state(w2, x, NULL));
    TU_OK(defsim_world_energy(w2, &e1));
    printf("  reordered element energy %.15g, given positive %.15g\n", e0.elastic, e1.elastic);
    assert_true(e0.elastic > 0.0);
    assert_true(fabs(e0.elastic - e1.elastic) < 1e-14 * e0.elastic);
    /* a mid-edge node pushed across the element: inverted near it */
    double Y[30];
    memcpy(Y, X, sizeof Y);
    Y[3 * 9 + 0] = 0.45;   /* node 23 (mid of (0,1,0)-(0,0,1)) moved far inside, past the centroid */
    Y[3 * 9 + 1] = 0.05;
    Y[3 * 9 + 2] = 0.05;
    bd.rest_positions = Y;
    bd.tets = tet2;
    assert_int_equal(defsim_world_add_body(w2, &bd, NULL), DEFSIM_ERR_INVALID_MESH);
    printf("  inverted by a mid-edge node: %s\n", defsim_world_last_error(w2));
    bd.rest_positions = X;
    int32_t tet3[10] = {1, 0, 2, 3, 4, 6, 5, 8, 7, 7};
    bd.tets = tet3;
    assert_int_equal(defsim_world_add_body(w2, &bd, NULL), DEFSIM_ERR_INVALID_MESH);
    defsim_world_destroy(w);
    defsim_world_destroy(w2);
}

/* defsim_mesh_make_quadratic: counts, mid-edge vertices at the middles, the boundary as 4
 * outward sub-triangles per face (their signed volume sum is the box's volume), refusals. */
static void test_make_quadratic(void **state)
{
    (void)state;
    defsim_mesh m = quad_box(2);
    /* vertices 3^3 + edges: 7 per cell edge direction... counted as V + E of the Kuhn mesh */
    assert_int_equal(m.tet_nodes, 10);
    assert_int_equal(m.tet_count, 48);
    assert_int_equal(m.vertex_count, 125);   /* the 5^3 lattice of the half-spaced box */
    assert_int_equal(m.triangle_count, 4 * 48);   /* 6 sides x 8 faces x 4 */
    for (int32_t t = 0; t < m.tet_count; ++t)
        for (int k = 0; k < 6; ++k) {
            const int32_t *tt = m.tets + 10 * (int64_t)t;
            const double *a = m.positions + 3 * (int64_t)tt[defsim__tet10_edge[k][0]];
            const double *b = m.positions + 3 * (int64_t)tt[defsim__tet10_edge[k][1]];
            const double *c = m.positions + 3 * (int64_t)tt[4 + k];
            for (int i = 0; i < 3; ++i) assert_true(fabs(c[i] - 0.5 * (a[i] + b[i])) < 1e-15);
        }
    double vol = 0.0;
    for (int32_t t = 0; t < m.triangle_count; ++t) {
        const int32_t *tr = m.triangles + 3 * (int64_t)t;
        const double *a = m.positions + 3 * (int64_t)tr[0], *b = m.positions + 3 * (int64_t)tr[1];
        const double *c = m.positions + 3 * (int64_t)tr[2];
        vol += (a[0] * (b[1] * c[2] - b[2] * c[1]) - a[1] * (b[0] * c[2] - b[2] * c[0]) +
                a[2] * (b[0] * c[1] - b[1] * c[0])) / 6.0;
    }
    assert_true(fabs(vol - 1.0) < 1e-14);
    assert_int_equal(defsim_mesh_make_quadratic(&m), DEFSIM_ERR_INVALID_ARGUMENT);   /* twice */
    defsim_mesh_free(&m);
    assert_int_equal(defsim_mesh_make_quadratic(NULL), DEFSIM_ERR_INVALID_ARGUMENT);
    defsim_mesh old;
    memset(&old, 0, sizeof old);
    old.size = (uint32_t)offsetof(defsim_mesh, tet_nodes);
    const double lo[3] = {0, 0, 0}, hi[3] = {1, 1, 1};
    TU_OK(defsim_mesh_box(lo, hi, 1, 1, 1, &old));
    assert_int_equal(defsim_mesh_make_quadratic(&old), DEFSIM_ERR_INVALID_ARGUMENT);
    defsim_mesh_free(&old);
}

/* Stress read-back of a homogeneous stretch: every element reports sigma = P F^T / det F of
 * F and psi(F) - psi(I); the watchdog's diagnostics count an element inverted at a quadrature
 * point. */
static void test_stress_and_inversion(void **state)
{
    (void)state;
    defsim_mesh m = quad_box(1);
    defsim_body_id id;
    defsim_world *w = quad_world(&m, DEFSIM_MODEL_NEOHOOKEAN, "explicit_euler", 0.0, &id);
    const int32_t nv = m.vertex_count;
    double *x = malloc(3 * (size_t)nv * sizeof *x);
    const double A[9] = {1.2, 0.1, 0, 0, 0.9, 0, 0, 0, 1.0};
    for (int32_t v = 0; v < nv; ++v)
        for (int i = 0; i < 3; ++i) {
            const double *X = m.positions + 3 * (int64_t)v;
            x[3 * v + i] = A[3 * i] * X[0] + A[3 * i + 1] * X[1] + A[3 * i + 2] * X[2];
        }
    TU_OK(defsim_world_set_state(w, x, NULL));
    double sigma[9 * 6], vm[6], psi[6];
    TU_OK(defsim_body_element_stress(w, id, sigma, vm, psi, 6));
    defsim_material mat;
    defsim_material_init(&mat, sizeof mat, DEFSIM_MODEL_NEOHOOKEAN);
    mat.youngs_modulus = 1e5;
    mat.poisson_ratio = 0.3;
    double p, P[9];
    TU_OK(defsim_material_eval(&mat, A, &p, P, NULL));
    const double J = A[0] * A[4] * A[8] - A[1] * A[3] * A[8];
    for (int t = 0; t < 6; ++t) {
        for (int i = 0; i < 3; ++i)
            for (int j = 0; j < 3; ++j) {
                const double s = (P[3 * i] * A[3 * j] + P[3 * i + 1] * A[3 * j + 1] +
                                  P[3 * i + 2] * A[3 * j + 2]) / J;
                assert_true(fabs(sigma[9 * t + 3 * i + j] - s) < 1e-9 * 1e5);
            }
        assert_true(fabs(psi[t] - p) < 1e-9 * p);
        assert_true(vm[t] > 0.0);
    }
    assert_int_equal(defsim_body_element_stress(w, id, sigma, vm, psi, 5), DEFSIM_ERR_INVALID_ARGUMENT);
    TU_OK(defsim_world_step(w, 1e-6));   /* the diagnostics are measured once a step was taken */
    defsim_stats st;
    TU_OK(defsim_world_stats(w, &st));
    assert_int_equal(st.inverted_elements, 0);
    assert_true(st.min_volume_ratio > 0.0);
    /* the body's centre vertex (a mid-edge node of the cell diagonal) pushed through a face:
     * the elements around it invert at quadrature points, not at their corners */
    const double c[3] = {0.5, 0.5, 0.5};
    int32_t centre = -1;
    for (int32_t v = 0; v < nv; ++v) {
        const double *X = m.positions + 3 * (int64_t)v;
        if (fabs(X[0] - c[0]) + fabs(X[1] - c[1]) + fabs(X[2] - c[2]) < 1e-12) centre = v;
    }
    assert_true(centre >= 8);
    for (int32_t v = 0; v < nv; ++v)
        for (int i = 0; i < 3; ++i) x[3 * v + i] = m.positions[3 * (int64_t)v + i];
    x[3 * centre] = 1.6;
    TU_OK(defsim_world_set_state(w, x, NULL));
    TU_OK(defsim_world_stats(w, &st));
    printf("  centre pushed out: %lld inverted elements, smallest J %.3g\n",
           (long long)st.inverted_elements, st.min_volume_ratio);
    assert_true(st.inverted_elements > 0);
    assert_true(st.min_volume_ratio < 0.0);
    /* and the watchdog refuses a step from there (neo-Hookean is undefined at J <= 0) */
    assert_int_equal(defsim_world_step(w, 1e-6), DEFSIM_ERR_UNSTABLE);
    printf("  step: %s\n", defsim_world_last_error(w));
    free(x);
    defsim_world_destroy(w);
    defsim_mesh_free(&m);
}

/* The stable step of a quadratic body: positive; symplectic Euler at half of it keeps the
 * energy of a perturbed free body bounded over 400 steps, at twice it the watchdog trips (the
 * criterion defsim stress checks for linear tets: docs/stability.md). */
static void test_stable_step(void **state)
{
    (void)state;
    defsim_mesh m = quad_box(2);
    for (int pass = 0; pass < 2; ++pass) {
        defsim_world *w = quad_world(&m, DEFSIM_MODEL_STABLE_NEOHOOKEAN, "symplectic_euler", 0.0, NULL);
        const int32_t nv = m.vertex_count;
        double *x = malloc(3 * (size_t)nv * sizeof *x);
        unsigned long long seed = 21;
        for (int32_t i = 0; i < 3 * nv; ++i) x[i] = m.positions[i] + 0.01 * tu_rand(&seed);
        TU_OK(defsim_world_set_state(w, x, NULL));
        double h, omega;
        TU_OK(defsim_world_stable_step(w, &h, &omega));
        assert_true(h > 0.0 && isfinite(h));
        defsim_energy e0;
        TU_OK(defsim_world_energy(w, &e0));
        const double f = pass ? 2.0 : 0.5;
        defsim_status st = DEFSIM_OK;
        double emax = 0.0;
        for (int k = 0; k < 400 && st == DEFSIM_OK; ++k) {
            st = defsim_world_step(w, f * h);
            defsim_energy e;
            TU_OK(defsim_world_energy(w, &e));
            emax = fmax(emax, e.total);
        }
        printf("  stable step %.3g s (omega_max %.4g rad/s): at %.1f x: %s, largest energy %.3g of "
               "%.3g J\n", h, omega, f, defsim_status_string(st), emax, e0.total);
        if (pass) assert_int_equal(st, DEFSIM_ERR_UNSTABLE);
        else {
            TU_OK(st);
            assert_true(emax < 1.5 * e0.total);
        }
        free(x);
        defsim_world_destroy(w);
    }
    defsim_mesh_free(&m);
}

/* Body contact between quadratic bodies (its surface: each boundary face as 4 triangles through
 * its mid-edge nodes): a quadratic box dropped at 1 m/s onto another, whose bottom is pinned,
 * comes to rest on it (no vertex, mid-edge ones included, below the lower box's top by more
 * than 2 cm, where it falls through without body contact). */
static void test_body_contact(void **state)
{
    (void)state;
    if (!tu_available("newton_cholmod")) return;   /* a build without CHOLMOD */
    for (int on = 0; on < 2; ++on) {
        defsim_world *w = tu_implicit_world("newton_cholmod", -9.81, 1, 1e-6, 200,
                                            DEFSIM_PROJECTION_CLAMP);
        TU_OK(defsim_world_set_option(w, "core.body_contact", on ? "true" : "false"));
        defsim_body_id ids[2];
        const double los[2][3] = {{0, 0, 0}, {0.25, 0.52, 0.25}};
        const double his[2][3] = {{1, 0.5, 1}, {0.75, 0.82, 0.75}};
        for (int k = 0; k < 2; ++k) {
            defsim_mesh m;
            memset(&m, 0, sizeof m);
            m.size = sizeof m;
            TU_OK(defsim_mesh_box(los[k], his[k], 2, 1, 2, &m));
            TU_OK(defsim_mesh_make_quadratic(&m));
            defsim_body_def bd = test_mesh_body(&m, DEFSIM_MODEL_STABLE_NEOHOOKEAN);
            bd.material.youngs_modulus = 1e5;
            bd.material.density = 500.0;
            TU_OK(defsim_world_add_body(w, &bd, &ids[k]));
            defsim_mesh_free(&m);
        }
        assert_true(tu_pin_below(w, ids[0], 1, 0.0) > 0);
        const int32_t off = defsim_body_vertex_offset(w, ids[1]), nb = defsim_body_vertex_count(w, ids[1]);
        const int32_t nv = defsim_world_vertex_count(w);
        double *x = tu_positions(w), *v = calloc(3 * (size_t)nv, sizeof *v);
        for (int32_t i = off; i < off + nb; ++i) v[3 * i + 1] = -1.0;
        TU_OK(defsim_world_set_state(w, x, v));
        for (int s = 0; s < 40; ++s) {
            const defsim_status st = defsim_world_step(w, 0.01);
            if (st != DEFSIM_OK) fail_msg("step %d: %s", s, defsim_world_last_error(w));
        }
        TU_OK(defsim_world_get_positions(w, x, nv));
        double lowest = INFINITY;
        for (int32_t i = off; i < off + nb; ++i) lowest = fmin(lowest, x[3 * i + 1]);
        printf("  body contact %s: the upper box's lowest vertex at %.4g m after 0.4 s (the lower "
               "box's top at 0.5 m)\n", on ? "on" : "off", lowest);
        if (on) assert_true(lowest > 0.48);
        else assert_true(lowest < 0.4);
        free(x);
        free(v);
        defsim_world_destroy(w);
    }
}

static double now_s(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

/* The cost of one force evaluation per element, quadratic next to linear tets (the batched
 * kernels, and the scalar ones): printed, not asserted (machines differ). */
static void test_cost(void **state)
{
    (void)state;
    for (int quad = 0; quad < 2; ++quad) {
        defsim_mesh m;
        memset(&m, 0, sizeof m);
        m.size = sizeof m;
        const double lo[3] = {0, 0, 0}, hi[3] = {1, 1, 1};
        TU_OK(defsim_mesh_box(lo, hi, 10, 10, 10, &m));
        if (quad) TU_OK(defsim_mesh_make_quadratic(&m));
        defsim_world *w = quad_world(&m, DEFSIM_MODEL_STABLE_NEOHOOKEAN, "explicit_euler", 0.0, NULL);
        double *f = malloc(3 * (size_t)m.vertex_count * sizeof *f);
        TU_OK(defsim_world_forces(w, m.positions, f));
        const int reps = 20;
        const double t0 = now_s();
        for (int r = 0; r < reps; ++r) TU_OK(defsim_world_forces(w, m.positions, f));
        const double per = (now_s() - t0) / reps / m.tet_count;
        printf("  %s tets (stable neo-Hookean, %d elements, %d vertices): %.3g us per element "
               "per force evaluation\n", quad ? "quadratic" : "linear", (int)m.tet_count,
               (int)m.vertex_count, 1e6 * per);
        free(f);
        defsim_world_destroy(w);
        defsim_mesh_free(&m);
    }
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_rules),           cmocka_unit_test(test_shape),
        cmocka_unit_test(test_patch),           cmocka_unit_test(test_curved_element),
        cmocka_unit_test(test_mass),            cmocka_unit_test(test_validation),
        cmocka_unit_test(test_make_quadratic),  cmocka_unit_test(test_stress_and_inversion),
        cmocka_unit_test(test_stable_step),     cmocka_unit_test(test_body_contact),
        cmocka_unit_test(test_cost),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
