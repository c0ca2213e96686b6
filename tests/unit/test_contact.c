/* SPDX-License-Identifier: MIT */
/*
 * Contact with colliders (issue 12; docs/contact.md), on every backend: BARRIER mode on the
 * implicit_core schemes (newton_cholmod, newmark, bdf2), PENALTY on the others. Forces against
 * finite differences of the energy and blocks against finite differences of the forces; a block
 * resting on the ground (weight carried, nothing below the plane, checked from the positions);
 * friction on a 30 degree incline (stick for mu 0.7, slide with g (sin 30 - 0.3 cos 30) for 0.3);
 * cloth draped on a sphere; a beam carried by a moving sphere; energy of a bouncing block; a
 * stiff block dropped at h = 1/30; the stable step with penalty contact; one CHOLMOD analysis
 * whatever contacts appear; far colliders that cost no per-vertex work and miss nothing.
 */
#include "test_util.h"

#include "clock.h"
#include "contact.h"
#include "world.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static const char *const BARRIER[] = {"newton_cholmod", "newmark", "bdf2"};
static const char *const PENALTY[] = {"symplectic_euler", "velocity_verlet", "explicit_euler",
                                      "sundials_erk", "sundials_ida", "sundials_kinsol"};
enum { NBARRIER = 3, NPENALTY = 6 };
static const double G = 9.81;
static const double PI = 3.14159265358979323846;

static int is_barrier(const char *backend)
{
    for (int i = 0; i < NBARRIER; ++i)
        if (!strcmp(backend, BARRIER[i])) return 1;
    return 0;
}

/* A world with gravity -G y and one thread, or NULL (a skip) when this build lacks the backend.
 * Barrier steps get 200 Newton iterations: an impact takes up to ~40 (docs/contact.md). */
static defsim_world *world_or_skip(const char *backend, double gy)
{
    defsim_world_def d = tu_world_def(backend, gy, 1);
    defsim_world *w = tu_create_or_skip(&d);
    if (!w) return NULL;
    if (is_barrier(backend)) {
        char name[64];
        snprintf(name, sizeof name, "%s.max_iterations", backend);
        TU_OK(defsim_world_set_option_number(w, name, 200));
    }
    return w;
}

/* Explicit backends split steps at their stable step (which includes the contact's). */
static void auto_substep(defsim_world *w, const char *backend)
{
    if (!strcmp(backend, "symplectic_euler") || !strcmp(backend, "velocity_verlet") ||
        !strcmp(backend, "explicit_euler"))
        TU_OK(defsim_world_set_option(w, "core.auto_substep", "true"));
}

static defsim_collider_id add_plane(defsim_world *w, const double q[4], double mu)
{
    defsim_collider_def cd;
    defsim_collider_def_init(&cd, sizeof cd);
    if (q) memcpy(cd.rotation, q, sizeof cd.rotation);
    cd.friction = mu;
    defsim_collider_id id;
    TU_OK(defsim_world_add_collider(w, &cd, &id));
    return id;
}

static defsim_collider_id add_sphere(defsim_world *w, const double c[3], double r, double mu)
{
    defsim_collider_def cd;
    defsim_collider_def_init(&cd, sizeof cd);
    cd.shape = DEFSIM_SHAPE_SPHERE;
    memcpy(cd.position, c, sizeof cd.position);
    cd.radius = r;
    cd.friction = mu;
    defsim_collider_id id;
    TU_OK(defsim_world_add_collider(w, &cd, &id));
    return id;
}

