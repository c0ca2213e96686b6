/* SPDX-License-Identifier: MIT */
/*
 * Body-body and self-contact (issue 13), checked independently of the solver: intersections by
 * the exact predicates of tests/common/exact_geom.c (triangle-triangle, point-in-tet), distances
 * by this file's own closest-point code, never by the solver's statistics.
 *  - a cloth dropped upright onto the ground crumples onto itself: no two triangles that share
 *    no vertex intersect after any step, on newton_cholmod and newmark; the fold is real (the
 *    pile gets low, and triangles far apart on the cloth come within a few d_hat); a cloth that
 *    is flat only up to rounding starts and steps;
 *  - a soft cube dropped onto a cube resting on the ground: no vertex of one inside a tet of
 *    the other (and no boundary triangles crossing) after any step; it ends resting on it (the
 *    surfaces within a few d_hat, its weight carried through them);
 *  - three soft cubes stacked come to rest; the contact forces on each cube add up to its
 *    weight, the ground's to the total weight, and each interface carries what lies above it;
 *  - the cloth fold is bit-identical run twice and with 1, 2 and 3 threads (the parallel
 *    contact loops sum in a fixed order);
 *  - filtering: without self-contact the cloth passes through itself (the exact test finds it),
 *    cubes in groups that do not collide pass through each other, and collide again when
 *    defsim_body_set_collision says so; an explicit backend refuses body contact, state
 *    unchanged. Figures: docs/body-contact-bench.md.
 */
#include "test_util.h"

#include "clock.h"
#include "exact_geom.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static const double G = 9.81;

/* ------------------------------------------------------------------------------------------ */
/* Vectors (the distances, in plain double arithmetic, are exact_geom.h's; only compared against
 * d_hat-sized thresholds, far above their rounding) */

static double dot3(const double *a, const double *b)
{
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}

static void sub3(const double *a, const double *b, double *o)
{
    o[0] = a[0] - b[0], o[1] = a[1] - b[1], o[2] = a[2] - b[2];
}

/* ------------------------------------------------------------------------------------------ */
/* Surfaces and their pair scan */

/* Triangles in world vertex indices, the body (0, 1, ...) each belongs to, and their centroids
 * at rest (to tell a fold from neighbours on the cloth). */
typedef struct tri_set {
    int n;
    int32_t *v;
    int32_t *owner;
    double *rest_c;
} tri_set;

static void tri_set_add(tri_set *s, const int32_t *tri, int n, int32_t offset, int32_t owner,
                        const double *rest)
{
    s->v = realloc(s->v, 3 * (size_t)(s->n + n) * sizeof *s->v);
    s->owner = realloc(s->owner, (size_t)(s->n + n) * sizeof *s->owner);
    s->rest_c = realloc(s->rest_c, 3 * (size_t)(s->n + n) * sizeof *s->rest_c);
    assert_non_null(s->v);
    assert_non_null(s->owner);
    assert_non_null(s->rest_c);
    for (int t = 0; t < n; ++t) {
        const int k = s->n + t;
        for (int j = 0; j < 3; ++j) s->v[3 * k + j] = offset + tri[3 * t + j];
        s->owner[k] = owner;
        for (int c = 0; c < 3; ++c)
            s->rest_c[3 * k + c] = (rest[3 * tri[3 * t] + c] + rest[3 * tri[3 * t + 1] + c] +
                                    rest[3 * tri[3 * t + 2] + c]) / 3.0;
    }
    s->n += n;
}

static void tri_set_free(tri_set *s)
{
    free(s->v);
    free(s->owner);
    free(s->rest_c);
    memset(s, 0, sizeof *s);
}

typedef struct scan {
    long intersecting;     /* pairs sharing no vertex that share a point (exact test) */
    double min_distance;   /* smallest distance of the pairs within `margin` (m), inf if none */
    long close_far;        /* pairs closer than `close` whose rest centroids lie `far` apart */
    long tested;           /* pairs given to the exact test */
} scan;

typedef struct box {
    double lo[3], hi[3];
} box;

static const box *sort_boxes;

static int by_lo_x(const void *a, const void *b)
{
    const double x = sort_boxes[*(const int *)a].lo[0], y = sort_boxes[*(const int *)b].lo[0];
    return (x > y) - (x < y);
}

/* Every pair of triangles of s that share no vertex (only pairs of different owners when
 * `between`): the exact intersection test for the pairs whose boxes overlap, distances for those
 * whose boxes come within `margin`. Sweep and prune along x. */
