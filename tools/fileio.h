/* SPDX-License-Identifier: MIT */
/* Small file helpers shared by the tools. */
#ifndef DEFSIM_TOOLS_FILEIO_H
#define DEFSIM_TOOLS_FILEIO_H

#include <stddef.h>

/* Reads a whole file into a malloc'd, NUL-terminated buffer; *len gets its size. NULL (errno
 * set; EFBIG beyond DEFSIM__FILE_MAX, 1 GiB) if it cannot be read. The reader is the library's
 * (src/file_read.c, compiled into the tools since the shared library does not export it). */
char *tools_read_file(const char *path, size_t *len);

/* Creates a folder and its missing parents (like mkdir -p). Returns 0, or -1 (errno set). */
int tools_make_dirs(const char *path);

#endif