/* A 2x2x2-cell neo-Hookean box on [lo, lo + size], positions rotated by q about the origin. */
static defsim_body_id add_block(defsim_world *w, const double lo[3], double size, double E,
                                double alpha, double beta, const double q[4])
{
    const double hi[3] = {lo[0] + size, lo[1] + size, lo[2] + size};
    defsim_mesh m;
    memset(&m, 0, sizeof m);
    m.size = sizeof m;
    TU_OK(defsim_mesh_box(lo, hi, 2, 2, 2, &m));
    if (q) {
        const double a = q[0], b = q[1], c = q[2], d = q[3];
        const double R[9] = {1 - 2 * (c * c + d * d), 2 * (b * c - a * d), 2 * (b * d + a * c),
                             2 * (b * c + a * d), 1 - 2 * (b * b + d * d), 2 * (c * d - a * b),
                             2 * (b * d - a * c), 2 * (c * d + a * b), 1 - 2 * (b * b + c * c)};
        for (int i = 0; i < m.vertex_count; ++i) {
            double *p = m.positions + 3 * i, r[3];
            for (int k = 0; k < 3; ++k) r[k] = R[3 * k] * p[0] + R[3 * k + 1] * p[1] + R[3 * k + 2] * p[2];
            memcpy(p, r, sizeof r);
        }
    }
    defsim_body_def bd = test_mesh_body(&m, DEFSIM_MODEL_NEOHOOKEAN);
    bd.material.youngs_modulus = E;
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

static double total_mass(const defsim_world *w)
{
    const int n = defsim_world_vertex_count(w);
    double *m = malloc((size_t)n * sizeof *m), s = 0.0;
    TU_OK(defsim_world_get_masses(w, m, n));
    for (int i = 0; i < n; ++i) s += m[i];
    free(m);
    return s;
}

/* Mass-weighted mean of the positions (axis k) or velocities. */
static double centre(const defsim_world *w, int velocity, int k)
{
    const int n = defsim_world_vertex_count(w);
    double *m = malloc((size_t)n * sizeof *m), *x = velocity ? tu_velocities(w) : tu_positions(w);
    TU_OK(defsim_world_get_masses(w, m, n));
    double s = 0.0, ms = 0.0;
    for (int i = 0; i < n; ++i) s += m[i] * x[3 * i + k], ms += m[i];
    free(m);
    free(x);
    return s / ms;
}

static double stat(const defsim_world *w, const char *name)
{
    double v = NAN;
    TU_OK(defsim_world_stat(w, name, &v));
    return v;
}

static double length_scale(double size)
{
    return sqrt(3.0) * size;   /* the rest bounding box's diagonal of one cube */
}

/* ------------------------------------------------------------------------------------------ */
/* Forces against the energy, blocks against the forces (finite differences) */

static void check_derivatives(const char *backend, int shape)
{
    defsim_world *w = world_or_skip(backend, -G);
    if (!w) return;
    const double lo[3] = {-0.1, 0.0, -0.1};
    add_block(w, lo, 0.2, 1e5, 0.0, 0.0, NULL);
    if (shape == DEFSIM_SHAPE_PLANE) {
        add_plane(w, NULL, 0.5);
    } else {
        const double c[3] = {0.0, -0.3, 0.0};
        add_sphere(w, c, 0.3 - 1e-4, 0.5);
    }
    TU_OK(defsim__world_plan(w));
    const int n = w->nv;
    double *x = tu_positions(w), *v = malloc(3 * (size_t)n * sizeof *v);
    unsigned long long seed = 7;
    /* Move the bottom vertices into the activation layer (dhat = 1e-3 L) and give every vertex
     * a velocity, so that normal and friction terms are all active. */
    const double dhat = 1e-3 * length_scale(0.2);
    for (int i = 0; i < n; ++i) {
        if (x[3 * i + 1] < 1e-9) x[3 * i + 1] = (0.3 + 0.2 * tu_rand(&seed)) * dhat + 1e-4 * (shape != 0);
        for (int k = 0; k < 3; ++k) v[3 * i + k] = 0.05 * tu_rand(&seed);
    }
    TU_OK(defsim_world_set_state(w, x, v));
    const double h = 0.01;
    defsim__contact_params p = {.mode = is_barrier(backend) ? DEFSIM__CONTACT_BARRIER
                                                            : DEFSIM__CONTACT_PENALTY,
                                .dhat_rel = 1e-3, .frequency = 300.0, .eps_v = 0.02};
    defsim__contact *c = &w->contact;
    /* The lagged friction of BARRIER needs a start point apart from x: start from x shifted. */
    double *xs = malloc(3 * (size_t)n * sizeof *xs);
    for (int i = 0; i < 3 * n; ++i) xs[i] = x[i] + (i % 3 == 1 ? 0.0 : 1e-4 * tu_rand(&seed));
    TU_OK(defsim__contact_begin(c, &w->sys, w->col, w->ncol, &p, xs, v, h, w->msg));
    assert_true(c->npair >= (shape == DEFSIM_SHAPE_PLANE ? 9 : 1));
    double *f = calloc(3 * (size_t)n, sizeof *f), *fp = calloc(3 * (size_t)n, sizeof *fp);
    double *fm = calloc(3 * (size_t)n, sizeof *fm);
    TU_OK(defsim__contact_forces(c, x, NULL, DEFSIM_FORCE_ELASTIC, f));
    const double e = 1e-7;
    double err = 0.0, fbig = 0.0;
    for (int i = 0; i < 3 * n; ++i) {
        const double x0 = x[i];
        x[i] = x0 + e;
        const double ep = defsim__contact_energy(c, x);
        x[i] = x0 - e;
        const double em = defsim__contact_energy(c, x);
        x[i] = x0;
        err = fmax(err, fabs(-(ep - em) / (2 * e) - f[i]));
        fbig = fmax(fbig, fabs(f[i]));
    }
    printf("  %s shape %d: |f| %.3g N, |f + dE/dx| %.3g\n", backend, shape, fbig, err);
    assert_true(fbig > 0.0);
    assert_true(err <= 1e-4 * fbig);
    /* Blocks: K = -df/dx (ELASTIC) for each vertex's own block, compared where the projection
     * leaves the exact matrix: along the columns of the block, up to its clamped part. */
    assert_true(defsim__contact_blocks(c, x, 1.0, 0.0, c->blk));
    double berr = 0.0, bmax = 0.0;
    for (int i = 0; i < n; ++i)
        for (int k = 0; k < 3; ++k) {
            const int dof = 3 * i + k;
            const double x0 = x[dof];
            memset(fp, 0, 3 * (size_t)n * sizeof *fp);
            memset(fm, 0, 3 * (size_t)n * sizeof *fm);
            x[dof] = x0 + e;
            TU_OK(defsim__contact_forces(c, x, NULL, DEFSIM_FORCE_ELASTIC, fp));
            x[dof] = x0 - e;
            TU_OK(defsim__contact_forces(c, x, NULL, DEFSIM_FORCE_ELASTIC, fm));
            x[dof] = x0;
            /* the normal direction (y) column of the block is exact for planes */
            if (shape == DEFSIM_SHAPE_PLANE && k == 1)
                for (int r = 0; r < 3; ++r) {
                    const double fd = -(fp[3 * i + r] - fm[3 * i + r]) / (2 * e);
                    berr = fmax(berr, fabs(fd - c->blk[9 * i + 3 * r + k]));
                    bmax = fmax(bmax, fabs(fd));
                }
        }
    if (shape == DEFSIM_SHAPE_PLANE) {
        printf("  %s: normal column of the blocks: max %.3g, error %.3g\n", backend, bmax, berr);
        assert_true(berr <= 1e-4 * bmax + 1e-9);
    }
    free(f); free(fp); free(fm); free(x); free(v); free(xs);
    defsim_world_destroy(w);
}

static void test_derivatives(void **state)
{
    (void)state;
    check_derivatives("newton_cholmod", DEFSIM_SHAPE_PLANE);
    check_derivatives("newton_cholmod", DEFSIM_SHAPE_SPHERE);
    check_derivatives("symplectic_euler", DEFSIM_SHAPE_PLANE);
    check_derivatives("symplectic_euler", DEFSIM_SHAPE_SPHERE);
}

/* ------------------------------------------------------------------------------------------ */
/* A block resting on the ground */

/* Lowest vertex height (y) of the world. */
static double min_y(const defsim_world *w)
{
    const int n = defsim_world_vertex_count(w);
    double *x = tu_positions(w), m = INFINITY;
    for (int i = 0; i < n; ++i) m = fmin(m, x[3 * i + 1]);
    free(x);
    return m;
}

static void resting_block(const char *backend)
{
    defsim_world *w = world_or_skip(backend, -G);
    if (!w) return;
    const int barrier = is_barrier(backend);
    const double y0 = 0.005, lo[3] = {-0.1, y0, -0.1};
    add_block(w, lo, 0.2, 1e5, 10.0, 0.0, NULL);
    const defsim_collider_id ground = add_plane(w, NULL, 0.0);
    auto_substep(w, backend);
    const double omega_c = 1000.0;   /* penalty: the penetration bound uses it */
    TU_OK(defsim_world_set_option_number(w, "core.contact_frequency", omega_c));
    /* newmark's trapezoidal rule gains energy on the stiff barrier at 2 ms (docs/contact.md) */
    const double h = !strcmp(backend, "newmark") ? 0.001 : barrier ? 0.01 : 0.005, vimpact = sqrt(2.0 * G * y0);
    const double bound = vimpact / omega_c + G / (omega_c * omega_c);
    double lowest = INFINITY;
    const int n = defsim_world_vertex_count(w), steps = (int)(2.0 / h), last = (int)(0.2 / h);
    double *f = malloc(3 * (size_t)n * sizeof *f), sum[3] = {0, 0, 0};
    for (int s = 0; s < steps; ++s) {
        if (defsim_world_step(w, h) != DEFSIM_OK)
            fail_msg("%s step %d: %s", backend, s, defsim_world_last_error(w));
        lowest = fmin(lowest, min_y(w));
        if (barrier) assert_true(lowest > 0.0);
        else assert_true(lowest >= -bound);
        if (s < steps - last) continue;
        /* the mean over the last 0.2 s: explicit_euler keeps a small ripple */
        TU_OK(defsim_world_get_contact_forces(w, f, n));
        for (int i = 0; i < n; ++i)
            for (int k = 0; k < 3; ++k) sum[k] += f[3 * i + k] / last;
    }
    /* vertices away from the ground get exactly nothing */
    double *x = tu_positions(w);
    for (int i = 0; i < n; ++i)
        if (x[3 * i + 1] > 0.05)
            assert_true(f[3 * i] == 0.0 && f[3 * i + 1] == 0.0 && f[3 * i + 2] == 0.0);
    free(x);
    const double weight = total_mass(w) * G;
    printf("  %-16s %s: lowest vertex %+.3g m (bound %s%.3g), contact force %.5f weights "
           "(%.2g, %.2g), active %g, pairs %g\n", backend, barrier ? "barrier" : "penalty", lowest,
           barrier ? "> 0" : ">= -", barrier ? 0.0 : bound, sum[1] / weight, sum[0] / weight,
           sum[2] / weight, stat(w, "contact.active"), stat(w, "contact.pairs"));
    assert_true(fabs(sum[1] / weight - 1.0) <= 0.01);
    assert_true(fabs(sum[0]) <= 1e-3 * weight && fabs(sum[2]) <= 1e-3 * weight);
    assert_true(stat(w, "contact.active") >= 9.0);
    assert_true(stat(w, "contact.min_distance") == stat(w, "contact.min_distance"));
    /* without the ground, the next step has no contact force at all */
    TU_OK(defsim_world_remove_collider(w, ground));
    if (defsim_world_step(w, h) != DEFSIM_OK)
        fail_msg("%s step without the ground: %s", backend, defsim_world_last_error(w));
    TU_OK(defsim_world_get_contact_forces(w, f, n));
    for (int i = 0; i < 3 * n; ++i) assert_true(f[i] == 0.0);
    free(f);
    defsim_world_destroy(w);
}

static void test_resting_block(void **state)
{
    (void)state;
    for (int i = 0; i < NBARRIER; ++i) resting_block(BARRIER[i]);
    for (int i = 0; i < NPENALTY; ++i) resting_block(PENALTY[i]);
}

/* ------------------------------------------------------------------------------------------ */
/* Friction on a 30 degree incline */

/* Runs the block on the incline; returns the fitted acceleration down the slope (m/s^2) over
 * [t0, t1] and the mean speed down the slope over that window. */
static int incline(const char *backend, double mu, double t0, double t1, double *accel,
                   double *speed)
{
    defsim_world *w = world_or_skip(backend, -G);
    if (!w) return 0;
    const double th = PI / 6.0, q[4] = {cos(th / 2), 0.0, 0.0, sin(th / 2)};
    const double dhat = 1e-3 * length_scale(0.2);
    const double lo[3] = {-0.1, 0.5 * dhat, -0.1};
    /* Stiffness damping calms the block's own vibrations (which would ratchet it down the slope
     * in the explicit backends) and leaves its rigid motion alone. */
    add_block(w, lo, 0.2, 1e6, 0.0, 1e-3, q);
    add_plane(w, q, mu);
    auto_substep(w, backend);
    if (getenv("SAFETY")) TU_OK(defsim_world_set_option(w, "core.substep_safety", getenv("SAFETY")));
    if (getenv("EPSV")) TU_OK(defsim_world_set_option(w, "core.friction_eps_v", getenv("EPSV")));
    /* Down the slope: the plane's local -x rotated by 30 degrees about z. */
    const double down[3] = {-cos(th), -sin(th), 0.0};
    const double h = is_barrier(backend) ? 0.005 : 0.002;
    const int steps = (int)(t1 / h + 0.5);
    double st = 0, sts = 0, stt = 0, sttt = 0, stttt = 0, ss = 0, sst = 0, sstt = 0;
    int m = 0;
    double s_start = 0.0, s_end = 0.0;
    for (int k = 1; k <= steps; ++k) {
        if (defsim_world_step(w, h) != DEFSIM_OK)
            fail_msg("%s step %d: %s", backend, k, defsim_world_last_error(w));
        const double t = k * h;
        double s = 0.0;
        for (int a = 0; a < 3; ++a) s += down[a] * centre(w, 0, a);
        if (t < t0 - 1e-12) continue;
        if (m == 0) s_start = s;
        s_end = s;
        st += t, stt += t * t, sttt += t * t * t, stttt += t * t * t * t;
        ss += s, sst += s * t, sstt += s * t * t;
        ++m;
    }
    (void)sts;
    /* Least squares s = c0 + c1 t + c2 t^2: the normal equations, solved by Cramer's rule. */
    const double A[9] = {m, st, stt, st, stt, sttt, stt, sttt, stttt}, b[3] = {ss, sst, sstt};
    const double det = A[0] * (A[4] * A[8] - A[5] * A[7]) - A[1] * (A[3] * A[8] - A[5] * A[6]) +
                       A[2] * (A[3] * A[7] - A[4] * A[6]);
    const double det2 = A[0] * (A[4] * b[2] - b[1] * A[7]) - A[1] * (A[3] * b[2] - b[1] * A[6]) +
                        b[0] * (A[3] * A[7] - A[4] * A[6]);
    *accel = 2.0 * det2 / det;
    *speed = (s_end - s_start) / (t1 - t0);
    defsim_world_destroy(w);
    return 1;
}

static void test_incline(void **state)
{
    (void)state;
    const char *const backends[] = {"newton_cholmod", "bdf2", "symplectic_euler"};
    const double a_exact = G * (0.5 - 0.3 * cos(PI / 6.0)), eps_v = 1e-3;
    for (int i = 0; i < 3; ++i) {
        double a, v;
        if (!incline(backends[i], 0.3, 0.2, 1.0, &a, &v)) continue;
        printf("  %-16s mu 0.3: acceleration %.4f m/s^2 (exact %.4f, %+.2f %%)\n", backends[i], a,
               a_exact, 100.0 * (a / a_exact - 1.0));
        assert_true(fabs(a / a_exact - 1.0) <= 0.03);
        incline(backends[i], 0.7, 0.5, 1.5, &a, &v);
        printf("  %-16s mu 0.7: creep %.3g m/s (threshold eps_v %.3g)\n", backends[i], v, eps_v);
        assert_true(fabs(v) < eps_v);
    }
}

/* ------------------------------------------------------------------------------------------ */
/* Cloth draped on a sphere */

/* Smallest |x - c| - r over the vertices: the independent check that none is inside. */
static double sphere_gap(const defsim_world *w, const double c[3], double r)
{
    const int n = defsim_world_vertex_count(w);
    double *x = tu_positions(w), gap = INFINITY;
    for (int i = 0; i < n; ++i) {
        const double *p = x + 3 * i;
        const double d[3] = {p[0] - c[0], p[1] - c[1], p[2] - c[2]};
        gap = fmin(gap, sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]) - r);
    }
    free(x);
    return gap;
}

