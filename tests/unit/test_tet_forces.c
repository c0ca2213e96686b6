/* SPDX-License-Identifier: MIT */
/* The batched SIMD force kernels (src/tet_forces.c): every variant this CPU runs against the
 * scalar reference kernels (linear and quadratic tets, mean-dilatation ones, shells; the
 * quadratic tets' energies too), and the co-rotated kernel's quaternion rotation against the
 * SVD. */
#include "test_util.h"

#include "energy.h"
#include "forces.h"
#include "isotropic.h"
#include "mesh_body.h"
#include "mat3.h"
#include "material.h"
#include "tet10.h"
#include "tet_forces.h"
#include "world.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static const char *const VARIANTS[3] = {"generic", "avx2", "avx512"};
static const defsim_model MODELS[4] = {DEFSIM_MODEL_STVK, DEFSIM_MODEL_COROTATED,
                                       DEFSIM_MODEL_NEOHOOKEAN, DEFSIM_MODEL_STABLE_NEOHOOKEAN};

static double fro(const double *A, int n)
{
    double s = 0.0;
    for (int i = 0; i < n; ++i) s += A[i] * A[i];
    return sqrt(s);
}

/* Elastic forces of the world at its state with the given kernels (NULL: scalar). */
static void forces_with(defsim_world *w, const defsim__tet_kernels *k, double *f)
{
    TU_OK(defsim__world_plan(w));
    w->sys.tet_kernels = k;
    double *x = tu_positions(w);
    TU_OK(defsim_world_forces(w, x, f));
    free(x);
}

/* Adds an nx ny nz-cell box of quadratic (10-node) tets on [lo, hi] of the given model
 * (mixed: the mean-dilatation element, volume_averaging). */
static void add_quad_box(defsim_world *w, defsim_model model, int mixed, int nx, int ny, int nz,
                         const double lo[3], const double hi[3], double E, double nu)
{
    defsim_mesh m;
    memset(&m, 0, sizeof m);
    m.size = sizeof m;
    TU_OK(defsim_mesh_box(lo, hi, nx, ny, nz, &m));
    TU_OK(defsim_mesh_make_quadratic(&m));
    defsim_body_def bd = test_mesh_body(&m, model);
    bd.material.youngs_modulus = E;
    bd.material.poisson_ratio = nu;
    bd.material.density = 1000.0;
    bd.volume_averaging = mixed;
    if (defsim_world_add_body(w, &bd, NULL) != DEFSIM_OK)
        fail_msg("add_body: %s", defsim_world_last_error(w));
    defsim_mesh_free(&m);
}

/* The element kinds of these tests: linear tets, quadratic ones, mean-dilatation quadratic ones
 * (their group: the model's index plus kind_group[kind]). */
enum { LINEAR = 0, QUAD = 1, QMIX = 2 };
static const int kind_group[3] = {0, DEFSIM__QUAD_GROUP, DEFSIM__QMIX_GROUP};
static const char *const kind_name[3] = {"linear", "quadratic", "mean-dilatation"};

/* Two boxes of model MODELS[mi] (quad: an element kind above) whose colours do not fill whole batches
 * (5x3x3 cells, 270 elements, and 2x2x3, 72), of different Lame parameters, deformed by a shear
 * and random displacements of 6 % of a cell (set as the world's state, also returned in *xo). */
static defsim_world *deformed_boxes(int mi, int quad, double **xo)
{
    defsim_world *w = tu_world("symplectic_euler", 0.0, 1);
    const double lo[3] = {0, 0, 0}, hi[3] = {2.5, 1.5, 1.5}, lo2[3] = {3, 0, 0},
                 hi2[3] = {4, 1, 1};
    if (quad) {
        add_quad_box(w, MODELS[mi], quad == QMIX, 5, 3, 3, lo, hi, 1e5, 0.35);
        add_quad_box(w, MODELS[mi], quad == QMIX, 2, 2, 3, lo2, hi2, 3e6, 0.45);
    } else {
        tu_add_box(w, MODELS[mi], 5, 3, 3, lo, hi, 1e5, 0.35, 1000.0);
        tu_add_box(w, MODELS[mi], 2, 2, 3, lo2, hi2, 3e6, 0.45, 1000.0);
    }
    const int n = defsim_world_vertex_count(w);
    double *x = tu_positions(w);
    unsigned long long seed = (quad ? 77 : 42) + (unsigned long long)mi;
    if (quad == QMIX) seed += 100;
    for (int i = 0; i < n; ++i) {
        x[3 * i] += 0.2 * x[3 * i + 1];
        for (int c = 0; c < 3; ++c) x[3 * i + c] += 0.03 * tu_rand(&seed);
    }
    TU_OK(defsim_world_set_state(w, x, NULL));
    *xo = x;
    return w;
}

