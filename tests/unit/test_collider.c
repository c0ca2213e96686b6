/* SPDX-License-Identifier: MIT */
/*
 * Collider geometry (collider_shape.c, collider_mesh.c) and the collider API's bad input:
 * distances against closed forms and brute force, gradients and Hessians against finite
 * differences in every region of every shape at rotated poses, the sign of meshes, bounds that
 * contain the shape, times of impact checked by sampling the segment, poses along a step.
 */
#include "test_util.h"

#include "collider.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

/* |a - b| <= tol in double precision (cmocka's assert_float_equal compares floats). */
#define NEAR(a, b, tol) near_((a), (b), (tol), #a, __LINE__)
static void near_(double a, double b, double tol, const char *what, int line)
{
    if (!(fabs(a - b) <= tol)) fail_msg("line %d: %s = %.17g, expected %.17g within %g", line, what, a, b, tol);
}

static unsigned long long seed = 12345;
static double rnd(void) { return tu_rand(&seed); }            /* [-1, 1) */
static double rnd01(void) { return 0.5 * (tu_rand(&seed) + 1.0); }

static void rand_quat(double q[4])
{
    double n = 0.0;
    do {
        n = 0.0;
        for (int k = 0; k < 4; ++k) { q[k] = rnd(); n += q[k] * q[k]; }
    } while (n < 0.1 || n > 1.0);
    n = sqrt(n);
    for (int k = 0; k < 4; ++k) q[k] /= n;
}

static void rand_dir(double u[3])
{
    double n;
    do {
        n = 0.0;
        for (int k = 0; k < 3; ++k) { u[k] = rnd(); n += u[k] * u[k]; }
    } while (n < 0.05 || n > 1.0);
    n = sqrt(n);
    for (int k = 0; k < 3; ++k) u[k] /= n;
}

/* A collider made from def at a random pose (rotation and position); fails the test on error. */
static defsim__collider make(defsim_collider_def *d, defsim__pose *pose)
{
    rand_quat(d->rotation);
    for (int k = 0; k < 3; ++k) d->position[k] = rnd();
    defsim__messages msg;
    memset(&msg, 0, sizeof msg);
    defsim__collider c;
    const defsim_status st = defsim__collider_make(&msg, d, &c);
    if (st != DEFSIM_OK) print_error("%s\n", msg.error);
    assert_int_equal(st, DEFSIM_OK);
    defsim__pose_set(pose, c.pos, c.rot);
    return c;
}

static void to_world(const defsim__pose *pose, const double l[3], double p[3])
{
    for (int i = 0; i < 3; ++i)
        p[i] = pose->p[i] + pose->R[3 * i] * l[0] + pose->R[3 * i + 1] * l[1] +
               pose->R[3 * i + 2] * l[2];
}

static double dist(const defsim__collider *c, const defsim__pose *pose, const double p[3],
                   double g[3], double h[9])
{
    double d, gg[3];
    assert_int_equal(defsim__collider_distance(c, pose, p, &d, g ? g : gg, h), DEFSIM_OK);
    return d;
}

/* Checks at world point p: the distance against `expect` (unless NAN), |grad| = 1, and the
 * gradient and Hessian against central differences of the distance and of the gradient. */
static void check_point(const defsim__collider *c, const defsim__pose *pose, const double p[3],
                        double expect, double tol_h)
{
    double g[3], h[9];
    const double d = dist(c, pose, p, g, h);
    if (!isnan(expect)) NEAR(d, expect, 1e-12 * (1.0 + fabs(expect)));
    NEAR(g[0] * g[0] + g[1] * g[1] + g[2] * g[2], 1.0, 1e-12);
    const double eps = 1e-6;
    double hmax = 0.0;
    for (int k = 0; k < 9; ++k) hmax = fmax(hmax, fabs(h[k]));
    for (int j = 0; j < 3; ++j) {
        double a[3], b[3], ga[3], gb[3];
        memcpy(a, p, sizeof a);
        memcpy(b, p, sizeof b);
        a[j] += eps;
        b[j] -= eps;
        const double da = dist(c, pose, a, ga, NULL), db = dist(c, pose, b, gb, NULL);
        NEAR((da - db) / (2 * eps), g[j], 1e-7);
        for (int i = 0; i < 3; ++i)
            NEAR((ga[i] - gb[i]) / (2 * eps), h[3 * i + j], tol_h * (1.0 + hmax));
    }
    for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j) NEAR(h[3 * i + j], h[3 * j + i], 1e-12 * (1 + hmax));
}