static void cloth_on_sphere(const char *backend, int nu, double h, double t_end, int check)
{
    defsim_world *w = world_or_skip(backend, -G);
    if (!w) return;
    const double r = 0.3, c[3] = {0.0, 0.0, 0.0};
    const double origin[3] = {-0.5, 0.4, -0.5}, u[3] = {1.0, 0.0, 0.0}, v[3] = {0.0, 0.0, 1.0};
    defsim_mesh m;
    memset(&m, 0, sizeof m);
    m.size = sizeof m;
    TU_OK(defsim_mesh_cloth(origin, u, v, nu, nu, &m));
    defsim_body_def bd = test_mesh_body(&m, DEFSIM_MODEL_SPRING);
    bd.material.stiffness = 2e3;
    bd.material.vertex_mass = 1.0 / ((nu + 1) * (nu + 1));
    bd.material.mass_damping = 1.0;
    defsim_body_id id;
    TU_OK(defsim_world_add_body(w, &bd, &id));
    defsim_mesh_free(&m);
    add_sphere(w, c, r, 0.5);
    auto_substep(w, backend);
    /* Explicit friction's damping rate 2 mu lam / (m eps_v) sets the explicit backends' stable
     * step: a wider stick-slip threshold keeps this test short. */
    if (!is_barrier(backend)) TU_OK(defsim_world_set_option(w, "core.friction_eps_v", "0.02"));
    /* and Newton's last digits converge slowly against the barrier (docs/contact.md) */
    else TU_OK(defsim_world_set_option(w, "newton_cholmod.tolerance", "1e-5"));
    const int n = defsim_world_vertex_count(w);
    const int barrier = is_barrier(backend);
    double closest = INFINITY;
    const double t0 = defsim__now();
    for (int s = 0; s < (int)(t_end / h + 0.5); ++s) {
        if (defsim_world_step(w, h) != DEFSIM_OK)
            fail_msg("%s step %d: %s", backend, s, defsim_world_last_error(w));
        closest = fmin(closest, sphere_gap(w, c, r));
        if (check) assert_true(barrier ? closest > 0.0 : closest > -0.01 * r);
    }
    const double elapsed = defsim__now() - t0;
    double *x = tu_positions(w);
    double top = -INFINITY;
    for (int i = 0; i < n; ++i) top = fmax(top, x[3 * i + 1]);
    const double corner = x[1];
    printf("  %-16s cloth %dx%d on a sphere: closest %.3g m, highest vertex %.4f (top %.2f), "
           "corner at %.3f; %.3g ms per step\n", backend, nu, nu, closest, top, r, corner,
           1e3 * elapsed / (t_end / h));
    if (check) {
        assert_true(top > r && top < r + 0.02);   /* resting on the top */
        assert_true(corner < 0.2);                /* hanging down around it */
    }
    free(x);
    defsim_world_destroy(w);
}