static scan scan_pairs(const double *x, const tri_set *s, int between, double margin,
                       double close, double far)
{
    scan r = {0, INFINITY, 0, 0};
    box *bx = malloc((size_t)s->n * sizeof *bx);
    int *order = malloc((size_t)s->n * sizeof *order);
    assert_non_null(bx);
    assert_non_null(order);
    for (int t = 0; t < s->n; ++t) {
        for (int c = 0; c < 3; ++c) {
            bx[t].lo[c] = INFINITY, bx[t].hi[c] = -INFINITY;
            for (int j = 0; j < 3; ++j) {
                const double p = x[3 * s->v[3 * t + j] + c];
                bx[t].lo[c] = fmin(bx[t].lo[c], p);
                bx[t].hi[c] = fmax(bx[t].hi[c], p);
            }
        }
        order[t] = t;
    }
    sort_boxes = bx;
    qsort(order, (size_t)s->n, sizeof *order, by_lo_x);
    for (int a = 0; a < s->n; ++a) {
        const int i = order[a];
        for (int b = a + 1; b < s->n && bx[order[b]].lo[0] <= bx[i].hi[0] + margin; ++b) {
            const int j = order[b];
            if (between && s->owner[i] == s->owner[j]) continue;
            int overlap = 1, near = 1;
            for (int c = 0; c < 3; ++c) {
                overlap &= bx[i].lo[c] <= bx[j].hi[c] && bx[j].lo[c] <= bx[i].hi[c];
                near &= bx[i].lo[c] <= bx[j].hi[c] + margin && bx[j].lo[c] <= bx[i].hi[c] + margin;
            }
            if (!near) continue;
            int shared = 0;
            for (int p = 0; p < 3; ++p)
                for (int q = 0; q < 3; ++q) shared |= s->v[3 * i + p] == s->v[3 * j + q];
            if (shared) continue;
            const double *P[3] = {x + 3 * s->v[3 * i], x + 3 * s->v[3 * i + 1],
                                  x + 3 * s->v[3 * i + 2]};
            const double *Q[3] = {x + 3 * s->v[3 * j], x + 3 * s->v[3 * j + 1],
                                  x + 3 * s->v[3 * j + 2]};
            int hit = 0;
            if (overlap) {
                ++r.tested;
                hit = eg_tri_tri_intersect(P[0], P[1], P[2], Q[0], Q[1], Q[2]);
                r.intersecting += hit;
            }
            const double d = hit ? 0.0 : eg_tri_tri_gap(P[0], P[1], P[2], Q[0], Q[1], Q[2]);
            r.min_distance = fmin(r.min_distance, d);
            double dc[3];
            sub3(s->rest_c + 3 * i, s->rest_c + 3 * j, dc);
            if (d < close && dot3(dc, dc) > far * far) ++r.close_far;
        }
    }
    free(bx);
    free(order);
    return r;
}

/* Vertices of [va, va + nva) strictly inside one of the tets (world indices): exact. */
static long vertices_in_tets(const double *x, int32_t va, int32_t nva, const int32_t *tets,
                             int ntet)
{
    long n = 0;
    for (int t = 0; t < ntet; ++t) {
        const double *c[4] = {x + 3 * tets[4 * t], x + 3 * tets[4 * t + 1],
                              x + 3 * tets[4 * t + 2], x + 3 * tets[4 * t + 3]};
        double lo[3], hi[3];
        for (int k = 0; k < 3; ++k) {
            lo[k] = fmin(fmin(c[0][k], c[1][k]), fmin(c[2][k], c[3][k]));
            hi[k] = fmax(fmax(c[0][k], c[1][k]), fmax(c[2][k], c[3][k]));
        }
        for (int32_t i = va; i < va + nva; ++i) {
            const double *p = x + 3 * i;
            if (p[0] < lo[0] || p[0] > hi[0] || p[1] < lo[1] || p[1] > hi[1] || p[2] < lo[2] ||
                p[2] > hi[2])
                continue;
            n += eg_point_in_tet(p, c[0], c[1], c[2], c[3]);
        }
    }
    return n;
}

/* ------------------------------------------------------------------------------------------ */
/* Worlds */

static defsim_world *contact_world(const char *backend, int threads)
{
    defsim_world_def d = tu_world_def(backend, -G, threads);
    defsim_world *w = tu_create_or_skip(&d);
    if (!w) return NULL;
    TU_OK(defsim_world_set_option(w, "core.body_contact", "true"));
    /* an impact takes Newton up to ~40 iterations (docs/contact.md) */
    if (strcmp(backend, "symplectic_euler") != 0) {
        char name[64];
        snprintf(name, sizeof name, "%s.max_iterations", backend);
        TU_OK(defsim_world_set_option_number(w, name, 200));
    }
    return w;
}

