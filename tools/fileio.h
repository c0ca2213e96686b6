/* SPDX-License-Identifier: MIT */
/* Small file helpers shared by the tools. */
#ifndef DEFSIM_TOOLS_FILEIO_H
#define DEFSIM_TOOLS_FILEIO_H

#include <stddef.h>
#include <stdint.h>
#include <stdio.h>

/* Reads a whole file into a malloc'd, NUL-terminated buffer; *len gets its size. NULL (errno
 * set; EFBIG beyond DEFSIM__FILE_MAX, 1 GiB) if it cannot be read. The reader is the library's
 * (src/file_read.c, compiled into the tools since the shared library does not export it). */
char *tools_read_file(const char *path, size_t *len);

/* Files replaced atomically: written to "PATH.tmp", renamed to PATH when complete, so that a
 * reader (or a run stopped half-way) never sees a partial file. tools_tmp_open opens PATH.tmp
 * for writing and puts its name in tmp; NULL with err set if it cannot. tools_tmp_commit closes
 * f and, when `ok` and nothing failed while writing, renames it; otherwise it removes it. Returns
 * 0, or -1 with err set ("PATH: write failed: ..."). */
FILE *tools_tmp_open(const char *path, char *tmp, size_t tmpsz, char *err, size_t errsz);
int tools_tmp_commit(FILE *f, const char *tmp, const char *path, int ok, char *err,
                     size_t errsz);

/* Creates a folder and its missing parents (like mkdir -p). Returns 0, or -1 (errno set). */
int tools_make_dirs(const char *path);

/* FNV-1a, 64 bits, of n bytes continuing from h (start: 14695981039346656037): a key that
 * changes with its input (not cryptographic). */
uint64_t tools_fnv1a(uint64_t h, const void *data, size_t n);

#endif
