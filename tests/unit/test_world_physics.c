/* SPDX-License-Identifier: MIT */
/* World-level physics: forces against finite differences of the energy, momentum and rotation
 * invariance, stiffness matrices against finite differences of the forces, determinism. */
#include "test_util.h"

#include "assembly.h"
#include "mat3.h"
#include "world.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

static const double LO[3] = {0, 0, 0}, HI[3] = {2, 1, 1};
static const defsim_model MODELS[4] = {DEFSIM_MODEL_STVK, DEFSIM_MODEL_COROTATED,
                                       DEFSIM_MODEL_NEOHOOKEAN, DEFSIM_MODEL_STABLE_NEOHOOKEAN};

/* A world with one box of the model and a spring network body beside it, deformed randomly. */
static defsim_world *deformed_world(defsim_model model, int threads, double amp,
                                    unsigned long long seed)
{
    defsim_world *w = tu_world("symplectic_euler", 0.0, threads);
    tu_add_box(w, model, 2, 2, 2, LO, HI, 1e5, 0.35, 1000.0);
    /* A spring ladder (cloth strip) body. */
    double sx[3 * 8];
    int32_t sp[2 * 10];
    tu_ladder(3.0, 0.5, 0.0, sx, sp);
    defsim_body_def bd;
    defsim_body_def_init(&bd, sizeof bd);
    defsim_material_init(&bd.material, sizeof bd.material, DEFSIM_MODEL_SPRING);
    bd.material.stiffness = 3e4;
    bd.rest_positions = sx;
    bd.vertex_count = 8;
    bd.springs = sp;
    bd.spring_count = 10;
    TU_OK(defsim_world_add_body(w, &bd, NULL));
    int n = defsim_world_vertex_count(w);
    double *x = tu_positions(w);
    for (int i = 0; i < 3 * n; ++i) x[i] += amp * tu_rand(&seed);
    TU_OK(defsim_world_set_state(w, x, NULL));
    free(x);
    return w;
}

static double elastic(defsim_world *w)
{
    defsim_energy e;
    TU_OK(defsim_world_energy(w, &e));
    return e.elastic;
}

static void test_forces_match_energy(void **state)
{
    (void)state;
    for (int mi = 0; mi < 4; ++mi) {
        defsim_world *w = deformed_world(MODELS[mi], 1, 0.08, 11 + mi);
        int n = defsim_world_vertex_count(w);
        double *x = tu_positions(w), *f = malloc(3 * (size_t)n * sizeof *f);
        TU_OK(defsim_world_forces(w, NULL, f));
        double fmax = 0, err = 0;
        for (int i = 0; i < 3 * n; ++i) {
            const double h = 1e-6, x0 = x[i];
            x[i] = x0 + h;
            TU_OK(defsim_world_set_state(w, x, NULL));
            double ep = elastic(w);
            x[i] = x0 - h;
            TU_OK(defsim_world_set_state(w, x, NULL));
            double em = elastic(w);
            x[i] = x0;
            double fd = -(ep - em) / (2 * h);
            if (fabs(f[i]) > fmax) fmax = fabs(f[i]);
            if (fabs(fd - f[i]) > err) err = fabs(fd - f[i]);
        }
        if (!(err < 1e-6 * fmax)) fail_msg("model %d: |f - fd| = %g, |f| = %g", MODELS[mi], err, fmax);
        free(x);
        free(f);
        defsim_world_destroy(w);
    }
}