/* A ground plane at height y (m), friction mu. */
static void add_ground(defsim_world *w, double y, double mu)
{
    defsim_collider_def cd;
    defsim_collider_def_init(&cd, sizeof cd);
    cd.position[1] = y;
    cd.friction = mu;
    TU_OK(defsim_world_add_collider(w, &cd, NULL));
}

/* d_hat (m): core.contact_dhat times the diagonal of the rest bounding box of all bodies. */
static double world_dhat(const defsim_world *w, const double *lo, const double *hi)
{
    double rel = NAN;
    TU_OK(defsim_world_get_option(w, "core.contact_dhat", &rel));
    const double d[3] = {hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]};
    return rel * sqrt(dot3(d, d));
}

static void grow_box(double *lo, double *hi, const double *p, int n)
{
    for (int i = 0; i < n; ++i)
        for (int k = 0; k < 3; ++k) {
            lo[k] = fmin(lo[k], p[3 * i + k]);
            hi[k] = fmax(hi[k], p[3 * i + k]);
        }
}

static void step_or_fail(defsim_world *w, double h, const char *what, int s)
{
    const defsim_status st = defsim_world_step(w, h);
    if (st != DEFSIM_OK)
        fail_msg("%s step %d: %s: %s", what, s, defsim_status_string(st),
                 defsim_world_last_error(w));
}

/* ------------------------------------------------------------------------------------------ */
/* The cloth fold */

/* A 0.5 m square cloth of nu x nu cells (springs of every kind, 0.1 kg) standing nearly upright
 * (along v, tilted towards +z) from the origin, its lower edge 5 cm above a ground plane at
 * y = -0.05 (mu 0.5), its triangles passed as its contact surface. It lands on its edge and
 * crumples onto itself. */
static const double CLOTH = 0.5, H_CLOTH = 0.01;
/* The fold's cloth: 12 x 12 cells, tilted 7 degrees by a v whose components differ by a power
 * of 2 (z = y / 8 exactly at every vertex), so that the flat start is coplanar in floating
 * point too (test_cloth_tilted_start starts from a cloth that is flat only up to rounding). */
enum { NU = 12 };
static const double V_FOLD[3] = {0.0, 0.5, 0.0625};

typedef struct cloth {
    defsim_world *w;
    defsim_body_id id;
    tri_set s;
    double dhat;
    int nv;
} cloth;

static int cloth_make(cloth *c, const char *backend, int threads, int self_contact, int nu,
                      const double v[3])
{
    memset(c, 0, sizeof *c);
    c->w = contact_world(backend, threads);
    if (!c->w) return 0;
    const double origin[3] = {-0.5 * CLOTH, 0.0, 0.0}, u[3] = {CLOTH, 0.0, 0.0};
    defsim_mesh m;
    memset(&m, 0, sizeof m);
    m.size = sizeof m;
    TU_OK(defsim_mesh_cloth(origin, u, v, nu, nu, &m));
    defsim_body_def bd = test_mesh_body(&m, DEFSIM_MODEL_SPRING);
    bd.spring_kinds = m.spring_kinds;
    bd.material.stiffness = 1000.0;
    bd.shear_stiffness = 200.0;
    bd.bend_stiffness = 2.0;
    bd.material.vertex_mass = 0.1 / m.vertex_count;
    bd.material.mass_damping = 0.5;
    bd.triangles = m.triangles;
    bd.triangle_count = m.triangle_count;
    bd.self_contact = self_contact;
    if (defsim_world_add_body(c->w, &bd, &c->id) != DEFSIM_OK)
        fail_msg("add cloth: %s", defsim_world_last_error(c->w));
    add_ground(c->w, -0.05, 0.5);
    double lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
    grow_box(lo, hi, m.positions, m.vertex_count);
    c->dhat = world_dhat(c->w, lo, hi);
    c->nv = m.vertex_count;
    tri_set_add(&c->s, m.triangles, m.triangle_count, 0, 0, m.positions);
    defsim_mesh_free(&m);
    return 1;
}

static void cloth_free(cloth *c)
{
    defsim_world_destroy(c->w);
    tri_set_free(&c->s);
}

/* Height of the cloth's bounding box (m). */
static double height(const double *x, int n)
{
    double lo = INFINITY, hi = -INFINITY;
    for (int i = 0; i < n; ++i) lo = fmin(lo, x[3 * i + 1]), hi = fmax(hi, x[3 * i + 1]);
    return hi - lo;
}

/* The fold for 1 s with steps of h: no two triangles that share no vertex intersect after any
 * step, and the fold happens: after some step at least 10 pairs of triangles that lie more than
 * 3 cells apart at rest are within 3 d_hat, and the pile gets lower than a quarter of the
 * cloth's length (newmark, without numerical damping, springs back up after the collapse:
 * 0.18 at its lowest, against 0.11 on newton_cholmod). */