static void test_plane_sphere(void **state)
{
    (void)state;
    defsim_collider_def d;
    defsim_collider_def_init(&d, sizeof d);
    d.normal[0] = 0.3; d.normal[1] = 2.0; d.normal[2] = -0.4;
    defsim__pose pose;
    defsim__collider c = make(&d, &pose);
    for (int i = 0; i < 100; ++i) {
        const double l[3] = {3 * rnd(), 3 * rnd(), 3 * rnd()};
        double p[3];
        to_world(&pose, l, p);
        const double n = sqrt(0.09 + 4.0 + 0.16);
        check_point(&c, &pose, p, (0.3 * l[0] + 2.0 * l[1] - 0.4 * l[2]) / n, 1e-6);
    }
    defsim__collider_free(&c);

    defsim_collider_def_init(&d, sizeof d);
    d.shape = DEFSIM_SHAPE_SPHERE;
    d.radius = 0.4;
    c = make(&d, &pose);
    for (int i = 0; i < 200; ++i) {
        double u[3], l[3], p[3];
        rand_dir(u);
        const double r = 0.05 + 2.0 * rnd01();   /* inside and outside */
        for (int k = 0; k < 3; ++k) l[k] = r * u[k];
        to_world(&pose, l, p);
        check_point(&c, &pose, p, r - 0.4, 1e-6);
    }
    defsim__collider_free(&c);
}

/* Box: points built in each region with a margin of 0.01 from the region's borders. */
static void test_box(void **state)
{
    (void)state;
    defsim_collider_def d;
    defsim_collider_def_init(&d, sizeof d);
    d.shape = DEFSIM_SHAPE_BOX;
    const double e[3] = {0.3, 0.5, 0.7};
    memcpy(d.half_extents, e, sizeof e);
    defsim__pose pose;
    defsim__collider c = make(&d, &pose);
    for (int region = 1; region <= 4; ++region) {   /* faces, edges, corners (outside axes); inside */
        for (int i = 0; i < 100; ++i) {
            double l[3], expect = 0.0;
            if (region <= 3) {
                int out[3] = {0, 0, 0};
                for (int n = 0; n < region;) {
                    const int k = (int)(3 * rnd01()) % 3;
                    if (!out[k]) { out[k] = 1; ++n; }
                }
                for (int k = 0; k < 3; ++k) {
                    const double s = rnd() < 0 ? -1.0 : 1.0;
                    if (out[k]) {
                        const double a = 0.01 + rnd01();
                        l[k] = s * (e[k] + a);
                        expect += a * a;
                    } else {
                        l[k] = 0.98 * e[k] * rnd();
                    }
                }
                expect = sqrt(expect);
            } else {
                /* inside, the nearest face m clearly nearer than the others */
                const int m = (int)(3 * rnd01()) % 3;
                const double a = 0.02 + 0.25 * rnd01();   /* depth below face m; < 0.29 */
                for (int k = 0; k < 3; ++k) {
                    const double s = rnd() < 0 ? -1.0 : 1.0;
                    l[k] = k == m ? s * (e[k] - a) : s * (e[k] - a - 0.01) * rnd01();
                }
                expect = -a;
            }
            double p[3];
            to_world(&pose, l, p);
            check_point(&c, &pose, p, expect, 1e-6);
        }
    }
    defsim__collider_free(&c);
}

static void test_capsule(void **state)
{
    (void)state;
    defsim_collider_def d;
    defsim_collider_def_init(&d, sizeof d);
    d.shape = DEFSIM_SHAPE_CAPSULE;
    d.radius = 0.25;
    d.half_height = 0.6;
    defsim__pose pose;
    defsim__collider c = make(&d, &pose);
    for (int i = 0; i < 300; ++i) {
        const double rho = 0.02 + 1.5 * rnd01();
        double l[3];
        if (i % 2) {   /* beside the segment */
            const double phi = 3.14159 * rnd();
            l[0] = rho * cos(phi); l[2] = rho * sin(phi);
            l[1] = 0.58 * rnd();
        } else {       /* beyond an end */
            double u[3];
            rand_dir(u);
            if (fabs(u[1]) < 0.05) continue;
            const double s = u[1] < 0 ? -1.0 : 1.0;
            for (int k = 0; k < 3; ++k) l[k] = rho * u[k];
            l[1] += s * 0.6;
        }
        double p[3];
        to_world(&pose, l, p);
        check_point(&c, &pose, p, rho - 0.25, 1e-6);
    }
    defsim__collider_free(&c);
}

/* ------------------------------------------------------------------------------------------ */
/* Meshes */

typedef struct tmesh {
    int nv, nt;
    double *x;
    int32_t *t;
} tmesh;

static void tmesh_free(tmesh *m) { free(m->x); free(m->t); }

/* The cube [-0.5, 0.5]^3, 12 outward triangles. */
static tmesh cube_mesh(void)
{
    static const int32_t T[36] = {0, 2, 1, 0, 3, 2, 4, 5, 6, 4, 6, 7, 0, 1, 5, 0, 5, 4,
                                  2, 3, 7, 2, 7, 6, 1, 2, 6, 1, 6, 5, 0, 4, 7, 0, 7, 3};
    tmesh m = {8, 12, malloc(24 * sizeof(double)), malloc(36 * sizeof(int32_t))};
    for (int i = 0; i < 8; ++i) {
        const int b[3] = {(i == 1 || i == 2 || i == 5 || i == 6), (i == 2 || i == 3 || i == 6 || i == 7), i >= 4};
        for (int k = 0; k < 3; ++k) m.x[3 * i + k] = b[k] - 0.5;
    }
    memcpy(m.t, T, sizeof T);
    return m;
}