static void test_free_body_forces_sum_to_zero(void **state)
{
    (void)state;
    for (int mi = 0; mi < 4; ++mi) {
        defsim_world *w = deformed_world(MODELS[mi], 2, 0.1, 5 + mi);
        int n = defsim_world_vertex_count(w);
        double *f = malloc(3 * (size_t)n * sizeof *f), *x = tu_positions(w);
        TU_OK(defsim_world_forces(w, NULL, f));
        double sum[3] = {0, 0, 0}, torque[3] = {0, 0, 0}, scale = 0;
        for (int i = 0; i < n; ++i) {
            const double *p = x + 3 * i, *q = f + 3 * i;
            for (int c = 0; c < 3; ++c) { sum[c] += q[c]; scale += fabs(q[c]); }
            torque[0] += p[1] * q[2] - p[2] * q[1];
            torque[1] += p[2] * q[0] - p[0] * q[2];
            torque[2] += p[0] * q[1] - p[1] * q[0];
        }
        for (int c = 0; c < 3; ++c) {
            assert_true(fabs(sum[c]) < 1e-11 * scale);
            assert_true(fabs(torque[c]) < 1e-10 * scale);   /* internal forces: no net torque */
        }
        free(f);
        free(x);
        defsim_world_destroy(w);
    }
}

static void rotate(double *x, int n, const double R[9], const double t[3])
{
    for (int i = 0; i < n; ++i) {
        double p[3] = {x[3 * i], x[3 * i + 1], x[3 * i + 2]};
        for (int r = 0; r < 3; ++r)
            x[3 * i + r] = R[3 * r] * p[0] + R[3 * r + 1] * p[1] + R[3 * r + 2] * p[2] + t[r];
    }
}

static void test_rigid_motion_energy(void **state)
{
    (void)state;
    /* Axis (1, 2, 2)/3, angle 2: Rodrigues. */
    const double a[3] = {1.0 / 3, 2.0 / 3, 2.0 / 3}, th = 2.0, c = cos(th), s = sin(th);
    double R[9];
    for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j)
            R[3 * i + j] = (i == j ? c : 0.0) + (1 - c) * a[i] * a[j];
    R[1] -= s * a[2]; R[2] += s * a[1]; R[3] += s * a[2]; R[5] -= s * a[0]; R[6] -= s * a[1]; R[7] += s * a[0];
    const double t[3] = {0.3, -7.0, 2.0};
    for (int mi = 0; mi < 4; ++mi) {
        /* At rest: zero elastic energy after any rigid motion (SNH's rest constant removed). */
        defsim_world *w = deformed_world(MODELS[mi], 1, 0.0, 1);
        int n = defsim_world_vertex_count(w);
        double *x = tu_positions(w);
        assert_true(fabs(elastic(w)) < 1e-9);
        rotate(x, n, R, t);
        TU_OK(defsim_world_set_state(w, x, NULL));
        assert_true(fabs(elastic(w)) < 1e-8);
        free(x);
        defsim_world_destroy(w);
        /* Deformed: the energy is unchanged by a rigid motion. */
        w = deformed_world(MODELS[mi], 1, 0.1, 9);
        x = tu_positions(w);
        double e0 = elastic(w);
        assert_true(e0 > 1.0);
        rotate(x, n, R, t);
        TU_OK(defsim_world_set_state(w, x, NULL));
        assert_true(fabs(elastic(w) - e0) < 1e-10 * e0);
        free(x);
        defsim_world_destroy(w);
    }
}

/* K = -df/dx by central differences, through the internal matrix assembly (both layouts), and
 * matrix_product against the assembled values. Unprojected, so the comparison is exact. */