static void cloth_fold(const char *backend, double h)
{
    cloth c;
    if (!cloth_make(&c, backend, 1, 1, NU, V_FOLD)) return;
    const int steps = (int)(1.0 / h + 0.5);
    const double far = 3.0 * CLOTH / NU;
    double min_d = INFINITY, hgt_most = NAN, lowest = INFINITY;
    long most = -1, tested = 0;
    const double t0 = defsim__now();
    double t_check = 0.0;
    for (int s = 0; s < steps; ++s) {
        step_or_fail(c.w, h, backend, s);
        const double t1 = defsim__now();
        double *x = tu_positions(c.w);
        const scan r = scan_pairs(x, &c.s, 0, 3.0 * c.dhat, 3.0 * c.dhat, far);
        if (r.close_far > most) most = r.close_far, hgt_most = height(x, c.nv);
        lowest = fmin(lowest, height(x, c.nv));
        free(x);
        t_check += defsim__now() - t1;
        if (r.intersecting)
            fail_msg("%s step %d: %ld non-adjacent triangle pairs intersect", backend, s,
                     r.intersecting);
        min_d = fmin(min_d, r.min_distance);
        tested += r.tested;
    }
    double *x = tu_positions(c.w);
    const double hgt = height(x, c.nv);
    const scan end = scan_pairs(x, &c.s, 0, 3.0 * c.dhat, 3.0 * c.dhat, far);
    free(x);
    const double it = tu_bstat(c.w, "newton_iterations");
    printf("  %-15s cloth %dx%d fold, %d steps of %g s: no intersecting pairs (%ld exact tests), "
           "min distance %.3g m = %.2f d_hat (d_hat %.3g m); pairs > 3 cells apart at rest within "
           "3 d_hat: most %ld (pile %.4f m then), %ld at the end (pile %.4f m); lowest pile %.4f m = "
           "%.3f of the length; %.0f Newton its, %.1f ms/step (checks %.1f ms/step)\n",
           backend, NU, NU, steps, h, tested, min_d, min_d / c.dhat, c.dhat, most, hgt_most,
           end.close_far, hgt, lowest, lowest / CLOTH, it, 1e3 * (defsim__now() - t0 - t_check) / steps,
           1e3 * t_check / steps);
    assert_true(most >= 10);
    assert_true(lowest < 0.25 * CLOTH);
    assert_true(min_d > 0.0);
    cloth_free(&c);
}

static void test_cloth_fold(void **state)
{
    (void)state;
    cloth_fold("newton_cholmod", H_CLOTH);
    /* the trapezoidal rule gains energy on the stiff barrier at larger steps (docs/contact.md):
     * at 0.01 s and 0.005 s Newton did not converge within 200 iterations */
    cloth_fold("newmark", 0.002);
}

/* A cloth tilted by 10 degrees (cos and sin in v) is flat only up to rounding: the start is
 * valid, and the first steps stay free of intersections. */
static void test_cloth_tilted_start(void **state)
{
    (void)state;
    const double tilt = 10.0 * 3.14159265358979323846 / 180.0;
    const double v[3] = {0.0, CLOTH * cos(tilt), CLOTH * sin(tilt)};
    cloth c;
    if (!cloth_make(&c, "newton_cholmod", 1, 1, 12, v)) return;
    for (int s = 0; s < 10; ++s) {
        step_or_fail(c.w, H_CLOTH, "tilted start", s);
        double *x = tu_positions(c.w);
        const scan r = scan_pairs(x, &c.s, 0, 0.0, 0.0, 0.0);
        free(x);
        assert_true(r.intersecting == 0);
    }
    cloth_free(&c);
}

/* Without self-contact the same cloth passes through itself: the checker finds it. */
static void test_cloth_no_self_contact(void **state)
{
    (void)state;
    cloth c;
    if (!cloth_make(&c, "newton_cholmod", 1, 0, NU, V_FOLD)) return;
    const int steps = (int)(1.0 / H_CLOTH + 0.5);
    int first = -1;
    long most = 0;
    for (int s = 0; s < steps && first < 0; ++s) {
        step_or_fail(c.w, H_CLOTH, "no self-contact", s);
        double *x = tu_positions(c.w);
        const scan r = scan_pairs(x, &c.s, 0, 0.0, 0.0, 0.0);
        free(x);
        if (r.intersecting) first = s, most = r.intersecting;
    }
    printf("  self_contact 0: first intersection after step %d (%ld pairs)\n", first, most);
    assert_true(first >= 0);
    cloth_free(&c);
}

