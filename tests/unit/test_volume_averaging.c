/* SPDX-License-Identifier: MIT */
/*
 * The volume-averaged tet (defsim_body_def.volume_averaging, src/term_nodal_volume.c) against
 * the standard linear tet, as physics (its ops' finite differences are test_terms.c's):
 *  - refused for the models without an isochoric / volumetric split (StVK, co-rotated) and for
 *    a value other than 0 and 1;
 *  - a homogeneous deformation (every J_n = J_e) has the standard element's energy, forces and
 *    stress read-back;
 *  - the explicit stable step sees the element; a checkpoint keeps it (and the mean-dilatation
 *    element of quadratic bodies with the flag); 1 and 2 threads give the same bits;
 *  - the issue-29 cantilever (3 m x 1 m x 1 m, clamped at x = 0, its own weight, E = 1e8,
 *    density 1000, neo-Hookean: the linear range) at static equilibrium, on the shipped
 *    12 x 4 x 4 cells: with nu = 0.499 the standard tets lock (a sixth of the reference), the
 *    averaged ones do not (4.5 times the standard sag) but keep the linear tet's bending error
 *    (25 % short; issue 29's 3 % is not met on this mesh); their sag falls by 6 % only from
 *    nu = 0.49 to 0.4999, the standard one's to 38 %; with nu = 0.3 both elements approach the
 *    same reference as the mesh is refined. The references are extrapolations of the averaged
 *    element from 24, 36 and 48 cells along the beam (test_volume_averaging --long computes them
 *    again), cross-checked against the standard element (nu = 0.3) and Timoshenko beam theory.
 *
 * Static equilibrium: newton_cholmod steps of h = 10 s from rest with the velocities zeroed
 * before each (a Newton solve of the static problem plus M/h^2 (x - x_n), which the next solve
 * removes), until the deflection changes by less than 1e-10 m.
 *
 * `test_volume_averaging --table` prints the deflections, Newton iterations and times per solve
 * of both elements for 12 x 4 x 4 and 24 x 8 x 8 cells at both ratios (48 x 16 x 16 with --long)
 * and the cost of explicit steps; `--one CELLS NU AVERAGED` one solve.
 */
#include "test_util.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

static int long_run, table_run;   /* --long: the references only; --table: the figures */

/* References (m): the top far corner's sag under its own weight, extrapolated from the averaged
 * element on 24 x 8 x 8, 36 x 12 x 12 and 48 x 16 x 16 cells (d = d_inf - C h^p fitted to the
 * three: p = 1.76 at nu = 0.3, 1.51 at nu = 0.499), which --long recomputes (within 0.1 %). At
 * nu = 0.3 the standard element's extrapolation is 12.963 mm (0.07 % apart) and issue 29's
 * quadratic tets gave 12.9 mm. Not from the tested 12 x 4 x 4 mesh. */
static const double REF_NU3 = 12.9541e-3, REF_NU499 = 12.4706e-3;

static double now(void)
{
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return (double)t.tv_sec + 1e-9 * (double)t.tv_nsec;
}

static defsim_body_def body_def(const defsim_mesh *m, defsim_model model, double nu, int avg)
{
    defsim_body_def bd = test_mesh_body(m, model);
    bd.material.youngs_modulus = 1e8;
    bd.material.poisson_ratio = nu;
    bd.material.density = 1000.0;
    bd.volume_averaging = avg;
    return bd;
}

/* ------------------------------------------------------------------------------------------ */