/* A UV sphere of radius r: nu around y, nv rings; outward. */
static tmesh sphere_mesh(double r, int nu, int nr)
{
    tmesh m = {2 + nu * (nr - 1), 2 * nu * (nr - 1), NULL, NULL};
    m.x = malloc(3 * (size_t)m.nv * sizeof *m.x);
    m.t = malloc(3 * (size_t)m.nt * sizeof *m.t);
    m.x[0] = 0; m.x[1] = r; m.x[2] = 0;
    m.x[3] = 0; m.x[4] = -r; m.x[5] = 0;
    for (int i = 1; i < nr; ++i)
        for (int j = 0; j < nu; ++j) {
            const double th = 3.141592653589793 * i / nr, ph = 2 * 3.141592653589793 * j / nu;
            double *p = m.x + 3 * (2 + (i - 1) * nu + j);
            p[0] = r * sin(th) * cos(ph); p[1] = r * cos(th); p[2] = -r * sin(th) * sin(ph);
        }
    int32_t *t = m.t;
#define V(i, j) (2 + ((i) - 1) * nu + ((j) % nu))
    for (int j = 0; j < nu; ++j) {
        *t++ = 0; *t++ = V(1, j); *t++ = V(1, j + 1);
        *t++ = 1; *t++ = V(nr - 1, j + 1); *t++ = V(nr - 1, j);
    }
    for (int i = 1; i < nr - 1; ++i)
        for (int j = 0; j < nu; ++j) {
            *t++ = V(i, j); *t++ = V(i + 1, j); *t++ = V(i + 1, j + 1);
            *t++ = V(i, j); *t++ = V(i + 1, j + 1); *t++ = V(i, j + 1);
        }
#undef V
    return m;
}

/* An open height field y = 0.15 sin(3x) cos(2z) over [0, 1]^2, n x n cells, normals up. */
static double height(double x, double z) { return 0.15 * sin(3 * x) * cos(2 * z); }
static tmesh open_mesh(int n)
{
    tmesh m = {(n + 1) * (n + 1), 2 * n * n, NULL, NULL};
    m.x = malloc(3 * (size_t)m.nv * sizeof *m.x);
    m.t = malloc(3 * (size_t)m.nt * sizeof *m.t);
    for (int i = 0; i <= n; ++i)
        for (int j = 0; j <= n; ++j) {
            double *p = m.x + 3 * (i * (n + 1) + j);
            p[0] = (double)i / n; p[2] = (double)j / n; p[1] = height(p[0], p[2]);
        }
    int32_t *t = m.t;
    for (int i = 0; i < n; ++i)
        for (int j = 0; j < n; ++j) {
            const int a = i * (n + 1) + j, b = a + n + 1;
            /* (x, z) counter-clockwise seen from +y: a, a + 1 (z + 1), b + 1, b */
            *t++ = a; *t++ = a + 1; *t++ = b + 1;
            *t++ = a; *t++ = b + 1; *t++ = b;
        }
    return m;
}

static defsim__collider mesh_collider(const tmesh *m, defsim__pose *pose, int rotate)
{
    defsim_collider_def d;
    defsim_collider_def_init(&d, sizeof d);
    d.shape = DEFSIM_SHAPE_MESH;
    d.vertices = m->x;
    d.vertex_count = m->nv;
    d.triangles = m->t;
    d.triangle_count = m->nt;
    defsim__collider c = make(&d, pose);
    if (!rotate) {
        const double z[3] = {0, 0, 0}, q[4] = {1, 0, 0, 0};
        defsim__pose_set(pose, z, q);
    }
    return c;
}

/* Independent unsigned point-triangle distance: inside the prism of the triangle the distance
 * to its plane, else the nearest of its three edges as segments. */
