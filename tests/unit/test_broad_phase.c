/* SPDX-License-Identifier: MIT */
/*
 * Broad phase for body-body and self-contact (src/broad_phase.c): the hash's pairs against all
 * pairs by brute force (random boxes of mixed sizes, self and two sets, degenerate cell sizes),
 * and the surfaces: the boundary of a box mesh (count, closed 2-manifold, outward normals whose
 * area-weighted sum is zero and whose divergence gives the volume) and the edges of triangles.
 */
#include "broad_phase.h"
#include "mesh.h"
#include "test_util.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

static void random_boxes(unsigned long long *rng, int n, double size, double *lo, double *hi)
{
    for (int i = 0; i < n; ++i)
        for (int a = 0; a < 3; ++a) {
            const double c = 5.0 * tu_rand(rng), e = size * (1.0 + tu_rand(rng)) *
                                                  (i % 17 == 0 ? 20.0 : 1.0);   /* a few long */
            lo[3 * i + a] = c - e;
            hi[3 * i + a] = c + e;
        }
}

static int overlap(const double *la, const double *ha, const double *lb, const double *hb)
{
    for (int a = 0; a < 3; ++a)
        if (la[a] > hb[a] || lb[a] > ha[a]) return 0;
    return 1;
}

static void check_against_brute_force(int na, int nb, int self, double cell)
{
    unsigned long long rng = (unsigned long long)(na * 31 + nb + self);
    double *la = malloc(3 * sizeof(double) * na), *ha = malloc(3 * sizeof(double) * na);
    double *lb = malloc(3 * sizeof(double) * nb), *hb = malloc(3 * sizeof(double) * nb);
    random_boxes(&rng, na, 0.1, la, ha);
    if (self) {
        memcpy(lb, la, 3 * sizeof(double) * na);
        memcpy(hb, ha, 3 * sizeof(double) * na);
    } else {
        random_boxes(&rng, nb, 0.1, lb, hb);
    }
    defsim__hash h;
    memset(&h, 0, sizeof h);
    assert_int_equal(defsim__hash_pairs(&h, la, ha, na, lb, hb, nb, self, cell), DEFSIM_OK);
    int64_t expect = 0, k = 0;
    for (int a = 0; a < na; ++a)
        for (int b = self ? a + 1 : 0; b < nb; ++b)
            if (overlap(la + 3 * a, ha + 3 * a, lb + 3 * b, hb + 3 * b)) {
                /* Both are in lexicographic order: the lists must be equal element by element. */
                assert_true(k < h.npairs);
                assert_true(h.pairs[k] == ((int64_t)a << 32 | b));
                ++k;
                ++expect;
            }
    assert_int_equal(h.npairs, expect);
    print_message("na %d nb %d self %d cell %g: %lld pairs, %lld keys\n", na, nb, self, cell,
                  (long long)expect, (long long)h.nkeys);
    defsim__hash_free(&h);
    free(la); free(ha); free(lb); free(hb);
}

static void test_hash_pairs(void **state)
{
    (void)state;
    check_against_brute_force(2000, 2000, 1, 0.2);
    check_against_brute_force(1500, 700, 0, 0.2);
    check_against_brute_force(500, 500, 1, 1e-6);   /* far too small: coarsened */
    check_against_brute_force(500, 500, 1, 1e6);    /* one cell */
    check_against_brute_force(300, 300, 0, 0.0);    /* automatic */
    check_against_brute_force(0, 10, 0, 0.2);
}

static void test_tet_boundary(void **state)
{
    (void)state;
    defsim_mesh m = {.size = sizeof m};
    const double lo[3] = {0, 0, 0}, hi[3] = {2, 1, 1};
    assert_int_equal(defsim_mesh_box(lo, hi, 4, 2, 3, &m), DEFSIM_OK);
    int32_t *f, nf;
    assert_int_equal(defsim__tet_boundary(m.positions, m.tets, m.tet_count, &f, &nf), DEFSIM_OK);
    /* Each square face of the box's surface is split in two triangles. */
    assert_int_equal(nf, 2 * 2 * (4 * 2 + 4 * 3 + 2 * 3));
    /* Outward and closed: sum of area vectors 0; divergence theorem: sum (c . n A) / 3 = V. */
    double s[3] = {0, 0, 0}, vol = 0.0;
    for (int32_t i = 0; i < nf; ++i) {
        const double *a = m.positions + 3 * f[3 * i], *b = m.positions + 3 * f[3 * i + 1],
                     *c = m.positions + 3 * f[3 * i + 2];
        const double u[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]};
        const double v[3] = {c[0] - a[0], c[1] - a[1], c[2] - a[2]};
        const double n[3] = {0.5 * (u[1] * v[2] - u[2] * v[1]), 0.5 * (u[2] * v[0] - u[0] * v[2]),
                             0.5 * (u[0] * v[1] - u[1] * v[0])};
        for (int k = 0; k < 3; ++k) {
            s[k] += n[k];
            vol += (a[k] + b[k] + c[k]) / 3.0 * n[k] / 3.0;
        }
    }
    for (int k = 0; k < 3; ++k) assert_true(fabs(s[k]) < 1e-12);
    assert_true(fabs(vol - 2.0) < 1e-12);
    /* Edges: a closed triangulated surface has E = 3F/2. */
    int32_t *e, ne;
    assert_int_equal(defsim__triangle_edges(f, nf, &e, &ne), DEFSIM_OK);
    assert_int_equal(ne, 3 * nf / 2);
    for (int32_t i = 0; i < ne; ++i) {
        assert_true(e[2 * i] < e[2 * i + 1]);
        if (i) assert_true(e[2 * i - 2] < e[2 * i] || (e[2 * i - 2] == e[2 * i] &&
                                                       e[2 * i - 1] < e[2 * i + 1]));
    }
    free(e);
    free(f);
    defsim_mesh_free(&m);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_hash_pairs),
        cmocka_unit_test(test_tet_boundary),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