static void test_refused(void **state)
{
    (void)state;
    const double lo[3] = {0, 0, 0}, hi[3] = {1, 1, 1};
    defsim_mesh m;
    memset(&m, 0, sizeof m);
    m.size = sizeof m;
    TU_OK(defsim_mesh_box(lo, hi, 1, 1, 1, &m));
    defsim_world *w = tu_world("explicit_euler", 0.0, 1);
    const defsim_model bad[2] = {DEFSIM_MODEL_STVK, DEFSIM_MODEL_COROTATED};
    for (int k = 0; k < 2; ++k) {
        defsim_body_def bd = body_def(&m, bad[k], 0.3, 1);
        assert_int_equal(defsim_world_add_body(w, &bd, NULL), DEFSIM_ERR_INVALID_MATERIAL);
        assert_non_null(strstr(defsim_world_last_error(w), "volume_averaging"));
        printf("  model %d refused: %s\n", (int)bad[k], defsim_world_last_error(w));
    }
    defsim_body_def bd = body_def(&m, DEFSIM_MODEL_NEOHOOKEAN, 0.3, 2);
    assert_int_equal(defsim_world_add_body(w, &bd, NULL), DEFSIM_ERR_INVALID_MATERIAL);
    bd.volume_averaging = 1;
    TU_OK(defsim_world_add_body(w, &bd, NULL));
    bd.material.model = DEFSIM_MODEL_STABLE_NEOHOOKEAN;
    TU_OK(defsim_world_add_body(w, &bd, NULL));
    assert_int_equal(defsim_world_vertex_count(w), 16);
    /* quadratic tets take the flag too (their mean-dilatation element: test_quadratic_mixed),
     * with the same models refused */
    TU_OK(defsim_mesh_make_quadratic(&m));
    bd = body_def(&m, DEFSIM_MODEL_STVK, 0.3, 1);
    bd.tet_nodes = 10;
    assert_int_equal(defsim_world_add_body(w, &bd, NULL), DEFSIM_ERR_INVALID_MATERIAL);
    assert_non_null(strstr(defsim_world_last_error(w), "volume_averaging"));
    bd.material.model = DEFSIM_MODEL_NEOHOOKEAN;
    TU_OK(defsim_world_add_body(w, &bd, NULL));
    assert_int_equal(defsim_world_vertex_count(w), 16 + m.vertex_count);
    defsim_world_destroy(w);
    defsim_mesh_free(&m);
}

/* x = F X on a 3 x 2 x 2-cell box: the averaged element's energy and forces are the standard
 * one's (every J_n is det F). */
static void test_homogeneous(void **state)
{
    (void)state;
    const double lo[3] = {0, 0, 0}, hi[3] = {0.3, 0.2, 0.2};
    const double F[9] = {1.04, 0.05, -0.02, 0.03, 0.97, 0.06, -0.01, 0.02, 1.06};
    const defsim_model models[2] = {DEFSIM_MODEL_NEOHOOKEAN, DEFSIM_MODEL_STABLE_NEOHOOKEAN};
    defsim_mesh m;
    memset(&m, 0, sizeof m);
    m.size = sizeof m;
    TU_OK(defsim_mesh_box(lo, hi, 3, 2, 2, &m));
    const int n = m.vertex_count, nt = m.tet_count;
    double *x = malloc(3 * (size_t)n * sizeof *x), *f[2], *sig[2], *psi[2];
    for (int i = 0; i < n; ++i)
        for (int r = 0; r < 3; ++r) {
            const double *X = m.positions + 3 * i;
            x[3 * i + r] = F[3 * r] * X[0] + F[3 * r + 1] * X[1] + F[3 * r + 2] * X[2];
        }
    for (int k = 0; k < 2; ++k) {
        double e[2];
        for (int avg = 0; avg < 2; ++avg) {
            defsim_world *w = tu_world("explicit_euler", 0.0, 1);
            defsim_body_def bd = body_def(&m, models[k], 0.45, avg);
            defsim_body_id id;
            TU_OK(defsim_world_add_body(w, &bd, &id));
            TU_OK(defsim_world_set_state(w, x, NULL));
            sig[avg] = malloc(9 * (size_t)nt * sizeof *sig[avg]);
            psi[avg] = malloc((size_t)nt * sizeof *psi[avg]);
            TU_OK(defsim_body_element_stress(w, id, sig[avg], NULL, psi[avg], nt));
            defsim_energy en;
            TU_OK(defsim_world_energy(w, &en));
            e[avg] = en.elastic;
            f[avg] = malloc(3 * (size_t)n * sizeof *f[avg]);
            TU_OK(defsim_world_forces(w, x, f[avg]));
            defsim_world_destroy(w);
        }
        double df = 0.0, fm = 0.0, ds = 0.0, sm = 0.0, dp = 0.0;
        for (int i = 0; i < 3 * n; ++i) {
            df = fmax(df, fabs(f[1][i] - f[0][i]));
            fm = fmax(fm, fabs(f[0][i]));
        }
        for (int i = 0; i < 9 * nt; ++i) {
            ds = fmax(ds, fabs(sig[1][i] - sig[0][i]));
            sm = fmax(sm, fabs(sig[0][i]));
        }
        for (int i = 0; i < nt; ++i) dp = fmax(dp, fabs(psi[1][i] - psi[0][i]) / psi[0][i]);
        printf("  stress read-back: |sigma - sigma_standard| %.3g of %.3g Pa, energy density "
               "%.3g relative\n", ds, sm, dp);
        assert_true(sm > 0.0 && ds <= 1e-11 * sm && dp <= 1e-11);
        free(sig[0]); free(sig[1]); free(psi[0]); free(psi[1]);
        printf("  model %d: energy %.15g J (standard %.15g J), |f - f_standard| %.3g of %.3g\n",
               (int)models[k], e[1], e[0], df, fm);
        assert_true(e[0] > 0.0);
        assert_true(fabs(e[1] - e[0]) <= 1e-12 * e[0]);
        assert_true(fm > 0.0 && df <= 1e-11 * fm);
        free(f[0]);
        free(f[1]);
    }
    free(x);
    defsim_mesh_free(&m);
}