/* deformed_boxes' forces in every variant this CPU runs against the scalar kernels, within
 * 1e-12 relative, tails and padding lanes included. Returns the variants tested. */
static int variants_vs_scalar(int mi, int quad)
{
    double *x;
    defsim_world *w = deformed_boxes(mi, quad, &x);
    const int n = defsim_world_vertex_count(w);
    int tested = 0;
    double *ref = malloc(3 * (size_t)n * sizeof *ref), *f = malloc(3 * (size_t)n * sizeof *f);
    forces_with(w, NULL, ref);
    assert_true(fro(ref, 3 * n) > 1.0);
    const defsim__group *g = &w->sys.groups[kind_group[quad] + mi];
    assert_int_equal(g->n, 270 + 72);   /* the group whose kernels are meant */
    assert_non_null(g->bdata);
    for (int v = 0; v < 3; ++v) {
        const defsim__tet_kernels *k = defsim__tet_kernels_find(VARIANTS[v]);
        if (!k) continue;
        forces_with(w, k, f);
        double d = tu_rel_diff(f, ref, 3 * n, 0.0);
        if (quad)
            printf("  %s, model %d, %s: rel diff %.3g\n", kind_name[quad], (int)MODELS[mi],
                   k->name, d);
        if (!(d < 1e-12))
            fail_msg("%s model %d, %s: rel diff %g", kind_name[quad], MODELS[mi], k->name, d);
        ++tested;
    }
    free(x); free(ref); free(f);
    defsim_world_destroy(w);
    return tested;
}

/* Linear tets: every model, every variant. */
static void test_variants_match_scalar(void **state)
{
    (void)state;
    int tested = 0;
    for (int mi = 0; mi < 4; ++mi) tested += variants_vs_scalar(mi, LINEAR);
    assert_true(tested >= 4);   /* the generic variant always exists */
    assert_non_null(defsim__tet_kernels_best());
    assert_null(defsim__tet_kernels_find("sse9"));
}

/* The quadratic tets' batched kernels (tet_batch.h's DEFSIM__BATCHED_QKERNEL) against the scalar
 * kernel of term_elastic_quadratic.c, every model (the batched kernel sums the points' nodal
 * forces before scattering, the scalar one scatters point by point). */
static void test_quadratic_match_scalar(void **state)
{
    (void)state;
    int tested = 0;
    for (int mi = 0; mi < 4; ++mi) tested += variants_vs_scalar(mi, QUAD);
    assert_true(tested >= 4);
}

/* The mean-dilatation quadratic tets' batched forces (tet_batch.h's DEFSIM__BATCHED_QMIXED)
 * against the scalar kernel of term_quadratic_mixed.c, each model with a split (neo-Hookean,
 * stable neo-Hookean), every variant; the table has none for StVK and co-rotated. */
static void test_quadratic_mixed_match_scalar(void **state)
{
    (void)state;
    int tested = 0;
    for (int mi = 2; mi < 4; ++mi) tested += variants_vs_scalar(mi, QMIX);
    assert_true(tested >= 2);
    const defsim__tet_kernels *k = defsim__tet_kernels_find("generic");
    assert_null(k->qmforces[0]);
    assert_null(k->qmenergy[1]);
}

/* Elastic energy of the world at x with the given kernels (NULL: scalar). */
static double energy_with(defsim_world *w, const defsim__tet_kernels *k, const double *x)
{
    TU_OK(defsim__world_plan(w));
    w->sys.tet_kernels = k;
    return defsim__elastic_energy(&w->sys, &w->work, x);
}

/* The batched energies of quadratic tets (kind QUAD: tet_batch.h's DEFSIM__BATCHED_QENERGY;
 * QMIX, mean-dilatation: DEFSIM__BATCHED_QMIXED) on deformed_boxes against the scalar element
 * energies (term_elastic_quadratic.c, term_quadratic_mixed.c), every model (QMIX: those with a
 * split), every variant: within 1e-12 relative (the subtracted rest energy included).
 * Sensitivity: the smallest single quadrature point's term over all elements and points, w_q
 * (psi(F_q) - psi(I)) (QMIX: of psi_iso), is asserted above 1e-9 of the total, so a kernel that
 * dropped (or doubled) any one point of any element, or any lane, would miss the tolerance by
 * more than 1000 times. Returns the variants tested. */