static void test_matrix_matches_forces(void **state)
{
    (void)state;
    for (int mi = 0; mi < 4; ++mi) {
        defsim_world *w = deformed_world(MODELS[mi], 2, 0.05, 21 + mi);
        int32_t pin[3] = {0, 1, 2};
        defsim_body_id b0 = {defsim__world_id_index(w, 0), 1};
        TU_OK(defsim_body_pin(w, b0, pin, 3));
        TU_OK(defsim__world_plan(w));
        TU_OK(defsim__pattern_build(&w->sys));
        w->sys.projection = DEFSIM_PROJECTION_NONE;
        defsim_csc full, up;
        TU_OK(defsim__matrix_pattern(&w->sys, DEFSIM_TRIANGLE_FULL, &full));
        TU_OK(defsim__matrix_pattern(&w->sys, DEFSIM_TRIANGLE_UPPER, &up));
        assert_int_equal(full.n, 3 * (defsim_world_vertex_count(w) - 3));
        assert_int_equal(up.nnz, (full.nnz + full.n) / 2);
        double *vf = malloc((size_t)full.nnz * sizeof *vf), *vu = malloc((size_t)up.nnz * sizeof *vu);
        defsim_matrix_coeffs cf = {1.0, 0.0, 0.0, 0.0};
        int n = defsim_world_vertex_count(w);
        double *x = tu_positions(w);
        TU_OK(defsim__matrix_values(&w->sys, x, &cf, DEFSIM_TRIANGLE_FULL, vf, NULL));
        TU_OK(defsim__matrix_values(&w->sys, x, &cf, DEFSIM_TRIANGLE_UPPER, vu, NULL));
        /* Dense copy of the full matrix; check symmetry and the upper layout. */
        int64_t nf = full.n;
        double *A = calloc((size_t)(nf * nf), sizeof *A);
        for (int64_t j = 0; j < nf; ++j)
            for (int64_t p = full.col_ptr[j]; p < full.col_ptr[j + 1]; ++p) {
                if (p > full.col_ptr[j]) assert_true(full.row_idx[p] > full.row_idx[p - 1]);
                A[full.row_idx[p] * nf + j] = vf[p];
            }
        double amax = 0;
        for (int64_t i = 0; i < nf * nf; ++i) amax = fmax(amax, fabs(A[i]));
        for (int64_t i = 0; i < nf; ++i)
            for (int64_t j = 0; j < nf; ++j)
                assert_true(fabs(A[i * nf + j] - A[j * nf + i]) < 1e-10 * amax);
        for (int64_t j = 0; j < nf; ++j)
            for (int64_t p = up.col_ptr[j]; p < up.col_ptr[j + 1]; ++p) {
                assert_true(up.row_idx[p] <= j);
                assert_true(fabs(vu[p] - A[up.row_idx[p] * nf + j]) <= 1e-12 * amax);
            }
        /* Column j of K against -(f(x + h e_j) - f(x - h e_j)) / 2h at free DOFs. */
        double *fp = malloc(3 * (size_t)n * sizeof *fp), *fm = malloc(3 * (size_t)n * sizeof *fm);
        double err = 0;
        for (int64_t j = 0; j < nf; ++j) {
            int64_t dof = w->sys.free_dofs[j];
            const double h = 1e-6, x0 = x[dof];
            x[dof] = x0 + h;
            TU_OK(defsim_world_forces(w, x, fp));
            x[dof] = x0 - h;
            TU_OK(defsim_world_forces(w, x, fm));
            x[dof] = x0;
            for (int64_t i = 0; i < nf; ++i) {
                int64_t r = w->sys.free_dofs[i];
                double fd = -(fp[r] - fm[r]) / (2 * h);
                err = fmax(err, fabs(fd - A[i * nf + j]));
            }
        }
        if (!(err < 1e-6 * amax)) fail_msg("model %d: |K - fd| = %g, |K| = %g", MODELS[mi], err, amax);
        /* matrix_product with mass and damping terms against the assembled values. */
        defsim_matrix_coeffs c2 = {0.7, 0.0, 3.0, 0.0};
        TU_OK(defsim__matrix_values(&w->sys, x, &c2, DEFSIM_TRIANGLE_FULL, vf, NULL));
        double *dx = malloc(3 * (size_t)n * sizeof *dx), *out = malloc(3 * (size_t)n * sizeof *out);
        unsigned long long seed = 77;
        for (int i = 0; i < 3 * n; ++i) dx[i] = tu_rand(&seed);
        TU_OK(defsim__matrix_product(&w->sys, x, &c2, dx, out));
        double perr = 0, pmax = 0;
        for (int64_t i = 0; i < nf; ++i) {
            double s = 0;
            for (int64_t j = 0; j < nf; ++j) {
                double a = 0;
                for (int64_t p = full.col_ptr[j]; p < full.col_ptr[j + 1]; ++p)
                    if (full.row_idx[p] == i) a = vf[p];
                s += a * dx[w->sys.free_dofs[j]];
            }
            perr = fmax(perr, fabs(s - out[w->sys.free_dofs[i]]));
            pmax = fmax(pmax, fabs(s));
        }
        assert_true(perr < 1e-10 * pmax);
        for (int i = 0; i < 9; ++i) assert_true(out[i] == 0.0);   /* pinned rows */
        free(dx); free(out); free(fp); free(fm); free(A); free(vf); free(vu); free(x);
        defsim_world_destroy(w);
    }
}

