/* SPDX-License-Identifier: MIT */
#include "fuzz_util.h"

#include <defsim/defsim.h>

#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

static char dir[256];

static void remove_dir(void)
{
    char cmd[300];
    snprintf(cmd, sizeof cmd, "rm -rf '%s'", dir);
    if (system(cmd) != 0) fprintf(stderr, "fuzz: could not remove %s\n", dir);
}

const char *fz_write(const char *name, const uint8_t *data, size_t size)
{
    static char path[512];
    if (!dir[0]) {
        const char *tmp = getenv("TMPDIR");
        snprintf(dir, sizeof dir, "%s/defsim-fuzz-XXXXXX", tmp && tmp[0] ? tmp : "/tmp");
        if (!mkdtemp(dir)) {
            perror("fuzz: mkdtemp");
            abort();
        }
        atexit(remove_dir);
    }
    snprintf(path, sizeof path, "%s/%s", dir, name);
    FILE *f = fopen(path, "wb");
    if (!f || (size && fwrite(data, 1, size, f) != size) || fclose(f) != 0) {
        perror("fuzz: writing the input");
        abort();
    }
    return path;
}

void fz_small_limits(void)
{
    if (defsim_set_limit(DEFSIM_LIMIT_FILE_BYTES, 1 << 20) != DEFSIM_OK ||
        defsim_set_limit(DEFSIM_LIMIT_VERTICES, 20000) != DEFSIM_OK ||
        defsim_set_limit(DEFSIM_LIMIT_ELEMENTS, 100000) != DEFSIM_OK)
        abort();
}