static int energy_vs_scalar(int mi, int kind)
{
    double *x;
    defsim_world *w = deformed_boxes(mi, kind, &x);
    const double ref = energy_with(w, NULL, x);
    assert_true(isfinite(ref) && ref > 1.0);
    const defsim__group *g = &w->sys.groups[kind_group[kind] + mi];
    assert_int_equal(g->n, 270 + 72);
    double smallest = INFINITY;
    for (int32_t e = 0; e < g->n; ++e) {
        const double *r = g->qrest + DEFSIM__TET10_REST * (int64_t)e;
        const double mu = g->mu[e], la = g->lambda[e], I[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1};
        double P[9];
        for (int q = 0; q < DEFSIM__TET10_QP; ++q) {
            const double *G = r + DEFSIM__TET10_QSTRIDE * q;
            double F[9];
            defsim__tet10_F(x, g->idx + 10 * (int64_t)e, G, F);
            const double term = kind == QMIX ? g->law->split->P(mu, la, F, P) -
                                                   g->law->split->P(mu, la, I, P)
                                             : g->law->psi(mu, la, F) - g->law->psi(mu, la, I);
            if (fabs(G[30] * term) < smallest) smallest = fabs(G[30] * term);
        }
    }
    printf("  %s energy, model %d: E %.6g J, smallest point term / E %.3g\n", kind_name[kind],
           (int)MODELS[mi], ref, smallest / ref);
    assert_true(smallest / ref > 1e-9);
    int tested = 0;
    for (int v = 0; v < 3; ++v) {
        const defsim__tet_kernels *k = defsim__tet_kernels_find(VARIANTS[v]);
        if (!k) continue;
        const double e = energy_with(w, k, x), d = fabs(e - ref) / ref;
        printf("  %s energy, model %d, %s: rel diff %.3g\n", kind_name[kind], (int)MODELS[mi],
               k->name, d);
        if (!(d < 1e-12))
            fail_msg("%s energy, model %d, %s: rel diff %g", kind_name[kind], MODELS[mi], k->name,
                     d);
        ++tested;
    }
    free(x);
    defsim_world_destroy(w);
    return tested;
}

/* A mirrored neo-Hookean quadratic box (every J < 0, mixed: the mean-dilatation element) has
 * energy +inf with the scalar and every batched kernel. */
static void inverted_energy_is_infinite(int mixed)
{
    defsim_world *w = tu_world("symplectic_euler", 0.0, 1);
    const double lo[3] = {0, 0, 0}, hi[3] = {1, 1, 1};
    add_quad_box(w, DEFSIM_MODEL_NEOHOOKEAN, mixed, 2, 1, 1, lo, hi, 1e5, 0.3);
    const int n = defsim_world_vertex_count(w);
    double *x = tu_positions(w);
    for (int i = 0; i < n; ++i) x[3 * i + 2] = -x[3 * i + 2];
    assert_true(energy_with(w, NULL, x) == INFINITY);
    for (int v = 0; v < 3; ++v) {
        const defsim__tet_kernels *k = defsim__tet_kernels_find(VARIANTS[v]);
        if (k) assert_true(energy_with(w, k, x) == INFINITY);
    }
    free(x);
    defsim_world_destroy(w);
}

static void test_quadratic_energy_match_scalar(void **state)
{
    (void)state;
    int tested = 0;
    for (int mi = 0; mi < 4; ++mi) tested += energy_vs_scalar(mi, QUAD);
    assert_true(tested >= 4);
    inverted_energy_is_infinite(0);
}

static void test_quadratic_mixed_energy_match_scalar(void **state)
{
    (void)state;
    int tested = 0;
    for (int mi = 2; mi < 4; ++mi) tested += energy_vs_scalar(mi, QMIX);
    assert_true(tested >= 2);
    inverted_energy_is_infinite(1);
}

/* The batched energies over more than one block of batches (10 x 10 x 6 cells: 3,600 elements
 * in about 460 batches, 2 blocks of 256) on 1 and 3 threads: bit-identical, for both quadratic
 * elements (neo-Hookean), and equal to the scalar energy within 1e-12. */
