/* SPDX-License-Identifier: MIT */
/* The backends of this build, as CMake's DEFSIM_CONFORMANCE_BACKENDS lists them, compiled into
 * the tests as DEFSIM_TEST_BACKENDS ("a,b,c"): a test may skip a case only for a backend that is
 * not in this list; any other failure to create a world is a failure. */
#ifndef DEFSIM_TEST_BUILT_BACKENDS_H
#define DEFSIM_TEST_BUILT_BACKENDS_H

#include <string.h>

#ifndef DEFSIM_TEST_BACKENDS
#error "DEFSIM_TEST_BACKENDS (the build's backends, comma-separated) comes from tests/CMakeLists.txt"
#endif

static inline int built_backend(const char *backend)
{
    const char *list = DEFSIM_TEST_BACKENDS;
    const size_t n = strlen(backend);
    for (const char *p = list; *p;) {
        const char *end = strchr(p, ',');
        const size_t len = end ? (size_t)(end - p) : strlen(p);
        if (len == n && strncmp(p, backend, n) == 0) return 1;
        if (!end) break;
        p = end + 1;
    }
    return 0;
}

#endif