/* Explicit stability at nu = 0.49 (symplectic Euler, a free 3 x 2 x 2-cell neo-Hookean box off
 * rest): defsim_world_stable_step sees the averaged element (its power iteration runs over the
 * term's products): the estimate is larger than the standard element's (no locked volumetric
 * stiffness per element), 0.9 of it stays bounded for 2,000 steps (the energy within 3 times its
 * start: symplectic Euler's energy oscillates near the limit) and 1.3 of it blows up. */
static void test_stable_step(void **state)
{
    (void)state;
    const double lo[3] = {0, 0, 0}, hi[3] = {0.3, 0.2, 0.2};
    defsim_mesh m;
    memset(&m, 0, sizeof m);
    m.size = sizeof m;
    TU_OK(defsim_mesh_box(lo, hi, 3, 2, 2, &m));
    double hs[2];
    for (int avg = 0; avg < 2; ++avg) {
        double fac[2] = {0.9, 1.3};
        for (int k = 0; k < 2; ++k) {
            defsim_world *w = tu_world("symplectic_euler", 0.0, 1);
            defsim_body_def bd = body_def(&m, DEFSIM_MODEL_NEOHOOKEAN, 0.49, avg);
            TU_OK(defsim_world_add_body(w, &bd, NULL));
            const int n = defsim_world_vertex_count(w);
            double *x = tu_positions(w);
            unsigned long long seed = 41;
            for (int i = 0; i < 3 * n; ++i) x[i] += 1e-4 * tu_rand(&seed);
            TU_OK(defsim_world_set_state(w, x, NULL));
            free(x);
            TU_OK(defsim_world_stable_step(w, &hs[avg], NULL));
            defsim_energy e0, e;
            TU_OK(defsim_world_energy(w, &e0));
            int steps = 0;
            defsim_status st = DEFSIM_OK;
            for (; steps < 2000 && st == DEFSIM_OK; ++steps) st = defsim_world_step(w, fac[k] * hs[avg]);
            TU_OK(defsim_world_energy(w, &e));
            printf("  %s: stable step %.4g s; at %.1f of it: %d steps, %s, energy %.4g J -> %.4g J\n",
                   avg ? "averaged" : "standard", hs[avg], fac[k], steps,
                   defsim_status_string(st), e0.total, e.total);
            if (k == 0) {
                assert_int_equal(st, DEFSIM_OK);
                /* symplectic Euler's energy oscillates near its limit; it does not grow */
                assert_true(e.total <= 3.0 * e0.total);
            } else {
                assert_true(st != DEFSIM_OK || !(e.total < 10.0 * e0.total));
            }
            defsim_world_destroy(w);
        }
    }
    assert_true(hs[1] > hs[0]);
    defsim_mesh_free(&m);
}

/* A checkpoint keeps volume_averaging (BODY, version 7; with quadratic tets, BODY's indices per
 * tet, version 8: the mean-dilatation element, test_quadratic_mixed): a clamped averaged box at
 * nu = 0.49, saved after 10 newton_cholmod steps and loaded, continues with the same bits as the
 * run that saved it, and not as the same box with standard tets does. Linear and quadratic
 * tets. */
