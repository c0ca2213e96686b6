/* SPDX-License-Identifier: MIT */
/*
 * The mean-dilatation quadratic tet (quadratic bodies with defsim_body_def.volume_averaging,
 * src/term_quadratic_mixed.c, docs/elements.md) as physics (its ops' finite differences are
 * test_terms.c's test_quadratic_mixed):
 *  - refused for the models without an isochoric / volumetric split (StVK, co-rotated), as the
 *    linear volume-averaged tets are; accepted for neo-Hookean and stable neo-Hookean;
 *  - the patch test: x = F X on a distorted quadratic mesh (interior corners moved) gives the
 *    analytic energy V (psi(F) - psi(I)), no force on interior nodes, the standard element's
 *    energy and forces, and the analytic Cauchy stress from the read-back in every element;
 *  - 1 and 2 threads give the same bits (explicit steps with stiffness damping, the matrix values
 *    and products, on boxes whose colours pass the term's parallel thresholds); the explicit
 *    stable step sees the element (test_volume_averaging's test_checkpoint: a checkpoint keeps
 *    it, bit-identical);
 *  - the issue-29 cantilever (test_tet10_accuracy's: 3 m x 1 m x 1 m clamped at x = 0, stable
 *    neo-Hookean, E = 1e8, density 1000, its own weight, static equilibrium by two newton_cholmod
 *    steps of 10 s) against the converged references of test_tet10_accuracy (REF_CANTILEVER at
 *    nu = 0.3, REF_CANTILEVER_NU499 at nu = 0.499, computed by its --long run from displacement
 *    quadratic tets on 18, 24 and 30 cells along the beam and confirmed by the volume-averaged
 *    linear tets' own extrapolation): at nu = 0.499 within 3 % at 12 x 4 x 4 cells (issue 29;
 *    measured -0.04 %, asserted within 0.5 %; the displacement element is 4.1 % short there)
 *    and at 18 x 6 x 6, and at nu = 0.3 within 2 % of REF_CANTILEVER at 12 x 4 x 4 (+0.40 %,
 *    asserted within 1 %: the remedy does not spoil compressible bending).
 *
 * `test_quadratic_mixed --one N NU MIXED` solves and prints one cantilever (3N x N x N cells,
 * quadratic tets, the mean-dilatation element if MIXED is 1); `--filter PATTERN` runs the tests
 * whose names match.
 */
#include "test_util.h"

#include "mesh_body.h"

#include "assembly.h"
#include "system.h"
#include "world.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

/* test_tet10_accuracy's converged references (m; its --long run recomputes them). */
static const double REF_CANTILEVER = 1.2952e-2, REF_CANTILEVER_NU499 = 1.2471e-2;