/* The fold bit for bit: twice on one thread, once on two, three and sixteen (issue 30's 1, 2
 * and 16; body contact's per-contact loops run in parallel into per-contact slots and are
 * summed in the constraint set's order; CCD takes a minimum). Sixteen threads on a machine of
 * fewer cores run time-sliced: the same bits are owed all the same. */
static void test_cloth_deterministic(void **state)
{
    (void)state;
    enum { RUNS = 5 };
    const int steps = 50, threads[RUNS] = {1, 1, 2, 3, 16};
    double *x[RUNS] = {NULL}, *v[RUNS] = {NULL};
    int nv = 0;
    for (int r = 0; r < RUNS; ++r) {
        cloth c;
        if (!cloth_make(&c, "newton_cholmod", threads[r], 1, NU, V_FOLD)) return;
        for (int s = 0; s < steps; ++s) step_or_fail(c.w, H_CLOTH, "determinism", s);
        x[r] = tu_positions(c.w);
        v[r] = tu_velocities(c.w);
        nv = c.nv;
        if (r == 0) {
            const scan sc = scan_pairs(x[0], &c.s, 0, 3.0 * c.dhat, 3.0 * c.dhat, 0.0);
            printf("  determinism: after %d steps %ld pairs within 3 d_hat (contact is "
                   "active)\n", steps, sc.close_far);
            assert_true(sc.close_far > 0);
        }
        cloth_free(&c);
    }
    for (int r = 1; r < RUNS; ++r) {
        printf("  run %d (%d threads) vs run 0: max |dx| %.3g m\n", r, threads[r],
               tu_rel_diff(x[r], x[0], 3 * nv, 1.0));
        assert_memory_equal(x[r], x[0], 3 * (size_t)nv * sizeof(double));
        assert_memory_equal(v[r], v[0], 3 * (size_t)nv * sizeof(double));
    }
    for (int r = 0; r < RUNS; ++r) free(x[r]), free(v[r]);
}

/* ------------------------------------------------------------------------------------------ */
/* Soft cubes */

/* A cube body and its elements in world indices. */
typedef struct cube {
    defsim_body_id id;
    int32_t off, nv, ntet;
    int32_t *tets;
} cube;

static const double SIDE = 0.2, H_CUBE = 0.01;

/* A 2x2x2-cell stable neo-Hookean cube (E 2e5 Pa, 1000 kg/m^3, mass damping alpha) with its
 * lower corner at lo; its boundary triangles join s as body `owner`. */
static cube add_cube(defsim_world *w, const double lo[3], double alpha, uint32_t group,
                     uint32_t mask, tri_set *s, int owner, double *bb_lo, double *bb_hi)
{
    const double hi[3] = {lo[0] + SIDE, lo[1] + SIDE, lo[2] + SIDE};
    defsim_mesh m;
    memset(&m, 0, sizeof m);
    m.size = sizeof m;
    TU_OK(defsim_mesh_box(lo, hi, 2, 2, 2, &m));
    defsim_body_def bd = test_mesh_body(&m, DEFSIM_MODEL_STABLE_NEOHOOKEAN);
    bd.material.youngs_modulus = 2e5;
    bd.material.poisson_ratio = 0.3;
    bd.material.density = 1000.0;
    bd.material.mass_damping = alpha;
    bd.collision_group = group;
    bd.collision_mask = mask;
    cube c;
    if (defsim_world_add_body(w, &bd, &c.id) != DEFSIM_OK)
        fail_msg("add cube: %s", defsim_world_last_error(w));
    c.off = defsim_body_vertex_offset(w, c.id);
    c.nv = m.vertex_count;
    c.ntet = m.tet_count;
    c.tets = malloc(4 * (size_t)m.tet_count * sizeof *c.tets);
    assert_non_null(c.tets);
    for (int i = 0; i < 4 * m.tet_count; ++i) c.tets[i] = c.off + m.tets[i];
    tri_set_add(s, m.triangles, m.triangle_count, c.off, owner, m.positions);
    grow_box(bb_lo, bb_hi, m.positions, m.vertex_count);
    defsim_mesh_free(&m);
    return c;
}

/* Vertices of either cube inside a tet of the other (exact). */
static long cubes_overlap(const double *x, const cube *a, const cube *b)
{
    return vertices_in_tets(x, a->off, a->nv, b->tets, b->ntet) +
           vertices_in_tets(x, b->off, b->nv, a->tets, a->ntet);
}

/* Mean height of a cube's vertices (m). */
static double cube_mid_y(const double *x, const cube *c)
{
    double m = 0.0;
    for (int i = c->off; i < c->off + c->nv; ++i) m += x[3 * i + 1];
    return m / c->nv;
}

