/* SPDX-License-Identifier: MIT */
/*
 * Body contact's engine (issue 13) at unit level; the acceptance tests are test_body_contact.c.
 *  - finite differences through the system: a probe backend evaluates the energy, forces and
 *    matrices that the host serves inside a step: the forces are -grad E (point-triangle,
 *    edge-edge, point-edge, friction), the Hessian of a single point-triangle pair is the PSD
 *    projection of the finite-difference Hessian (in the vertices' differences, as the engine
 *    projects), and the sparse matrix (whose pattern grew for
 *    the pair's off-diagonal blocks) holds the same numbers as the product;
 *  - two boxes pressed together: no vertex of one inside a tet of the other (exact predicate),
 *    the body-body forces sum to zero (Newton's third law) and balance the load;
 *  - pattern growth: the number of CHOLMOD analyses (from the backend's log) is one plus the
 *    growths counted in contact.pattern_growths, and far fewer than the steps;
 *  - an explicit backend refuses body contact with the state unchanged;
 *  - the constraint set: pairs within dhat merged into one VV, EV or FV contact whose weight and
 *    energy are the pairs' sum (n khat b(d) at a known distance); a point outside the
 *    candidates' boxes makes a new broad phase;
 *  - collision groups, masks and self_contact filter pairs (candidate counts);
 *  - bad body defs; a checkpoint round trip continues bit for bit with body contact on.
 */
#include "test_util.h"

#include "body_contact.h"
#include "contact_barrier.h"
#include "exact_geom.h"
#include "world.h"

#include <defsim/backend.h>

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* ------------------------------------------------------------------------------------------ */
/* The probe backend: in its step it checks the host's services at the start of the step plus
 * `shift` (state left unchanged). */

enum { PROBE_MAX = 24 };

static struct {
    double shift[3 * PROBE_MAX];   /* where to evaluate, relative to the start */
    int hessian;                   /* also check the Hessian against the PSD-projected FD one */
    int pair[4], npair;            /* the vertices of the one active pair (hessian) */
    double grad_err, hess_err, values_err;
    double grad_scale, hess_scale;
    int grew;                      /* matrix_pattern_version changed during the step */
    int projected_same;            /* matrix_values_projected(clamp) == matrix_values */
    int projected_refused;         /* ... refuses a projection that does not exist */
} probe;

static double dot(const double *a, const double *b, int n)
{
    double s = 0.0;
    for (int i = 0; i < n; ++i) s += a[i] * b[i];
    return s;
}