/* One free tet, strongly deformed: its exact Hessian is indefinite; CLAMP and ABS projections
 * give positive semi-definite matrices (smallest eigenvalue of the dense 12x12 matrix). */
static void test_projection_psd(void **state)
{
    (void)state;
    static const double X[12] = {1, 0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0};
    static const int32_t T[4] = {0, 1, 2, 3};
    const defsim_model models[3] = {DEFSIM_MODEL_STABLE_NEOHOOKEAN, DEFSIM_MODEL_COROTATED,
                                    DEFSIM_MODEL_STVK};
    unsigned long long seed = 12;
    for (int mi = 0; mi < 3; ++mi) {
        double min_none = INFINITY;
        for (int trial = 0; trial < 20; ++trial) {
            defsim_world *w = tu_world("symplectic_euler", 0.0, 1);
            defsim_body_def bd;
            defsim_body_def_init(&bd, sizeof bd);
            defsim_material_init(&bd.material, sizeof bd.material, models[mi]);
            bd.rest_positions = X;
            bd.vertex_count = 4;
            bd.tets = T;
            bd.tet_count = 1;
            TU_OK(defsim_world_add_body(w, &bd, NULL));
            double x[12];
            for (int i = 0; i < 12; ++i) x[i] = 0.6 * X[i] + 0.5 * tu_rand(&seed);
            TU_OK(defsim__world_plan(w));
            TU_OK(defsim__pattern_build(&w->sys));
            defsim_csc full;
            TU_OK(defsim__matrix_pattern(&w->sys, DEFSIM_TRIANGLE_FULL, &full));
            assert_int_equal(full.nnz, 144);
            for (int proj = 0; proj <= 2; ++proj) {
                w->sys.projection = proj;
                defsim_matrix_coeffs c = {1.0, 0.0, 0.0, 0.0};
                double v[144], A[144], ev[12], evec[144];
                TU_OK(defsim__matrix_values(&w->sys, x, &c, DEFSIM_TRIANGLE_FULL, v, NULL));
                for (int j = 0; j < 12; ++j)
                    for (int64_t p = full.col_ptr[j]; p < full.col_ptr[j + 1]; ++p)
                        A[full.row_idx[p] * 12 + j] = v[p];
                double amax = 0;
                for (int i = 0; i < 144; ++i) amax = fmax(amax, fabs(A[i]));
                defsim__sym_eig(12, A, ev, evec);
                double emin = INFINITY;
                for (int i = 0; i < 12; ++i) emin = fmin(emin, ev[i]);
                if (proj == 0) min_none = fmin(min_none, emin / amax);
                else assert_true(emin >= -1e-10 * amax);
            }
            defsim_world_destroy(w);
        }
        if (!(min_none < -1e-3)) fail_msg("model %d: no indefinite Hessian found (%g)", models[mi], min_none);
    }
}