/* The lowest vertex of cube c over the footprint (x-z bounds) of cube `under` and its distance
 * to the triangles of s owned by `owner` (m); parts hanging over the edge are not resting. */
static double lowest_vertex_distance(const double *x, const cube *c, const cube *under,
                                     const tri_set *s, int owner)
{
    double lo[2] = {INFINITY, INFINITY}, hi[2] = {-INFINITY, -INFINITY};
    for (int32_t i = under->off; i < under->off + under->nv; ++i)
        for (int k = 0; k < 2; ++k) {
            lo[k] = fmin(lo[k], x[3 * i + 2 * k]);
            hi[k] = fmax(hi[k], x[3 * i + 2 * k]);
        }
    int32_t low = -1;
    for (int32_t i = c->off; i < c->off + c->nv; ++i) {
        const double *p = x + 3 * i;
        if (p[0] < lo[0] || p[0] > hi[0] || p[2] < lo[1] || p[2] > hi[1]) continue;
        if (low < 0 || p[1] < x[3 * low + 1]) low = i;
    }
    assert_true(low >= 0);
    double d = INFINITY;
    for (int t = 0; t < s->n; ++t)
        if (s->owner[t] == owner)
            d = fmin(d, eg_point_tri_distance(x + 3 * low, x + 3 * s->v[3 * t],
                                              x + 3 * s->v[3 * t + 1], x + 3 * s->v[3 * t + 2]));
    return d;
}

/* Sum of the contact forces on a cube's vertices (N) and its weight (N). */
static void cube_load(const defsim_world *w, const cube *c, double f_sum[3], double *weight)
{
    const int n = defsim_world_vertex_count(w);
    double *f = malloc(3 * (size_t)n * sizeof *f), *m = malloc((size_t)n * sizeof *m);
    assert_non_null(f);
    assert_non_null(m);
    TU_OK(defsim_world_get_contact_forces(w, f, n));
    TU_OK(defsim_world_get_masses(w, m, n));
    f_sum[0] = f_sum[1] = f_sum[2] = *weight = 0.0;
    for (int i = c->off; i < c->off + c->nv; ++i) {
        for (int k = 0; k < 3; ++k) f_sum[k] += f[3 * i + k];
        *weight += m[i] * G;
    }
    free(f);
    free(m);
}

/* A cube resting on the ground (2 mm above it at the start) and one dropped from 10 cm above it,
 * shifted by (3, 2) cm. Returns the world (NULL: backend missing). */
static defsim_world *two_cubes(const char *backend, uint32_t top_group, uint32_t top_mask,
                               cube *bottom, cube *top, tri_set *s, double *dhat)
{
    defsim_world *w = contact_world(backend, 1);
    if (!w) return NULL;
    double lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
    const double b0[3] = {-0.1, 0.002, -0.1}, t0[3] = {-0.07, 0.302, -0.08};
    *bottom = add_cube(w, b0, 5.0, 1u, 0xFFFFFFFFu, s, 0, lo, hi);
    *top = add_cube(w, t0, 5.0, top_group, top_mask, s, 1, lo, hi);
    add_ground(w, 0.0, 0.5);
    *dhat = world_dhat(w, lo, hi);
    return w;
}

static void test_cube_on_cube(void **state)
{
    (void)state;
    cube b, t;
    tri_set s = {0};
    double dhat;
    defsim_world *w = two_cubes("newton_cholmod", 1u, 0xFFFFFFFFu, &b, &t, &s, &dhat);
    if (!w) return;
    const int steps = (int)(1.5 / H_CUBE + 0.5);
    double min_d = INFINITY;
    for (int k = 0; k < steps; ++k) {
        step_or_fail(w, H_CUBE, "cube on cube", k);
        double *x = tu_positions(w);
        const long inside = cubes_overlap(x, &b, &t);
        const scan r = scan_pairs(x, &s, 1, 3.0 * dhat, 0.0, 0.0);
        free(x);
        if (inside || r.intersecting)
            fail_msg("step %d: %ld vertices inside a tet of the other cube, %ld boundary "
                     "triangle pairs intersecting", k, inside, r.intersecting);
        min_d = fmin(min_d, r.min_distance);
    }
    double *x = tu_positions(w), *v = tu_velocities(w);
    const scan end = scan_pairs(x, &s, 1, 3.0 * dhat, 0.0, 0.0);
    const double low = lowest_vertex_distance(x, &t, &b, &s, 0);
    double vmax = 0.0, f[3], weight;
    for (int i = 0; i < 3 * defsim_world_vertex_count(w); ++i) vmax = fmax(vmax, fabs(v[i]));
    cube_load(w, &t, f, &weight);
    printf("  cube on cube, %d steps: no vertex inside, no boundary triangles crossing; min "
           "distance %.3g m = %.2f d_hat over the run, %.3g m = %.2f d_hat at the end (d_hat "
           "%.3g m); the top cube's lowest vertex over the bottom one %.3g m = %.2f d_hat from the bottom cube; "
           "contact force on the top cube %.6g N up, its weight %.6g N; max |v| %.3g m/s\n",
           steps, min_d, min_d / dhat, end.min_distance, end.min_distance / dhat, dhat, low,
           low / dhat, f[1], weight, vmax);
    /* resting on it: the surfaces within a few d_hat, the weight carried through them */
    assert_true(end.min_distance > 0.0 && end.min_distance < 2.0 * dhat);
    assert_true(low < 3.0 * dhat);
    assert_true(fabs(f[1] / weight - 1.0) <= 0.01);
    assert_true(vmax < 0.01);
    free(x);
    free(v);
    free(b.tets);
    free(t.tets);
    tri_set_free(&s);
    defsim_world_destroy(w);
}