static void test_quadratic_energy_threads(void **state)
{
    (void)state;
    for (int mixed = 0; mixed < 2; ++mixed) {
        double e[2];
        for (int k = 0; k < 2; ++k) {
            defsim_world *w = tu_world("symplectic_euler", 0.0, k == 0 ? 1 : 3);
            const double lo[3] = {0, 0, 0}, hi[3] = {1, 1, 0.6};
            add_quad_box(w, DEFSIM_MODEL_NEOHOOKEAN, mixed, 10, 10, 6, lo, hi, 1e5, 0.45);
            const int n = defsim_world_vertex_count(w);
            double *x = tu_positions(w);
            unsigned long long seed = 5;
            for (int i = 0; i < 3 * n; ++i) x[i] += 0.005 * tu_rand(&seed);
            e[k] = energy_with(w, defsim__tet_kernels_best(), x);
            const defsim__group *g =
                &w->sys.groups[(mixed ? DEFSIM__QMIX_GROUP : DEFSIM__QUAD_GROUP) + 2];
            assert_true(g->nbatch > DEFSIM__REDUCE_BLOCK / DEFSIM__BATCH);
            const double ref = energy_with(w, NULL, x);
            assert_true(ref > 0.0 && fabs(e[k] - ref) < 1e-12 * ref);
            free(x);
            defsim_world_destroy(w);
        }
        assert_memory_equal(&e[0], &e[1], sizeof e[0]);
    }
}

/* The shells' batched kernels (shell_batch.c): a bent and perturbed 7 x 5 sheet (70 triangles,
 * 97 hinges: colours that do not fill whole batches), each membrane law with hinges, in every
 * variant against the scalar kernels: within 1e-12 relative, and bit for bit in the generic
 * variant (no FMA) for StVK, orthotropic StVK and the hinges (neo-Hookean's vector log is within
 * 1 ulp of libm's, so it may differ there). A triangle collapsed to a point (F = 0: a neo-Hookean
 * energy of +inf) adds no force in any. */
static void test_shells_match_scalar(void **state)
{
    (void)state;
    const int32_t laws[3] = {DEFSIM_SHELL_MEMBRANE_STVK, DEFSIM_SHELL_MEMBRANE_NEOHOOKEAN,
                             DEFSIM_SHELL_MEMBRANE_ORTHOTROPIC_STVK};
    int tested = 0;
    for (int k = 0; k < 3; ++k) {
        defsim_world *w = tu_world("symplectic_euler", 0.0, 1);
        const double o[3] = {0, 0, 0}, u[3] = {0.35, 0, 0}, v[3] = {0, 0.25, 0};
        defsim_mesh m;
        memset(&m, 0, sizeof m);
        m.size = sizeof m;
        TU_OK(defsim_mesh_cloth(o, u, v, 7, 5, &m));
        defsim_body_def d = test_shell_body(&m);
        d.shell_membrane = laws[k];
        d.shell_youngs_modulus = 2e5;
        d.shell_warp_direction[1] = 0.4;
        d.shell_bending_rigidity = 1e-4;
        d.shell_bending_rigidity_weft = 3e-5;
        TU_OK(defsim_world_add_body(w, &d, NULL));
        /* a second body, one triangle, to be collapsed onto a point (F = 0, det C = 0) */
        const double tri_rest[9] = {0.5, 0, 0, 0.6, 0, 0, 0.5, 0.1, 0};
        const int32_t tri[3] = {0, 1, 2};
        d.rest_positions = tri_rest;
        d.vertex_count = 3;
        d.triangles = tri;
        d.triangle_count = 1;
        TU_OK(defsim_world_add_body(w, &d, NULL));
        const int n = defsim_world_vertex_count(w);
        double *x = tu_positions(w);
        unsigned long long seed = 7 + (unsigned long long)k;
        for (int i = 0; i < n; ++i) {
            x[3 * i + 2] += 0.8 * x[3 * i] * x[3 * i];   /* bent: the hinges are not at rest */
            for (int c = 0; c < 3; ++c) x[3 * i + c] += 0.004 * tu_rand(&seed);
        }
        for (int i = 9; i > 0; --i) x[3 * n - i] = 0.0;   /* the lone triangle collapsed */
        TU_OK(defsim_world_set_state(w, x, NULL));
        double *ref = malloc(3 * (size_t)n * sizeof *ref), *f = malloc(3 * (size_t)n * sizeof *f);
        forces_with(w, NULL, ref);
        assert_true(fro(ref, 3 * n) > 1.0);
        for (int i = 0; i < 3 * n; ++i) assert_true(isfinite(ref[i]));
        for (int vi = 0; vi < 3; ++vi) {
            const defsim__tet_kernels *kv = defsim__tet_kernels_find(VARIANTS[vi]);
            if (!kv) continue;
            forces_with(w, kv, f);
            const double dd = tu_rel_diff(f, ref, 3 * n, 0.0);
            printf("  shells, membrane %d, %s: rel diff %.3g\n", (int)laws[k], kv->name, dd);
            if (!(dd < 1e-12)) fail_msg("membrane %d, %s: rel diff %g", (int)laws[k], kv->name, dd);
            if (vi == 0 && k != 1) assert_memory_equal(f, ref, 3 * (size_t)n * sizeof *f);
            if (k == 1)
                for (int i = 9; i > 0; --i) assert_true(f[3 * n - i] == 0.0);
            ++tested;
        }
        free(x); free(ref); free(f);
        defsim_mesh_free(&m);
        defsim_world_destroy(w);
    }
    assert_true(tested >= 3);
}