/* Explicit runs are bit-identical run to run, and (by the coloured scatter) for 1 and 2 threads. */
static void test_determinism(void **state)
{
    (void)state;
    double *res[3];
    const int threads[3] = {2, 2, 1};
    for (int r = 0; r < 3; ++r) {
        defsim_world *w = tu_world("symplectic_euler", -9.81, threads[r]);
        const double hi[3] = {3, 1, 1};
        defsim_body_id b = tu_add_box(w, DEFSIM_MODEL_COROTATED, 12, 4, 4, LO, hi, 1e5, 0.3, 1000);
        tu_pin_below(w, b, 0, 0.0);
        for (int i = 0; i < 1000; ++i) TU_OK(defsim_world_step(w, 1e-4));
        res[r] = tu_positions(w);
        if (r == 0) {
            /* The beam bent: the run did something. */
            int n = defsim_world_vertex_count(w);
            assert_true(res[r][3 * (n - 1) + 1] < 1.0 - 1e-4);
        }
        defsim_stats s = {.size = sizeof s};
        TU_OK(defsim_world_stats(w, &s));
#ifdef _OPENMP
        assert_int_equal(s.threads, threads[r]);
#else
        assert_int_equal(s.threads, 1);
#endif
        assert_true(s.passes & DEFSIM_PASS_COROTATED);
        assert_true(s.passes & DEFSIM_PASS_GRAVITY);
        assert_true(s.passes & DEFSIM_PASS_PINS);
        assert_false(s.passes & (DEFSIM_PASS_HESSIAN | DEFSIM_PASS_MASS_DAMPING |
                                 DEFSIM_PASS_STIFFNESS_DAMPING | DEFSIM_PASS_ENERGY |
                                 DEFSIM_PASS_STVK | DEFSIM_PASS_SPRINGS));
        defsim_world_destroy(w);
    }
    size_t bytes = 3 * 13 * 5 * 5 * sizeof(double);
    assert_memory_equal(res[0], res[1], bytes);
    assert_memory_equal(res[0], res[2], bytes);
    for (int r = 0; r < 3; ++r) free(res[r]);
}

/* Damping: mass and stiffness damping dissipate, forces oppose velocity. */
static void test_damping_dissipates(void **state)
{
    (void)state;
    for (int mode = 0; mode < 2; ++mode) {
        defsim_world *w = tu_world("symplectic_euler", 0.0, 1);
        defsim_mesh m = {.size = sizeof m};
        TU_OK(defsim_mesh_box(LO, HI, 2, 1, 1, &m));
        defsim_body_def bd = test_mesh_body(&m, DEFSIM_MODEL_STABLE_NEOHOOKEAN);
        bd.material.youngs_modulus = 1e4;
        if (mode == 0) bd.material.mass_damping = 2.0;
        else bd.material.stiffness_damping = 0.01;
        TU_OK(defsim_world_add_body(w, &bd, NULL));
        int n = m.vertex_count;
        double *x = tu_positions(w), *v = malloc(3 * (size_t)n * sizeof *v);
        unsigned long long seed = 8;
        for (int i = 0; i < 3 * n; ++i) { x[i] += 0.05 * tu_rand(&seed); v[i] = 0.0; }
        TU_OK(defsim_world_set_state(w, x, v));
        defsim_energy e0, e1;
        TU_OK(defsim_world_energy(w, &e0));
        for (int i = 0; i < 4000; ++i) TU_OK(defsim_world_step(w, 2e-4));
        TU_OK(defsim_world_energy(w, &e1));
        assert_true(e1.total < 0.5 * e0.total);
        defsim_stats s = {.size = sizeof s};
        TU_OK(defsim_world_stats(w, &s));
        assert_true(s.passes & (mode == 0 ? DEFSIM_PASS_MASS_DAMPING : DEFSIM_PASS_STIFFNESS_DAMPING));
        assert_false(s.passes & DEFSIM_PASS_GRAVITY);
        free(x); free(v);
        defsim_mesh_free(&m);
        defsim_world_destroy(w);
    }
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_forces_match_energy),
        cmocka_unit_test(test_free_body_forces_sum_to_zero),
        cmocka_unit_test(test_rigid_motion_energy),
        cmocka_unit_test(test_matrix_matches_forces),
        cmocka_unit_test(test_projection_psd),
        cmocka_unit_test(test_determinism),
        cmocka_unit_test(test_damping_dissipates),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
