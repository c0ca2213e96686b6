/* SPDX-License-Identifier: MIT */
/* CHECK for the tool tests (plain programs that drive the defsim executable; one source file
 * each): a failed check is reported with its line and counted, and the test goes on. */
#ifndef DEFSIM_TESTS_TOOL_CHECK_H
#define DEFSIM_TESTS_TOOL_CHECK_H

#include <stdio.h>

static int failures;

#define CHECK(cond, ...)                                                                          \
    do {                                                                                          \
        if (!(cond)) {                                                                            \
            fprintf(stderr, "FAIL %s:%d: ", __FILE__, __LINE__);                                  \
            fprintf(stderr, __VA_ARGS__);                                                         \
            fprintf(stderr, "\n");                                                                \
            ++failures;                                                                           \
        }                                                                                         \
    } while (0)

#endif