static void test_checkpoint(void **state)
{
    (void)state;
    const double lo[3] = {0, 0, 0}, hi[3] = {0.6, 0.2, 0.2};
    for (int quadratic = 0; quadratic < 2; ++quadratic) {
        defsim_mesh m;
        memset(&m, 0, sizeof m);
        m.size = sizeof m;
        TU_OK(defsim_mesh_box(lo, hi, 6, 2, 2, &m));
        if (quadratic) TU_OK(defsim_mesh_make_quadratic(&m));
        defsim_world *w[2];
        for (int avg = 0; avg < 2; ++avg) {
            w[avg] = tu_world("newton_cholmod", -9.81, 1);
            defsim_body_def bd = body_def(&m, DEFSIM_MODEL_STABLE_NEOHOOKEAN, 0.49, avg);
            bd.material.youngs_modulus = 1e5;
            defsim_body_id id;
            TU_OK(defsim_world_add_body(w[avg], &bd, &id));
            tu_pin_below(w[avg], id, 0, 0.0);
            for (int k = 0; k < 10; ++k) TU_OK(defsim_world_step(w[avg], 0.01));
        }
        void *buf = NULL;
        size_t size = 0;
        TU_OK(defsim_world_save_buffer(w[1], &buf, &size));
        defsim_world *back = NULL;
        TU_OK(defsim_world_load_buffer(buf, size, NULL, NULL, &back));
        defsim_buffer_free(buf);
        for (int k = 0; k < 10; ++k) {
            TU_OK(defsim_world_step(w[0], 0.01));
            TU_OK(defsim_world_step(w[1], 0.01));
            TU_OK(defsim_world_step(back, 0.01));
        }
        double *a = tu_positions(w[1]), *b = tu_positions(back), *c = tu_positions(w[0]);
        const int n = defsim_world_vertex_count(back);
        double d = 0.0;
        for (int i = 0; i < 3 * n; ++i) d = fmax(d, fabs(a[i] - c[i]));
        printf("  %s tets, loaded run: bit-identical %d; the standard box differs by %.3g m\n",
               quadratic ? "quadratic" : "linear", !memcmp(a, b, 3 * (size_t)n * sizeof *a), d);
        assert_memory_equal(a, b, 3 * (size_t)n * sizeof *a);
        assert_true(d > 1e-4);
        free(a); free(b); free(c);
        defsim_world_destroy(w[0]);
        defsim_world_destroy(w[1]);
        defsim_world_destroy(back);
        defsim_mesh_free(&m);
    }
}

/* The same bits on 1 and 2 threads: an 8 x 4 x 4-cell averaged box (768 tets, past the term's
 * threshold for parallel loops) with stiffness damping, 5 newton_cholmod steps. */
static void test_threads(void **state)
{
    (void)state;
    const double lo[3] = {0, 0, 0}, hi[3] = {0.8, 0.4, 0.4};
    defsim_mesh m;
    memset(&m, 0, sizeof m);
    m.size = sizeof m;
    TU_OK(defsim_mesh_box(lo, hi, 8, 4, 4, &m));
    double *x[2];
    for (int k = 0; k < 2; ++k) {
        defsim_world *w = tu_world("newton_cholmod", -9.81, k + 1);
        defsim_body_def bd = body_def(&m, DEFSIM_MODEL_NEOHOOKEAN, 0.49, 1);
        bd.material.youngs_modulus = 1e5;
        bd.material.stiffness_damping = 0.01;
        defsim_body_id id;
        TU_OK(defsim_world_add_body(w, &bd, &id));
        tu_pin_below(w, id, 0, 0.0);
        for (int s = 0; s < 5; ++s) TU_OK(defsim_world_step(w, 0.01));
        x[k] = tu_positions(w);
        defsim_world_destroy(w);
    }
    assert_memory_equal(x[0], x[1], 3 * (size_t)m.vertex_count * sizeof *x[0]);
    free(x[0]);
    free(x[1]);
    defsim_mesh_free(&m);
}

/* ------------------------------------------------------------------------------------------ */
/* The cantilever */

typedef struct sag {
    double dy;        /* the top far corner's deflection (m, positive down) */
    double secs;      /* wall time of the solves */
    int solves;       /* static solves (steps) */
    double newton;    /* Newton iterations, all solves */
} sag;

/* The backend's message on its analysis (free DOFs, non-zeros of A and L, flops). */
static void print_analysis(void *user, int level, const char *message)
{
    (void)user;
    (void)level;
    if (strstr(message, "nnz(A upper)")) printf("    %s\n", message);
}

