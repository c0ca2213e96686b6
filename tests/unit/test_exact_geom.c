/* SPDX-License-Identifier: MIT */
/*
 * The exact predicates that contact tests use to check intersections independently of the
 * solver (tests/common/exact_geom.c): orient3d against a 113-bit evaluation where that is
 * unambiguous and against exactly coplanar constructions, where double-precision evaluation is
 * shown to fail; triangle-triangle and point-in-tet cases, touching and near-miss included.
 */
#include "exact_geom.h"
#include "test_util.h"

#include <math.h>
#include <quadmath.h>

static int naive_orient3d(const double *a, const double *b, const double *c, const double *d)
{
    const double ax = a[0] - d[0], ay = a[1] - d[1], az = a[2] - d[2];
    const double bx = b[0] - d[0], by = b[1] - d[1], bz = b[2] - d[2];
    const double cx = c[0] - d[0], cy = c[1] - d[1], cz = c[2] - d[2];
    const double det = ax * (by * cz - bz * cy) + ay * (bz * cx - bx * cz) + az * (bx * cy - by * cx);
    return (det > 0) - (det < 0);
}

static __float128 det128(const double *a, const double *b, const double *c, const double *d)
{
    __float128 A[3], B[3], C[3];
    for (int k = 0; k < 3; ++k) {
        A[k] = (__float128)a[k] - d[k];
        B[k] = (__float128)b[k] - d[k];
        C[k] = (__float128)c[k] - d[k];
    }
    return A[0] * (B[1] * C[2] - B[2] * C[1]) + A[1] * (B[2] * C[0] - B[0] * C[2]) +
           A[2] * (B[0] * C[1] - B[1] * C[0]);
}

static void test_orient3d(void **state)
{
    (void)state;
    unsigned long long rng = 3;
    int naive_wrong = 0, checked = 0;
    for (int trial = 0; trial < 20000; ++trial) {
        double a[3], b[3], c[3], d[3];
        for (int k = 0; k < 3; ++k) {
            a[k] = tu_rand(&rng);
            b[k] = tu_rand(&rng);
            c[k] = tu_rand(&rng);
        }
        /* d near the plane of a, b, c: an affine combination, rounded to doubles. */
        const double u = tu_rand(&rng), v = tu_rand(&rng);
        for (int k = 0; k < 3; ++k) d[k] = a[k] + u * (b[k] - a[k]) + v * (c[k] - a[k]);
        const __float128 q = det128(a, b, c, d);
        const int exact = eg_orient3d(a, b, c, d);
        /* Where 113 bits leave no doubt (errors below 1e-30 here), the signs must agree. */
        if (fabsq(q) > 1e-28Q) {
            assert_int_equal(exact, q > 0 ? 1 : -1);
            ++checked;
            naive_wrong += naive_orient3d(a, b, c, d) != exact;
        }
    }
    print_message("orient3d near-coplanar: %d checked against 113 bits, double wrong in %d\n",
                  checked, naive_wrong);
    assert_true(checked > 1000);
    assert_true(naive_wrong > 0);   /* why the tests need the exact predicate */
    /* Exactly coplanar by construction (small integers times powers of two): 0. */
    for (int trial = 0; trial < 1000; ++trial) {
        double a[3], b[3], c[3], d[3];
        for (int k = 0; k < 3; ++k) {
            a[k] = ldexp(floor(1e3 * tu_rand(&rng)), -7);
            b[k] = ldexp(floor(1e3 * tu_rand(&rng)), -7);
            c[k] = ldexp(floor(1e3 * tu_rand(&rng)), -7);
            d[k] = a[k] + b[k] - c[k];
        }
        assert_int_equal(eg_orient3d(a, b, c, d), 0);
    }
}