static double now_s(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

static void box_mesh(const double lo[3], const double hi[3], int nx, int ny, int nz,
                     defsim_mesh *m)
{
    memset(m, 0, sizeof *m);
    m->size = sizeof *m;
    TU_OK(defsim_mesh_box(lo, hi, nx, ny, nz, m));
}

static defsim_body_def body_def(const defsim_mesh *m, defsim_model model, double nu, int mixed)
{
    defsim_body_def bd = test_mesh_body(m, model);
    bd.material.youngs_modulus = 1e5;
    bd.material.poisson_ratio = nu;
    bd.material.density = 1000.0;
    bd.volume_averaging = mixed;
    return bd;
}

/* A quadratic box with its interior corners moved (seeded, a tenth of a cell): distorted,
 * straight-sided elements (mid-edge nodes at their edges' middles). */
static void distorted_quadratic_box(const double lo[3], const double hi[3], int nx, int ny,
                                    int nz, defsim_mesh *m)
{
    box_mesh(lo, hi, nx, ny, nz, m);
    const double cell = (hi[0] - lo[0]) / nx;
    unsigned long long seed = 17;
    for (int32_t i = 0; i < m->vertex_count; ++i) {
        double *p = m->positions + 3 * (int64_t)i;
        int inside = 1;
        for (int k = 0; k < 3; ++k)
            inside &= p[k] > lo[k] + 1e-9 && p[k] < hi[k] - 1e-9;
        if (inside)
            for (int k = 0; k < 3; ++k) p[k] += 0.1 * cell * tu_rand(&seed);
    }
    TU_OK(defsim_mesh_make_quadratic(m));
}

/* ------------------------------------------------------------------------------------------ */

static void test_refused(void **state)
{
    (void)state;
    const double lo[3] = {0, 0, 0}, hi[3] = {1, 1, 1};
    defsim_mesh m;
    box_mesh(lo, hi, 1, 1, 1, &m);
    TU_OK(defsim_mesh_make_quadratic(&m));
    defsim_world *w = tu_world("explicit_euler", 0.0, 1);
    const defsim_model bad[2] = {DEFSIM_MODEL_STVK, DEFSIM_MODEL_COROTATED};
    for (int k = 0; k < 2; ++k) {
        defsim_body_def bd = body_def(&m, bad[k], 0.3, 1);
        assert_int_equal(defsim_world_add_body(w, &bd, NULL), DEFSIM_ERR_INVALID_MATERIAL);
        assert_non_null(strstr(defsim_world_last_error(w), "volume_averaging"));
        printf("  quadratic, model %d refused: %s\n", (int)bad[k], defsim_world_last_error(w));
    }
    assert_int_equal(defsim_world_vertex_count(w), 0);
    const defsim_model good[2] = {DEFSIM_MODEL_NEOHOOKEAN, DEFSIM_MODEL_STABLE_NEOHOOKEAN};
    for (int k = 0; k < 2; ++k) {
        defsim_body_def bd = body_def(&m, good[k], 0.3, 1);
        TU_OK(defsim_world_add_body(w, &bd, NULL));
    }
    assert_int_equal(defsim_world_vertex_count(w), 2 * m.vertex_count);
    TU_OK(defsim__world_plan(w));
    for (int k = 0; k < DEFSIM__TET_MODELS; ++k) {
        assert_int_equal(w->sys.groups[DEFSIM__QUAD_GROUP + k].n, 0);   /* none standard */
        assert_int_equal(w->sys.vgroups[k].g.n, 0);                    /* none linear */
    }
    defsim_world_destroy(w);
    defsim_mesh_free(&m);
}

/* The patch test: x = F X on the distorted 3 x 2 x 2-cell quadratic box. F_q = F at every
 * point, so Jbar = det F and the element is the standard one exactly; the rule integrates the
 * straight elements' constant stress exactly, so interior nodes feel no force. (Curved
 * elements: test_terms' differences.) */
static void test_patch(void **state)
{
    (void)state;
    const double lo[3] = {0, 0, 0}, hi[3] = {0.3, 0.2, 0.2};
    const double F[9] = {1.04, 0.05, -0.02, 0.03, 0.97, 0.06, -0.01, 0.02, 1.06};
    const defsim_model models[2] = {DEFSIM_MODEL_NEOHOOKEAN, DEFSIM_MODEL_STABLE_NEOHOOKEAN};
    defsim_mesh m;
    distorted_quadratic_box(lo, hi, 3, 2, 2, &m);
    const int n = m.vertex_count, nt = m.tet_count;
    double *x = malloc(3 * (size_t)n * sizeof *x), *f[2];
    for (int i = 0; i < n; ++i)
        for (int r = 0; r < 3; ++r) {
            const double *X = m.positions + 3 * i;
            x[3 * i + r] = F[3 * r] * X[0] + F[3 * r + 1] * X[1] + F[3 * r + 2] * X[2];
        }
    const double V = 0.3 * 0.2 * 0.2, J = 1.04 * (0.97 * 1.06 - 0.06 * 0.02) -
                                            0.05 * (0.03 * 1.06 + 0.06 * 0.01) +
                                            -0.02 * (0.03 * 0.02 + 0.97 * 0.01);
    for (int k = 0; k < 2; ++k) {
        defsim_material mat;
        defsim_material_init(&mat, sizeof mat, models[k]);
        mat.youngs_modulus = 1e5;
        mat.poisson_ratio = 0.49;
        const double I[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1};
        double psi, psi0, P[9], sig[9];
        TU_OK(defsim_material_eval(&mat, F, &psi, P, NULL));
        TU_OK(defsim_material_eval(&mat, I, &psi0, NULL, NULL));
        for (int i = 0; i < 3; ++i)
            for (int j = 0; j < 3; ++j)
                sig[3 * i + j] = (P[3 * i] * F[3 * j] + P[3 * i + 1] * F[3 * j + 1] +
                                  P[3 * i + 2] * F[3 * j + 2]) / J;
        double e[2];
        for (int mixed = 0; mixed < 2; ++mixed) {
            defsim_world *w = tu_world("explicit_euler", 0.0, 1);
            defsim_body_def bd = body_def(&m, models[k], 0.49, mixed);
            defsim_body_id id;
            TU_OK(defsim_world_add_body(w, &bd, &id));
            TU_OK(defsim_world_set_state(w, x, NULL));
            defsim_energy en;
            TU_OK(defsim_world_energy(w, &en));
            e[mixed] = en.elastic;
            f[mixed] = malloc(3 * (size_t)n * sizeof *f[mixed]);
            TU_OK(defsim_world_forces(w, x, f[mixed]));
            if (mixed) {
                double *cs = malloc(9 * (size_t)nt * sizeof *cs), ds = 0.0, smax = 0.0;
                TU_OK(defsim_body_element_stress(w, id, cs, NULL, NULL, nt));
                for (int t = 0; t < nt; ++t)
                    for (int i = 0; i < 9; ++i) {
                        ds = fmax(ds, fabs(cs[9 * t + i] - sig[i]));
                        smax = fmax(smax, fabs(sig[i]));
                    }
                printf("  model %d: read-back |sigma - analytic| %.3g of %.3g Pa\n",
                       (int)models[k], ds, smax);
                assert_true(ds <= 1e-10 * smax);
                free(cs);
            }
            defsim_world_destroy(w);
        }
        /* interior nodes: every node not on the box's boundary faces */
        double fin = 0.0, fmaxb = 0.0, df = 0.0;
        for (int i = 0; i < n; ++i) {
            const double *X = m.positions + 3 * i;
            int inside = 1;
            for (int r = 0; r < 3; ++r) inside &= X[r] > lo[r] + 1e-9 && X[r] < hi[r] - 1e-9;
            for (int r = 0; r < 3; ++r) {
                const double fi = fabs(f[1][3 * i + r]);
                if (inside) fin = fmax(fin, fi);
                else fmaxb = fmax(fmaxb, fi);
                df = fmax(df, fabs(f[1][3 * i + r] - f[0][3 * i + r]));
            }
        }
        const double exact = V * (psi - psi0);
        printf("  model %d: energy %.15g J (analytic %.15g J, standard %.15g J), interior |f| "
               "%.3g of %.3g N, |f - f_standard| %.3g\n", (int)models[k], e[1], exact, e[0], fin,
               fmaxb, df);
        assert_true(exact > 0.0);
        assert_true(fabs(e[1] - exact) <= 1e-10 * exact);
        assert_true(fabs(e[1] - e[0]) <= 1e-10 * exact);
        assert_true(fmaxb > 0.0 && fin <= 1e-10 * fmaxb && df <= 1e-10 * fmaxb);
        free(f[0]);
        free(f[1]);
    }
    free(x);
    defsim_mesh_free(&m);
}

/* The largest colour of the system's mixed groups (elements that one parallel loop shares). */
static int32_t largest_colour(defsim_world *w)
{
    TU_OK(defsim__world_plan(w));
    int32_t big = 0;
    for (int k = 0; k < DEFSIM__TET_MODELS; ++k) {
        const defsim__group *g = &w->sys.groups[DEFSIM__QMIX_GROUP + k];
        for (int32_t c = 0; c < g->ncolors; ++c)
            if (g->color_ptr[c + 1] - g->color_ptr[c] > big)
                big = g->color_ptr[c + 1] - g->color_ptr[c];
    }
    return big;
}

/* The same bits on 1 and 2 threads: symplectic Euler steps at 0.9 of the stable step with
 * stiffness damping on a 16 x 8 x 8-cell box (6,144 elements, colours of more than the term's
 * 256 that open its parallel loops: forces and damping forces); the matrix (values, in parallel
 * past 64 elements per colour, and products) of a 12 x 6 x 6-cell box at a state off rest. (Whole
 * newton_cholmod steps are not compared across thread counts: the standard quadratic tets' differ
 * there in the last bit too on a box this size, and the linear tets' on 24 x 12 x 12 cells.) The
 * stable step sees the element: at 0.9 of it the run stays bounded. */
static void test_threads(void **state)
{
    (void)state;
    for (int implicit = 0; implicit < 2; ++implicit) {
        const int nx = implicit ? 12 : 16;
        const double lo[3] = {0, 0, 0}, hi[3] = {0.1 * nx, 0.05 * nx, 0.05 * nx};
        defsim_mesh m;
        box_mesh(lo, hi, nx, nx / 2, nx / 2, &m);
        TU_OK(defsim_mesh_make_quadratic(&m));
        const int nv = m.vertex_count;
        double *x[2] = {NULL, NULL}, *val[2] = {NULL, NULL}, h = 0.0;
        int64_t nnz = 0;
        for (int k = 0; k < 2; ++k) {
            defsim_world *w = tu_world(implicit ? "newton_cholmod" : "symplectic_euler", -9.81,
                                       k + 1);
            defsim_body_def bd = body_def(&m, DEFSIM_MODEL_NEOHOOKEAN, 0.49, 1);
            bd.material.stiffness_damping = implicit ? 0.01 : 1e-4;
            defsim_body_id id;
            TU_OK(defsim_world_add_body(w, &bd, &id));
            tu_pin_below(w, id, 0, 0.0);
            const int32_t big = largest_colour(w);
            if (k == 0)
                printf("  %s: %d elements, largest colour %d\n",
                       implicit ? "matrix" : "symplectic_euler", m.tet_count, big);
            assert_true(big > (implicit ? 64 : 256));
            if (!implicit) {
                if (k == 0) {
                    TU_OK(defsim_world_stable_step(w, &h, NULL));
                    printf("  stable step %.4g s\n", h);
                    assert_true(h > 0.0);
                }
                for (int s = 0; s < 20; ++s) TU_OK(defsim_world_step(w, 0.9 * h));
                x[k] = tu_positions(w);
                defsim_energy e;
                TU_OK(defsim_world_energy(w, &e));
                assert_true(isfinite(e.total));
            } else {
                double *p = tu_positions(w);
                unsigned long long seed = 9;
                for (int i = 0; i < 3 * nv; ++i) p[i] += 2e-3 * tu_rand(&seed);
                TU_OK(defsim_world_set_state(w, p, NULL));
                TU_OK(defsim__world_plan(w));
                defsim__system *s = &w->sys;
                TU_OK(defsim__pattern_build(s));
                defsim_csc pat;
                TU_OK(defsim__matrix_pattern(s, DEFSIM_TRIANGLE_UPPER, &pat));
                nnz = pat.nnz;
                const defsim_matrix_coeffs c = {1.0, 1.0, 0.0, 0.0};
                val[k] = calloc((size_t)nnz + 3 * (size_t)nv, sizeof *val[k]);
                TU_OK(defsim__matrix_values(s, p, &c, DEFSIM_TRIANGLE_UPPER, val[k], NULL));
                /* and a product, after the values */
                double *dx = malloc(3 * (size_t)nv * sizeof *dx);
                for (int i = 0; i < 3 * nv; ++i) dx[i] = tu_rand(&seed);
                defsim__matrix_apply(s, p, &c, s->projection, dx, val[k] + nnz);
                free(dx);
                free(p);
            }
            defsim_world_destroy(w);
        }
        if (implicit) {
            const size_t bytes = ((size_t)nnz + 3 * (size_t)nv) * sizeof *val[0];
            printf("  matrix: %lld values and a product, 1 and 2 threads bit-identical %d\n",
                   (long long)nnz, !memcmp(val[0], val[1], bytes));
            assert_memory_equal(val[0], val[1], bytes);
        } else {
            assert_memory_equal(x[0], x[1], 3 * (size_t)nv * sizeof *x[0]);
        }
        for (int k = 0; k < 2; ++k) {
            free(x[k]);
            free(val[k]);
        }
        defsim_mesh_free(&m);
    }
}

/* ------------------------------------------------------------------------------------------ */
/* The cantilever */

typedef struct beam {
    double sag;       /* the top far corner's deflection (m, positive down) */
    double seconds;   /* the static solve's wall time */
    int vertices;
    double newton;    /* Newton iterations of the solve */
} beam;

/* test_tet10_accuracy's cantilever on n cells per metre (3n x n x n), quadratic tets (the
 * mean-dilatation element if mixed), Poisson ratio nu: two newton_cholmod steps of 10 s from
 * rest, each from zero velocity, Newton to 1e-10. */
static beam cantilever(int n, double nu, int mixed)
{
    defsim_world *w = tu_implicit_world("newton_cholmod", -9.81, 1, 1e-10, 50,
                                        DEFSIM_PROJECTION_CLAMP);
    const double lo[3] = {0, 0, 0}, hi[3] = {3, 1, 1};
    defsim_mesh m;
    box_mesh(lo, hi, 3 * n, n, n, &m);
    TU_OK(defsim_mesh_make_quadratic(&m));
    defsim_body_def bd = body_def(&m, DEFSIM_MODEL_STABLE_NEOHOOKEAN, nu, mixed);
    bd.material.youngs_modulus = 1e8;
    defsim_body_id id;
    TU_OK(defsim_world_add_body(w, &bd, &id));
    tu_pin_below(w, id, 0, 0.0);
    const int nv = m.vertex_count;
    int probe = -1;
    for (int i = 0; i < nv; ++i) {
        const double *p = m.positions + 3 * i;
        if (fabs(p[0] - 3) < 1e-12 && fabs(p[1] - 1) < 1e-12 && fabs(p[2] - 1) < 1e-12) probe = i;
    }
    assert_true(probe >= 0);
    double *x = malloc(3 * (size_t)nv * sizeof *x), *v = calloc(3 * (size_t)nv, sizeof *v);
    const double t0 = now_s();
    for (int k = 0; k < 2; ++k) {
        if (defsim_world_step(w, 10.0) != DEFSIM_OK)
            fail_msg("static step: %s", defsim_world_last_error(w));
        TU_OK(defsim_world_get_positions(w, x, nv));
        TU_OK(defsim_world_set_state(w, x, v));
    }
    beam r = {1.0 - x[3 * probe + 1], now_s() - t0, nv, tu_bstat(w, "newton_iterations")};
    free(x);
    free(v);
    defsim_world_destroy(w);
    defsim_mesh_free(&m);
    return r;
}

static void print_beam(const char *what, int n, double nu, beam b, double ref)
{
    printf("  %-17s %2d x %2d x %2d, nu %.3f: %.5f mm (%+.2f %% of %.4f mm; %d vertices, "
           "%.0f Newton iterations, %.2f s)\n", what, 3 * n, n, n, nu, 1e3 * b.sag,
           100.0 * (b.sag / ref - 1.0), 1e3 * ref, b.vertices, b.newton, b.seconds);
}

/* nu = 0.499: the mean-dilatation element within issue 29's 3 % at 12 x 4 x 4 cells (measured
 * -0.04 %; the displacement element: -4.1 %, test_tet10_accuracy) and at 18 x 6 x 6 (-0.09 %),
 * both within 0.5 % (REF_CANTILEVER_NU499's two extrapolations agree to 0.01 %). */
static void test_cantilever_incompressible(void **state)
{
    (void)state;
    const double nu = 0.499, ref = REF_CANTILEVER_NU499;
    const beam q = cantilever(4, nu, 0), mx = cantilever(4, nu, 1), mx6 = cantilever(6, nu, 1);
    print_beam("quadratic", 4, nu, q, ref);
    print_beam("mean dilatation", 4, nu, mx, ref);
    print_beam("mean dilatation", 6, nu, mx6, ref);
    const double e4 = mx.sag / ref - 1.0, e6 = mx6.sag / ref - 1.0, eq = q.sag / ref - 1.0;
    assert_true(fabs(e4) < 0.005);
    assert_true(fabs(e6) < 0.005);
    assert_true(eq < -0.04);   /* the locking left in the displacement element */
}

/* nu = 0.3: the remedy keeps compressible bending within 2 % of REF_CANTILEVER at 12 x 4 x 4
 * (measured +0.40 %, within 1 %; the displacement element: -0.49 %). */
static void test_cantilever_compressible(void **state)
{
    (void)state;
    const double nu = 0.3, ref = REF_CANTILEVER;
    const beam q = cantilever(4, nu, 0), mx = cantilever(4, nu, 1);
    print_beam("quadratic", 4, nu, q, ref);
    print_beam("mean dilatation", 4, nu, mx, ref);
    assert_true(fabs(mx.sag / ref - 1.0) < 0.01);
    assert_true(fabs(q.sag / ref - 1.0) < 0.01);
}

int main(int argc, char **argv)
{
    if (argc > 4 && strcmp(argv[1], "--one") == 0) {   /* --one N NU MIXED: one cantilever */
        const int n = atoi(argv[2]), mixed = atoi(argv[4]);
        const double nu = atof(argv[3]);
        const beam b = cantilever(n, nu, mixed);
        print_beam(mixed ? "mean dilatation" : "quadratic", n, nu, b,
                   nu > 0.4 ? REF_CANTILEVER_NU499 : REF_CANTILEVER);
        return 0;
    }
    if (argc > 2 && strcmp(argv[1], "--filter") == 0) cmocka_set_test_filter(argv[2]);
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_refused),
        cmocka_unit_test(test_patch),
        cmocka_unit_test(test_threads),
        cmocka_unit_test(test_cantilever_incompressible),
        cmocka_unit_test(test_cantilever_compressible),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
