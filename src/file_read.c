/* SPDX-License-Identifier: MIT */
#include "file_read.h"

#include <errno.h>
#include <fcntl.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

/* Opens `path` for reading if it is a regular file: O_NONBLOCK so that opening a FIFO does not
 * wait for a writer, then fstat on what was opened (no race with a rename in between). */
static int open_regular(const char *path, FILE **out)
{
    int fd = open(path, O_RDONLY | O_NONBLOCK | O_CLOEXEC);
    if (fd < 0) return errno ? errno : EIO;
    struct stat st;
    int err = 0;
    if (fstat(fd, &st) != 0) err = errno ? errno : EIO;
    else if (S_ISDIR(st.st_mode)) err = EISDIR;
    else if (!S_ISREG(st.st_mode)) err = DEFSIM__ENOTREG;
    /* Blocking reads from here on (a regular file never blocks; this is for clarity). */
    else if (fcntl(fd, F_SETFL, fcntl(fd, F_GETFL) & ~O_NONBLOCK) != 0)
        err = errno ? errno : EIO;
    FILE *f = err ? NULL : fdopen(fd, "rb");
    if (!f) {
        if (!err) err = errno ? errno : EIO;
        close(fd);
        return err;
    }
    *out = f;
    return 0;
}

int defsim__read_file(const char *path, size_t max_bytes, char **buf, size_t *len)
{
    *buf = NULL;
    *len = 0;
    FILE *f = NULL;
    int rc = open_regular(path, &f);
    if (rc) return rc;
    /* Grow by doubling up to one byte past the limit, to tell "exactly max_bytes" from more. */
    if (max_bytes > SIZE_MAX / 4) max_bytes = SIZE_MAX / 4;
    size_t cap = 1 << 16, n = 0;
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

const char *defsim__read_strerror(int err)
{
    if (err == DEFSIM__ENOTREG)
        return "not a regular file (a FIFO, device or socket is not read)";
    return strerror(err);
}