static double seg_dist(const double *p, const double *a, const double *b)
{
    double ab[3], ap[3], s = 0.0, l2 = 0.0;
    for (int k = 0; k < 3; ++k) { ab[k] = b[k] - a[k]; ap[k] = p[k] - a[k]; s += ab[k] * ap[k]; l2 += ab[k] * ab[k]; }
    s = s < 0 ? 0 : s > l2 ? 1 : s / l2;
    double r = 0.0;
    for (int k = 0; k < 3; ++k) { const double e = ap[k] - s * ab[k]; r += e * e; }
    return sqrt(r);
}
static double tri_dist(const double *p, const double *a, const double *b, const double *c)
{
    const double *v[3] = {a, b, c};
    double n[3], e1[3], e2[3];
    for (int k = 0; k < 3; ++k) { e1[k] = b[k] - a[k]; e2[k] = c[k] - a[k]; }
    n[0] = e1[1] * e2[2] - e1[2] * e2[1]; n[1] = e1[2] * e2[0] - e1[0] * e2[2]; n[2] = e1[0] * e2[1] - e1[1] * e2[0];
    const double nn = sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
    int inside = 1;
    for (int i = 0; i < 3; ++i) {
        const double *u = v[i], *w = v[(i + 1) % 3];
        double ed[3], up[3], cr[3];
        for (int k = 0; k < 3; ++k) { ed[k] = w[k] - u[k]; up[k] = p[k] - u[k]; }
        cr[0] = ed[1] * up[2] - ed[2] * up[1]; cr[1] = ed[2] * up[0] - ed[0] * up[2]; cr[2] = ed[0] * up[1] - ed[1] * up[0];
        if (cr[0] * n[0] + cr[1] * n[1] + cr[2] * n[2] < 0) inside = 0;
    }
    if (inside)
        return fabs((p[0] - a[0]) * n[0] + (p[1] - a[1]) * n[1] + (p[2] - a[2]) * n[2]) / nn;
    return fmin(seg_dist(p, a, b), fmin(seg_dist(p, b, c), seg_dist(p, c, a)));
}
static double brute(const tmesh *m, const double *p)
{
    double best = INFINITY;
    for (int t = 0; t < m->nt; ++t)
        best = fmin(best, tri_dist(p, m->x + 3 * m->t[3 * t], m->x + 3 * m->t[3 * t + 1],
                                   m->x + 3 * m->t[3 * t + 2]));
    return best;
}

static void test_mesh_brute_force(void **state)
{
    (void)state;
    tmesh ms[3] = {cube_mesh(), open_mesh(12), sphere_mesh(0.7, 32, 16)};
    for (int which = 0; which < 3; ++which) {
        defsim__pose pose;
        defsim__collider c = mesh_collider(&ms[which], &pose, 0);
        int neg = 0, pos = 0;
        for (int i = 0; i < 1000; ++i) {
            const double p[3] = {1.2 * rnd() + (which == 1) * 0.5, 1.2 * rnd(), 1.2 * rnd() + (which == 1) * 0.5};
            double g[3];
            const double d = dist(&c, &pose, p, g, NULL), b = brute(&ms[which], p);
            NEAR(fabs(d), b, 1e-12);
            /* the tree finds what the loop over every triangle finds, to the last bit */
            assert_true(fabs(d) == defsim__mesh_distance_brute(&c, p));
            if (which == 0) {   /* closed cube: negative exactly inside */
                const int in = fabs(p[0]) < 0.5 && fabs(p[1]) < 0.5 && fabs(p[2]) < 0.5;
                assert_true(in ? d < 0 : d > 0);
                neg += in;
            } else if (which == 2) {
                /* the polyhedron lies between the radii 0.7 cos(pi/16) cos(pi/32) and 0.7 */
                const double r = sqrt(p[0] * p[0] + p[1] * p[1] + p[2] * p[2]);
                if (r < 0.67) { assert_true(d < 0); ++neg; }
                if (r > 0.7) { assert_true(d > 0); ++pos; }
            } else if (p[0] > 0 && p[0] < 1 && p[2] > 0 && p[2] < 1) {
                /* open height field: the sign of the side, well away from the surface */
                const double y = height(p[0], p[2]);
                if (p[1] > y + 0.05) { assert_true(d > 0); ++pos; }
                if (p[1] < y - 0.05) { assert_true(d < 0); ++neg; }
            }
        }
        assert_true(neg > 50);
        if (which) assert_true(pos > 50);
        defsim__collider_free(&c);
    }
    for (int k = 0; k < 3; ++k) tmesh_free(&ms[k]);
}

/* Gradient and Hessian of mesh distances at random points (faces, edges, corners, inside) of a
 * rotated cube and sphere mesh, and the cube's distance against the box's outside it. */
static void test_mesh_derivatives(void **state)
{
    (void)state;
    tmesh ms[2] = {cube_mesh(), sphere_mesh(0.7, 24, 12)};
    for (int which = 0; which < 2; ++which) {
        defsim__pose pose;
        defsim__collider c = mesh_collider(&ms[which], &pose, 1);
        int curved = 0;
        for (int i = 0; i < 400; ++i) {
            const double l[3] = {1.3 * rnd(), 1.3 * rnd(), 1.3 * rnd()};
            double p[3], g[3], h[9];
            to_world(&pose, l, p);
            const double d = dist(&c, &pose, p, g, h);
            if (fabs(d) < 1e-3) continue;
            double expect = NAN;
            if (which == 0 && d > 0) {
                double s = 0.0;
                for (int k = 0; k < 3; ++k) { const double a = fmax(fabs(l[k]) - 0.5, 0.0); s += a * a; }
                expect = sqrt(s);
            }
            check_point(&c, &pose, p, expect, 1e-5);
            curved += fabs(h[0]) + fabs(h[4]) + fabs(h[8]) > 0;
        }
        assert_true(curved > 20);   /* edges and corners were visited */
        defsim__collider_free(&c);
    }
    for (int k = 0; k < 2; ++k) tmesh_free(&ms[k]);
}

