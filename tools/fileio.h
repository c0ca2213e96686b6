/* SPDX-License-Identifier: MIT */
/* Small file helpers shared by the tools. */
#ifndef DEFSIM_TOOLS_FILEIO_H
#define DEFSIM_TOOLS_FILEIO_H

#include <stddef.h>
#include <stdint.h>

/* Reads a whole file into a malloc'd, NUL-terminated buffer; *len gets its size. NULL (errno
 * set) if it cannot be read. */
char *tools_read_file(const char *path, size_t *len);

/* Creates a folder and its missing parents (like mkdir -p). Returns 0, or -1 (errno set). */
int tools_make_dirs(const char *path);

/* FNV-1a, 64 bits, of n bytes continuing from h (start: 14695981039346656037): a key that
 * changes with its input (not cryptographic). */
uint64_t tools_fnv1a(uint64_t h, const void *data, size_t n);

#endif