static sag cantilever(int nx, double nu, int avg)
{
    const double lo[3] = {0, 0, 0}, hi[3] = {3, 1, 1};
    defsim_mesh m;
    memset(&m, 0, sizeof m);
    m.size = sizeof m;
    TU_OK(defsim_mesh_box(lo, hi, nx, nx / 3, nx / 3, &m));
    defsim_world_def wd = tu_world_def("newton_cholmod", -9.81, 1);
    if (table_run) wd.log = print_analysis;   /* the factorisation's size */
    defsim_world *w = tu_create(&wd);
    tu_backend_option(w, "newton_cholmod", "tolerance", 1e-13);
    tu_backend_option(w, "newton_cholmod", "max_iterations", 100);
    tu_backend_option(w, "newton_cholmod", "projection", DEFSIM_PROJECTION_CLAMP);
    defsim_body_def bd = body_def(&m, DEFSIM_MODEL_NEOHOOKEAN, nu, avg);
    defsim_body_id id;
    TU_OK(defsim_world_add_body(w, &bd, &id));
    tu_pin_below(w, id, 0, 0.0);
    const int n = defsim_world_vertex_count(w);
    int probe = -1;
    for (int i = 0; i < n; ++i) {
        const double *p = m.positions + 3 * i;
        if (fabs(p[0] - 3) < 1e-12 && fabs(p[1] - 1) < 1e-12 && fabs(p[2] - 1) < 1e-12) probe = i;
    }
    assert_true(probe >= 0);
    double *x = malloc(3 * (size_t)n * sizeof *x), *v = calloc(3 * (size_t)n, sizeof *v);
    sag r = {0.0, 0.0, 0, 0.0};
    double last = 0.0;
    for (int s = 0; s < 12; ++s) {
        TU_OK(defsim_world_get_positions(w, x, n));
        TU_OK(defsim_world_set_state(w, x, v));
        const double t0 = now();
        TU_OK(defsim_world_step(w, 10.0));
        r.secs += now() - t0;
        r.solves++;
        TU_OK(defsim_world_get_positions(w, x, n));
        r.dy = 1.0 - x[3 * probe + 1];
        if (s > 0 && fabs(r.dy - last) < 1e-10) break;
        last = r.dy;
    }
    r.newton = tu_bstat(w, "newton_iterations");
    free(x);
    free(v);
    defsim_world_destroy(w);
    defsim_mesh_free(&m);
    return r;
}

/* Timoshenko's cantilever under a uniform load q = rho g A: q L^4 / (8 E I) + q L^2 / (2 k G A),
 * with Cowper's shear coefficient of a rectangle k = 10 (1 + nu) / (12 + 11 nu). */
static double timoshenko(double nu)
{
    const double E = 1e8, L = 3.0, A = 1.0, I = 1.0 / 12.0, q = 1000.0 * 9.81 * A;
    const double G = E / (2.0 * (1.0 + nu)), k = 10.0 * (1.0 + nu) / (12.0 + 11.0 * nu);
    return q * L * L * L * L / (8.0 * E * I) + q * L * L / (2.0 * k * G * A);
}

/* The limit d_inf of d = d_inf - C h^p through the sags d[k] on n[k] cells along the beam
 * (h = 1/n), the order p into *order (bisection on the ratio of the differences). */
static double richardson(const int n[3], const double d[3], double *order)
{
    const double r = (d[2] - d[1]) / (d[1] - d[0]);
    double lo = 0.3, hi = 4.0;
    for (int k = 0; k < 100; ++k) {
        const double p = 0.5 * (lo + hi);
        const double f = (pow(n[1], -p) - pow(n[2], -p)) / (pow(n[0], -p) - pow(n[1], -p)) - r;
        const double flo = (pow(n[1], -lo) - pow(n[2], -lo)) / (pow(n[0], -lo) - pow(n[1], -lo)) - r;
        if (flo * f <= 0.0) hi = p;
        else lo = p;
    }
    const double p = 0.5 * (lo + hi);
    *order = p;
    return d[2] + (d[1] - d[0]) / (pow(n[0], -p) - pow(n[1], -p)) * pow(n[2], -p);
}

static void print_sag(const char *what, int nx, double nu, sag s)
{
    printf("  %-9s %2d x %2d x %2d nu %.3f: %.6f mm, %d solves, %.0f Newton iterations, "
           "%.3f s per solve\n", what, nx, nx / 3, nx / 3, nu, 1e3 * s.dy, s.solves, s.newton,
           s.secs / s.solves);
}