/* ------------------------------------------------------------------------------------------ */
/* SDF */

/* A torus about y (major radius 0.6, minor 0.2): a true signed distance. */
static int sdf_calls;
static double torus(void *user, const double p[3], double g[3])
{
    (void)user;
    ++sdf_calls;
    const double q = sqrt(p[0] * p[0] + p[2] * p[2]);
    const double a = q - 0.6, r = sqrt(a * a + p[1] * p[1]);
    g[0] = a * p[0] / (q * r) * 2.0;   /* deliberately not unit: defsim normalises */
    g[1] = p[1] / r * 2.0;
    g[2] = a * p[2] / (q * r) * 2.0;
    return r - 0.2;
}
static double bad_sdf(void *user, const double p[3], double g[3])
{
    (void)p;
    g[0] = g[1] = 0.0; g[2] = 1.0;
    return *(const double *)user;
}

static void test_sdf(void **state)
{
    (void)state;
    defsim_collider_def d;
    defsim_collider_def_init(&d, sizeof d);
    d.shape = DEFSIM_SHAPE_SDF;
    d.sdf = torus;
    defsim__pose pose;
    defsim__collider c = make(&d, &pose);
    for (int i = 0; i < 200; ++i) {
        /* around the ring, inside and outside the tube, away from its axis and centre */
        const double ph = 3.14159 * rnd(), th = 3.14159 * rnd(), r = 0.03 + 0.5 * rnd01();
        const double q = 0.6 + r * cos(th);
        const double l[3] = {q * cos(ph), r * sin(th), q * sin(ph)};
        double p[3];
        to_world(&pose, l, p);
        check_point(&c, &pose, p, r - 0.2, 1e-5);
    }
    /* a non-finite return or a zero gradient is the callback's error */
    double v = NAN, dd, g[3];
    const double p[3] = {0, 0, 0};
    d.sdf = bad_sdf;
    d.sdf_user = &v;
    defsim__collider b = make(&d, &pose);
    assert_int_equal(defsim__collider_distance(&b, &pose, p, &dd, g, NULL), DEFSIM_ERR_CALLBACK);
    double tt;
    assert_int_equal(defsim__collider_toi(&b, &pose, p, p, 0.0, &tt), DEFSIM_ERR_CALLBACK);
    defsim__collider_free(&b);
    defsim__collider_free(&c);
}

/* ------------------------------------------------------------------------------------------ */
/* Bounds and time of impact over every shape */

enum { NSHAPE = 11 };
static tmesh g_cube, g_sphere, g_open, g_flat;

static defsim__collider shape_n(int n, defsim__pose *pose)
{
    defsim_collider_def d;
    defsim_collider_def_init(&d, sizeof d);
    switch (n) {
    case 0: d.normal[0] = 0.2; d.normal[1] = 1.0; break;
    case 1: d.shape = DEFSIM_SHAPE_SPHERE; d.radius = 0.4; break;
    case 2: d.shape = DEFSIM_SHAPE_BOX; d.half_extents[0] = 0.2; d.half_extents[2] = 0.7; break;
    case 3: d.shape = DEFSIM_SHAPE_CAPSULE; d.radius = 0.2; d.half_height = 0.5; break;
    case 4: return mesh_collider(&g_cube, pose, 1);
    case 5: return mesh_collider(&g_sphere, pose, 1);
    case 6: return mesh_collider(&g_open, pose, 1);
    case 7: d.shape = DEFSIM_SHAPE_SDF; d.sdf = torus;
            d.sdf_bounds[0] = d.sdf_bounds[2] = -0.8; d.sdf_bounds[1] = -0.2;
            d.sdf_bounds[3] = d.sdf_bounds[5] = 0.8; d.sdf_bounds[4] = 0.2; break;
    case 8: d.shape = DEFSIM_SHAPE_CAPSULE; d.radius = 0.3; d.half_height = 0.0; break;
    case 9: return mesh_collider(&g_sphere, pose, 0);   /* not rotated: the root box */
    case 10: return mesh_collider(&g_flat, pose, 1);    /* a flat open sheet */
    }
    return make(&d, pose);
}

static int setup_meshes(void **state)
{
    (void)state;
    g_cube = cube_mesh();
    g_sphere = sphere_mesh(0.5, 16, 8);
    g_open = open_mesh(6);
    g_flat = open_mesh(1);
    for (int i = 0; i < g_flat.nv; ++i) g_flat.x[3 * i + 1] = 0.0;
    return 0;
}
static int teardown_meshes(void **state)
{
    (void)state;
    tmesh_free(&g_cube);
    tmesh_free(&g_sphere);
    tmesh_free(&g_open);
    tmesh_free(&g_flat);
    return 0;
}

