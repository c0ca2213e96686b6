/* SPDX-License-Identifier: MIT */
/* The shared rest-shape rule (src/tet_rest.c) and the one whole-file reader (src/file_read.c). */
#include "test_util.h"

#include "file_read.h"
#include "tet_rest.h"

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* Right tet with legs a, b, c along x, y, z at vertex 3: Dm = diag(a, b, c). */
static void test_rest_right_tet(void **state)
{
    (void)state;
    const double P[12] = {2, 0, 0, 0, 3, 0, 0, 0, 4, 0, 0, 0};
    const int32_t tet[4] = {0, 1, 2, 3}, flipped[4] = {1, 0, 2, 3};
    defsim__tet_rest r;
    double inv[9];
    assert_int_equal(defsim__tet_rest_eval(P, tet, &r, inv), 0);
    assert_true(r.det == 24.0);
    assert_true(r.longest_edge == 5.0);   /* the 3-4-5 edge between vertices 1 and 2 */
    const double want[9] = {0.5, 0, 0, 0, 1.0 / 3.0, 0, 0, 0, 0.25};
    for (int i = 0; i < 9; ++i) assert_true(fabs(inv[i] - want[i]) <= 1e-16);
    assert_int_equal(defsim__tet_rest_eval(P, flipped, &r, NULL), 0);
    assert_true(r.det == -24.0);
}

/* The rule is |det Dm| > 1e-12 * longest_edge^3: a sliver just above passes, one at or below
 * it (and a flat or coincident tet) is degenerate (add_body: test_world.c). */
static void test_rest_degenerate_rule(void **state)
{
    (void)state;
    const int32_t tet[4] = {0, 1, 2, 3};
    defsim__tet_rest r;
    for (int k = 0; k < 4; ++k) {
        /* Unit legs along x and y and height z along z: det Dm = z exactly, longest edge
         * sqrt 2; k = 3 puts z exactly on the threshold, which counts as degenerate. */
        const double l = sqrt(2.0), limit = DEFSIM__DEGENERATE_REL * l * l * l;
        const double z = k == 0 ? 2.0 * limit : k == 1 ? 0.5 * limit : k == 2 ? 0.0 : limit;
        const double P[12] = {1, 0, 0, 0, 1, 0, 0, 0, z, 0, 0, 0};
        const int want = k == 0 ? 0 : 1;
        assert_int_equal(defsim__tet_rest_eval(P, tet, &r, NULL), want);
        assert_int_equal(r.degenerate, want);
        assert_true(r.longest_edge == sqrt(2.0));
    }
    const double same[12] = {1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1};
    double inv[9];
    assert_int_equal(defsim__tet_rest_eval(same, tet, &r, inv), 1);
    for (int i = 0; i < 9; ++i) assert_true(inv[i] == 0.0);}

static void test_read_file_limit(void **state)
{
    (void)state;
    const char *path = tu_write_file("ten.txt", "0123456789");
    char *buf = NULL;
    size_t len = 0;
    assert_int_equal(defsim__read_file(path, 10, &buf, &len), 0);
    assert_int_equal(len, 10);
    assert_int_equal(buf[10], '\0');
    assert_memory_equal(buf, "0123456789", 10);
    free(buf);
    assert_int_equal(defsim__read_file(path, 9, &buf, &len), EFBIG);
    assert_null(buf);
    assert_int_equal(len, 0);
    /* A file that never ends (a device) is refused before reading; so is a folder. */
    assert_int_equal(defsim__read_file("/dev/zero", 100000, &buf, &len), DEFSIM__ENOTREG);
    assert_null(buf);
    assert_int_equal(defsim__read_file(tu_tmpdir, 100000, &buf, &len), EISDIR);
    assert_null(buf);
    char missing[512];
    snprintf(missing, sizeof missing, "%s/missing", tu_tmpdir);
    assert_int_equal(defsim__read_file(missing, DEFSIM__FILE_MAX, &buf, &len), ENOENT);
    assert_null(buf);
    /* Larger than the first 64 KiB chunk: the buffer grows and keeps every byte. */
    size_t n = 200000;
    char *big = malloc(n + 1);
    for (size_t i = 0; i < n; ++i) big[i] = (char)('a' + i % 26);
    big[n] = '\0';
    path = tu_write_file("big.txt", big);
    assert_int_equal(defsim__read_file(path, n, &buf, &len), 0);
    assert_int_equal(len, n);
    assert_memory_equal(buf, big, n);
    free(buf);
    assert_int_equal(defsim__read_file(path, n - 1, &buf, &len), EFBIG);
    free(big);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_rest_right_tet),
        cmocka_unit_test(test_rest_degenerate_rule),
        cmocka_unit_test_setup_teardown(test_read_file_limit, tu_tmpdir_setup, tu_tmpdir_teardown),
    };
    return cmocka_run_group_tests_name("tet_rest", tests, NULL, NULL);
}