static void test_cloth_on_sphere(void **state)
{
    (void)state;
    cloth_on_sphere("newton_cholmod", 20, 0.01, 1.5, 1);
    cloth_on_sphere("symplectic_euler", 20, 0.01, 1.5, 1);
}

/* ------------------------------------------------------------------------------------------ */
/* A beam carried by a moving sphere */

/* Signed distance of p to the axis-aligned box [c - e, c + e] (negative inside). */
static double box_distance(const double p[3], const double c[3], const double e[3])
{
    double out = 0.0, in = -INFINITY;
    for (int k = 0; k < 3; ++k) {
        const double q = fabs(p[k] - c[k]) - e[k];
        out += q > 0.0 ? q * q : 0.0;
        in = fmax(in, q);
    }
    return out > 0.0 ? sqrt(out) : in;
}

/* Smallest distance of the world's vertices to that box: the independent check. */
static double box_gap(const defsim_world *w, const double c[3], const double e[3])
{
    const int n = defsim_world_vertex_count(w);
    double *x = tu_positions(w), gap = INFINITY;
    for (int i = 0; i < n; ++i) gap = fmin(gap, box_distance(x + 3 * i, c, e));
    free(x);
    return gap;
}

/* A beam lying on rough ground (mu 0.5), its end pushed along x at 0.5 m/s for 1 s by a sphere
 * (touching the end face's four vertices, 0.05 sqrt(2) off its axis) or a box (its face on the
 * end face): carried along, no vertex inside the pusher. */