static void test_bounds(void **state)
{
    (void)state;
    for (int n = 0; n < NSHAPE; ++n) {
        defsim__pose pose;
        defsim__collider c = shape_n(n, &pose);
        double lo[3], hi[3], lo0[3], hi0[3];
        defsim__collider_bounds(&c, &pose, 0.1, lo, hi);
        defsim__collider_bounds(&c, &pose, 0.0, lo0, hi0);
        for (int k = 0; k < 3 && n != 0; ++k) {
            assert_true(isfinite(lo[k]) && isfinite(hi[k]));
            NEAR(lo0[k] - lo[k], 0.1, 1e-12);
            NEAR(hi[k] - hi0[k], 0.1, 1e-12);
        }
        /* surface points (p - d grad) and points within the margin lie inside; the bounds are
         * reached (tight): some sampled surface point comes within 2 % of each face */
        double reach_lo[3] = {INFINITY, INFINITY, INFINITY}, reach_hi[3] = {-INFINITY, -INFINITY, -INFINITY};
        for (int i = 0; i < 20000; ++i) {
            const double l[3] = {1.5 * rnd(), 1.5 * rnd(), 1.5 * rnd()};
            double p[3], g[3], s[3];
            to_world(&pose, l, p);
            const double d = dist(&c, &pose, p, g, NULL);
            for (int k = 0; k < 3; ++k) s[k] = p[k] - d * g[k];
            for (int k = 0; k < 3; ++k) {
                /* behind an open mesh d < 0 far from it: there only |d| <= margin counts */
                const int open = n == 6 || n == 10;
                if ((open ? fabs(d) : d) <= 0.1) assert_true(p[k] >= lo[k] && p[k] <= hi[k]);
                assert_true(s[k] >= lo0[k] - 1e-9 && s[k] <= hi0[k] + 1e-9);
                reach_lo[k] = fmin(reach_lo[k], s[k]);
                reach_hi[k] = fmax(reach_hi[k], s[k]);
            }
        }
        if (n != 0 && n != 7)   /* an SDF's bounds are its rotated sdf_bounds box, not tight */
            for (int k = 0; k < 3; ++k) {
                assert_true(reach_lo[k] - lo0[k] < 0.02 * (hi0[k] - lo0[k]));
                assert_true(hi0[k] - reach_hi[k] < 0.02 * (hi0[k] - lo0[k]));
            }
        defsim__collider_free(&c);
    }
    /* a plane whose normal is a world axis bounds that axis only */
    defsim_collider_def d;
    defsim_collider_def_init(&d, sizeof d);
    d.position[1] = 0.25;
    defsim__messages msg;
    defsim__collider c;
    assert_int_equal(defsim__collider_make(&msg, &d, &c), DEFSIM_OK);
    defsim__pose pose;
    defsim__pose_set(&pose, c.pos, c.rot);
    double lo[3], hi[3];
    defsim__collider_bounds(&c, &pose, 0.05, lo, hi);
    NEAR(hi[1], 0.3, 1e-15);
    assert_true(isinf(lo[1]) && isinf(hi[0]) && isinf(lo[2]));
}

static void test_toi(void **state)
{
    (void)state;
    for (int n = 0; n < NSHAPE; ++n) {
        defsim__pose pose;
        defsim__collider c = shape_n(n, &pose);
        int hits = 0;
        for (int i = 0; i < 300; ++i) {
            double p0[3], p1[3], u[3];
            for (int k = 0; k < 3; ++k) p0[k] = pose.p[k] + 1.5 * rnd();
            rand_dir(u);
            if (i % 2) {   /* half of them roughly towards the centre */
                double w[3], nw = 0.0;
                for (int k = 0; k < 3; ++k) { w[k] = pose.p[k] - p0[k]; nw += w[k] * w[k]; }
                for (int k = 0; k < 3; ++k) u[k] = w[k] / sqrt(nw) + 0.4 * u[k];
            }
            const double len = 2.5 * rnd01();
            for (int k = 0; k < 3; ++k) p1[k] = p0[k] + len * u[k];
            const double d0 = dist(&c, &pose, p0, NULL, NULL);
            const double md = 0.1 * rnd01();
            if (!(d0 > md + 1e-3)) continue;
            double t;
            assert_int_equal(defsim__collider_toi(&c, &pose, p0, p1, md, &t), DEFSIM_OK);
            assert_true(t >= 0.0 && t <= 1.0);
            /* never closer than md on [0, t]: sampled independently of the iteration */
            for (int s = 0; s <= 2000; ++s) {
                double q[3];
                for (int k = 0; k < 3; ++k) q[k] = p0[k] + t * s / 2000.0 * (p1[k] - p0[k]);
                double dq = dist(&c, &pose, q, NULL, NULL);
                /* a curved open mesh: the sheet itself is never approached closer than md; a
                 * pass behind its border between two samples is not seen (docs/colliders.md).
                 * A flat sheet's negative side is a half-space: there the signed bound holds. */
                if (n == 6 && s < 2000) dq = fabs(dq);
                if (!(dq >= md))
                    fail_msg("shape %d: t %.17g, at %d/2000 of it d %.17g < md %.17g (d0 %g)", n,
                             t, s, dq, md, d0);
            }
            if (t >= 1.0) continue;
            ++hits;
            /* not needlessly small: at t the point is at md (exact for the convex shapes, to
             * 1e-5 of the gap for advancement), or just after t it is closer (an open mesh's
             * sign flip behind its border) */
            double q[3], q2[3];
            for (int k = 0; k < 3; ++k) {
                q[k] = p0[k] + t * (p1[k] - p0[k]);
                q2[k] = p0[k] + (t + 1e-9) * (p1[k] - p0[k]);
            }
            const double dt = dist(&c, &pose, q, NULL, NULL);
            const double tol = (n <= 3 || n == 8) ? 1e-6 : 1e-5;
            assert_true(dt - md <= tol * (d0 - md) + 1e-12 ||
                        ((n == 6 || n == 10) && dist(&c, &pose, q2, NULL, NULL) < md));
        }
        assert_true(hits > 20);
        defsim__collider_free(&c);
    }
}