/* Cyclic Jacobi: replaces the symmetric n x n A by V max(L, 0) V^T. */
static void project_psd(int n, double *A)
{
    double V[144], a[144];
    memcpy(a, A, (size_t)n * n * sizeof *a);
    for (int i = 0; i < n * n; ++i) V[i] = (i / n == i % n);
    for (int sweep = 0; sweep < 100; ++sweep) {
        double off = 0.0, tot = 0.0;
        for (int i = 0; i < n; ++i)
            for (int j = 0; j < n; ++j) {
                tot += a[i * n + j] * a[i * n + j];
                if (i != j) off += a[i * n + j] * a[i * n + j];
            }
        if (off <= 1e-30 * tot) break;
        for (int p = 0; p < n; ++p)
            for (int q = p + 1; q < n; ++q) {
                if (a[p * n + q] == 0.0) continue;
                const double th = 0.5 * atan2(2.0 * a[p * n + q], a[q * n + q] - a[p * n + p]);
                const double c = cos(th), s = sin(th);
                for (int k = 0; k < n; ++k) {   /* A <- A J */
                    const double akp = a[k * n + p], akq = a[k * n + q];
                    a[k * n + p] = c * akp - s * akq;
                    a[k * n + q] = s * akp + c * akq;
                }
                for (int k = 0; k < n; ++k) {   /* A <- J^T A */
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
            double s = 0.0;
            for (int k = 0; k < n; ++k) s += V[i * n + k] * fmax(a[k * n + k], 0.0) * V[j * n + k];
            A[i * n + j] = s;
        }
}

static defsim_status probe_init(const defsim_host *host, defsim_system *sys, void *state)
{
    (void)host;
    (void)sys;
    (void)state;
    return DEFSIM_OK;
}

static void probe_fini(const defsim_host *host, defsim_system *sys, void *state)
{
    (void)host;
    (void)sys;
    (void)state;
}

static defsim_status probe_step(const defsim_host *host, defsim_system *sys, void *state, double h)
{
    (void)state;
    (void)h;
    const int64_t n = host->dof_count(sys);
    assert_true(n <= 3 * PROBE_MAX);
    const double *x0 = host->positions(sys);
    double x[3 * PROBE_MAX], xp[3 * PROBE_MAX], xm[3 * PROBE_MAX], f[3 * PROBE_MAX];
    double fp[3 * PROBE_MAX], fm[3 * PROBE_MAX], u[3 * PROBE_MAX];
    for (int64_t i = 0; i < n; ++i) x[i] = x0[i] + probe.shift[i];
    const uint32_t all = DEFSIM_FORCE_ELASTIC | DEFSIM_FORCE_GRAVITY;
    TU_OK(host->forces(sys, x, NULL, all, f));
    /* gradient: directional derivatives along fixed pseudo-random directions */
    unsigned long long seed = 7;
    const double eps = 1e-7;
    probe.grad_err = probe.grad_scale = 0.0;
    for (int k = 0; k < 6; ++k) {
        for (int64_t i = 0; i < n; ++i) u[i] = tu_rand(&seed);
        for (int64_t i = 0; i < n; ++i) xp[i] = x[i] + eps * u[i], xm[i] = x[i] - eps * u[i];
        const double ep = host->potential_energy(sys, xp), em = host->potential_energy(sys, xm);
        const double fd = (ep - em) / (2.0 * eps), an = -dot(f, u, (int)n);
        probe.grad_err = fmax(probe.grad_err, fabs(fd - an));
        probe.grad_scale = fmax(probe.grad_scale, fabs(an));
    }
    if (!probe.hessian) return DEFSIM_OK;
    /* Hessian of the one active pair: central differences of the forces, projected */
    const int m = 3 * probe.npair;
    double Hfd[144], Hp[144];
    int dof[12];
    for (int a = 0; a < probe.npair; ++a)
        for (int c = 0; c < 3; ++c) dof[3 * a + c] = 3 * probe.pair[a] + c;
    const double he = 1e-7;
    for (int j = 0; j < m; ++j) {
        memcpy(xp, x, (size_t)n * sizeof *x);
        memcpy(xm, x, (size_t)n * sizeof *x);
        xp[dof[j]] += he;
        xm[dof[j]] -= he;
        TU_OK(host->forces(sys, xp, NULL, all, fp));
        TU_OK(host->forces(sys, xm, NULL, all, fm));
        for (int i = 0; i < m; ++i) Hfd[i * m + j] = -(fp[dof[i]] - fm[dof[i]]) / (2.0 * he);
    }
    for (int i = 0; i < m; ++i)
        for (int j = 0; j < i; ++j)
            Hfd[i * m + j] = Hfd[j * m + i] = 0.5 * (Hfd[i * m + j] + Hfd[j * m + i]);
    /* the engine clamps the eigenvalues of the whole pair matrix (contact_pair.c) */
    project_psd(m, Hfd);
    const defsim_matrix_coeffs kc = {1.0, 0.0, 0.0, 0.0};
    probe.hess_err = probe.hess_scale = 0.0;
    for (int j = 0; j < m; ++j) {
        memset(u, 0, (size_t)n * sizeof *u);
        u[dof[j]] = 1.0;
        TU_OK(host->matrix_product(sys, x, &kc, u, fp));
        for (int i = 0; i < m; ++i) {
            Hp[i * m + j] = fp[dof[i]];
            probe.hess_err = fmax(probe.hess_err, fabs(Hp[i * m + j] - Hfd[i * m + j]));
            probe.hess_scale = fmax(probe.hess_scale, fabs(Hfd[i * m + j]));
        }
    }
    /* the sparse matrix: the pattern grows for the pair's blocks when the backend asks */
    const uint64_t v0 = host->matrix_pattern_version(sys);
    defsim_csc pat;
    TU_OK(host->matrix_pattern(sys, DEFSIM_TRIANGLE_FULL, &pat));
    (void)v0;
    double *vals = malloc((size_t)pat.nnz * sizeof *vals);
    assert_non_null(vals);
    TU_OK(host->matrix_values(sys, x, &kc, DEFSIM_TRIANGLE_FULL, vals));
    probe.values_err = 0.0;
    int found = 0;
    for (int j = 0; j < m; ++j)
        for (int64_t p = pat.col_ptr[dof[j]]; p < pat.col_ptr[dof[j] + 1]; ++p)
            for (int i = 0; i < m; ++i)
                if (pat.row_idx[p] == dof[i]) {
                    probe.values_err = fmax(probe.values_err, fabs(vals[p] - Hp[i * m + j]));
                    ++found;
                }
    probe.grew = found == m * m;   /* every block of the pair, off-diagonal ones included */
    /* matrix_values_projected with the world's own projection (clamp) is matrix_values, bit for
     * bit; a projection that does not exist is refused */
    double *vals2 = malloc((size_t)pat.nnz * sizeof *vals2);
    assert_non_null(vals2);
    TU_OK(host->matrix_values_projected(sys, x, &kc, DEFSIM_TRIANGLE_FULL,
                                        DEFSIM_PROJECTION_CLAMP, vals2));
    probe.projected_same = memcmp(vals, vals2, (size_t)pat.nnz * sizeof *vals) == 0;
    probe.projected_refused = host->matrix_values_projected(sys, x, &kc, DEFSIM_TRIANGLE_FULL, 7,
                                                            vals2) == DEFSIM_ERR_INVALID_ARGUMENT;
    free(vals2);
    free(vals);
    return DEFSIM_OK;
}

static const defsim_backend PROBE = {
    .abi_version = DEFSIM_BACKEND_ABI_VERSION, .struct_size = sizeof(defsim_backend),
    .name = "bc_probe", .flags = DEFSIM_BACKEND_CONTACT_CCD | DEFSIM_BACKEND_NEEDS_MATRIX,
    .init = probe_init, .step = probe_step, .fini = probe_fini};

static defsim_world *probe_world(void)
{
    static int registered = 0;
    if (!registered) TU_OK(defsim_register_backend(&PROBE));
    registered = 1;
    defsim_world *w = tu_world("bc_probe", 0.0, 1);
    TU_OK(defsim_world_set_option(w, "core.body_contact", "true"));
    TU_OK(defsim_world_set_option(w, "core.contact_dhat", "0.01"));
    return w;
}

/* A body of n vertices (1 kg each) with the given triangles or springs (k as given). */
static void add_raw(defsim_world *w, const double *x, int nv, const int32_t *tris, int nt,
                    const int32_t *springs, int ns, double k, double mu)
{
    defsim_body_def d;
    defsim_body_def_init(&d, sizeof d);
    defsim_material_init(&d.material, sizeof d.material, DEFSIM_MODEL_SPRING);
    d.material.stiffness = k;
    d.material.vertex_mass = 1.0;
    d.rest_positions = x;
    d.vertex_count = nv;
    d.triangles = tris;
    d.triangle_count = nt;
    d.springs = springs;
    d.spring_count = ns;
    d.friction = mu;
    if (defsim_world_add_body(w, &d, NULL) != DEFSIM_OK)
        fail_msg("add body: %s", defsim_world_last_error(w));
}

/* The dhat of a probe world whose rest positions span [lo, hi]. */
static double dhat_of(const double lo[3], const double hi[3])
{
    double d2 = 0.0;
    for (int k = 0; k < 3; ++k) d2 += (hi[k] - lo[k]) * (hi[k] - lo[k]);
    return 0.01 * sqrt(d2);
}

static void test_fd_point_triangle(void **state)
{
    (void)state;
    defsim_world *w = probe_world();
    const double lo[3] = {0, 0, 0}, hi[3] = {1, 1, 1}, dh = dhat_of(lo, hi);
    const double tri[9] = {0, 0, 0, 1, 0, 0, 0, 1, 0};
    const int32_t t[3] = {0, 1, 2};
    add_raw(w, tri, 3, t, 1, NULL, 0, 0.0, 0.0);
    /* a vertical rope over the triangle's interior, its lower end 0.4 dhat above it */
    const double rope[6] = {0.25, 0.2, 0.4 * dh, 0.25, 0.2, 1.0};
    const int32_t s[2] = {0, 1};
    add_raw(w, rope, 2, NULL, 0, s, 1, 0.0, 0.0);
    memset(&probe, 0, sizeof probe);
    /* evaluated off the start (a different distance, a tilted triangle) */
    probe.shift[3 * 3 + 0] = 0.1 * dh;
    probe.shift[3 * 3 + 2] = 0.2 * dh;
    probe.shift[3 * 1 + 2] = 0.1 * dh;
    probe.hessian = 1;
    probe.npair = 4;
    probe.pair[0] = 3, probe.pair[1] = 0, probe.pair[2] = 1, probe.pair[3] = 2;
    TU_OK(defsim_world_step(w, 0.01));
    printf("  point-triangle: |dE/du + f.u| %.3g of %.3g; |H - proj(H_fd)| %.3g of %.3g; "
           "sparse values vs product %.3g, all 16 blocks in the grown pattern: %d\n",
           probe.grad_err, probe.grad_scale, probe.hess_err, probe.hess_scale,
           probe.values_err, probe.grew);
    assert_true(probe.grad_scale > 0.0 && probe.grad_err < 1e-6 * probe.grad_scale);
    assert_true(probe.hess_scale > 0.0 && probe.hess_err < 1e-4 * probe.hess_scale);
    assert_true(probe.values_err <= 1e-12 * probe.hess_scale);
    assert_true(probe.grew);
    assert_true(probe.projected_same && probe.projected_refused);
    double g;
    TU_OK(defsim_world_stat(w, "contact.pattern_growths", &g));
    assert_true(g == 1.0);
    defsim_world_destroy(w);
}

/* Two ropes crossing 0.4 dhat apart (edge-edge), then a rope end over another rope's interior
 * (point-edge and edge-edge), with friction lagged from a start that the evaluation slides
 * away from: forces are -grad E. */
static void test_fd_edges_and_friction(void **state)
{
    (void)state;
    for (int cfg = 0; cfg < 3; ++cfg) {
        defsim_world *w = probe_world();
        const double lo[3] = {0, -0.5, 0}, hi[3] = {1, 0.5, 1}, dh = dhat_of(lo, hi);
        const double r1[6] = {0, 0, 0, 1, 0, 0};
        const double r2a[6] = {0.5, -0.5, 0.4 * dh, 0.5, 0.5, 0.4 * dh};
        const double r2b[6] = {0.5, 0.0, 0.4 * dh, 0.5, 0.0, 1.0};
        const int32_t s[2] = {0, 1};
        const double mu = cfg == 2 ? 0.5 : 0.0;
        add_raw(w, r1, 2, NULL, 0, s, 1, 0.0, mu);
        add_raw(w, cfg == 0 ? r2a : r2b, 2, NULL, 0, s, 1, 0.0, mu);
        memset(&probe, 0, sizeof probe);
        probe.shift[3 * 2 + 0] = 0.3 * dh;   /* slide and approach */
        probe.shift[3 * 2 + 2] = -0.1 * dh;
        probe.shift[3 * 0 + 1] = 0.05 * dh;
        TU_OK(defsim_world_step(w, 0.01));
        printf("  %s: |dE/du + f.u| %.3g of %.3g\n",
               cfg == 0 ? "edge-edge" : cfg == 1 ? "point-edge + edge-edge"
                                                 : "point-edge + edge-edge with friction",
               probe.grad_err, probe.grad_scale);
        assert_true(probe.grad_scale > 0.0 && probe.grad_err < 1e-6 * probe.grad_scale);
        double active;
        TU_OK(defsim_world_stat(w, "contact.body_active", &active));
        assert_true(active >= 1.0);
        defsim_world_destroy(w);
    }
}

/* ------------------------------------------------------------------------------------------ */
/* Boxes */

static defsim_body_id add_box(defsim_world *w, const double lo[3], const double hi[3], int n,
                              uint32_t group, uint32_t mask, int32_t **tets, int32_t *nt)
{
    defsim_mesh m = {.size = sizeof m};
    TU_OK(defsim_mesh_box(lo, hi, n, n, n, &m));
    defsim_body_def d;
    defsim_body_def_init(&d, sizeof d);
    d.rest_positions = m.positions;
    d.vertex_count = m.vertex_count;
    d.tets = m.tets;
    d.tet_count = m.tet_count;
    d.material.youngs_modulus = 1e5;
    d.material.poisson_ratio = 0.3;
    d.material.density = 100.0;
    d.material.mass_damping = 2.0;
    d.collision_group = group;
    d.collision_mask = mask;
    defsim_body_id id;
    TU_OK(defsim_world_add_body(w, &d, &id));
    if (tets) {
        const int32_t off = defsim_body_vertex_offset(w, id);
        *tets = malloc(4 * (size_t)m.tet_count * sizeof **tets);
        assert_non_null(*tets);
        for (int i = 0; i < 4 * m.tet_count; ++i) (*tets)[i] = m.tets[i] + off;
        *nt = m.tet_count;
    }
    defsim_mesh_free(&m);
    return id;
}

/* Vertices [v0, v1) strictly inside one of the tets (exact). */
static long inside(const double *x, int v0, int v1, const int32_t *tets, int nt)
{
    long n = 0;
    for (int v = v0; v < v1; ++v)
        for (int t = 0; t < nt; ++t) {
            const int32_t *q = tets + 4 * t;
            int out = 0;   /* outside the tet's bounding box: not inside (cheap) */
            for (int k = 0; k < 3 && !out; ++k) {
                const double a = x[3 * q[0] + k], b = x[3 * q[1] + k], c = x[3 * q[2] + k],
                             d = x[3 * q[3] + k], p = x[3 * v + k];
                out = p < fmin(fmin(a, b), fmin(c, d)) || p > fmax(fmax(a, b), fmax(c, d));
            }
            if (!out)
                n += eg_point_in_tet(x + 3 * v, x + 3 * q[0], x + 3 * q[1], x + 3 * q[2],
                                     x + 3 * q[3]);
        }
    return n;
}

/* A box whose bottom is pinned and a box on it pressed down by a force: they never
 * interpenetrate, body-body forces cancel and carry the load. Optionally a log counter. */
static int analyses;
static long long first_nnz, last_nnz;   /* nnz(A upper) of the first and the last analysis */

static void count_analyses(void *user, int level, const char *message)
{
    (void)user;
    (void)level;
    if (strstr(message, "CHOLMOD") == NULL && strstr(message, "nnz(L)")) {
        const char *p = strstr(message, "nnz(A upper) ");
        if (p) last_nnz = atoll(p + strlen("nnz(A upper) "));
        if (analyses++ == 0) first_nnz = last_nnz;
    }
}

/* A world (newton_cholmod, body contact on, analyses counted) with a unit box of 3 cells pinned
 * at its bottom and a second one above it, `gap` m higher and a little shifted. */
static defsim_world *stacked_boxes(double gap, int32_t **t0, int32_t *n0, int32_t **t1,
                                   int32_t *n1)
{
    defsim_world_def d = tu_world_def("newton_cholmod", -9.81, 1);
    d.log = count_analyses;
    analyses = 0;
    first_nnz = last_nnz = -1;
    defsim_world *w = tu_create(&d);
    TU_OK(defsim_world_set_option(w, "core.body_contact", "true"));
    const double lo0[3] = {0, 0, 0}, hi0[3] = {1, 1, 1}, lo1[3] = {0.1, 1.0 + gap, 0.05},
                 hi1[3] = {1.1, 2.0 + gap, 1.05};
    const defsim_body_id b0 = add_box(w, lo0, hi0, 3, 1u, ~0u, t0, n0);
    add_box(w, lo1, hi1, 3, 1u, ~0u, t1, n1);
    tu_pin_below(w, b0, 1, 0.0);
    return w;
}

/* The pattern keeps only what the contacts of the present use: a box lands on another (the
 * pattern grows for their pairs), then is lifted off by a force 3 times its weight; once no
 * pair is within dhat at a step's end, the pairs go and the matrix has the nonzeros of the two
 * separate boxes again (the backend analyses it once more: analyses > 1 + growths). */
static void test_pattern_released(void **state)
{
    (void)state;
    if (!tu_available("newton_cholmod")) return;
    int32_t *t0, *t1, n0, n1;
    defsim_world *w = stacked_boxes(0.01, &t0, &n0, &t1, &n1);
    const int nv = defsim_world_vertex_count(w), half = nv / 2;
    double *m = malloc((size_t)nv * sizeof *m), *fext = calloc(3 * (size_t)nv, sizeof *fext);
    assert_non_null(m);
    assert_non_null(fext);
    TU_OK(defsim_world_get_masses(w, m, nv));
    double grown = 0.0, active = 0.0;
    for (int s = 0; s < 160; ++s) {
        if (s == 60) {   /* lift: 3 times the top box's weight, upwards */
            for (int i = half; i < nv; ++i) fext[3 * i + 1] = 3.0 * 9.81 * m[i];
            TU_OK(defsim_world_set_external_forces(w, fext, nv));
            TU_OK(defsim_world_stat(w, "contact.pattern_growths", &grown));
            TU_OK(defsim_world_stat(w, "contact.body_active", &active));
        }
        if (defsim_world_step(w, 0.01) != DEFSIM_OK)
            fail_msg("step %d: %s", s, defsim_world_last_error(w));
    }
    double growths, active_end;
    TU_OK(defsim_world_stat(w, "contact.pattern_growths", &growths));
    TU_OK(defsim_world_stat(w, "contact.body_active", &active_end));
    double *x = tu_positions(w);
    double gap = INFINITY;
    for (int i = half; i < nv; ++i) gap = fmin(gap, x[3 * i + 1] - 1.0);
    free(x);
    printf("  pattern released: %g contacts before the lift, %g at the end (gap %.3g m); %g "
           "growths, %d analyses; nnz(A upper) %lld at the start, %lld at the last analysis\n",
           active, active_end, gap, growths, analyses, first_nnz, last_nnz);
    assert_true(active > 0.0 && grown >= 1.0);   /* the boxes touched, the pattern grew */
    assert_true(active_end == 0.0 && gap > 0.01);   /* and came apart */
    assert_true(analyses > 1 + (int)growths);       /* an analysis for the smaller pattern */
    assert_true(first_nnz > 0 && last_nnz == first_nnz);
    free(t0);
    free(t1);
    free(fext);
    free(m);
    defsim_world_destroy(w);
}

static void test_boxes_pressed(void **state)
{
    (void)state;
    if (!tu_available("newton_cholmod")) return;
    int32_t *t0, *t1, n0, n1;
    defsim_world *w = stacked_boxes(0.02, &t0, &n0, &t1, &n1);
    const int nv = defsim_world_vertex_count(w), half = nv / 2;
    /* 500 N down on the top box's top face, spread over its vertices there */
    double *fext = calloc(3 * (size_t)nv, sizeof *fext), *f = malloc(3 * (size_t)nv * sizeof *f);
    assert_non_null(fext);
    assert_non_null(f);
    int ntop = 0;
    for (int i = half; i < nv; ++i) ntop += 1;
    for (int i = half; i < nv; ++i) fext[3 * i + 1] = -500.0 / ntop;
    TU_OK(defsim_world_set_external_forces(w, fext, nv));
    const int steps = 200;
    double worst_sum = 0.0, load = 0.0;
    for (int s = 0; s < steps; ++s) {
        if (defsim_world_step(w, 0.01) != DEFSIM_OK)
            fail_msg("step %d: %s", s, defsim_world_last_error(w));
        double *x = tu_positions(w);
        const long in = inside(x, 0, half, t1, n1) + inside(x, half, nv, t0, n0);
        free(x);
        if (in) fail_msg("step %d: %ld vertices inside the other box", s, in);
        TU_OK(defsim_world_get_contact_forces(w, f, nv));
        double sum[3] = {0, 0, 0}, top = 0.0, mag = 0.0;
        for (int i = 0; i < nv; ++i)
            for (int k = 0; k < 3; ++k) {
                sum[k] += f[3 * i + k];
                mag = fmax(mag, fabs(f[3 * i + k]));
            }
        for (int i = half; i < nv; ++i) top += f[3 * i + 1];
        for (int k = 0; k < 3; ++k) worst_sum = fmax(worst_sum, fabs(sum[k]) / fmax(mag, 1e-300));
        load = top;
    }
    double mass[2] = {0, 0}, *m = malloc((size_t)nv * sizeof *m);
    assert_non_null(m);
    TU_OK(defsim_world_get_masses(w, m, nv));
    for (int i = half; i < nv; ++i) mass[1] += m[i];
    const double weight = mass[1] * 9.81 + 500.0;
    double growths, stepsd;
    TU_OK(defsim_world_stat(w, "contact.pattern_growths", &growths));
    TU_OK(defsim_world_stat(w, "steps", &stepsd));
    printf("  boxes pressed, %d steps: no vertex inside (exact); |sum of body-body forces| <= "
           "%.2g of the largest; the top box carried %.2f N of %.2f N (weight + push); %d "
           "CHOLMOD analyses = 1 + %g pattern growths in %g steps\n", steps, worst_sum, load,
           weight, analyses, growths, stepsd);
    assert_true(worst_sum < 1e-9);
    assert_true(fabs(load - weight) < 0.02 * weight);
    assert_true(growths >= 1.0 && growths <= 10.0);
    assert_true(analyses == 1 + (int)growths);
    free(t0);
    free(t1);
    free(fext);
    free(f);
    free(m);
    defsim_world_destroy(w);
}

/* An explicit backend refuses a step with body contact on: the status, a message naming the
 * backends that can, nothing changed; with it off the same world steps. */
static void test_explicit_refusal(void **state)
{
    (void)state;
    defsim_world *w = tu_world("symplectic_euler", -9.81, 1);
    const double lo[3] = {0, 0, 0}, hi[3] = {1, 1, 1};
    add_box(w, lo, hi, 1, 1u, ~0u, NULL, NULL);
    TU_OK(defsim_world_set_option(w, "core.body_contact", "true"));
    double *x0 = tu_positions(w), *v0 = tu_velocities(w);
    assert_int_equal(defsim_world_step(w, 1e-3), DEFSIM_ERR_UNSUPPORTED);
    assert_non_null(strstr(defsim_world_last_error(w), "newton_cholmod"));
    double *x1 = tu_positions(w), *v1 = tu_velocities(w);
    const int n = defsim_world_vertex_count(w);
    assert_memory_equal(x0, x1, 3 * (size_t)n * sizeof *x0);
    assert_memory_equal(v0, v1, 3 * (size_t)n * sizeof *v0);
    assert_true(defsim_world_time(w) == 0.0);
    TU_OK(defsim_world_set_option(w, "core.body_contact", "false"));
    TU_OK(defsim_world_step(w, 1e-3));
    free(x0); free(v0); free(x1); free(v1);
    defsim_world_destroy(w);
}

/* Groups, masks and self_contact decide which pairs exist (the candidates of a step). */
static double candidates(defsim_world *w)
{
    TU_OK(defsim_world_step(w, 0.01));
    double c;
    TU_OK(defsim_world_stat(w, "contact.body_candidates", &c));
    return c;
}

static void test_filters(void **state)
{
    (void)state;
    defsim_world *w = probe_world();
    /* two triangles of one body, 0.2 dhat apart (a folded cloth), and a third body's triangle */
    const double x[9 * 2] = {0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 0.002, 1, 0, 0.002, 0, 1, 0.002};
    const int32_t t[6] = {0, 1, 2, 3, 4, 5};
    add_raw(w, x, 6, t, 2, NULL, 0, 0.0, 0.0);
    const double far[9] = {5, 5, 5, 6, 5, 5, 5, 6, 5};
    add_raw(w, far, 3, t, 1, NULL, 0, 0.0, 0.0);
    defsim_body_id cloth, other;
    TU_OK(defsim_world_body_at(w, 0, &cloth));
    TU_OK(defsim_world_body_at(w, 1, &other));
    memset(&probe, 0, sizeof probe);
    const double self = candidates(w);
    TU_OK(defsim_body_set_collision(w, cloth, 0, 1u, ~0u));
    const double none = candidates(w);
    printf("  self_contact on: %g candidate pairs, off: %g\n", self, none);
    assert_true(self >= 15.0 && none == 0.0);   /* 3 + 3 PT, 9 EE at least */
    defsim_world_destroy(w);

    /* two bodies overlapping in x-y, 0.2 dhat apart in z: groups decide */
    const uint32_t g[4][4] = {{1u, ~0u, 1u, ~0u}, {1u, 1u, 2u, ~0u}, {1u, ~0u, 2u, ~1u},
                              {3u, 2u, 2u, 1u}};
    const int collide[4] = {1, 0, 0, 1};
    for (int k = 0; k < 4; ++k) {
        w = probe_world();
        add_raw(w, x, 3, t, 1, NULL, 0, 0.0, 0.0);
        add_raw(w, x + 9, 3, t, 1, NULL, 0, 0.0, 0.0);
        TU_OK(defsim_world_body_at(w, 0, &cloth));
        TU_OK(defsim_world_body_at(w, 1, &other));
        TU_OK(defsim_body_set_collision(w, cloth, 1, g[k][0], g[k][1]));
        TU_OK(defsim_body_set_collision(w, other, 1, g[k][2], g[k][3]));
        const double c = candidates(w);
        printf("  groups %u/%x and %u/%x: %g candidate pairs\n", g[k][0], g[k][1], g[k][2],
               g[k][3], c);
        assert_true(collide[k] ? c >= 15.0 : c == 0.0);
        defsim_world_destroy(w);
    }
}

/* Bad body contact fields: a clear status, nothing added. */
static void test_bad_defs(void **state)
{
    (void)state;
    defsim_world *w = tu_world("symplectic_euler", 0.0, 1);
    const double x[9] = {0, 0, 0, 1, 0, 0, 0, 1, 0};
    const int32_t bad[3] = {0, 1, 3}, rep[3] = {0, 1, 1}, good[3] = {0, 1, 2};
    defsim_body_def d;
    defsim_body_def_init(&d, sizeof d);
    assert_int_equal(d.self_contact, 1);
    assert_true(d.collision_group == 1u && d.collision_mask == 0xFFFFFFFFu && d.friction == 0.5);
    defsim_material_init(&d.material, sizeof d.material, DEFSIM_MODEL_SPRING);
    d.material.vertex_mass = 1.0;
    d.rest_positions = x;
    d.vertex_count = 3;
    d.triangle_count = 1;
    d.triangles = bad;
    assert_int_equal(defsim_world_add_body(w, &d, NULL), DEFSIM_ERR_INVALID_MESH);
    d.triangles = rep;
    assert_int_equal(defsim_world_add_body(w, &d, NULL), DEFSIM_ERR_INVALID_MESH);
    d.triangles = NULL;
    assert_int_equal(defsim_world_add_body(w, &d, NULL), DEFSIM_ERR_INVALID_ARGUMENT);
    d.triangles = good;
    d.self_contact = 2;
    assert_int_equal(defsim_world_add_body(w, &d, NULL), DEFSIM_ERR_INVALID_ARGUMENT);
    d.self_contact = 0;
    d.friction = -0.1;
    assert_int_equal(defsim_world_add_body(w, &d, NULL), DEFSIM_ERR_INVALID_MATERIAL);
    d.friction = NAN;
    assert_int_equal(defsim_world_add_body(w, &d, NULL), DEFSIM_ERR_INVALID_MATERIAL);
    assert_int_equal(defsim_world_body_count(w), 0);
    d.friction = 0.2;
    TU_OK(defsim_world_add_body(w, &d, NULL));
    assert_int_equal(defsim_world_body_count(w), 1);
    defsim_world_destroy(w);
}

/* The constraint set (IPC's merge): a rope's lower end 0.4 dhat above a flat 2 x 2-cell patch
 * (1 kg per vertex, no friction), over a triangle's interior, over the interior edge that two
 * triangles share, and over the interior vertex of six triangles. The pairs within dhat there
 * are 1 (point-triangle), 3 (two point-triangle, one edge-edge) and 13 (six point-triangle, six
 * edge-edge with the vertex's edges, the vertex against the rope's edge); they merge into one
 * face-vertex, one edge-vertex and one vertex-vertex contact, whose energy is the sum of the
 * pairs': n khat b(0.4 dhat), computed here from the barrier's formula. Moving the rope without
 * a step leaves the candidates' boxes: they are found again (one more broad phase) and the set
 * at the new point is the right one. */
static void test_constraint_set(void **state)
{
    (void)state;
    static const double P[3][2] = {{0.8, 0.1}, {0.75, 0.25}, {0.5, 0.5}};
    static const int expect_pairs[3] = {1, 3, 13};
    static const int expect_type[3] = {DEFSIM__C_FV, DEFSIM__C_EV, DEFSIM__C_VV};
    double patch[27];
    int32_t tris[24], nt = 0;
    for (int j = 0; j < 3; ++j)
        for (int i = 0; i < 3; ++i) {
            patch[3 * (3 * j + i)] = 0.5 * i;
            patch[3 * (3 * j + i) + 1] = 0.5 * j;
            patch[3 * (3 * j + i) + 2] = 0.0;
        }
    for (int j = 0; j < 2; ++j)
        for (int i = 0; i < 2; ++i) {
            const int32_t a = 3 * j + i, b = a + 1, c = a + 3, d = a + 4;
            const int32_t t[6] = {a, b, d, a, d, c};
            memcpy(tris + 3 * nt, t, sizeof t);
            nt += 2;
        }
    for (int cfg = 0; cfg < 3; ++cfg) {
        defsim_world *w = probe_world();
        const double lo[3] = {0, 0, 0}, hi[3] = {1, 1, 1}, dh = dhat_of(lo, hi);
        add_raw(w, patch, 9, tris, nt, NULL, 0, 0.0, 0.0);
        const double rope[6] = {P[cfg][0], P[cfg][1], 0.4 * dh, P[cfg][0], P[cfg][1], 1.0};
        const int32_t sp[2] = {0, 1};
        add_raw(w, rope, 2, NULL, 0, sp, 1, 0.0, 0.0);
        memset(&probe, 0, sizeof probe);
        TU_OK(defsim_world_step(w, 0.01));
        defsim__body_contact *bc = &w->body_contact;
        double *x = tu_positions(w);
        TU_OK(defsim__body_contact_build(bc, x));
        const double e = defsim__body_contact_energy(bc, x);
        const double want = expect_pairs[cfg] * bc->khat * barrier(0.4 * dh, dh);
        printf("  rope end over %s: %d contact(s) (VV %d, EV %d, FV %d, EE %d), kappa %.6g = %g "
               "khat; energy %.15g, %d pairs' %.15g\n",
               cfg == 0 ? "a face" : cfg == 1 ? "an edge" : "a vertex", (int)bc->ncon,
               (int)bc->ncon_type[DEFSIM__C_VV], (int)bc->ncon_type[DEFSIM__C_EV],
               (int)bc->ncon_type[DEFSIM__C_FV], (int)bc->ncon_type[DEFSIM__C_EE],
               bc->ncon ? bc->con[0].kappa : 0.0, bc->ncon ? bc->con[0].kappa / bc->khat : 0.0,
               e, expect_pairs[cfg], want);
        assert_int_equal(bc->ncon, 1);
        assert_int_equal(bc->con[0].type, expect_type[cfg]);
        assert_int_equal(bc->ncon_type[expect_type[cfg]], 1);
        assert_true(fabs(bc->con[0].kappa - expect_pairs[cfg] * bc->khat) <=
                    1e-14 * expect_pairs[cfg] * bc->khat);
        assert_true(want > 0.0 && fabs(e - want) <= 1e-12 * want);
        if (cfg == 2) {
            /* over the edge instead, without a step: outside the candidates' boxes */
            const int64_t broads = bc->broads;
            for (int v = 9; v < 11; ++v) {
                x[3 * v] = P[1][0];
                x[3 * v + 1] = P[1][1];
            }
            const double e2 = defsim__body_contact_energy(bc, x);
            const double want2 = expect_pairs[1] * bc->khat * barrier(0.4 * dh, dh);
            printf("  moved over the edge: %lld more broad phase, energy %.15g, want %.15g\n",
                   (long long)(bc->broads - broads), e2, want2);
            assert_true(bc->broads == broads + 1);
            assert_true(fabs(e2 - want2) <= 1e-12 * want2);
            assert_int_equal(bc->ncon_type[DEFSIM__C_EV], 1);
        }
        free(x);
        defsim_world_destroy(w);
    }
}

/* A checkpoint of a world with body contact continues bit for bit: the bodies' contact fields
 * (triangles, filter, friction) and the option come back. */
static void test_checkpoint(void **state)
{
    (void)state;
    if (!tu_available("newton_cholmod")) return;
    defsim_world *w = tu_world("newton_cholmod", -9.81, 1);
    TU_OK(defsim_world_set_option(w, "core.body_contact", "true"));
    const double lo0[3] = {0, 0, 0}, hi0[3] = {1, 1, 1}, lo1[3] = {0.2, 1.05, 0.1},
                 hi1[3] = {1.2, 2.05, 1.1};
    const defsim_body_id b0 = add_box(w, lo0, hi0, 2, 1u, ~0u, NULL, NULL);
    const defsim_body_id b1 = add_box(w, lo1, hi1, 2, 2u, 3u, NULL, NULL);
    tu_pin_below(w, b0, 1, 0.0);
    TU_OK(defsim_body_set_collision(w, b1, 0, 2u, 5u));
    for (int s = 0; s < 15; ++s) TU_OK(defsim_world_step(w, 0.01));
    void *buf = NULL;
    size_t size = 0;
    TU_OK(defsim_world_save_buffer(w, &buf, &size));
    defsim_world *r = NULL;
    TU_OK(defsim_world_load_buffer(buf, size, NULL, NULL, &r));
    defsim_buffer_free(buf);
    double on;
    TU_OK(defsim_world_get_option(r, "core.body_contact", &on));
    assert_true(on == 1.0);
    for (int s = 0; s < 25; ++s) {
        TU_OK(defsim_world_step(w, 0.01));
        TU_OK(defsim_world_step(r, 0.01));
    }
    const int n = defsim_world_vertex_count(w);
    double *xa = tu_positions(w), *xb = tu_positions(r);
    double ca, cb, ma, mb;
    TU_OK(defsim_world_stat(w, "contact.body_candidates", &ca));
    TU_OK(defsim_world_stat(r, "contact.body_candidates", &cb));
    TU_OK(defsim_world_stat(w, "contact.body_min_distance", &ma));
    TU_OK(defsim_world_stat(r, "contact.body_min_distance", &mb));
    printf("  checkpoint: %g candidates in both, min distance %.4g m, positions bit for bit\n",
           ca, ma);
    assert_true(ca > 0.0 && ca == cb && ma == mb);
    assert_memory_equal(xa, xb, 3 * (size_t)n * sizeof *xa);
    free(xa);
    free(xb);
    defsim_world_destroy(w);
    defsim_world_destroy(r);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_fd_point_triangle),
        cmocka_unit_test(test_fd_edges_and_friction),
        cmocka_unit_test(test_constraint_set),
        cmocka_unit_test(test_boxes_pressed),
        cmocka_unit_test(test_pattern_released),
        cmocka_unit_test(test_explicit_refusal),
        cmocka_unit_test(test_filters),
        cmocka_unit_test(test_bad_defs),
        cmocka_unit_test(test_checkpoint),
    };
    return tu_exit(cmocka_run_group_tests(tests, NULL, NULL));
}