static void test_tri_tri(void **state)
{
    (void)state;
    const double p0[3] = {0, 0, 0}, p1[3] = {1, 0, 0}, p2[3] = {0, 1, 0};
    /* Piercing. */
    const double a0[3] = {0.2, 0.2, -1}, a1[3] = {0.2, 0.2, 1}, a2[3] = {0.3, 0.3, 1};
    assert_true(eg_tri_tri_intersect(p0, p1, p2, a0, a1, a2));
    assert_true(eg_tri_tri_intersect(a0, a1, a2, p0, p1, p2));
    /* Above by the smallest double: apart; touching at one point: intersecting. */
    const double t = 0x1p-1074;
    const double b0[3] = {0.2, 0.2, t}, b1[3] = {0.2, 0.8, 1}, b2[3] = {0.8, 0.2, 1};
    assert_false(eg_tri_tri_intersect(p0, p1, p2, b0, b1, b2));
    const double c0[3] = {0.2, 0.2, 0}, c1[3] = {0.2, 0.8, 1}, c2[3] = {0.8, 0.2, 1};
    assert_true(eg_tri_tri_intersect(p0, p1, p2, c0, c1, c2));
    /* Sharing the hypotenuse, from outside the plane. */
    const double d0[3] = {1, 0, 0}, d1[3] = {0, 1, 0}, d2[3] = {1, 1, 1};
    assert_true(eg_tri_tri_intersect(p0, p1, p2, d0, d1, d2));
    /* Coplanar: overlapping, disjoint, one inside the other. */
    const double e0[3] = {0.5, 0.5, 0}, e1[3] = {1.5, 0.5, 0}, e2[3] = {0.5, 1.5, 0};
    assert_true(eg_tri_tri_intersect(p0, p1, p2, e0, e1, e2));   /* touch at (0.5, 0.5) */
    const double f0[3] = {0.6, 0.6, 0}, f1[3] = {1.5, 0.6, 0}, f2[3] = {0.6, 1.5, 0};
    assert_false(eg_tri_tri_intersect(p0, p1, p2, f0, f1, f2));
    const double g0[3] = {0.1, 0.1, 0}, g1[3] = {0.2, 0.1, 0}, g2[3] = {0.1, 0.2, 0};
    assert_true(eg_tri_tri_intersect(p0, p1, p2, g0, g1, g2));
    assert_true(eg_tri_tri_intersect(g0, g1, g2, p0, p1, p2));
    /* Parallel planes apart. */
    const double h0[3] = {0, 0, 1e-300}, h1[3] = {1, 0, 1e-300}, h2[3] = {0, 1, 1e-300};
    assert_false(eg_tri_tri_intersect(p0, p1, p2, h0, h1, h2));
}

static void test_point_in_tet(void **state)
{
    (void)state;
    const double a[3] = {0, 0, 0}, b[3] = {1, 0, 0}, c[3] = {0, 1, 0}, d[3] = {0, 0, 1};
    const double in[3] = {0.1, 0.1, 0.1}, face[3] = {0.1, 0.1, 0}, out[3] = {0.5, 0.5, 0.5};
    assert_true(eg_point_in_tet(in, a, b, c, d));
    assert_true(eg_point_in_tet(in, a, c, b, d));   /* either orientation */
    assert_false(eg_point_in_tet(face, a, b, c, d));
    assert_false(eg_point_in_tet(out, a, b, c, d));
    const double just_in[3] = {1.0 / 3.0 - 1e-16, 1.0 / 3.0 - 1e-16, 1.0 / 3.0 - 1e-16};
    assert_true(eg_point_in_tet(just_in, a, b, c, d));
}

/* The distances: a triangle 0.3 above a parallel one, over its interior (vertex-face); two
 * triangles whose edges cross at right angles 0.25 apart (edge-edge); a point beyond a corner
 * (vertex-vertex); intersecting triangles (0). */
static void test_distances(void **state)
{
    (void)state;
    const double a[3] = {0, 0, 0}, b[3] = {1, 0, 0}, c[3] = {0, 1, 0};
    const double p[3] = {0.2, 0.2, 0.3}, q[3] = {0.5, 0.2, 0.3}, r[3] = {0.2, 0.5, 0.3};
    assert_true(fabs(eg_tri_tri_distance(a, b, c, p, q, r) - 0.3) < 1e-15);
    assert_true(fabs(eg_tri_tri_gap(p, q, r, a, b, c) - 0.3) < 1e-15);
    /* edge (0.5, -1, 0.25)-(0.5, 1, 0.25) above the edge a-b (y = 0), its triangle rising */
    const double e0[3] = {0.5, -1, 0.25}, e1[3] = {0.5, 1, 0.25}, e2[3] = {0.5, 0, 2};
    const double f0[3] = {0, 0, 0}, f1[3] = {1, 0, 0}, f2[3] = {0.5, 0, -2};
    assert_true(fabs(eg_tri_tri_distance(e0, e1, e2, f0, f1, f2) - 0.25) < 1e-15);
    const double x[3] = {-0.3, -0.4, 0};
    assert_true(fabs(eg_point_tri_distance(x, a, b, c) - 0.5) < 1e-15);
    const double s0[3] = {0.2, 0.2, -1}, s1[3] = {0.2, 0.2, 1}, s2[3] = {0.3, 0.3, 0};
    assert_true(eg_tri_tri_distance(a, b, c, s0, s1, s2) == 0.0);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_orient3d),
        cmocka_unit_test(test_tri_tri),
        cmocka_unit_test(test_point_in_tet),
        cmocka_unit_test(test_distances),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