/* ------------------------------------------------------------------------------------------ */
/* Poses along a step */

static void test_pose_at(void **state)
{
    (void)state;
    defsim_collider_def d;
    defsim_collider_def_init(&d, sizeof d);
    d.shape = DEFSIM_SHAPE_SPHERE;
    defsim__pose pose;
    for (int i = 0; i < 50; ++i) {
        defsim__collider c = make(&d, &pose);
        double q1[4];
        rand_quat(q1);
        for (int k = 0; k < 3; ++k) c.pos1[k] = rnd();
        memcpy(c.rot1, q1, sizeof q1);
        defsim__pose a, b;
        defsim__collider_pose_at(&c, 0.0, &a);
        defsim__collider_pose_at(&c, 1.0, &b);
        for (int k = 0; k < 4; ++k) {
            assert_true(a.q[k] == c.rot[k] && b.q[k] == c.rot1[k]);
            if (k < 3) assert_true(a.p[k] == c.pos[k] && b.p[k] == c.pos1[k]);
        }
        /* constant angular velocity along the shortest arc: angle(q0, q(s)) = s angle(q0, q1) */
        double dot1 = 0.0;
        for (int k = 0; k < 4; ++k) dot1 += c.rot[k] * c.rot1[k];
        const double total = 2.0 * acos(fmin(1.0, fabs(dot1)));
        for (int j = 1; j < 10; ++j) {
            const double s = j / 10.0;
            defsim__pose m;
            defsim__collider_pose_at(&c, s, &m);
            double nq = 0.0, dt = 0.0;
            for (int k = 0; k < 4; ++k) { nq += m.q[k] * m.q[k]; dt += m.q[k] * c.rot[k]; }
            NEAR(nq, 1.0, 1e-14);
            NEAR(2.0 * acos(fmin(1.0, fabs(dt))), s * total, 1e-7);
            for (int k = 0; k < 3; ++k)
                NEAR(m.p[k], c.pos[k] + s * (c.pos1[k] - c.pos[k]), 1e-15);
            /* R is a rotation: R R^T = I */
            for (int r = 0; r < 3; ++r)
                for (int q = 0; q < 3; ++q) {
                    double e = 0.0;
                    for (int k = 0; k < 3; ++k) e += m.R[3 * r + k] * m.R[3 * q + k];
                    NEAR(e, r == q, 1e-13);
                }
        }
        defsim__collider_free(&c);
    }
}

/* ------------------------------------------------------------------------------------------ */
/* The API's bad input: a clear status, nothing changed */

static void expect_bad(defsim_world *w, const defsim_collider_def *d)
{
    const int32_t n = defsim_world_collider_count(w);
    defsim_collider_id id = {77, 77};
    assert_int_equal(defsim_world_add_collider(w, d, &id), DEFSIM_ERR_INVALID_ARGUMENT);
    assert_true(id.index == 77 && id.generation == 77);
    assert_int_equal(defsim_world_collider_count(w), n);
    assert_true(strlen(defsim_world_last_error(w)) > 0);
}