/* nu = 0.499 on the shipped 12 x 4 x 4 cells: the standard tets lock (a sixth of the
 * reference); the averaged ones sag 4.5 times as much, 25 % short of the reference: what is left
 * is the linear tet's bending error, which the standard element has at nu = 0.3 too (20 %), and
 * volume averaging does not remove. Issue 29's 3 % at 12 x 4 x 4 is not met (quadratic tets'
 * business); --long shows the averaged element 3.3 % short at 48 x 16 x 16. */
static void test_locking(void **state)
{
    (void)state;
    const double nu = 0.499;
    const sag lin = cantilever(12, nu, 0), avg = cantilever(12, nu, 1);
    const sag lin3 = cantilever(12, 0.3, 0);
    print_sag("standard", 12, nu, lin);
    print_sag("averaged", 12, nu, avg);
    const double beam = timoshenko(nu);
    const double e_avg = avg.dy / REF_NU499 - 1.0, e_lin3 = lin3.dy / REF_NU3 - 1.0;
    printf("  reference %.4f mm (Timoshenko %.4f mm): standard %+.1f %%, averaged %+.1f %% "
           "(the standard element at nu = 0.3: %+.1f %%)\n", 1e3 * REF_NU499, 1e3 * beam,
           100.0 * (lin.dy / REF_NU499 - 1.0), 100.0 * e_avg, 100.0 * e_lin3);
    assert_true(lin.dy < 0.25 * REF_NU499);                 /* locked */
    assert_true(avg.dy > 4.0 * lin.dy);                      /* the volumetric locking is gone */
    assert_true(e_avg < 0.0 && fabs(e_avg) < 1.5 * fabs(e_lin3));   /* the bending error left */
    /* beam theory is above the 3D beam, whose fully clamped face is stiffer: by 2.4 % at
     * nu = 0.3, 7.4 % at 0.499 (the clamp also holds the lateral expansion) */
    assert_true(REF_NU499 < beam && REF_NU499 > 0.9 * beam);
}

/* Locking as nu -> 1/2 on 12 x 4 x 4 cells: the continuum's sag hardly changes from nu = 0.49
 * to 0.4999 (Timoshenko: by 0.07 %); the averaged element's falls by 6 % (towards a limit: 4 %
 * from 0.49 to 0.499, 2 % from there), the standard element's to 38 % of it. */
static void test_incompressible_limit(void **state)
{
    (void)state;
    const double nus[3] = {0.49, 0.499, 0.4999};
    sag s[3][2];
    for (int k = 0; k < 3; ++k)
        for (int avg = 0; avg < 2; ++avg) {
            s[k][avg] = cantilever(12, nus[k], avg);
            print_sag(avg ? "averaged" : "standard", 12, nus[k], s[k][avg]);
        }
    const double ra = s[2][1].dy / s[0][1].dy, rs = s[2][0].dy / s[0][0].dy;
    printf("  sag at 0.4999 over sag at 0.49: averaged %.4f, standard %.4f (Timoshenko %.4f)\n",
           ra, rs, timoshenko(0.4999) / timoshenko(0.49));
    assert_true(ra > 0.9);
    assert_true(rs < 0.5);
}

static void test_consistency(void **state)
{
    (void)state;
    const double nu = 0.3;
    sag s[2][2];
    for (int k = 0; k < 2; ++k)
        for (int avg = 0; avg < 2; ++avg) {
            s[k][avg] = cantilever(12 << k, nu, avg);
            print_sag(avg ? "averaged" : "standard", 12 << k, nu, s[k][avg]);
        }
    const double g12 = fabs(s[0][1].dy - s[0][0].dy), g24 = fabs(s[1][1].dy - s[1][0].dy);
    printf("  reference %.6f mm (Timoshenko %.6f mm); averaged - standard: %.4f mm at 12, "
           "%.4f mm at 24 cells\n", 1e3 * REF_NU3, 1e3 * timoshenko(nu), 1e3 * g12, 1e3 * g24);
    /* both converge towards the reference from below, the gap closing as the cell shrinks */
    assert_true(g24 < 0.5 * g12);
    for (int avg = 0; avg < 2; ++avg) {
        assert_true(s[0][avg].dy < s[1][avg].dy && s[1][avg].dy < REF_NU3);
        assert_true(fabs(s[1][avg].dy / REF_NU3 - 1.0) < fabs(s[0][avg].dy / REF_NU3 - 1.0));
    }
    assert_true(fabs(REF_NU3 / timoshenko(nu) - 1.0) <= 0.05);
}