/* Neo-Hookean forces are NaN (a step reports unstable) on inverted elements in every variant. */
static void test_neohookean_inverted_is_unstable(void **state)
{
    (void)state;
    for (int v = 0; v < 3; ++v) {
        const defsim__tet_kernels *k = defsim__tet_kernels_find(VARIANTS[v]);
        if (!k) continue;
        defsim_world *w = tu_world("symplectic_euler", 0.0, 1);
        const double lo[3] = {0, 0, 0}, hi[3] = {1, 1, 1};
        tu_add_box(w, DEFSIM_MODEL_NEOHOOKEAN, 2, 1, 1, lo, hi, 1e5, 0.3, 1000.0);
        int n = defsim_world_vertex_count(w);
        double *x = tu_positions(w), *f = malloc(3 * (size_t)n * sizeof *f);
        for (int i = 0; i < n; ++i) x[3 * i + 2] = -x[3 * i + 2];   /* mirror: every J < 0 */
        TU_OK(defsim__world_plan(w));
        w->sys.tet_kernels = k;
        assert_int_equal(defsim__forces(&w->sys, x, NULL, DEFSIM_FORCE_ELASTIC, f, NULL),
                         DEFSIM_ERR_UNSTABLE);
        for (int i = 0; i < 3 * n; ++i) assert_true(isnan(f[i]));
        free(x); free(f);
        defsim_world_destroy(w);
    }
}

/* F = U diag(s) V^T for random proper rotations U, V (from normalised random quaternions). */
static void random_rotation(unsigned long long *seed, double R[9])
{
    double q[4], n = 0.0;
    for (int i = 0; i < 4; ++i) { q[i] = tu_rand(seed); n += q[i] * q[i]; }
    n = sqrt(n);
    double w = q[0] / n, x = q[1] / n, y = q[2] / n, z = q[3] / n;
    double r[9] = {1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y),
                   2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x),
                   2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)};
    memcpy(R, r, sizeof r);
}

static void compose(unsigned long long *seed, const double s[3], double F[9])
{
    double U[9], V[9], US[9];
    random_rotation(seed, U);
    random_rotation(seed, V);
    for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j) US[3 * i + j] = U[3 * i + j] * s[j];
    defsim__m3_mul_nt(US, V, F);
}

enum { NF = 1200 };

/* The quaternion rotation equals the SVD's R = U V^T, to rounding over the conditioning
 * 1 / (s1 + s2) of R itself, for random, near-singular, inverted and scaled F; and the
 * co-rotated stress agrees with the co-rotated model's P to 1e-12 relative where R is unique. */