static void pushed_beam(const char *backend, defsim_shape shape)
{
    defsim_world *w = world_or_skip(backend, -G);
    if (!w) return;
    const double lo[3] = {0.0, 5e-4, -0.05}, hi[3] = {0.6, 0.1005, 0.05};
    tu_add_box(w, DEFSIM_MODEL_NEOHOOKEAN, 6, 1, 1, lo, hi, 1e5, 0.3, 1000.0);
    add_plane(w, NULL, 0.5);
    const double r = 0.1, e[3] = {0.05, 0.1, 0.1}, speed = 0.5, gap = 0.01;
    double c[3] = {-gap, 0.05, 0.0};
    c[0] -= shape == DEFSIM_SHAPE_BOX ? e[0] : sqrt(r * r - 0.005);
    defsim_collider_def cd;
    defsim_collider_def_init(&cd, sizeof cd);
    cd.shape = shape;
    memcpy(cd.position, c, sizeof cd.position);
    cd.radius = r;
    memcpy(cd.half_extents, e, sizeof cd.half_extents);
    defsim_collider_id s;
    TU_OK(defsim_world_add_collider(w, &cd, &s));
    auto_substep(w, backend);
    const double h = 0.01, q[4] = {1, 0, 0, 0};
    double inside = INFINITY;
    const double x0 = centre(w, 0, 0);
    for (int k = 0; k < 100; ++k) {
        c[0] += speed * h;
        TU_OK(defsim_collider_set_pose(w, s, c, q));
        if (defsim_world_step(w, h) != DEFSIM_OK)
            fail_msg("%s step %d: %s", backend, k, defsim_world_last_error(w));
        inside = fmin(inside, shape == DEFSIM_SHAPE_BOX ? box_gap(w, c, e) : sphere_gap(w, c, r));
    }
    const double moved = centre(w, 0, 0) - x0, vx = centre(w, 1, 0);
    printf("  %-16s beam pushed 0.5 m by a %s on rough ground: moved %.3f m, speed %.3f m/s, "
           "closest %.3g m\n", backend, shape == DEFSIM_SHAPE_BOX ? "box" : "sphere", moved, vx,
           inside);
    assert_true(inside > (is_barrier(backend) ? 0.0 : -0.005));
    assert_true(moved > 0.5 - gap - 0.03 && moved < 0.5 - gap + 0.01);
    defsim_world_destroy(w);
}

static void test_pushed_beam(void **state)
{
    (void)state;
    pushed_beam("newton_cholmod", DEFSIM_SHAPE_SPHERE);
    pushed_beam("symplectic_euler", DEFSIM_SHAPE_SPHERE);
    pushed_beam("newton_cholmod", DEFSIM_SHAPE_BOX);
    pushed_beam("symplectic_euler", DEFSIM_SHAPE_BOX);
}

/* ------------------------------------------------------------------------------------------ */
/* A frictionless elastic block bouncing gains no energy: velocity_verlet (penalty, conservative),
 * newton_cholmod and bdf2 (barrier, dissipative) */

static void bouncing(const char *backend, double h, int conservative)
{
    defsim_world *w = world_or_skip(backend, -G);
    if (!w) return;
    const double drop = 0.1, lo[3] = {-0.1, drop, -0.1};
    add_block(w, lo, 0.2, 1e5, 0.0, 0.0, NULL);
    add_plane(w, NULL, 0.0);
    auto_substep(w, backend);
    const double M = total_mass(w);
    defsim_energy e;
    TU_OK(defsim_world_energy(w, &e));
    /* Energy above the block at rest on the ground (its centre at half its size). */
    const double ground = M * G * 0.1, e0 = e.total - ground;
    double emax = e0, highest_after = 0.0;
    int bounces = 0, in_contact = 0;
    for (int k = 0; k < (int)(1.5 / h); ++k) {
        if (defsim_world_step(w, h) != DEFSIM_OK)
            fail_msg("%s step %d: %s", backend, k, defsim_world_last_error(w));
        const int active = stat(w, "contact.active") > 0.0;
        if (in_contact && !active) ++bounces;
        in_contact = active;
        if (active) continue;
        TU_OK(defsim_world_energy(w, &e));
        emax = fmax(emax, e.total - ground);
        if (bounces > 0) highest_after = fmax(highest_after, centre(w, 0, 1) - 0.1);
    }
    printf("  %-16s bouncing block: %d bounces, max energy out of contact %.4f of the start, "
           "rebound height %.3f of the drop\n", backend, bounces, emax / e0, highest_after / drop);
    assert_true(bounces >= 1);
    assert_true(emax <= 1.01 * e0);
    /* a conservative scheme keeps most of it: the block rebounds */
    if (conservative) assert_true(highest_after >= 0.5 * drop);
    defsim_world_destroy(w);
}

static void test_bouncing_energy(void **state)
{
    (void)state;
    /* newmark is left out: its trapezoidal rule gains energy at barrier impacts (docs/contact.md) */
    bouncing("velocity_verlet", 0.002, 1);
    bouncing("newton_cholmod", 0.002, 0);
    bouncing("bdf2", 0.002, 0);
}

/* ------------------------------------------------------------------------------------------ */
/* Large steps: a stiff block dropped at h = 1/30 neither tunnels nor explodes */

static void test_large_steps(void **state)
{
    (void)state;
    defsim_world *w = world_or_skip("newton_cholmod", -G);
    if (!w) return;
    const double lo[3] = {-0.1, 0.5, -0.1};
    add_block(w, lo, 0.2, 1e8, 0.0, 0.0, NULL);
    add_plane(w, NULL, 0.0);
    const double h = 1.0 / 30.0;
    double lowest = INFINITY, vmax = 0.0;
    for (int k = 0; k < 60; ++k) {
        if (defsim_world_step(w, h) != DEFSIM_OK)
            fail_msg("step %d: %s", k, defsim_world_last_error(w));
        lowest = fmin(lowest, min_y(w));
        assert_true(lowest > 0.0);
        if (k > 30) vmax = fmax(vmax, fabs(centre(w, 1, 1)));
    }
    const double y = centre(w, 0, 1);
    printf("  stiff block at h = 1/30: lowest vertex %.3g m, centre %.4f m (0.1 at rest), "
           "|v| after 1 s %.3g m/s\n", lowest, y, vmax);
    assert_true(y > 0.1 && y < 0.1 + 0.01);
    assert_true(vmax < 0.1);
    defsim_world_destroy(w);
}

/* ------------------------------------------------------------------------------------------ */
/* Penalty contact lowers the stable step: omega^2 grows by (2.5 omega_c)^2 */

