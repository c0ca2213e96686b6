/* SPDX-License-Identifier: MIT */
#include "file_read.h"

#include <errno.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>

int defsim__read_file(const char *path, size_t max_bytes, char **buf, size_t *len)
{
    *buf = NULL;
    *len = 0;
    FILE *f = fopen(path, "rb");
    if (!f) return errno ? errno : EIO;
    /* Grow by doubling up to one byte past the limit, to tell "exactly max_bytes" from more. */
    if (max_bytes > SIZE_MAX / 4) max_bytes = SIZE_MAX / 4;
    size_t cap = 1 << 16, n = 0;
    int rc = 0;
    char *b = malloc(cap + 1);
    while (b) {
        n += fread(b + n, 1, cap - n, f);
        if (n < cap || n > max_bytes) break;
        const size_t next = cap > max_bytes / 2 ? max_bytes + 1 : cap * 2;
        char *nb = realloc(b, next + 1);
        if (!nb) { free(b); b = NULL; }
        else { b = nb; cap = next; }
    }
    if (!b) rc = ENOMEM;
    else if (n > max_bytes) rc = EFBIG;
    else if (ferror(f)) rc = EIO;
    fclose(f);
    if (rc) {
        free(b);
        return rc;
    }
    b[n] = '\0';
    *buf = b;
    *len = n;
    return 0;
}