static void test_rotation_matches_svd(void **state)
{
    (void)state;
    double *F = malloc(9 * NF * sizeof *F), *R = malloc(9 * NF * sizeof *R);
    double *gap = malloc(NF * sizeof *gap);
    unsigned long long seed = 7;
    for (int e = 0; e < NF; ++e) {
        double *Fe = F + 9 * e;
        int kind = e % 8;
        if (kind == 0) {
            for (int i = 0; i < 9; ++i) Fe[i] = 2.0 * tu_rand(&seed);   /* random, any sign */
        } else if (kind == 1) {
            for (int i = 0; i < 9; ++i) Fe[i] = (i % 4 == 0) + 0.3 * tu_rand(&seed);  /* ~I */
        } else {
            double s[3];
            double a = 1.0 + 0.5 * tu_rand(&seed), b = a * (0.5 + 0.5 * fabs(tu_rand(&seed)));
            switch (kind) {
            case 2: s[0] = a; s[1] = b; s[2] = 1e-9 * b; break;          /* near-singular */
            case 3: s[0] = a; s[1] = b; s[2] = 0.0; break;               /* flat */
            case 4: s[0] = a; s[1] = b; s[2] = -0.7 * b; break;          /* inverted */
            case 5: s[0] = a; s[1] = b; s[2] = -(1.0 - 1e-4) * b; break; /* nearly degenerate */
            case 6: s[0] = 1e150 * a; s[1] = 1e150 * b; s[2] = 1e149 * b; break;
            default: s[0] = 1e-150 * a; s[1] = 1e-150 * b; s[2] = -1e-151 * b; break;
            }
            compose(&seed, s, Fe);
        }
        if (e == 8) for (int i = 0; i < 9; ++i) Fe[i] = (i % 4 == 0);   /* exactly I */
        if (e == 16) for (int i = 0; i < 9; ++i) Fe[i] = (i % 4 == 0) ? (i == 8 ? -1.0 : 1.0) : 0.0;
        double U[9], s[3], V[9];
        defsim__svd3(Fe, U, s, V);
        gap[e] = (s[1] + s[2]) / (s[0] > 0.0 ? s[0] : 1.0);
    }
    int tested = 0;
    for (int v = 0; v < 3; ++v) {
        const defsim__tet_kernels *k = defsim__tet_kernels_find(VARIANTS[v]);
        if (!k) continue;
        k->rotation(NF, F, R);
        double worst = 0.0, worst_p = 0.0;
        for (int e = 0; e < NF; ++e) {
            const double *Fe = F + 9 * e, *Re = R + 9 * e;
            double U[9], s[3], V[9], Rs[9], RtR[9], d[9];
            defsim__svd3(Fe, U, s, V);
            defsim__m3_mul_nt(U, V, Rs);
            /* Always a proper rotation that maximises tr(R^T F) = s0 + s1 + s2. */
            defsim__m3_mul_tn(Re, Re, RtR);
            for (int i = 0; i < 9; ++i) d[i] = RtR[i] - (i % 4 == 0);
            assert_true(fro(d, 9) < 1e-14);
            assert_true(fabs(defsim__m3_det(Re) - 1.0) < 1e-14);
            double trRF = 0.0;
            for (int i = 0; i < 9; ++i) trRF += Re[i] * Fe[i];
            assert_true(fabs(trRF - (s[0] + s[1] + s[2])) <= 1e-14 * fro(Fe, 9));
            if (e == 16) continue;   /* diag(1, 1, -1): s1 + s2 = 0, R not unique */
            for (int i = 0; i < 9; ++i) d[i] = Re[i] - Rs[i];
            double err = fro(d, 9) * gap[e];
            if (err > worst) worst = err;
            /* Stresses where R is well determined (gap >= 1e-3), in units of mu = lambda = 1. */
            if (gap[e] >= 1e-3 && fabs(s[0]) < 1e3 && fabs(s[0]) > 1e-3) {
                double Ps[9], Pf[9];
                defsim__model_corotated.P(1.0, 1.0, Fe, Ps);
                double tr = trRF - 3.0;
                for (int i = 0; i < 9; ++i) Pf[i] = 2.0 * (Fe[i] - Re[i]) + tr * Re[i];
                for (int i = 0; i < 9; ++i) d[i] = Pf[i] - Ps[i];
                double rel = fro(d, 9) / fro(Ps, 9);
                if (rel > worst_p) worst_p = rel;
            }
        }
        if (!(worst < 1e-14)) fail_msg("%s: |R - R_svd| (s1 + s2)/s0 = %g", k->name, worst);
        if (!(worst_p < 1e-12)) fail_msg("%s: |P - P_svd| / |P| = %g", k->name, worst_p);
        /* F = 0 gives R = I, as the SVD path does. */
        double Z[9] = {0}, RZ[9];
        k->rotation(1, Z, RZ);
        for (int i = 0; i < 9; ++i) assert_true(RZ[i] == (i % 4 == 0 ? 1.0 : 0.0));
        ++tested;
    }
    assert_true(tested >= 1);
    free(F); free(R); free(gap);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_variants_match_scalar),
        cmocka_unit_test(test_quadratic_match_scalar),
        cmocka_unit_test(test_quadratic_energy_match_scalar),
        cmocka_unit_test(test_quadratic_mixed_match_scalar),
        cmocka_unit_test(test_quadratic_mixed_energy_match_scalar),
        cmocka_unit_test(test_quadratic_energy_threads),
        cmocka_unit_test(test_shells_match_scalar),
        cmocka_unit_test(test_neohookean_inverted_is_unstable),
        cmocka_unit_test(test_rotation_matches_svd),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