/* Cubes whose groups do not collide pass through each other: the exact test sees a vertex
 * inside; the setter turns the same pair back into colliding ones. */
static void test_cube_groups(void **state)
{
    (void)state;
    for (int setter = 0; setter < 2; ++setter) {
        cube b, t;
        tri_set s = {0};
        double dhat;
        /* top: group 2, mask without group 1 (the bottom's) */
        defsim_world *w = two_cubes("newton_cholmod", 2u, ~1u, &b, &t, &s, &dhat);
        if (!w) return;
        if (setter) TU_OK(defsim_body_set_collision(w, t.id, 1, 2u, 0xFFFFFFFFu));
        const int steps = (int)(0.6 / H_CUBE + 0.5);
        long most = 0;
        for (int k = 0; k < steps; ++k) {
            step_or_fail(w, H_CUBE, "groups", k);
            double *x = tu_positions(w);
            const long inside = cubes_overlap(x, &b, &t);
            free(x);
            most = inside > most ? inside : most;
        }
        double *x = tu_positions(w);
        const double rise = cube_mid_y(x, &t) - cube_mid_y(x, &b);
        free(x);
        printf("  groups %s: most vertices inside the other cube %ld, top cube's mean height "
               "above the bottom one's %.4g m\n", setter ? "set to collide by "
               "defsim_body_set_collision" : "not colliding", most, rise);
        /* on top of it (about one side higher), or through it down to the ground beside it */
        if (setter) {
            assert_true(most == 0);
            assert_true(rise > 0.9 * SIDE);
        } else {
            assert_true(most > 0);
            assert_true(fabs(rise) < 0.1 * SIDE);
        }
        free(b.tets);
        free(t.tets);
        tri_set_free(&s);
        defsim_world_destroy(w);
    }
}