static void test_api_bad_input(void **state)
{
    (void)state;
    defsim_world *w = tu_world("symplectic_euler", -9.81, 1);
    defsim_collider_def d;
    defsim_collider_def_init(&d, sizeof d);
    d.normal[1] = 0.0;
    expect_bad(w, &d);                                   /* zero normal */
    defsim_collider_def_init(&d, sizeof d);
    d.rotation[0] = 1.1;
    expect_bad(w, &d);                                   /* non-unit quaternion */
    d.rotation[0] = 1.0 + 5e-7;                          /* within 1e-6: normalised */
    defsim_collider_id plane;
    assert_int_equal(defsim_world_add_collider(w, &d, &plane), DEFSIM_OK);
    defsim_collider_def got;
    defsim_collider_def_init(&got, sizeof got);
    assert_int_equal(defsim_world_get_collider(w, 0, NULL, &got), DEFSIM_OK);
    NEAR(got.rotation[0], 1.0, 1e-15);

    defsim_collider_def_init(&d, sizeof d);
    d.shape = DEFSIM_SHAPE_SPHERE;
    d.radius = -0.1;
    expect_bad(w, &d);
    d.shape = DEFSIM_SHAPE_CAPSULE;
    expect_bad(w, &d);
    d.radius = 0.1;
    d.half_height = -1e-3;
    expect_bad(w, &d);
    defsim_collider_def_init(&d, sizeof d);
    d.shape = DEFSIM_SHAPE_BOX;
    for (int k = 0; k < 3; ++k) {
        d.half_extents[k] = k == 1 ? 0.0 : -1.0;
        expect_bad(w, &d);
        d.half_extents[k] = 0.5;
    }
    d.half_extents[2] = NAN;
    expect_bad(w, &d);

    tmesh m = cube_mesh();
    defsim_collider_def_init(&d, sizeof d);
    d.shape = DEFSIM_SHAPE_MESH;
    d.vertices = m.x;
    d.vertex_count = m.nv;
    d.triangles = m.t;
    d.triangle_count = m.nt;
    m.t[7] = 8;
    expect_bad(w, &d);                                   /* index out of range */
    m.t[7] = -1;
    expect_bad(w, &d);
    m.t[7] = m.t[6];
    expect_bad(w, &d);                                   /* degenerate triangle */
    tmesh good = cube_mesh();
    memcpy(m.t, good.t, 36 * sizeof *m.t);
    m.x[4] = NAN;
    expect_bad(w, &d);                                   /* non-finite vertex */
    memcpy(m.x, good.x, 24 * sizeof *m.x);
    d.triangles = NULL;
    expect_bad(w, &d);
    d.triangles = m.t;
    d.vertex_count = 2;
    expect_bad(w, &d);
    d.vertex_count = m.nv;
    defsim_collider_id mid;
    assert_int_equal(defsim_world_add_collider(w, &d, &mid), DEFSIM_OK);
    m.x[0] = 100.0;   /* copied: the host may change or free its arrays */
    assert_int_equal(defsim_world_get_collider(w, 1, NULL, &got), DEFSIM_OK);
    assert_true(got.shape == DEFSIM_SHAPE_MESH && got.vertices[0] == -0.5 && got.triangle_count == 12);

    defsim_collider_def_init(&d, sizeof d);
    d.shape = DEFSIM_SHAPE_SDF;
    expect_bad(w, &d);                                   /* no callback */
    d.sdf = torus;
    d.sdf_bounds[0] = 1.0;                               /* lo x > hi x = 0 */
    expect_bad(w, &d);
    d.sdf_bounds[3] = 2.0;
    assert_int_equal(defsim_world_add_collider(w, &d, NULL), DEFSIM_OK);
    assert_int_equal(defsim_world_collider_count(w), 3);

    /* set_pose: bad quaternion leaves the pose as it was */
    const double pos[3] = {1, 2, 3}, badq[4] = {0.5, 0, 0, 0}, q[4] = {0, 1, 0, 0};
    assert_int_equal(defsim_collider_set_pose(w, plane, pos, badq), DEFSIM_ERR_INVALID_ARGUMENT);
    assert_int_equal(defsim_collider_set_pose(w, plane, pos, q), DEFSIM_OK);
    assert_int_equal(defsim_world_remove_collider(w, mid), DEFSIM_OK);
    assert_int_equal(defsim_world_remove_collider(w, mid), DEFSIM_ERR_STALE_ID);
    assert_int_equal(defsim_collider_set_pose(w, mid, pos, q), DEFSIM_ERR_STALE_ID);
    assert_int_equal(defsim_world_collider_count(w), 2);
    tmesh_free(&m);
    tmesh_free(&good);
    defsim_world_destroy(w);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_plane_sphere),
        cmocka_unit_test(test_box),
        cmocka_unit_test(test_capsule),
        cmocka_unit_test(test_mesh_brute_force),
        cmocka_unit_test(test_mesh_derivatives),
        cmocka_unit_test(test_sdf),
        cmocka_unit_test(test_bounds),
        cmocka_unit_test(test_toi),
        cmocka_unit_test(test_pose_at),
        cmocka_unit_test(test_api_bad_input),
    };
    return cmocka_run_group_tests(tests, setup_meshes, teardown_meshes);
}