static void test_stable_step(void **state)
{
    (void)state;
    defsim_world *w = world_or_skip("symplectic_euler", -G);
    const double lo[3] = {-0.1, 0.0, -0.1};
    add_block(w, lo, 0.2, 1e5, 0.0, 0.0, NULL);
    double h0, om0, h1, om1;
    TU_OK(defsim_world_stable_step(w, &h0, &om0));
    add_plane(w, NULL, 0.0);
    const double wc = 3.0 * om0;
    TU_OK(defsim_world_set_option_number(w, "core.contact_frequency", wc));
    TU_OK(defsim_world_stable_step(w, &h1, &om1));
    printf("  stable step %.3g s (omega %.4g) without contact, %.3g s (omega %.4g) with "
           "omega_c %.4g\n", h0, om0, h1, om1, wc);
    /* The penalty counts 2.5 times its frequency (docs/stability.md "Contact"). */
    assert_true(om1 >= sqrt(om0 * om0 + 6.25 * wc * wc) * (1 - 1e-3));
    assert_true(om1 <= om0 + 2.5 * wc * 1.001 + 1e-9);
    assert_true(h1 < h0);
    defsim_world_destroy(w);
}

/* ------------------------------------------------------------------------------------------ */
/* Contacts appearing never re-analyse CHOLMOD: the pattern already has each vertex's block */

static int analyses;
static void count_log(void *user, int level, const char *message)
{
    (void)user;
    (void)level;
    if (strstr(message, "free DOFs")) ++analyses;
}

static void test_no_reanalysis(void **state)
{
    (void)state;
    defsim_world_def d = tu_world_def("newton_cholmod", -G, 1);
    d.log = count_log;
    defsim_world *w = NULL;
    if (defsim_world_create(&d, &w) != DEFSIM_OK) return;
    const double lo[3] = {-0.1, 0.02, -0.1};
    add_block(w, lo, 0.2, 1e5, 0.0, 0.0, NULL);
    add_plane(w, NULL, 0.0);
    analyses = 0;
    TU_OK(defsim_world_step(w, 0.01));
    const int before = analyses;
    double active_seen = 0.0;
    for (int k = 0; k < 50; ++k) {
        TU_OK(defsim_world_step(w, 0.01));
        active_seen = fmax(active_seen, stat(w, "contact.active"));
    }
    printf("  CHOLMOD analyses: %d before contact, %d after (%g contacts appeared)\n", before,
           analyses, active_seen);
    assert_int_equal(before, 1);
    assert_int_equal(analyses, 1);
    assert_true(active_seen >= 9.0);
    defsim_world_destroy(w);
}

/* ------------------------------------------------------------------------------------------ */
/* Bad input: an SDF returning NaN fails the step with DEFSIM_ERR_CALLBACK, nothing changed */

typedef struct sdf_ground {
    int calls_left;   /* < 0: always finite */
    int calls;        /* counted */
} sdf_ground;

static double ground_sdf(void *user, const double p[3], double grad[3])
{
    sdf_ground *g = user;
    grad[0] = 0.0, grad[1] = 1.0, grad[2] = 0.0;
    g->calls++;
    if (g->calls_left == 0) return NAN;
    if (g->calls_left > 0) g->calls_left--;
    return p[1];
}

static void sdf_nan(const char *backend)
{
    defsim_world *w = world_or_skip(backend, -G);
    if (!w) return;
    const double lo[3] = {-0.1, 0.001, -0.1};
    add_block(w, lo, 0.2, 1e5, 10.0, 0.0, NULL);
    sdf_ground g = {-1, 0};
    defsim_collider_def cd;
    defsim_collider_def_init(&cd, sizeof cd);
    cd.shape = DEFSIM_SHAPE_SDF;
    cd.sdf = ground_sdf;
    cd.sdf_user = &g;
    cd.friction = 0.3;
    defsim_collider_id id;
    TU_OK(defsim_world_add_collider(w, &cd, &id));
    const double h = 0.002;
    for (int k = 0; k < 20; ++k) TU_OK(defsim_world_step(w, h));
    const int n = defsim_world_vertex_count(w);
    double *x = tu_positions(w), *v = tu_velocities(w), *f = malloc(3 * (size_t)n * sizeof *f);
    double *f2 = malloc(3 * (size_t)n * sizeof *f2);
    TU_OK(defsim_world_get_contact_forces(w, f, n));
    /* NaN at the first query of a step (the broad phase) and at its last (the solve's end) */
    g.calls = 0;
    TU_OK(defsim_world_step(w, h));
    const int per_step = g.calls;
    TU_OK(defsim_world_set_state(w, x, v));
    TU_OK(defsim_world_step(w, h));   /* the same step again: the read-back as before it */
    TU_OK(defsim_world_set_state(w, x, v));
    TU_OK(defsim_world_get_contact_forces(w, f, n));
    const double t = defsim_world_time(w);
    const int when[2] = {0, per_step - 1};
    for (int k = 0; k < 2; ++k) {
        g.calls_left = when[k];
        assert_int_equal(defsim_world_step(w, h), DEFSIM_ERR_CALLBACK);
        double *x2 = tu_positions(w), *v2 = tu_velocities(w);
        TU_OK(defsim_world_get_contact_forces(w, f2, n));
        assert_memory_equal(x, x2, 3 * (size_t)n * sizeof *x);
        assert_memory_equal(v, v2, 3 * (size_t)n * sizeof *v);
        assert_memory_equal(f, f2, 3 * (size_t)n * sizeof *f);
        assert_true(defsim_world_time(w) == t);
        free(x2);
        free(v2);
    }
    printf("  %-16s SDF returning NaN at query 1 or %d of a step: DEFSIM_ERR_CALLBACK, state "
           "and contact forces unchanged (%s)\n", backend, per_step, defsim_world_last_error(w));
    g.calls_left = -1;
    TU_OK(defsim_world_step(w, h));
    free(x); free(v); free(f); free(f2);
    defsim_world_destroy(w);
}

static void test_sdf_nan(void **state)
{
    (void)state;
    sdf_nan("newton_cholmod");
    sdf_nan("symplectic_euler");
}

/* ------------------------------------------------------------------------------------------ */
/* Far colliders: no per-vertex work, and nothing missed when the bodies leave the safe box */

/* Three spheres and a plane 100 m away. */
static void add_far_colliders(defsim_world *w)
{
    for (int k = 0; k < 3; ++k) {
        double c[3] = {0.0, 0.0, 0.0};
        c[k] = 100.0;
        add_sphere(w, c, 0.5, 0.5);
    }
    defsim_collider_def cd;
    defsim_collider_def_init(&cd, sizeof cd);
    cd.position[1] = -100.0;
    cd.friction = 0.5;
    TU_OK(defsim_world_add_collider(w, &cd, NULL));
}

