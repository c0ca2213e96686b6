/* SPDX-License-Identifier: MIT */
#include "fileio.h"

#include "../src/file_read.h"

#include <errno.h>
#include <stdio.h>
#include <sys/stat.h>

char *tools_read_file(const char *path, size_t *len)
{
    char *buf;
    int err = defsim__read_file(path, DEFSIM__FILE_MAX, &buf, len);
    if (err) errno = err;
    return buf;
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