/* Three cubes stacked 5 mm apart (shifted sideways by 2 cm each) come to rest on the ground. */
static void test_stack(void **state)
{
    (void)state;
    defsim_world *w = contact_world("newton_cholmod", 1);
    if (!w) return;
    cube c[3];
    tri_set s = {0};
    double lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
    for (int k = 0; k < 3; ++k) {
        const double at[3] = {-0.1 + 0.02 * k, 0.005 + k * (SIDE + 0.005), -0.1 - 0.01 * k};
        c[k] = add_cube(w, at, 10.0, 1u, 0xFFFFFFFFu, &s, k, lo, hi);
    }
    add_ground(w, 0.0, 0.5);
    const double dhat = world_dhat(w, lo, hi);
    const int n = defsim_world_vertex_count(w), steps = (int)(3.0 / H_CUBE + 0.5);
    for (int k = 0; k < steps; ++k) {
        step_or_fail(w, H_CUBE, "stack", k);
        double *x = tu_positions(w);
        long inside = 0;
        for (int a = 0; a < 3; ++a)
            for (int b = a + 1; b < 3; ++b) inside += cubes_overlap(x, &c[a], &c[b]);
        free(x);
        if (inside) fail_msg("stack step %d: %ld vertices inside another cube", k, inside);
    }
    double *x = tu_positions(w), *v = tu_velocities(w), *m = malloc((size_t)n * sizeof *m);
    double *f = malloc(3 * (size_t)n * sizeof *f);
    assert_non_null(m);
    assert_non_null(f);
    TU_OK(defsim_world_get_masses(w, m, n));
    TU_OK(defsim_world_get_contact_forces(w, f, n));
    double vmax = 0.0;
    for (int i = 0; i < 3 * n; ++i) vmax = fmax(vmax, fabs(v[i]));
    double weight[3], total = 0.0;
    for (int k = 0; k < 3; ++k) {
        weight[k] = 0.0;
        for (int i = c[k].off; i < c[k].off + c[k].nv; ++i) weight[k] += m[i] * G;
        total += weight[k];
    }
    printf("  stack of 3 cubes after %d steps: max |v| %.3g m/s (d_hat %.3g m)\n", steps, vmax,
           dhat);
    /* each cube: net contact force = its weight; below its mid-height the load of the cubes
     * above plus its own, above its mid-height minus the load of those above */
    double above = 0.0;
    for (int k = 2; k >= 0; --k) {
        double net[3] = {0, 0, 0}, lower = 0.0, upper = 0.0;
        const double mid = cube_mid_y(x, &c[k]);
        for (int i = c[k].off; i < c[k].off + c[k].nv; ++i) {
            for (int j = 0; j < 3; ++j) net[j] += f[3 * i + j];
            if (x[3 * i + 1] < mid) lower += f[3 * i + 1];
            else upper += f[3 * i + 1];
        }
        printf("  cube %d: contact force (%.4g, %.6g, %.4g) N, weight %.6g N (ratio %.5f); "
               "lower half %.6g N (load %.6g), upper half %.6g N (load %.6g)\n", k, net[0],
               net[1], net[2], weight[k], net[1] / weight[k], lower, weight[k] + above, upper,
               -above);
        assert_true(fabs(net[1] / weight[k] - 1.0) <= 0.01);
        assert_true(fabs(net[0]) <= 0.01 * weight[k] && fabs(net[2]) <= 0.01 * weight[k]);
        assert_true(fabs(lower - (weight[k] + above)) <= 0.01 * (weight[k] + above));
        assert_true(fabs(upper + above) <= 0.01 * (weight[k] + above));
        above += weight[k];
    }
    /* the ground's share: what the bottom cube's lower half receives (the second cube does not
     * reach it) */
    double ground = 0.0;
    for (int i = c[0].off; i < c[0].off + c[0].nv; ++i)
        if (x[3 * i + 1] < 0.5 * SIDE) ground += f[3 * i + 1];
    printf("  ground: %.6g N, total weight %.6g N (ratio %.5f)\n", ground, total, ground / total);
    assert_true(fabs(ground / total - 1.0) <= 0.01);
    assert_true(vmax < 1e-3);
    free(x);
    free(v);
    free(m);
    free(f);
    for (int k = 0; k < 3; ++k) free(c[k].tets);
    tri_set_free(&s);
    defsim_world_destroy(w);
}

/* An explicit backend refuses body contact (documented refusal), the state unchanged; with the
 * option off the same world steps. */
static void test_explicit_refuses(void **state)
{
    (void)state;
    defsim_world *w = contact_world("symplectic_euler", 1);
    assert_non_null(w);
    tri_set s = {0};
    double lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
    const double at[3] = {-0.1, 0.01, -0.1};
    cube c = add_cube(w, at, 0.0, 1u, 0xFFFFFFFFu, &s, 0, lo, hi);
    add_ground(w, 0.0, 0.5);
    const int n = defsim_world_vertex_count(w);
    double *x0 = tu_positions(w), *v0 = tu_velocities(w);
    const double t0 = defsim_world_time(w);
    assert_int_equal(defsim_world_step(w, 1e-4), DEFSIM_ERR_UNSUPPORTED);
    double *x1 = tu_positions(w), *v1 = tu_velocities(w);
    assert_memory_equal(x0, x1, 3 * (size_t)n * sizeof(double));
    assert_memory_equal(v0, v1, 3 * (size_t)n * sizeof(double));
    assert_true(defsim_world_time(w) == t0);
    printf("  symplectic_euler with body_contact: %s (\"%s\")\n",
           defsim_status_string(DEFSIM_ERR_UNSUPPORTED), defsim_world_last_error(w));
    TU_OK(defsim_world_set_option(w, "core.body_contact", "false"));
    TU_OK(defsim_world_step(w, 1e-4));
    free(x0);
    free(v0);
    free(x1);
    free(v1);
    free(c.tets);
    tri_set_free(&s);
    defsim_world_destroy(w);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_explicit_refuses),
        cmocka_unit_test(test_cube_on_cube),
        cmocka_unit_test(test_cube_groups),
        cmocka_unit_test(test_stack),
        cmocka_unit_test(test_cloth_tilted_start),
        cmocka_unit_test(test_cloth_fold),
        cmocka_unit_test(test_cloth_no_self_contact),
        cmocka_unit_test(test_cloth_deterministic),
    };
    return tu_exit(cmocka_run_group_tests(tests, NULL, NULL));
}