/* Every vertex gets the force m_i a along -y (a uniform acceleration a, m/s^2). */
static void push_down(defsim_world *w, double a)
{
    const int n = defsim_world_vertex_count(w);
    double *m = malloc((size_t)n * sizeof *m), *f = calloc(3 * (size_t)n, sizeof *f);
    TU_OK(defsim_world_get_masses(w, m, n));
    for (int i = 0; i < n; ++i) f[3 * i + 1] = -m[i] * a;
    TU_OK(defsim_world_set_external_forces(w, f, n));
    free(m);
    free(f);
}

/* Largest |contact force| of the read-back (N) and the lowest vertex's height. */
static double readback_max(const defsim_world *w)
{
    const int n = defsim_world_vertex_count(w);
    double *f = malloc(3 * (size_t)n * sizeof *f), big = 0.0;
    TU_OK(defsim_world_get_contact_forces(w, f, n));
    for (int i = 0; i < 3 * n; ++i) big = fmax(big, fabs(f[i]));
    free(f);
    return big;
}

/* A falling block with colliders 100 m away steps bit for bit as without them, pairs nothing,
 * and after its first step runs without per-vertex balls (the safe box of an earlier step). */
static void far_is_free(const char *backend)
{
    defsim_world *w[2] = {world_or_skip(backend, -G), world_or_skip(backend, -G)};
    if (!w[0] || !w[1]) return;
    const double lo[3] = {-0.1, 0.5, -0.1};
    for (int k = 0; k < 2; ++k) add_block(w[k], lo, 0.2, 1e5, 1.0, 0.0, NULL);
    add_far_colliders(w[1]);
    const int n = defsim_world_vertex_count(w[0]), steps = 40;
    int free_steps = 0;
    for (int s = 0; s < steps; ++s) {
        for (int k = 0; k < 2; ++k) TU_OK(defsim_world_step(w[k], 0.005));
        assert_true(stat(w[1], "contact.pairs") == 0.0);
        assert_true(readback_max(w[1]) == 0.0);
        free_steps += w[1]->contact.far && !w[1]->contact.balls;
    }
    double *x0 = tu_positions(w[0]), *x1 = tu_positions(w[1]);
    double *v0 = tu_velocities(w[0]), *v1 = tu_velocities(w[1]);
    printf("  %-16s far colliders: %d of %d steps without per-vertex work, fell %.4f m, state "
           "bit-identical to the world without colliders\n", backend, free_steps, steps,
           lo[1] - min_y(w[1]));
    assert_memory_equal(x0, x1, 3 * (size_t)n * sizeof *x0);
    assert_memory_equal(v0, v1, 3 * (size_t)n * sizeof *v0);
    assert_int_equal(free_steps, steps - 1);
    assert_true(lo[1] - min_y(w[1]) > 0.01);   /* it fell: the vertices moved in the safe box */
    free(x0); free(x1); free(v0); free(v1);
    for (int k = 0; k < 2; ++k) defsim_world_destroy(w[k]);
}

/* No gravity: a block 5 cm above a collider runs without balls; then a force the broad phase
 * does not foresee (held external forces) pushes it down by far more than the gap in one step.
 * BARRIER: Newton's first update leaves the safe box and would carry the block right through a
 * 1 cm slab (a box collider) under it, every vertex ending below it at finite energy: the line
 * search must pair and stop the block on the slab. PENALTY: the step ends with the bottom
 * within dhat of the ground, so the read-back of that step must hold the penalty forces (the
 * end of the step is a point no evaluation saw). */
static void far_then_pushed(const char *backend)
{
    defsim_world *w = world_or_skip(backend, 0.0);
    if (!w) return;
    const int barrier = is_barrier(backend);
    const double y0 = 0.05, lo[3] = {-0.1, y0, -0.1}, dhat = 1e-3 * length_scale(0.2);
    const double top = 0.005;   /* the slab's top face */
    add_block(w, lo, 0.2, 1e5, 0.0, 0.0, NULL);
    if (barrier) {
        defsim_collider_def cd;
        defsim_collider_def_init(&cd, sizeof cd);
        cd.shape = DEFSIM_SHAPE_BOX;
        cd.half_extents[0] = cd.half_extents[2] = 1.0;
        cd.half_extents[1] = top;
        TU_OK(defsim_world_add_collider(w, &cd, NULL));
    } else {
        add_plane(w, NULL, 0.0);
    }
    const double h = barrier ? 0.1 : 0.01;
    for (int s = 0; s < 3; ++s) TU_OK(defsim_world_step(w, h));
    assert_true(w->contact.far && !w->contact.balls);
    /* BARRIER: a full update goes 0.2 m down; PENALTY: the bottom ends at dhat / 2 */
    const double a = barrier ? 20.0 : (y0 - 0.5 * dhat) / (h * h);
    push_down(w, a);
    TU_OK(defsim_world_step(w, h));
    const double low = min_y(w), active = stat(w, "contact.active"), f = readback_max(w);
    printf("  %-16s pushed %.3g m/s^2 from %.2g m: lowest vertex %+.3g m above the %s, active "
           "%g, largest contact force %.3g N\n", backend, a, y0, low - (barrier ? top : 0.0),
           barrier ? "slab" : "ground", active, f);
    if (barrier) {
        assert_true(low > top && low < top + dhat);
        assert_true(active == 9.0);
    } else {
        assert_true(fabs(low - 0.5 * dhat) < 1e-3 * dhat);
        /* k_i (dhat - d) with k_i = m_i omega_c^2: positive on the bottom vertices */
        assert_true(active == 9.0);
    }
    assert_true(f > 0.0);
    defsim_world_destroy(w);
}

/* The safe box is kept from step to step only while it stays valid: a collider moved next to
 * the block (PENALTY: it pushes the block in the first step), and a block set next to the
 * ground by the host (BARRIER: its friction is lagged from the start of the step, so the start
 * must be paired: a block sliding at 0.1 m/s slows down in that very step). */