/* --long: the references again from 24, 36 and 48 cells along the beam (the averaged element at
 * both ratios, the standard one at nu = 0.3 as the cross-check), and the averaged element's error
 * falling with the mesh. */
static void test_reference(void **state)
{
    (void)state;
    const int n[3] = {24, 36, 48};
    const double nus[3] = {0.3, 0.499, 0.3}, refs[3] = {REF_NU3, REF_NU499, REF_NU3};
    for (int k = 0; k < 3; ++k) {
        const int avg = k < 2;
        double d[3];
        for (int j = 0; j < 3; ++j) {
            const sag s = cantilever(n[j], nus[k], avg);
            print_sag(avg ? "averaged" : "standard", n[j], nus[k], s);
            d[j] = s.dy;
        }
        double p;
        const double r = richardson(n, d, &p);
        printf("  %s nu %.3f: extrapolated %.4f mm (order %.2f), reference %.4f mm; at 48 x 16 x "
               "16 cells %+.2f %%\n", avg ? "averaged" : "standard", nus[k], 1e3 * r, p,
               1e3 * refs[k], 100.0 * (d[2] / refs[k] - 1.0));
        assert_true(fabs(r / refs[k] - 1.0) <= (avg ? 1e-3 : 2e-3));
        assert_true(d[0] < d[1] && d[1] < d[2] && d[2] < refs[k]);
    }
}

int main(int argc, char **argv)
{
    for (int i = 1; i < argc; ++i) {
        if (!strcmp(argv[i], "--long")) long_run = 1;
        if (!strcmp(argv[i], "--table")) table_run = 1;
        if (!strcmp(argv[i], "--one") && i + 3 < argc) {   /* --one CELLS NU AVERAGED */
            const int nx = atoi(argv[i + 1]), avg = atoi(argv[i + 3]);
            const double nu = atof(argv[i + 2]);
            print_sag(avg ? "averaged" : "standard", nx, nu, cantilever(nx, nu, avg));
            return 0;
        }
    }
    if (table_run) {
        /* explicit steps: symplectic Euler on the 12 x 4 x 4 beam, 2,000 steps each */
        for (int avg = 0; avg < 2; ++avg) {
            const double lo[3] = {0, 0, 0}, hi[3] = {3, 1, 1};
            defsim_mesh m;
            memset(&m, 0, sizeof m);
            m.size = sizeof m;
            TU_OK(defsim_mesh_box(lo, hi, 12, 4, 4, &m));
            defsim_world *w = tu_world("symplectic_euler", -9.81, 1);
            defsim_body_def bd = body_def(&m, DEFSIM_MODEL_NEOHOOKEAN, 0.3, avg);
            defsim_body_id id;
            TU_OK(defsim_world_add_body(w, &bd, &id));
            tu_pin_below(w, id, 0, 0.0);
            double hs;
            TU_OK(defsim_world_stable_step(w, &hs, NULL));
            const double t0 = now();
            for (int k = 0; k < 2000; ++k) TU_OK(defsim_world_step(w, 0.5 * hs));
            printf("  %s symplectic_euler 12 x 4 x 4: stable step %.4g s, %.2f us per step\n",
                   avg ? "averaged" : "standard", hs, 1e6 * (now() - t0) / 2000);
            defsim_world_destroy(w);
            defsim_mesh_free(&m);
        }
        const double nus[2] = {0.3, 0.499};
        for (int k = 0; k < 2; ++k)
            for (int j = 0; j < (long_run ? 3 : 2); ++j)
                for (int avg = 0; avg < 2; ++avg)
                    print_sag(avg ? "averaged" : "standard", 12 << j, nus[k],
                              cantilever(12 << j, nus[k], avg));
        return 0;
    }
    if (long_run) {   /* ctest -L long: long_volume_averaging */
        const struct CMUnitTest refs[] = {cmocka_unit_test(test_reference)};
        return cmocka_run_group_tests(refs, NULL, NULL);
    }
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_refused),     cmocka_unit_test(test_homogeneous),
        cmocka_unit_test(test_stable_step), cmocka_unit_test(test_checkpoint),
        cmocka_unit_test(test_threads),
        cmocka_unit_test(test_locking),     cmocka_unit_test(test_incompressible_limit),
        cmocka_unit_test(test_consistency),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
