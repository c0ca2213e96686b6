/* SPDX-License-Identifier: MIT */
#include "fileio.h"

#include "../src/file_read.h"

#include <errno.h>
#include <stdio.h>
#include <string.h>
#include <sys/stat.h>

char *tools_read_file(const char *path, size_t *len)
{
    char *buf;
    int err = defsim__read_file(path, DEFSIM__FILE_MAX, &buf, len);
    if (err) errno = err;
    return buf;
}

FILE *tools_tmp_open(const char *path, char *tmp, size_t tmpsz, char *err, size_t errsz)
{
    snprintf(tmp, tmpsz, "%s.tmp", path);
    FILE *f = fopen(tmp, "wb");
    if (!f) snprintf(err, errsz, "%s: cannot write: %s", tmp, strerror(errno));
    return f;
}

int tools_tmp_commit(FILE *f, const char *tmp, const char *path, int ok, char *err,
                     size_t errsz)
{
    ok = ok && !ferror(f);
    ok = (fclose(f) == 0) && ok;
    if (ok && rename(tmp, path) == 0) return 0;
    const int e = errno;
    remove(tmp);
    snprintf(err, errsz, "%s: write failed: %s", path, strerror(e));
    return -1;
}

int tools_make_dirs(const char *path)
{
    char tmp[2048];
    snprintf(tmp, sizeof tmp, "%s", path);
    for (char *p = tmp + 1; *p; ++p)
        if (*p == '/') {
            *p = '\0';
            if (mkdir(tmp, 0777) != 0 && errno != EEXIST) return -1;
            *p = '/';
        }
    return mkdir(tmp, 0777) != 0 && errno != EEXIST ? -1 : 0;
}

uint64_t tools_fnv1a(uint64_t h, const void *data, size_t n)
{
    const unsigned char *p = data;
    for (size_t i = 0; i < n; ++i) {
        h ^= p[i];
        h *= 1099511628211ULL;
    }
    return h;
}