static void far_box_stale(const char *backend)
{
    defsim_world *w = world_or_skip(backend, 0.0);
    if (!w) return;
    const double y0 = 0.3, lo[3] = {-0.1, y0, -0.1}, dhat = 1e-3 * length_scale(0.2);
    add_block(w, lo, 0.2, 1e5, 0.0, 0.0, NULL);
    const defsim_collider_id ground = add_plane(w, NULL, 0.5);
    const double h = 0.01;
    for (int s = 0; s < 3; ++s) TU_OK(defsim_world_step(w, h));
    assert_true(w->contact.far && !w->contact.balls);
    if (!is_barrier(backend)) {
        const double p[3] = {0.0, y0 - 0.5 * dhat, 0.0}, q[4] = {1.0, 0.0, 0.0, 0.0};
        TU_OK(defsim_collider_set_pose(w, ground, p, q));
        TU_OK(defsim_world_step(w, h));
        const double up = centre(w, 1, 1);
        printf("  %-16s ground moved under the block: pairs %g, pushed up to %.3g m/s\n",
               backend, stat(w, "contact.pairs"), up);
        assert_true(stat(w, "contact.pairs") >= 9.0);
        assert_true(up > 0.0);
        defsim_world_destroy(w);
        return;
    }
    const int n = defsim_world_vertex_count(w);
    double *x = tu_positions(w), *v = calloc(3 * (size_t)n, sizeof *v);
    for (int i = 0; i < n; ++i) {
        x[3 * i + 1] -= y0 - 0.5 * dhat;   /* the bottom at dhat / 2 */
        v[3 * i] = 0.1;
    }
    TU_OK(defsim_world_set_state(w, x, v));
    TU_OK(defsim_world_step(w, h));
    const double u = centre(w, 1, 0);
    printf("  %-16s block set sliding on the ground: pairs %g, speed 0.1 -> %.4f m/s in one "
           "step\n", backend, stat(w, "contact.pairs"), u);
    assert_true(stat(w, "contact.pairs") >= 9.0);
    assert_true(u < 0.1 - 1e-3);
    free(x);
    free(v);
    defsim_world_destroy(w);
}

static void test_far_colliders(void **state)
{
    (void)state;
    const char *const backends[] = {"symplectic_euler", "velocity_verlet", "newton_cholmod"};
    for (int i = 0; i < 3; ++i) far_is_free(backends[i]);
    far_then_pushed("newton_cholmod");
    far_then_pushed("symplectic_euler");
    far_box_stale("newton_cholmod");
    far_box_stale("symplectic_euler");
}

/* A backend that claims DEFSIM_BACKEND_CONTACT_CCD but steps like symplectic Euler without
 * calling contact_max_step: its vertices can jump through a collider. The watchdog's contact
 * check must refuse such a step (state restored), and let it through with core.watchdog off. */
static defsim_status liar_init(const defsim_host *host, defsim_system *sys, void *state)
{
    double **f = state;
    *f = host->alloc((size_t)host->dof_count(sys) * sizeof(double));
    return *f ? DEFSIM_OK : DEFSIM_ERR_OUT_OF_MEMORY;
}

static defsim_status liar_step(const defsim_host *host, defsim_system *sys, void *state, double h)
{
    double *f = *(double **)state, *x = host->positions(sys), *v = host->velocities(sys);
    const double *m = host->mass(sys);
    const int64_t n = host->dof_count(sys);
    /* Gravity only: the barrier's force would be +-inf or NaN behind the surface. */
    defsim_status st = host->forces(sys, x, v, DEFSIM_FORCE_GRAVITY, f);
    if (st != DEFSIM_OK) return st;
    for (int64_t i = 0; i < n; ++i) {
        v[i] += h * f[i] / m[i];
        x[i] += h * v[i];
    }
    return DEFSIM_OK;
}

static void liar_fini(const defsim_host *host, defsim_system *sys, void *state)
{
    (void)sys;
    host->release(*(double **)state);
    *(double **)state = NULL;
}

static const defsim_backend LIAR = {
    .abi_version = DEFSIM_BACKEND_ABI_VERSION, .struct_size = sizeof(defsim_backend),
    .name = "contact_liar", .flags = DEFSIM_BACKEND_CONTACT_CCD, .state_size = sizeof(double *),
    .init = liar_init, .step = liar_step, .fini = liar_fini};

static void test_watchdog_barrier_crossed(void **state)
{
    (void)state;
    TU_OK(defsim_register_backend(&LIAR));
    for (int on = 1; on >= 0; --on) {
        defsim_world *w = world_or_skip("contact_liar", -G);
        TU_OK(defsim_world_set_option(w, "core.watchdog", on ? "true" : "false"));
        add_plane(w, NULL, 0.0);
        const double lo[3] = {0, 0.05, 0};
        add_block(w, lo, 0.1, 1e5, 0.0, 0.0, NULL);
        const int32_t n = defsim_world_vertex_count(w);
        double *v = calloc(3 * (size_t)n, sizeof *v);
        assert_non_null(v);
        for (int32_t i = 0; i < n; ++i) v[3 * i + 1] = -10.0;   /* 0.1 m per 10 ms step */
        TU_OK(defsim_world_set_state(w, NULL, v));
        defsim_status st = DEFSIM_OK;
        int steps = 0;
        for (; steps < 10 && st == DEFSIM_OK; ++steps) {
            double *before = tu_positions(w);
            st = defsim_world_step(w, 0.01);
            if (st != DEFSIM_OK) {
                double *after = tu_positions(w);
                assert_memory_equal(before, after, 3 * (size_t)n * sizeof *before);
                free(after);
            }
            free(before);
        }
        if (on) {
            /* Refused at the first step that ends below the plane, with the state restored. */
            assert_int_equal(st, DEFSIM_ERR_UNSTABLE);
            assert_non_null(strstr(defsim_world_last_error(w), "crossed a collider"));
            assert_true(min_y(w) > 0.0);
        } else {
            assert_true(min_y(w) < 0.0);   /* without the watchdog the lie goes through */
        }
        free(v);
        defsim_world_destroy(w);
    }
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_watchdog_barrier_crossed),
        cmocka_unit_test(test_derivatives),
        cmocka_unit_test(test_resting_block),
        cmocka_unit_test(test_incline),
        cmocka_unit_test(test_cloth_on_sphere),
        cmocka_unit_test(test_pushed_beam),
        cmocka_unit_test(test_bouncing_energy),
        cmocka_unit_test(test_large_steps),
        cmocka_unit_test(test_stable_step),
        cmocka_unit_test(test_no_reanalysis),
        cmocka_unit_test(test_sdf_nan),
        cmocka_unit_test(test_far_colliders),
    };
    return tu_exit(cmocka_run_group_tests(tests, NULL, NULL));
}
